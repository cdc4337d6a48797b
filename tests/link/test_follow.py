"""`lfctl follow` against a vehicle endpoint on loopback UDP: a rendered banner video as the
camera, GUIDED setpoints out, formation status reported."""

from __future__ import annotations

import base64
import contextlib
import json
import logging
import math
import re
import socket
import threading
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from pymavlink.dialects.v10 import ardupilotmega as mav1
from pymavlink.dialects.v20 import ardupilotmega as mav
from support import left_stopped, loopback_udp, rtp_camera, wait_until

from lfctl.cli import main
from lfctl.cli.follow import DEFAULT_SCENARIO, MAVLINK_MAX_PER_S, NO_FIX_AFTER_S, LiveView
from lfctl.config import parse_config
from lfctl.errors import ConfigError
from lfctl.follower import rover as rover_module
from lfctl.follower.rover import _check_speed_limit
from lfctl.frames import ned_to_geodetic
from lfctl.guidance.formation import FormationSettings
from lfctl.link.camera import CameraComponent
from lfctl.link.companion import COMPANION_COMPID, ODOMETRY_MSG_IDS, Companion
from lfctl.link.endpoint import MODES, VehicleEndpoint
from lfctl.link.port import MavPort
from lfctl.link.signing import signing_key_from_passphrase
from lfctl.link.transport import MemoryLink
from lfctl.vision.camera_model import CameraModel

pytestmark = pytest.mark.integration


@pytest.mark.parametrize(
    ("passphrase", "video_flags"),
    [(None, ()), ("convoy-7", ("--video",)), (None, ("--video", "--no-camera-component"))],
)
def test_follow_drives_a_guided_rover_from_video(
    banner_video,
    standing_rover,
    capsys: pytest.CaptureFixture[str],
    passphrase: str | None,
    video_flags: tuple[str, ...],
) -> None:
    # with a passphrase the rover signs and takes only signed packets: the companion must sign,
    # and so must the camera component that announces --video's stream
    video = banner_video(40)
    received: list[tuple[float, float]] = []
    names: set[str] = set()
    senders: set[tuple[int, int]] = set()
    rtp = loopback_udp()  # (where --video sends; never read)
    stream = [*video_flags[:1], f"127.0.0.1:{rtp.getsockname()[1]}", *video_flags[1:]] if video_flags else []

    def commanded(rover: VehicleEndpoint) -> None:
        cmd = rover.guided_command()
        if cmd is not None:
            received.append(cmd)

    with standing_rover(signing_key_from_passphrase(passphrase), commanded) as rover:

        def heard(direction: str, m: Any, raw: bytes) -> None:
            if direction == "in":
                names.add(m.get_type())
                senders.add((m.get_srcSystem(), m.get_srcComponent()))

        rover.tap = heard
        rc = main(
            [
                "follow",
                "--mavlink",
                f"udpout:127.0.0.1:{rover.link.port}",
                "--camera",
                str(video),
                "--arm",
                "--max-frames",
                "30",
                "--timeout",
                "5",
                *(["--signing-passphrase", passphrase] if passphrase else []),
                *stream,
            ]
        )
        stopped = wait_until(lambda: left_stopped(rover))  # the last setpoints reach the rover in its time
        time.sleep(0.2)  # and nothing else comes after them
        stopped = stopped and left_stopped(rover)
    rtp.close()
    assert rc == 0 and "sent" in capsys.readouterr().out
    # the camera component (100) beside the companion (191) only with --video
    announced = video_flags == ("--video",)
    assert senders == {(1, COMPANION_COMPID)} | ({(1, 100)} if announced else set())
    assert rover.mode == MODES["GUIDED"] and rover.armed
    assert {"SET_POSITION_TARGET_LOCAL_NED", "NAMED_VALUE_FLOAT"} <= names
    assert max(v for v, _ in received) > 0.05  # the leader is ~1.8 m away: drive towards the slot
    assert stopped, rover.guided  # left stopped: the last target is zero speed and zero turn rate


# -- what the companion's link shows: the rover's global position, every packet both ways -----------
HOME = (12.96, 77.67, 900.0)


def test_the_companion_takes_the_rovers_global_position_and_asks_for_it() -> None:
    a, b = MemoryLink.pair("rover", "companion")
    rover = VehicleEndpoint("rover", 1, a, HOME)
    still = {"north_m": 3.0, "east_m": -4.0, "yaw_rad": 0.0, "speed_mps": 0.0, "yaw_rate_radps": 0.0}
    clock = [0.0]  # the rover's time: each read of the companion lets it tick at it
    companion = Companion(MavPort.memory(b, 1, COMPANION_COMPID, lambda: rover.tick(clock[0], still)), 1)
    companion.wait_vehicle(1.0, 20.0)
    clock[0] = 1.0
    companion.poll(1.0)  # the rover takes the requests, and streams
    assert rover._rates.intervals[mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT] == pytest.approx(0.05)
    v = companion.vehicle
    lat, lon, alt = ned_to_geodetic(3.0, -4.0, 0.0, *HOME)
    assert v.lat_deg == pytest.approx(lat, abs=1e-7) and v.lon_deg == pytest.approx(lon, abs=1e-7)
    assert v.alt_m == pytest.approx(alt, abs=1e-3) and v.global_t_s == 1.0
    # no global position: ArduPilot sends GLOBAL_POSITION_INT at 0, 0; that is no position
    rover.home = (0.0, 0.0, 0.0)
    still["north_m"] = still["east_m"] = 0.0
    clock[0] = 2.0
    companion.poll(2.0)
    assert (v.lat_deg, v.lon_deg, v.alt_m, v.global_t_s) == (None, None, None, 2.0)


def test_a_position_or_attitude_that_is_not_a_number_is_passed_over(caplog: pytest.LogCaptureFixture) -> None:
    """From the rover's address, a NaN or a 1e38 in LOCAL_POSITION_NED or ATTITUDE (ArduPilot
    sends none) would go into the odometry and stay in the formation filter: it is passed
    over."""
    a, b = MemoryLink.pair("rover", "companion")
    rover = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    companion = Companion(MavPort.memory(b, 1, COMPANION_COMPID), 1)
    good = (mav.MAVLink_local_position_ned_message(1000, 2.0, -1.0, 0.0, 0.5, 0.0, 0.0),
            mav.MAVLink_attitude_message(1000, 0.0, 0.0, 0.3, 0.0, 0.0, 0.0))  # fmt: skip
    nans = (mav.MAVLink_local_position_ned_message(1100, math.nan, -1.0, 0.0, 0.5, 0.0, 0.0),
            mav.MAVLink_local_position_ned_message(1100, 2.0, -1.0, 0.0, math.inf, 0.0, 0.0),
            mav.MAVLink_attitude_message(1100, 0.0, 0.0, math.nan, 0.0, 0.0, 0.0),
            mav.MAVLink_local_position_ned_message(1100, 1e38, -1.0, 0.0, 0.5, 0.0, 0.0),
            mav.MAVLink_local_position_ned_message(1100, 2.0, -1.0, 0.0, -2e3, 0.0, 0.0),
            mav.MAVLink_attitude_message(1100, 0.0, 0.0, 1e38, 0.0, 0.0, 0.0))  # fmt: skip
    for t, msgs in ((1.0, good), (1.1, nans)):
        for m in msgs:
            a.send(m.pack(rover))
        companion.poll(t)
    v = companion.vehicle
    assert (v.north_m, v.east_m, v.speed_mps, v.yaw_rad, v.t_s) == (2.0, -1.0, 0.5, pytest.approx(0.3), 1.0)
    assert companion.passed_over == 6
    (said,) = [r.getMessage() for r in caplog.records if "passed over" in r.getMessage()]  # once
    assert said.startswith("LOCAL_POSITION_NED from the vehicle with x = nan, not a number or past 2.00375e+07")


def test_the_companion_port_shows_every_packet_both_ways_and_odd_ones_do_not_break_the_log() -> None:
    port = MavPort.open("udpin:127.0.0.1:0", 1, COMPANION_COMPID)
    seen: list[tuple[str, Any, bytes]] = []
    port.tap = lambda d, m, raw: seen.append((d, m, raw))
    rover = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    old = mav1.MAVLink(None, srcSystem=1, srcComponent=1)
    position = mav.MAVLink_global_position_int_message(5, 129600000, 776700000, 900000, 0, 0, 0, 0, 0).pack(rover)
    heartbeat_v1 = mav1.MAVLink_heartbeat_message(10, 3, 0, 15, 3, 3).pack(old)
    no_value = mav.MAVLink_named_value_float_message(7, b"rng_err", math.nan).pack(rover)
    unknown_id = bytes([0xFD, 4, 0, 0, 7, 1, 1]) + (60123).to_bytes(3, "little") + b"\x01\x02\x03\x04\x00\x00"
    with loopback_udp() as s:
        for data in (position, heartbeat_v1, unknown_id, no_value, b"\x00junk\xfd\x01", position[:9]):
            s.sendto(data, port.connection.port.getsockname())
        deadline = time.monotonic() + 5.0
        while port.junk < 4 and time.monotonic() < deadline:
            port.recv(0.1)
    port.send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_ONBOARD_CONTROLLER, 8, 0, 0, 4, 3))
    port.close()
    # what could be framed (a message id the dialect does not know too), as it travelled;
    # garbage and a cut frame are not shown. The unknown id, the garbage (twice: its bytes, and
    # the frame it starts at its end) and the cut frame are counted as junk (each datagram is
    # read on its own: a cut frame swallows nothing after it)
    assert [(d, m.get_type()) for d, m, _ in seen] == [
        ("in", "GLOBAL_POSITION_INT"),
        ("in", "HEARTBEAT"),
        ("in", "UNKNOWN_60123"),
        ("in", "NAMED_VALUE_FLOAT"),
        ("out", "HEARTBEAT"),
    ]
    assert [raw for _, _, raw in seen[:4]] == [position, heartbeat_v1, unknown_id, no_value]
    assert port.junk == 4 and port.received == 3
    assert mav.MAVLink(None).parse_buffer(seen[4][2])[0].get_srcComponent() == COMPANION_COMPID
    # on /mavlink/<rover> as the rover sees it: what the companion sent went in, the rest came out
    cfg = parse_config(DEFAULT_SCENARIO, "follow")
    view = LiveView(cfg, "rover", CameraModel.from_config(cfg.camera), None, None)
    view.rec = rec = FakeRecorder()
    for d, m, raw in seen:
        view.mavlink(d, m, raw)
    assert [(p["direction"], p["msgid"]) for _, _, p in rec.packets] == [
        ("out", mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT),
        ("out", mav.MAVLINK_MSG_ID_HEARTBEAT),
        ("out", 60123),
        ("out", mav.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT),
        ("in", mav.MAVLINK_MSG_ID_HEARTBEAT),
    ]
    for _, vehicle, p in rec.packets:
        assert vehicle == "rover"
        json.dumps(p, allow_nan=False)  # NaN (no value) is logged as text, not refused
    assert rec.packets[3][2]["fields"]["value"] == "nan"
    assert {k: rec.packets[2][2][k] for k in ("sysid", "compid", "seq")} == {"sysid": 1, "compid": 1, "seq": 7}
    assert [base64.b64decode(p["raw"]) for _, _, p in rec.packets[:4]] == [position, heartbeat_v1, unknown_id, no_value]


class FakeRecorder:
    """What the live view hands the recorder: packets and /log lines."""

    def __init__(self) -> None:
        self.packets: list[tuple[float, str, dict[str, Any]]] = []
        self.events: list[tuple[float, str, str, str]] = []

    def mavlink(self, t_s: float, vehicle: str, packet: dict[str, Any]) -> None:
        self.packets.append((t_s, vehicle, packet))

    def event(self, t_s: float, source: str, text: str, level: str = "info") -> None:
        self.events.append((t_s, source, text, level))

    def close(self) -> None:
        pass


