"""The vehicle endpoint over real loopback UDP with a real pymavlink ground station."""

from __future__ import annotations

import io
import math
import random
import socket
import struct
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav
from support import list_file, loopback_udp, wait_until

from lfctl.errors import LinkTimeoutError, MissionProtocolError
from lfctl.link.camera import CameraComponent, CameraRouter
from lfctl.link.endpoint import GUIDED_TIMEOUT_S, MODES, VehicleEndpoint
from lfctl.link.gcs import GroundStation
from lfctl.link.mission import MissionItem, load_mission, local_mission, save_mission
from lfctl.link.signing import setup_signing, signing_key_from_passphrase
from lfctl.link.transport import LossyLink, MemoryLink, UdpLink

pytestmark = pytest.mark.integration
HOME = (12.9602, 77.6690, 900.0)
STATE = {"north_m": 1.0, "east_m": 2.0, "yaw_rad": 0.5, "speed_mps": 0.2, "yaw_rate_radps": 0.0}


class LiveEndpoint:
    """An endpoint on 127.0.0.1:0 ticked at 100 Hz by a thread (time = wall time)."""

    def __init__(
        self, loss: float = 0.0, signing_key: bytes | None = None, channels: bool = False, camera: bool = False
    ) -> None:
        udp = UdpLink(("127.0.0.1", 0))
        self.link = LossyLink(udp, loss) if loss else udp
        link: Any = self.link
        self.camera: CameraComponent | None = None
        if camera:  # a camera component on the port, as a realtime follower's with --video
            self.camera = CameraComponent(
                1, udp.send, video_port=5600, width=640, height=480, fps=30.0, bitrate_kbps=1500, hfov_deg=62.0,
                name="follower camera",
            )  # fmt: skip
            link = CameraRouter(self.link, [self.camera])
        self.ep = VehicleEndpoint("leader", 1, link, HOME, signing_key=signing_key)
        if channels:  # each peer a channel of its own, as the simulator's realtime ports are
            self.ep.network = udp
        self.port = udp.port
        self._stop = threading.Event()
        self._t0 = time.monotonic()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            t = time.monotonic() - self._t0
            self.ep.tick(t, STATE)
            if self.camera is not None:
                self.camera.tick(t)
            time.sleep(0.01)

    def gcs(self, timeout_s: float = 3.0, signing_key: bytes | None = None) -> GroundStation:
        g = GroundStation(
            f"udpout:127.0.0.1:{self.port}", target_system=1, timeout_s=timeout_s, signing_key=signing_key
        )
        g.wait_heartbeat()
        return g

    def close(self) -> None:
        self._stop.set()
        self.thread.join(timeout=2)
        self.link.close()


@pytest.fixture
def live():
    ep = LiveEndpoint()
    yield ep
    ep.close()


SQUARE = [(4.0, 0.0), (4.0, 4.0, 2.0), (0.0, 4.0), (0.0, 0.0)]


def test_heartbeat_identifies_an_ardupilot_rover(live: LiveEndpoint) -> None:
    g = live.gcs()
    hb = g.wait(("HEARTBEAT",))
    assert (hb.type, hb.autopilot, hb.custom_mode) == (
        mav.MAV_TYPE_GROUND_ROVER,
        mav.MAV_AUTOPILOT_ARDUPILOTMEGA,
        MODES["HOLD"],
    )
    pos = g.wait(("GLOBAL_POSITION_INT",))
    assert pos.lat == pytest.approx((HOME[0] + 1.0 / 111319.5) * 1e7, abs=20) and pos.hdg == pytest.approx(2865, abs=2)
    # disarmed, home is where the vehicle stands (Rover's update_home); HOME_POSITION is sent as
    # home is set, and when asked for (it is in no stream group)
    lat, lon, _alt = g.home()
    assert (lat * 1e7, lon * 1e7) == pytest.approx((pos.lat, pos.lon), abs=2)
    g.close()


def test_packets_carry_consecutive_sequence_numbers_so_a_gcs_counts_no_loss(live: LiveEndpoint) -> None:
    # pymavlink's pack() leaves the sequence number alone (send() advances it): a vehicle
    # that only packed sent every packet as seq 0, and a GCS counted all but one as lost
    g = live.gcs()
    g.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_ALL, 10, 1))  # (MAVProxy asks too)
    seqs = [g.wait(("HEARTBEAT", "ATTITUDE", "GLOBAL_POSITION_INT", "SYS_STATUS")).get_seq() for _ in range(40)]
    assert len(set(seqs)) > 30
    assert g.port.lost == 0 and g.port.received >= 40
    g.close()


