"""Building the vehicle FMUs: validity, archive contents, cache, missing compiler, sanitizers."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import fmpy
import pytest
from fmpy.validation import validate_fmu
from support import unmakeable_folder

from lfctl import data
from lfctl.cli import main
from lfctl.errors import BuildToolError, FmuError, LfctlError
from lfctl.fmu import build as fmu_build
from lfctl.fmu.build import available_models, build_model, parse_model_source

pytestmark = pytest.mark.fmu


def test_every_model_is_listed() -> None:
    assert {"SkidSteerRover", "KinematicUnicycle"} <= set(available_models())


@pytest.mark.parametrize("model", ["SkidSteerRover", "KinematicUnicycle"])
@pytest.mark.parametrize("fmi", [2, 3])
def test_fmu_passes_fmpy_validator_with_zero_problems(model: str, fmi: int) -> None:
    path = build_model(model).path(fmi)
    assert validate_fmu(str(path)) == []


@pytest.mark.parametrize("fmi", [2, 3])
def test_archive_carries_sources_binary_and_description(rover, fmi: int) -> None:
    names = set(zipfile.ZipFile(rover.path(fmi)).namelist())
    platform = fmpy.platform if fmi == 2 else fmpy.platform_tuple
    assert f"binaries/{platform}/SkidSteerRover.so" in names
    assert {
        "modelDescription.xml",
        "sources/model.c",
        "sources/config.h",
        "sources/model_core.c",
        "sources/model_core.h",
    } <= names
    assert f"sources/fmi{fmi}_wrapper.c" in names
    if fmi == 3:
        assert "sources/buildDescription.xml" in names


def test_variable_table_matches_description(rover) -> None:
    src = parse_model_source(data.models_dir() / "SkidSteerRover")
    md = fmpy.read_model_description(str(rover.fmi2))
    assert [(v.name, v.valueReference) for v in md.modelVariables] == [
        (v.name, v.value_reference) for v in src.variables
    ]
    units = {v.name: v.unit for v in md.modelVariables}
    assert units["yaw_rate_cmd"] == "rad/s" and units["north"] == "m" and units["tau"] == "s"


def test_second_build_is_a_cache_hit(tmp_path: Path) -> None:
    first = build_model("KinematicUnicycle", tmp_path)
    stamp = first.fmi2.stat().st_mtime_ns
    second = build_model("KinematicUnicycle", tmp_path)
    assert second == first and second.fmi2.stat().st_mtime_ns == stamp


def test_processes_building_at_once_build_once_and_all_get_it(tmp_path: Path) -> None:
    # a sweep's workers on a cold cache: each asks for the same model at the same moment
    script = (
        "import logging, sys; from pathlib import Path; from lfctl.fmu.build import build_model; "
        "logging.basicConfig(level=logging.INFO, format='%(message)s'); "
        "b = build_model('KinematicUnicycle', Path(sys.argv[1])); print(b.fmi2.stat().st_size, b.fmi3.stat().st_size)"
    )
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", script, str(tmp_path)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        for _ in range(3)
    ]
    outs = [p.communicate(timeout=300) for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0], outs
    assert sum(err.count("building KinematicUnicycle FMUs") for _, err in outs) == 1, outs  # the others waited
    assert len({out for out, _ in outs}) == 1 and int(outs[0][0].split()[0]) > 0


def test_a_cache_this_user_cannot_write_is_named_with_how_to_move_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # no home (a service's HOME=/nonexistent, a container's HOME=/): the run failed with a bare
    # "[Errno 13] Permission denied: '/nonexistent'", nothing saying it was the FMU cache
    unmakeable_folder("lfctl-test")
    with pytest.raises(LfctlError, match=r"cannot write lfctl's cache /sys/lfctl-test/fmu \(.*\): give a folder"):
        build_model("KinematicUnicycle", Path("/sys/lfctl-test/fmu"))
    monkeypatch.setenv("XDG_CACHE_HOME", "/sys/lfctl-test")
    assert main(["fmu", "build", "KinematicUnicycle"]) == 1
    err = capsys.readouterr().err  # (why: root's "Operation not permitted", a user's "Permission denied", ...)
    assert err.startswith("lfctl: error: cannot write lfctl's cache /sys/lfctl-test/lfctl/fmu (")
    assert "): set XDG_CACHE_HOME to a folder this user can write (lfctl's cache is then $XDG_CACHE_HOME/lfctl)" in err
    # another user's cache: its entries read, but adding one failed naming only a lock file
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    if os.getuid() == 0:
        os.chown(theirs, 65534, 65534)

    def refused(path: Path) -> None:
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(fmu_build, "_locked", refused)
    with pytest.raises(LfctlError, match=r"cannot write lfctl's cache .*theirs \(Permission denied.*\): give") as err:
        build_model("KinematicUnicycle", theirs)
    if os.getuid() == 0:
        assert f"; {theirs} belongs to " in str(err.value)


def test_a_build_killed_midway_leaves_no_folder_behind_after_the_next_build(tmp_path: Path) -> None:
    # a build killed while it compiled left its hidden .build-* folder in the cache for good
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    old = time.time() - fmu_build.STALE_BUILD_S - 60
    gone = tmp_path / f".build-{int(dead.stdout)}-abcd1234"  # its process has ended
    before = tmp_path / ".build-wxyz9876"  # one from before the process id was in the name
    alive = tmp_path / f".build-{os.getppid()}-efgh5678"  # a live process's
    recent = tmp_path / f".build-{int(dead.stdout)}-ijkl4321"  # maybe another machine's build, under way
    for folder in (gone, before, alive, recent):
        (folder / "out").mkdir(parents=True)
        if folder is not recent:
            os.utime(folder, (old, old))
    build_model("KinematicUnicycle", tmp_path)
    assert sorted(p.name for p in tmp_path.glob(".build-*")) == sorted([alive.name, recent.name])


def test_cache_key_changes_with_compiler_version() -> None:
    src = parse_model_source(data.models_dir() / "SkidSteerRover")
    assert fmu_build.cache_key(src, "gcc 12.2.0") != fmu_build.cache_key(src, "gcc 13.1.0")


def test_no_compiler_gives_an_error_saying_what_to_install(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setattr(shutil, "which", lambda name: None)
    with pytest.raises(BuildToolError, match=r"no C compiler on PATH.*apt-get install gcc"):
        build_model("SkidSteerRover", tmp_path)


def test_without_a_compiler_the_same_sources_built_earlier_run(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # a rover's computer that built its FMUs once and lost its compiler (or an image without one)
    built = build_model("KinematicUnicycle", tmp_path)
    (built.fmi2.parent / fmu_build.SOURCES_KEY_FILE).unlink()  # as an entry built by an older lfctl
    build_model("KinematicUnicycle", tmp_path)  # a cache hit with a compiler marks it
    monkeypatch.setattr(shutil, "which", lambda name: None)
    with caplog.at_level("INFO", logger="lfctl.fmu.build"):
        assert build_model("KinematicUnicycle", tmp_path) == built
    assert "no C compiler on PATH: the KinematicUnicycle FMUs built earlier" in caplog.text
    with pytest.raises(BuildToolError, match=r"no C compiler on PATH"):
        build_model("KinematicUnicycle", tmp_path, force=True)  # a rebuild needs one
    with pytest.raises(BuildToolError, match=r"no C compiler on PATH"):
        build_model("SkidSteerRover", tmp_path)  # never built here
    # other sources (an edited model) are not taken for these
    edited = tmp_path / "edited"
    shutil.copytree(data.models_dir() / "KinematicUnicycle", edited)
    (edited / "model.c").write_text((edited / "model.c").read_text() + "\n/* edited */\n")
    with pytest.raises(BuildToolError, match=r"no C compiler on PATH"):
        fmu_build.build_model_folder(edited, tmp_path)


def test_unknown_model_is_named() -> None:
    with pytest.raises(FmuError, match=r"unknown built-in model 'Tank'.*SkidSteerRover"):
        build_model("Tank")


@pytest.mark.slow
@pytest.mark.parametrize("fmi", [2, 3])
def test_c_harness_is_clean_under_address_and_leak_sanitizers(tmp_path: Path, fmi: int) -> None:
    cc = fmu_build.find_compiler()
    headers = Path(fmpy.__file__).parent / "c-code"
    repo = data.models_dir()
    exe = tmp_path / "harness"
    cmd = [
        cc, "-std=c99", "-g", "-fsanitize=address,undefined", "-fno-omit-frame-pointer", f"-DFMI_VERSION={fmi}",
        "-Wall", "-Wextra", "-Werror", "-Wno-unused-parameter",
        f"-I{repo / 'SkidSteerRover'}", f"-I{repo / 'common'}", f"-I{headers}",
        str(Path(__file__).parents[1] / "c" / "harness.c"), str(repo / "common" / "model_core.c"),
        str(repo / "common" / f"fmi{fmi}_wrapper.c"), str(repo / "SkidSteerRover" / "model.c"), "-lm", "-o", str(exe),
    ]  # fmt: skip
    build = subprocess.run(cmd, capture_output=True, text=True)
    if build.returncode != 0 and "asan" in build.stderr.lower():
        pytest.skip(f"this compiler has no AddressSanitizer runtime: {build.stderr.strip()[:200]}")
    assert build.returncode == 0, build.stderr
    run = subprocess.run(
        [str(exe)],
        capture_output=True,
        text=True,
        env={"ASAN_OPTIONS": "detect_leaks=1:halt_on_error=1", "UBSAN_OPTIONS": "halt_on_error=1"},
    )
    assert run.returncode == 0, run.stderr
    assert f"fmi{fmi} harness ok" in run.stdout


@pytest.mark.slow
@pytest.mark.parametrize("fmi", [2, 3])
def test_fmpy_rebuilds_the_binary_from_the_shipped_sources(rover, tmp_path: Path, fmi: int) -> None:
    """The archive alone is enough for an importer to compile it on another platform."""
    from fmpy import extract, simulate_fmu
    from fmpy.build import build_platform_binary

    if shutil.which("cmake") is None:
        pytest.skip("cmake not on PATH (fmpy's build uses it)")
    source_only = tmp_path / "source_only.fmu"
    with zipfile.ZipFile(rover.path(fmi)) as zin, zipfile.ZipFile(source_only, "w") as zout:
        for item in zin.infolist():
            if not item.filename.startswith("binaries/"):
                zout.writestr(item, zin.read(item.filename))
    unzipdir = Path(extract(str(source_only), unzipdir=tmp_path / "x")).resolve()
    build_platform_binary(unzipdir, cmake_options={"CMAKE_C_STANDARD_LIBRARIES:STRING": "-lm"})
    rebuilt = simulate_fmu(str(unzipdir), stop_time=1.0, start_values={"speed_cmd": 0.3})
    original = simulate_fmu(str(rover.path(fmi)), stop_time=1.0, start_values={"speed_cmd": 0.3})
    assert tuple(rebuilt[-1]) == tuple(original[-1])