def test_mavlink_logging_is_bounded_per_second_but_keeps_every_statustext() -> None:
    cfg = parse_config(DEFAULT_SCENARIO, "follow")
    view = LiveView(cfg, "rover", CameraModel.from_config(cfg.camera), None, None)
    view.rec = rec = FakeRecorder()
    now = [10.0]
    view.clock = lambda: now[0]  # type: ignore[method-assign]
    m = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    hb = mav.MAVLink_heartbeat_message(10, 3, 0, 15, 3, 3)
    hb_raw = hb.pack(m)
    text = mav.MAVLink_statustext_message(4, b"Fence breached")
    text_raw = text.pack(m)
    for _ in range(MAVLINK_MAX_PER_S + 7):
        view.mavlink("in", hb, hb_raw)
    view.mavlink("in", text, text_raw)
    assert len(rec.packets) == MAVLINK_MAX_PER_S + 1 and rec.packets[-1][2]["name"] == "STATUSTEXT"
    assert view.skipped_packets == 7
    assert [level for *_, level in rec.events] == ["warning"]  # said once
    now[0] = 11.0  # a new second: logged again
    view.mavlink("in", hb, hb_raw)
    assert len(rec.packets) == MAVLINK_MAX_PER_S + 2 and view.skipped_packets == 7
    view.close()
    assert "skipped 7 packets" in rec.events[-1][2] and len(rec.events) == 2


def test_the_live_view_sends_its_camera_as_h264_whatever_the_scenario_records(tmp_path: Path) -> None:
    # its encoder makes H.264 and its layout names /<name>/camera/video: a scenario recording
    # JPEG put those frames on /<name>/camera/image/compressed, a CompressedImage said to be jpeg
    import foxglove
    import numpy as np
    from mcap.reader import make_reader

    cfg = parse_config(DEFAULT_SCENARIO + '\n[recording]\nimage_format = "jpeg"\n', "follow")
    camera = CameraModel.from_config(cfg.camera)
    view = LiveView(cfg, "rover", camera, ("127.0.0.1", 0), None)
    assert view.rec is not None
    sink = foxglove.open_mcap(str(tmp_path / "view.mcap"), context=view.rec._ctx)  # what a viewer gets
    lost = SimpleNamespace(value="lost")
    step = SimpleNamespace(
        t_s=0.1,
        frame=np.zeros((camera.height, camera.width, 3), np.uint8),
        seen=SimpleNamespace(
            measurement=SimpleNamespace(status=lost, range_m=None, bearing_rad=None), track=None, pose=None
        ),
        odometry=SimpleNamespace(north_m=0.0, east_m=0.0, yaw_rad=0.0),
        output=SimpleNamespace(
            status=lost, speed_mps=0.0, yaw_rate_radps=0.0, law="smc", range_est_m=None, bearing_est_rad=None
        ),
        settings=SimpleNamespace(range_cmd_m=1.5, bearing_cmd_rad=0.0),
        events=[],
        fix=None,
    )
    try:
        view(step)  # type: ignore[arg-type]
    finally:
        view.close()
        sink.close()
    with (tmp_path / "view.mcap").open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    topics = {ch.topic: summary.schemas[ch.schema_id].name for ch in summary.channels.values()}
    assert topics["/rover/camera/video"] == "foxglove.CompressedVideo"
    assert "/rover/camera/image/compressed" not in topics


def test_the_live_view_says_when_the_rover_has_no_global_position_once_per_change() -> None:
    cfg = parse_config(DEFAULT_SCENARIO, "follow")
    view = LiveView(cfg, "rover", CameraModel.from_config(cfg.camera), None, None)
    view.rec = rec = FakeRecorder()
    for t in (5.0, 5.0 + NO_FIX_AFTER_S / 2):  # the rover's first GLOBAL_POSITION_INT may be on its way
        view._say_fix(t, False)
    assert rec.events == []
    for t in (5.0 + NO_FIX_AFTER_S, 8.0, 9.0):
        view._say_fix(t, False)
    assert [(t, text.startswith("no global position")) for t, _, text, _ in rec.events] == [
        (5.0 + NO_FIX_AFTER_S, True)
    ]
    view._say_fix(10.0, True)
    view._say_fix(11.0, True)
    view._say_fix(12.0, False)
    assert [t for t, *_ in rec.events] == [5.0 + NO_FIX_AFTER_S, 10.0, 12.0]
    assert "LocationFix on /rover/fix" in rec.events[1][2] and "lost" in rec.events[2][2]
    # a rover whose position comes in time: nothing to say
    quiet = LiveView(cfg, "rover", CameraModel.from_config(cfg.camera), None, None)
    quiet.rec = FakeRecorder()
    quiet._say_fix(0.0, False)
    quiet._say_fix(0.1, True)
    assert quiet.rec.events == []


# -- the companion as a component of its own: heartbeat, LFC_* parameters, commands --------------
def _gcs_to(port: MavPort) -> tuple[socket.socket, mav.MAVLink]:
    """A ground station's socket and codec (system 255), sending to ``port`` as the rover's
    MAVLink routing would forward it."""
    s = loopback_udp()
    return s, mav.MAVLink(None, srcSystem=255, srcComponent=190)


def test_the_companion_answers_a_ground_stations_parameter_requests_for_its_own_component(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, logger="lfctl.link.companion")
    companion = Companion(MavPort.open("udpin:127.0.0.1:0", 1, COMPANION_COMPID), 1)
    sent: list[Any] = []
    companion.port.tap = lambda d, m, raw: sent.append(m) if d == "out" else None
    address = companion.port.connection.port.getsockname()
    sock, gcs = _gcs_to(companion.port)

    def ask(msg: Any) -> list[Any]:
        sent.clear()
        sock.sendto(msg.pack(gcs), address)
        companion.poll(0.0, 2.0)
        return [(m.get_type(), m) for m in sent]

    try:
        # a list to every component of the vehicle (QGroundControl's): each LFC_* with its index
        answers = ask(mav.MAVLink_param_request_list_message(1, 0))
        names = [m.param_id for _, m in answers]
        assert names == ["LFC_RANGE", "LFC_BEARING", "LFC_COAST", "LFC_SEARCH", "LFC_LAW", "LFC_LOOKAHEAD"]
        assert [(m.param_index, m.param_count) for _, m in answers] == [(k, 6) for k in range(6)]
        assert answers[4][1].param_type == mav.MAV_PARAM_TYPE_INT8
        # a set addressed to it: stored, answered with the value in force (index -1)
        ((kind, m),) = ask(mav.MAVLink_param_set_message(1, COMPANION_COMPID, b"LFC_RANGE", 2.5, 9))
        assert (kind, m.param_id, m.param_value, m.param_index) == ("PARAM_VALUE", "LFC_RANGE", 2.5, 65535)
        assert companion.param("LFC_RANGE") == 2.5
        assert "LFC_RANGE set to 2.5 by 255/190" in caplog.text  # (lfctl follow -v says it)
        # a broadcast set of LFC_LAW is its; of an autopilot parameter, not (it stays silent)
        ((kind, m),) = ask(mav.MAVLink_param_set_message(1, 0, b"LFC_LAW", 2.0, mav.MAV_PARAM_TYPE_INT8))
        assert (m.param_id, m.param_value) == ("LFC_LAW", 2.0) and companion.param("LFC_LAW") == 2
        assert ask(mav.MAVLink_param_set_message(1, 0, b"WP_SPEED", 1.0, 9)) == []
        assert ask(mav.MAVLink_param_request_read_message(1, 0, b"", 0)) == []  # by index: the autopilot's
        # addressed to it: out of range, unknown, by index past the end: said, the value kept
        answers = ask(mav.MAVLink_param_set_message(1, COMPANION_COMPID, b"LFC_RANGE", 5000.0, 9))
        assert [k for k, _ in answers] == ["STATUSTEXT", "PARAM_VALUE"] and answers[1][1].param_value == 2.5
        assert "LFC_RANGE rejected: 5000 outside 0.1..1000 m" in answers[0][1].text
        ((kind, m),) = ask(mav.MAVLink_param_request_read_message(1, COMPANION_COMPID, b"WP_SPEED", -1))
        assert kind == "STATUSTEXT" and m.text == "Unknown parameter WP_SPEED"
        ((kind, m),) = ask(mav.MAVLink_param_request_read_message(1, COMPANION_COMPID, b"", 6))
        assert m.text == "No parameter at index 6 (there are 6)"
        ((kind, m),) = ask(mav.MAVLink_param_request_read_message(1, COMPANION_COMPID, b"", 1))
        assert (m.param_id, m.param_index) == ("LFC_BEARING", 1)
        # another vehicle's, or the autopilot's alone: not its to answer
        assert ask(mav.MAVLink_param_request_list_message(2, 0)) == []
        assert ask(mav.MAVLink_param_request_list_message(1, 1)) == []
        # a command addressed to it: UNSUPPORTED, to the sender; a broadcast one is the autopilot's
        ((kind, m),) = ask(mav.MAVLink_command_long_message(1, COMPANION_COMPID, 400, 0, 1, 0, 0, 0, 0, 0, 0))
        assert (kind, m.command, m.result) == ("COMMAND_ACK", 400, mav.MAV_RESULT_UNSUPPORTED)
        assert (m.target_system, m.target_component) == (255, 190)
        assert ask(mav.MAVLink_command_long_message(1, 0, 400, 0, 1, 0, 0, 0, 0, 0, 0)) == []
        # its heartbeat once a second, however often asked
        sent.clear()
        for t in (10.0, 10.4, 10.99, 11.0, 11.5, 12.1):
            companion.heartbeat(t)
        assert [m.get_type() for m in sent] == ["HEARTBEAT"] * 3
        assert (sent[0].type, sent[0].autopilot) == (mav.MAV_TYPE_ONBOARD_CONTROLLER, mav.MAV_AUTOPILOT_INVALID)
    finally:
        sock.close()
        companion.close()