def test_mission_round_trip_upload_download_clear(
    live: LiveEndpoint, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    g = live.gcs()
    items = local_mission(SQUARE, HOME)
    g.upload(items)
    back = g.download()
    assert [(i.seq, i.command, i.x, i.y, i.param1) for i in back[1:]] == [
        (i.seq, i.command, i.x, i.y, i.param1) for i in items[1:]
    ]
    # item 0 comes back as home now, as Rover answers it: the disarmed vehicle's place
    pos = g.wait(("GLOBAL_POSITION_INT",))
    assert back[0].seq == 0 and (back[0].x, back[0].y) == pytest.approx((pos.lat, pos.lon), abs=2)
    for ext in ("waypoints", "plan"):  # the files round trip too
        save_mission(back, tmp_path / f"m.{ext}")
        again = load_mission(tmp_path / f"m.{ext}")
        assert [(i.command, i.x, i.y) for i in again] == [(i.command, i.x, i.y) for i in back]
    g.clear()
    assert g.download() == []
    g.close()
    from lfctl.cli import main

    connect = ["gcs", "--connect", f"udpout:127.0.0.1:{live.port}", "--timeout", "5"]
    assert main([*connect, "download"]) == 0
    assert main([*connect, "arm"]) == 0
    assert capsys.readouterr().out.splitlines()[-2:] == ["system 1 has no mission", "arm: MAV_RESULT_ACCEPTED"]
    # every mode the vehicles fly, RTL and SmartRTL too (any case)
    assert main([*connect, "mode", "rtl"]) == 0 and live.ep.mode == MODES["RTL"]
    assert main([*connect, "mode", "hold"]) == 0 and live.ep.mode == MODES["HOLD"]
    assert capsys.readouterr().out.splitlines()[-2:] == [
        "mode RTL: MAV_RESULT_ACCEPTED",
        "mode HOLD: MAV_RESULT_ACCEPTED",
    ]
    # a plan made for another site goes up, as a Rover takes it, with a warning naming the place
    far = tmp_path / "far.waypoints"
    far.write_text("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t52.0\t4.0\t0\t1\n1\t0\t3\t16\t0\t0\t0\t0\t52.0\t4.0\t0\t1\n")
    assert main([*connect, "upload", str(far)]) == 0
    err = capsys.readouterr().err
    assert "warning" in err and "mission item 1 (NAV_WAYPOINT) at 52.0000000, 4.0000000 is" in err
    assert "km from the vehicle's home" in err and len(live.ep.mission) == 2
    save_mission(local_mission(SQUARE, HOME), tmp_path / "near.waypoints")
    assert main([*connect, "upload", str(tmp_path / "near.waypoints")]) == 0
    assert "warning" not in capsys.readouterr().err


def test_invalid_latitude_is_rejected_and_the_old_mission_stays(live: LiveEndpoint) -> None:
    g = live.gcs()
    good = local_mission(SQUARE, HOME)
    g.upload(good)
    bad = list(good)
    bad[3] = type(bad[3])(**{**bad[3].__dict__, "x": 95 * 10**7})
    with pytest.raises(
        MissionProtocolError, match=r"on item 3 \(NAV_WAYPOINT\), the last sent: MAV_MISSION_INVALID_PARAM5_X"
    ):
        g.upload(bad)
    assert [i.x for i in g.download()[1:]] == [i.x for i in good[1:]]  # item 0: home now
    # a command ArduPilot's mission library does not know (a Rover takes even NAV_TAKEOFF, and skips it)
    unsupported = [*good[:2], type(good[2])(**{**good[2].__dict__, "command": mav.MAV_CMD_USER_1})]
    with pytest.raises(MissionProtocolError, match="MAV_MISSION_UNSUPPORTED"):
        g.upload(unsupported)
    g.close()


def test_upload_and_download_complete_with_20_percent_loss_both_ways() -> None:
    live = LiveEndpoint(loss=0.2)
    try:
        g = GroundStation(f"udpout:127.0.0.1:{live.port}", target_system=1, timeout_s=5.0)
        g.wait_heartbeat()
        items = local_mission([(float(k), float(k % 3)) for k in range(1, 31)], HOME)
        # a round trip is lost with probability 1 - 0.8^2 = 0.36 (the loss follows the
        # telemetry's wall-clock timing, so it differs between runs): 12 restarts put a failed
        # upload at 0.36^13 = 2e-6; a download asks for an item again every 0.25-0.31 s
        # (16 retries of 5 s), at least 16 times: 32 x 0.36^16 = 3e-6
        g.upload(items, item_timeout_s=0.5, restarts=12)
        assert [(i.x, i.y) for i in g.download(retries=16)[1:]] == [(i.x, i.y) for i in items[1:]]
        g.close()
    finally:
        live.close()


def test_duplicated_and_reordered_items_are_handled() -> None:
    a, b = MemoryLink.pair("ep", "gcs")
    ep = VehicleEndpoint("v", 1, a, HOME)
    m = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    items = local_mission(SQUARE, HOME)

    def item(k: int) -> bytes:
        it = items[k]
        return mav.MAVLink_mission_item_int_message(
            1, 1, it.seq, it.frame, it.command, 0, 1, it.param1, 0, 0, 0, it.x, it.y, it.z, 0
        ).pack(m)

    b.send(mav.MAVLink_mission_count_message(1, 1, len(items), 0).pack(m))
    ep.tick(0.0, STATE)
    b.send(item(0))
    b.send(item(0))  # duplicate
    b.send(item(2))  # out of order: the endpoint asks again for 1
    b.send(item(1))
    for k in range(2, len(items)):
        b.send(item(k))
    ep.tick(0.01, STATE)
    assert [i.seq for i in ep.mission] == list(range(len(items)))


def test_frames_of_unknown_message_ids_take_no_place_in_the_peer_table(live: LiveEndpoint) -> None:
    # pymavlink cannot check the CRC of an id outside the dialect, so one random datagram in
    # about a hundred passed as an UNKNOWN_<id> message: junk from 20 ports filled the 16-peer
    # table, and a new ground station heard nothing until they timed out (30 s)
    rng = random.Random(5)
    junk = []
    for _ in range(20):
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.bind(("127.0.0.1", 0))
        junk.append(s)
        for _ in range(5):  # a MAVLink 2 header, an unknown id (10000 and up), random payload and CRC
            payload = bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 40)))
            msgid = rng.randint(10000, 0xFFFFFF)
            header = bytes([0xFD, len(payload), 0, 0, rng.getrandbits(8), 7, 1]) + msgid.to_bytes(3, "little")
            s.sendto(header + payload + bytes([rng.getrandbits(8), rng.getrandbits(8)]), ("127.0.0.1", live.port))
    deadline = time.monotonic() + 3.0
    while live.ep.stats.unknown < 100 and time.monotonic() < deadline:
        time.sleep(0.02)
    assert live.ep.stats.unknown == 100 and live.ep.stats.messages == 0
    assert not live.link.peers and live.link.refused_peers == 0  # type: ignore[attr-defined]
    g = live.gcs(timeout_s=3.0)  # heard at once: a heartbeat or two (1 Hz), not the 30 s lock-out
    assert g.arm(True) == mav.MAV_RESULT_ACCEPTED
    g.close()
    for s in junk:
        s.close()


def test_garbage_is_dropped_and_counted_and_the_endpoint_keeps_serving(live: LiveEndpoint) -> None:
    rng = random.Random(3)
    m = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    good = mav.MAVLink_command_long_message(
        1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0
    ).pack(m)
    other = mav.MAVLink_command_long_message(7, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0).pack(m)
    bad_crc = bytearray(good)
    bad_crc[-1] ^= 0xFF
    unknown = bytearray(b"\xfd\x00\x00\x00\xff\xbe\x01\xe8\x03\x00")  # message id 1000, empty payload
    s = loopback_udp()
    for k in range(3000):
        kind = k % 5
        if kind == 0:
            data = bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 300)))
        elif kind == 1:
            data = good[: rng.randint(1, len(good) - 1)]  # truncated frame
        elif kind == 2:
            data = bytes(bad_crc)
        elif kind == 3:
            data = bytes(unknown) + b"\x00\x00"
        else:
            data = other  # for another system
        s.sendto(data, ("127.0.0.1", live.port))
        if k % 200 == 199:
            time.sleep(0.01)  # a few thousand datagrams, not a flood the kernel drops
    s.close()
    g = live.gcs()
    assert g.arm(True) == mav.MAV_RESULT_ACCEPTED
    assert live.ep.armed
    st = live.ep.stats
    assert st.datagrams >= 2900  # all (or nearly all) arrived and were read
    assert st.bad >= 0.5 * 2900 and st.other_sysid >= 550 and st.unknown >= 550  # id 1000: unknown
    g.close()


