"""`lfctl audit` on damaged and hostile files: seeded bit flips and cuts of a Recorder log,
crafted length fields, zstd and lz4 bombs, sparse zeros, message floods, non-regular files,
crafted content with valid CRCs, recovery after SIGKILL, and `lfctl replay` on images that
do not decode. Each case: :func:`audit` returns, the CLI exits 1 or 2 without a traceback,
memory stays bounded, nothing is written outside the folder it belongs in."""

from __future__ import annotations

import collections
import dataclasses
import json
import math
import os
import random
import signal
import socket
import struct
import subprocess
import sys
import textwrap
import tracemalloc
import zlib
from pathlib import Path

import cv2
import lz4.frame
import numpy as np
import pytest
import zstandard
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from mcap.reader import NonSeekingReader
from mcap.writer import CompressionType, Writer

from lfctl.cli import main
from lfctl.config import load_config
from lfctl.record.audit import audit, format_report, recover
from lfctl.record.mcap_read import MAGIC, MAX_CHUNK_BYTES, ReadLimits, locate_flip, read_contents
from lfctl.record.replay import replay
from lfctl.record.writer import Recorder

ROOT = Path(__file__).parents[2]
EXAMPLES = ROOT / "examples"
MiB = 1 << 20


# -- a small real log, written with the Recorder (no FMU, no simulation) ---------------------------
def config(compression: str = "zstd", sensing: str = "truth", images: bool = False):
    cfg = load_config(EXAMPLES / "convoy.toml")
    rec = dataclasses.replace(
        cfg.recording, compression=compression, chunk_size_bytes=6000, images=images, image_rate_hz=10.0
    )
    return dataclasses.replace(cfg, recording=rec, sim=dataclasses.replace(cfg.sim, sensing=sensing))


def fill(rec: Recorder, seconds: float = 4.0, start: int = 0) -> None:
    """Poses at 10 Hz, controller, pose estimate and two MAVLink links at 20 Hz, one waypoint."""
    for k in range(start, start + int(seconds * 20)):
        t = k * 0.05
        if k % 2 == 0:
            pos = np.array([[0.05 * t, 0.0], [0.05 * t - 1.5, 0.0]])
            rec.poses(t, ("leader", "follower1"), pos, np.array([0.0, 0.01 * k]))
        rec.controller(
            t,
            "follower1",
            {
                "status": "tracking" if k % 40 < 35 else "occluded",
                "speed_cmd_mps": 0.2,
                "yaw_rate_cmd_degps": math.sin(k),
                "range_cmd_m": 1.5,
                "bearing_cmd_deg": 0.0,
                "range_m": 1.5,
                "bearing_deg": 0.0,
                "range_error_m": 0.01 * math.cos(k),
                "bearing_error_deg": 0.2,
                "separation_m": 1.5,
                "target": "leader",
            },
        )
        rec.json(
            "/follower1/pose_estimate",
            "lfctl.PoseEstimate",
            t,
            {"method": "pnp", "range_m": 1.51, "bearing_deg": 0.1, "truth_range_m": 1.5, "truth_bearing_deg": 0.0},
        )
        packet = {"msgid": 0, "name": "HEARTBEAT", "seq": k % 256, "fields": {}, "raw": "AAAA"}
        rec.mavlink(t, "leader", {"direction": "out", "sysid": 1, "compid": 1, **packet})
        rec.mavlink(t, "follower1", {"direction": "in", "sysid": 2, "compid": 191, **packet})
        if k == 40:
            rec.mission_reached(t, 0, 2, 4, 4)


def write_log(path: Path, compression: str = "zstd", reason: str | None = "completed") -> Path:
    rec = Recorder(path, config(compression))
    fill(rec)
    if reason is None:  # killed: what reached the disk stays, nothing is finished
        rec.flush()
        killed = path.read_bytes()
        rec.close()
        path.write_bytes(killed)
    else:
        rec.close(reason, 3.95)
    return path


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("logs")
    out = {c: write_log(tmp / f"{c}.mcap", c) for c in ("zstd", "lz4")}
    for p in out.values():
        assert audit(p).ok, [f.line() for f in audit(p).findings]
    return out


def layout(data: bytes) -> list[tuple[int, int, int]]:
    """(start, end, opcode) of each top-level record of an intact file; the magics as -1."""
    out = [(0, 8, -1)]
    pos = 8
    while pos < len(data) - 8:
        op, length = struct.unpack_from("<BQ", data, pos)
        out.append((pos, pos + 9 + length, op))
        pos += 9 + length
    return [*out, (pos, pos + 8, -1)]


def records_of(data: bytes, op: int) -> list[tuple[int, int, int]]:
    return [r for r in layout(data) if r[2] == op]