def test_the_video_is_announced_as_the_rovers_camera_until_another_camera_talks(
    caplog: pytest.LogCaptureFixture,
) -> None:
    companion = Companion(MavPort.open("udpin:127.0.0.1:0", 1, COMPANION_COMPID), 1)
    tapped: list[tuple[str, Any]] = []
    companion.port.tap = lambda d, m, raw: tapped.append((d, m))
    camera = CameraComponent(
        1, companion.port.write, video_port=5602, width=640, height=480, fps=20.0, bitrate_kbps=1500, hfov_deg=62.0,
        name="follower1 camera", tap=companion.camera_tap,
    )  # fmt: skip
    companion.offer_video(camera)
    switched: list[bool] = []
    camera.on_streaming = switched.append
    address = companion.port.connection.port.getsockname()
    sock, gcs = _gcs_to(companion.port)
    sock.settimeout(0.5)
    parser = mav.MAVLink(None)

    def heard() -> list[Any]:
        out: list[Any] = []
        with contextlib.suppress(TimeoutError):
            while True:
                out += parser.parse_buffer(sock.recv(4096)) or []
                sock.settimeout(0.1)
        sock.settimeout(0.5)
        return out

    def ask(msg: Any, sender: mav.MAVLink = gcs) -> list[Any]:
        sock.sendto(msg.pack(sender), address)
        companion.poll(0.0, 2.0)
        return heard()

    try:
        ask(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))
        companion.heartbeat(1.0)
        first = heard()
        beats = {(m.get_srcSystem(), m.get_srcComponent(), m.type) for m in first if m.get_type() == "HEARTBEAT"}
        # the rover's camera (system 1, component 100) beside its companion (191)
        assert beats == {(1, 100, mav.MAV_TYPE_CAMERA), (1, COMPANION_COMPID, mav.MAV_TYPE_ONBOARD_CONTROLLER)}
        # a relay looping the link back sends them back: echoes, not another camera or companion
        for m in first:
            sock.sendto(bytes(m.get_msgbuf()), address)
        companion.poll(0.0, 1.0)
        companion.poll(0.0, 0.2)
        assert companion.echoes == 2 and companion.camera is camera
        assert not companion.camera_clash and not companion.other_companion
        # QGroundControl's questions, addressed to it as the rover's routing forwards them
        info = mav.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION
        ack, stream = ask(
            mav.MAVLink_command_long_message(1, 100, mav.MAV_CMD_REQUEST_MESSAGE, 0, info, 0, 0, 0, 0, 0, 0)
        )
        assert (ack.get_type(), ack.result, ack.target_system, ack.target_component) == ("COMMAND_ACK", 0, 255, 190)
        assert (stream.get_srcSystem(), stream.get_srcComponent()) == (1, 100)
        assert (stream.type, stream.uri, stream.encoding) == (
            mav.VIDEO_STREAM_TYPE_RTPUDP,
            "5602",
            mav.VIDEO_STREAM_ENCODING_H264,
        )
        assert (stream.resolution_h, stream.resolution_v, stream.framerate, stream.hfov) == (640, 480, 20.0, 62)
        (ack,) = ask(mav.MAVLink_command_long_message(1, 100, mav.MAV_CMD_VIDEO_STOP_STREAMING, 0, 1, 0, 0, 0, 0, 0, 0))
        assert ack.result == mav.MAV_RESULT_ACCEPTED and switched == [False]
        # what it sends is in the port's log once, and so is what it was handed (the read's)
        outs = [m.get_type() for d, m in tapped if d == "out" and m.get_srcComponent() == 100]
        ins = [m.get_type() for d, m in tapped if d == "in" and m.get_type() == "COMMAND_LONG"]
        assert outs == ["HEARTBEAT", "COMMAND_ACK", "VIDEO_STREAM_INFORMATION", "COMMAND_ACK"] and len(ins) == 2
        # a request that is not a message id (NaN, infinity) is answered UNSUPPORTED and ends nothing;
        # one to every component of the rover is the autopilot's (and the camera's only for its messages)
        for bad in (math.nan, math.inf, -1.0, 2.5):
            (ack,) = ask(
                mav.MAVLink_command_long_message(1, 100, mav.MAV_CMD_REQUEST_MESSAGE, 0, bad, 0, 0, 0, 0, 0, 0)
            )
            assert (ack.get_srcComponent(), ack.result) == (100, mav.MAV_RESULT_UNSUPPORTED)
            assert (
                ask(mav.MAVLink_command_long_message(1, 0, mav.MAV_CMD_REQUEST_MESSAGE, 0, bad, 0, 0, 0, 0, 0, 0)) == []
            )
        assert companion.handler_errors == 0
        # the rover's own camera talks (only its broadcasts reach this link once the rover has heard
        # ours here): ours steps aside, said once, and the stream it had stopped goes again;
        # questions to 100 are left to the other
        other = mav.MAVLink(None, srcSystem=1, srcComponent=100)
        status = mav.MAVLink_video_stream_status_message(1, 1, 30.0, 1280, 720, 2000000, 0, 90)
        ask(status, other)
        assert companion.camera is None and companion.camera_clash
        assert "another camera (component 100 of system 1) talks on the link" in caplog.text
        assert switched == [False, True]
        assert (
            ask(mav.MAVLink_command_long_message(1, 100, mav.MAV_CMD_REQUEST_MESSAGE, 0, info, 0, 0, 0, 0, 0, 0)) == []
        )
        companion.heartbeat(3.0)
        assert {m.get_srcComponent() for m in heard()} == {COMPANION_COMPID}
    finally:
        sock.close()
        companion.close()


def test_a_ground_station_moves_a_real_rovers_follower_with_lfc_parameters(banner_video, standing_rover) -> None:
    # lfctl follow's loop on a rover over loopback UDP; a PARAM_SET for component 191 comes in
    # on the companion's link as the rover's MAVLink routing forwards a ground station's
    from lfctl.config import parse_config
    from lfctl.follower.rover import follow_rover
    from lfctl.follower.stack import formation_settings
    from lfctl.video import VideoSource
    from lfctl.vision.perception import BannerPerception

    cfg = parse_config(DEFAULT_SCENARIO, "follow")
    heard: list[Any] = []
    slots: list[tuple[int, float, str]] = []
    with standing_rover() as rover:
        rover.tap = lambda d, m, raw: heard.append(m) if d == "in" and m.get_srcComponent() == 191 else None
        companion = Companion.open(f"udpout:127.0.0.1:{rover.link.port}", 1)
        sock, gcs = _gcs_to(companion.port)

        def on_step(step: Any) -> None:
            slots.append((len(slots), step.settings.range_cmd_m, step.output.law))
            if len(slots) == 5:  # the companion's socket is bound once it has sent
                address = ("127.0.0.1", companion.port.connection.port.getsockname()[1])
                sock.sendto(mav.MAVLink_param_set_message(1, 191, b"LFC_RANGE", 2.5, 9).pack(gcs), address)
                sock.sendto(mav.MAVLink_param_set_message(1, 191, b"LFC_LAW", 2, 2).pack(gcs), address)

        try:
            with VideoSource(str(banner_video(60))) as video:
                perception = BannerPerception.from_config(cfg.camera, cfg.banner, (1.5, 0.0))
                settings = formation_settings(cfg, 1.5, 0.0, "smc", cfg.camera)
                done = follow_rover(companion, video, perception, settings, rate_hz=20.0, status_rate_hz=2.0,
                                    timeout_s=5.0, max_frames=40, on_step=on_step)  # fmt: skip
        finally:
            sock.close()
            companion.close()
    assert done.steps == 40 and done.tracking + done.occluded + done.lost == 40 and done.tracking > 0
    assert done.guided == 0  # not armed: the rover ignored every setpoint, and the summary says so
    assert done.summary().startswith(
        f"sent 40 setpoints (the rover in GUIDED, armed and with odometry for 0); 40 frames; target tracking in {done.tracking}, "
    )
    assert slots[0][1:] == (1.5, "smc")  # the settings' slot, as the companion's parameters say it
    moved = [k for k, r, law in slots if r == 2.5 and law in ("trail", "smc")]
    assert moved and moved[0] >= 5 and slots[-1][1] == 2.5  # taken on a later step, and kept
    assert any(law == "trail" for _, _, law in slots[moved[0] :])
    values = [m for m in heard if m.get_type() == "PARAM_VALUE"]
    assert [(m.param_id, m.param_value) for m in values] == [("LFC_RANGE", 2.5), ("LFC_LAW", 2.0)]
    assert any(m.get_type() == "HEARTBEAT" and m.type == mav.MAV_TYPE_ONBOARD_CONTROLLER for m in heard)


def test_odometry_that_stops_is_said_to_the_log_and_the_ground_station_and_so_is_its_return(
    banner_video, standing_rover, caplog: pytest.LogCaptureFixture
) -> None:
    from lfctl.config import parse_config
    from lfctl.follower.rover import follow_rover
    from lfctl.follower.stack import formation_settings
    from lfctl.video import VideoSource
    from lfctl.vision.perception import BannerPerception

    cfg = parse_config(DEFAULT_SCENARIO, "follow")
    texts: list[tuple[float, str]] = []
    stopped_at: list[float] = []
    with standing_rover() as rover:
        rover.tap = lambda d, m, raw: (
            texts.append((time.monotonic(), m.text)) if d == "in" and m.get_type() == "STATUSTEXT" else None
        )
        companion = Companion.open(f"udpout:127.0.0.1:{rover.link.port}", 1)
        sock, gcs = loopback_udp(), mav.MAVLink(None, srcSystem=255, srcComponent=190)

        def interval(us: float) -> None:  # a ground station's SET_MESSAGE_INTERVAL to the rover
            cmd = mav.MAVLink_command_long_message(
                1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED, us, 0, 0, 0, 0, 0
            )
            sock.sendto(cmd.pack(gcs), ("127.0.0.1", rover.link.port))

        def on_step(step: Any) -> None:
            if not stopped_at and step.t_s > 0.5:  # the rover stops sending its position
                stopped_at.append(time.monotonic())
                interval(-1)  # (the companion, finding it missing, asks for it again)

        try:
            with VideoSource(str(banner_video(100))) as video, caplog.at_level("INFO", "lfctl.follower.rover"):
                perception = BannerPerception.from_config(cfg.camera, cfg.banner, (1.5, 0.0))
                settings = formation_settings(cfg, 1.5, 0.0, "smc", cfg.camera)
                follow_rover(companion, video, perception, settings, rate_hz=20.0, status_rate_hz=2.0,
                             timeout_s=5.0, max_frames=90, on_step=on_step)  # fmt: skip
        finally:
            sock.close()
            companion.close()
    said = [(t, text) for t, text in texts if "odometry" in text]
    assert [text for _t, text in said] == ["rover: no odometry for 1 s", "rover: odometry back"]
    assert stopped_at[0] < said[0][0] < said[1][0]  # each after what it tells of
    logged = [
        r.getMessage() for r in caplog.records if r.name == "lfctl.follower.rover" and "odometry" in r.getMessage()
    ]
    # missing, the odometry is asked for again (a rover that rebooted sends only its own stream
    # rates: the start-up requests were never made again, and the follower steered on its last
    # position for the rest of the run), and comes back with no ground station's help
    assert logged == ["rover: no odometry (LOCAL_POSITION_NED) for 1 s: the stack steers on its last position",
                      "rover: asked the rover for its odometry again",
                      "rover: odometry (LOCAL_POSITION_NED) back"]  # fmt: skip
    # its return is said as loudly as its loss: without -v (warnings only) the loss stood unanswered
    levels = [r.levelno for r in caplog.records if r.name == "lfctl.follower.rover" and "odometry (" in r.getMessage()]
    assert levels == [logging.WARNING, logging.WARNING]


def test_odometry_is_missing_after_three_periods_at_a_slow_rate_and_each_line_fits_one_statustext() -> None:
    from types import SimpleNamespace

    from lfctl.follower.rover import _say_odometry

    said: list[tuple[str, int]] = []
    companion = SimpleNamespace(vehicle=SimpleNamespace(t_s=None), statustext=lambda t, sev=4: said.append((t, sev)))
    name = "a-follower-with-a-name-of-forty-letters"
    stale = False
    for t, last in ((0.5, None), (1.2, None), (1.5, 1.5), (3.4, 1.5), (4.6, 1.5), (5.0, 5.0)):
        companion.vehicle.t_s = last
        stale = _say_odometry(companion, name, t, 0.0, stale, 3.0)  # type: ignore[arg-type]  # 1 Hz: 3 s
    # none yet at 1.2 s is not missing at 1 Hz; 3.1 s after the last one is
    assert said == [("a-follower-with-a-na: no odometry for 3 s", mav.MAV_SEVERITY_WARNING),
                    ("a-follower-with-a-na: odometry back", mav.MAV_SEVERITY_INFO)]  # fmt: skip
    assert all(len(text.encode()) <= 50 for text, _sev in said)  # one STATUSTEXT each


def test_a_slot_the_companion_could_not_hold_as_a_parameter_is_refused_at_the_start() -> None:
    # LFC_RANGE is 0.1..1000 m: a value outside would be one a ground station could not set back
    from lfctl.link.params import formation_params, set_values

    params = formation_params()
    set_values(params, {"LFC_RANGE": 20.0, "LFC_LAW": 2.0}, "lfctl follow")
    assert (params["LFC_RANGE"].value, params["LFC_LAW"].value) == (20.0, 2.0)
    with pytest.raises(ConfigError, match=r"lfctl follow: LFC_RANGE would be 0\.05, outside its 0\.1\.\.1000 m"):
        set_values(params, {"LFC_RANGE": 0.05}, "lfctl follow")
    assert params["LFC_RANGE"].value == 20.0