def test_commands_are_acknowledged_as_ardupilot_does(live: LiveEndpoint) -> None:
    g = live.gcs()
    assert g.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED and live.ep.mode == MODES["GUIDED"]
    # an unknown mode, or one that cannot start, is FAILED (GCS_Common's _set_mode_common);
    # a mode without the custom-mode flag, or a parameter that is not a number, DENIED
    assert g.command(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 99) == mav.MAV_RESULT_FAILED
    assert g.command(mav.MAV_CMD_DO_SET_MODE, 0, MODES["HOLD"]) == mav.MAV_RESULT_DENIED
    assert g.command(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, math.nan) == mav.MAV_RESULT_DENIED
    assert g.command(mav.MAV_CMD_NAV_TAKEOFF) == mav.MAV_RESULT_UNSUPPORTED
    # FOLLOW (6) is a Rover mode lfctl does not fly: refused with a reason, GUIDED kept
    assert g.set_mode("FOLLOW") == mav.MAV_RESULT_FAILED and live.ep.mode == MODES["GUIDED"]
    assert g.command(mav.MAV_CMD_REQUEST_MESSAGE, mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION) == mav.MAV_RESULT_ACCEPTED
    assert g.wait(("AUTOPILOT_VERSION",)).capabilities & mav.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    # SET_MESSAGE_INTERVAL: ATTITUDE at 40 Hz (the fastest at Rover's SCHED_LOOP_RATE 50: 0.8 x)
    # instead of 10 Hz; 50 Hz is refused
    assert g.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_ATTITUDE, 20_000) == mav.MAV_RESULT_DENIED
    assert g.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_ATTITUDE, 25_000) == mav.MAV_RESULT_ACCEPTED
    g.wait(("ATTITUDE",))  # one that may have left before the new interval
    boot_ms = [g.wait(("ATTITUDE",)).time_boot_ms for _ in range(15)]
    gaps = np.diff(boot_ms)  # the vehicle's clock, not the wall's
    # 25 ms (40 Hz) from 100 ms (10 Hz); a gap is whole ticks of this wall-clock endpoint
    # (10 ms sleeps), so a busy machine's slow ticks lengthen it, but not near 100 ms
    assert np.median(gaps) <= 60, boot_ms
    assert g.param_set("WP_SPEED", 0.42) == pytest.approx(0.42)
    # named in another case (AP_Param::find takes it): the vehicle answers as WP_SPEED, and
    # the client takes that answer (it waited for 'wp_speed' and timed out)
    assert g.param_set("wp_speed", 0.45) == pytest.approx(0.45) and g.param_get("wp_speed") == pytest.approx(0.45)
    assert g.param_set("WP_SPEED", 0.42) == pytest.approx(0.42)
    assert g.param_set("WP_SPEED", 550.0) == pytest.approx(0.42)  # out of range: refused, value kept
    assert g.param_set("WP_SPEED", math.nan) == pytest.approx(0.42)
    assert len(g.param_list()) == len(live.ep.params)
    g.close()


def test_gcs_heartbeat_lost_puts_the_vehicle_in_hold_when_the_failsafe_is_on() -> None:
    a, b = MemoryLink.pair("ep", "gcs")
    ep = VehicleEndpoint("v", 1, a, HOME, mode="AUTO", armed=True)
    ep.params["FS_GCS_ENABLE"].value = 1  # ArduPilot Rover ships with it off
    m = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    b.send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, 8, 0, 0, 4, 3).pack(m))
    ep.tick(0.0, STATE)
    ep.tick(4.9, STATE)
    ep.tick(5.0, STATE)  # FS_GCS_TIMEOUT (5 s) of silence: lost ...
    ep.tick(6.5, STATE)
    assert ep.mode == MODES["AUTO"]
    ep.tick(6.6, STATE)  # ... for more than FS_TIMEOUT (1.5 s): FS_ACTION's HOLD
    assert ep.mode == MODES["HOLD"] and any(t == "GCS Failsafe" for _, t in ep.statustexts)


def test_by_default_a_lost_gcs_heartbeat_changes_nothing_as_on_a_rover() -> None:
    a, b = MemoryLink.pair("ep", "gcs")
    ep = VehicleEndpoint("v", 1, a, HOME, mode="AUTO", armed=True)
    m = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    b.send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, 8, 0, 0, 4, 3).pack(m))
    ep.tick(0.0, STATE)
    ep.tick(30.0, STATE)
    assert ep.mode == MODES["AUTO"] and ep.param("FS_GCS_ENABLE") == 0


def test_companion_silence_stops_the_follower_within_the_timeout() -> None:
    a, b = MemoryLink.pair("ep", "companion")
    ep = VehicleEndpoint("f", 2, a, HOME, mode="GUIDED", armed=True)
    m = mav.MAVLink(None, srcSystem=2, srcComponent=191)
    b.send(
        mav.MAVLink_set_position_target_local_ned_message(
            0, 2, 1, mav.MAV_FRAME_BODY_NED, 1479, 0, 0, 0, 0.3, 0, 0, 0, 0, 0, 0, 0.1
        ).pack(m)
    )
    ep.tick(10.0, STATE)
    assert ep.guided_command() == pytest.approx((0.3, 0.1))
    ep.tick(10.0 + GUIDED_TIMEOUT_S - 0.05, STATE)
    assert ep.guided_command() is not None
    ep.tick(10.0 + GUIDED_TIMEOUT_S + 0.2, STATE)
    assert ep.guided_command() is None
    assert ("target not received last 3secs, stopping") in [t for _, t in ep.statustexts]  # Rover 4.6's
    assert "GUID_TIMEOUT" not in ep.params  # Rover 4.6 has none: its 3 s is fixed


def test_signed_link_obeys_the_key_holder_and_ignores_everyone_else() -> None:
    key = signing_key_from_passphrase("convoy-7")
    assert key == signing_key_from_passphrase("convoy-7") and len(key) == 32
    live = LiveEndpoint(signing_key=key)
    try:
        good = live.gcs(signing_key=key)
        hb = good.wait(("HEARTBEAT",))
        assert hb.get_signed() and hb.get_link_id() == 0  # what the vehicle sends is signed
        assert good.arm() == mav.MAV_RESULT_ACCEPTED and live.ep.armed
        good.close()
        # no key, or the wrong one: its commands are dropped and counted, the mode stays
        for other in (None, signing_key_from_passphrase("convoy-8")):
            bad_before = live.ep.stats.bad
            g = GroundStation(f"udpout:127.0.0.1:{live.port}", target_system=1, timeout_s=0.3, signing_key=other)
            with pytest.raises(LinkTimeoutError):
                g.set_mode("GUIDED")
            assert live.ep.mode == MODES["HOLD"] and live.ep.stats.bad > bad_before
            g.close()
    finally:
        live.close()


