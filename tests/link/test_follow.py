"""`lfctl follow` against a vehicle endpoint on loopback UDP: a rendered banner video as the
camera, GUIDED setpoints out, formation status reported."""

from __future__ import annotations

import base64
import json
import math
import socket
import time
from typing import Any

import pytest
from pymavlink.dialects.v10 import ardupilotmega as mav1
from pymavlink.dialects.v20 import ardupilotmega as mav
from support import left_stopped, wait_until

from lfctl.cli import main
from lfctl.cli.follow import DEFAULT_SCENARIO, MAVLINK_MAX_PER_S, NO_FIX_AFTER_S, LiveView
from lfctl.config import parse_config
from lfctl.frames import ned_to_geodetic
from lfctl.link.companion import COMPANION_COMPID, Companion
from lfctl.link.endpoint import MODES, VehicleEndpoint
from lfctl.link.port import MavPort
from lfctl.link.signing import signing_key_from_passphrase
from lfctl.link.transport import MemoryLink
from lfctl.vision.camera_model import CameraModel

pytestmark = pytest.mark.integration


@pytest.mark.parametrize("passphrase", [None, "convoy-7"])
def test_follow_drives_a_guided_rover_from_video(
    banner_video, standing_rover, capsys: pytest.CaptureFixture[str], passphrase: str | None
) -> None:
    # with a passphrase the rover signs and takes only signed packets: the companion must sign
    video = banner_video(40)
    received: list[tuple[float, float]] = []
    names: set[str] = set()

    def commanded(rover: VehicleEndpoint) -> None:
        cmd = rover.guided_command()
        if cmd is not None:
            received.append(cmd)

    with standing_rover(signing_key_from_passphrase(passphrase), commanded) as rover:
        rover.tap = lambda d, m, raw: names.add(m.get_type()) if d == "in" else None
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
            ]
        )
        stopped = wait_until(lambda: left_stopped(rover))  # the last setpoints reach the rover in its time
        time.sleep(0.2)  # and nothing else comes after them
        stopped = stopped and left_stopped(rover)
    assert rc == 0 and "sent" in capsys.readouterr().out
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
    assert rover._intervals[mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT] == pytest.approx(0.05)
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
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        for data in (position, heartbeat_v1, unknown_id, no_value, b"\x00junk\xfd\x01", position[:9]):
            s.sendto(data, port.connection.port.getsockname())
        deadline = time.monotonic() + 5.0
        while len(seen) < 4 and time.monotonic() < deadline:
            port.recv(0.1)
    port.send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_ONBOARD_CONTROLLER, 8, 0, 0, 4, 3))
    port.close()
    # what could be framed (a message id the dialect does not know too), as it travelled;
    # garbage and a cut frame are not shown
    assert [(d, m.get_type()) for d, m, _ in seen] == [
        ("in", "GLOBAL_POSITION_INT"),
        ("in", "HEARTBEAT"),
        ("in", "UNKNOWN_60123"),
        ("in", "NAMED_VALUE_FLOAT"),
        ("out", "HEARTBEAT"),
    ]
    assert [raw for _, _, raw in seen[:4]] == [position, heartbeat_v1, unknown_id, no_value]
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