def test_a_run_that_never_saw_its_target_says_so() -> None:
    from lfctl.follower.rover import RoverRun

    assert RoverRun(60, 60, 0, 60, 0, guided=55).summary() == (
        "sent 60 setpoints (the rover in GUIDED, armed and with odometry for 55); 60 frames; target tracking in 0, occluded"
        " in 60, lost in 0 steps (never seen: check the camera, the banner and its markers' hue)"
    )
    assert RoverRun(0, 0).summary() == "sent 0 setpoints; 0 frames"
    # a live camera faster than the steps: each step took its newest frame
    assert (
        RoverRun(20, 20, 20, skipped=10)
        .summary()
        .startswith(
            "sent 20 setpoints (the rover in GUIDED, armed and with odometry for 0); 20 frames (and 10 older ones passed over for the newest)"
        )
    )


@pytest.mark.parametrize(
    ("connect", "said"),
    [
        ("udpout:999.1.1.1:14550", "host '999.1.1.1' is not an address here"),
        ("udpout:127.0.0.1:0", "the address must be HOST:PORT with a port within 1..65535"),
        ("tcp:127.0.0.1:x", "the address must be HOST:PORT"),
        ("udpout:127.0.0.1:\u00b2", "the address must be HOST:PORT"),  # a digit to str.isdigit, not to int()
        ("nonsense", "no such serial device 'nonsense' here"),  # pymavlink: "No module named 'serial'"
        ("/dev/ttyNOPE0,57600", "no such serial device '/dev/ttyNOPE0' here (unplugged, or a typo?)"),
    ],
)
def test_a_mistyped_address_is_named_not_waited_on(connect: str, said: str) -> None:
    # pymavlink took udpout:999.1.1.1 and dropped every datagram: "no HEARTBEAT" after the timeout
    from lfctl.errors import LinkError

    with pytest.raises(LinkError, match=re.escape(said)):
        MavPort.open(connect, 255, 190)


@pytest.mark.parametrize(
    ("video", "refused"),
    [
        ("127.0.0.1:5600", True),
        ("localhost:5601", True),  # RTCP's port, bound on every address
        ("127.0.0.2:5601", True),
        ("127.0.0.1:5602", False),
        ("[::1]:5600", False),
        ("192.0.2.1:5601", False),  # (a documentation address: not this machine's)
    ],
)
def test_a_stream_sent_to_the_port_the_camera_reads_is_refused(
    video: str, refused: bool, capsys: pytest.CaptureFixture[str]
) -> None:
    # a rehearsal's `lfctl follow --camera rtp://127.0.0.1:5600 --video` (its default is 5600 too)
    # sent its annotated stream into its own input: the tracker saw two streams mixed
    from lfctl.cli.follow import _check_not_own_input
    from lfctl.config import parse_host_port

    to = parse_host_port(video, "--video")
    if refused:
        with pytest.raises(ConfigError, match=re.escape(f"--video {to[0]}:{to[1]} sends to what --camera")):
            _check_not_own_input(to, "rtp://127.0.0.1:5600")
    else:
        _check_not_own_input(to, "rtp://127.0.0.1:5600")
    _check_not_own_input(("127.0.0.1", 5600), "0")  # a camera, not a stream: nothing to mix
    _check_not_own_input(("127.0.0.1", 5600), "rtp://0.0.0.0:5610")
    with pytest.raises(ConfigError):  # read on every address: this machine's any is the same receiver
        _check_not_own_input(("127.0.0.1", 5610), "rtp://0.0.0.0:5610")