def test_a_replayed_signed_packet_is_refused_even_after_garbage() -> None:
    key = signing_key_from_passphrase("convoy-7")
    live = LiveEndpoint(signing_key=key)
    sender = mav.MAVLink(None, srcSystem=254, srcComponent=190)
    setup_signing(sender, key)
    sock = loopback_udp()
    try:
        manual = mav.MAVLink_set_mode_message(1, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES["MANUAL"]).pack(sender)
        sock.sendto(manual, ("127.0.0.1", live.port))
        deadline = time.monotonic() + 3.0
        while live.ep.mode != MODES["MANUAL"] and time.monotonic() < deadline:
            time.sleep(0.02)
        assert live.ep.mode == MODES["MANUAL"]
        live.ep.set_mode(MODES["HOLD"])
        sock.sendto(manual[:7], ("127.0.0.1", live.port))  # a fragment: the parser is reset
        sock.sendto(manual, ("127.0.0.1", live.port))  # the same signed bytes again
        time.sleep(0.3)
        assert live.ep.mode == MODES["HOLD"]
    finally:
        sock.close()
        live.close()


@pytest.mark.parametrize("fmt", ["mavproxy", "qgc"])
def test_param_files_save_and_load_through_the_cli(live: LiveEndpoint, tmp_path: Path, fmt: str) -> None:
    from lfctl.cli import main

    f = tmp_path / "rover.parm"
    connect = ["gcs", "--connect", f"udpout:127.0.0.1:{live.port}", "--timeout", "3", "param"]
    assert main([*connect, "save", str(f), "--format", fmt]) == 0
    text = f.read_text()
    assert "WP_SPEED" in text and "FENCE_ACTION" in text
    if fmt == "qgc":
        assert text.startswith("# Onboard parameters") and "\t1\tWP_SPEED\t" in text
    edited = text.replace("WP_SPEED", "WP_SPEED_OLD") + (
        "1\t1\tWP_SPEED\t0.75\t9\n" if fmt == "qgc" else "WP_SPEED 0.75\n"
    )
    edited += "" if fmt == "qgc" else "SOME_OTHER_PARAM 3\n"
    f.write_text(edited)
    assert main([*connect, "load", str(f)]) == 0
    assert live.ep.param("WP_SPEED") == pytest.approx(0.75)


def test_a_refused_param_set_exits_1(live: LiveEndpoint, capsys: pytest.CaptureFixture[str]) -> None:
    from lfctl.cli import main

    connect = ["gcs", "--connect", f"udpout:127.0.0.1:{live.port}", "--timeout", "3", "param", "set"]
    with pytest.raises(SystemExit) as stop:  # NaN is refused before anything is sent
        main([*connect, "WP_SPEED", "nan"])
    assert stop.value.code == 2
    capsys.readouterr()
    assert main([*connect, "WP_SPEED", "1000"]) == 1
    err = capsys.readouterr().err
    # with the vehicle's reason, which was only on the vehicle's console
    assert err == "lfctl: error: WP_SPEED kept 2 (refused 1000: WP_SPEED rejected: 1000 outside 0..100 m/s)\n", err
    assert main([*connect, "WP_SPEED", "0.5"]) == 0


def test_a_parameter_the_vehicle_lacks_is_named_at_once(live: LiveEndpoint, capsys: pytest.CaptureFixture[str]) -> None:
    from lfctl.cli import main

    # on the vehicle's word ("Unknown parameter NOPE"), not a timeout's "is the vehicle up?"
    connect = ["gcs", "--connect", f"udpout:127.0.0.1:{live.port}", "--timeout", "5"]
    for op in (["get", "NOPE"], ["set", "NOPE", "1"]):
        assert main([*connect, "param", *op]) == 1
        assert "system 1 has no parameter 'NOPE'" in capsys.readouterr().err


