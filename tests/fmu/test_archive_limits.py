"""An FMU archive is checked before anything is read from it and unpacked within limits: zip
bombs, too many members, paths out of the folder, links and corrupt archives are FmuErrors
naming the file, and nothing is left in the temp folder."""

from __future__ import annotations

import io
import re
import struct
import tempfile
import zipfile
import zlib
from pathlib import Path

import pytest

from lfctl.errors import FmuError
from lfctl.fmu import archive
from lfctl.fmu.archive import check_archive, extract_archive
from lfctl.fmu.build import BuiltModel
from lfctl.fmu.load import FmuLibrary

pytestmark = pytest.mark.fmu


@pytest.fixture
def tmpdir_for_fmus(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A private temp folder for extractions, so nothing left behind goes unnoticed."""
    where = tmp_path / "tmp"
    where.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(where))
    return where


def with_members(fmu: Path, out: Path, extra: dict[str, bytes], method: int = zipfile.ZIP_DEFLATED) -> Path:
    """A copy of a real FMU with more members."""
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(out, "w", method) as dst:
        for info in src.infolist():
            dst.writestr(info, src.read(info))
        for name, data in extra.items():
            dst.writestr(name, data)
    return out


def patch_central_entry(path: Path, name: str, **fields: int) -> None:
    """Rewrite a member's sizes in the central directory only (a lying header)."""
    data = bytearray(path.read_bytes())
    at = data.rfind(b"PK\x01\x02", 0, data.rfind(name.encode()))
    offsets = {"compress_size": 20, "file_size": 24}
    for key, value in fields.items():
        struct.pack_into("<L", data, at + offsets[key], value)
    path.write_bytes(bytes(data))


def raw_zip(path: Path, members: list[tuple[str, bytes, int, int]]) -> Path:
    """A zip written by hand: (name, deflate stream, CRC-32, uncompressed size) per member."""
    out, central = io.BytesIO(), io.BytesIO()
    for name, raw, crc, size in members:
        offset = out.tell()
        n = name.encode()
        out.write(struct.pack("<4s2B4HL2L2H", b"PK\x03\x04", 20, 0, 0, 8, 0, 0x21, crc, len(raw), size, len(n), 0))
        out.write(n + raw)
        head = (b"PK\x01\x02", 20, 3, 20, 0, 0, 8, 0, 0x21, crc, len(raw), size, len(n), 0, 0, 0, 0, 0o100644 << 16)
        central.write(struct.pack("<4s4B4HL2L5H2L", *head, offset) + n)
    cd = central.getvalue()
    end = struct.pack("<4s4H2LH", b"PK\x05\x06", 0, 0, len(members), len(members), len(cd), out.tell(), 0)
    path.write_bytes(out.getvalue() + cd + end)
    return path


def zeros_bomb(mib: int) -> tuple[bytes, int]:
    """A deflate stream of ``mib`` MiB of zeros, fast: one MiB compressed, full-flushed (so it
    stands alone) and repeated; and its CRC-32."""
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    block = b"\0" * 2**20
    one = c.compress(block) + c.flush(zlib.Z_FULL_FLUSH)
    crc = 0
    for _ in range(mib):
        crc = zlib.crc32(block, crc)
    return one * mib + c.flush(), crc


def leftovers(where: Path) -> list[Path]:
    return [p for p in where.iterdir() if p.name.startswith("lfctl-")]


def test_a_zip_bomb_is_refused_before_a_byte_is_written(
    faulty: BuiltModel, tmp_path: Path, tmpdir_for_fmus: Path
) -> None:
    raw, crc = zeros_bomb(600)
    md = zipfile.ZipFile(faulty.fmi2).read("modelDescription.xml")
    bomb = raw_zip(
        tmp_path / "bomb.fmu",
        [
            ("modelDescription.xml", zlib.compress(md)[2:-4], zlib.crc32(md), len(md)),
            ("resources/zeros.bin", raw, crc, 600 * 2**20),
        ],
    )
    assert bomb.stat().st_size < 2**20  # 600 MiB of zeros in under 1 MiB: a real, readable bomb
    with zipfile.ZipFile(bomb) as z, z.open("resources/zeros.bin") as f:
        assert f.read(4096) == b"\0" * 4096
    with pytest.raises(
        FmuError,
        match=r"bomb\.fmu: member 'resources/zeros\.bin' unpacks .* to 600 MiB, a compression ratio of \d+ \(limit 200\); refused",
    ):
        FmuLibrary(bomb)
    assert leftovers(tmpdir_for_fmus) == []


def test_more_than_the_total_limit_is_refused(faulty: BuiltModel, tmp_path: Path, tmpdir_for_fmus: Path) -> None:
    # honest ratios (100), a total of 600 MiB declared: beyond 512 MiB
    fmu = with_members(
        faulty.fmi2, tmp_path / "big.fmu", {"resources/a.bin": b"x" * 1000, "resources/b.bin": b"y" * 1000}
    )
    for name in ("resources/a.bin", "resources/b.bin"):
        patch_central_entry(fmu, name, file_size=300 * 2**20, compress_size=3 * 2**20)
    with pytest.raises(FmuError, match=r"big\.fmu: unpacks to 60\d\.?\d* MiB, more than the limit of 512 MiB; refused"):
        FmuLibrary(fmu)
    assert leftovers(tmpdir_for_fmus) == []


def test_a_header_that_lies_small_cannot_make_it_write_more(faulty: BuiltModel, tmp_path: Path) -> None:
    # the central directory says 1000 bytes; the member holds 4 MiB of random-ish data
    data = bytes(range(256)) * (4 * 2**12)
    fmu = with_members(faulty.fmi2, tmp_path / "liar.fmu", {"resources/data.bin": data})
    patch_central_entry(fmu, "resources/data.bin", file_size=1000)
    dest = tmp_path / "out"
    dest.mkdir()
    with pytest.raises(FmuError, match=r"liar\.fmu: cannot extract member 'resources/data\.bin': Bad CRC-32"):
        extract_archive(fmu, dest)
    assert (dest / "resources" / "data.bin").stat().st_size <= 1000


def test_the_stream_is_capped_whatever_zipfile_does() -> None:
    src, dst = io.BytesIO(b"z" * 5000), io.BytesIO()
    assert archive._copy_capped(src, dst, 1000) == -1
    assert len(dst.getvalue()) <= 1000
    assert archive._copy_capped(io.BytesIO(b"z" * 1000), io.BytesIO(), 1000) == 1000


def test_too_many_members_is_refused(tmp_path: Path) -> None:
    fmu = tmp_path / "many.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        for i in range(10_001):
            z.writestr(f"resources/{i}", b"")
    with pytest.raises(FmuError, match=r"many\.fmu: 10001 members, more than the limit of 10000; refused"):
        check_archive(fmu)


def test_a_huge_central_directory_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(archive, "MAX_CENTRAL_DIRECTORY_BYTES", 4096)
    fmu = tmp_path / "long.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        for i in range(40):
            z.writestr(f"resources/{'n' * 200}{i}", b"")
    with pytest.raises(FmuError, match=r"long\.fmu: a central directory of .* MiB, more than the limit"):
        check_archive(fmu)


@pytest.mark.parametrize(
    ("name", "why"),
    [
        ("../evil.so", "has a '..' component"),
        ("resources/../../evil.so", "has a '..' component"),
        ("/etc/cron.d/evil", "is an absolute path"),
        ("..\\evil.so", "contains a backslash"),
        ("C:/evil.so", "contains ':'"),
        ("resources//x", "has an empty or '.' component"),
        ("./modelDescription.xml", "has an empty or '.' component"),
    ],
)
def test_a_member_outside_the_folder_is_refused(
    faulty: BuiltModel, tmp_path: Path, tmpdir_for_fmus: Path, name: str, why: str
) -> None:
    fmu = with_members(faulty.fmi2, tmp_path / "escape.fmu", {name: b"boom"})
    with pytest.raises(FmuError, match=rf"escape\.fmu: member {re.escape(repr(name))} {re.escape(why)}"):
        FmuLibrary(fmu)
    assert leftovers(tmpdir_for_fmus) == []
    assert not (tmp_path / "evil.so").exists()


@pytest.mark.parametrize(
    ("mode", "why"), [(0o120777, "is a symbolic link"), (0o010644, "is not a regular file or folder")]
)
def test_links_and_special_files_are_refused(faulty: BuiltModel, tmp_path: Path, mode: int, why: str) -> None:
    fmu = tmp_path / "link.fmu"
    with zipfile.ZipFile(faulty.fmi2) as src, zipfile.ZipFile(fmu, "w") as dst:
        for info in src.infolist():
            dst.writestr(info, src.read(info))
        link = zipfile.ZipInfo("resources/passwd")
        link.create_system = 3
        link.external_attr = mode << 16
        dst.writestr(link, "/etc/passwd")
    with pytest.raises(FmuError, match=rf"member 'resources/passwd' {why}"):
        check_archive(fmu)


def test_a_member_named_twice_is_refused(faulty: BuiltModel, tmp_path: Path) -> None:
    with pytest.warns(UserWarning, match="Duplicate name"):
        fmu = with_members(faulty.fmi2, tmp_path / "twice.fmu", {"modelDescription.xml": b"<fmiModelDescription/>"})
    with pytest.raises(FmuError, match=r"member 'modelDescription\.xml' appears twice"):
        check_archive(fmu)


def test_a_method_other_than_stored_or_deflated_is_refused(faulty: BuiltModel, tmp_path: Path) -> None:
    fmu = with_members(faulty.fmi2, tmp_path / "bz.fmu", {"resources/x": b"x" * 100}, zipfile.ZIP_BZIP2)
    with pytest.raises(FmuError, match=r"uses compression method 12 \(FMUs use stored or deflated\)"):
        check_archive(fmu)


def test_an_oversized_model_description_is_refused(faulty: BuiltModel, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(archive, "MAX_MODEL_DESCRIPTION_BYTES", 1000)
    with pytest.raises(FmuError, match=r"member 'modelDescription\.xml' is .* MiB, more than the limit"):
        FmuLibrary.describe(faulty.fmi2)


def test_not_a_zip_is_an_fmu_error(tmp_path: Path) -> None:
    junk = tmp_path / "junk.fmu"
    junk.write_bytes(bytes(range(256)) * 40)
    with pytest.raises(FmuError, match=r"junk\.fmu is not an FMU: not a readable zip archive"):
        FmuLibrary(junk)


def test_a_truncated_fmu_is_an_fmu_error(faulty: BuiltModel, tmp_path: Path, tmpdir_for_fmus: Path) -> None:
    cut = tmp_path / "cut.fmu"
    cut.write_bytes(faulty.fmi2.read_bytes()[: faulty.fmi2.stat().st_size // 2])
    with pytest.raises(FmuError, match=r"cut\.fmu is not an FMU: not a readable zip archive"):
        FmuLibrary(cut)
    assert leftovers(tmpdir_for_fmus) == []


@pytest.mark.parametrize("member", ["binaries/", "modelDescription.xml"])
def test_a_bad_crc_is_an_fmu_error(faulty: BuiltModel, tmp_path: Path, tmpdir_for_fmus: Path, member: str) -> None:
    # stored members: a flipped byte in the data is a clean CRC mismatch
    fmu = tmp_path / "crc.fmu"
    with zipfile.ZipFile(faulty.fmi2) as src, zipfile.ZipFile(fmu, "w", zipfile.ZIP_STORED) as dst:
        for info in src.infolist():
            dst.writestr(info.filename, src.read(info))
        target = next(i for i in dst.infolist() if i.filename.startswith(member) and not i.is_dir())
    data = bytearray(fmu.read_bytes())
    data[target.header_offset + 30 + len(target.filename) + 100] ^= 0xFF
    fmu.write_bytes(bytes(data))
    with pytest.raises(FmuError, match=r"crc\.fmu.*Bad CRC-32"):
        FmuLibrary(fmu)
    assert leftovers(tmpdir_for_fmus) == []


def test_a_sound_fmu_unpacks_in_full(faulty: BuiltModel, tmp_path: Path) -> None:
    dest = tmp_path / "ok"
    dest.mkdir()
    written = extract_archive(faulty.fmi3, dest)
    with zipfile.ZipFile(faulty.fmi3) as z:
        assert written == sum(i.file_size for i in z.infolist())
        for info in z.infolist():
            if not info.is_dir():
                assert (dest / info.filename).read_bytes() == z.read(info)


def test_an_fmu_without_its_binary_is_named_not_its_temporary_folder(faulty: BuiltModel, tmp_path: Path) -> None:
    import numpy as np

    from lfctl.fmu.load import INPUT_ROLES, OUTPUT_ROLES, FmuInstance

    fmu, bad = tmp_path / "nobin.fmu", tmp_path / "badbin.fmu"
    with zipfile.ZipFile(faulty.fmi2) as src, zipfile.ZipFile(fmu, "w") as dst, zipfile.ZipFile(bad, "w") as junk:
        for info in src.infolist():
            name, data = info.filename, src.read(info)
            if not name.startswith("binaries/"):
                dst.writestr(name, data)
                junk.writestr(name, data)
            elif name.endswith(".so"):
                junk.writestr(name, b"not a shared library")
                dst.writestr(name.replace("linux64", "win64").replace(".so", ".dll"), data)  # another platform's only
    # no binary for this platform: the file is unusable, said at load (exit 2), with what it has
    with pytest.raises(FmuError, match=r"no binary for this platform \(linux64\); it has win64") as err:
        FmuLibrary(fmu)
    assert err.value.call == "load"
    # a binary that does not load: named as the .fmu's member, not the temporary folder
    rows = np.zeros(len(INPUT_ROLES)), np.zeros(len(OUTPUT_ROLES))
    with FmuLibrary(bad) as lib, pytest.raises(FmuError) as err:
        FmuInstance(lib, "leader", {}, (0.0, 0.0, 0.0), *rows, 0.0)
    # (a file that cannot be used: exit 2, dlerror's reason once)
    assert str(err.value).startswith(f"{bad}: cannot load binaries/linux64/FaultyRover.so: ")
    assert "lfctl-" not in str(err.value) and err.value.call == "load"


def test_an_fmu_whose_identifier_names_no_library_is_named_at_load(faulty: BuiltModel, tmp_path: Path) -> None:
    import numpy as np

    from lfctl.fmu.load import INPUT_ROLES, OUTPUT_ROLES, FmuInstance

    other = tmp_path / "other.fmu"
    with zipfile.ZipFile(faulty.fmi2) as src, zipfile.ZipFile(other, "w") as dst:
        for info in src.infolist():
            data = src.read(info)
            if info.filename == "modelDescription.xml":
                data = data.replace(b'modelIdentifier="FaultyRover"', b'modelIdentifier="Other"')
            dst.writestr(info.filename, data)
    rows = np.zeros(len(INPUT_ROLES)), np.zeros(len(OUTPUT_ROLES))
    with FmuLibrary(other) as lib, pytest.raises(FmuError) as err:
        FmuInstance(lib, "leader", {}, (0.0, 0.0, 0.0), *rows, 0.0)
    assert (
        str(err.value) == (f"{other} has no binaries/linux64/Other.so, the library its modelIdentifier 'Other' names")
        and err.value.call == "load"
    )


def test_a_model_description_with_another_root_element_is_named(faulty: BuiltModel, tmp_path: Path) -> None:
    # fmpy's own error leaked: "'NoneType' object has no attribute 'startswith'"
    fmu = tmp_path / "wrong_root.fmu"
    with zipfile.ZipFile(faulty.fmi2) as src, zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as dst:
        for info in src.infolist():
            dst.writestr(info, b"<foo/>" if info.filename == "modelDescription.xml" else src.read(info))
    with pytest.raises(FmuError) as caught:
        FmuLibrary.describe(fmu)
    said = str(caught.value)
    assert (
        "wrong_root.fmu has no valid modelDescription.xml: its root element is <foo>, not <fmiModelDescription>" in said
    )
    assert "NoneType" not in said