def test_a_companion_handler_that_fails_is_said_once_and_the_run_goes_on(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    companion = Companion(MavPort.open("udpin:127.0.0.1:0", 1, COMPANION_COMPID), 1)
    sock, gcs = _gcs_to(companion.port)

    def broken(m: Any, t_s: float) -> None:
        raise ValueError("a bug")

    monkeypatch.setattr(companion, "_take", broken)
    try:
        for _ in range(3):
            sock.sendto(
                mav.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(gcs), companion.port.connection.port.getsockname()
            )
        time.sleep(0.1)
        assert companion.poll(0.0, 1.0) == 3 and companion.handler_errors == 3
        assert caplog.text.count("handling HEARTBEAT from 255/190 failed") == 1
    finally:
        sock.close()
        companion.close()


def test_no_camera_component_without_video_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["follow", "--mavlink", "udpout:127.0.0.1:14999", "--camera", "0", "--no-camera-component"]
    assert main(args) == 2
    assert "--no-camera-component is for --video" in capsys.readouterr().err


# -- the rover's answers: awaited, sent again, refusals and mode changes said -----------------------
def _memory_rover(drop: int = 0) -> tuple[VehicleEndpoint, Companion, list[int]]:
    """A rover endpoint and its companion on an in-memory link, the rover ticking at each read;
    the rover ignores its first ``drop`` COMMAND_LONGs (lost on the way). Returns the rover,
    the companion and the confirmation field of each COMMAND_LONG the rover got."""
    a, b = MemoryLink.pair("rover", "companion")
    rover = VehicleEndpoint("rover", 1, a, HOME)
    still = {"north_m": 0.0, "east_m": 0.0, "yaw_rad": 0.0, "speed_mps": 0.0, "yaw_rate_radps": 0.0}
    t0 = time.monotonic()
    companion = Companion(MavPort.memory(b, 1, COMPANION_COMPID, lambda: rover.tick(time.monotonic() - t0, still)), 1)
    got: list[int] = []
    carry_out = rover._on_command_long

    def lossy(m: Any) -> None:
        got.append(m.confirmation)
        if len(got) > drop:
            carry_out(m)

    rover._on_command_long = lossy  # type: ignore[method-assign]
    return rover, companion, got


def test_a_command_lost_on_the_way_is_sent_again_and_its_answer_returned() -> None:
    rover, companion, got = _memory_rover(drop=2)
    result = companion.request(mav.MAV_CMD_DO_SET_MODE, 1, MODES["GUIDED"], try_s=0.2)
    assert result == mav.MAV_RESULT_ACCEPTED and rover.mode == MODES["GUIDED"]
    assert got == [0, 1, 2]  # MAVLink's command protocol: the confirmation counts the tries
    rover, companion, got = _memory_rover(drop=5)
    assert companion.request(mav.MAV_CMD_DO_SET_MODE, 1, MODES["GUIDED"], try_s=0.05, tries=3) is None
    assert got == [0, 1, 2] and rover.mode != MODES["GUIDED"]


def test_a_companion_that_stalls_still_sends_every_try(monkeypatch: pytest.MonkeyPatch) -> None:
    # a loaded companion computer (here a 0.4 s stall in its first read, longer than the
    # three tries' 0.15 s): the deadline passed and the tries left were never sent (seen in CI)
    rover, companion, got = _memory_rover(drop=2)
    recv = companion.port.recv
    stalled: list[bool] = []

    def slow(timeout: float) -> Any:
        if not stalled:
            stalled.append(True)
            time.sleep(0.4)
        return recv(timeout)

    monkeypatch.setattr(companion.port, "recv", slow)
    assert (
        companion.request(mav.MAV_CMD_DO_SET_MODE, 1, MODES["GUIDED"], try_s=0.05, tries=3) == mav.MAV_RESULT_ACCEPTED
    )
    assert got == [0, 1, 2] and rover.mode == MODES["GUIDED"]


def test_a_refused_stream_request_is_said_with_the_parameter_to_set(caplog: pytest.LogCaptureFixture) -> None:
    rover, companion, _got = _memory_rover()
    rover._set_interval = lambda *p: mav.MAV_RESULT_DENIED  # type: ignore[method-assign]
    answers = companion.wait_vehicle(2.0, 20.0)
    assert set(answers.values()) == {mav.MAV_RESULT_DENIED}
    said = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert any("refused ATTITUDE at 20 Hz (MAV_RESULT_DENIED)" in t and "SRn_EXTRA1" in t for t in said)
    assert any("refused LOCAL_POSITION_NED" in t and "SRn_POSITION" in t for t in said)


def test_odometry_asked_faster_than_a_rover_sends_is_asked_for_at_40_hz(caplog: pytest.LogCaptureFixture) -> None:
    # ArduPilot 4.6 at a Rover's default SCHED_LOOP_RATE (50 Hz) refuses an interval under
    # 25 ms (no message faster than 0.8 x 50 = 40 Hz): 50 Hz asked is DENIED, asked again at
    # 40 Hz it is taken: every odometry message then comes each 25 ms, and is asked again at
    # that rate (after a reboot, or when it slows), not refused again
    rover, companion, _got = _memory_rover()
    with caplog.at_level("INFO", "lfctl.link.companion"):
        answers = companion.wait_vehicle(2.0, 50.0)
    assert set(answers.values()) == {mav.MAV_RESULT_ACCEPTED}
    assert companion.stream_hz == dict.fromkeys(ODOMETRY_MSG_IDS, 40.0)
    assert all(rover._rates.intervals[i] == 0.025 for i in ODOMETRY_MSG_IDS)
    said = [r.getMessage() for r in caplog.records]
    assert any("refused LOCAL_POSITION_NED at 50 Hz" in t and "SCHED_LOOP_RATE" in t for t in said), said
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    refusals = len([t for _, t in rover.statustexts if "too fast" in t])
    assert refusals == 3
    companion.ask_streams_again(50.0)
    companion.poll(0.0, 0.2)
    assert len([t for _, t in rover.statustexts if "too fast" in t]) == refusals


def test_the_rovers_parameters_are_read_by_name() -> None:
    rover, companion, _got = _memory_rover()
    rover.params["WP_SPEED"].value = 1.25
    assert companion.read_param("WP_SPEED", try_s=0.3) == 1.25
    # a name the autopilot does not have: no answer (Rover sends none), None after the tries
    assert companion.read_param("NO_SUCH_PARAM", try_s=0.05, tries=2) is None


@pytest.mark.parametrize(("wp_speed", "warned"), [(0.3, True), (0.5, False), (2.0, False)])
def test_a_rover_slower_than_the_follower_may_drive_is_said(
    caplog: pytest.LogCaptureFixture, wp_speed: float, warned: bool
) -> None:
    # Rover's handle_set_position_target_local_ned holds a GUIDED speed to WP_SPEED: a follower
    # whose top speed (0.5 m/s, the default) is above it would fall behind without a word
    rover, companion, _got = _memory_rover()
    rover.params["WP_SPEED"].value = wp_speed
    settings = FormationSettings()
    assert settings.range.max_speed_mps == 0.5
    with caplog.at_level("INFO", "lfctl.follower.rover"):
        _check_speed_limit(companion, "rover", settings)
    said = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert bool(said) == warned, said
    if warned:
        assert "WP_SPEED, 0.3 m/s, under the follower's 0.5 m/s" in said[0]


@pytest.mark.parametrize(
    ("baud", "rate_hz", "passphrase", "said"),
    [
        (57600, 20.0, None, ""),  # the defaults on a 57600 telemetry port: 1462 and 2400 bytes/s of 5760
        (57600, 20.0, "convoy-7", ""),
        (57600, 100.0, None, "the setpoints at 100 Hz need 6680 and the odometry asked for at 40 Hz 4800:"),
        (57600, 40.0, "convoy-7", "the setpoints at 40 Hz need 3378 and the odometry asked for at 40 Hz 6360, signed:"),
        (921600, 100.0, "convoy-7", ""),
    ],
)
def test_a_serial_port_too_slow_for_the_setpoints_or_the_odometry_is_said(
    caplog: pytest.LogCaptureFixture, baud: int, rate_hz: float, passphrase: str | None, said: str
) -> None:
    # a UART carries baud / 10 bytes a second each way: at 57600 the setpoints at 100 Hz
    # queued in the port's buffer and reached the rover up to 0.8 s late, without a word
    import os
    import pty

    from lfctl.follower.rover import _check_link_budget
    from lfctl.link.signing import signing_key_from_passphrase

    parent, child = pty.openpty()
    companion = Companion.open(f"{os.ttyname(child)},{baud}", 1, signing_key_from_passphrase(passphrase))
    try:
        with caplog.at_level("WARNING", "lfctl.follower.rover"):
            _check_link_budget(companion, "rover", rate_hz, 2.0)
    finally:
        companion.close()
        os.close(parent)
        os.close(child)
    warned = [r.getMessage() for r in caplog.records]
    assert len(warned) == bool(said) and all(f"at {baud} baud the serial port carries" in w for w in warned)
    assert all(said in w for w in warned), warned
    # each consequence said where it holds: the signed odometry alone is over (its setpoints fit)
    late = "setpoints that do not fit queue and reach the rover late"
    assert all((late in w) == (rate_hz == 100.0) and "the rover sends the odometry slower" in w for w in warned)
    # over a network there is no baud to check
    assert not rover_module._check_link_budget(_memory_rover()[1], "rover", 100.0, 2.0)


def test_odometry_the_rover_took_faster_than_its_default_loop_is_counted_in_the_serial_budget(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # a Rover with SCHED_LOOP_RATE raised takes the odometry at --rate 100: 12000 bytes/s over
    # a 115200 baud port's 11520, counted as 40 Hz (4800) and not said
    import os
    import pty

    from lfctl.follower.rover import _check_link_budget
    from lfctl.link.companion import ODOMETRY_MSG_IDS

    parent, child = pty.openpty()
    companion = Companion.open(f"{os.ttyname(child)},115200", 1, None)
    companion.stream_hz.update(dict.fromkeys(ODOMETRY_MSG_IDS, 100.0))  # (what wait_vehicle keeps)
    try:
        with caplog.at_level("WARNING", "lfctl.follower.rover"):
            _check_link_budget(companion, "rover", 100.0, 2.0)
    finally:
        companion.close()
        os.close(parent)
        os.close(child)
    warned = [r.getMessage() for r in caplog.records]
    assert len(warned) == 1 and "the odometry asked for at 100 Hz 12000" in warned[0], warned


def test_the_last_setpoints_are_spread_out_so_a_lost_burst_does_not_leave_the_rover_driving(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    sent: list[tuple[float, float, float]] = []
    slept: list[float] = []
    monkeypatch.setattr(rover_module.time, "sleep", slept.append)
    companion = SimpleNamespace(setpoint=lambda t, v, w: sent.append((t, v, w)))
    rover_module._leave_standing(companion, 10.0)  # type: ignore[arg-type]
    assert sent == [(10.0, 0.0, 0.0), (10.15, 0.0, 0.0), (10.3, 0.0, 0.0)]
    assert slept == [0.15, 0.15]


def test_a_rover_that_will_not_arm_is_said_with_its_reason_and_the_run_goes_on(
    banner_video, standing_rover, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    # Rover's pre-arm check: WP_SPEED 0 fails it ("Arm: WP_SPEED too low", MAV_RESULT_FAILED)
    with standing_rover() as rover:
        rover.params["WP_SPEED"].value = 0.0
        rc = main(["follow", "--mavlink", f"udpout:127.0.0.1:{rover.link.port}", "--camera",
                   str(banner_video(20)), "--arm", "--max-frames", "10", "--timeout", "5"])  # fmt: skip
        assert not rover.armed
    said = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert rc == 0 and any(
        "the rover refused to arm (MAV_RESULT_FAILED; it said: Arm: WP_SPEED too low)" in t for t in said
    ), said
    assert "sent 10 setpoints (the rover in GUIDED, armed and with odometry for 0)" in capsys.readouterr().out


def test_a_shipped_clip_is_taken_by_name_as_lfctl_track_takes_it(
    standing_rover, capsys: pytest.CaptureFixture[str]
) -> None:
    # a wheel's user has no footage/ folder: `--camera bikes.mp4` said "does not exist"
    with standing_rover() as rover:
        rc = main(["follow", "--mavlink", f"udpout:127.0.0.1:{rover.link.port}", "--camera", "bikes.mp4",
                   "--max-frames", "3", "--timeout", "5"])  # fmt: skip
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert "bikes.mp4" in out.err + out.out and "sent 3 setpoints" in out.out


def _follow(rover: VehicleEndpoint, video_path: Any, on_step: Any, max_frames: int | None = None) -> Any:
    """`follow_rover` with the default scenario's follower on ``rover`` (armed, 20 Hz), from
    the video at ``video_path``; each step to ``on_step``."""
    from lfctl.config import parse_config
    from lfctl.follower.rover import follow_rover
    from lfctl.follower.stack import formation_settings
    from lfctl.video import VideoSource
    from lfctl.vision.perception import BannerPerception

    cfg = parse_config(DEFAULT_SCENARIO, "follow")
    companion = Companion.open(f"udpout:127.0.0.1:{rover.link.port}", 1)
    try:
        with VideoSource(str(video_path)) as video:
            perception = BannerPerception.from_config(cfg.camera, cfg.banner, (1.5, 0.0))
            settings = formation_settings(cfg, 1.5, 0.0, "smc", cfg.camera)
            return follow_rover(companion, video, perception, settings, rate_hz=20.0, status_rate_hz=2.0,
                                arm=True, timeout_s=5.0, max_frames=max_frames, on_step=on_step)  # fmt: skip
    finally:
        companion.close()


def test_a_pilot_taking_the_rover_out_of_guided_is_said_and_not_fought(
    banner_video, standing_rover, caplog: pytest.LogCaptureFixture
) -> None:
    modes: list[int] = []
    with standing_rover() as rover:

        def on_step(step: Any) -> None:
            modes.append(rover.mode)
            if len(modes) == 10:  # the pilot's mode switch: MANUAL
                rover.set_mode(MODES["MANUAL"])
            elif len(modes) == 35:  # and the disarm switch
                rover.set_armed(False)

        done = _follow(rover, banner_video(60), on_step, max_frames=50)
    assert modes[0] == MODES["GUIDED"] and modes[-1] == MODES["MANUAL"]  # never taken back
    assert 9 <= done.guided < 50  # GUIDED and armed until the switch reached it (a heartbeat a second)
    said = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert any("the rover is in MANUAL, not GUIDED: it ignores the setpoints" in t for t in said), said
    assert said[-1] == "rover: the rover is disarmed: it does not move until it is armed again"


class _ScriptedRover:
    """A port whose rover floods the link with HEARTBEATs and answers each COMMAND_LONG as
    ``answer(sends, t)`` says (None: not at all): the companion's side of it."""

    def __init__(self, answer) -> None:
        self.sysid, self.sent, self.answer, self.t0 = 1, [], answer, time.monotonic()
        self.codec = mav.MAVLink(None, srcSystem=1, srcComponent=1)

    def send(self, msg: Any) -> None:
        if msg.get_type() == "COMMAND_LONG":
            self.sent.append(msg.confirmation)

    def echo(self, m: Any) -> bool:  # (nothing comes back: see MavPort.echo)
        return False

    def recv(self, timeout_s: float = 0.0) -> Any:
        t = time.monotonic() - self.t0
        result = self.answer(len(self.sent), t) if self.sent else None
        if result is not None:
            msg = mav.MAVLink_command_ack_message(mav.MAV_CMD_DO_SET_MODE, result, 0, 0, 1, COMPANION_COMPID)
        else:
            msg = mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GROUND_ROVER, 3, 0, 0, 4, 3)
        return self.codec.decode(bytearray(msg.pack(self.codec)))


def test_a_request_ends_at_its_deadline_on_a_link_that_never_stops_talking() -> None:
    # it hung before, reading on for as long as messages came (pytest-timeout fails a hang)
    port = _ScriptedRover(lambda sends, t: None)
    assert Companion(port, 1).request(mav.MAV_CMD_DO_SET_MODE, 1, 15, try_s=0.1, tries=3) is None  # type: ignore[arg-type]
    assert port.sent == [0, 1, 2]  # three tries, then done


def test_a_request_in_progress_is_not_sent_again_and_waits_for_its_final_answer() -> None:
    # IN_PROGRESS every message for 0.5 s (beyond a try's 0.1 s), then ACCEPTED
    port = _ScriptedRover(lambda sends, t: mav.MAV_RESULT_IN_PROGRESS if t < 0.5 else mav.MAV_RESULT_ACCEPTED)
    assert Companion(port, 1).request(mav.MAV_CMD_DO_SET_MODE, 1, 15, try_s=0.1, tries=3) == mav.MAV_RESULT_ACCEPTED  # type: ignore[arg-type]
    assert port.sent == [0]


def test_a_rover_that_does_not_answer_is_said_and_the_run_goes_on(caplog: pytest.LogCaptureFixture) -> None:
    from lfctl.follower.rover import _ask

    companion = Companion(_ScriptedRover(lambda sends, t: None), 1)  # type: ignore[arg-type]
    companion.request = lambda cmd, *p: None  # type: ignore[method-assign]  (three silent tries)
    assert not _ask(companion, "f1", "arm", mav.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)
    assert not _ask(companion, "f1", "GUIDED", mav.MAV_CMD_DO_SET_MODE, 1, 15)
    said = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert said[0].startswith("f1: the rover did not answer the request to arm (no answer to 3 tries): it ignores")
    assert said[1].startswith("f1: the rover did not answer the request for GUIDED (no answer to 3 tries)")


@pytest.mark.parametrize(
    "connect", ["127.0.0.1:14550", "mcast:", "uds:/tmp/x.sock", "wsserver:127.0.0.1:1", r"\\.\COM10", "COM3"]
)
def test_every_other_form_pymavlink_opens_is_left_to_it(connect: str) -> None:
    from lfctl.link.port import _check_serial_device

    _check_serial_device(connect)  # no LinkError: pymavlink's own forms, not a missing serial device


def test_a_rover_that_refuses_guided_is_not_armed(
    banner_video, standing_rover, caplog: pytest.LogCaptureFixture
) -> None:
    # armed in the mode it is in (AUTO, RTL) a rover would drive off on its own: --arm waits for GUIDED
    with standing_rover() as rover:
        keep = rover.set_mode

        def no_guided(custom_mode: int) -> bool:  # as Rover armed without a position estimate
            return rover._refuse_mode(None) if custom_mode == MODES["GUIDED"] else keep(custom_mode)

        rover.set_mode = no_guided
        rc = main(["follow", "--mavlink", f"udpout:127.0.0.1:{rover.link.port}", "--camera",
                   str(banner_video(20)), "--arm", "--max-frames", "10", "--timeout", "5"])  # fmt: skip
        assert rc == 0 and not rover.armed and rover.mode == MODES["HOLD"]
    said = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert any("refused GUIDED (MAV_RESULT_FAILED; it said: Flight mode change failed)" in t for t in said), said
    assert "rover: not arming the rover: it is not in GUIDED (arm it yourself once it is)" in said


def test_a_rover_gone_silent_is_said_its_setpoints_not_counted_and_ctrl_c_keeps_the_figures(
    banner_video, standing_rover, caplog: pytest.LogCaptureFixture
) -> None:
    # the rover's HEARTBEAT stops at step 10: the closing line counted every setpoint as
    # carried out on its last word, however old; and Ctrl-C lost the closing line
    from lfctl.follower.rover import HEARTBEAT_STALE_S
    from lfctl.link.endpoint import MSG_IDS

    steps: list[float] = []
    with standing_rover() as rover:

        def on_step(step: Any) -> None:
            steps.append(step.t_s)
            if len(steps) == 10:
                rover._rates.intervals[MSG_IDS["HEARTBEAT"]] = math.inf  # silent from here
            if len(steps) > 10 and step.t_s - steps[9] > HEARTBEAT_STALE_S + 3.0:
                raise KeyboardInterrupt  # the user's Ctrl-C

        done = _follow(rover, banner_video(200), on_step)
    assert done.interrupted and done.summary().endswith("; interrupted") and done.steps == len(steps)
    # carried out while its heartbeat was fresh (10 steps, its last heartbeat up to 1 s later,
    # then HEARTBEAT_STALE_S more at 20 Hz), not in the seconds after
    assert 10 <= done.guided <= 10 + (1.0 + HEARTBEAT_STALE_S) * 20 + 5 and done.steps - done.guided >= 30
    said = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert any("no HEARTBEAT from the rover (system 1) for 3 s" in t for t in said), said


def test_a_slot_the_camera_cannot_see_from_is_said_at_the_start(
    banner_video, standing_rover, caplog: pytest.LogCaptureFixture
) -> None:
    # a 40 deg slot with the default 62 deg lens: the banner is out of the picture there
    with standing_rover() as rover:
        rc = main(["follow", "--mavlink", f"udpout:127.0.0.1:{rover.link.port}", "--camera",
                   str(banner_video(5)), "--bearing", "40", "--max-frames", "3", "--timeout", "5"])  # fmt: skip
    said = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert rc == 0 and any(t.startswith("the slot (1.5 m, 40 deg) leaves the target's banner out of") for t in said)


class _SlowRover:
    """A port whose rover answers a read after ``delay_s`` with two HEARTBEATs, then is quiet."""

    def __init__(self, delay_s: float) -> None:
        self.sysid, self.delay_s, self.queue = 1, delay_s, []
        self.codec = mav.MAVLink(None, srcSystem=1, srcComponent=1)
        self.ftp = None

    def send(self, msg: Any) -> None:
        pass

    def echo(self, m: Any) -> bool:
        return False

    def recv(self, timeout_s: float = 0.0) -> Any:
        if not self.queue and timeout_s >= self.delay_s:
            time.sleep(self.delay_s)
            beat = mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GROUND_ROVER, 3, 0, 0, 4, 3)
            self.queue = [self.codec.decode(bytearray(beat.pack(self.codec))) for _ in range(2)]
        return self.queue.pop(0) if self.queue else None


def test_a_slow_first_answer_is_not_taken_for_a_flood() -> None:
    # the read's 50 ms budget began before the wait for the first message: a rover answering
    # 100 ms late with two packets was said to flood the link, in most runs of lfctl follow
    companion = Companion(_SlowRover(0.1), 1)  # type: ignore[arg-type]
    assert companion.poll(0.0, 0.2) == 2
    assert companion.overloaded == 0


def test_a_wrong_target_is_told_the_system_that_talks_on_the_link() -> None:
    from lfctl.errors import LinkTimeoutError

    companion = Companion(_ScriptedRover(lambda sends, t: None), 2)  # type: ignore[arg-type]
    with pytest.raises(LinkTimeoutError, match=r"system 1's autopilot talks on this link: --target 1\?"):
        companion.wait_vehicle(0.3, 20.0)


def test_another_companion_of_the_rover_on_the_link_is_said(caplog: pytest.LogCaptureFixture) -> None:
    # a simulated follower's own companion (2/191) and lfctl follow took turns commanding it
    from lfctl.follower.rover import _LinkWatch

    companion = Companion(_ScriptedRover(lambda sends, t: None), 1)  # type: ignore[arg-type]
    other = mav.MAVLink(None, srcSystem=1, srcComponent=COMPANION_COMPID)
    text = mav.MAVLink_statustext_message(mav.MAV_SEVERITY_INFO, b"follower1: leader reacquired")
    companion._take(other.decode(bytearray(text.pack(other))), 0.0)
    assert companion.other_companion
    companion.port.junk = 0  # type: ignore[attr-defined]
    watch = _LinkWatch(companion, "rover")
    watch.check(0.0)
    watch.check(0.1)
    said = [r.getMessage() for r in caplog.records if "another companion" in r.getMessage()]
    assert len(said) == 1 and said[0].startswith("rover: another companion (system 1, component 191) talks")


def test_the_rovers_heartbeat_coming_back_is_said_as_loudly_as_its_loss(caplog: pytest.LogCaptureFixture) -> None:
    # without -v (warnings only) the loss was said and its end never
    from lfctl.follower.rover import HEARTBEAT_STALE_S, _LinkWatch

    companion = Companion(_ScriptedRover(lambda sends, t: None), 1)  # type: ignore[arg-type]
    companion.port.junk = 0  # type: ignore[attr-defined]
    watch = _LinkWatch(companion, "rover")
    companion.vehicle.heartbeat_t_s = 0.0
    assert watch.check(0.0)
    assert not watch.check(HEARTBEAT_STALE_S + 1.0)  # lost
    companion.vehicle.heartbeat_t_s = HEARTBEAT_STALE_S + 2.0
    assert watch.check(HEARTBEAT_STALE_S + 2.0) and watch.came_back  # back
    said = [(r.levelno, r.getMessage()) for r in caplog.records if "HEARTBEAT" in r.getMessage()]
    assert [level for level, _text in said] == [logging.WARNING, logging.WARNING], said
    assert said[1][1] == "rover: the rover's HEARTBEAT is back"


# -- a review against ArduPilot Rover's source: what a real rover needs ---------------------------
@pytest.mark.parametrize(
    ("mav_type", "autopilot", "taken"),
    [
        (mav.MAV_TYPE_GROUND_ROVER, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, True),
        (mav.MAV_TYPE_SURFACE_BOAT, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, True),  # Rover's boat frame
        (mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, False),  # its mode 15 is AUTOTUNE
        (mav.MAV_TYPE_GROUND_ROVER, mav.MAV_AUTOPILOT_PX4, False),  # its custom mode is laid out otherwise
    ],
)
def test_the_companion_commands_only_an_ardupilot_rover(mav_type: int, autopilot: int, taken: bool) -> None:
    from lfctl.errors import VehicleKindError

    a, b = MemoryLink.pair("vehicle", "companion")
    vehicle = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    beat = mav.MAVLink_heartbeat_message(mav_type, autopilot, 0, 0, mav.MAV_STATE_STANDBY, 3)
    sent: list[object] = []

    def pump() -> None:  # the vehicle beats, and records what reaches it
        a.send(beat.pack(vehicle))
        sent.extend(data for data, _addr in a.recv(100))

    companion = Companion(MavPort.memory(b, 1, COMPANION_COMPID, pump), 1)
    if taken:
        companion.wait_vehicle(0.3, 20.0)  # (the streams asked for, no answer: said, and on)
        return
    with pytest.raises(VehicleKindError, match=r"system 1 is MAV_TYPE_\w+ / MAV_AUTOPILOT_\w+, not an ArduPilot Rover"):
        companion.wait_vehicle(1.0, 20.0)
    parser = mav.MAVLink(None)
    kinds = {m.get_type() for data in sent for m in (parser.parse_buffer(data) or [])}
    assert "COMMAND_LONG" not in kinds  # nothing asked of it: no stream, no mode


def test_the_rovers_speed_is_signed_along_its_heading_and_its_own_components_are_not_other_autopilots() -> None:
    a, b = MemoryLink.pair("rover", "companion")
    rover = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    gimbal = mav.MAVLink(None, srcSystem=1, srcComponent=154)  # ArduPilot forwards its HEARTBEAT
    companion = Companion(MavPort.memory(b, 1, COMPANION_COMPID), 1)
    yaw = math.radians(30.0)
    for m, codec in (
        (mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GIMBAL, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 4, 3), gimbal),
        (mav.MAVLink_attitude_message(1000, 0.0, 0.0, yaw, 0.0, 0.0, 0.0), rover),
        # backing up at 0.15 m/s: the ground velocity points opposite the heading
        (mav.MAVLink_local_position_ned_message(1000, 1.0, 2.0, 0.0, -0.15 * math.cos(yaw), -0.15 * math.sin(yaw), 0.0), rover),
    ):  # fmt: skip
        a.send(m.pack(codec))
    companion.poll(1.0)
    assert companion.vehicle.speed_mps == pytest.approx(-0.15, abs=1e-6)  # (its size was taken: +0.15)
    assert companion.other_autopilots == set()
    a.send(
        mav.MAVLink_local_position_ned_message(1100, 1.0, 2.0, 0.0, 0.2 * math.cos(yaw), 0.2 * math.sin(yaw), 0.0).pack(
            rover
        )
    )
    companion.poll(1.1)
    assert companion.vehicle.speed_mps == pytest.approx(0.2, abs=1e-6)


def test_a_rover_that_sends_no_local_position_is_said_to_need_an_ekf_origin_and_its_setpoints_not_counted(
    banner_video, standing_rover, caplog: pytest.LogCaptureFixture
) -> None:
    # Rover without a position estimate and EKF origin sends no LOCAL_POSITION_NED
    # (GCS_MAVLINK::send_local_position) and drops every SET_POSITION_TARGET_LOCAL_NED
    # (handle_set_position_target_local_ned: "need ekf origin"): the rover here takes the
    # request for it and sends none
    with standing_rover() as rover, caplog.at_level("INFO", "lfctl.follower.rover"):
        send = rover.send
        rover.send = lambda msg: None if msg.get_type() == "LOCAL_POSITION_NED" else send(msg)
        run = _follow(rover, banner_video(60), None, max_frames=40)
    assert run.steps == 40 and run.guided == 0  # in GUIDED and armed, but nothing taken
    said = [r.getMessage() for r in caplog.records if "odometry" in r.getMessage()]
    assert any("no odometry (LOCAL_POSITION_NED) in the first 1 s" in s and "EKF origin" in s for s in said), said


def _follow_while_a_gcs_sends(
    banner_video: Any, standing_rover: Any, caplog: pytest.LogCaptureFixture, msg: Any, after_s: float
) -> tuple[list[str], float | None, Any]:
    """lfctl follow on a standing rover for 180 frames (9 s), a ground station on the rover's
    link sending it ``msg`` once ``after_s`` in: follow's log lines, the rover's
    LOCAL_POSITION_NED period at the end, and the rover."""
    sock, gcs = loopback_udp(), mav.MAVLink(None, srcSystem=255, srcComponent=190)
    sent: list[float] = []

    def on_step(step: Any) -> None:
        if not sent and step.t_s > after_s:
            sent.append(step.t_s)
            sock.sendto(msg.pack(gcs), ("127.0.0.1", rover.link.port))

    try:
        with standing_rover() as rover, caplog.at_level("INFO", "lfctl.follower.rover"):
            _follow(rover, banner_video(200), on_step, max_frames=180)
            period = rover._rates.intervals.get(mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED)
    finally:
        sock.close()
    return [r.getMessage() for r in caplog.records if r.name == "lfctl.follower.rover"], period, rover


def test_odometry_slowed_by_a_ground_stations_stream_request_is_asked_for_again(
    banner_video, standing_rover, caplog: pytest.LogCaptureFixture
) -> None:
    # a ground station on the rover's link sends REQUEST_DATA_STREAM (QGroundControl, Mission
    # Planner and MAVProxy do as they connect): ArduPilot resets the stream's messages to its
    # rate, LOCAL_POSITION_NED among them; never stale at 1 Hz, the odometry lagged for good
    req = mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_POSITION, 1, 1)
    said, period, _rover = _follow_while_a_gcs_sends(banner_video, standing_rover, caplog, req, 0.3)
    slow = [s for s in said if "LOCAL_POSITION_NED at" in s]
    assert slow and "not the 20 Hz asked for: asked again" in slow[0] and "SERIALn_OPTIONS bit 12" in slow[0], slow
    assert period == pytest.approx(0.05)  # 20 Hz again