def test_a_ground_station_reboots_the_vehicle_and_hears_it_come_back(live: LiveEndpoint) -> None:
    # as a script written for ArduPilot does it: the ACK, then wait for "ArduPilot Ready"
    g = live.gcs(timeout_s=10.0)
    assert g.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert g.command(mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == mav.MAV_RESULT_ACCEPTED
    ready = g.wait(("STATUSTEXT",), where=lambda m: m.text == "ArduPilot Ready")
    beat = g.wait(("HEARTBEAT",), where=lambda m: m.get_srcComponent() == 1)
    assert ready.severity == mav.MAV_SEVERITY_INFO and beat.custom_mode == MODES["HOLD"]
    assert g.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED  # and it takes commands again
    g.close()


def test_the_vehicle_port_is_its_own() -> None:
    from lfctl.errors import LinkError

    link = UdpLink(("127.0.0.1", 0))
    try:
        with pytest.raises(LinkError, match="in use"):
            UdpLink(("127.0.0.1", link.port))  # a second run on the same port
        thief = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        thief.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        with pytest.raises(OSError):
            thief.bind(("127.0.0.1", link.port))  # another program, hoping to read the commands
        thief.close()
    finally:
        link.close()


def test_a_crowd_of_new_senders_does_not_evict_the_ground_station_in_use() -> None:
    now = [0.0]
    link = UdpLink(("127.0.0.1", 0), clock=lambda: now[0])
    try:
        gcs = ("127.0.0.1", 40001)
        link.accept_peer(gcs)
        for k in range(100):  # a flood of one-heartbeat senders from other ports
            now[0] += 0.01
            link.accept_peer(("127.0.0.1", 41000 + k))
            link.accept_peer(gcs) if k % 20 == 0 else None
        assert gcs in link.peers and link.refused_peers > 0
        now[0] += 31.0  # they all fall silent for longer than the peer timeout
        link.accept_peer(gcs)
        link.accept_peer(("127.0.0.1", 50000))
        assert set(link.peers) == {gcs, ("127.0.0.1", 50000)}
    finally:
        link.close()


def test_one_shot_calls_one_after_another_each_take_the_place_of_the_longest_silent() -> None:
    # a script setting 20 parameters with one `lfctl gcs` call each (a new source port each,
    # about a second each): the 17th was refused while the first 16 held their slots for 30 s,
    # and told "is the vehicle up?"
    from lfctl.link.transport import MAX_PEERS, STALE_PEER_S

    now = [0.0]
    link = UdpLink(("127.0.0.1", 0), clock=lambda: now[0])
    try:
        for k in range(MAX_PEERS + 4):
            caller = ("127.0.0.1", 42000 + k)
            for _ in range(3):  # its heartbeats and requests over the call's second
                link.accept_peer(caller)
                assert caller in link.peers, k
                now[0] += 0.4
        assert link.refused_peers == 0 and len(link.peers) == MAX_PEERS
        assert ("127.0.0.1", 42000) not in link.peers  # the first ones made room
        # a peer silent for less than STALE_PEER_S keeps its place: a full table of them refuses
        now[0] += STALE_PEER_S + 1.0
        busy = [("127.0.0.1", 43000 + k) for k in range(MAX_PEERS)]
        for peer in busy:
            link.accept_peer(peer)
        assert set(link.peers) == set(busy)
        now[0] += STALE_PEER_S / 2
        link.accept_peer(("127.0.0.1", 44000))
        assert set(link.peers) == set(busy) and link.refused_peers == 1
    finally:
        link.close()


def test_a_long_flood_of_new_ports_never_evicts_a_ground_station_sending_each_second(
    caplog: pytest.LogCaptureFixture,
) -> None:
    import logging

    from lfctl.link.transport import REFUSAL_LOG_S

    now = [0.0]
    link = UdpLink(("127.0.0.1", 0), clock=lambda: now[0])
    try:
        gcs = ("127.0.0.1", 40001)
        link.accept_peer(gcs)
        with caplog.at_level(logging.WARNING, logger="lfctl.link.transport"):
            for k in range(6000):  # ten a second for ten minutes, each port sending once
                now[0] += 0.1
                link.accept_peer(("127.0.0.1", 1024 + k))
                if k % 10 == 0:
                    link.accept_peer(gcs)  # its HEARTBEAT each second
                assert gcs in link.peers, k
        assert link.refused_peers > 0
        said = [r.getMessage() for r in caplog.records if "refused" in r.getMessage()]
        assert 1 <= len(said) <= 600 / REFUSAL_LOG_S + 1, len(said)
        assert f"UDP port {link.port}: refused 1 new peer (latest 127.0.0.1:" in said[0]
    finally:
        link.close()


def test_a_client_that_only_listens_keeps_its_telemetry_and_older_silent_ones_are_dropped() -> None:
    # a pymavlink logger that sent one heartbeat and then only listens lost its stream after
    # the peer timeout; a Rover's UDP port keeps sending to the client it heard
    now = [0.0]
    link = UdpLink(("127.0.0.1", 0), clock=lambda: now[0])
    listeners = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(2)]
    try:
        for sock in listeners:
            sock.bind(("127.0.0.1", 0))
            sock.settimeout(2.0)
        old, last = (("127.0.0.1", s.getsockname()[1]) for s in listeners)
        link.accept_peer(old)
        now[0] += 1.0
        link.accept_peer(last)
        now[0] += 600.0  # both silent for ten minutes
        link.send(b"x")
        assert listeners[1].recv(16) == b"x"  # the one heard last still gets it
        listeners[0].settimeout(0.2)
        with pytest.raises(TimeoutError):
            listeners[0].recv(16)  # an older silent one does not
    finally:
        link.close()
        for sock in listeners:
            sock.close()


def test_a_plans_fence_and_rally_points_go_up_and_come_back_with_its_mission(
    live: LiveEndpoint, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # as QGroundControl uploads a plan: its mission, its geofence (an inclusion polygon and an
    # exclusion circle) and its rally points; `gcs download x.plan` brings the three back
    import json

    from lfctl.cli import main

    lat, lon = HOME[0], HOME[1]
    square = [[lat + 1e-4, lon - 1e-4], [lat + 1e-4, lon + 1e-4], [lat - 1e-4, lon + 1e-4], [lat - 1e-4, lon - 1e-4]]
    plan = {
        "fileType": "Plan",
        "version": 1,
        "mission": {"version": 2, "plannedHomePosition": [lat, lon, HOME[2]], "items": []},
        "geoFence": {
            "version": 2,
            "polygons": [{"inclusion": True, "polygon": square, "version": 1}],
            "circles": [{"inclusion": False, "circle": {"center": [lat + 5e-5, lon], "radius": 2.5}, "version": 1}],
        },
        "rallyPoints": {"version": 2, "points": [[lat - 5e-5, lon + 5e-5, 0.0]]},
    }
    path = tmp_path / "fenced.plan"
    path.write_text(json.dumps(plan))
    connect = ["gcs", "--connect", f"udpout:127.0.0.1:{live.port}", "--timeout", "5"]
    assert main([*connect, "upload", str(path)]) == 0
    assert capsys.readouterr().out.strip() == (
        "uploaded 0 items (+ home), a fence of 5 items and 1 rally point to system 1"
    )
    assert [(it.command, it.param1) for it in live.ep.missions.lists[1]] == [(5001, 4.0)] * 4 + [(5004, 2.5)]
    assert len(live.ep.fence.inclusion_polygons) == 1 and len(live.ep.rally) == 1
    assert main([*connect, "download", str(tmp_path / "back.plan")]) == 0
    back = json.loads((tmp_path / "back.plan").read_text())
    corners = [c for vertex in back["geoFence"]["polygons"][0]["polygon"] for c in vertex]
    assert corners == pytest.approx([c for vertex in square for c in vertex], abs=1e-7)
    assert back["geoFence"]["circles"][0]["circle"]["radius"] == 2.5
    assert back["geoFence"]["circles"][0]["inclusion"] is False
    assert back["rallyPoints"]["points"][0][:2] == pytest.approx([lat - 5e-5, lon + 5e-5], abs=1e-7)
    g = live.gcs()
    g.clear(mav.MAV_MISSION_TYPE_FENCE)  # one list at a time: the rally point stays
    assert (live.ep.missions.lists[1], len(live.ep.missions.lists[2])) == ([], 1)
    g.close()


def test_a_plan_whose_fence_the_vehicle_refuses_says_what_went_up(
    live: LiveEndpoint, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # three polygons of 100 vertices: each one a fence may hold, 300 items more than the
    # simulated vehicle's room for 200: the mission is up, the fence and rally points are not
    import json

    from lfctl.cli import main

    lat, lon = HOME[0], HOME[1]
    ring = [[lat + 1e-4 * math.cos(a / 16), lon + 1e-4 * math.sin(a / 16)] for a in range(100)]
    plan = {
        "fileType": "Plan",
        "version": 1,
        "mission": {"plannedHomePosition": [lat, lon, HOME[2]], "items": []},
        "geoFence": {"version": 2, "polygons": [{"inclusion": True, "polygon": ring}] * 3, "circles": []},
        "rallyPoints": {"version": 2, "points": [[lat, lon, 0.0]]},
    }
    path = tmp_path / "too-big.plan"
    path.write_text(json.dumps(plan))
    assert main(["gcs", "--connect", f"udpout:127.0.0.1:{live.port}", "--timeout", "5", "upload", str(path)]) == 1
    err = capsys.readouterr().err
    assert "fence refused by system 1: MAV_MISSION_NO_SPACE" in err
    assert "(the mission went up; the vehicle keeps its fence and its rally points as they were)" in err
    assert live.ep.missions.lists[1] == [] and live.ep.missions.lists[2] == []
    assert "Fence upload refused: 300 items, room for 200" in [text for _t, text in live.ep.statustexts]


def test_do_set_mission_current_param2_1_resets_the_mission_as_rover(live: LiveEndpoint) -> None:
    # Rover 4.5+, GCS_Common's handle_command_do_set_mission_current: param2 1 ("reset
    # mission") is AP_Mission::reset before the item is made current (DO_JUMP's counts start
    # afresh, the driver's mission_restarts); any other param2 is a plain set, not refused;
    # an item the mission has not is DENIED, a mission of home alone FAILED
    g = live.gcs()
    items = [*local_mission(SQUARE, HOME), MissionItem(5, 0, mav.MAV_CMD_DO_JUMP, 1.0, 2.0)]
    g.upload(items)
    ep = live.ep
    restarts = ep.mission_restarts
    for param2 in (0.0, 2.0, 0.5, math.nan):
        assert g.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 3, param2) == mav.MAV_RESULT_ACCEPTED
        assert (ep.current_seq, ep.mission_restarts) == (3, restarts)
    assert g.wait(("MISSION_CURRENT",), where=lambda m: m.seq == 3).total == 5
    assert g.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 3, 1) == mav.MAV_RESULT_ACCEPTED
    assert (ep.current_seq, ep.mission_restarts) == (3, restarts + 1)
    assert g.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 5, 1) == mav.MAV_RESULT_ACCEPTED  # the DO_JUMP: an item
    assert ep.mission_restarts == restarts + 2
    assert g.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 6, 1) == mav.MAV_RESULT_DENIED  # past the last item
    assert ep.mission_restarts == restarts + 2
    g.upload(items[:1])  # home alone: nothing to head for
    assert g.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 0, 1) == mav.MAV_RESULT_FAILED
    assert g.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 1) == mav.MAV_RESULT_DENIED
    g.clear()
    assert g.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 0) == mav.MAV_RESULT_DENIED
    g.close()


