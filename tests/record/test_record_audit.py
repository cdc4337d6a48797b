"""MCAP recording and `lfctl audit`: round trip, figures, damage, crash recovery."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from mcap.decoder import DecoderFactory as McapDecoderFactory
from mcap.reader import NonSeekingReader, make_reader
from mcap.stream_reader import StreamReader
from mcap_protobuf.decoder import DecoderFactory
from support import free_udp_ports

from lfctl.cli import main
from lfctl.config import load_config
from lfctl.data import code_digest
from lfctl.record.audit import audit, format_report, recover
from lfctl.record.writer import FLUSH_INTERVAL_S, Recorder
from lfctl.sim.runner import run_scenario

pytestmark = pytest.mark.fmu


class JsonDecoders(McapDecoderFactory):
    """JSON channels for the official reader (mcap ships decoders for protobuf and ROS only)."""

    def decoder_for(self, message_encoding: str, schema: object):
        return json.loads if message_encoding == "json" else None


EXAMPLES = Path(__file__).parents[2] / "examples"


def small_chunks(cfg, tmp: Path, sensing: str = "truth", duration: float = 12.0):
    rec = dataclasses.replace(cfg.recording, dir=str(tmp), chunk_size_bytes=4096, image_rate_hz=5.0)
    sim = dataclasses.replace(cfg.sim, sensing=sensing, duration_s=duration)
    return dataclasses.replace(cfg, recording=rec, sim=sim)


def recorded_run(tmp: Path, sensing: str, duration: float):
    cfg = small_chunks(load_config(EXAMPLES / "convoy.toml"), tmp, sensing, duration)
    path = tmp / "run.mcap"
    report = run_scenario(cfg, record_to=path)
    return path, report


@pytest.fixture(scope="module")
def camera_log(tmp_path_factory: pytest.TempPathFactory):
    return recorded_run(tmp_path_factory.mktemp("log"), "camera", 8.0)


@pytest.fixture(scope="module")
def truth_log(tmp_path_factory: pytest.TempPathFactory):
    return recorded_run(tmp_path_factory.mktemp("log"), "truth", 40.0)


def test_every_topic_round_trips_through_the_official_reader(camera_log) -> None:
    path, _ = camera_log
    seen: dict[str, int] = {}
    start_ns = None
    stamps: dict[str, set[int]] = {"video": set(), "annotations": set()}
    tf_children: dict[str, str] = {}
    with path.open("rb") as f:
        reader = NonSeekingReader(f, validate_crcs=True, decoder_factories=[DecoderFactory(), JsonDecoders()])
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            seen[channel.topic] = seen.get(channel.topic, 0) + 1
            if channel.message_encoding == "json":
                assert isinstance(decoded, dict) and decoded == json.loads(message.data)
                # epoch log time = the run's start + the simulation time the message carries
                start = message.log_time - round(decoded["t_s"] * 1e9)
                start_ns = start if start_ns is None else start_ns
                assert abs(start - start_ns) <= 1000 and start_ns > 1.6e18  # after 2020: not 1970
            else:
                assert decoded.DESCRIPTOR.full_name == schema.name
                if hasattr(decoded, "timestamp"):
                    stamp = decoded.timestamp.seconds * 10**9 + decoded.timestamp.nanos
                    assert stamp == message.log_time, channel.topic
            if channel.topic == "/leader/pose":
                assert (
                    type(decoded).DESCRIPTOR.full_name == PoseInFrame.DESCRIPTOR.full_name and decoded.frame_id == "ned"
                )
            if channel.topic == "/follower1/camera/video":
                assert decoded.format == "h264" and decoded.frame_id == "follower1/camera"
                stamps["video"].add(message.log_time)
            if channel.topic == "/follower1/camera/annotations":
                for p in decoded.points:
                    assert p.timestamp.seconds * 10**9 + p.timestamp.nanos == message.log_time
                stamps["annotations"].add(message.log_time)
            if channel.topic == "/tf":
                tf_children |= {t.child_frame_id: t.parent_frame_id for t in decoded.transforms}
            if channel.topic == "/leader/fix":
                assert 12 < decoded.latitude < 14 and 77 < decoded.longitude < 78  # CSIR-NAL, Bengaluru
            if channel.topic == "/follower1/camera/calibration":
                assert decoded.frame_id == "follower1/camera"
    expected = {
        "/leader/pose", "/follower1/pose", "/leader/fix", "/follower1/fix", "/tf", "/scene", "/scene/vehicles",
        "/scene/mission", "/log",
        "/follower1/controller", "/follower1/tracker", "/follower1/pose_estimate", "/follower1/camera/video",
        "/follower1/camera/annotations", "/follower1/camera/calibration",
    }  # fmt: skip
    assert expected <= set(seen)
    assert seen["/follower1/camera/video"] == pytest.approx(8 * 5, abs=2)  # image_rate_hz = 5
    # every image has annotations stamped with its time, and no annotations go without an image
    # (Foxglove draws the newest over the image shown: a frame not recorded put its window
    # over an older picture); the calibration's frame is in /tf
    assert stamps["video"] == stamps["annotations"]
    assert tf_children["follower1/camera"] == "follower1" and tf_children["follower1"] == "ned"
    assert tf_children["ned"] == "map"


def foxglove_json_types(schema: dict, where: str) -> None:
    """Raise where Foxglove's JSON-schema reader would refuse ``schema`` (its
    ``parseJsonSchema``: an object lists its properties; each field is one type, boolean,
    string (base64 or plain), number, integer, an object, or an array of one of those but an
    array; integer enums as ``oneOf`` consts; no type lists, no null)."""
    assert schema.get("type") == "object", f"{where}: not an object"
    assert isinstance(schema.get("properties"), dict), f"{where}: an object without properties"
    for name, field in schema["properties"].items():
        at = f"{where}.{name}"
        if "oneOf" in field:
            assert all(isinstance(a.get("const"), int) for a in field["oneOf"]), at
            continue
        kind = field.get("type")
        if kind == "array":
            items = field.get("items")
            assert isinstance(items, dict), f"{at}: an array without items"
            if items.get("type") == "object":
                foxglove_json_types(items, at)
            else:
                assert items.get("type") in ("boolean", "string", "number", "integer"), f"{at}: items {items}"
                assert "contentEncoding" not in items, at
        elif kind == "object":
            foxglove_json_types(field, at)
        else:
            assert kind in ("boolean", "string", "number", "integer"), f"{at}: type {kind!r}"
            assert field.get("contentEncoding") in (None, "base64"), at


def test_the_json_topics_load_in_foxglove_and_each_message_fits_its_schema(camera_log) -> None:
    """Foxglove drops a channel whose schema its reader refuses (an error on the topic); the
    messages must be what the schema says, null nowhere."""
    import jsonschema

    path, _ = camera_log
    checked: dict[str, int] = {}
    with path.open("rb") as f:
        for schema, channel, message in NonSeekingReader(f).iter_messages():
            if channel.message_encoding != "json":
                continue
            doc = json.loads(schema.data)
            if schema.name not in checked:
                foxglove_json_types(doc, schema.name)
                checked[schema.name] = 0
            jsonschema.validate(json.loads(message.data), doc)
            checked[schema.name] += 1
    assert {"lfctl.Tracker", "lfctl.Controller", "lfctl.PoseEstimate", "lfctl.MavlinkPacket"} <= set(checked), checked


def test_every_json_schema_the_recorder_has_loads_in_foxglove() -> None:
    from lfctl.record.writer import JSON_SCHEMAS

    for name, schema in JSON_SCHEMAS.items():
        foxglove_json_types(schema, name)


def test_a_jpeg_log_keeps_jpeg_images(tmp_path: Path) -> None:
    cfg = small_chunks(load_config(EXAMPLES / "convoy.toml"), tmp_path, "camera", 1.0)
    cfg = dataclasses.replace(cfg, recording=dataclasses.replace(cfg.recording, image_format="jpeg"))
    run_scenario(cfg, record_to=tmp_path / "j.mcap")
    rep = audit(tmp_path / "j.mcap")
    assert rep.ok, [f.line() for f in rep.findings]
    images = rep.contents.messages["/follower1/camera/image/compressed"]
    assert images and all(CompressedImage.FromString(d).data[:2] == b"\xff\xd8" for _, d in images)
    assert "/follower1/camera/video" not in rep.contents.messages


def test_metadata_and_attachments_come_first_with_hashes(camera_log) -> None:
    path, _ = camera_log
    rep = audit(path)
    assert rep.ok, [f.line() for f in rep.findings]
    assert {"scenario.toml", "SkidSteerRover.fmi2.fmu/modelDescription.xml"} <= set(rep.contents.attachments)
    assert rep.figures["run"]["scenario"] == "convoy" and rep.figures["run"]["seed"] == "1"
    assert rep.figures["provenance"]["version"]
    # which build wrote it: the code's digest (every wheel of a version says "0.1.0 (installed)")
    assert rep.figures["provenance"]["code_sha256"] == code_digest()
    assert f"; code {code_digest()[:12]})" in format_report(rep)
    with path.open("rb") as f:
        kinds = [type(r).__name__ for r in StreamReader(f, emit_chunks=True).records]
    first_chunk = kinds.index("Chunk")
    assert kinds[:first_chunk].count("Attachment") == 2 and kinds[:first_chunk].count("Metadata") >= 4


def test_audit_figures_equal_the_run_that_wrote_the_file(truth_log, capsys: pytest.CaptureFixture[str]) -> None:
    from lfctl.cli.sim import print_report

    path, report = truth_log
    rep = audit(path)
    assert rep.ok
    (f,) = rep.figures["followers"]
    m = report.metrics[0]
    assert f["range_err_rms_m"] == pytest.approx(m.range_err_rms_m, abs=1e-4)
    assert f["range_err_max_m"] == pytest.approx(m.range_err_max_m, abs=1e-4)
    assert f["bearing_err_rms_deg"] == pytest.approx(math.degrees(m.bearing_err_rms_rad), abs=1e-3)
    assert f["min_separation_m"] == pytest.approx(m.min_separation_m, abs=1e-3)
    for state, secs in m.time_in_state_s.items():
        assert f["time_in_state_s"][state] == pytest.approx(secs, abs=1e-6)
    assert [w["index"] - 1 for w in rep.figures["mission"]] == [i for i, _ in report.waypoints_reached]
    # the same times, written the same way (the run's summary said 13.0 where the audit said 12.95)
    said = ", ".join(f"{w['index']}@{w['t_s']}s" for w in rep.figures["mission"])
    print_report(report)
    assert said and said in format_report(rep) and said in capsys.readouterr().out
    # an episode is time without TRACKING, worded as such (its states' seconds are the columns)
    for e in f["occlusion_episodes"]:
        line = f"not tracking from {e['start_s']} s for {e['duration_s']} s (at worst {e['worst']})"
        assert line in format_report(rep)
    assert f["occlusion_episodes"], "the scenario's 1.5 s dropout makes one"


def test_a_flipped_byte_inside_a_chunk_is_a_crc_error(truth_log, tmp_path: Path) -> None:
    data = bytearray(truth_log[0].read_bytes())
    with truth_log[0].open("rb") as f:  # the middle of the largest chunk: in its compressed records
        chunk = max(make_reader(f).get_summary().chunk_indexes, key=lambda c: c.chunk_length)
    i = chunk.chunk_start_offset + chunk.chunk_length // 2  # (not a chunk's header, whose sizes give another error)
    data[i] ^= 0xFF
    bad = tmp_path / "flipped.mcap"
    bad.write_bytes(bytes(data))
    rep = audit(bad)
    assert not rep.ok
    err = next(f for f in rep.findings if f.level == "error")
    assert ("CRC" in err.what or "corrupt" in err.what) and err.offset is not None and err.offset <= len(data)
    assert main(["audit", str(bad)]) == 1


def test_a_file_cut_at_60_percent_is_reported_and_recovered(
    truth_log, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = truth_log[0].read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    rep = audit(cut)
    assert not rep.ok
    assert any("truncated" in f.what for f in rep.findings)
    full = audit(truth_log[0])
    assert 0.3 * full.figures["messages"] < rep.figures["messages"] < 0.7 * full.figures["messages"]
    out = tmp_path / "recovered.mcap"
    assert main(["audit", str(cut), "--recover", str(out)]) == 1
    assert "truncated" in capsys.readouterr().out
    again = audit(out)
    assert again.ok and again.figures["messages"] == rep.figures["messages"]
    assert "recovery" in again.contents.metadata
    assert main(["audit", str(cut), "--recover", str(tmp_path / "nowhere" / "r.mcap")]) == 2
    assert "the folder" in capsys.readouterr().err and not (tmp_path / "nowhere").exists()


def test_a_file_cut_inside_a_finished_chunk_keeps_that_chunks_whole_messages(tmp_path: Path) -> None:
    """A copy or a disk that ended early cuts a chunk whose length is written: the messages
    of it that reached the file whole are kept, as from a chunk the writer had not finished;
    the recovered file keeps the attachments' times."""
    from mcap.reader import make_reader

    # chunks of the default size: a zstd block is inflated whole, and a 4 KiB chunk is one block
    cfg = load_config(EXAMPLES / "convoy.toml")
    cfg = dataclasses.replace(cfg, sim=dataclasses.replace(cfg.sim, duration_s=20.0))
    run_scenario(cfg, record_to=tmp_path / "run.mcap")
    data = (tmp_path / "run.mcap").read_bytes()
    with (tmp_path / "run.mcap").open("rb") as f:
        summary = make_reader(f).get_summary()
        times = {a.name: (a.log_time, a.create_time) for a in make_reader(f).iter_attachments()}
    assert summary is not None
    chunk = max(summary.chunk_indexes, key=lambda c: c.uncompressed_size)
    at_start, inside = tmp_path / "start.mcap", tmp_path / "inside.mcap"
    at_start.write_bytes(data[: chunk.chunk_start_offset])
    inside.write_bytes(data[: chunk.chunk_start_offset + int(chunk.chunk_length * 0.7)])
    before, rep = audit(at_start), audit(inside)
    (cut,) = [f for f in rep.findings if f.kind == "truncated"]
    assert f"a Chunk record ({chunk.chunk_length - 9} bytes declared" in cut.what, cut.what
    assert rep.figures["messages"] > before.figures["messages"], cut.what
    out = tmp_path / "recovered.mcap"
    recover(rep, out)
    with out.open("rb") as g:
        again = {a.name: (a.log_time, a.create_time) for a in make_reader(g).iter_attachments()}
    assert again == times and min(t for pair in times.values() for t in pair) > 1.6e18  # not 1970
    assert audit(out).figures["messages"] == rep.figures["messages"]


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"\x89PNG\r\n\x1a\n" + bytes(64), "looks like a PNG image"),
        (b"", "the file is empty"),
        (b"hello world, not mcap", "bad magic"),
    ],
)
def test_non_mcap_files_get_a_clear_error(
    tmp_path: Path, content: bytes, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    p = tmp_path / "x.mcap"
    p.write_bytes(content)
    assert main(["audit", str(p), "--plot", str(tmp_path / "plots")]) == 1
    out = capsys.readouterr().out
    assert message in out and "Traceback" not in out
    assert not (tmp_path / "plots").exists()  # nothing to plot: no empty PNGs


def test_strict_fails_on_the_scenarios_limits(truth_log, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path, _ = truth_log
    assert main(["audit", str(path), "--strict"]) == 0
    assert "limits (--strict): OK\n  within the scenario's [audit] limits" in capsys.readouterr().out
    text = (EXAMPLES / "convoy.toml").read_text() + "\n[audit]\nmax_range_err_rms_frac = 0.0001\n"
    cfg = load_config(EXAMPLES / "convoy.toml")
    cfg = small_chunks(dataclasses.replace(cfg, source=text), tmp_path, "truth", 8.0)
    p = tmp_path / "strict.mcap"
    run_scenario(cfg, record_to=p)
    assert main(["audit", str(p), "--strict"]) == 1
    out = capsys.readouterr().out
    # a run outside its limits is not a broken log: the two are said apart
    assert "integrity: OK\n  no findings" in out
    assert "limits (--strict): FAILED\n  ERROR: follower1: range error RMS" in out
    assert main(["audit", str(p), "--strict", "--json"]) == 1
    doc = json.loads(capsys.readouterr().out)
    assert doc["ok"] is False and doc["findings"] == [] and doc["limits"][0]["level"] == "error"


def test_json_and_plots(truth_log, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["audit", str(truth_log[0]), "--json", "--plot", str(tmp_path / "plots")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["ok"] and out["figures"]["followers"][0]["follower"] == "follower1"
    run = out["figures"]["run"]  # numbers as numbers (the metadata holds text)
    assert isinstance(run["seed"], int) and isinstance(run["duration_s"], float) and run["images"] is False
    assert isinstance(run["scenario"], str)
    for name in ("trajectories", "follower1_errors", "link"):
        assert (tmp_path / "plots" / f"{name}.png").stat().st_size > 1000
    assert not (tmp_path / "plots" / "follower1_pose.png").exists()  # truth sensing: no camera pose to plot


def test_plots_of_a_camera_run_include_the_pose_against_truth(camera_log, tmp_path: Path) -> None:
    from lfctl.record.audit import plot

    made = plot(audit(camera_log[0]), tmp_path)
    assert [p.name for p in made] == ["trajectories.png", "follower1_errors.png", "follower1_pose.png", "link.png"]


def test_replay_reruns_a_tracker_on_recorded_frames(camera_log, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["replay", str(camera_log[0]), "--tracker", "hue-only"]) == 0
    out = capsys.readouterr().out
    assert "replayed tracker (hue-only): success" in out and "recorded tracker (full):  success" in out
    assert "truncated" not in out


def test_replay_names_what_is_wrong_with_the_file(camera_log, tmp_path: Path, capsys) -> None:
    data = camera_log[0].read_bytes()
    (tmp_path / "text.mcap").write_text("hello\n")
    (tmp_path / "head.mcap").write_bytes(data[:2000])  # cut before any image
    (tmp_path / "half.mcap").write_bytes(data[: len(data) // 2])
    for name, argv, said in (
        ("text", [], "not an MCAP file"),
        ("head", [], "truncated"),
        ("whole", ["--follower", "nobody"], "has no follower 'nobody' (its followers: follower1)"),
    ):
        path = camera_log[0] if name == "whole" else tmp_path / f"{name}.mcap"
        assert main(["replay", str(path), *argv]) == 2
        assert said in capsys.readouterr().err, name
    assert main(["replay", str(tmp_path / "half.mcap")]) == 0  # what came before the cut, said so
    assert "the log is truncated (not finished)" in capsys.readouterr().out


def test_replay_of_a_log_whose_every_chunk_is_damaged_says_it_is_damaged(camera_log, tmp_path: Path, capsys) -> None:
    # every chunk's middle overwritten (the attachments and the summary intact): no image can
    # be read, and that is the damage's doing, not the run's settings (sensing, images)
    from mcap.reader import make_reader

    data = bytearray(camera_log[0].read_bytes())
    with camera_log[0].open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.chunk_indexes
    for chunk in summary.chunk_indexes:
        mid = chunk.chunk_start_offset + chunk.chunk_length // 2
        data[mid : mid + 64] = b"\xff" * 64
    (tmp_path / "damaged.mcap").write_bytes(bytes(data))
    assert main(["replay", str(tmp_path / "damaged.mcap")]) == 2
    err = capsys.readouterr().err
    assert "is damaged" in err and "camera images can be read" in err and "was it run with" not in err


def test_replay_of_a_cut_log_without_images_says_there_were_none(truth_log, tmp_path: Path, capsys) -> None:
    data = truth_log[0].read_bytes()
    (tmp_path / "cut.mcap").write_bytes(data[: len(data) // 2])
    assert main(["replay", str(tmp_path / "cut.mcap")]) == 2
    err = capsys.readouterr().err  # a truth-sensing run records no images, cut or not
    assert "no recorded camera images" in err and "before any camera image" not in err


@pytest.mark.slow
@pytest.mark.integration
def test_a_run_killed_with_sigkill_is_recovered(tmp_path: Path) -> None:
    scen = tmp_path / "s.toml"
    scen.write_text(
        (EXAMPLES / "convoy.toml").read_text().replace('sensing = "camera"   # or "truth"', 'sensing = "truth"')
        + f'\n[recording]\ndir = "{tmp_path}"\n[link]\ngcs_udpout = ""\nudp_base_port = {free_udp_ports(2)}\n'
    )  # default 1 MiB chunks: what reaches the disk is the recorder's once-a-second flush
    proc = subprocess.Popen(
        [sys.executable, "-m", "lfctl", "sim", str(scen), "--realtime", "-q"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.time() + 60
        while time.time() < deadline and not list(tmp_path.glob("*.mcap")):
            time.sleep(0.2)
        time.sleep(5.0)  # five seconds of simulated time: a few kB, far from a full chunk
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
    (log,) = tmp_path.glob("*.mcap")
    rep = audit(log)
    assert not rep.ok and any("truncated" in f.what or "no footer" in f.what for f in rep.findings)
    assert rep.figures["messages"] > 50
    last_s = max(t for t, _ in rep.contents.messages["/leader/pose"]) / 1e9
    assert last_s >= 5.0 - FLUSH_INTERVAL_S - 1.5, f"lost the log after t = {last_s:.2f} s of about 5 s"
    assert {"scenario.toml", "SkidSteerRover.fmi2.fmu/modelDescription.xml"} <= set(rep.contents.attachments)
    out = tmp_path / "fixed.mcap"
    assert recover(rep, out) == rep.figures["messages"]
    assert audit(out).ok
    assert os.path.getsize(out) > 0


def test_a_flipped_byte_in_the_summary_is_caught_by_its_crc(truth_log, tmp_path: Path) -> None:
    data = bytearray(truth_log[0].read_bytes())
    i = data.rfind(b"/leader/pose")  # the channel record repeated in the summary section
    data[i] ^= 0x20
    bad = tmp_path / "summary.mcap"
    bad.write_bytes(bytes(data))
    rep = audit(bad)
    assert any("summary CRC" in f.what for f in rep.findings if f.level == "error")


@pytest.mark.parametrize(("image_rate_hz", "expected"), [(30.0, 1800), (10.0, 600), (7.0, 420)])
def test_images_keep_their_rate_when_camera_ticks_jitter(tmp_path: Path, image_rate_hz: float, expected: int) -> None:
    # a 30 Hz camera on 100 Hz physics ticks 0.03 or 0.04 s apart; 60 s must give the
    # configured image rate, not the rate of the shorter gap (30 Hz used to record 20)
    cfg = load_config(EXAMPLES / "convoy.toml")
    cfg = dataclasses.replace(cfg, recording=dataclasses.replace(cfg.recording, image_rate_hz=image_rate_hz))
    ticks = sorted({math.ceil(k / 30.0 * 100 - 1e-9) / 100 for k in range(1800)})
    assert {round(b - a, 2) for a, b in itertools.pairwise(ticks)} == {0.03, 0.04}
    with Recorder(tmp_path / "r.mcap", cfg) as rec:
        taken = [t for t in ticks if rec.image_due(t, "follower1")]
    assert abs(len(taken) - expected) <= 1
    gaps = np.diff(taken)
    # evenly spread: within a camera period plus a physics step of each other
    assert gaps.max() - gaps.min() <= 1 / 30 + 0.011


def _children(pid: int) -> set[int]:
    out: set[int] = set()
    for task in Path(f"/proc/{pid}/task").glob("*/children"):
        out.update(int(c) for c in task.read_text().split())
    return out


@pytest.mark.slow
@pytest.mark.integration
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_or_sigterm_ends_a_camera_run_with_a_whole_log_and_no_workers_left(tmp_path: Path, sig) -> None:
    # the signal only asks the run to stop after the current step: it must never land in the
    # middle of a record (which left a truncated file), and camera workers must go too
    scen = tmp_path / "s.toml"
    text = (
        (EXAMPLES / "column5.toml").read_text().replace("[sim]\n", '[sim]\nsensing = "camera"\ncamera_workers = 1\n', 1)
    )
    scen.write_text(text + f'\n[recording]\ndir = "{tmp_path}"\n')
    proc = subprocess.Popen(
        [sys.executable, "-m", "lfctl", "sim", str(scen), "-q"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        # stepping, with its camera worker: the log has grown past its header (a chunk reaches
        # the disk every second), however long a busy machine takes to start the worker
        deadline = time.time() + 120
        while time.time() < deadline and not (
            _children(proc.pid) and sum(f.stat().st_size for f in tmp_path.glob("*.mcap")) > 64 * 1024
        ):
            time.sleep(0.2)
        workers = _children(proc.pid)
        assert workers, "the run should have a camera worker"
        proc.send_signal(sig)
        assert proc.wait(timeout=30) == 128 + sig  # as a shell reports it: 130 after SIGINT, 143 after SIGTERM
    finally:
        if proc.poll() is None:
            proc.kill()
    assert not any(Path(f"/proc/{w}").exists() for w in workers)
    (log,) = tmp_path.glob("*.mcap")
    rep = audit(log)
    assert not [f for f in rep.findings if f.level == "error"], rep.findings
    assert rep.figures["messages"] > 100
    assert rep.figures["end"]["reason"] == "interrupted" and float(rep.figures["end"]["t_s"]) > 0.1  # mid-run


def test_two_runs_in_the_same_second_keep_both_logs(tmp_path: Path) -> None:
    cfg = small_chunks(load_config(EXAMPLES / "convoy.toml"), tmp_path)
    with Recorder(tmp_path / "same.mcap", cfg) as first, Recorder(tmp_path / "same.mcap", cfg) as second:
        first.metadata("which", {"run": "first"})
        second.metadata("which", {"run": "second"})
    assert (first.path.name, second.path.name) == ("same.mcap", "same-2.mcap")
    assert audit(first.path).contents.metadata["which"] == {"run": "first"}
    assert audit(second.path).contents.metadata["which"] == {"run": "second"}


def test_a_write_the_disk_refuses_ends_the_run_naming_the_log_and_why(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # the foxglove SDK's writer reports each message it could not write (a full disk) as a
    # warning on its logger, and its next flush fails: the run ends there with one error
    # naming the log and the writer's own words, the repeats of the warning dropped, and a
    # log that cannot be finished is an error from close() too
    import logging

    from lfctl.record.writer import FOXGLOVE_LOGGER, RecordError

    cfg = load_config(EXAMPLES / "convoy.toml")
    rec = Recorder(tmp_path / "r.mcap", cfg)
    mission = {"event": "reached", "index": 0, "active": 0, "count": 1}
    rec.json("/leader/mission", "lfctl.Mission", 0.0, mission)
    full = 'McapError(Io(Os { code: 28, kind: StorageFull, message: "No space left on device" }))'
    for _ in range(3):
        logging.getLogger(FOXGLOVE_LOGGER).warning("error logging message: %s", full)
    assert capsys.readouterr().err.count("No space left") <= 1  # the first said, not each
    real = rec._mcap

    def failed(*_args: object) -> None:
        raise RuntimeError("FoxgloveError: MCAP error: attempted another write after a write method failed")

    monkeypatch.setattr(
        rec, "_mcap", type("Broken", (), {"flush": failed, "write_metadata": failed, "close": failed})()
    )
    with pytest.raises(RecordError, match=r"cannot write the run log .*r\.mcap: .*write method failed.*No space left"):
        rec.flush()
    rec.metadata("link.leader", {"datagrams": "1"})  # after it: not taken, not raised again
    with pytest.raises(RecordError, match="cannot write the run log"):
        rec.close("error: RecordError")
    real.close()
    other = Recorder(tmp_path / "next.mcap", cfg)  # the next log in the process is not blamed
    other.json("/leader/mission", "lfctl.Mission", 0.0, mission)
    other.close()
    assert audit(other.path).contents.metadata["end"]["reason"] == "completed"


def test_the_recorder_hands_a_chunk_to_the_os_every_second(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import lfctl.record.writer as writer

    clock = [100.0]
    monkeypatch.setattr(writer.time, "monotonic", lambda: clock[0])
    cfg = load_config(EXAMPLES / "convoy.toml")  # 1 MiB chunks
    rec = Recorder(tmp_path / "r.mcap", cfg)
    try:
        for k in range(50):
            rec.json(
                "/leader/mission", "lfctl.Mission", k * 0.1, {"event": "reached", "index": k, "active": k, "count": 50}
            )
        early = tmp_path / "early.mcap"
        early.write_bytes(rec.path.read_bytes())
        assert audit(early).figures["messages"] == 0  # all 50 still in the open chunk
        clock[0] += FLUSH_INTERVAL_S
        rec.json("/leader/mission", "lfctl.Mission", 5.0, {"event": "reached", "index": 50, "active": 50, "count": 51})
        data = rec.path.read_bytes()
    finally:
        rec.close()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data)  # what a SIGKILL at this moment leaves
    assert audit(cut).figures["messages"] == 51


def test_the_audit_counts_waypoints_as_the_run_summary_does(tmp_path: Path) -> None:
    # an uploaded mission of 2 waypoints and a DO item (items 1, 3) replaced the scenario's 4;
    # item 3 reported twice (the mission flown again): 2 of 2, not 3 events of the scenario's 4
    cfg = load_config(EXAMPLES / "convoy.toml")
    assert len(cfg.mission.waypoints) == 4
    rec = Recorder(tmp_path / "m.mcap", cfg)
    ack = {"msgid": 47, "name": "MISSION_ACK", "seq": 0, "raw": "AAAA", "direction": "out", "sysid": 1, "compid": 1}
    rec.mavlink(0.0, "leader", {**ack, "fields": {"type": 0, "mission_type": 0}})  # the scenario's, at the start
    rec.mavlink(0.5, "leader", {**ack, "fields": {"type": 0, "mission_type": 0}})  # a client's upload
    rec.mavlink(0.7, "leader", {**ack, "fields": {"type": 0, "mission_type": 1}})  # a fence: not the mission
    rec.mavlink(0.8, "leader", {**ack, "fields": {"type": 13, "mission_type": 0}})  # refused: nothing changed
    rec.mavlink(0.9, "leader", {**ack, "fields": {"type": 0, "mission_type": 255}})  # a clear of ALL lists
    for t, index in ((1.0, 0), (2.0, 2), (3.0, 2)):
        rec.mission_reached(t, index, min(index + 2, 3), 3, 2)
    rec.close("completed", 3.0)
    rep = audit(tmp_path / "m.mcap")
    assert (rep.figures["waypoints_reached"], rep.figures["waypoints"]) == (2, 2)
    assert rep.figures["mission_changes_s"] == [0.5, 0.9]
    assert (
        "mission: 2/2 waypoints reached (1@1.0s, 3@2.0s, 3@3.0s); the mission was replaced or cleared by a client "
        "at 0.5, 0.9 s" in format_report(rep)
    )


def test_the_newest_message_of_each_scene_topic_shows_the_whole_scene(truth_log) -> None:
    """Foxglove's 3D panel, after a seek, draws only the newest message of each topic (its
    backfill): at every moment the scene's topics' newest messages together hold every
    vehicle, the mission and every follower's slot. (One /scene carrying the vehicles and the
    mission every 5 s and the slots alone between left the vehicles and waypoints out of a
    view sought to, for up to 5 s, or for good while paused.)"""
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

    path, _report = truth_log
    cfg = load_config(EXAMPLES / "convoy.toml")
    messages = audit(path).contents.messages
    topics = ("/scene", "/scene/vehicles", "/scene/mission")
    timeline = sorted((t, topic, d) for topic in topics for t, d in messages[topic])
    first_whole = max(messages[topic][0][0] for topic in topics)
    newest: dict[str, set[str]] = {}
    want = {f"vehicle/{v.name}" for v in cfg.vehicles} | {"mission"} | {f"slot/{f.name}" for f in cfg.followers}
    checked = 0
    for k, (t, topic, d) in enumerate(timeline):
        newest[topic] = {e.id for e in SceneUpdate.FromString(d).entities}
        if t >= first_whole and (k + 1 == len(timeline) or timeline[k + 1][0] > t):  # (all of time t taken)
            assert set().union(*newest.values()) == want, (t, newest)
            checked += 1
    assert checked > 100
    # each topic holds its own part, whole: the slots at every guidance step, the rest every 5 s
    assert len(messages["/scene"]) > 10 * len(messages["/scene/vehicles"]) > 0
    assert len(messages["/scene/vehicles"]) == len(messages["/scene/mission"])


def test_the_scene_shows_each_vehicles_own_tag(tmp_path: Path) -> None:
    """With the ArUco banner each vehicle's entity carries its tag (a black square on the
    panel, no red markers) and names its id, as its banner prints it."""
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

    cfg = small_chunks(load_config(EXAMPLES / "convoy-aruco.toml"), tmp_path, "truth", 1.0)
    run_scenario(cfg, record_to=tmp_path / "t.mcap")
    first = SceneUpdate.FromString(audit(tmp_path / "t.mcap").contents.messages["/scene/vehicles"][0][1])
    vehicles = {e.id: e for e in first.entities if e.id.startswith("vehicle/")}
    texts = {k: e.texts[0].text for k, e in vehicles.items()}
    assert texts == {f"vehicle/{n}": f"{n} (tag {t})" for n, t in cfg.tag_ids().items()}
    for e in vehicles.values():
        _body, _panel, *print_ = e.cubes
        assert len(print_) == 1 and print_[0].size.y == pytest.approx(cfg.banner.tag_size_m)
        assert print_[0].color.r < 0.1  # black, not the markers' red


def test_plot_lines_break_at_gaps_and_close_marks_share_a_label() -> None:
    import numpy as np

    from lfctl.record.plots import _broken, _grouped

    t = np.array([0.0, 0.1, 0.2, 1.5, 1.6])  # no pose from 0.2 s to 1.5 s
    t2, (v,) = _broken(t, [np.array([1.0, 2.0, 3.0, 4.0, 5.0])])
    assert np.isnan(t2[3]) and np.isnan(v[3]) and list(t2[[0, 4]]) == [0.0, 1.5] and len(v) == 6
    assert _grouped([(42.0, "b"), (40.0, "a"), (40.5, "c"), (60.0, "d")], gap=1.0) == [
        (40.0, "a (40.0 s) / c (40.5 s)"),
        (42.0, "b (42.0 s)"),
        (60.0, "d (60.0 s)"),
    ]


def test_marks_are_numbered_over_the_plot_and_named_in_a_key_under_it() -> None:
    # names written along the lines ran over the curves
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from lfctl.record.plots import _marks

    fig, ax = plt.subplots()
    ax.plot([0.0, 70.0], [0.0, 1.0])
    keys = _marks(
        ax, [(30.0, "occluder"), (40.0, "lighting key: gain 1"), (40.5, "gust")], [(10.0, "leader", "AUTO")], True
    )
    assert keys == [
        "1 leader: AUTO (10.0 s)",
        "2 occluder (30.0 s)",
        "3 lighting key: gain 1 (40.0 s) / gust (40.5 s)",  # each with its own time
    ]
    numbers = [(a.get_text(), a.get_color()) for a in ax.texts]
    assert numbers == [("1", "dimgrey"), ("2", "tab:red"), ("3", "tab:red")]
    assert _marks(ax, [(30.0, "x")], [], False) == []  # the plots below: lines only
    plt.close(fig)
    # a thousand mode changes: the key stays a few lines (it grew to 19,000 characters)
    fig, ax = plt.subplots()
    ax.plot([0.0, 500.0], [0.0, 1.0])
    modes = [(0.5 * i, "follower1", "HOLD" if i % 2 else "GUIDED") for i in range(1, 1001)]
    keys = _marks(ax, [], modes, True)
    assert len(keys) == 13 and keys[-1].startswith("13-") and keys[-1].endswith(": see the log's /log topic")
    assert keys[0] == "1 follower1: HOLD (0.5 s) / follower1: GUIDED (1.0 s) / follower1: HOLD (1.5 s) / 19 more"
    plt.close(fig)


def test_time_labels_where_tracks_meet_are_not_piled_up() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from lfctl.record.plots import _time_labels

    fig, ax = plt.subplots(figsize=(4, 4))
    ax.plot([0.0, 10.0], [0.0, 10.0])
    # three vehicles' 20 s dots on one spot, and one far from them: the first and the far one
    _time_labels(ax, [(5.0, 5.0, "20", "C0"), (5.01, 5.0, "20", "C1"), (5.0, 5.02, "30", "C2"), (9.0, 1.0, "40", "C3")])
    assert [(a.get_text(), a.get_color()) for a in ax.texts] == [("20", "C0"), ("40", "C3")]
    plt.close(fig)


def test_run_metadata_numbers_are_typed_only_as_the_recorder_writes_them() -> None:
    from lfctl.record.audit import run_values

    typed = run_values({"seed": "7_0", "video_gop": "+7", "waypoints": "4", "duration_s": "70.0", "dt_s": "1e-05"})
    assert typed == {"seed": "7_0", "video_gop": "+7", "waypoints": 4, "duration_s": 70.0, "dt_s": 1e-05}
    assert run_values({"images": "yes", "camera_rate_hz": "inf"}) == {"images": "yes", "camera_rate_hz": "inf"}


def test_the_pose_errors_say_how_many_poses_they_leave_out(camera_log, monkeypatch: pytest.MonkeyPatch) -> None:
    # a follower 4.5 m back showed "-" for its pose errors with no word why
    from lfctl.record import audit as audit_module

    path, _ = camera_log
    (f,) = audit(path).figures["followers"]
    within, every = f["pose_samples"]
    assert every > 0 and within == every  # the convoy's slot is 1.5 m: every pose counts
    assert "poses with the target within" not in format_report(audit(path))
    monkeypatch.setattr(audit_module, "POSE_RANGE_M", 1.0)  # as if the slot were beyond the range
    rep = audit(path)
    assert rep.figures["followers"][0]["pose_samples"] == [0, every]
    assert f"pose errors from the 0 of {every} poses with the target within 1 m" in format_report(rep)


@pytest.mark.parametrize("companion", [True, False])
def test_a_step_without_its_track_state_is_a_finding_unless_the_companion_ran_outside(
    tmp_path: Path, companion: bool
) -> None:
    # a rehearsal's follower (companion = false) records no track state; any other follower's
    # step without one is a damaged message, left out of the figures and said
    cfg = load_config(EXAMPLES / "convoy.toml")
    cfg = dataclasses.replace(
        cfg, vehicles=(cfg.vehicles[0], dataclasses.replace(cfg.vehicles[1], companion=companion))
    )
    rec = Recorder(tmp_path / "c.mcap", cfg)
    step = {"speed_cmd_mps": 0.3, "yaw_rate_cmd_degps": 1.0, "range_cmd_m": 1.5, "range_error_m": 0.1,
            "bearing_error_deg": 1.0, "separation_m": 1.4}  # fmt: skip
    for k in range(10):
        rec.controller(k * 0.05, "follower1", {**step, **({"status": "tracking"} if k < 5 else {})})
    rec.close("completed", 0.5)
    rep = audit(tmp_path / "c.mcap")
    found = [f.what for f in rep.findings if "/follower1/controller" in f.what]
    (fig,) = rep.figures["followers"]
    if companion:
        assert found == [
            "5 of 10 messages on /follower1/controller are not valid lfctl.Controller (first: message 5 at "
            "t = 0.250 s: no field 'status'); figures leave them out"
        ]
        assert fig["time_in_state_s"]["tracking"] == 0.25 and fig["occlusion_episodes"] == []
    else:
        assert not found
        assert fig["time_in_state_s"] == {"tracking": None, "occluded": None, "lost": None}