def test_a_rover_that_rebooted_is_asked_again_and_no_ground_station_is_blamed(
    banner_video, standing_rover, caplog: pytest.LogCaptureFixture
) -> None:
    # the reboot's 2 s of silence fell inside the odometry's rate window, and the restarted
    # rover's default 10 Hz was asked up to 20 Hz only at the window's end, said to be a
    # ground station's REQUEST_DATA_STREAM: a restart (its clock going back) is asked again at once
    force = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0, 1, 0, 0, 0, 0, 20190226, 0)
    said, period, rover = _follow_while_a_gcs_sends(banner_video, standing_rover, caplog, force, 0.5)
    assert rover._boot_t_s > 0 and any("the rover restarted (its clock began again): asked for" in s for s in said), (
        said
    )
    assert not [s for s in said if "LOCAL_POSITION_NED at" in s], said
    assert period == pytest.approx(0.05)  # 20 Hz again after the restart


# -- a simulated follower with no companion: lfctl follow is its companion -------------------------
@pytest.mark.integration
def test_lfctl_follow_is_the_companion_of_a_simulated_follower_that_has_none(
    background_run, free_udp_ports, capsys: pytest.CaptureFixture[str]
) -> None:
    # the whole real-rover set-up on one machine: the simulated follower waits in HOLD,
    # disarmed, on its UDP port; its camera streams as RTP/UDP H.264 (unannotated, as a
    # camera sends); lfctl follow reads the stream by its port and commands the follower
    import dataclasses

    from lfctl.data import examples_dir

    cfg = parse_config((examples_dir() / "convoy.toml").read_text(), "convoy")
    follower = dataclasses.replace(cfg.vehicles[1], companion=False)
    base, video = free_udp_ports(2), free_udp_ports(2)  # (the stream's port and its RTCP's)
    ground = loopback_udp()  # a ground station that talks to the follower's port
    rtp_out = loopback_udp()  # where lfctl follow's own stream goes (never read)
    rtp_port = rtp_out.getsockname()[1]
    cfg = dataclasses.replace(
        cfg,
        vehicles=(cfg.vehicles[0], follower),
        sim=dataclasses.replace(cfg.sim, duration_s=60.0),
        link=dataclasses.replace(cfg.link, udp_base_port=base, gcs_udpout=""),  # (it sends to the port itself)
    )
    links: list[Any] = []
    seen: dict[str, Any] = {}
    stop = threading.Event()

    def ground_station() -> None:
        # QGroundControl on the follower's port: hears the camera lfctl follow announces
        # through the simulator's routing, asks it for its stream and the companion for LFC_RANGE
        gcs, parser = mav.MAVLink(None, srcSystem=255, srcComponent=190), mav.MAVLink(None)
        to = ("127.0.0.1", base + 1)
        ground.settimeout(0.05)
        asked = 0.0
        while not stop.is_set() and len(seen) < 3:
            if time.monotonic() - asked > 0.5:
                asked = time.monotonic()
                ground.sendto(mav.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(gcs), to)
                if "camera" in seen:
                    info = mav.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION
                    ask = mav.MAVLink_command_long_message(
                        2, 100, mav.MAV_CMD_REQUEST_MESSAGE, 0, info, 0, 0, 0, 0, 0, 0
                    )
                    ground.sendto(ask.pack(gcs), to)
                    ground.sendto(mav.MAVLink_param_request_read_message(2, 191, b"LFC_RANGE", -1).pack(gcs), to)
            try:
                data = ground.recv(65535)
            except TimeoutError:
                continue
            for m in parser.parse_buffer(data) or []:
                src = (m.get_srcSystem(), m.get_srcComponent())
                if src == (2, 100) and m.get_type() == "HEARTBEAT":
                    seen["camera"] = m
                elif src == (2, 100) and m.get_type() == "VIDEO_STREAM_INFORMATION":
                    seen["stream"] = m
                elif m.get_type() == "PARAM_VALUE" and m.param_id == "LFC_RANGE" and src[0] == 2:
                    seen.setdefault("lfc_range", []).append((src, round(m.param_value, 3)))

    try:
        with background_run(cfg, realtime=True, video=("127.0.0.1", video), on_links=links.append) as errors:
            assert wait_until(lambda: bool(links), timeout_s=60.0), errors
            ep = links[0].endpoints[1]
            assert ep.mode == MODES["HOLD"] and not ep.armed  # no companion took it: as a Rover stands
            station = threading.Thread(target=ground_station, daemon=True)
            station.start()
            rc = main(["follow", "--mavlink", f"udpout:127.0.0.1:{base + 1}", "--target", "2", "--camera",
                       f"rtp://127.0.0.1:{video}", "--arm", "--max-frames", "100", "--timeout", "10", "--range", "1.7",
                       "--video", f"127.0.0.1:{rtp_port}"])  # fmt: skip
            took = (ep.mode, ep.armed)
            stop.set()
            assert "LFC_RANGE" not in ep.params  # the companion's alone: a Rover has none
            station.join(5.0)
    finally:
        ground.close()
        rtp_out.close()
    assert not errors, errors
    assert rc == 0 and took == (MODES["GUIDED"], True)
    out = capsys.readouterr().out
    tracking = int(re.search(r"target tracking in (\d+)", out).group(1))  # type: ignore[union-attr]
    assert tracking >= 60, out  # the leader 1.5 m ahead, seen through the stream
    # through the simulator as through a Rover: the camera's stream, and the companion's own
    # LFC_RANGE (lfctl follow's 1.7), not the simulated autopilot's
    assert seen["camera"].type == mav.MAV_TYPE_CAMERA, seen
    assert seen["stream"].uri == str(rtp_port), seen
    assert seen["lfc_range"] and {v for _src, v in seen["lfc_range"]} == {1.7}, seen["lfc_range"]
    assert {src for src, _v in seen["lfc_range"]} == {(2, COMPANION_COMPID)}