def test_an_item_with_no_upload_under_way_is_a_mission_error_for_each_list(live: LiveEndpoint) -> None:
    # Rover's GCS_MAVLINK::handle_mission_item: an item of a list whose upload is not under
    # way (here the last one sent again, as after a lost final ACK) is MISSION_ACK
    # MAV_MISSION_ERROR for that list, nothing changed: no special case for the last item;
    # a list there is none of is MAV_MISSION_UNSUPPORTED
    g = live.gcs()
    lat, lon = int(HOME[0] * 1e7), int(HOME[1] * 1e7)
    corners = [(1000, -1000), (1000, 1000), (-1000, 1000), (-1000, -1000)]
    inclusion = mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
    lists = {
        mav.MAV_MISSION_TYPE_MISSION: local_mission(SQUARE, HOME),
        mav.MAV_MISSION_TYPE_FENCE: [
            MissionItem(k, mav.MAV_FRAME_GLOBAL, inclusion, 4.0, x=lat + dn, y=lon + de)
            for k, (dn, de) in enumerate(corners)
        ],
        mav.MAV_MISSION_TYPE_RALLY: [
            MissionItem(0, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, mav.MAV_CMD_NAV_RALLY_POINT, x=lat + 500, y=lon)
        ],
    }
    for mtype, items in lists.items():
        g.upload(items, mission_type=mtype)
    held = {mtype: list(live.ep.missions.lists[mtype]) for mtype in lists}
    mission = lists[mav.MAV_MISSION_TYPE_MISSION]

    def answer(msg: object, mtype: int) -> int:
        g.send(msg)
        return int(g.wait(("MISSION_ACK",), where=lambda m: m.mission_type == mtype).type)

    def item_int(it: MissionItem, mtype: int, current: int = 0) -> object:
        return mav.MAVLink_mission_item_int_message(
            1, 1, it.seq, it.frame, it.command, current, 1, it.param1, 0, 0, 0, it.x, it.y, it.z, mtype
        )

    for mtype, items in lists.items():
        last = items[-1]
        assert answer(item_int(last, mtype), mtype) == mav.MAV_MISSION_ERROR
        as_float = mav.MAVLink_mission_item_message(
            1, 1, last.seq, last.frame, last.command, 0, 1, last.param1, 0, 0, 0, last.lat_deg, last.lon_deg, 0, mtype
        )
        assert answer(as_float, mtype) == mav.MAV_MISSION_ERROR
    assert answer(item_int(mission[1], 3), 3) == mav.MAV_MISSION_UNSUPPORTED  # no such list
    assert {mtype: live.ep.missions.lists[mtype] for mtype in lists} == held
    # current = 3, an altitude change (MAVProxy's `guided` module): Rover takes it and has no
    # altitude to change; current = 2 stays a guided target (refused outside GUIDED)
    assert answer(item_int(mission[1], 0, current=3), 0) == mav.MAV_MISSION_ACCEPTED
    assert answer(item_int(mission[1], 0, current=2), 0) == mav.MAV_MISSION_ERROR
    assert live.ep.mission == held[mav.MAV_MISSION_TYPE_MISSION] and live.ep.guided is None
    # a stray item's MAV_MISSION_ERROR that reaches lfctl's ground station after it has
    # started a new upload (before the vehicle asks for anything) does not fail that upload
    g.send(item_int(mission[-1], 0))
    g.upload(mission[:3])
    assert len(live.ep.mission) == 3
    g.close()


def test_nav_set_yaw_speed_is_unsupported_as_on_a_current_rover(live: LiveEndpoint) -> None:
    # Rover's newest source is built without it (AP_MAVLINK_MAV_CMD_NAV_SET_YAW_SPEED_ENABLED
    # 0): the command falls through to GCS_Common's UNSUPPORTED, as a COMMAND_LONG (turned into
    # a COMMAND_INT) or a COMMAND_INT, in GUIDED too; the target stays
    g = live.gcs()
    assert g.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert g.command(mav.MAV_CMD_NAV_SET_YAW_SPEED, 90, 0.3, 0) == mav.MAV_RESULT_UNSUPPORTED
    g.send(
        mav.MAVLink_command_int_message(
            1, 1, mav.MAV_FRAME_GLOBAL, mav.MAV_CMD_NAV_SET_YAW_SPEED, 0, 0, 90, 0.3, 1, 0, 0, 0, 0
        )
    )
    ack = g.wait(("COMMAND_ACK",), where=lambda m: m.command == mav.MAV_CMD_NAV_SET_YAW_SPEED)
    assert ack.result == mav.MAV_RESULT_UNSUPPORTED
    assert live.ep.guided is None and live.ep.mode == MODES["GUIDED"]
    g.close()