def run_cli(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    rc = main(args)
    cap = capsys.readouterr()
    text = cap.out + cap.err
    assert "Traceback" not in text
    return rc, text


# -- hand-made MCAP ----------------------------------------------------------------------------------
def record(op: int, body: bytes) -> bytes:
    return struct.pack("<BQ", op, len(body)) + body


def string(s: str) -> bytes:
    b = s.encode()
    return struct.pack("<I", len(b)) + b


def header() -> bytes:
    return record(1, string("") + string("crafted"))


def channel(cid: int, topic: str) -> bytes:
    return record(4, struct.pack("<HH", cid, 0) + string(topic) + string("json") + struct.pack("<I", 0))


def message(cid: int, seq: int, t: int, data: bytes) -> bytes:
    return record(5, struct.pack("<HIQQ", cid, seq, t, t) + data)


def chunk(
    records: bytes, compression: str = "zstd", compressed: bytes | None = None, size: int | None = None, crc=None
) -> bytes:
    if compressed is None:
        compressed = zstandard.compress(records) if compression == "zstd" else records
    size = len(records) if size is None else size
    body = struct.pack("<QQQI", 0, 2**64 - 1, size, zlib.crc32(records) if crc is None else crc)
    return record(6, body + string(compression) + struct.pack("<Q", len(compressed)) + compressed)


def finish(parts: list[bytes]) -> bytes:
    data = MAGIC + b"".join(parts)
    data += record(15, struct.pack("<I", zlib.crc32(data)))
    return data + record(2, struct.pack("<QQI", 0, 0, 0)) + MAGIC


MEASURE = textwrap.dedent(
    """
    import json, resource, sys
    from lfctl.record.audit import audit
    out = []
    for path in sys.argv[1:]:
        r = audit(path)
        out.append({"findings": [f.__dict__ for f in r.findings], "messages": r.figures["messages"]})
    try:  # this process's own peak (ru_maxrss also counts the parent's memory, kept across exec)
        with open("/proc/self/status") as f:
            peak_kb = next(int(line.split()[1]) for line in f if line.startswith("VmHWM:"))
    except OSError:
        peak_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(json.dumps({"rss_mb": peak_kb / 1024, "reports": out}))
    """
)


def measure(*paths: Path, timeout: float = 60) -> dict:
    """Audit the files in a fresh process: its peak RSS (MB) and findings; a
    process still running after ``timeout`` seconds fails the test (a hang, not a speed)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-c", MEASURE, *map(str, paths)],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
        check=False,
    )
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    return json.loads(done.stdout)


def lfctl_cli(*args: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-m", "lfctl", *args], capture_output=True, text=True, timeout=timeout, env=env, check=False
    )
    assert "Traceback" not in done.stdout + done.stderr, done.stderr
    return done


# -- single-bit flips ------------------------------------------------------------------------------
@pytest.mark.parametrize(("compression", "seed"), [("zstd", 1), ("zstd", 2), ("zstd", 3), ("lz4", 4)])
def test_every_bit_flip_is_reported_at_the_damaged_record_and_not_as_truncation(
    logs, tmp_path: Path, capsys: pytest.CaptureFixture[str], compression: str, seed: int
) -> None:
    data = logs[compression].read_bytes()
    where = layout(data)
    rng = random.Random(seed)
    bad = tmp_path / "flipped.mcap"
    kinds: collections.Counter[str] = collections.Counter()
    for n in range(100):
        pos, bit = rng.randrange(len(data)), rng.randrange(8)
        flipped = bytearray(data)
        flipped[pos] ^= 1 << bit
        bad.write_bytes(flipped)
        rep = audit(bad)
        start, end, _ = next(r for r in where if r[0] <= pos < r[1])
        errors = [f for f in rep.findings if f.level == "error"]
        assert errors, (pos, bit)
        assert not any(f.kind == "truncated" or "truncated" in f.what for f in rep.findings), (pos, bit, errors)
        assert any(f.offset is not None and start <= f.offset < end for f in errors), (pos, bit, start, end, errors)
        kinds[errors[0].kind] += 1
        if n % 25 == 0:
            rc, out = run_cli(["audit", str(bad)], capsys)
            assert rc == 1 and "integrity: FAILED" in out
    assert set(kinds) <= {"crc", "corrupt", "limit"}  # a flipped size field can pass a limit


def test_a_flip_in_a_chunk_and_a_changed_digit_in_the_metadata_are_located(logs, tmp_path: Path) -> None:
    data = logs["zstd"].read_bytes()
    start, end, _ = records_of(data, 6)[2]  # a chunk in the middle
    flipped = bytearray(data)
    flipped[(start + end) // 2] ^= 0x10
    bad = tmp_path / "chunk.mcap"
    bad.write_bytes(flipped)
    rep = audit(bad)
    first = next(f for f in rep.findings if f.level == "error")
    assert first.offset == start and first.kind in ("crc", "corrupt") and "truncated" not in first.what
    # a digit of the run metadata: only the data section's CRC covers it, and locates it
    run = next(r for r in records_of(data, 12) if b"telemetry_rate_hz" in data[r[0] : r[1]])
    i = data.index(b"1", data.index(b"telemetry_rate_hz", run[0]) + 17)
    changed = bytearray(data)
    changed[i : i + 1] = b"3"  # 10.0 Hz -> 30.0 Hz (two bits differ: the record, not the bit)
    bad.write_bytes(changed)
    rep = audit(bad)
    crc = next(f for f in rep.findings if "data section CRC" in f.what)
    assert crc.level == "error"
    changed[i : i + 1] = b"0"  # "1" -> "0": one bit
    bad.write_bytes(changed)
    crc = next(f for f in audit(bad).findings if "data section CRC" in f.what)
    assert crc.offset == run[0] and f"byte {i} bit 0" in crc.what and "Metadata record" in crc.what


def _records_at(data: bytes, chunk_start: int) -> int:
    """Where a Chunk record's compressed records begin."""
    compression = int.from_bytes(data[chunk_start + 9 + 28 : chunk_start + 9 + 32], "little")
    return chunk_start + 9 + 32 + compression + 8


@pytest.mark.parametrize("compression", ["zstd", "lz4"])
def test_a_flip_in_the_chunk_that_defines_the_channels_loses_only_that_chunks_messages(
    logs, tmp_path: Path, compression: str
) -> None:
    """The writer puts each Schema and Channel record in the data section once, in the first
    chunk that uses it, and again in the summary. One flipped bit in the first chunk lost
    every message on the channels it defined (all of the log's but those first used later),
    though the summary defines them: the summary's definitions are used."""
    log = logs[compression]
    data = log.read_bytes()
    start, end, _ = records_of(data, 6)[0]
    c, _ = read_contents(log)
    in_first = collections.Counter(
        (c.channels[cid].topic, s.log_times[i], s.sequences[i])
        for cid, s in c.by_channel.items()
        for i in range(len(s))
        if s.offset(i) == start
    )
    rest = message_keys(log) - in_first
    assert in_first and rest
    flipped = bytearray(data)
    flipped[(_records_at(data, start) + end) // 2] ^= 0x10
    bad = tmp_path / "flipped.mcap"
    bad.write_bytes(flipped)
    rep = audit(bad)
    errors = [f for f in rep.findings if f.level == "error"]
    assert errors[0].offset == start and errors[0].kind in ("crc", "corrupt"), errors
    assert not any("missing" in f.what or "defined" in f.what for f in errors), errors
    (used,) = [f for f in rep.findings if "defined only in the summary" in f.what]
    assert used.level == "warning" and used.offset == start
    assert rep.figures["messages"] == sum(rest.values())
    out = tmp_path / "recovered.mcap"
    assert recover(rep, out) == sum(rest.values())
    assert message_keys(out) == rest  # every message of the other chunks, once
    again = audit(out)
    assert again.ok, again.findings


def test_a_killed_logs_channels_defined_in_a_damaged_first_chunk_are_lost(tmp_path: Path) -> None:
    """A killed run's log has no summary: the channels its first chunk defined are defined
    nowhere else, so their messages cannot be read (docs/audit.md says so)."""
    log = write_log(tmp_path / "killed.mcap", reason=None)
    data = log.read_bytes()
    start, end, _ = records_of(data, 6)[0]
    flipped = bytearray(data)
    flipped[(_records_at(data, start) + end) // 2] ^= 0x10
    log.write_bytes(flipped)
    rep = audit(log)
    lost = [f for f in rep.findings if "which no intact Channel record defines" in f.what]
    assert lost and all(f.level == "error" and f"the Chunk skipped at byte {start}" in f.what for f in lost)
    assert "/leader/pose" not in rep.contents.messages and rep.figures["messages"] > 0


def finish_with_summary(parts: list[bytes], summary: bytes) -> bytes:
    """Like finish, with ``summary``'s records in the summary section."""
    data = MAGIC + b"".join(parts)
    data += record(15, struct.pack("<I", zlib.crc32(data)))
    foot = struct.pack("<BQQQ", 2, 20, len(data), 0)
    return data + summary + foot + struct.pack("<I", zlib.crc32(summary + foot)) + MAGIC


def test_messages_read_before_their_channels_definition_are_kept_until_it_turns_up(tmp_path: Path) -> None:
    """A definition later in the data section or only in the summary keeps the messages read
    before it (each an error: the writer's order is wrong); a channel defined nowhere loses them."""
    late = chunk(message(1, 0, 5, b"{}") + channel(1, "/late") + message(1, 1, 6, b"{}"))
    parts = [header(), late, chunk(message(2, 0, 7, b"{}")), chunk(message(3, 0, 8, b"{}"))]
    p = tmp_path / "order.mcap"
    p.write_bytes(finish_with_summary(parts, channel(1, "/late") + channel(2, "/summary")))
    rep = audit(p)
    errors = {f.what for f in rep.findings if f.level == "error"}
    assert "message on channel 1 (/late) before the channel is defined" in errors
    assert "message on channel 2 (/summary) before the channel is defined (only the summary defines it)" in errors
    assert "message on channel 3, which no intact Channel record defines" in errors
    assert not any("Footer" in e or "CRC" in e for e in errors), errors
    assert {t: len(m) for t, m in rep.contents.messages.items()} == {"/late": 2, "/summary": 1}
    assert rep.figures["messages"] == 4 and recover(rep, tmp_path / "out.mcap") == 3


def test_locate_flip_agrees_with_zlib() -> None:
    rng = random.Random(7)
    data = rng.randbytes(5000)
    for _ in range(30):
        pos, bit = rng.randrange(len(data)), rng.randrange(8)
        other = bytearray(data)
        other[pos] ^= 1 << bit
        assert locate_flip(zlib.crc32(data), zlib.crc32(other), len(data)) == (pos, bit)
    two = bytearray(data)
    two[10] ^= 1
    two[4000] ^= 4
    assert locate_flip(zlib.crc32(data), zlib.crc32(two), len(data)) is None


# -- cuts and recovery ------------------------------------------------------------------------------
def message_keys(path: Path) -> collections.Counter:
    c, _ = read_contents(path)
    return collections.Counter(
        (c.channels[cid].topic, t, seq)
        for cid, s in c.by_channel.items()
        for t, seq in zip(s.log_times, s.sequences, strict=True)
    )


@pytest.mark.parametrize("compression", ["zstd", "lz4"])
def test_a_log_cut_anywhere_is_truncated_and_recovers_each_message_once(
    logs, tmp_path: Path, capsys: pytest.CaptureFixture[str], compression: str
) -> None:
    data = logs[compression].read_bytes()
    original = message_keys(logs[compression])
    first_chunk = records_of(data, 6)[0][0]
    rng = random.Random(11)
    cuts = sorted({*range(1, 60, 7), *range(0, len(data), len(data) // 25), *rng.sample(range(len(data)), 15)})
    cuts += list(range(len(data) - 9, len(data)))  # inside the footer and the closing magic
    cut, out = tmp_path / "cut.mcap", tmp_path / "recovered.mcap"
    for n in cuts:
        cut.write_bytes(data[:n])
        rep = audit(cut)
        assert not rep.ok and "integrity: FAILED" in format_report(rep)
        errors = [f for f in rep.findings if f.level == "error"]
        if n:
            assert errors[0].kind == "truncated", (n, errors)
        assert all(f.offset is None or f.offset <= n for f in rep.findings), (n, rep.findings)
        if n % 10 == 0:
            rc, text = run_cli(["audit", str(cut), "--json"], capsys)
            assert rc == 1 and json.loads(text)["ok"] is False
        if n < first_chunk:
            continue
        out.unlink(missing_ok=True)  # a recovery writes over nothing
        assert recover(rep, out) == rep.figures["messages"]
        again = audit(out)
        assert again.ok and all(f.kind == "recovery" for f in again.findings), (n, again.findings)
        got = message_keys(out)
        assert max(got.values(), default=1) == 1 and not got - original  # once each, none made up
        assert sum(got.values()) == rep.figures["messages"]
    assert {q.name for q in tmp_path.iterdir()} == {"cut.mcap", "recovered.mcap"}  # no partial file left


@pytest.mark.integration
def test_a_log_killed_with_sigkill_is_recovered_without_duplicates(tmp_path: Path) -> None:
    log = tmp_path / "killed.mcap"
    script = textwrap.dedent(
        f"""
        import sys, time
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        from test_audit_fuzz import Recorder, config, fill
        rec = Recorder({str(log)!r}, config())
        k = 0
        while True:
            fill(rec, 1.0, k)
            k += 20
            rec.flush()
            if k == 200:
                print("ready", flush=True)
            time.sleep(0.01)
        """
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", script],
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "ready"
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
    rep = audit(log)
    assert not rep.ok and rep.figures["end"] is None
    assert any(f.kind == "truncated" for f in rep.findings if f.level == "error")
    assert "integrity: FAILED" in format_report(rep)
    assert rep.figures["messages"] > 1000
    out = tmp_path / "fixed.mcap"
    assert recover(rep, out) == rep.figures["messages"]
    again = audit(out)
    assert again.ok and [f.kind for f in again.findings] == ["recovery"]
    got = message_keys(out)
    assert max(got.values()) == 1 and sum(got.values()) == rep.figures["messages"]


@pytest.mark.parametrize("compression", ["zstd", "lz4", ""])
def test_a_chunk_the_writer_never_finished_keeps_its_whole_messages(tmp_path: Path, compression: str) -> None:
    """A streaming writer puts a placeholder (all ones) in a chunk's lengths and fills them in
    when the chunk is finished; a kill in between leaves the placeholder and part of the
    compressed records. The messages that reached the file in full are kept; the cut one is not."""
    rng = random.Random(7)
    records = channel(1, "/x") + b"".join(
        message(1, k, 1000 + k, bytes(rng.getrandbits(8) for _ in range(300))) for k in range(400)
    )
    if compression == "zstd":
        c, step = zstandard.ZstdCompressor().compressobj(), 40 * 331  # a block out every 40 messages
        compressed = b"".join(
            c.compress(records[i : i + step]) + c.flush(zstandard.COMPRESSOBJ_FLUSH_BLOCK)
            for i in range(0, len(records), step)
        )
    elif compression == "lz4":
        compressed = lz4.frame.compress(records, block_size=lz4.frame.BLOCKSIZE_MAX64KB)
    else:
        compressed = records
    cut = compressed[: len(compressed) * 3 // 5]
    head = struct.pack("<QQQI", 0, 2**64 - 1, 2**64 - 1, 0) + string(compression) + struct.pack("<Q", 2**64 - 1)
    path = tmp_path / "unfinished.mcap"
    path.write_bytes(MAGIC + header() + struct.pack("<BQ", 6, 2**64 - 1) + head + cut)
    rep = audit(path)
    (f,) = [f for f in rep.findings if f.level == "error" and "Chunk" in f.what]
    assert f.kind == "truncated" and "the writer had not finished" in f.what, f.what
    kept = rep.figures["messages"]
    assert f"{kept} whole messages recovered" in f.what
    assert 100 < kept < 400  # some, not all: the rest never reached the file
    out = tmp_path / "fixed.mcap"
    assert recover(rep, out) == kept
    got = [(m.sequence, m.data) for _, _, m in NonSeekingReader(out.open("rb")).iter_messages()]
    want = [
        (k, records[i + 9 + 22 : i + 9 + 322]) for k, i in enumerate(range(len(channel(1, "/x")), len(records), 331))
    ]
    assert got == want[:kept]


def test_two_channels_on_one_topic_are_recovered_once_each(tmp_path: Path) -> None:
    src = tmp_path / "shared.mcap"
    with src.open("wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD, enable_crcs=True, enable_data_crcs=True)
        w.start(profile="", library="test")
        a = w.register_channel("/follower1/controller", "json", 0)
        b = w.register_channel("/follower1/controller", "json", 0)
        for k in range(50):
            w.add_message(a, k * 10, b'{"from": "a"}', k * 10, k)
            w.add_message(b, k * 10 + 5, b'{"from": "b"}', k * 10 + 5, k)
        w.finish()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(src.read_bytes()[:-200])  # into the summary: every message was read
    rep = audit(cut)
    assert len(rep.contents.messages["/follower1/controller"]) == 100
    out = tmp_path / "out.mcap"
    assert recover(rep, out) == 100
    with out.open("rb") as f:
        per_channel = collections.Counter(m.channel_id for _, _, m in NonSeekingReader(f).iter_messages())
    assert sorted(per_channel.values()) == [50, 50]


# -- crafted length fields -----------------------------------------------------------------------
def _set_u64(data: bytearray, at: int, value: int) -> None:
    data[at : at + 8] = value.to_bytes(8, "little")


def _set_u32(data: bytearray, at: int, value: int) -> None:
    data[at : at + 4] = value.to_bytes(4, "little")


def crafted_lengths(data: bytes) -> list[tuple[str, bytearray, int]]:
    """(what was crafted, the file, offset of the record it is in): record lengths of 2^62
    and 2^64-1 in each kind of record, and inner length fields of a chunk, an attachment,
    a metadata record."""
    out = []
    kinds = {1: "Header", 2: "Footer", 6: "Chunk", 7: "MessageIndex", 8: "ChunkIndex", 9: "Attachment"}
    kinds |= {11: "Statistics", 12: "Metadata", 13: "MetadataIndex", 14: "SummaryOffset", 15: "DataEnd"}
    for op, name in kinds.items():
        start = records_of(data, op)[0][0]
        for value in (2**62, 2**64 - 1):
            d = bytearray(data)
            _set_u64(d, start + 1, value)
            out.append((f"{name} length {value:#x}", d, start))
    chunk0 = records_of(data, 6)[0][0]
    attach = records_of(data, 9)[0][0]
    meta = records_of(data, 12)[0][0]
    compression = int.from_bytes(data[chunk0 + 9 + 28 : chunk0 + 9 + 32], "little")
    name, media = len(b"scenario.toml"), len(b"application/toml")
    u64_fields = (
        ("Chunk uncompressed_size", chunk0, chunk0 + 9 + 16),
        ("Chunk records length", chunk0, chunk0 + 9 + 32 + compression),
        ("Attachment data length", attach, attach + 9 + 20 + name + 4 + media),
    )
    u32_fields = (
        ("Chunk compression length", chunk0, chunk0 + 9 + 28),
        ("Attachment name length", attach, attach + 9 + 16),
        ("Metadata name length", meta, meta + 9),
    )
    for what, rec, at in u64_fields:
        for value in (2**62, 2**64 - 1):
            d = bytearray(data)
            _set_u64(d, at, value)
            out.append((f"{what} {value:#x}", d, rec))
    for what, rec, at in u32_fields:
        for value in (2**32 - 1, 2**31):
            d = bytearray(data)
            _set_u32(d, at, value)
            out.append((f"{what} {value:#x}", d, rec))
    return out


def test_crafted_record_and_field_lengths_are_refused_at_their_record(
    logs, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = logs["zstd"].read_bytes()
    bad = tmp_path / "crafted.mcap"
    cases = crafted_lengths(data)
    assert len(cases) >= 30
    tracemalloc.start()
    try:
        for name, d, at in cases:
            bad.write_bytes(d)
            rep = audit(bad)
            errors = [f for f in rep.findings if f.level == "error"]
            assert errors and not any(f.kind == "truncated" for f in errors), (name, errors)
            assert errors[0].kind in ("corrupt", "crc", "limit") and errors[0].offset == at, (name, at, errors)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 32 * MiB
    for _, d, _ in cases[::5]:
        bad.write_bytes(d)
        rc, out = run_cli(["audit", str(bad)], capsys)
        assert rc == 1 and "integrity: FAILED" in out


@pytest.mark.parametrize("length", [2**62, 2**64 - 1, MAX_CHUNK_BYTES + 1])
def test_crafted_lengths_inside_a_chunk_with_a_valid_crc(tmp_path: Path, length: int) -> None:
    inner = channel(1, "/x") + message(1, 0, 5, b"{}")
    inner += struct.pack("<BQ", 5, length) + b"\0" * 30  # a message whose length runs past the chunk
    p = tmp_path / "inner.mcap"
    p.write_bytes(finish([header(), chunk(inner)]))
    rep = audit(p)
    (err,) = [f for f in rep.findings if f.level == "error"]
    assert err.offset == 8 + len(header()) and "corrupt Chunk" in err.what and "declares" in err.what


@pytest.mark.parametrize(
    ("compression", "compressed", "size"),
    [
        ("zstd", random.Random(1).randbytes(4000), 9000),
        ("zstd", b"\x28\xb5\x2f\xfd" + random.Random(2).randbytes(4000), 9000),  # a zstd magic, then garbage
        ("lz4", random.Random(3).randbytes(4000), 9000),
        ("lz4", b"\x04\x22\x4d\x18\x60\x40\x82" + random.Random(4).randbytes(4000), 9000),  # lz4 magic
        ("brotli", b"whatever", 8),
        ("", b"short", 9000),
    ],
)
def test_garbage_in_a_chunk_is_a_corrupt_chunk(tmp_path: Path, compression: str, compressed: bytes, size: int) -> None:
    p = tmp_path / "garbage.mcap"
    p.write_bytes(finish([header(), chunk(b"", compression, compressed, size, crc=0)]))
    rep = audit(p)
    (err,) = rep.findings
    assert err.offset == 8 + len(header()) and err.kind == "corrupt" and "Chunk" in err.what


# -- bombs, zeros, floods ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def bombs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Chunks that inflate to 3 GB of zeros (zstd 0.1 MB, lz4 13 MB), declaring 3 GB, 1 MiB or
    60 MiB; and frames without a declared size that inflate past the 60 MiB they claim."""
    tmp = tmp_path_factory.mktemp("bombs")
    zero = bytes(64 * MiB)
    z = zstandard.ZstdCompressor(level=1).compressobj(size=3 << 30)
    zstd_3g = b"".join([*(z.compress(zero) for _ in range(48)), z.flush()])
    c = lz4.frame.LZ4FrameCompressor()
    lz4_3g = b"".join([c.begin(source_size=3 << 30), *(c.compress(zero) for _ in range(48)), c.flush()])
    z = zstandard.ZstdCompressor(level=1, write_content_size=False).compressobj()
    zstd_unsized = b"".join([*(z.compress(zero) for _ in range(4)), z.flush()])
    c = lz4.frame.LZ4FrameCompressor()
    lz4_unsized = b"".join([c.begin(), *(c.compress(zero) for _ in range(4)), c.flush()])
    out = {}
    for name, comp, data, size in (
        ("zstd-3g", "zstd", zstd_3g, 3 << 30),
        ("zstd-1m", "zstd", zstd_3g, MiB),
        ("zstd-60m", "zstd", zstd_3g, 60 * MiB),
        ("zstd-unsized", "zstd", zstd_unsized, 60 * MiB),
        ("lz4-3g", "lz4", lz4_3g, 3 << 30),
        ("lz4-1m", "lz4", lz4_3g, MiB),
        ("lz4-60m", "lz4", lz4_3g, 60 * MiB),
        ("lz4-unsized", "lz4", lz4_unsized, 60 * MiB),
    ):
        out[name] = tmp / f"{name}.mcap"
        out[name].write_bytes(finish([header(), chunk(b"", comp, data, size, crc=0)]))
    return out


@pytest.mark.integration
@pytest.mark.parametrize("compression", ["zstd", "lz4"])
def test_zstd_and_lz4_bombs_are_refused_in_bounded_memory(bombs, compression: str) -> None:
    names = [n for n in bombs if n.startswith(compression)]
    got = measure(*(bombs[n] for n in names))
    assert got["rss_mb"] < 300, got
    for name, rep in zip(names, got["reports"], strict=True):
        (err,) = [f for f in rep["findings"] if f["level"] == "error"]
        assert err["offset"] == 8 + len(header()) and err["kind"] in ("limit", "corrupt"), (name, err)
        if name.endswith("3g"):
            assert "MAX_CHUNK_BYTES = 64 MiB" in err["what"]
    done = lfctl_cli("audit", str(bombs[f"{compression}-unsized"]))
    assert done.returncode == 1 and "corrupt Chunk" in done.stdout


@pytest.mark.integration
def test_200_mb_of_zeros_is_not_read_into_memory(logs, tmp_path: Path) -> None:
    after_magic = tmp_path / "zeros.mcap"
    with after_magic.open("wb") as f:
        f.write(MAGIC)
        f.truncate(8 + 200_000_000)  # sparse: costs nothing on disk
    after_log = tmp_path / "log-then-zeros.mcap"
    after_log.write_bytes(logs["zstd"].read_bytes())
    with after_log.open("r+b") as f:
        f.truncate(after_log.stat().st_size + 200_000_000)
    got = measure(after_magic, after_log)
    assert got["rss_mb"] < 150, got
    (first,), second = (
        [f for f in r["findings"] if f["level"] == "error"] for r in got["reports"]
    )  # fmt: skip
    assert first["offset"] == 8 and "unknown opcode 0x00" in first["what"]
    assert any("200000000 bytes after the closing magic" in f["what"] for f in second)
    assert got["reports"][1]["messages"] == audit(logs["zstd"]).figures["messages"]


def flood(path: Path, n: int) -> Path:
    one = message(1, 0, 5, b"{}")
    per = (60 * MiB) // len(one)
    parts, left = [header()], n
    while left > 0:
        k = min(per, left)
        parts.append(chunk((channel(1, "/flood") if left == n else b"") + one * k))
        left -= k
    path.write_bytes(finish(parts))
    return path


def test_each_limit_is_named_when_a_file_passes_it(logs, tmp_path: Path) -> None:
    p = flood(tmp_path / "flood.mcap", 5000)
    rep = audit(p, ReadLimits(messages=1000))
    err = next(f for f in rep.findings if f.level == "error")
    assert err.kind == "limit" and "MAX_MESSAGES" in err.what and rep.figures["messages"] == 1000
    full = audit(logs["zstd"])
    for limits, name in (
        (ReadLimits(records=50), "MAX_RECORDS"),
        (ReadLimits(other_bytes=1000), "MAX_OTHER_BYTES"),
        (ReadLimits(record_bytes=1000), "MAX_RECORD_BYTES"),
        (ReadLimits(chunk_bytes=1000), "MAX_CHUNK_BYTES"),
    ):
        rep = audit(logs["zstd"], limits)
        assert any(name in f.what and f.level == "error" for f in rep.findings), (name, rep.findings)
    rep = audit(logs["zstd"], ReadLimits(message_bytes=20_000))  # payloads past it: counted, not kept
    warn = next(f for f in rep.findings if "MAX_MESSAGE_BYTES" in f.what)
    assert warn.level == "warning" and rep.ok
    assert rep.figures["messages"] == full.figures["messages"] > rep.contents.payloads_dropped > 0


def test_a_long_runs_log_is_read_whole_with_a_larger_message_limit(logs, capsys: pytest.CaptureFixture[str]) -> None:
    # a clean 3-hour run's log (2.1 million messages) failed the audit at the default limit,
    # and the command had no way to raise it
    from lfctl.cli import main

    n = audit(logs["zstd"]).figures["messages"]
    assert main(["audit", str(logs["zstd"]), "--max-messages", str(n - 1)]) == 1
    assert (
        f"more than {n - 1} messages (MAX_MESSAGES): the audit stops here (lfctl audit --max-messages N reads further)"
        in capsys.readouterr().out
    )
    assert main(["audit", str(logs["zstd"]), "--max-messages", str(n)]) == 0


@pytest.mark.slow
@pytest.mark.integration
def test_two_million_tiny_messages_stop_at_the_default_limit_in_bounded_memory(tmp_path: Path) -> None:
    got = measure(flood(tmp_path / "flood.mcap", 2_100_000), timeout=120)
    assert got["rss_mb"] < 400, got
    err = next(f for f in got["reports"][0]["findings"] if f["level"] == "error")
    assert "more than 2000000 messages (MAX_MESSAGES)" in err["what"]


# -- paths that are not regular files --------------------------------------------------------------
@pytest.mark.integration
@pytest.mark.timeout(60)  # blocked on the FIFO in this process: failed, not hung
def test_a_fifo_is_refused_without_blocking(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    fifo = tmp_path / "x.mcap"
    os.mkfifo(fifo)
    link = tmp_path / "link.mcap"
    link.symlink_to(fifo)
    got = measure(fifo, link, timeout=30)
    for rep in got["reports"]:
        (err,) = rep["findings"]
        assert err["kind"] == "file" and "FIFO" in err["what"]
    done = lfctl_cli("audit", str(fifo), timeout=30)
    assert done.returncode == 2 and "is a FIFO (named pipe), not a regular file" in done.stderr
    for args in (["audit", str(link), "--json"], ["replay", str(fifo)]):
        rc, out = run_cli(args, capsys)
        assert rc == 2 and "is a FIFO (named pipe), not a regular file" in out


def test_directories_devices_and_sockets_are_refused(logs, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sock_path = tmp_path / "s.mcap"
    sock = socket.socket(socket.AF_UNIX)
    sock.bind(str(sock_path))
    try:
        for path, what in (
            (tmp_path, "a directory"),
            (Path("/dev/null"), "a character device"),
            (sock_path, "a socket"),
        ):
            rep = audit(path)
            assert not rep.ok and rep.findings[0].kind == "file" and what in rep.findings[0].what
            rc, out = run_cli(["audit", str(path)], capsys)
            assert rc == 2 and f"is {what}, not a regular file" in out
    finally:
        sock.close()
    rc, out = run_cli(["audit", str(logs["zstd"]), "--recover", str(tmp_path)], capsys)
    assert rc == 2 and "--recover" in out
    rc, out = run_cli(["audit", str(logs["zstd"]), "--recover", str(logs["zstd"])], capsys)
    assert rc == 2 and "the log being audited" in out
    precious = tmp_path / "precious.toml"  # another file: a recovery writes over nothing
    precious.write_text("[sim]\n")
    rc, out = run_cli(["audit", str(logs["zstd"]), "--recover", str(precious)], capsys)
    assert rc == 2 and "exists" in out and precious.read_text() == "[sim]\n"


# -- crafted content with valid CRCs ---------------------------------------------------------------
def rewrite(src: Path, dst: Path, run: dict[str, str] | None = None, extra=(), end=None, attach=None) -> Path:
    """``src`` written again with mcap's Writer (valid CRCs), with run metadata values
    replaced, ``extra`` (topic, payload[, time s]) messages added, metadata ``end`` and attachments
    (name -> bytes) replaced."""
    c = audit(src).contents
    with dst.open("wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD, enable_crcs=True, enable_data_crcs=True)
        w.start(profile="", library=c.header_library)
        for name, data in {**c.attachments, **(attach or {})}.items():
            w.add_attachment(0, 0, name, c.attachment_types[name], data)
        for name, md in c.metadata.items():
            if name == "end" and end is not None:
                md = end
            w.add_metadata(name, {**md, **(run or {})} if name == "run" else md)
        schemas = {sid: w.register_schema(s.name, s.encoding, s.data) for sid, s in c.schemas.items()}
        topics = {}
        for cid, ch in c.channels.items():
            topics[ch.topic] = w.register_channel(ch.topic, ch.message_encoding, schemas.get(ch.schema_id, 0))
            for t, data in c.by_channel[cid]:
                w.add_message(topics[ch.topic], t, data, t, 0)
        for k, (topic, data, *when) in enumerate(extra):
            if topic not in topics:
                topics[topic] = w.register_channel(topic, "json", 0)
            # 5 s into the run, or the time given, s (log times are on the epoch clock)
            at = c.start_ns + int((when[0] if when else 5.0) * 1e9) + k
            w.add_message(topics[topic], at, data, at, 0)
        w.finish()
    return dst


CONTROLLER = json.dumps(
    {"status": "tracking", "range_cmd_m": 1.5, "range_error_m": 0.1, "bearing_error_deg": 1.0,
     "separation_m": 1.5, "yaw_rate_cmd_degps": 0.5}
).encode()  # fmt: skip
ODD_MESSAGES = [
    ("/follower1/controller", b"\xff\xfe\x00garbage"),
    ("/follower1/controller", b"[1, 2, 3]"),
    ("/follower1/controller", b'{"status": "tracking"}'),
    ("/follower1/controller", CONTROLLER.replace(b'"tracking"', b"3")),
    ("/follower1/controller", CONTROLLER.replace(b"0.1", b"NaN")),
    ("/follower1/controller", CONTROLLER.replace(b"0.1", b"1e400")),
    ("/follower1/controller", CONTROLLER.replace(b"0.1", b"true")),
    ("/follower1/controller", CONTROLLER.replace(b"0.1", b"1" * 400)),
    ("/follower1/controller", b"[" * 100_000 + b"]" * 100_000),
    ("/follower1/controller", CONTROLLER[:-1] + b', "target": "\\ud800\\u001b[2J"}'),
    ("/follower1/controller", "{}".encode("utf-16")),
    ("/follower1/pose_estimate", b'{"range_m": 1, "bearing_deg": 0, "truth_range_m": 0, "truth_bearing_deg": 0}'),
    ("/mavlink/leader", b'{"direction": 5, "sysid": 1, "compid": 1, "name": "X", "fields": {}}'),
    (
        "/mavlink/leader",
        b'{"direction": "in", "sysid": 1, "compid": 1, "name": "COMMAND_LONG", "fields": {"command": [1]}}',
    ),
    ("/mavlink/leader", b'{"direction": "in", "sysid": 1, "compid": 1, "name": "X", "seq": 300, "fields": {}}'),
    ("/mavlink/leader", b'{"direction": "out", "sysid": 1, "compid": 1, "name": "X", "fields": "none"}'),
    ("/leader/mission", b'{"event": "reached", "index": -1}'),
    ("/leader/mission", b'{"event": "reached", "index": "first"}'),
    ("/leader/pose", b"\xff\xff\xff\xff not a protobuf"),
    ("/leader/pose", b""),  # parses as an empty PoseInFrame: no timestamp
    ("/tf", b"\x08\x96\x01"),  # parses, as a field FrameTransforms does not have
    ("/leader/pose", PoseInFrame(frame_id="local").SerializeToString()[:-1]),  # cut short
]


@pytest.mark.parametrize(("topic", "payload"), ODD_MESSAGES, ids=[f"{t}-{i}" for i, (t, _) in enumerate(ODD_MESSAGES)])
def test_an_odd_message_with_a_valid_crc_is_a_finding_naming_its_topic(
    logs, tmp_path: Path, capsys: pytest.CaptureFixture[str], topic: str, payload: bytes
) -> None:
    p = rewrite(logs["zstd"], tmp_path / "odd.mcap", extra=[(topic, payload)])
    rep = audit(p)
    err = next(f for f in rep.findings if f.level == "error")
    assert topic in err.what and "not valid" in err.what and "t = 5.000 s" in err.what and err.offset
    rc, out = run_cli(["audit", str(p), "--json", "--strict"], capsys)
    assert rc == (0 if rep.ok else 1)
    json.loads(out)
    assert all(ch == "\n" or ch.isprintable() for ch in format_report(rep))


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("guidance_rate_hz", "0"),
        ("telemetry_rate_hz", "nan"),
        ("camera_rate_hz", "-5"),
        ("image_rate_hz", "1e400"),
        ("guidance_rate_hz", "fast"),
        ("telemetry_rate_hz", "1e300"),
        ("waypoints", "many"),
        ("waypoints", "9" * 50),
        ("followers", "../../x,follower1"),
        ("vehicles", "leader,follower1,\x1b[2J"),
    ],
)
def test_bad_run_metadata_values_are_findings(
    logs, tmp_path: Path, capsys: pytest.CaptureFixture[str], key: str, value: str
) -> None:
    p = rewrite(logs["zstd"], tmp_path / "meta.mcap", run={key: value})
    rep = audit(p)
    err = next(f for f in rep.findings if f.level == "error")
    assert err.kind == "provenance" and key in err.what
    assert rep.figures["followers"] and rep.figures["followers"][0]["follower"] == "follower1"
    rc, out = run_cli(["audit", str(p), "--strict"], capsys)
    assert rc == 1 and "\x1b" not in out


def test_plots_of_a_hostile_log_stay_in_their_folder(logs, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    extra = [("/../../x/controller", CONTROLLER)] * 3 + [("/leader/pose", b"\xff\xff garbage")]
    extra += [(t, d) for t, d in ODD_MESSAGES if t.endswith("controller")]
    p = rewrite(logs["zstd"], work / "hostile.mcap", run={"followers": "../../x,follower1,$\\frac{"}, extra=extra)
    plots = work / "plots"
    before = {q for q in tmp_path.rglob("*")}
    rc, _ = run_cli(["audit", str(p), "--plot", str(plots)], capsys)
    assert rc == 1
    new = {q for q in tmp_path.rglob("*")} - before
    assert new and all(q.parent == plots or q == plots for q in new), new
    assert {q.name for q in new} == {
        "plots",
        "trajectories.png",
        "follower1_errors.png",
        "follower1_pose.png",
        "link.png",
    }


@pytest.mark.parametrize(("topic", "late_s"), [("/mavlink/leader", 1e5), ("/leader/pose", 1e9), ("/tf", -3600.0)])
def test_a_message_logged_far_outside_the_run_is_a_finding_and_the_plots_stay_bounded(
    logs, tmp_path: Path, capsys: pytest.CaptureFixture[str], topic: str, late_s: float
) -> None:
    # one stray log time (or a foreign file's wall-clock times) must not become the run's
    # length: the plots' time marks and rate bins were sized by it (memory without end)
    src = audit(logs["zstd"]).contents
    payload = next(iter(src.messages[topic]))[1]
    p = rewrite(logs["zstd"], tmp_path / "late.mcap", extra=[(topic, payload, late_s)])
    rep = audit(p)
    (f,) = [x for x in rep.findings if "outside the run" in x.what]
    assert f.level == "error" and topic in f.what and "1 of" in f.what
    rc, _ = run_cli(["audit", str(p), "--plot", str(tmp_path / "plots")], capsys)
    assert rc == 1 and (tmp_path / "plots" / "trajectories.png").is_file()


def test_a_plot_replaces_a_link_in_its_folder_and_writes_nothing_through_it(
    logs, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    precious = tmp_path / "precious.txt"
    precious.write_text("keep me")
    plots = tmp_path / "plots"
    plots.mkdir()
    (plots / "link.png").symlink_to(precious)
    rc, _ = run_cli(["audit", str(logs["zstd"]), "--plot", str(plots)], capsys)
    assert rc == 0 and precious.read_text() == "keep me"
    assert not (plots / "link.png").is_symlink() and (plots / "link.png").read_bytes()[:4] == b"\x89PNG"


def test_a_run_that_ended_with_an_error_or_was_killed_never_passes(logs, tmp_path: Path) -> None:
    err = audit(write_log(tmp_path / "error.mcap", reason="error: ValueError: the disk went away"))
    (f,) = [x for x in err.findings if x.level == "error"]
    assert f.what == "the run ended abnormally at t = 3.95 s: error: ValueError: the disk went away"
    interrupted = audit(write_log(tmp_path / "int.mcap", reason="interrupted"))
    assert interrupted.ok and [x.what for x in interrupted.findings] == [
        "the run ended early at t = 3.95 s: interrupted"
    ]
    killed = audit(write_log(tmp_path / "killed.mcap", reason=None))
    assert not killed.ok and "integrity: FAILED" in format_report(killed)
    odd = audit(rewrite(logs["zstd"], tmp_path / "odd.mcap", end={"reason": "error: X", "t_s": "nan"}))
    assert not odd.ok and any(x.what == "the run ended abnormally: error: X" for x in odd.findings)


# -- replay ------------------------------------------------------------------------------------
def camera_log(path: Path, frames: list[bytes]) -> Path:
    from foxglove import channels as fc
    from foxglove import messages as fm

    rec = Recorder(path, config(sensing="camera", images=True))
    for k, jpeg in enumerate(frames):
        t = k / 10
        rec._log("/follower1/camera/image/compressed", fc.CompressedImageChannel, t,
                 fm.CompressedImage(format="jpeg", data=jpeg))  # fmt: skip
        rec.json("/follower1/tracker", "lfctl.Tracker", t, {"bbox": [40, 30, 20, 20], "truth_bbox": [40, 30, 20, 20],
                 "truth_visible_fraction": 1.0})  # fmt: skip
    rec.close("completed", len(frames) / 10)
    return path


def test_replay_skips_images_that_do_not_decode(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    empty = camera_log(tmp_path / "empty.mcap", [b""] * 5)
    with pytest.raises(Exception, match="none of the 5 recorded images") as exc:
        replay(empty, "hue")
    assert type(exc.value).__name__ == "ConfigError"
    rc, out = run_cli(["replay", str(empty), "--tracker", "hue-only"], capsys)
    assert rc == 2 and "none of the 5 recorded images" in out
    frame = np.zeros((120, 160, 3), np.uint8)
    frame[30:50, 40:60] = (0, 0, 255)
    good = cv2.imencode(".jpg", frame)[1].tobytes()
    huge = good[:2] + b"\xff\xc0\x00\x11\x08\xff\xff\xff\xff" + good[2:]  # claims 65535 x 65535
    mixed = camera_log(tmp_path / "mixed.mcap", [good, b"", good, b"\xff\xd8junk", huge, good, good])
    r = replay(mixed, "hue")
    assert r.frames == 7 and r.unreadable == 3
    rc, out = run_cli(["replay", str(mixed), "--tracker", "hue-only"], capsys)
    assert rc == 0 and "skipped 3 recorded images" in out and "damaged" not in out
    # bytes after the closing magic (or a chunk skipped) are said: the frames are those read
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(mixed.read_bytes() + b"\x00" * 100)
    assert replay(damaged, "hue").damaged
    rc, out = run_cli(["replay", str(damaged), "--tracker", "hue-only"], capsys)
    assert rc == 0 and "the log is damaged (a chunk skipped, a record passed over, or bytes after its end" in out


def test_an_attached_scenario_nested_too_deeply_fails_strict(logs, tmp_path: Path, capsys) -> None:
    deep = b"a = " + b"[" * 5000 + b"]" * 5000
    p = rewrite(logs["zstd"], tmp_path / "deep.mcap", attach={"scenario.toml": deep})
    rc, out = run_cli(["audit", str(p), "--strict"], capsys)
    assert rc == 1 and "nested too deeply" in out and "SHA-256" in out


@pytest.mark.parametrize(
    ("attached", "said"),
    [
        (b"a." * 500_000 + b"b = 1", "a key of 500001 dotted parts (at most 16 are read)"),  # hours to parse
        (b"name = 'x'\n" + b"# padding\n" * 120_000, "a scenario of 1200011 characters: at most 1048576 are read"),
    ],
)
def test_an_attached_scenario_too_costly_to_read_fails_strict_and_plots_without_it(
    logs, tmp_path: Path, capsys, attached: bytes, said: str
) -> None:
    # Python's TOML reader takes time with the square of a key's dotted parts: a 1 MB key held
    # --strict and --plot for hours; the attachment is refused before it is parsed
    p = rewrite(logs["zstd"], tmp_path / "hostile.mcap", attach={"scenario.toml": attached})
    rc, out = run_cli(["audit", str(p), "--strict"], capsys)
    assert rc == 1 and said in out and "SHA-256" in out
    rc, out = run_cli(["audit", str(p), "--plot", str(tmp_path / "plots")], capsys)
    assert rc == 1 and any((tmp_path / "plots").glob("*.png"))


def test_replay_with_an_unknown_tracker_kind_is_refused_before_the_log_is_read(tmp_path: Path) -> None:
    from lfctl.errors import ConfigError
    from lfctl.record.replay import replay

    with pytest.raises(ConfigError, match=r"tracker kind must be one of full, hs-lbp, hue .*got 'bogus'"):
        replay(tmp_path / "none.mcap", kind="bogus")


def test_a_damaged_record_header_in_a_whole_log_loses_no_message_its_index_can_reach(
    logs, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # one byte in a record's framing stopped the reading: the audit read 0 of 4819 messages and
    # --recover wrote none, while the summary's ChunkIndex reaches every chunk (mcap's own
    # reader read them all)
    data = logs["zstd"].read_bytes()
    whole = message_keys(logs["zstd"])
    chunks = records_of(data, 6)
    index = records_of(data, 7)[0][0]  # a MessageIndex after the first chunk
    assert len(chunks) >= 3 and whole
    header_len = bytearray(data)
    header_len[20] ^= 0xFF  # inside the Header's profile length: its own length holds
    chunk_len = bytearray(data)
    chunk_len[chunks[0][0] + 8] ^= 0x7F  # the high byte of the first Chunk's length
    opcode = bytearray(data)
    opcode[index] = 0x69  # a record no MCAP has, between two chunks
    cases = {"header": (header_len, 8), "chunk length": (chunk_len, chunks[0][0]), "opcode": (opcode, index)}
    for what, (damaged, at) in cases.items():
        bad = tmp_path / f"{what}.mcap"
        bad.write_bytes(damaged)
        assert message_keys(bad) == whole, what
        errors = [f for f in audit(bad).findings if f.level == "error"]
        assert errors[0].offset == at and errors[0].kind == "corrupt", (what, errors)
        out = tmp_path / f"{what}-recovered.mcap"
        rc, text = run_cli(["audit", str(bad), "--recover", str(out)], capsys)
        assert rc == 1 and message_keys(out) == whole, (what, text)
    rc, text = run_cli(["audit", str(tmp_path / "chunk length.mcap")], capsys)
    assert "reading went on at this Chunk again, with the length the summary's index gives it" in text
    rc, text = run_cli(["audit", str(tmp_path / "opcode.mcap")], capsys)
    assert f"reading went on at byte {chunks[1][0]}, the next Chunk the summary's index names" in text
    # ... but not on an index whose own CRC fails: what was read before the damage is what there is
    summary_too = bytearray(chunk_len)
    summary_too[records_of(data, 8)[0][0] + 9 + 16] ^= 1  # the first ChunkIndex's chunk_start_offset
    (tmp_path / "both.mcap").write_bytes(summary_too)
    assert not message_keys(tmp_path / "both.mcap")


def test_damaged_records_passed_over_stop_at_their_limit_which_is_named(tmp_path: Path) -> None:
    # Metadata records whose name length runs past the record (their framing intact): each is
    # passed over, until MAX_PASSED_OVER of them; the next one stops the reading, as a limit
    bad_meta = record(12, struct.pack("<I", 1000) + b"x")
    p = tmp_path / "many.mcap"
    p.write_bytes(finish([header(), *[bad_meta] * 8]))
    _, findings = read_contents(p, ReadLimits(passed_over=5))
    corrupt = [f for f in findings if f.kind == "corrupt" and "Metadata record" in f.what]
    limit = [f for f in findings if f.kind == "limit"]
    # the sixth is damaged (corrupt) and where the reading stops (limit)
    assert len(corrupt) == 6 and len(limit) == 1, [f.line() for f in findings]
    assert "MAX_PASSED_OVER = 5" in limit[0].what and "the audit stops here" in limit[0].what
    assert limit[0].offset == corrupt[-1].offset == len(MAGIC) + len(header()) + 5 * len(bad_meta)
    assert not [f for f in read_contents(p)[1] if f.kind == "limit"]  # the default (64) reads all eight
