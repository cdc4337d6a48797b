"""Live: the Foxglove WebSocket of a running `lfctl sim --live`, the RTP/UDP H.264 stream,
H.264 in the MCAP, the MAVLink camera component, and the audit's link figures."""

from __future__ import annotations

import asyncio
import base64
import contextlib
import dataclasses
import json
import math
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import av
import numpy as np
import pytest
import websockets
from foxglove_schemas_protobuf.CompressedVideo_pb2 import CompressedVideo
from foxglove_schemas_protobuf.LocationFix_pb2 import LocationFix
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from mcap.reader import NonSeekingReader
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mav
from support import left_stopped, wait_until

from lfctl.cli import main
from lfctl.config import load_config
from lfctl.link.camera import CameraComponent, CameraRouter
from lfctl.link.transport import UdpLink
from lfctl.record.audit import audit
from lfctl.record.layout import layout_json
from lfctl.record.rtp import RtpH264Sender, nal_units, sdp
from lfctl.record.video import H264Encoder, psnr
from lfctl.record.writer import Recorder, RecordError
from lfctl.sim.runner import run_scenario

pytestmark = pytest.mark.fmu
EXAMPLES = Path(__file__).parents[2] / "examples"
ROOT = Path(__file__).parents[2]


def short_camera_cfg(duration_s: float, **recording: object):
    cfg = load_config(EXAMPLES / "convoy.toml")
    return dataclasses.replace(
        cfg,
        sim=dataclasses.replace(cfg.sim, sensing="camera", duration_s=duration_s),
        recording=dataclasses.replace(cfg.recording, **recording),
    )


def interrupt(proc: subprocess.Popen) -> None:
    """Ctrl-C for a run in another process; killed if it has not ended 30 s later."""
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()


# -- the Foxglove WebSocket ---------------------------------------------------------------------
async def subscribe_and_collect(
    port: int,
    wanted: set[str],
    until: Callable[[dict[str, list[bytes]]], bool] | None = None,
    advertised: set[str] | None = None,
) -> dict[str, list[bytes]]:
    """Connect as Foxglove does, subscribe to every advertised channel, keep payloads per topic
    until every wanted topic has sent a message and ``until(got)`` holds (or 30 s passed);
    ``advertised`` collects every topic the server advertised.

    A wanted channel silent for a second is subscribed again: foxglove-sdk may advertise a
    channel a moment before it takes subscriptions to it ("subscribe to unknown channel"
    when the machine is busy), and a client that asks once then waits for ever.

    The client closes with a 1 s close timeout: foxglove-sdk's server answers the close frame
    but leaves the TCP connection for the client to end, so websockets' default (10 s) made
    every collection 10 s longer, long enough for a run's video to end first in a busy suite."""
    got: dict[str, list[bytes]] = {}
    async with websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"], close_timeout=1.0) as ws:
        assert ws.subprotocol == "foxglove.sdk.v1"
        topic_of_sub: dict[int, str] = {}
        channel_of_topic: dict[str, int] = {}

        async def subscribe(channels: dict[str, int]) -> None:
            subs = []
            for topic, channel_id in channels.items():
                sub_id = len(topic_of_sub) + 1
                topic_of_sub[sub_id] = topic
                subs.append({"id": sub_id, "channelId": channel_id})
            await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

        async def loop() -> None:
            loop_clock = asyncio.get_running_loop()
            asked_at = loop_clock.time()
            while not (wanted <= set(got) and (until is None or until(got))):
                if loop_clock.time() - asked_at > 1.0:
                    asked_at = loop_clock.time()
                    await subscribe({t: c for t, c in channel_of_topic.items() if t in wanted and t not in got})
                try:
                    frame = await asyncio.wait_for(ws.recv(), timeout=1.0)
                except TimeoutError:
                    continue
                if isinstance(frame, str):
                    msg = json.loads(frame)
                    if msg["op"] == "advertise":
                        new = {ch["topic"]: ch["id"] for ch in msg["channels"]}
                        if advertised is not None:
                            advertised.update(new)
                        channel_of_topic.update(new)
                        await subscribe(new)
                elif frame[0] == 1:  # messageData: op, subscription id, log time, payload
                    sub_id, _log_time = struct.unpack_from("<IQ", frame, 1)
                    got.setdefault(topic_of_sub[sub_id], []).append(bytes(frame[13:]))

        await asyncio.wait_for(loop(), timeout=30)
    return got


@pytest.mark.integration
def test_a_websocket_client_gets_poses_video_and_location_from_a_running_sim(tmp_path: Path, free_udp_ports) -> None:
    base = free_udp_ports(2)
    scen = tmp_path / "live.toml"
    scen.write_text(
        (EXAMPLES / "convoy.toml").read_text()
        + f'\n[link]\nudp_base_port = {base}\ngcs_udpout = ""\n[recording]\ndir = "{tmp_path}"\n'
    )
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "lfctl",
            "sim",
            str(scen),
            "--realtime",
            "--duration",
            "20",
            "-q",
            "--live",
            "127.0.0.1:0",
        ],
        stdout=subprocess.PIPE,
        stderr=(tmp_path / "stderr").open("w"),
        text=True,
        env=env,
    )
    try:
        assert proc.stdout is not None
        port = None
        for line in proc.stdout:
            if line.startswith("foxglove"):
                port = int(line.split("ws://127.0.0.1:")[1].split()[0])
                break
        assert port, "lfctl sim --live did not say where it serves"
        wanted = {"/leader/pose", "/follower1/camera/video", "/leader/fix", "/tf", "/follower1/controller"}
        got = asyncio.run(subscribe_and_collect(port, wanted))
    finally:
        interrupt(proc)
    assert wanted <= set(got), (sorted(got), (tmp_path / "stderr").read_text())
    pose = PoseInFrame.FromString(got["/leader/pose"][0])
    assert pose.frame_id == "ned" and pose.timestamp.seconds > 1_600_000_000
    video = CompressedVideo.FromString(got["/follower1/camera/video"][0])
    assert video.format == "h264" and nal_units(video.data)
    fix = LocationFix.FromString(got["/leader/fix"][0])
    assert 12 < fix.latitude < 14 and 77 < fix.longitude < 78
    assert "range_error_m" in json.loads(got["/follower1/controller"][0])
    assert proc.returncode == 130  # stopped by the interrupt, its log finished
    (log,) = tmp_path.glob("*.mcap")
    assert audit(log).ok