def test_a_refused_arm_says_the_vehicles_reasons(live: LiveEndpoint, capsys: pytest.CaptureFixture[str]) -> None:
    from lfctl.cli import main

    live.ep.params["WP_SPEED"].value = 0.0  # Rover's parameter check will not arm it
    connect = ["gcs", "--connect", f"udpout:127.0.0.1:{live.port}", "--timeout", "3"]
    assert main([*connect, "arm"]) == 1
    out, err = capsys.readouterr()
    assert out == "arm: MAV_RESULT_FAILED\n"
    assert "vehicle: Arm: WP_SPEED too low" in err.splitlines(), err


def test_a_refused_clear_says_the_vehicles_reason(live: LiveEndpoint) -> None:
    from lfctl.errors import MissionProtocolError

    g = live.gcs()
    g.upload(local_mission(SQUARE, HOME))
    assert g.set_mode("AUTO") == mav.MAV_RESULT_ACCEPTED and g.arm(True) == mav.MAV_RESULT_ACCEPTED
    # Rover says why after its MISSION_ACK: the ground station waits a moment for it
    with pytest.raises(
        MissionProtocolError, match=r"^mission clear refused: MAV_MISSION_ERROR \(Mission is running: not cleared\)$"
    ):
        g.clear()
    g.close()


# -- MAVLink FTP with pymavlink's own client (mavftp, MAVProxy's ftp module made a library) --
def ftp_client(live: LiveEndpoint) -> tuple[Any, Any]:
    from pymavlink import mavutil
    from pymavlink.mavftp import MAVFTP

    conn = mavutil.mavlink_connection(f"udpout:127.0.0.1:{live.port}", source_system=255, source_component=190)
    conn.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    assert conn.wait_heartbeat(timeout=5) is not None
    return conn, MAVFTP(conn, 1, 1)


def ftp_put(client: Any, data: bytes, remote: str) -> int:
    client.cmd_put(["-", remote], fh=io.BytesIO(data))
    return int(client.process_ftp_reply("put", timeout=10).error_code)


def ftp_get(client: Any, remote: str, local: Path) -> bytes:
    client.cmd_get([remote, str(local)])
    assert client.process_ftp_reply("get", timeout=10).error_code == 0
    return local.read_bytes()


def test_pymavlink_fetches_the_parameters_with_their_defaults_over_ftp(live: LiveEndpoint, tmp_path: Path) -> None:
    conn, client = ftp_client(live)
    live.ep.params["WP_SPEED"].value = 3.5  # a value the ground station set: its default 2 follows it
    client.cmd_getparams([str(tmp_path / "values.parm"), str(tmp_path / "defaults.parm")])
    assert client.process_ftp_reply("getparams", timeout=10).error_code == 0
    values = dict(line.split(",") for line in (tmp_path / "values.parm").read_text().splitlines())
    defaults = dict(line.split(",") for line in (tmp_path / "defaults.parm").read_text().splitlines())
    assert {k: float(v) for k, v in values.items()} == {k: p.value for k, p in live.ep.params.items()}
    assert float(defaults["WP_SPEED"]) == 2.0 and float(defaults["SYSID_THISMAV"]) == 1
    conn.close()


def test_a_mission_goes_up_and_comes_back_over_ftp_as_by_the_mission_protocol(
    live: LiveEndpoint, tmp_path: Path
) -> None:
    conn, client = ftp_client(live)
    items = local_mission(SQUARE, HOME)
    assert ftp_put(client, list_file(items), "@MISSION/mission.dat") == 0
    assert [(i.seq, i.command, i.x, i.y, i.param1) for i in live.ep.mission] == [
        (i.seq, i.command, i.x, i.y, i.param1) for i in items
    ]
    assert live.ep.statustexts[-1][1] == "Flight plan received"
    g = live.gcs()
    by_protocol = g.download()
    g.close()
    data = ftp_get(client, "@MISSION/mission.dat", tmp_path / "mission.dat")
    assert struct.unpack_from("<HHHHH", data) == (0x763D, 0, 0, 0, len(items))
    unit = mav.MAVLink_mission_item_int_message
    size = unit.unpacker.size
    got = [dict(zip(unit.ordered_fieldnames, unit.unpacker.unpack(data[10 + k * size : 10 + (k + 1) * size]), strict=True))
           for k in range(len(items))]  # fmt: skip
    assert [(f["seq"], f["command"], f["x"], f["y"], f["param1"]) for f in got] == [
        (i.seq, i.command, i.x, i.y, i.param1) for i in by_protocol
    ]
    # a refused file (a latitude past the pole) changes nothing and says which item and why
    bad = [*items[:2], MissionItem(2, items[2].frame, 16, x=950_000_000, y=items[2].y)]
    # (pymavlink's put, as MAVProxy's, does not read the refusal in the reply to its
    # TerminateSession: what its user sees is the vehicle's text)
    ftp_put(client, list_file(bad), "@MISSION/mission.dat")
    assert len(live.ep.mission) == len(items)
    assert live.ep.statustexts[-1][1] == "FTP: @MISSION/mission.dat refused: item 2: MAV_MISSION_INVALID_PARAM5_X"
    conn.close()


def test_parameters_written_as_a_file_are_set_as_param_set_sets_them(live: LiveEndpoint) -> None:
    from lfctl.link.param_server import pack_params
    from lfctl.link.params import Param

    conn, client = ftp_client(live)
    upload = {"WP_SPEED": Param(4.5, 0, 100, "", ""), "WP_RADIUS": Param(-1.0, -10, 10, "", "")}
    data = bytearray(pack_params(upload))
    struct.pack_into("<H", data, 4, len(data))  # an upload's header gives the file's length
    assert ftp_put(client, bytes(data), "@PARAM/param.pck") == 0
    assert live.ep.param("WP_SPEED") == 4.5 and live.ep.param("WP_RADIUS") == 2.0  # -1 is outside 0..100
    assert live.ep.statustexts[-1][1] == "Param upload: 1 of 2 set; refused WP_RADIUS (-1)"
    conn.close()