def test_a_follower_without_a_companion_needs_realtime_and_a_leader_has_none_to_leave_out() -> None:
    import dataclasses

    from lfctl.data import examples_dir
    from lfctl.sim.runner import run_scenario

    cfg = parse_config((examples_dir() / "convoy.toml").read_text(), "convoy")
    alone = dataclasses.replace(cfg, vehicles=(cfg.vehicles[0], dataclasses.replace(cfg.vehicles[1], companion=False)))
    with pytest.raises(ConfigError, match=r"vehicles\[follower1\]\.companion = false needs --realtime"):
        run_scenario(alone, realtime=False)
    text = (
        (examples_dir() / "convoy.toml")
        .read_text()
        .replace('role = "leader"\n', 'role = "leader"\ncompanion = false\n', 1)
    )
    with pytest.raises(ConfigError, match=r"vehicles\[leader\]\.companion: a leader has no companion computer"):
        parse_config(text, "convoy")


def test_follower_names_which_of_the_scenarios_followers_the_rover_is(
    banner_video, standing_rover, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    # its slot, its target's banner and its name are the named follower's (lfctl follow ran
    # the first follower's stack, whatever the rover was: in a chain of ArUco banners the
    # second looked for the leader's tag)
    video = str(banner_video(3))
    rc = main(["follow", "--mavlink", "udpout:127.0.0.1:9", "--scenario", "column5", "--follower", "nobody",
               "--camera", video])  # fmt: skip
    err = capsys.readouterr().err
    assert rc == 2 and "--follower 'nobody': the scenario's followers are f1, f2, f3, f4" in err, err
    with standing_rover() as rover, caplog.at_level("INFO", "lfctl.follower.rover"):
        rc = main(["follow", "--mavlink", f"udpout:127.0.0.1:{rover.link.port}", "--scenario", "column5",
                   "--follower", "f3", "--camera", video, "--max-frames", "2", "--timeout", "5"])  # fmt: skip
    assert rc == 0
    said = [r.getMessage() for r in caplog.records if r.name == "lfctl.follower.rover"]
    assert said and all(s.startswith("f3: ") for s in said), said


@pytest.mark.integration
def test_the_summary_leaves_a_companionless_followers_tracking_to_its_companion(
    tmp_path: Path, free_udp_ports, capsys: pytest.CaptureFixture[str]
) -> None:
    from lfctl.data import examples_dir

    text = (
        (examples_dir() / "convoy.toml")
        .read_text()
        .replace("bearing_deg = 0.0\n", "bearing_deg = 0.0\ncompanion = false\n", 1)
    )
    scenario = tmp_path / "solo.toml"
    scenario.write_text(text + f'\n[link]\nudp_base_port = {free_udp_ports(2)}\ngcs_udpout = ""\n')
    assert main(["sim", str(scenario), "--realtime", "--duration", "1", "--no-record", "-q"]) == 0
    out = capsys.readouterr().out
    assert "follower1    has no companion: waits in HOLD, disarmed, for one: `lfctl follow" in out
    assert "--follower follower1" in out and "follower1: its companion ran outside the simulator" in out
    row = next(line for line in out.splitlines() if line.startswith("follower1  leader"))
    assert row.split()[-3:] == ["-", "-", "-"]  # its simulated tracker's seconds are not its companion's


@pytest.mark.slow
def test_a_rehearsal_follower_is_not_tracked_by_the_simulator_and_its_log_has_what_drove_it(
    tmp_path: Path, free_udp_ports
) -> None:
    # a rehearsal's follower is tracked by lfctl follow, outside: the simulator only renders
    # its frames (its own tracker used to run on them, and its stack's unsent commands and
    # track state went into the log as if they had driven the vehicle)
    import dataclasses

    from lfctl.config import load_config
    from lfctl.data import examples_dir
    from lfctl.record.audit import audit, format_report
    from lfctl.record.mcap_read import read_contents
    from lfctl.record.plots import plot_all
    from lfctl.record.replay import replay
    from lfctl.sim.runner import run_scenario

    cfg = load_config(examples_dir() / "convoy.toml")
    base = free_udp_ports(2)
    cfg = dataclasses.replace(
        cfg,
        vehicles=(cfg.vehicles[0], dataclasses.replace(cfg.vehicles[1], companion=False)),
        link=dataclasses.replace(cfg.link, udp_base_port=base, gcs_udpout=""),
    )
    speed, yaw_rate = 0.4, 0.25  # what the outside companion asks for
    done = threading.Event()

    def outside_companion() -> None:  # as lfctl follow drives it: GUIDED, armed, setpoints at 20 Hz
        comp = Companion.open(f"udpout:127.0.0.1:{base + 1}", 2)
        try:
            comp.request(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES["GUIDED"])
            comp.request(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)
            t0 = time.monotonic()
            while not done.is_set():
                comp.setpoint(time.monotonic() - t0, speed, yaw_rate)
                comp.poll(time.monotonic() - t0, 0.05)
        finally:
            comp.close()

    log = tmp_path / "rehearsal.mcap"
    driver = threading.Thread(target=outside_companion, daemon=True)
    driver.start()
    try:
        report = run_scenario(cfg, realtime=True, duration_s=4.0, record_to=log)
    finally:
        done.set()
        driver.join(10)
    extra = report.result.extra
    assert extra["vision_s"] == 0.0 and extra["render_s"] > 0  # rendered, never tracked
    (m,) = report.metrics
    assert m.time_in_state_s == {"tracking": None, "occluded": None, "lost": None}
    c, findings = read_contents(log)
    assert not findings
    assert "/follower1/camera/annotations" not in c.messages and "/follower1/pose_estimate" not in c.messages
    assert len(c.messages["/follower1/camera/video"]) > 60  # the frames are recorded, with their truth alone
    frames = [json.loads(payload) for _t, payload in c.messages["/follower1/tracker"]]
    assert frames and all(set(x) <= {"t_s", "truth_bbox", "truth_visible_fraction"} for x in frames)
    assert any("truth_bbox" in x for x in frames)
    assert c.metadata["run"]["companion_outside"] == "follower1"
    steps = [json.loads(payload) for _t, payload in c.messages["/follower1/controller"]]
    assert steps and not any("status" in x for x in steps)
    driven = [(x["speed_cmd_mps"], x["yaw_rate_cmd_degps"]) for x in steps[len(steps) // 2 :]]
    assert all(v == pytest.approx((speed, math.degrees(yaw_rate)), abs=1e-3) for v in driven), driven[:5]
    r = audit(log)
    assert r.ok, r.findings
    (fig,) = r.figures["followers"]
    assert fig["time_in_state_s"] == {"tracking": None, "occluded": None, "lost": None}
    assert fig["occlusion_episodes"] is None
    row = next(line for line in format_report(r).splitlines() if line.startswith("  follower1 "))
    assert row.split()[9:12] == ["-", "-", "-"]
    assert any(p.name.startswith("follower1") for p in plot_all(r, tmp_path / "plots"))
    # the frames lfctl follow saw, tracked again against their truth
    replayed = replay(log)
    assert replayed.recorded_success is None and replayed.scored > 0 and 0 <= replayed.replayed_success <= 1


# -- a camera that stops and comes back -----------------------------------------------------------


def test_a_camera_that_stops_holds_the_rover_and_is_opened_again_when_its_stream_comes_back(
    standing_rover, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    # a rover's camera streaming RTP (as `lfctl sim --video` and most rover cameras do) that
    # pauses long enough for FFmpeg's read to time out (its sender restarted, a cable), then
    # resumes: the rover is held still meanwhile, said to the ground station, and the run goes
    # on with the target looked for afresh
    import lfctl.video
    from lfctl.follower.rover import follow_rover
    from lfctl.follower.stack import formation_settings
    from lfctl.render.sequences import make_sequence
    from lfctl.video import open_live
    from lfctl.vision.perception import BannerPerception
    from lfctl.vision.track_state import TrackStatus

    monkeypatch.setattr(lfctl.video, "STREAM_TIMEOUT_S", 1.0)  # FFmpeg's read gives up 1 s into the pause
    caplog.set_level(logging.INFO, logger="lfctl.follower.rover")
    frames = [f for _t, f, _truth in make_sequence("clear", 1, 30).frames()]
    heard: list[tuple[str, Any]] = []  # what the rover got from the companion, in order
    pause, resume = threading.Event(), threading.Event()

    def tap(direction: str, m: Any, raw: bytes, *to: Any) -> None:
        if direction == "in" and m.get_type() in ("STATUSTEXT", "SET_POSITION_TARGET_LOCAL_NED"):
            heard.append((m.get_type(), m))
            if m.get_type() == "STATUSTEXT" and "camera silent" in m.text:
                # the reading thread ends 1 s into the pause; resumed once the camera is being opened again
                threading.Timer(2.0, resume.set).start()

    statuses: list[TrackStatus] = []

    def on_step(step: Any) -> None:
        statuses.append(step.seen.measurement.status)
        if len(statuses) == 20:
            pause.set()

    cfg = parse_config(DEFAULT_SCENARIO, "follow")
    with rtp_camera(frames, lambda k: not pause.is_set() or resume.is_set()) as rtp_port, standing_rover() as rover:
        rover.tap = tap
        companion = Companion.open(f"udpout:127.0.0.1:{rover.link.port}", 1)
        try:
            video, _first = open_live(f"rtp://127.0.0.1:{rtp_port}", 10.0)
            with video:
                perception = BannerPerception.from_config(cfg.camera, cfg.banner, (1.5, 0.0))
                settings = formation_settings(cfg, 1.5, 0.0, "smc", cfg.camera)
                done = follow_rover(companion, video, perception, settings, rate_hz=20.0, status_rate_hz=2.0,
                                    arm=True, timeout_s=5.0, max_frames=50, on_step=on_step)  # fmt: skip
        finally:
            companion.close()
    texts = [m.text for kind, m in heard if kind == "STATUSTEXT" and "camera" in m.text]
    assert texts == ["rover: camera silent, rover held", "rover: camera back"]
    silent_at = next(i for i, (_k, m) in enumerate(heard) if "camera silent" in getattr(m, "text", ""))
    back_at = next(i for i, (_k, m) in enumerate(heard) if "camera back" in getattr(m, "text", ""))
    held = [m for kind, m in heard[silent_at:back_at] if kind == "SET_POSITION_TARGET_LOCAL_NED"]
    assert len(held) >= 10 and all((m.vx, m.vy, m.yaw_rate) == (0.0, 0.0, 0.0) for m in held)
    assert done.frames == 50 and done.camera_gaps == 1 and done.camera_silent_s > 1.0
    assert done.steps >= 50 + len(held)  # the held steps are setpoints sent too
    assert statuses[20:].count(TrackStatus.TRACKING) >= 20, statuses  # found again on its markers
    said = [r.getMessage() for r in caplog.records]
    assert any("stopped: opening it again until it is back (tries 1 s apart or more" in t for t in said), said
    assert any("opened again: waiting for its frames" in t for t in said)
    assert any("looking for the target afresh" in t for t in said)
    assert "the camera silent once" in done.summary()


class _FakeCamera:
    """A live source giving ``n`` frames of ``shape`` (then none: it has stopped)."""

    def __init__(self, n: int, shape: tuple[int, int]) -> None:
        self.name, self.live, self.skipped, self.closed = "rtp://127.0.0.1:5600", True, 0, False
        self.left, self.shape = n, shape

    @property
    def ended(self) -> bool:
        return self.left <= 0

    def read(self, timeout_s: float | None = None) -> Any:
        import numpy as np

        if self.left <= 0:
            return None
        self.left -= 1
        return np.full((*self.shape, 3), 128, np.uint8)

    def close(self, wait_s: float | None = None) -> None:
        self.closed = True


def test_a_camera_back_at_another_size_ends_the_run_and_the_source_opened_for_it_is_closed(
    caplog: pytest.LogCaptureFixture,
) -> None:
    from lfctl.follower.rover import follow_rover
    from lfctl.follower.stack import formation_settings
    from lfctl.vision.perception import BannerPerception

    cfg = parse_config(DEFAULT_SCENARIO, "follow")
    _rover, companion, _got = _memory_rover()
    first, again = _FakeCamera(5, (480, 640)), _FakeCamera(5, (240, 320))
    tries: list[int] = []

    def opener() -> Any:
        tries.append(1)
        if len(tries) < 2:
            raise ConfigError("no RTP stream yet")
        return again

    perception = BannerPerception.from_config(cfg.camera, cfg.banner, (1.5, 0.0))
    done = follow_rover(companion, first, perception, formation_settings(cfg, 1.5, 0.0, "smc", cfg.camera),  # type: ignore[arg-type]
                        rate_hz=20.0, status_rate_hz=2.0, timeout_s=2.0, open_camera=opener)  # fmt: skip
    assert done.frames == 5 and done.camera_gaps == 1 and len(tries) == 2
    assert first.closed and again.closed  # the stopped one freed (its port), the one opened here closed
    said = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert any("came back with 320x240 frames, not the 640x480 the run began with: the run ends" in t for t in said)


def test_camera_wait_bounds_the_wait_for_a_camera_not_there_yet(
    capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    args = ["follow", "--mavlink", "udpout:127.0.0.1:14999", "--camera", "/dev/lfctl-no-camera", "--camera-wait", "0.3"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "no camera device /dev/lfctl-no-camera (not plugged in, or not ready) (waited 0." in err, err
    said = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert said == [
        "waiting for the camera: no camera device /dev/lfctl-no-camera (not plugged in, or not ready); trying "
        "again (for up to 0.3 s)"
    ]


def test_a_camera_that_opens_and_stops_at_once_is_tried_again_once_a_second() -> None:
    # (it was tried again at every step: 58 opens and as many lines in 3 s at 20 Hz)
    from lfctl.follower.rover import follow_rover
    from lfctl.follower.stack import formation_settings
    from lfctl.vision.perception import BannerPerception

    cfg = parse_config(DEFAULT_SCENARIO, "follow")
    _rover, companion, _got = _memory_rover()
    opened: list[_FakeCamera] = []

    def opener() -> Any:
        opened.append(_FakeCamera(0, (480, 640)))  # opens, and has already stopped
        return opened[-1]

    perception = BannerPerception.from_config(cfg.camera, cfg.banner, (1.5, 0.0))
    done = follow_rover(companion, _FakeCamera(3, (480, 640)), perception,  # type: ignore[arg-type]
                        formation_settings(cfg, 1.5, 0.0, "smc", cfg.camera), rate_hz=20.0, status_rate_hz=2.0,
                        timeout_s=2.0, max_steps=3 + 50, open_camera=opener)  # fmt: skip
    # 50 steps held (2.5 s at 20 Hz): a try a second, not one a step (a slow machine's 2.5 s may
    # run longer: far fewer than the 50 steps' tries all the same)
    assert done.frames == 3 and 1 <= len(opened) < 12, len(opened)
    assert all(c.closed for c in opened)


class _ScriptedCamera(_FakeCamera):
    """A live source that gives, read after read, what ``script`` says: a frame (1) or none (0)."""

    def __init__(self, script: list[int]) -> None:
        super().__init__(len(script), (480, 640))
        self.script = script

    def read(self, timeout_s: float | None = None) -> Any:
        import numpy as np

        if not self.script:
            self.left = 0
            return None
        return np.full((480, 640, 3), 128, np.uint8) if self.script.pop(0) else None


def test_single_frames_a_stream_leaves_as_it_ends_are_no_return_of_the_camera(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # as an RTP stream stops, FFmpeg hands over a frame it still held at each read timeout:
    # one frame seconds after the last does not end the silence (nor restart the target's search)
    from lfctl.follower.rover import follow_rover
    from lfctl.follower.stack import formation_settings
    from lfctl.vision.perception import BannerPerception

    caplog.set_level(logging.INFO, logger="lfctl.follower.rover")
    cfg = parse_config(DEFAULT_SCENARIO, "follow")
    _rover, companion, _got = _memory_rover()
    camera = _ScriptedCamera([1] * 5 + ([0] * 30 + [1]) * 2 + [0] * 30 + [1] * 4)
    perception = BannerPerception.from_config(cfg.camera, cfg.banner, (1.5, 0.0))
    done = follow_rover(companion, camera, perception, formation_settings(cfg, 1.5, 0.0, "smc", cfg.camera),  # type: ignore[arg-type]
                        rate_hz=20.0, status_rate_hz=2.0, timeout_s=2.0, max_steps=101)  # fmt: skip
    said = [r.getMessage() for r in caplog.records]
    back = [t for t in said if "frames are back" in t]
    assert done.camera_gaps == 1 and len(back) == 1, said  # back only with the run of frames at the end
    assert [r.levelno for r in caplog.records if "frames are back" in r.getMessage()] == [logging.WARNING]
    assert done.frames == 5 + 2 and done.steps == 101, done  # the first frames, the run's third and fourth


def test_the_companions_ftp_answers_what_it_read_before_a_burst_goes_on() -> None:
    # Wrong, a burst under way would spend the reply ration at each poll before the requests
    # waiting were read, and those (a client's own TerminateSession) would go unanswered for
    # the burst's whole run: the companion reads first, then lets the bursts go on, as the
    # vehicle's endpoint does
    a, b = MemoryLink.pair("gcs", "companion")
    gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    companion = Companion(MavPort.memory(b, 1, COMPANION_COMPID), 1)
    calls: list[str] = []
    real = companion.ftp
    companion.ftp = SimpleNamespace(  # type: ignore[assignment]
        tick=lambda: calls.append("tick") or real.tick(),
        handle=lambda *args: calls.append("handle") or real.handle(*args),
    )
    payload = bytes(251)  # a None request (opcode 0) of session 0
    a.send(mav.MAVLink_file_transfer_protocol_message(0, 1, COMPANION_COMPID, list(payload)).pack(gcs))
    companion.poll(1.0)
    assert calls == ["handle", "tick"]