@pytest.mark.parametrize("logs_there", [False, True])
def test_live_on_a_port_in_use_is_a_clear_error(
    logs_there: bool, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)  # the log would go to ./logs
    if logs_there:
        (tmp_path / "logs").mkdir()
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        code = main(["sim", "convoy", "--duration", "1", "--live", f"127.0.0.1:{port}", "-q"])
    err = capsys.readouterr().err
    assert code == 1 and f"127.0.0.1:{port}" in err and "Traceback" not in err
    assert not list(tmp_path.rglob("*.mcap"))  # no empty log left behind, which audit would fail
    # nor the folder made for it; one that was there stays
    assert (tmp_path / "logs").is_dir() == logs_there


def test_a_refused_start_removes_every_folder_made_for_its_log_dotdot_too(tmp_path: Path) -> None:
    # mkdir makes a/../b/logs by making a, b and logs: a is removed too (a/.. is no folder to remove)
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        with pytest.raises(RecordError, match="cannot serve Foxglove"):
            Recorder(tmp_path / "a" / ".." / "b" / "logs" / "run.mcap", short_camera_cfg(1.0), live=("127.0.0.1", port))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("value", ["nohost", "127.0.0.1:99999", ":80"])
def test_a_bad_live_address_names_the_value(value: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "convoy", "--duration", "1", "--no-record", "--live", value]) == 2
    err = capsys.readouterr().err
    assert repr(value) in err and "Traceback" not in err


@pytest.mark.integration
def test_the_server_is_announced_once_the_first_step_has_made_its_channels(background_run) -> None:
    # foxglove-sdk 0.30 can tell a client that joins while channels are being made of one
    # and then refuse it ("Unknown channel ID"), which leaves its panel empty for the run:
    # the channels are made by the first step, before the server takes anyone
    cfg = short_camera_cfg(20.0)
    served: list[int] = []
    first: dict[str, object] = {}

    async def first_advertise(port: int) -> None:
        async with websockets.connect(
            f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"], close_timeout=1.0
        ) as ws:
            while "advertise" not in first:
                msg = json.loads(await asyncio.wait_for(ws.recv(), timeout=10))
                first[msg["op"]] = msg

    with background_run(cfg, realtime=True, live=("127.0.0.1", 0), on_live=served.append) as errors:
        assert wait_until(lambda: bool(served) or bool(errors), timeout_s=60.0), errors
        asyncio.run(first_advertise(served[0]))
    assert not errors, errors
    topics = {ch["topic"] for ch in first["advertise"]["channels"]}  # type: ignore[index]
    assert {"/follower1/camera/video", "/follower1/camera/annotations", "/follower1/camera/calibration",
            "/tf", "/leader/pose", "/follower1/controller", "/scene", "/log"} <= topics, topics  # fmt: skip