def test_mavsdk_lists_downloads_compares_and_uploads_over_ftp(live: LiveEndpoint, tmp_path: Path) -> None:
    # MAVSDK's Ftp plugin (its own MAVLink FTP client, C++), as a user's ground software uses it
    pytest.importorskip("mavsdk")
    import asyncio

    from pymavlink.mavftp import MAVFTP

    async def session() -> dict:
        from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
        from mavsdk.asyncio.plugins.ftp.ftp import FtpAsync

        sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
        try:
            await sdk.add_any_connection(f"udpout://127.0.0.1:{live.port}")
            system = await sdk.first_autopilot(timeout_s=15.0)
            ftp = FtpAsync(system)
            out: dict = {"listed": await ftp.list_directory("@MISSION")}
            (tmp_path / "got").mkdir()
            async for _ in ftp.download("@PARAM/param.pck", str(tmp_path / "got"), True):
                pass
            out["same"] = await ftp.are_files_identical(str(tmp_path / "got" / "param.pck"), "@PARAM/param.pck")
            (tmp_path / "up").mkdir()
            (tmp_path / "up" / "mission.dat").write_bytes(list_file(local_mission(SQUARE, HOME)))
            async for _ in ftp.upload(str(tmp_path / "up" / "mission.dat"), "@MISSION"):
                pass
            return out
        finally:
            sdk.destroy()

    out = asyncio.run(asyncio.wait_for(session(), 60))
    assert sorted(e.name for e in out["listed"].entries) == ["fence.dat", "mission.dat", "rally.dat"]
    decoded = MAVFTP.ftp_param_decode((tmp_path / "got" / "param.pck").read_bytes())
    assert decoded is not None and {n.decode(): v for n, v, _ in decoded.params} == pytest.approx(
        {k: p.value for k, p in live.ep.params.items()}, rel=1e-7
    )  # (float32 in the file)
    assert out["same"]  # its CRC-32 of the local copy is the vehicle's
    assert wait_until(lambda: len(live.ep.mission) == len(SQUARE) + 1)


def test_two_clients_on_one_port_keep_their_own_rates_and_count_no_packet_lost() -> None:
    # a rehearsal's port: MAVProxy asks for every group at 4 Hz as it connects, lfctl follow
    # for its odometry at 20 Hz; each keeps its rate (as on a Rover's two links), and each
    # counts every packet it gets in sequence (pymavlink's mav_loss, MAVProxy's link quality)
    from pymavlink import mavutil

    live = LiveEndpoint(channels=True)
    clients = {
        name: mavutil.mavlink_connection(f"udpout:127.0.0.1:{live.port}", source_system=sysid, source_component=comp)
        for name, sysid, comp in (("mavproxy", 255, 190), ("follow", 1, 191))
    }
    gpi = mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
    try:
        for c in clients.values():
            c.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            assert c.wait_heartbeat(timeout=5) is not None
        clients["mavproxy"].mav.request_data_stream_send(1, 1, mav.MAV_DATA_STREAM_ALL, 4, 1)
        clients["follow"].mav.command_long_send(1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, gpi, 50000, 0, 0, 0, 0, 0)
        ack = clients["follow"].recv_match(type="COMMAND_ACK", blocking=True, timeout=5)
        assert ack is not None and ack.result == mav.MAV_RESULT_ACCEPTED
        # GLOBAL_POSITION_INT's own clock: from half a second after the ACK, for 3 s
        start_ms = live.ep._boot_ms() + 500
        stamps: dict[str, list[int]] = {name: [] for name in clients}

        def window_read() -> bool:
            for name, c in clients.items():
                while (m := c.recv_match(blocking=False)) is not None:
                    if m.get_type() == "GLOBAL_POSITION_INT" and m.time_boot_ms >= start_ms:
                        stamps[name].append(m.time_boot_ms)
            return all(s and s[-1] >= start_ms + 3000 for s in stamps.values())

        assert wait_until(window_read, timeout_s=30)
        counts = {name: sum(t < start_ms + 3000 for t in s) for name, s in stamps.items()}
        assert 45 <= counts["follow"] <= 61 and 9 <= counts["mavproxy"] <= 13, counts  # 60 and 12 asked for
        assert {name: c.mav_loss for name, c in clients.items()} == {"mavproxy": 0, "follow": 0}
    finally:
        for c in clients.values():
            c.close()
        live.close()


def test_mavsdk_finds_the_camera_component_and_starts_and_stops_its_stream() -> None:
    # MAVSDK's Camera plugin, as a user's ground software uses it: the camera found with its
    # vendor, model and size; its stream stopped and started; VIDEO, its one mode, taken;
    # what it cannot do (a photo) refused at once
    pytest.importorskip("mavsdk")
    import asyncio

    live = LiveEndpoint(camera=True)
    assert live.camera is not None
    heard: list[bool] = []
    live.camera.on_streaming = heard.append

    async def session() -> dict:
        from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
        from mavsdk.asyncio.plugins.camera.camera import CameraAsync
        from mavsdk.plugins.camera import CameraError, Mode

        async def result(coro: Any) -> str:
            try:
                await coro
            except CameraError as exc:
                return str(exc.result.name)
            return "SUCCESS"

        sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
        try:
            await sdk.add_any_connection(f"udpout://127.0.0.1:{live.port}")
            system = await sdk.first_autopilot(timeout_s=15.0)
            cam = CameraAsync(system)
            cameras: list = []
            for _ in range(60):  # found within a second or two
                cameras = (await cam.camera_list()).cameras
                if cameras:
                    break
                await asyncio.sleep(0.25)
            out: dict = {"cameras": [(c.component_id, c.vendor_name, c.model_name, c.horizontal_resolution_px,
                                      c.vertical_resolution_px) for c in cameras]}  # fmt: skip
            out["stop"] = await result(cam.stop_video_streaming(100, 1))
            out["start"] = await result(cam.start_video_streaming(100, 1))
            out["stream 5"] = await result(cam.start_video_streaming(100, 5))
            out["video mode"] = await result(cam.set_mode(100, Mode.VIDEO))
            out["photo mode"] = await result(cam.set_mode(100, Mode.PHOTO))
            out["photo"] = await result(cam.take_photo(100))
            return out
        finally:
            sdk.destroy()

    try:
        out = asyncio.run(asyncio.wait_for(session(), 90))
    finally:
        live.close()
    assert out["cameras"] == [(100, "lfctl", "follower camera", 640, 480)]
    assert (out["stop"], out["start"]) == ("SUCCESS", "SUCCESS")
    assert wait_until(lambda: heard[-2:] == [False, True], 5.0), heard
    assert (out["stream 5"], out["video mode"], out["photo mode"]) == ("DENIED", "SUCCESS", "DENIED")
    assert out["photo"] == "ACTION_UNSUPPORTED"