def test_a_live_port_taken_before_it_is_served_leaves_the_run_without_the_live_view(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # the port is checked as the recorder is made and served after the first step: one
    # another program takes in between is said, and the run goes on (it ended the run)
    rec = Recorder(None, short_camera_cfg(1.0), live=("127.0.0.1", 0))
    port = rec.live_port
    with socket.socket() as thief:
        thief.bind(("127.0.0.1", port))
        thief.listen()
        rec.serve()
    rec.close()
    assert any(f"cannot serve Foxglove on 127.0.0.1:{port}" in r.getMessage() for r in caplog.records)


def test_an_ipv6_live_address_is_served_and_announced_as_a_url(capsys: pytest.CaptureFixture[str]) -> None:
    # `--live [::1]:0` (HOST:PORT's IPv6 form) failed ("Name or service not known"), and
    # `--live ::1:0` printed ws://::1:PORT, which no WebSocket client takes
    from functools import partial

    from websockets.asyncio.client import connect

    from lfctl.cli.sim import announce_live

    try:
        with socket.socket(socket.AF_INET6) as s:
            s.bind(("::1", 0))
    except OSError:
        pytest.skip("no IPv6 loopback here")
    for given in ("[::1]", "::1"):
        rec = Recorder(None, short_camera_cfg(1.0), live=(given, 0))
        rec.on_serve = partial(announce_live, host=given, layout=Path("layout.json"))
        rec.event(0.0, "lfctl", "start")
        rec.serve()
        try:
            url = re.search(r"foxglove +(\S+)", capsys.readouterr().out)
            assert url is not None and url.group(1) == f"ws://[::1]:{rec.live_port}"

            async def subprotocol(url: str) -> str | None:
                async with connect(url, subprotocols=["foxglove.sdk.v1"]) as ws:  # type: ignore[list-item]
                    return ws.subprotocol

            assert asyncio.run(subprotocol(url.group(1))) == "foxglove.sdk.v1"
        finally:
            rec.close()


def test_closing_does_not_wait_for_ever_on_a_server_held_by_a_client(caplog: pytest.LogCaptureFixture) -> None:
    # foxglove-sdk's stop waits for every client to take its close: one that stopped reading
    # held the process after its run, Ctrl-C and SIGTERM too (the file was finished)
    import threading
    from types import SimpleNamespace

    from lfctl.record.writer import SERVER_STOP_S

    rec = Recorder(None, short_camera_cfg(1.0), live=("127.0.0.1", 0))
    held = threading.Event()
    rec._server = SimpleNamespace(stop=held.wait, port=0)  # a stop that never returns by itself
    closing = threading.Thread(target=rec.close, daemon=True)
    closing.start()
    closing.join(SERVER_STOP_S + 30.0)  # (a hang check, not a timing: the wait is SERVER_STOP_S)
    held.set()
    assert not closing.is_alive()
    assert any("did not stop within" in r.getMessage() for r in caplog.records)


# -- RTP/UDP H.264 ----------------------------------------------------------------------------
@pytest.mark.integration
def test_the_rtp_stream_decodes_with_pyav_to_the_rendered_frames(
    tmp_path: Path, free_udp_ports, background_run
) -> None:
    port = free_udp_ports(2)  # RTP and its RTCP port, as the receiver binds both
    cfg = short_camera_cfg(4.0)
    cfg = dataclasses.replace(cfg, live=dataclasses.replace(cfg.live, video_annotated=False))
    rendered: list[np.ndarray] = []
    (tmp_path / "s.sdp").write_text(sdp("127.0.0.1", port))
    decoded = []
    # the stream starts at once: frames sent before the receiver binds are lost, and it
    # begins at the next keyframe (one a second)
    with background_run(
        cfg, realtime=True, video=("127.0.0.1", port), on_frame=lambda _f, s: rendered.append(s.frame)
    ) as errors:
        container = av.open(
            str(tmp_path / "s.sdp"),
            format="sdp",
            options={"protocol_whitelist": "file,udp,rtp", "timeout": "10000000", "buffer_size": str(8 << 20)},
            timeout=20,
        )
        try:
            for frame in container.decode(video=0):
                decoded.append(frame.to_ndarray(format="bgr24"))
                if len(decoded) >= 40:
                    break
        finally:
            container.close()
    assert not errors, errors
    assert len(decoded) >= 40
    # the first decoded frame is one of the rendered ones; the rest follow it in order
    first = max(range(len(rendered)), key=lambda k: psnr(decoded[0], rendered[k]))
    scores = [psnr(d, rendered[first + k]) for k, d in enumerate(decoded)]
    assert min(scores) > 30.0, scores


@pytest.mark.integration
def test_the_camera_component_answers_a_ground_stations_requests() -> None:
    udp = UdpLink(None)
    camera = CameraComponent(
        2,
        udp.send,
        video_port=5600,
        width=640,
        height=480,
        fps=30.0,
        bitrate_kbps=1500,
        hfov_deg=62.0,
        name="follower1 camera",
    )
    router = CameraRouter(udp, [camera])
    gcs = mavutil.mavlink_connection(f"udpout:127.0.0.1:{udp.port}", source_system=255, source_component=190)
    try:
        # the autopilot's command on the same link passes through; the camera's are taken
        gcs.mav.command_long_send(2, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
        gcs.mav.command_long_send(
            2, 100, mav.MAV_CMD_REQUEST_MESSAGE, 0, mav.MAVLINK_MSG_ID_CAMERA_INFORMATION, 0, 0, 0, 0, 0, 0
        )
        gcs.mav.command_long_send(
            2, 100, mav.MAV_CMD_REQUEST_MESSAGE, 0, mav.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION, 1, 0, 0, 0, 0, 0
        )
        gcs.mav.command_long_send(
            2, 100, mav.MAV_CMD_REQUEST_MESSAGE, 0, mav.MAVLINK_MSG_ID_BATTERY_STATUS, 0, 0, 0, 0, 0, 0
        )
        passed: list[bytes] = []
        received = []
        for _ in range(200):
            for data, addr in router.recv():
                udp.accept_peer(addr)
                passed.append(data)
            if camera.requests == 3:
                break
            camera.tick(camera.t_s + 0.01)
            received.append(gcs.recv_match(timeout=0.01))
        camera.tick(camera.t_s + 1.0)
        received += [gcs.recv_match(timeout=0.2) for _ in range(8)]
        heard: dict[str, object] = {}
        acks: dict[int, list[int]] = {}
        for m in received:
            if m is not None and m.get_srcComponent() == 100:
                heard[m.get_type()] = m
                if m.get_type() == "COMMAND_ACK":
                    acks[m.command] = [*acks.get(m.command, []), m.result]
    finally:
        gcs.close()
        udp.close()
    (arm,) = [mav.MAVLink(None).parse_buffer(d)[0] for d in passed]
    assert arm.get_type() == "COMMAND_LONG" and arm.command == mav.MAV_CMD_COMPONENT_ARM_DISARM
    assert heard["HEARTBEAT"].type == mav.MAV_TYPE_CAMERA
    assert heard["CAMERA_INFORMATION"].flags & mav.CAMERA_CAP_FLAGS_HAS_VIDEO_STREAM
    info = heard["VIDEO_STREAM_INFORMATION"]
    assert info.type == mav.VIDEO_STREAM_TYPE_RTPUDP and info.uri == "5600" and info.resolution_h == 640
    assert acks[mav.MAV_CMD_REQUEST_MESSAGE] == [mav.MAV_RESULT_ACCEPTED] * 2 + [mav.MAV_RESULT_UNSUPPORTED]


def test_a_ground_station_stops_and_starts_the_camera_stream() -> None:
    # QGroundControl sends VIDEO_STOP_STREAMING as its user leaves the vehicle and
    # VIDEO_START_STREAMING as they choose it (both were UNSUPPORTED, the stream went on)
    out: list[bytes] = []
    camera = CameraComponent(
        2, out.append, video_port=5600, width=640, height=480, fps=30.0, bitrate_kbps=1500, hfov_deg=62.0, name="c"
    )
    heard: list[bool] = []
    camera.on_streaming = heard.append
    gcs, parser = mav.MAVLink(None, srcSystem=255, srcComponent=190), mav.MAVLink(None)

    def ask(command: int, *p: float) -> list[object]:
        msg = mav.MAVLink_command_long_message(2, 100, command, 0, *p, *([0.0] * (7 - len(p))))
        camera.handle(parser.parse_buffer(msg.pack(gcs))[0])
        got = [m for data in out for m in parser.parse_buffer(data) or []]
        out.clear()
        return got

    info = (mav.MAV_CMD_REQUEST_MESSAGE, mav.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION, 1)
    (ack,) = ask(mav.MAV_CMD_VIDEO_STOP_STREAMING, 1)
    assert ack.result == mav.MAV_RESULT_ACCEPTED and heard == [False] and not camera.streaming
    assert ask(*info)[1].flags == 0  # not running
    (ack,) = ask(mav.MAV_CMD_VIDEO_START_STREAMING, 0)  # 0: every stream
    assert ack.result == mav.MAV_RESULT_ACCEPTED and heard == [False, True]
    assert ask(*info)[1].flags == mav.VIDEO_STREAM_STATUS_FLAGS_RUNNING
    (ack,) = ask(mav.MAV_CMD_VIDEO_STOP_STREAMING, 2)  # no stream 2
    assert ack.result == mav.MAV_RESULT_DENIED and camera.streaming
    # stopped, then found by a ground station started afresh (which sends no START to a camera
    # it finds): its CAMERA_INFORMATION request, discovery's first, starts the stream again
    ask(mav.MAV_CMD_VIDEO_STOP_STREAMING, 1)
    ask(mav.MAV_CMD_REQUEST_MESSAGE, mav.MAVLINK_MSG_ID_VIDEO_STREAM_STATUS)
    assert heard[-1] is False and not camera.streaming  # (status asked: still stopped)
    ask(mav.MAV_CMD_REQUEST_CAMERA_INFORMATION, 1)
    assert heard[-1] is True and camera.streaming
    # its one mode, VIDEO (as CAMERA_SETTINGS says), is taken; PHOTO is not one it has
    # (MAVSDK's set_mode(VIDEO) was UNSUPPORTED)
    assert [a.result for a in ask(mav.MAV_CMD_SET_CAMERA_MODE, 0, mav.CAMERA_MODE_VIDEO)] == [mav.MAV_RESULT_ACCEPTED]
    assert [a.result for a in ask(mav.MAV_CMD_SET_CAMERA_MODE, 0, mav.CAMERA_MODE_IMAGE)] == [mav.MAV_RESULT_DENIED]
    assert camera.streaming


def test_the_camera_answers_only_for_its_one_stream_and_only_when_asked() -> None:
    # MAVLink's camera protocol: MAV_CMD_REQUEST_MESSAGE's param2 (the older commands' param1)
    # names the stream, 0 every one, 1 the first (this camera has one); the older
    # REQUEST_CAMERA_INFORMATION / _SETTINGS param1 is 1 "send" or 0 "do not", any other
    # value invalid. A long name ends in a NUL within its char[32] (QGroundControl reads it as
    # a C string: a full field ran on into the URI after it)
    out: list[bytes] = []
    camera = CameraComponent(
        2, out.append, video_port=5602, width=640, height=480, fps=30.0, bitrate_kbps=1500, hfov_deg=62.0,
        name="convoy_alpha_follower_north camera",
    )  # fmt: skip
    gcs, parser = mav.MAVLink(None, srcSystem=255, srcComponent=190), mav.MAVLink(None)

    def ask(command: int, *p: float) -> list[tuple[str, int | None]]:
        msg = mav.MAVLink_command_long_message(2, 100, command, 0, *p, *([0.0] * (7 - len(p))))
        camera.handle(parser.parse_buffer(msg.pack(gcs))[0])
        got = [m for data in out for m in parser.parse_buffer(data) or []]
        out.clear()
        return [(m.get_type(), getattr(m, "result", None)) for m in got]

    accepted, denied = ("COMMAND_ACK", mav.MAV_RESULT_ACCEPTED), ("COMMAND_ACK", mav.MAV_RESULT_DENIED)
    for msg_id, name in ((mav.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION, "VIDEO_STREAM_INFORMATION"),
                         (mav.MAVLINK_MSG_ID_VIDEO_STREAM_STATUS, "VIDEO_STREAM_STATUS")):  # fmt: skip
        for stream in (0, 1):
            assert ask(mav.MAV_CMD_REQUEST_MESSAGE, msg_id, stream) == [accepted, (name, None)]
        for stream in (2, 0.5, math.nan):
            assert ask(mav.MAV_CMD_REQUEST_MESSAGE, msg_id, stream) == [denied]
    assert ask(mav.MAV_CMD_REQUEST_VIDEO_STREAM_INFORMATION, 7) == [denied]
    camera.streaming = False
    assert ask(mav.MAV_CMD_REQUEST_CAMERA_INFORMATION, 0) == [accepted]  # "no request"
    assert not camera.streaming  # (nor taken as a ground station finding the camera)
    assert ask(mav.MAV_CMD_REQUEST_CAMERA_SETTINGS, 0) == [accepted]
    assert ask(mav.MAV_CMD_REQUEST_CAMERA_INFORMATION, 2) == [denied]
    assert ask(mav.MAV_CMD_REQUEST_CAMERA_INFORMATION, 1) == [accepted, ("CAMERA_INFORMATION", None)]
    assert camera.streaming
    # REQUEST_MESSAGE of CAMERA_INFORMATION names no stream: its param2 is not looked at
    assert ask(mav.MAV_CMD_REQUEST_MESSAGE, mav.MAVLINK_MSG_ID_CAMERA_INFORMATION, 5) == [
        accepted,
        ("CAMERA_INFORMATION", None),
    ]
    info = camera._video_stream_information()
    raw = bytes(info.pack(mav.MAVLink(None)))
    (decoded,) = mav.MAVLink(None).parse_buffer(raw)
    assert decoded.name == "convoy_alpha_follower_north cam"  # 31 bytes, then its NUL
    assert decoded.uri == "5602"
    assert bytes(camera._camera_information().model_name)[31] == 0


def test_a_signed_camera_keeps_its_signing_clock_on_the_wall_clock(monkeypatch: pytest.MonkeyPatch) -> None:
    # its codec reads nothing, so its clock moved by 10 us a packet: a ground station joining
    # more than a minute into the run took its stream for an old capture and dropped it
    from lfctl.link import camera as camera_module
    from lfctl.link import signing as signing_module
    from lfctl.link.signing import setup_signing, signing_key_from_passphrase

    key = signing_key_from_passphrase("convoy-7")
    out: list[bytes] = []
    camera = CameraComponent(
        2, out.append, video_port=5600, width=640, height=480, fps=30.0, bitrate_kbps=1500, hfov_deg=62.0,
        name="c", signing_key=key,
    )  # fmt: skip
    later = time.time() + 120.0
    monkeypatch.setattr(camera_module.time, "time", lambda: later)
    monkeypatch.setattr(signing_module.time, "time", lambda: later)
    camera.tick(120.0)
    late_gcs = mav.MAVLink(None)  # a ground station that joins two minutes in
    setup_signing(late_gcs, key)
    (beat,) = late_gcs.parse_buffer(out[-1])
    assert beat.get_type() == "HEARTBEAT" and beat.type == mav.MAV_TYPE_CAMERA


def test_a_request_for_no_message_id_is_refused_by_the_camera_and_ends_nothing() -> None:
    udp = UdpLink(None)
    camera = CameraComponent(
        2, udp.send, video_port=5600, width=640, height=480, fps=30.0, bitrate_kbps=1500, hfov_deg=62.0, name="c"
    )
    router = CameraRouter(udp, [camera])
    gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.bind(("127.0.0.1", 0))
            s.settimeout(1.0)
            for bad in (math.nan, math.inf, -math.inf, 1e30):
                for component in (100, 0):
                    msg = mav.MAVLink_command_long_message(
                        2, component, mav.MAV_CMD_REQUEST_MESSAGE, 0, bad, 0, 0, 0, 0, 0, 0
                    )
                    s.sendto(msg.pack(gcs), ("127.0.0.1", udp.port))
            time.sleep(0.1)
            passed = router.recv()
            acks = [m for data in [s.recv(2048) for _ in range(4)] for m in mav.MAVLink(None).parse_buffer(data) or []]
    finally:
        udp.close()
    # to the camera: UNSUPPORTED; to every component: not the camera's, passed on to the autopilot
    assert [(a.get_srcComponent(), a.result) for a in acks] == [(100, mav.MAV_RESULT_UNSUPPORTED)] * 4
    assert len(passed) == 4 and camera.requests == 4


def test_rtp_timestamps_start_at_random_and_a_paused_sender_sends_nothing() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as rx:
        rx.bind(("127.0.0.1", 0))
        rx.settimeout(2.0)
        port = rx.getsockname()[1]
        a, b = RtpH264Sender("127.0.0.1", port), RtpH264Sender("127.0.0.1", port)
        try:
            assert a.timestamp0 != b.timestamp0  # RFC 3550 5.1: a random start (2**-32 to collide)
            unit = b"\0\0\0\x01\x65" + bytes(50)  # one small IDR slice: one packet
            a.send(unit, 0.0)
            a.paused = True
            a.send(unit, 0.5)
            a.paused = False
            a.send(unit, 1.0)
            stamps = [struct.unpack("!I", rx.recv(2048)[4:8])[0] for _ in range(2)]
            rx.settimeout(0.2)
            with pytest.raises(TimeoutError):
                rx.recv(2048)
        finally:
            a.close()
            b.close()
    assert stamps[0] == a.timestamp0 and (stamps[1] - stamps[0]) % 2**32 == 90000  # 1 s on the 90 kHz clock


def test_rtp_goes_to_an_ipv6_address_as_host_port_writes_it() -> None:
    # `--video [::1]:5600` was accepted, announced, and then failed ("Name or service not
    # known"): the sender took IPv4 only, where `--camera rtp://[::1]:5600` receives IPv6
    rx = socket.socket(socket.AF_INET6, socket.SOCK_DGRAM)
    with rx:
        try:
            rx.bind(("::1", 0))
        except OSError:
            pytest.skip("no IPv6 loopback here")
        rx.settimeout(2.0)
        port = rx.getsockname()[1]
        for host in ("[::1]", "::1"):
            sender = RtpH264Sender(host, port)
            try:
                sender.send(b"\0\0\0\x01\x65" + bytes(50), 0.0)
                assert rx.recv(2048)[12:] == b"\x65" + bytes(50)  # the NAL unit behind the RTP header
            finally:
                sender.close()


# -- H.264 in the MCAP ------------------------------------------------------------------------------
def test_h264_in_the_mcap_reads_in_the_official_reader_and_decodes_to_the_rendered_frames(tmp_path: Path) -> None:
    cfg = short_camera_cfg(2.0, image_rate_hz=10.0, dir=str(tmp_path))
    rendered: dict[int, np.ndarray] = {}
    run_scenario(
        cfg, record_to=tmp_path / "v.mcap", on_frame=lambda _f, s: rendered.__setitem__(round(s.t_s * 100), s.frame)
    )
    start_ns = int(audit(tmp_path / "v.mcap").contents.metadata["run"]["start_time_ns"])
    decoder = av.CodecContext.create("h264", "r")
    scores = []
    with (tmp_path / "v.mcap").open("rb") as f:
        for _schema, channel, message in NonSeekingReader(f, validate_crcs=True).iter_messages(
            topics=["/follower1/camera/video"]
        ):
            del channel
            video = CompressedVideo.FromString(message.data)
            t_cs = round((message.log_time - start_ns) / 1e7)  # the frame's simulation time, 10 ms steps
            for frame in decoder.decode(av.Packet(video.data)):
                scores.append(psnr(frame.to_ndarray(format="bgr24"), rendered[t_cs]))
    assert len(scores) == pytest.approx(20, abs=1)
    assert min(scores) > 30.0, scores
    # the shipped layout is the one the code builds, and every topic it shows is in such a log
    shipped = json.loads((EXAMPLES / "foxglove-layout.json").read_text())
    assert shipped == json.loads(layout_json())
    text = json.dumps(shipped)
    named = {t.split(".")[0] for t in re.findall(r'"(/[\w/]+(?:\.\w+)?)"', text)}
    assert named and named <= set(audit(tmp_path / "v.mcap").contents.messages), named


def test_the_encoder_holds_its_bitrate_and_gop() -> None:
    rng = np.random.default_rng(3)
    base = (rng.random((240, 320, 3)) * 255).astype(np.uint8)
    enc = H264Encoder(320, 240, 30.0, 400, gop=15)
    units = [enc.encode(np.roll(base, 4 * k, axis=1)) for k in range(60)]
    assert [u.index for u in units if u.keyframe] == [0, 15, 30, 45]
    assert all(nal_units(u.data)[0][0] & 0x1F == 7 for u in units if u.keyframe)  # SPS first
    kbps = sum(len(u.data) for u in units) * 8 / 2.0 / 1000
    assert kbps < 400 * 1.5  # random noise is the worst case for a rate-controlled encoder


# -- the audit's link figures --------------------------------------------------------------------------
def packet(direction: str, sysid: int, compid: int, seq: int, name: str = "HEARTBEAT", **fields: object) -> dict:
    return {
        "direction": direction,
        "sysid": sysid,
        "compid": compid,
        "msgid": 0,
        "name": name,
        "seq": seq,
        "fields": fields,
        "raw": "",
    }


def test_loss_is_counted_per_sender_across_links_and_acks_match_their_commands(tmp_path: Path) -> None:
    cfg = load_config(EXAMPLES / "convoy.toml")
    path = tmp_path / "l.mcap"
    with Recorder(path, cfg, start_ns=1_700_000_000 * 10**9) as rec:
        # one ground station (255/190) talks to both vehicles with one counter: 0..9 alternate
        for seq in range(10):
            rec.mavlink(seq * 0.1, "leader" if seq % 2 else "follower1", packet("in", 255, 190, seq))
        rec.mavlink(1.05, "leader", packet("in", 255, 190, 13))  # 10, 11, 12 lost
        rec.mavlink(1.3, "leader", packet("in", 255, 190, 0))  # `lfctl gcs` run again at once: a restart
        rec.mavlink(9.0, "leader", packet("in", 255, 190, 0))  # a new process 8 s later: not loss
        rec.mavlink(9.1, "leader", packet("in", 255, 190, 1, "COMMAND_LONG", command=400))
        rec.mavlink(9.1, "leader", packet("in", 255, 190, 1, "COMMAND_LONG", command=400))  # a duplicate
        rec.mavlink(
            9.12, "leader", packet("out", 1, 1, 40, "COMMAND_ACK", command=400, target_system=255, target_component=190)
        )
        rec.mavlink(9.2, "leader", packet("in", 250, 1, 0, "COMMAND_LONG", command=176))
        rec.mavlink(
            9.5, "leader", packet("out", 1, 1, 41, "COMMAND_ACK", command=176, target_system=250, target_component=1)
        )
        # a stream one network peer set its own rate for: counted as that peer's, over its own time
        for k in range(21):
            rec.mavlink(
                9.0 + 0.1 * k, "leader", {**packet("out", 1, 1, k, "GLOBAL_POSITION_INT"), "to": "127.0.0.1:40001"}
            )
        # a peer named on a packet that came in: no packet comes in to one peer alone
        rec.mavlink(9.6, "leader", {**packet("in", 240, 1, 0), "to": "127.0.0.1:40003"})
    rep = audit(path)  # a log of MAVLink only: the missing topics are findings, the figures are what counts
    assert rep.figures["link_senders"]["255/190"] == {"packets": 15, "lost": 3, "loss_pct": 16.67}
    assert "240/1" not in rep.figures["link_senders"]
    assert any("'to' (the peer a packet went to alone) on a packet that came in" in f.what for f in rep.findings), [
        f.what for f in rep.findings
    ]
    leader = rep.figures["links"]["/mavlink/leader"]
    assert leader["commands"] == 3 and leader["commands_acked"] == 2
    assert leader["command_ack_latency_ms_max"] == pytest.approx(300.0)
    assert leader["command_ack_latency_ms_median"] == pytest.approx(160.0)
    assert not math.isnan(leader["rates_hz"]["in HEARTBEAT"])
    assert leader["rates_hz"]["out GLOBAL_POSITION_INT to 127.0.0.1:40001"] == pytest.approx(10.0, rel=0.06)
    assert "out GLOBAL_POSITION_INT" not in leader["rates_hz"]


def test_acks_are_matched_to_the_command_they_answer_by_who_sent_it_and_to_whom() -> None:
    # MAVSDK asks lfctl follow's camera (2/100) and the autopilot (2/1) for messages with one
    # command number: the camera's acks pass through the vehicle's port (logged in), the
    # autopilot's go out; and commands for another system that reached the port are not the
    # vehicle's (they were all counted, and acks were paired with the oldest command of the
    # number: "364 commands, 46 acked, median 14810 ms" for 359 commands all answered in 80 ms)
    from lfctl.record.audit import ack_latencies

    def cmd(t: float, target: tuple[int, int], number: int = 512) -> tuple[float, dict]:
        return t, packet(
            "in", 245, 190, 0, "COMMAND_LONG", command=number, target_system=target[0], target_component=target[1]
        )

    def ack(t: float, sender: tuple[int, int], direction: str, number: int = 512) -> tuple[float, dict]:
        return t, packet(direction, *sender, 0, "COMMAND_ACK", command=number, target_system=245, target_component=190)

    beat = (0.0, packet("out", 2, 1, 0))
    log = [
        beat,
        cmd(1.0, (2, 100)),
        cmd(1.01, (2, 1)),
        cmd(1.0, (3, 1)),  # for the leader, heard here too
        ack(1.02, (2, 1), "out"),  # the autopilot's: for the command to it, not the camera's
        ack(1.04, (2, 100), "in"),  # the camera's, through the port
        cmd(2.0, (2, 0), 511),
        ack(2.01, (2, 1), "out", 511),  # a command to every component: the first to answer
        ack(2.02, (2, 191), "in", 511),  # ... and no other
        # a command sent while the rover rebooted, twice unanswered, then answered at once:
        # the answer is to the last try (it was paired with the first: 2.16 s)
        cmd(5.0, (2, 1), 520),
        cmd(6.0, (2, 1), 520),
        cmd(7.0, (2, 1), 520),
        ack(7.01, (2, 1), "out", 520),
        # ... sent to both peers the asker was heard on: one ack, recorded twice
        (7.01, {**ack(7.01, (2, 1), "out", 520)[1], "to": "127.0.0.1:40002"}),
    ]
    commands, acks = ack_latencies(log)
    assert commands == 6
    assert [(t, round(lat, 3)) for t, lat in acks] == [(1.02, 0.01), (1.04, 0.04), (2.01, 0.01), (7.01, 0.01)]


# -- lfctl follow --live ---------------------------------------------------------------------------
def start_follow(tmp_path: Path, rover, video: Path, *extra: str) -> tuple[subprocess.Popen, int]:
    """`lfctl follow --live 127.0.0.1:0` against the rover in another process, and its Foxglove port."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    proc = subprocess.Popen(
        [
            sys.executable, "-m", "lfctl", "follow", "--mavlink", f"udpout:127.0.0.1:{rover.link.port}",
            "--camera", str(video), "--timeout", "10", "--live", "127.0.0.1:0", *extra,
        ],
        stdout=subprocess.PIPE, stderr=(tmp_path / "stderr").open("w"), text=True, env=env,
    )  # fmt: skip
    assert proc.stdout is not None
    line = proc.stdout.readline()
    if not line.startswith("foxglove"):
        interrupt(proc)
        raise AssertionError(line + (tmp_path / "stderr").read_text())
    return proc, int(line.split("ws://127.0.0.1:")[1].split()[0])


def packets(got: dict[str, list[bytes]], topic: str) -> list[dict]:
    return [json.loads(p) for p in got.get(topic, [])]


def both_ways(got: dict[str, list[bytes]]) -> bool:
    """/mavlink/rover has shown the rover's global position and a setpoint to it."""
    seen = {(p["direction"], p["name"]) for p in packets(got, "/mavlink/rover")}
    return {("out", "GLOBAL_POSITION_INT"), ("in", "SET_POSITION_TARGET_LOCAL_NED")} <= seen


def camera_beat(got: dict[str, list[bytes]]) -> bool:
    """/mavlink/rover has shown the camera component's HEARTBEAT (once a second)."""
    return any(p["compid"] == 100 for p in packets(got, "/mavlink/rover"))


@pytest.mark.integration
def test_follow_live_shows_the_rover_in_foxglove_and_streams_its_camera(
    tmp_path: Path, banner_video, standing_rover
) -> None:
    video = banner_video(400)
    rtp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rtp.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 * 1024 * 1024)  # read after the run: keep it all
    rtp.bind(("127.0.0.1", 0))
    rtp.settimeout(0.05)
    wanted = {"/rover/pose", "/rover/camera/video", "/rover/controller", "/rover/fix", "/mavlink/rover"}
    with standing_rover() as rover:
        proc, port = start_follow(tmp_path, rover, video, "--video", f"127.0.0.1:{rtp.getsockname()[1]}")
        try:
            got = asyncio.run(subscribe_and_collect(port, wanted, until=lambda g: both_ways(g) and camera_beat(g)))
        finally:
            interrupt(proc)
        stopped = wait_until(lambda: left_stopped(rover))  # the last setpoints reach the rover in its time
        time.sleep(0.2)  # and nothing else comes after them
        stopped = stopped and left_stopped(rover)
    datagrams = []
    while True:
        try:
            datagrams.append(rtp.recv(2048))
        except TimeoutError:
            break
    rtp.close()
    assert proc.returncode == 130, (tmp_path / "stderr").read_text()
    assert wanted <= set(got), sorted(got)
    assert CompressedVideo.FromString(got["/rover/camera/video"][0]).format == "h264"
    assert PoseInFrame.FromString(got["/rover/pose"][0]).frame_id == "ned"
    # the Map panel's position is the rover's own, from its GLOBAL_POSITION_INT (degE7)
    fix = LocationFix.FromString(got["/rover/fix"][-1])
    lat, lon, alt = rover.home
    assert fix.frame_id == "rover"
    assert fix.latitude == pytest.approx(lat, abs=1e-7) and fix.longitude == pytest.approx(lon, abs=1e-7)
    assert fix.altitude == pytest.approx(alt, abs=1e-3)
    # the companion's link both ways, as the rover sees it; raw bytes kept, fields decoded
    parser = mav.MAVLink(None)
    for p in packets(got, "/mavlink/rover"):
        decoded = parser.parse_buffer(base64.b64decode(p["raw"]))
        assert decoded and decoded[0].get_type() == p["name"] and decoded[0].get_msgId() == p["msgid"]
        # out: from the rover's autopilot; in: from its companion (component 191) and the camera
        # component that announces the video (100)
        assert (p["sysid"], p["compid"]) in ({(1, 1)} if p["direction"] == "out" else {(1, 191), (1, 100)}), p
    camera = [p for p in packets(got, "/mavlink/rover") if p["compid"] == 100]
    assert camera and {p["name"] for p in camera} == {"HEARTBEAT"}  # (nobody asked it anything)
    assert camera[0]["fields"]["type"] == mav.MAV_TYPE_CAMERA
    pos = next(p for p in packets(got, "/mavlink/rover") if p["name"] == "GLOBAL_POSITION_INT")
    assert (pos["fields"]["lat"], pos["fields"]["lon"]) == (round(lat * 1e7), round(lon * 1e7))
    sp = next(p for p in packets(got, "/mavlink/rover") if p["name"] == "SET_POSITION_TARGET_LOCAL_NED")
    assert sp["fields"]["type_mask"] == 1479 and sp["fields"]["coordinate_frame"] == mav.MAV_FRAME_BODY_NED
    # RTP version 2, payload type 96, the last packet of each frame marked
    assert datagrams and all(d[0] >> 6 == 2 and d[1] & 0x7F == 96 for d in datagrams)
    assert sum(d[1] >> 7 for d in datagrams) >= 1
    assert stopped, rover.guided  # stopped by the interrupt, the rover was left with a zero setpoint


@pytest.mark.integration
def test_follow_live_says_once_that_a_rover_without_gps_has_no_location_fix(
    tmp_path: Path, banner_video, standing_rover
) -> None:
    # an ArduPilot rover with no global position sends GLOBAL_POSITION_INT at 0, 0
    video = banner_video(400)

    def said(got: dict[str, list[bytes]]) -> bool:
        return any("no global position" in Log.FromString(m).message for m in got.get("/log", []))

    advertised: set[str] = set()
    with standing_rover(home=(0.0, 0.0, 0.0)) as rover:
        proc, port = start_follow(tmp_path, rover, video)
        try:
            got = asyncio.run(
                subscribe_and_collect(
                    port, {"/rover/pose", "/mavlink/rover", "/log"}, until=said, advertised=advertised
                )
            )
            # the rover goes on sending 0, 0: more steps, still no fix, and no second line
            more = asyncio.run(
                subscribe_and_collect(
                    port, {"/rover/pose"}, until=lambda g: len(g["/rover/pose"]) > 20, advertised=advertised
                )
            )
        finally:
            interrupt(proc)
    assert proc.returncode == 130, (tmp_path / "stderr").read_text()
    assert said(got)
    assert any(p["name"] == "GLOBAL_POSITION_INT" for p in packets(got, "/mavlink/rover"))
    assert "/rover/fix" not in advertised | set(got) | set(more)
    assert not any("global position" in Log.FromString(m).message for m in more.get("/log", []))


@pytest.mark.parametrize(
    ("scenario", "image_format", "video_topic"),
    [("convoy", "h264", "/follower1/camera/video"), ("vee", "h264", "/r1/camera/video"),
     ("convoy", "jpeg", "/follower1/camera/image/compressed")],
)  # fmt: skip
def test_the_layout_live_prints_shows_the_runs_own_follower_and_images(
    scenario: str, image_format: str, video_topic: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from lfctl.cli.sim import live_layout
    from lfctl.config import load_config

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    cfg = load_config(EXAMPLES / f"{scenario}.toml")
    path = live_layout(cfg.followers[0].name, cfg.leader.name, image_format)
    if (scenario, image_format) == ("convoy", "h264"):
        assert path == EXAMPLES / "foxglove-layout.json"  # the shipped one fits
    else:
        assert path.is_relative_to(tmp_path)
    text = path.read_text()
    follower = cfg.followers[0].name
    assert video_topic in text and f"/{follower}/controller.range_error_m" in text
    assert "/follower1/" not in text or follower == "follower1"


def test_a_run_without_a_camera_gets_a_layout_without_a_camera_panel(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the vee (truth sensing) got a layout whose camera topics never came
    from lfctl.cli.sim import live_layout

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    path = live_layout("r1", "leader", "h264", camera=False)
    text = path.read_text()
    assert path.is_relative_to(tmp_path) and "/camera/" not in text
    assert "/r1/controller.range_error_m" in text and '"/log"' in text
    assert live_layout("follower1", "leader", "h264", camera=False) != EXAMPLES / "foxglove-layout.json"


def test_a_camera_run_recording_no_images_gets_a_layout_without_a_camera_panel(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # [recording] images = false: the run has a camera but sends no frames, and --live printed
    # the shipped layout, whose Image panel waited for /follower1/camera/video for ever
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    scenario = tmp_path / "noimages.toml"
    scenario.write_text((EXAMPLES / "convoy.toml").read_text() + "\n[recording]\nimages = false\n")
    assert main(["sim", str(scenario), "--duration", "0.3", "--no-record", "--live", "127.0.0.1:0", "-q"]) == 0
    found = re.search(r"\(layout: (.+)\)", capsys.readouterr().out)
    assert found is not None
    layout = Path(found.group(1))
    assert layout != EXAMPLES / "foxglove-layout.json" and "/camera/" not in layout.read_text()


def test_a_run_with_no_follower_gets_a_layout_without_a_followers_panels(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # a leader alone (camera sensing, as the convoy's): --live printed the shipped layout, whose
    # Image panel and error plot waited for /follower1/... topics the run never has
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    text = (EXAMPLES / "convoy.toml").read_text()
    follower = text.index('[[vehicles]]\nname = "follower1"')
    occluder = text.index("[[scene.occluders]]")
    text = text[:follower] + text[text.index("[mission]") : occluder] + text[text.index("[[scene.lighting]]") :]
    scenario = tmp_path / "alone.toml"
    scenario.write_text(text)
    assert main(["sim", str(scenario), "--duration", "0.3", "--no-record", "--live", "127.0.0.1:0", "-q"]) == 0
    found = re.search(r"\(layout: (.+)\)", capsys.readouterr().out)
    assert found is not None
    layout = Path(found.group(1)).read_text()
    assert "follower" not in layout and "/camera/" not in layout
    assert '"/scene/vehicles"' in layout and '"/log"' in layout
    assert '"followTf":"leader"' in json.dumps(json.loads(layout), separators=(",", ":"))


def test_a_real_rovers_layout_calls_its_errors_an_estimate() -> None:
    # lfctl follow's controller errors are the stack's own estimate (a rover has no truth):
    # its layout, with no 3D scene, said "(truth)" as the simulator's does
    def titles(text: str) -> list[str]:
        return re.findall(r'"title":\s*"([^"]*formation errors[^"]*)"', text)

    assert titles(layout_json("rover", "rover", "h264", scene=False)) == ["rover formation errors (estimate)"]
    assert titles(layout_json()) == ["follower1 formation errors (truth)"]
    assert "/scene" not in layout_json("rover", "rover", "h264", scene=False)


def test_the_live_view_is_told_the_logs_clock() -> None:
    # Foxglove reads a WebSocket's messages on the server's clock when it publishes one, else
    # on the wall clock: a lockstep run (faster than the wall) drew its vehicles, placed at
    # that time, behind their slots, placed at their own stamps. The server says it has a
    # clock ("time") and tells each new time (opcode 2) before that time's messages
    rec = Recorder(None, short_camera_cfg(1.0), live=("127.0.0.1", 0))
    rec.event(0.0, "lfctl", "start")
    rec.serve()
    told: list[int] = []

    async def client() -> dict[str, object]:
        async with websockets.connect(
            f"ws://127.0.0.1:{rec.live_port}", subprotocols=["foxglove.sdk.v1"], close_timeout=1.0
        ) as ws:
            info = json.loads(await asyncio.wait_for(ws.recv(), timeout=10))
            for k in range(1, 200):
                rec.event(k * 0.25, "lfctl", f"step {k}")
                try:
                    frame = await asyncio.wait_for(ws.recv(), timeout=0.05)
                except TimeoutError:
                    continue
                if isinstance(frame, bytes) and frame[0] == 2:  # time: op, u64 ns
                    told.append(struct.unpack_from("<Q", frame, 1)[0])
                    break
            return info

    try:
        info = asyncio.run(client())
    finally:
        rec.close()
    assert info["op"] == "serverInfo" and "time" in info["capabilities"], info  # type: ignore[operator]
    (ns,) = told
    assert (ns - rec.start_ns) % 250_000_000 == 0 and ns > rec.start_ns  # a step's time, on the log's clock


@pytest.mark.integration
def test_the_cameras_answers_go_to_the_asking_peer_alone() -> None:
    # a Rover routes a message addressed to one system and component only to the link where it
    # learnt it: a second ground station on a follower's port got the camera's COMMAND_ACKs and
    # answers to the first one's requests (its HEARTBEAT still goes to both)
    udp = UdpLink(None)
    camera = CameraComponent(
        2, udp.send, video_port=5600, width=640, height=480, fps=30.0, bitrate_kbps=1500, hfov_deg=62.0,
        name="c", send_to=udp.send_to,
    )  # fmt: skip
    router = CameraRouter(udp, [camera])
    gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as a, socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as b:
        for s in (a, b):
            s.bind(("127.0.0.1", 0))
            s.settimeout(0.2)
            udp.accept_peer(s.getsockname())  # both heard before (each a ground station)
        ask = mav.MAVLink_command_long_message(
            2, 100, mav.MAV_CMD_REQUEST_MESSAGE, 0, mav.MAVLINK_MSG_ID_CAMERA_INFORMATION, 0, 0, 0, 0, 0, 0
        )
        a.sendto(ask.pack(gcs), ("127.0.0.1", udp.port))
        assert wait_until(lambda: bool(router.recv()) or camera.requests == 1, timeout_s=5.0)
        camera.tick(1.0)  # a HEARTBEAT, to everyone

        def heard(s: socket.socket) -> list[str]:
            parser, out = mav.MAVLink(None), []
            with contextlib.suppress(TimeoutError):
                while True:
                    out += [m.get_type() for m in parser.parse_buffer(s.recv(4096)) or []]
            return out

        got_a, got_b = heard(a), heard(b)
    udp.close()
    assert got_a == ["COMMAND_ACK", "CAMERA_INFORMATION", "HEARTBEAT"], got_a
    assert got_b == ["HEARTBEAT"], got_b


def test_the_layouts_plot_series_are_switched_on() -> None:
    # each series says it is on, as the app writes a plot's series itself: a reader that takes
    # a missing "enabled" as off would leave the formation errors plot empty
    def series(node: object) -> list[dict]:
        if isinstance(node, dict):
            found = [p for p in node.get("paths", []) if isinstance(p, dict)] if "paths" in node else []
            return found + [s for v in node.values() for s in series(v)]
        return [s for v in node for s in series(v)] if isinstance(node, list) else []

    for text in (layout_json(), layout_json("r1", "lead", "jpeg", camera=False)):
        paths = series(json.loads(text))
        assert paths and all(p.get("enabled") is True for p in paths)
