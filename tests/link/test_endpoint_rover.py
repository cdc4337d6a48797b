"""The endpoint answers as ArduPilot Rover does and survives anything on the wire: hostile
values, unknown messages, forged signatures, floods; FENCE and RALLY kept apart from the
MISSION; GUIDED in every setpoint form. In memory, driven by pymavlink frames."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import struct
import time
from collections.abc import Callable
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl import __version__
from lfctl.bench.fuzz import datagrams
from lfctl.frames import ned_to_geodetic
from lfctl.link.endpoint import (
    MAX_DATAGRAMS_PER_TICK,
    MAX_PASSED_ON_PER_TICK,
    MAX_ROUTES,
    MODES,
    PASSED_ON_MEMORY_S,
    ROUTE_IDLE_S,
    VehicleEndpoint,
    packet_record,
)
from lfctl.link.port import pack_next
from lfctl.link.signing import setup_signing, signing_clock
from lfctl.link.transport import MAX_PEERS, MemoryLink

HOME = (12.9602, 77.6690, 900.0)
STATE = {"north_m": 1.0, "east_m": 2.0, "yaw_rad": 0.5, "speed_mps": 0.2, "yaw_rate_radps": 0.0}
NAN, INF = math.nan, math.inf


class Network:
    """A stand-in for an endpoint's UDP side: what it is given to send goes to the callables
    (``send`` returns the copies sent); ``peers`` are the ones it reaches."""

    def __init__(
        self,
        send_to: Callable[[bytes, object], object] = lambda data, addr: None,
        send: Callable[..., int] = lambda data, exclude=(): 0,
        peers: list[object] | None = None,
    ) -> None:
        self.send_to, self.send, self.peers = send_to, send, peers or []

    def reachable(self) -> list[object]:
        return list(self.peers)


def _sends_of(kinds: tuple[str, ...], into: list[tuple[str, object]]) -> Callable[[bytes, object], None]:
    """A ``Network.send_to`` that keeps (message name, peer) of each packet of ``kinds`` (the
    autopilot's streams left out)."""
    parser = mav.MAVLink(None)

    def sent(data: bytes, addr: object) -> None:
        kind = parser.parse_buffer(data)[0].get_type()
        if kind in kinds:
            into.append((kind, addr))

    return sent


class Bench:
    """An endpoint in memory, a ground station's MAVLink codec on the other end, and every
    packet the endpoint logs run through the recorder's JSON encoding."""

    def __init__(self, signing_key: bytes | None = None, **kw: object) -> None:
        self.a, self.b = MemoryLink.pair("ep", "gcs")
        self.records: list[str] = []
        self.ep = VehicleEndpoint("v", 1, self.a, HOME, tap=self._tap, signing_key=signing_key, **kw)  # type: ignore[arg-type]
        self.gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
        self.parser = mav.MAVLink(None)
        self.parser.robust_parsing = True
        self.t = 0.0
        self.state = STATE  # the vehicle, for ticks that do not give one

    def _tap(self, direction: str, msg: object, raw: bytes, to: object = None) -> None:
        # the recorder's encoding: allow_nan=False, no default: must never raise
        self.records.append(json.dumps(packet_record(direction, msg, raw, to), allow_nan=False))

    def send(self, msg: object, memory: bool = True) -> None:
        self.b.send(msg.pack(self.gcs))  # type: ignore[attr-defined]

    def raw(self, data: bytes) -> None:
        self.b.send(data)

    def tick(self, dt: float = 0.02, state: dict[str, float] | None = None) -> list[object]:
        self.t += dt
        self.ep.tick(self.t, state or self.state)
        out = []
        for data, _addr in self.b.recv(100000):
            out += [m for m in (self.parser.parse_buffer(data) or []) if m.get_type() != "BAD_DATA"]
        return out

    def command(self, cmd: int, *p: float, long: bool = True) -> int:
        params = [*p, *([0.0] * (7 - len(p)))]
        if long:
            self.send(mav.MAVLink_command_long_message(1, 1, cmd, 0, *params))
        else:
            x, y = (int(params[4]), int(params[5])) if all(math.isfinite(v) for v in params[4:6]) else (0, 0)
            self.send(
                mav.MAVLink_command_int_message(1, 1, mav.MAV_FRAME_GLOBAL_INT, cmd, 0, 0, *params[:4], x, y, params[6])
            )
        acks = [m for m in self.tick() if m.get_type() == "COMMAND_ACK" and m.command == cmd]
        assert len(acks) == 1, f"{len(acks)} acks for command {cmd}"
        return int(acks[0].result)

    def command_to(self, component: int, cmd: int, *p: float) -> int:
        """A COMMAND_LONG to ``component`` of this system: its ACK's result."""
        self.send(mav.MAVLink_command_long_message(1, component, cmd, 0, *p, *([0.0] * (7 - len(p)))))
        (ack,) = [m for m in self.tick() if m.get_type() == "COMMAND_ACK" and m.command == cmd]
        return int(ack.result)

    def set_mode(self, name: str) -> int:
        return self.command(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES[name])


@pytest.fixture
def bench() -> Bench:
    return Bench()


# -- hostile values --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("cmd", "params"),
    [
        (mav.MAV_CMD_DO_SET_MODE, (NAN, 15)),
        (mav.MAV_CMD_DO_SET_MODE, (1, NAN)),
        (mav.MAV_CMD_DO_SET_MODE, (1, INF)),
        (mav.MAV_CMD_REQUEST_MESSAGE, (NAN,)),
        (mav.MAV_CMD_REQUEST_MESSAGE, (-INF,)),
        (mav.MAV_CMD_SET_MESSAGE_INTERVAL, (NAN, 1000)),
        (mav.MAV_CMD_SET_MESSAGE_INTERVAL, (mav.MAVLINK_MSG_ID_ATTITUDE, NAN)),
        (mav.MAV_CMD_SET_MESSAGE_INTERVAL, (mav.MAVLINK_MSG_ID_ATTITUDE, -5)),
        (mav.MAV_CMD_MISSION_START, (NAN, 0)),
        (mav.MAV_CMD_MISSION_START, (1, 3)),
        (mav.MAV_CMD_DO_SET_MISSION_CURRENT, (NAN,)),
        (mav.MAV_CMD_DO_SET_MISSION_CURRENT, (1e30,)),
        (mav.MAV_CMD_COMPONENT_ARM_DISARM, (NAN,)),
        (mav.MAV_CMD_COMPONENT_ARM_DISARM, (0.5,)),
        (mav.MAV_CMD_DO_CHANGE_SPEED, (1, INF)),
        (mav.MAV_CMD_DO_CHANGE_SPEED, (NAN, 1)),
        (mav.MAV_CMD_DO_CHANGE_SPEED, (2, 1)),  # climb speed: not a rover's
        (mav.MAV_CMD_DO_SET_REVERSE, (NAN,)),
        (mav.MAV_CMD_DO_FENCE_ENABLE, (NAN,)),
        (mav.MAV_CMD_DO_REPOSITION, (NAN, 1, 0, 0, NAN, NAN, 0)),
    ],
)
def test_a_command_with_values_that_are_not_numbers_is_denied_and_nothing_changes(
    bench: Bench, cmd: int, params: tuple[float, ...]
) -> None:
    bench.tick()
    before = (bench.ep.mode, bench.ep.armed, dict(bench.ep._rates.intervals), bench.ep.current_seq)
    # refused (COMPONENT_ARM_DISARM with neither 0 nor 1, and DO_REPOSITION as a COMMAND_LONG:
    # UNSUPPORTED, as Rover)
    refused = (
        (mav.MAV_RESULT_UNSUPPORTED,)
        if cmd in (mav.MAV_CMD_COMPONENT_ARM_DISARM, mav.MAV_CMD_DO_REPOSITION)
        else (mav.MAV_RESULT_DENIED, mav.MAV_RESULT_FAILED)
    )
    assert bench.command(cmd, *params) in refused
    assert (bench.ep.mode, bench.ep.armed, dict(bench.ep._rates.intervals), bench.ep.current_seq) == before
    assert bench.ep.stats.handler_errors == 0


def upload(bench: Bench, items: list, mission_type: int = mav.MAV_MISSION_TYPE_MISSION, as_float: bool = False) -> int:
    """Upload like a ground station: answer each request; the final MISSION_ACK's result."""
    bench.send(mav.MAVLink_mission_count_message(1, 1, len(items), mission_type))
    for _ in range(len(items) + 3):
        for m in bench.tick():
            if m.get_type() == "MISSION_ACK":
                return int(m.type)
            if m.get_type() == "MISSION_REQUEST":
                it = items[m.seq]
                if as_float:
                    bench.send(
                        mav.MAVLink_mission_item_message(
                            1, 1, it.seq, it.frame, it.command, 0, 1, it.param1, it.param2, it.param3, it.param4,
                            it.x / 1e7, it.y / 1e7,
                            it.z, mission_type,
                        )
                    )  # fmt: skip
                else:
                    bench.send(
                        mav.MAVLink_mission_item_int_message(
                            1, 1, it.seq, it.frame, it.command, 0, 1, it.param1, it.param2, it.param3, it.param4,
                            it.x, it.y, it.z, mission_type,
                        )
                    )  # fmt: skip
    raise AssertionError("no MISSION_ACK")


class Item:
    def __init__(self, seq: int, command: int, p1: float = 0, p2: float = 0, x: float = 129602000, y: float = 776690000,
                 frame: int = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, p4: float = 0) -> None:  # fmt: skip
        self.seq, self.command, self.param1, self.param2, self.param3, self.param4 = seq, command, p1, p2, 0.0, p4
        self.x, self.y, self.z, self.frame = x, y, 0.0, frame


def good_mission(n: int = 3) -> list[Item]:
    return [Item(k, mav.MAV_CMD_NAV_WAYPOINT, y=776690000 + 100 * k) for k in range(n)]


@pytest.mark.parametrize(
    ("bad", "result"),
    [
        (Item(2, mav.MAV_CMD_DO_JUMP, p1=NAN, p2=1), mav.MAV_MISSION_INVALID_PARAM1),
        (Item(2, mav.MAV_CMD_DO_JUMP, p1=INF, p2=1), mav.MAV_MISSION_INVALID_PARAM1),
        (Item(2, mav.MAV_CMD_DO_JUMP, p1=1, p2=NAN), mav.MAV_MISSION_INVALID_PARAM2),
        (Item(2, mav.MAV_CMD_DO_JUMP, p1=1, p2=INF), mav.MAV_MISSION_INVALID_PARAM2),
        (Item(2, mav.MAV_CMD_DO_CHANGE_SPEED, p1=1, p2=INF), mav.MAV_MISSION_INVALID_PARAM2),
        (Item(2, mav.MAV_CMD_DO_CHANGE_SPEED, p1=1, p2=NAN), mav.MAV_MISSION_INVALID_PARAM2),
        (Item(2, mav.MAV_CMD_DO_CHANGE_SPEED, p1=1, p2=101), mav.MAV_MISSION_INVALID_PARAM2),  # lfctl's limit
        (Item(2, mav.MAV_CMD_NAV_WAYPOINT, p1=NAN), mav.MAV_MISSION_INVALID_PARAM1),
        # a jump to item 0 or past the mission: MissionItemProtocol_Waypoints::append_item's ERROR
        (Item(2, mav.MAV_CMD_DO_JUMP, p1=9, p2=1), mav.MAV_MISSION_ERROR),
        (Item(2, mav.MAV_CMD_DO_JUMP, p1=0.5, p2=1), mav.MAV_MISSION_ERROR),
    ],
)
def test_a_mission_item_that_is_not_a_number_is_refused_and_the_old_mission_stays(
    bench: Bench, bad: Item, result: int
) -> None:
    assert upload(bench, good_mission()) == mav.MAV_MISSION_ACCEPTED
    old = list(bench.ep.mission)
    items = good_mission()
    items.insert(2, bad)
    for k, it in enumerate(items):
        it.seq = k
    assert upload(bench, items) == result
    assert bench.ep.mission == old and bench.ep.stats.handler_errors == 0


@pytest.mark.parametrize(
    ("x", "y", "result"), [(NAN, 77.6, mav.MAV_MISSION_INVALID_PARAM5_X), (12.9, INF, mav.MAV_MISSION_INVALID_PARAM6_Y)]
)
def test_a_float_mission_item_at_nan_or_inf_is_refused(bench: Bench, x: float, y: float, result: int) -> None:
    items = good_mission()
    items[1].x, items[1].y = x * 1e7, y * 1e7
    assert upload(bench, items, as_float=True) == result
    assert bench.ep.stats.handler_errors == 0


def test_nan_in_a_parameter_qgroundcontrol_leaves_unset_is_taken(bench: Bench) -> None:
    items = good_mission()
    items[1].param4 = NAN  # QGroundControl's "no yaw"
    assert upload(bench, items) == mav.MAV_MISSION_ACCEPTED


def test_unknown_message_ids_and_nan_fields_are_logged_not_fatal(bench: Bench) -> None:
    # an unknown message id decodes with a bytearray payload; a NaN float field: both once
    # crashed the recorder's JSON encoding
    frame = bytearray(mav.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(bench.gcs))
    frame[7:10] = (60000).to_bytes(3, "little")  # a message id nobody defines
    crc = mav.x25crc(frame[1:-2])
    crc.accumulate(struct.pack("B", 0))  # CRC extra of an unknown id: pymavlink takes 0
    frame[-2:] = struct.pack("<H", crc.crc)
    bench.raw(bytes(frame))
    bench.send(mav.MAVLink_named_value_float_message(0, b"x", NAN))
    bench.send(mav.MAVLink_attitude_message(0, INF, -INF, NAN, 0, 0, 0))
    bench.tick()
    assert bench.ep.stats.handler_errors == 0 and len(bench.records) >= 2
    assert any('"nan"' in r for r in bench.records)


def test_thousands_of_fuzzed_datagrams_crash_nothing_and_the_vehicle_still_answers() -> None:
    bench = guided_bench()  # setpoints are acted on (until a fuzzed command changes the mode)
    sent = before = bench.ep.stats.datagrams  # the mode command's
    for chunk_start in range(0, 3000, 200):
        for d in datagrams(chunk_start, 200):
            bench.raw(d)
            sent += 1
        bench.tick()
        bench.tick()
    assert sent - before > 2500 and bench.ep.stats.datagrams == sent  # every one read
    assert bench.ep.stats.handler_errors == bench.ep.stats.send_errors == 0
    # still a vehicle: a mode change and a mission upload work
    bench.ep.force_mode("HOLD")
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert upload(bench, good_mission()) == mav.MAV_MISSION_ACCEPTED


def test_inbound_work_per_tick_is_bounded(bench: Bench) -> None:
    for _ in range(1000):
        bench.send(mav.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))
    bench.tick()
    assert bench.ep.stats.datagrams == MAX_DATAGRAMS_PER_TICK  # the rest wait for the next tick
    bench.tick()
    assert bench.ep.stats.datagrams == 2 * MAX_DATAGRAMS_PER_TICK
    for _ in range(3):
        bench.tick()
    big = b"\xfd" + b"\x00" * 9000
    bench.raw(big)
    bench.tick(0.0)
    assert bench.ep.stats.dropped >= 1  # no ground station sends a datagram that long


# -- signing -----------------------------------------------------------------------------------

KEY = bytes(range(32))


def signed_codec(link_id: int = 0, timestamp: int | None = None) -> mav.MAVLink:
    m = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    setup_signing(m, KEY)
    m.signing.link_id = link_id
    if timestamp is not None:
        m.signing.timestamp = timestamp
    return m


def forged(msg: object, codec: mav.MAVLink) -> bytes:
    frame = bytearray(msg.pack(codec))  # type: ignore[attr-defined]
    frame[-6:] = b"\x00" * 6  # a signature only the key could make
    return bytes(frame)


class UdpAddr(MemoryLink):
    """An in-memory link whose datagrams look as if they came over UDP (signatures checked)."""

    def recv(self, max_datagrams: int = 256) -> list[tuple[bytes, tuple[str, int]]]:
        return [(d, ("127.0.0.1", 40000)) for d, _a in super().recv(max_datagrams)]


def signed_bench() -> Bench:
    b = Bench(signing_key=KEY)
    a, other = UdpAddr("ep"), MemoryLink("gcs")
    a.other, other.other = other, a
    b.a, b.b, b.ep.link = a, other, a
    return b


def test_a_forged_far_future_packet_does_not_lock_the_key_holder_out() -> None:
    b = signed_bench()
    gcs = signed_codec()
    attacker = signed_codec(timestamp=signing_clock(time.time()) + 10**12)  # decades ahead
    b.raw(forged(mav.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3), attacker))
    b.tick()
    assert b.ep.stats.messages == 0
    b.raw(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0).pack(gcs))
    b.tick()
    assert b.ep.armed  # the genuine sender is still heard


def test_a_forged_copy_sent_ahead_does_not_burn_the_genuine_packet() -> None:
    b = signed_bench()
    gcs = signed_codec()
    genuine = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0).pack(gcs)
    copy = bytearray(genuine)
    copy[-6:] = b"\xff" * 6  # same stream, same timestamp, wrong signature
    b.raw(bytes(copy))
    b.raw(genuine)
    b.tick()
    assert b.ep.armed


def test_a_replay_and_an_old_capture_are_refused() -> None:
    b = signed_bench()
    gcs = signed_codec()
    arm = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0).pack(gcs)
    disarm = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0).pack(gcs)
    b.raw(arm)
    b.raw(disarm)
    b.raw(arm)  # replayed: its timestamp is behind the stream's
    b.tick()
    assert not b.ep.armed
    old = signed_codec(link_id=3, timestamp=signing_clock(time.time() - 3600))  # a capture from an hour ago
    b.raw(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0).pack(old))
    b.tick()
    assert not b.ep.armed


def test_setup_signing_changes_the_key_only_over_a_signed_link() -> None:
    b = signed_bench()
    new_key = bytes(31) + b"\x07"
    plain = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    b.raw(mav.MAVLink_setup_signing_message(1, 1, list(new_key), signing_clock(time.time())).pack(plain))
    b.tick()
    assert b.ep.signed_parser is not None and b.ep.signed_parser.signing.secret_key == KEY  # unsigned: ignored
    b.raw(mav.MAVLink_setup_signing_message(1, 1, list(new_key), signing_clock(time.time())).pack(signed_codec()))
    b.tick()
    assert b.ep.signed_parser.signing.secret_key == new_key
    fresh = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    setup_signing(fresh, new_key)
    b.raw(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0).pack(fresh))
    b.tick()
    assert b.ep.armed


# -- FENCE and RALLY -----------------------------------------------------------------------------


def fence_square(half_m: float = 5.0) -> list[Item]:
    """An inclusion polygon: a square of 2 * half_m around home."""
    dlat, dlon = half_m / 111_320 * 1e7, half_m / (111_320 * math.cos(math.radians(HOME[0]))) * 1e7
    corners = [(1, 1), (1, -1), (-1, -1), (-1, 1)]
    lat0, lon0 = HOME[0] * 1e7, HOME[1] * 1e7
    return [
        Item(k, mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, p1=4, x=int(lat0 + a * dlat), y=int(lon0 + b * dlon), frame=mav.MAV_FRAME_GLOBAL_INT)
        for k, (a, b) in enumerate(corners)
    ]  # fmt: skip


def download(bench: Bench, mission_type: int) -> list[object]:
    bench.send(mav.MAVLink_mission_request_list_message(1, 1, mission_type))
    (count,) = [m for m in bench.tick() if m.get_type() == "MISSION_COUNT"]
    assert count.mission_type == mission_type
    items = []
    for seq in range(count.count):
        bench.send(mav.MAVLink_mission_request_int_message(1, 1, seq, mission_type))
        (it,) = [m for m in bench.tick() if m.get_type() == "MISSION_ITEM_INT"]
        assert it.mission_type == mission_type
        items.append(it)
    return items


def test_fence_and_rally_are_kept_apart_from_the_mission(bench: Bench) -> None:
    assert upload(bench, good_mission(4)) == mav.MAV_MISSION_ACCEPTED
    assert upload(bench, fence_square(), mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_ACCEPTED
    rally = [Item(0, mav.MAV_CMD_NAV_RALLY_POINT, x=129602100, y=776690100, frame=mav.MAV_FRAME_GLOBAL_INT)]
    assert upload(bench, rally, mav.MAV_MISSION_TYPE_RALLY) == mav.MAV_MISSION_ACCEPTED
    assert len(download(bench, mav.MAV_MISSION_TYPE_MISSION)) == 4
    assert [it.command for it in download(bench, mav.MAV_MISSION_TYPE_FENCE)] == [5001] * 4
    assert [it.command for it in download(bench, mav.MAV_MISSION_TYPE_RALLY)] == [5100]
    assert len(bench.ep.rally) == 1
    bench.send(mav.MAVLink_mission_clear_all_message(1, 1, mav.MAV_MISSION_TYPE_FENCE))
    acks = [m for m in bench.tick() if m.get_type() == "MISSION_ACK"]
    assert acks[0].type == mav.MAV_MISSION_ACCEPTED and acks[0].mission_type == mav.MAV_MISSION_TYPE_FENCE
    assert len(download(bench, mav.MAV_MISSION_TYPE_MISSION)) == 4  # untouched
    assert download(bench, mav.MAV_MISSION_TYPE_FENCE) == [] and len(download(bench, mav.MAV_MISSION_TYPE_RALLY)) == 1


def test_a_mission_item_in_a_fence_upload_and_a_broken_polygon_are_refused(bench: Bench) -> None:
    assert upload(bench, good_mission(), mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_UNSUPPORTED
    # the whole list is checked when its last item has come, as AC_PolyFence_loader's
    # validate_fence: MAV_MISSION_ERROR, Rover's words for the problem in a STATUSTEXT
    short = fence_square()[:3]  # says 4 vertices, has 3
    assert upload(bench, short, mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_ERROR
    texts = [t for _, t in bench.ep.statustexts]
    assert texts[-3:] == [
        "Incorrect item count",
        "Fence validation failed",
        "Fence rejected at item 2: MAV_MISSION_ERROR",
    ]
    backs = [Item(k, mav.MAV_CMD_NAV_FENCE_RETURN_POINT, frame=mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT) for k in (4, 5)]
    assert upload(bench, [*fence_square(), *backs], mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_ERROR
    assert "Multiple return points" in [t for _, t in bench.ep.statustexts]
    in_mission_frame = [Item(0, mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, p1=5, frame=mav.MAV_FRAME_MISSION)]
    assert upload(bench, in_mission_frame, mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_UNSUPPORTED_FRAME
    assert bench.ep.fence.empty


def test_a_fence_breach_is_reported_and_sends_the_vehicle_home(bench: Bench) -> None:
    assert upload(bench, fence_square(5.0), mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_ACCEPTED
    bench.ep.params["FENCE_ENABLE"].value = 1
    bench.ep.set_armed(True)
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    inside = dict(STATE, north_m=1.0, east_m=1.0)
    bench.tick(state=inside)
    assert bench.ep.fence_breach is None
    outside = dict(STATE, north_m=7.0, east_m=1.0)
    msgs = bench.tick(state=outside)
    assert bench.ep.fence_breach == "polygon" and bench.ep.mode == MODES["RTL"]
    # Rover's fence_check says nothing of the breach; its switch to RTL starts AC_Fence's
    # manual recovery, which is said (manual_recovery_start, at INFO)
    said = [(m.severity, m.text) for m in msgs if m.get_type() == "STATUSTEXT"]
    assert said == [(mav.MAV_SEVERITY_INFO, "Manual recovery started")]
    status = [m for m in msgs if m.get_type() == "FENCE_STATUS"]
    assert status and status[-1].breach_status == 1 and status[-1].breach_count == 1
    assert status[-1].breach_mitigation == mav.FENCE_MITIGATE_NONE  # GCS_Fence, a vehicle with AC_Avoid
    back = [m for m in bench.tick(state=inside) if m.get_type() == "STATUSTEXT"]
    assert bench.ep.fence_breach is None and back == []  # cleared without a word too


@pytest.mark.parametrize(
    ("action", "points", "mode", "armed"),
    [(0, 300, "GUIDED", True), (2, 300, "HOLD", True), (3, 300, "SMART_RTL", True), (3, 0, "RTL", True),
     (4, 300, "SMART_RTL", True), (4, 0, "HOLD", True), (5, 300, "GUIDED", False), (6, 300, "HOLD", True)],
)  # fmt: skip
def test_a_fence_breach_takes_fence_action(bench: Bench, action: int, points: int, mode: str, armed: bool) -> None:
    # Rover's fence_check: the same FailsafeAction chain as a failsafe's (1 is the test above);
    # SRTL_POINTS 0 as the autopilot starts keeps no way back, so SmartRTL cannot start
    bench.ep.params["SRTL_POINTS"].value = points
    bench.ep.params["FENCE_ACTION"].value = action
    assert upload(bench, fence_square(5.0), mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_ACCEPTED
    bench.ep.params["FENCE_ENABLE"].value = 1
    bench.ep.set_armed(True)
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    bench.tick(state=dict(STATE, north_m=1.0, east_m=1.0))
    bench.tick(state=dict(STATE, north_m=7.0, east_m=1.0))
    assert bench.ep.fence_breach == "polygon" and (bench.ep.mode, bench.ep.armed) == (MODES[mode], armed)
    assert not any("LOITER" in t for _, t in bench.ep.statustexts)  # (no LOITER tried: straight to HOLD)


def test_a_circle_breach_is_met_again_20_m_farther_out_and_past_100_m_the_action_is_hold(bench: Bench) -> None:
    # Rover's fence_check on AC_Fence::check: after a circle breach a backup circle 20 m
    # farther out is breached again (the action again), once the 10 s of manual recovery a
    # mode change starts have passed; more than 100 m outside the fence
    # (AC_FENCE_GIVE_UP_DISTANCE) the action is HOLD whatever FENCE_ACTION says
    ep = bench.ep
    ep.params["FENCE_ENABLE"].value, ep.params["FENCE_TYPE"].value, ep.params["FENCE_RADIUS"].value = 1, 2, 30
    ep.set_armed(True)
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED

    def at(north_m: float, dt: float = 0.02) -> list[object]:
        bench.state = dict(STATE, north_m=north_m, east_m=0.0)  # where the commands' ticks find it too
        return bench.tick(dt)

    counted = [ep.fence_breaches]

    def breached(_msgs: list[object]) -> int:
        """The breaches counted since the last call (FENCE_STATUS's breach_count)."""
        new, counted[0] = ep.fence_breaches - counted[0], ep.fence_breaches
        return new

    at(10.0)
    assert breached(at(31.0)) == 1 and ep.mode == MODES["RTL"] and ep.fence_breaches == 1
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED  # the ground station takes it on outwards
    assert breached(at(45.0)) == 0 and ep.mode == MODES["GUIDED"]  # inside the backup circle (51 m)
    # past it, within the 10 s of recovery: counted (Rover 4.6's AC_Fence::check records the
    # breach before it looks at the recovery), not acted on
    assert breached(at(51.5)) == 1 and ep.mode == MODES["GUIDED"]
    # the checks go on during the recovery (AC_Fence's last step is the recovery's): the
    # backup circle moved out to 71.5 m
    assert breached(at(52.0, dt=10.0)) == 0 and ep.mode == MODES["GUIDED"]
    assert breached(at(72.0)) == 1 and ep.mode == MODES["RTL"] and ep.fence_breaches == 3
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert breached(at(140.0, dt=10.0)) == 1 and ep.mode == MODES["HOLD"]  # 110 m outside: HOLD, not RTL
    at(10.0)  # back inside: cleared, and the next breach is a first one again
    assert ep.fence_breach is None and ep._circle_backup_m == 0.0
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert breached(at(31.0, dt=10.0)) == 1 and ep.mode == MODES["RTL"]


# -- GUIDED -------------------------------------------------------------------------------------


def guided_bench() -> Bench:
    b = Bench()
    b.ep.set_armed(True)
    assert b.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    return b


def target_of(b: Bench, msg: object) -> object:
    b.send(msg)
    b.tick()
    return b.ep.guided


@pytest.mark.parametrize(
    ("frame", "mask", "xyz", "v", "yaw", "rate", "expect"),
    [
        # the companion's form: velocity + yaw rate in the body frame
        (mav.MAV_FRAME_BODY_NED, 1479, (0, 0), (0.3, 0), 0, 0.2, ("rate", 0.3, 0.2)),
        (mav.MAV_FRAME_BODY_NED, 1479, (0, 0), (-0.3, 0), 0, 0.2, ("rate", -0.3, 0.2)),  # vx < 0: backwards
        # velocity only: heading from the velocity's direction (LOCAL: absolute)
        (mav.MAV_FRAME_LOCAL_NED, 0b110111000111, (0, 0), (0, 0.4), 0, 0, ("heading", 0.4, math.pi / 2)),
        # velocity + heading
        (mav.MAV_FRAME_LOCAL_NED, 0b101111000111, (0, 0), (0.2, 0), 1.0, 0, ("heading", 0.2, 1.0)),
        # heading only
        (mav.MAV_FRAME_LOCAL_NED, 0b101111111111, (0, 0), (0, 0), -1.0, 0, ("heading", 0.0, -1.0)),
        # turn rate only
        (mav.MAV_FRAME_LOCAL_NED, 0b011111111111, (0, 0), (0, 0), 0, 0.3, ("rate", 0.0, 0.3)),
        # a position in the local frame, and an offset from the vehicle
        (mav.MAV_FRAME_LOCAL_NED, 0b110111111000, (10, 5), (0, 0), 0, 0, ("location", 10.0, 5.0)),
        (mav.MAV_FRAME_LOCAL_OFFSET_NED, 0b110111111000, (2, 0), (0, 0), 0, 0, ("location", 3.0, 2.0)),
    ],
)
def test_every_setpoint_form_rover_takes(frame, mask, xyz, v, yaw, rate, expect) -> None:  # type: ignore[no-untyped-def]
    b = guided_bench()
    g = target_of(
        b,
        mav.MAVLink_set_position_target_local_ned_message(
            0, 1, 1, frame, mask, xyz[0], xyz[1], 0, v[0], v[1], 0, 0, 0, 0, yaw, rate
        ),
    )
    assert g is not None and g.kind == expect[0]
    got = {
        "rate": (g.speed_mps, g.yaw_rate_radps),
        "heading": (g.speed_mps, g.heading_rad),
        "location": (g.north_m, g.east_m),
    }[g.kind]
    assert got == pytest.approx(expect[1:], abs=1e-6)


def test_a_body_frame_velocity_is_turned_by_the_vehicle_heading() -> None:
    b = guided_bench()
    g = target_of(
        b,
        mav.MAVLink_set_position_target_local_ned_message(
            0, 1, 1, mav.MAV_FRAME_BODY_NED, 0b110111000111, 0, 0, 0, 0.3, 0, 0, 0, 0, 0, 0, 0
        ),
    )
    assert g.kind == "heading" and g.heading_rad == pytest.approx(STATE["yaw_rad"])


def test_acceleration_not_ignored_is_refused_with_rovers_message() -> None:
    b = guided_bench()
    b.send(
        mav.MAVLink_set_position_target_local_ned_message(
            0, 1, 1, mav.MAV_FRAME_BODY_NED, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0
        )
    )
    msgs = b.tick()
    assert b.ep.guided is None
    texts = [m for m in msgs if m.get_type() == "STATUSTEXT"]
    # longer than 50 bytes: two chunks with one id, as ArduPilot sends it
    assert len(texts) == 2 and texts[0].id == texts[1].id != 0 and (texts[0].chunk_seq, texts[1].chunk_seq) == (0, 1)
    assert "".join(t.text for t in texts) == "Ignoring SET_POSITION_TARGET_LOCAL_NED; set ACC_IGNORE in mask"


@pytest.mark.parametrize(
    ("home", "x", "y", "taken"),
    [
        ((-16.8, 179.9995, 10.0), 0.0, 100.0, True),  # across the 180th meridian (Taveuni): a place
        ((89.9999, 10.0, 0.0), 0.0, 5000.0, True),  # beside the pole: east is still somewhere
        (HOME, 1e38, 0.0, False),
        (HOME, 0.0, -2.1e7, False),  # farther than half the Earth
        (HOME, 9e6, 0.0, False),  # past the North Pole
    ],
)
def test_a_location_target_is_refused_only_off_the_earth(home, x: float, y: float, taken: bool) -> None:  # type: ignore[no-untyped-def]
    b = guided_bench()
    b.ep.home = home
    mask = 0b110111111000  # the position only
    b.send(
        mav.MAVLink_set_position_target_local_ned_message(
            0, 1, 1, mav.MAV_FRAME_LOCAL_NED, mask, x, y, 0, 0, 0, 0, 0, 0, 0, 0, 0
        )
    )
    msgs = b.tick()
    for _ in range(5):  # and it is sent as Rover's destination, packed
        msgs += b.tick(0.1)
    said = "".join(m.text for m in msgs if m.get_type() == "STATUSTEXT")
    if taken:
        assert b.ep.guided is not None and (b.ep.guided.north_m, b.ep.guided.east_m) == (x, y) and not said
    else:
        assert b.ep.guided is None
        assert said == f"Ignoring SET_POSITION_TARGET_LOCAL_NED; target {x:.4g} m N {y:.4g} m E is off the Earth"
    assert b.ep.stats.send_errors == b.ep.stats.handler_errors == 0


def test_setpoints_outside_guided_are_ignored_as_on_rover(bench: Bench) -> None:
    bench.send(
        mav.MAVLink_set_position_target_local_ned_message(
            0, 1, 1, mav.MAV_FRAME_BODY_NED, 1479, 0, 0, 0, 0.3, 0, 0, 0, 0, 0, 0, 0.1
        )
    )
    bench.tick()
    assert bench.ep.guided is None


def test_global_target_and_attitude_target() -> None:
    b = guided_bench()
    lat, lon = int(HOME[0] * 1e7) + 90, int(HOME[1] * 1e7)  # about 1 m north
    g = target_of(
        b,
        mav.MAVLink_set_position_target_global_int_message(
            0, 1, 1, mav.MAV_FRAME_GLOBAL_INT, 0b110111111000, lat, lon, 0, 0, 0, 0, 0, 0, 0, 0, 0
        ),
    )
    assert (
        g.kind == "location" and g.north_m == pytest.approx(1.0, abs=0.02) and g.east_m == pytest.approx(0.0, abs=0.02)
    )
    q = (math.cos(0.4), 0.0, 0.0, math.sin(0.4))  # a heading of 0.8 rad
    g = target_of(b, mav.MAVLink_set_attitude_target_message(0, 1, 1, 0b00000111, q, 0, 0, 0, 0.5))
    assert (
        g.kind == "heading"
        and g.heading_rad == pytest.approx(0.8)
        and g.speed_mps == pytest.approx(0.5 * b.ep.param("WP_SPEED"))
    )
    g = target_of(b, mav.MAVLink_set_attitude_target_message(0, 1, 1, 0b00000011, (1, 0, 0, 0), 0, 0, 0.25, -1.0))
    assert (
        g.kind == "rate"
        and g.yaw_rate_radps == pytest.approx(0.25)
        and g.speed_mps == pytest.approx(-b.ep.param("WP_SPEED"))
    )


def test_reposition_goes_there_in_guided_or_switches_with_the_flag(bench: Bench) -> None:
    lat, lon = HOME[0] + 2e-5, HOME[1]
    bench.ep.set_armed(True)
    # not in GUIDED and no change-mode flag: denied, as Rover
    assert (
        bench.command(mav.MAV_CMD_DO_REPOSITION, -1, 0, 0, 0, lat * 1e7, lon * 1e7, 0, long=False)
        == mav.MAV_RESULT_DENIED
    )
    # with the flag and a speed: GUIDED is entered, but a GUIDED just entered is stopped and
    # takes no speed, so the command FAILS there, as Rover's (no target)
    assert (
        bench.command(mav.MAV_CMD_DO_REPOSITION, 0.4, 1, 0, 0, lat * 1e7, lon * 1e7, 0, long=False)
        == mav.MAV_RESULT_FAILED
    )
    assert bench.ep.mode == MODES["GUIDED"] and bench.ep.guided is None
    # without a speed it goes; then, driving there, a speed is taken
    assert (
        bench.command(mav.MAV_CMD_DO_REPOSITION, -1, 0, 0, 0, lat * 1e7, lon * 1e7, 0, long=False)
        == mav.MAV_RESULT_ACCEPTED
    )
    assert bench.ep.guided.kind == "location" and bench.ep.guided.north_m == pytest.approx(2.2, abs=0.05)
    assert (
        bench.command(mav.MAV_CMD_DO_REPOSITION, 0.4, 0, 0, 0, lat * 1e7, lon * 1e7, 0, long=False)
        == mav.MAV_RESULT_ACCEPTED
    )
    # the waypoint speed, as Rover's set_speed_max: a DO_CHANGE_SPEED replaces it, later targets keep it
    assert bench.ep.speed_mps == pytest.approx(0.4) and bench.ep.guided.speed_mps == 0.0
    assert bench.command(mav.MAV_CMD_DO_CHANGE_SPEED, 1, 0.15, -1, 0, 0, 0, 0) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.speed_mps == pytest.approx(0.15)
    # lat/lon 0, 0 is refused, as Rover
    assert bench.command(mav.MAV_CMD_DO_REPOSITION, -1, 1, 0, 0, 0, 0, 0, long=False) == mav.MAV_RESULT_DENIED
    # as a COMMAND_LONG: UNSUPPORTED (Rover reads DO_REPOSITION's place from a COMMAND_INT only)
    assert bench.command(mav.MAV_CMD_DO_REPOSITION, -1, 0, 0, 0, lat, lon, 0) == mav.MAV_RESULT_UNSUPPORTED


@pytest.mark.parametrize(
    ("frame", "z"),
    [
        (mav.MAV_FRAME_LOCAL_NED, 0.0),  # not a frame a place is read in
        (mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, NAN),
        (mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 1e6),  # beyond Rover's 83 km
    ],
)
def test_a_reposition_whose_altitude_rover_cannot_read_is_denied(bench: Bench, frame: int, z: float) -> None:
    x, y = (int(round(v * 1e7)) for v in ned_to_geodetic(5.0, 5.0, 0.0, *HOME)[:2])
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    bench.send(mav.MAVLink_command_int_message(1, 1, frame, mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, 0, x, y, z))
    acks = [m for m in bench.tick() if m.get_type() == "COMMAND_ACK"]
    assert [a.result for a in acks] == [mav.MAV_RESULT_DENIED] and bench.ep.guided is None


def test_mission_item_current_2_is_a_guided_target() -> None:
    b = guided_bench()
    b.send(
        mav.MAVLink_mission_item_int_message(
            1,
            1,
            0,
            mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            16,
            2,
            1,
            0,
            0,
            0,
            0,
            int(HOME[0] * 1e7) + 180,
            int(HOME[1] * 1e7),
            0,
            0,
        )
    )
    acks = [m for m in b.tick() if m.get_type() == "MISSION_ACK"]
    assert acks and acks[0].type == mav.MAV_MISSION_ACCEPTED
    assert b.ep.guided.kind == "location" and b.ep.guided.north_m == pytest.approx(2.0, abs=0.02)
    assert b.ep.mission == []  # not a mission upload


def test_rtl_reverse_and_speed_commands(bench: Bench) -> None:
    bench.ep.set_armed(True)
    assert bench.command(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH) == mav.MAV_RESULT_ACCEPTED and bench.ep.mode == MODES["RTL"]
    assert bench.command(
        mav.MAV_CMD_DO_CHANGE_SPEED, 1, 0.7
    ) == mav.MAV_RESULT_ACCEPTED and bench.ep.speed_mps == pytest.approx(0.7)
    assert bench.command(mav.MAV_CMD_DO_SET_REVERSE, 1) == mav.MAV_RESULT_ACCEPTED and bench.ep.reversed
    assert bench.set_mode("SMART_RTL") in (mav.MAV_RESULT_ACCEPTED, mav.MAV_RESULT_FAILED)
    assert bench.set_mode("HOLD") == mav.MAV_RESULT_ACCEPTED
    assert bench.command(mav.MAV_CMD_DO_CHANGE_SPEED, 1, 0.7) == mav.MAV_RESULT_FAILED  # HOLD has no speed


@pytest.mark.parametrize("mode", ["RTL", "SMART_RTL"])
def test_a_ground_station_cannot_arm_in_rtl_or_smartrtl_as_on_rover(bench: Bench, mode: str) -> None:
    bench.ep.set_armed(True)
    bench.tick(1.0, {**STATE, "north_m": 3.0})  # a way back for SmartRTL
    assert bench.set_mode(mode) == mav.MAV_RESULT_ACCEPTED
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED and not bench.ep.armed
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0))
    out = bench.tick()
    (ack,) = [m for m in out if m.get_type() == "COMMAND_ACK"]
    assert ack.result == mav.MAV_RESULT_FAILED and not bench.ep.armed
    assert any(m.get_type() == "STATUSTEXT" and "Mode not armable" in m.text for m in out)
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1, 2989) == mav.MAV_RESULT_ACCEPTED  # forced
    assert bench.ep.armed
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED
    assert bench.set_mode("HOLD") == mav.MAV_RESULT_ACCEPTED  # MAVSDK's way: HOLD, then arm
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED and bench.ep.armed


def test_home_follows_the_disarmed_vehicle_and_holds_while_armed(bench: Bench) -> None:
    # Rover's update_home: while disarmed, home moves to the vehicle once it is 0.5 m away
    def at(n: float, e: float) -> None:
        bench.state = {**STATE, "north_m": n, "east_m": e}
        bench.tick()

    at(1.0, 2.0)
    assert bench.ep.home_point() == (1.0, 2.0)
    at(1.4, 2.0)
    assert bench.ep.home_point() == (1.0, 2.0)  # 0.4 m: GPS noise, not a move
    at(3.0, 2.0)
    assert bench.ep.home_point() == (3.0, 2.0)
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    at(10.0, 2.0)
    assert bench.ep.home_point() == (3.0, 2.0)  # armed: RTL's home stays
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED
    bench.tick()
    assert bench.ep.home_point() == (10.0, 2.0)


@pytest.mark.parametrize("long", [True, False])
def test_do_set_home_puts_home_there_and_keeps_it(bench: Bench, long: bool) -> None:
    north_5m, lon_deg, _alt = ned_to_geodetic(5.0, 0.0, 0.0, *HOME)
    lat, lon = (north_5m, lon_deg) if long else (north_5m * 1e7, lon_deg * 1e7)
    texts = len(bench.ep.statustexts)
    assert bench.command(mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, lat, lon, 0, long=long) == mav.MAV_RESULT_ACCEPTED
    n, e = bench.ep.home_point()
    tol = 0.2 if long else 0.02  # COMMAND_LONG carries degrees as float32: 1e-6 deg, 0.1 m
    assert n == pytest.approx(5.0, abs=tol) and e == pytest.approx(0.0, abs=tol)
    assert any("Set HOME to" in text for _t, text in bench.ep.statustexts[texts:])
    bench.state = {**STATE, "north_m": 20.0}
    bench.tick()  # disarmed, but a home a ground station put stays
    assert bench.ep.home_point() == (n, e)
    assert bench.command(mav.MAV_CMD_DO_SET_HOME, 1, long=long) == mav.MAV_RESULT_ACCEPTED  # here
    assert bench.ep.home_point() == (20.0, STATE["east_m"])
    assert bench.command(mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, NAN, NAN) == mav.MAV_RESULT_DENIED
    assert bench.command(mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, 91.0, 0.0) == mav.MAV_RESULT_DENIED
    assert bench.ep.home_point() == (20.0, STATE["east_m"])


def test_do_set_home_keeps_the_altitude_in_the_commands_frame(bench: Bench) -> None:
    # the ground is flat at HOME's 900 m; a COMMAND_LONG's altitude is above mean sea level (as
    # ArduPilot reads it, MAV_FRAME_GLOBAL), a COMMAND_INT's in its own frame
    lat, lon = 12.9605, 77.6695

    def home_and_relative_alt() -> tuple[float, float, float]:
        bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_GET_HOME_POSITION, 0, 0, 0, 0, 0, 0, 0, 0))
        out = [m for _ in range(60) for m in bench.tick(0.02)]  # (GLOBAL_POSITION_INT at 1 Hz)
        home = [m for m in out if m.get_type() == "HOME_POSITION"][-1]
        pos = [m for m in out if m.get_type() == "GLOBAL_POSITION_INT"][-1]
        return home.altitude / 1000, home.z, pos.relative_alt / 1000

    def command_int(frame: int, z: float) -> int:
        x, y = int(lat * 1e7), int(lon * 1e7)
        bench.send(mav.MAVLink_command_int_message(1, 1, frame, mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, 0, 0, x, y, z))
        (ack,) = [m for m in bench.tick() if m.get_type() == "COMMAND_ACK"]
        return int(ack.result)

    assert home_and_relative_alt() == (900.0, 0.0, 0.0)
    assert bench.command(mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, lat, lon, 912.5) == mav.MAV_RESULT_ACCEPTED
    text = bench.ep.statustexts[-1][1]  # COMMAND_LONG's degrees are float32: 1e-6 deg
    assert text.startswith("Set HOME to 12.9605") and text.endswith(" at 912.50m")
    # home 12.5 m above the ground: the rover on the ground is 12.5 m below it
    assert home_and_relative_alt() == pytest.approx((912.5, -12.5, -12.5), abs=1e-3)
    assert command_int(mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, -2.5) == mav.MAV_RESULT_ACCEPTED  # 2.5 m below home
    assert home_and_relative_alt() == pytest.approx((910.0, -10.0, -10.0), abs=1e-3)
    assert command_int(mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, 3.0) == mav.MAV_RESULT_ACCEPTED  # above the ground
    assert home_and_relative_alt() == pytest.approx((903.0, -3.0, -3.0), abs=1e-3)
    assert command_int(mav.MAV_FRAME_GLOBAL_INT, 880.0) == mav.MAV_RESULT_ACCEPTED
    assert home_and_relative_alt() == pytest.approx((880.0, 20.0, 20.0), abs=1e-3)
    # a frame no location is read in, or an altitude the messages cannot carry: refused, home kept
    assert command_int(mav.MAV_FRAME_LOCAL_NED, 0.0) == mav.MAV_RESULT_DENIED
    assert command_int(mav.MAV_FRAME_GLOBAL_INT, 3e6) == mav.MAV_RESULT_DENIED
    assert command_int(mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 83_001) == mav.MAV_RESULT_DENIED  # Rover's limit
    assert bench.command(mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, lat, lon, NAN) == mav.MAV_RESULT_DENIED
    assert bench.command(mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, lat, lon, -INF) == mav.MAV_RESULT_DENIED
    assert home_and_relative_alt() == pytest.approx((880.0, 20.0, 20.0), abs=1e-3)
    # here (param1 1): where the vehicle is, on the ground
    assert bench.command(mav.MAV_CMD_DO_SET_HOME, 1) == mav.MAV_RESULT_ACCEPTED
    assert home_and_relative_alt() == pytest.approx((900.0, 0.0, 0.0), abs=1e-3)


def test_the_fence_circle_is_centred_on_home_not_the_origin(bench: Bench) -> None:
    for name, value in (("FENCE_ENABLE", 1), ("FENCE_TYPE", 2), ("FENCE_RADIUS", 30)):
        bench.ep.params[name].value = value
    bench.state = {**STATE, "north_m": 100.0, "east_m": 0.0}  # home is here, 100 m from the origin
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    bench.tick()
    assert bench.ep.fence_breach is None
    bench.state = {**bench.state, "north_m": 131.0}
    bench.tick()
    assert bench.ep.fence_breach == "circle"


def test_auto_needs_a_mission_as_on_rover(bench: Bench) -> None:
    assert bench.set_mode("AUTO") == mav.MAV_RESULT_FAILED
    assert upload(bench, good_mission()) == mav.MAV_MISSION_ACCEPTED
    assert bench.set_mode("AUTO") == mav.MAV_RESULT_ACCEPTED


def test_health_bits_mavsdk_reads_are_present_enabled_and_healthy(bench: Bench) -> None:
    msgs = bench.tick(1.1)
    (st,) = [m for m in msgs if m.get_type() == "SYS_STATUS"]
    for bit in (
        mav.MAV_SYS_STATUS_SENSOR_3D_GYRO,
        mav.MAV_SYS_STATUS_SENSOR_3D_ACCEL,
        mav.MAV_SYS_STATUS_SENSOR_3D_MAG,
        mav.MAV_SYS_STATUS_SENSOR_GPS,
    ):
        assert (
            st.onboard_control_sensors_present & bit
            and st.onboard_control_sensors_enabled & bit
            and st.onboard_control_sensors_health & bit
        )


# -- the mission protocol against ArduPilot's MissionItemProtocol ------------------------------


def _acks(out: list[object]) -> list[int]:
    return [int(m.type) for m in out if m.get_type() == "MISSION_ACK"]  # type: ignore[attr-defined]


def _item_msg(it: Item) -> object:
    return mav.MAVLink_mission_item_int_message(
        1, 1, it.seq, it.frame, it.command, 0, 1, it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, 0
    )


def test_the_mission_is_not_cleared_while_it_is_flown(bench: Bench) -> None:
    assert upload(bench, good_mission(4)) == mav.MAV_MISSION_ACCEPTED
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    assert bench.set_mode("AUTO") == mav.MAV_RESULT_ACCEPTED
    bench.send(mav.MAVLink_mission_clear_all_message(1, 1, mav.MAV_MISSION_TYPE_MISSION))
    assert _acks(bench.tick()) == [mav.MAV_MISSION_ERROR]  # AP_Mission::clear refuses while running
    assert len(bench.ep.mission) == 4
    assert bench.set_mode("HOLD") == mav.MAV_RESULT_ACCEPTED
    bench.send(mav.MAVLink_mission_clear_all_message(1, 1, mav.MAV_MISSION_TYPE_MISSION))
    assert _acks(bench.tick()) == [mav.MAV_MISSION_ACCEPTED] and bench.ep.mission == []


def test_a_finished_mission_can_be_cleared_in_auto(bench: Bench) -> None:
    assert upload(bench, good_mission(3)) == mav.MAV_MISSION_ACCEPTED
    assert bench.set_mode("AUTO") == mav.MAV_RESULT_ACCEPTED
    bench.ep.reached(1)
    bench.send(mav.MAVLink_mission_clear_all_message(1, 1, mav.MAV_MISSION_TYPE_MISSION))
    assert _acks(bench.tick()) == [mav.MAV_MISSION_ERROR]
    bench.ep.reached(2)  # the last item
    bench.send(mav.MAVLink_mission_clear_all_message(1, 1, mav.MAV_MISSION_TYPE_MISSION))
    assert _acks(bench.tick()) == [mav.MAV_MISSION_ACCEPTED]


def test_while_one_ground_station_uploads_another_is_refused_and_the_upload_completes(bench: Bench) -> None:
    items = good_mission(3)
    other = mav.MAVLink(None, srcSystem=254, srcComponent=190)
    bench.send(mav.MAVLink_mission_count_message(1, 1, 3, 0))
    (req,) = [m for m in bench.tick() if m.get_type() == "MISSION_REQUEST"]
    assert req.seq == 0
    bench.send(_item_msg(items[0]))
    assert [m.seq for m in bench.tick() if m.get_type() == "MISSION_REQUEST"] == [1]
    for msg, expect in (
        (mav.MAVLink_mission_request_list_message(1, 1, 0), mav.MAV_MISSION_DENIED),
        (mav.MAVLink_mission_request_int_message(1, 1, 0, 0), mav.MAV_MISSION_DENIED),
        (mav.MAVLink_mission_count_message(1, 1, 2, 0), mav.MAV_MISSION_DENIED),
        (mav.MAVLink_mission_clear_all_message(1, 1, 0), mav.MAV_MISSION_ERROR),
        (_item_msg(items[1]), mav.MAV_MISSION_DENIED),
    ):
        bench.raw(msg.pack(other))  # type: ignore[attr-defined]
        out = bench.tick()
        acks = [m for m in out if m.get_type() == "MISSION_ACK"]
        assert [(a.type, a.target_system) for a in acks] == [(expect, 254)], msg
        assert not [m for m in out if m.get_type() in ("MISSION_COUNT", "MISSION_ITEM_INT")]
    bench.send(_item_msg(items[1]))
    bench.tick()
    bench.send(_item_msg(items[2]))
    out = bench.tick()
    assert [(a.type, a.target_system) for a in out if a.get_type() == "MISSION_ACK"] == [(0, 255)]
    assert len(bench.ep.mission) == 3


def test_an_item_not_yet_asked_for_is_an_invalid_sequence_and_the_upload_goes_on(bench: Bench) -> None:
    items = good_mission(3)
    bench.send(mav.MAVLink_mission_count_message(1, 1, 3, 0))
    bench.tick()
    bench.send(_item_msg(Item(7, mav.MAV_CMD_NAV_WAYPOINT, y=776690000)))
    assert _acks(bench.tick()) == [mav.MAV_MISSION_INVALID_SEQUENCE]
    for it in items:
        bench.send(_item_msg(it))
        out = bench.tick()
    assert _acks(out) == [mav.MAV_MISSION_ACCEPTED] and len(bench.ep.mission) == 3


def test_an_abandoned_upload_is_asked_again_and_cancelled_after_8_s(bench: Bench) -> None:
    assert upload(bench, good_mission(4)) == mav.MAV_MISSION_ACCEPTED
    bench.send(mav.MAVLink_mission_count_message(1, 1, 3, 0))
    bench.tick()
    asked, acks = 0, []
    for _ in range(79):  # 7.9 s
        out = bench.tick(0.1)
        asked += sum(m.get_type() == "MISSION_REQUEST" for m in out)
        acks += _acks(out)
    assert acks == [] and asked >= 7  # still open: asked again, not yet given up
    for _ in range(5):
        acks += _acks(bench.tick(0.1))
    assert acks == [mav.MAV_MISSION_OPERATION_CANCELLED] and len(bench.ep.mission) == 4  # the old one stays


def test_item_0_downloads_as_home_whatever_was_uploaded(bench: Bench) -> None:
    items = good_mission(3)
    items[0] = Item(0, mav.MAV_CMD_NAV_WAYPOINT, x=10000000, y=10000000)  # (1 deg, 1 deg)
    assert upload(bench, items) == mav.MAV_MISSION_ACCEPTED
    back = download(bench, mav.MAV_MISSION_TYPE_MISSION)
    lat, lon, _alt = ned_to_geodetic(STATE["north_m"], STATE["east_m"], 0.0, *HOME)  # the disarmed vehicle's place
    assert (back[0].x, back[0].y) == (round(lat * 1e7), round(lon * 1e7))  # type: ignore[attr-defined]
    assert [m.y for m in back[1:]] == [it.y for it in items[1:]]  # type: ignore[attr-defined]


# -- parameters, fence enable, heartbeat as Rover ---------------------------------------------


def _param(bench: Bench, name: str, value: float | None = None) -> object:
    if value is None:
        bench.send(mav.MAVLink_param_request_read_message(1, 1, name.encode(), -1))
    else:
        bench.send(mav.MAVLink_param_set_message(1, 1, name.encode(), value, mav.MAV_PARAM_TYPE_REAL32))
    (pv,) = [m for m in bench.tick() if m.get_type() == "PARAM_VALUE"]
    return pv


def test_integer_parameters_say_so_and_store_whole_numbers_as_ardupilot(bench: Bench) -> None:
    pv = _param(bench, "FENCE_ENABLE")
    assert pv.param_type == mav.MAV_PARAM_TYPE_INT8  # type: ignore[attr-defined]  # MAVSDK get_param_int needs it
    assert _param(bench, "SYSID_THISMAV").param_type == mav.MAV_PARAM_TYPE_INT16  # type: ignore[attr-defined]
    assert _param(bench, "WP_SPEED").param_type == mav.MAV_PARAM_TYPE_REAL32  # type: ignore[attr-defined]
    # AP_Param::set_float: + 0.01 away from zero, then truncated
    assert _param(bench, "FENCE_ENABLE", 0.5).param_value == 0  # type: ignore[attr-defined]
    assert bench.ep.param("FENCE_ENABLE") == 0  # the fence stays off
    assert _param(bench, "FENCE_ENABLE", 0.995).param_value == 1  # type: ignore[attr-defined]
    assert _param(bench, "FENCE_ACTION", 2.7).param_value == 2  # type: ignore[attr-defined]
    assert _param(bench, "WP_SPEED", 1.25).param_value == 1.25  # type: ignore[attr-defined]
    bench.send(mav.MAVLink_param_request_read_message(1, 1, b"", 999))
    out = bench.tick()
    assert not [m for m in out if m.get_type() == "PARAM_VALUE"]
    assert any(m.get_type() == "STATUSTEXT" and "No parameter at index 999" in m.text for m in out)


@pytest.mark.parametrize(
    ("action", "fences", "result", "enabled"),
    [(1, 0, 0, 6), (0, 0, 0, 0), (2, 0, 0, None), (3, 0, 4, None), (1, 2, 0, 2), (0, 4, 0, 2), (1, 4, 4, None)],
)
def test_do_fence_enable_as_ardupilot(bench: Bench, action: int, fences: int, result: int, enabled: int | None) -> None:
    # Rover 4.6's GCS_Fence: param1 0 off, 1 on, 2 the floor off (a rover has none: accepted,
    # nothing changes), else FAILED; param2 the fences it is for (0: all): on is FAILED when
    # none of them is there to check (here the circle alone, FENCE_TYPE 6 with no polygon)
    bench.ep.params["FENCE_TYPE"].value = 6
    bench.ep.params["FENCE_ENABLE"].value = 1 if action == 0 else 0
    bench.tick()
    before = bench.ep.fences_enabled
    assert bench.command(mav.MAV_CMD_DO_FENCE_ENABLE, action, fences) == result
    assert bench.ep.fences_enabled == (before if enabled is None else enabled)
    # AC_Fence::enable changes the fences in RAM only: FENCE_ENABLE is as it was
    assert bench.ep.param("FENCE_ENABLE") == (1 if action == 0 else 0)
    # what a ground station sees: FENCE_STATUS while a fence is on (GCS_Fence's
    # send_fence_status), and SYS_STATUS's geofence bit enabled (FENCE_ACTION 1)
    out = bench.tick(1.0)
    on = bool(bench.ep.fences_enabled)
    assert bool([m for m in out if m.get_type() == "FENCE_STATUS"]) is on
    (status,) = [m for m in out if m.get_type() == "SYS_STATUS"][-1:]
    assert bool(status.onboard_control_sensors_enabled & mav.MAV_SYS_STATUS_GEOFENCE) is on


def test_do_fence_enable_is_forgotten_at_a_reboot_and_fence_enable_rules_when_it_changes(bench: Bench) -> None:
    # AC_Fence's parameter says "these changes are not persisted": after a reboot the fences
    # are as FENCE_ENABLE says (0: off); a change of FENCE_ENABLE turns them all on or off
    ep = bench.ep
    ep.params["FENCE_TYPE"].value = 2
    assert bench.command(mav.MAV_CMD_DO_FENCE_ENABLE, 1) == mav.MAV_RESULT_ACCEPTED
    assert ep.fences_enabled == 2 and ep.param("FENCE_ENABLE") == 0
    assert [m for m in bench.tick(1.0) if m.get_type() == "FENCE_STATUS"]  # with a fence on
    assert bench.command(mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == mav.MAV_RESULT_ACCEPTED
    bench.tick(3.0)
    assert ep.fences_enabled == 0
    assert not [m for m in bench.tick(1.0) if m.get_type() == "FENCE_STATUS"]
    bench.send(mav.MAVLink_param_set_message(1, 1, b"FENCE_ENABLE", 1.0, mav.MAV_PARAM_TYPE_INT8))
    bench.tick()
    assert ep.fences_enabled == 2
    assert bench.command(mav.MAV_CMD_DO_FENCE_ENABLE, 0) == mav.MAV_RESULT_ACCEPTED and ep.fences_enabled == 0
    bench.send(mav.MAVLink_param_set_message(1, 1, b"FENCE_ENABLE", 1.0, mav.MAV_PARAM_TYPE_INT8))
    bench.tick()
    assert ep.fences_enabled == 0  # set to what it was: no change, so the command's off stands


def test_manual_mode_says_it_takes_manual_input(bench: Bench) -> None:
    assert bench.set_mode("MANUAL") == mav.MAV_RESULT_ACCEPTED
    (hb,) = [m for m in bench.tick(1.1) if m.get_type() == "HEARTBEAT"]
    assert hb.base_mode & mav.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
    assert not hb.base_mode & mav.MAV_MODE_FLAG_GUIDED_ENABLED
    assert bench.set_mode("HOLD") == mav.MAV_RESULT_ACCEPTED
    (hb,) = [m for m in bench.tick(1.1) if m.get_type() == "HEARTBEAT"]
    assert not hb.base_mode & mav.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED


def _count(out: list[object], name: str) -> int:
    return sum(m.get_type() == name for m in out)  # type: ignore[attr-defined]


def test_request_data_stream_sets_rovers_stream_groups(bench: Bench) -> None:
    # MAVProxy and Mission Planner ask by group: 0 stops all (HEARTBEAT is in no group)
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_ALL, 0, 0))
    bench.tick()
    out = [m for _ in range(100) for m in bench.tick(0.02)]  # 2 s
    assert _count(out, "ATTITUDE") == _count(out, "GLOBAL_POSITION_INT") == _count(out, "SYS_STATUS") == 0
    assert _count(out, "HEARTBEAT") == 2
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_POSITION, 4, 1))
    bench.tick()
    out = [m for _ in range(100) for m in bench.tick(0.02)]
    assert 7 <= _count(out, "GLOBAL_POSITION_INT") <= 9 and _count(out, "LOCAL_POSITION_NED") >= 7
    assert _count(out, "ATTITUDE") == 0  # EXTRA1 still stopped
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_EXTRA1, 1000, 1))
    bench.tick()
    out = [m for _ in range(100) for m in bench.tick(0.01)]  # 1 s at 100 ticks a second
    # 1000 / 1000 = 1 ms, held to 0.8 x SCHED_LOOP_RATE (50 Hz): 25 ms
    assert 38 <= _count(out, "ATTITUDE") <= 41


def test_message_intervals_as_ardupilot(bench: Bench) -> None:
    att = mav.MAVLINK_MSG_ID_ATTITUDE
    # a message not sent here: DENIED, with Rover's text (MAVSDK's "Command Denied" against Rover 4.5+)
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, 12345, 100000) == mav.MAV_RESULT_DENIED
    assert bench.ep.statustexts[-1][1] == "No ap_message for mavlink id (12345)"
    assert bench.command(mav.MAV_CMD_REQUEST_MESSAGE, 12345) == mav.MAV_RESULT_FAILED
    # 500 us is 1 ms, faster than 0.8 x SCHED_LOOP_RATE (50 Hz): DENIED, with Rover 4.6's text
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, att, 500) == mav.MAV_RESULT_DENIED
    assert bench.ep.statustexts[-1][1] == "Requested rate for message ID 30 too fast. Increase SCHED_LOOP_RATE"
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, att, -1) == mav.MAV_RESULT_ACCEPTED
    out = [m for _ in range(50) for m in bench.tick(0.02)]
    assert _count(out, "ATTITUDE") == 0


@pytest.mark.parametrize("start_s", [0.0, 255.0, 4090.0, 8190.0])
def test_stream_rates_hold_however_long_the_run_has_gone(bench: Bench, start_s: float) -> None:
    # each stream keeps its phase: sent again one period after it was due, not after the tick
    # it went in (a 0.1 s period that landed a float's width past a 50 Hz tick slipped to the
    # next: 9 Hz from 256 s on, 8.67 Hz from 4096 s), and a 4 Hz stream on 50 Hz ticks
    # averages 4 Hz (0.24 and 0.26 s apart), not 3.85 Hz (every 0.26 s)
    bench.t = start_s
    bench.tick()
    set_interval = mav.MAV_CMD_SET_MESSAGE_INTERVAL  # (a ground station's rates: Rover's are 1 Hz)
    assert bench.command(set_interval, mav.MAVLINK_MSG_ID_ATTITUDE, 100_000) == mav.MAV_RESULT_ACCEPTED
    assert bench.command(set_interval, mav.MAVLINK_MSG_ID_VFR_HUD, 250_000) == mav.MAV_RESULT_ACCEPTED
    out = [m for _ in range(1000) for m in bench.tick(0.02)]  # 20 s
    assert 199 <= _count(out, "ATTITUDE") <= 201  # 10 Hz
    assert 79 <= _count(out, "VFR_HUD") <= 81  # 4 Hz


def test_rtl_skips_a_rally_point_outside_the_fence(bench: Bench) -> None:
    # AP_Rally_Rover::is_valid: with the fence on, a rally point outside it is not a place to go
    assert upload(bench, fence_square(5.0), mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_ACCEPTED
    inside, outside = ned_to_geodetic(3.0, 3.0, 0.0, *HOME), ned_to_geodetic(0.0, 7.0, 0.0, *HOME)
    rally = [
        Item(k, mav.MAV_CMD_NAV_RALLY_POINT, x=round(lat * 1e7), y=round(lon * 1e7), frame=mav.MAV_FRAME_GLOBAL_INT)
        for k, (lat, lon, _alt) in enumerate((inside, outside))
    ]
    assert upload(bench, rally, mav.MAV_MISSION_TYPE_RALLY) == mav.MAV_MISSION_ACCEPTED
    bench.state = {**STATE, "north_m": 0.0, "east_m": 0.0}
    bench.tick()  # home here
    near_outside = (0.5, 6.5)
    n, e = bench.ep.rtl_destination(*near_outside)
    assert (n, e) == pytest.approx((0.0, 7.0), abs=0.05)  # fence off: the nearest rally point
    bench.ep.params["FENCE_ENABLE"].value = 1
    bench.tick()  # (the fences turn on as AC_Fence::update sees the parameter change)
    n, e = bench.ep.rtl_destination(*near_outside)
    assert (n, e) == pytest.approx((3.0, 3.0), abs=0.05)  # fence on: the one inside it
    assert bench.ep.rtl_destination(0.2, -0.3) == (0.0, 0.0)  # home, nearer than either


def test_get_message_interval_as_ardupilot(bench: Bench) -> None:
    def interval(msg_id: int, result: int = mav.MAV_RESULT_ACCEPTED) -> int:
        bench.send(
            mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_GET_MESSAGE_INTERVAL, 0, msg_id, 0, 0, 0, 0, 0, 0)
        )
        out = bench.tick()
        (ack,) = [m for m in out if m.get_type() == "COMMAND_ACK"]
        (mi,) = [m for m in out if m.get_type() == "MESSAGE_INTERVAL"]
        assert ack.result == result and mi.message_id == msg_id & 0xFFFF
        return int(mi.interval_us)

    att = mav.MAVLINK_MSG_ID_ATTITUDE
    assert interval(att) == 1_000_000  # 1 Hz by default (SRn_EXTRA1's)
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, att, 250_000) == mav.MAV_RESULT_ACCEPTED
    assert interval(att) == 250_000
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, att, 500) == mav.MAV_RESULT_DENIED  # too fast
    assert interval(att) == 250_000  # kept
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, att, -1) == mav.MAV_RESULT_ACCEPTED
    assert interval(att) == -1
    assert interval(12345, mav.MAV_RESULT_FAILED) == 0  # not a message this vehicle sends
    assert interval(70000, mav.MAV_RESULT_FAILED) == 0  # beyond the reply's 16-bit field: no raise
    assert bench.ep.stats.handler_errors == 0


def test_item_0_downloads_as_a_waypoint_at_home_with_an_absolute_altitude(bench: Bench) -> None:
    # good_mission's item 0 is relative-altitude: home's 900 m must not read as 900 m above home
    assert upload(bench, good_mission(3)) == mav.MAV_MISSION_ACCEPTED
    items = download(bench, mav.MAV_MISSION_TYPE_MISSION)
    home = items[0]
    # frames as Rover's AP_Mission::mission_cmd_to_mavlink_int names them (no _INT): MAVProxy
    # writes them into its files, and MAVSDK's Mission plugin refuses frame 5
    assert (home.frame, home.command, home.z) == (mav.MAV_FRAME_GLOBAL, mav.MAV_CMD_NAV_WAYPOINT, HOME[2])  # type: ignore[attr-defined]
    assert {it.frame for it in items[1:]} == {mav.MAV_FRAME_GLOBAL_RELATIVE_ALT}  # type: ignore[attr-defined]


def test_a_finished_mission_starts_again_when_auto_is_entered_again(bench: Bench) -> None:
    assert upload(bench, good_mission(3)) == mav.MAV_MISSION_ACCEPTED
    assert bench.set_mode("AUTO") == mav.MAV_RESULT_ACCEPTED
    bench.ep.reached(1)
    bench.ep.reached(2)
    assert bench.ep.mission_complete
    assert bench.set_mode("HOLD") == mav.MAV_RESULT_ACCEPTED
    version = bench.ep.mission_version
    assert bench.command(mav.MAV_CMD_MISSION_START, 0, 0) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.current_seq == 1 and not bench.ep.mission_complete  # AP_Mission::resume: start()
    assert bench.ep.mission_version > version  # the autopilot rebuilds its legs
    bench.send(mav.MAVLink_mission_clear_all_message(1, 1, mav.MAV_MISSION_TYPE_MISSION))
    assert _acks(bench.tick()) == [mav.MAV_MISSION_ERROR]  # flown again: not cleared


def test_auto_without_a_mission_does_not_block_a_clear(bench: Bench) -> None:
    bench.ep.force_mode("AUTO")  # a scripted leader: AUTO with nothing loaded
    bench.send(mav.MAVLink_mission_clear_all_message(1, 1, mav.MAV_MISSION_TYPE_MISSION))
    assert _acks(bench.tick()) == [mav.MAV_MISSION_ACCEPTED]


def test_a_lockstep_leader_starting_off_the_origin_has_its_home_where_it_starts() -> None:
    from lfctl.config import load_config
    from lfctl.data import resolve_scenario
    from lfctl.sim.links import Links

    cfg = load_config(resolve_scenario("convoy"))
    leader = dataclasses.replace(cfg.vehicles[0], north_m=7.0, east_m=-3.0)
    cfg = dataclasses.replace(cfg, vehicles=(leader, *cfg.vehicles[1:]))
    links = Links(cfg, realtime=False)
    assert links.endpoints[0].armed  # armed by the set-up, before any step of the simulation
    assert links.endpoints[0].home_point() == (7.0, -3.0)


def test_the_fence_cannot_be_enabled_when_there_is_none(bench: Bench) -> None:
    # AC_Fence::present: FENCE_TYPE polygons only and none uploaded is no fence (FAILED)
    bench.ep.params["FENCE_TYPE"].value = 4
    assert bench.command(mav.MAV_CMD_DO_FENCE_ENABLE, 1) == mav.MAV_RESULT_FAILED
    assert bench.ep.fences_enabled == 0
    assert upload(bench, fence_square(5.0), mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_ACCEPTED
    assert bench.command(mav.MAV_CMD_DO_FENCE_ENABLE, 1) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.fences_enabled == 4  # the polygon, turned on in RAM (FENCE_ENABLE stays 0)


def test_vfr_hud_as_rover_fills_it(bench: Bench) -> None:
    # QGroundControl's ground speed and throttle and MAVSDK's fixed-wing metrics come from it
    out = [m for _ in range(150) for m in bench.tick(0.02)]  # 3 s
    huds = [m for m in out if m.get_type() == "VFR_HUD"]
    assert 3 <= len(huds) <= 4  # 1 Hz by default (SRn_EXTRA2's)
    hud = huds[-1]
    assert hud.groundspeed == hud.airspeed == pytest.approx(0.2)  # no airspeed sensor: the ground speed
    assert hud.heading == 28  # 0.5 rad = 28.6 degrees, in whole degrees as Rover's yaw_sensor / 100
    assert hud.alt == pytest.approx(HOME[2], abs=1e-3) and hud.climb == 0.0
    assert hud.throttle == 0  # disarmed: the motors are off

    def throttle(**state: float) -> int:
        bench.state = {**STATE, **state}
        request = (mav.MAVLINK_MSG_ID_VFR_HUD, 0, 0, 0, 0, 0, 0)
        bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, *request))
        return int([m for m in bench.tick(0.001) if m.get_type() == "VFR_HUD"][-1].throttle)

    bench.ep.set_armed(True)
    # Rover's base throttle: the commanded speed times CRUISE_THROTTLE (50 %) / CRUISE_SPEED (2 m/s)
    assert throttle(speed_cmd_mps=1.0) == 25
    assert throttle(speed_cmd_mps=0.99) == 24  # 24.75, truncated as Rover's int16_t
    assert throttle(speed_cmd_mps=-1.0) == 25  # reversing: its magnitude
    assert throttle(speed_cmd_mps=9.0) == 100  # to at most 100 %
    assert throttle() == 5  # no command given: what its speed (0.2 m/s) needs
    bench.ep.params["CRUISE_THROTTLE"].value = 0
    assert throttle(speed_cmd_mps=1.0) == 0
    bench.ep.params["CRUISE_THROTTLE"].value = 50
    bench.ep.params["CRUISE_SPEED"].value = 0.0
    assert throttle(speed_cmd_mps=1.0) == 0  # Rover's guard against dividing by 0
    assert throttle(speed_cmd_mps=NAN) == 0 and bench.ep.stats.handler_errors == 0


@pytest.mark.parametrize(("yaw_deg", "heading"), [(28.996, 28), (359.999, 359), (-0.5, 359), (-0.004, 0), (180.0, 180)])
def test_vfr_hud_heading_in_whole_degrees_as_rovers_yaw_sensor(bench: Bench, yaw_deg: float, heading: int) -> None:
    bench.state = {**STATE, "yaw_rad": math.radians(yaw_deg)}
    request = (mav.MAVLINK_MSG_ID_VFR_HUD, 0, 0, 0, 0, 0, 0)
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, *request))
    assert [m for m in bench.tick(0.001) if m.get_type() == "VFR_HUD"][-1].heading == heading


def test_cruise_throttle_is_an_int8_percent_as_on_rover(bench: Bench) -> None:
    bench.send(mav.MAVLink_param_request_read_message(1, 1, b"CRUISE_THROTTLE", -1))
    (value,) = [m for m in bench.tick() if m.get_type() == "PARAM_VALUE"]
    assert value.param_type == mav.MAV_PARAM_TYPE_INT8 and value.param_value == 50


def test_extra2_is_vfr_huds_stream_group(bench: Bench) -> None:
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_EXTRA2, 10, 1))
    bench.tick()
    out = [m for _ in range(100) for m in bench.tick(0.02)]  # 2 s
    assert 18 <= _count(out, "VFR_HUD") <= 21
    assert 1 <= _count(out, "ATTITUDE") <= 3  # EXTRA1 as it was (1 Hz)


def _heartbeat_state(bench: Bench) -> int:
    beats = [m for _ in range(60) for m in bench.tick(0.02) if m.get_type() == "HEARTBEAT"]
    return int(beats[-1].system_status)


def test_heartbeat_state_as_rover_says_it(bench: Bench) -> None:
    # QGroundControl takes an armed vehicle that is ACTIVE as moving: no Disarm, no Start Mission
    assert bench.ep.mode == MODES["HOLD"] and _heartbeat_state(bench) == mav.MAV_STATE_STANDBY
    assert bench.set_mode("MANUAL") == mav.MAV_RESULT_ACCEPTED
    assert _heartbeat_state(bench) == mav.MAV_STATE_ACTIVE  # disarmed, not in HOLD: ACTIVE, as on Rover
    assert bench.set_mode("HOLD") == mav.MAV_RESULT_ACCEPTED
    bench.ep.set_armed(True)
    assert _heartbeat_state(bench) == mav.MAV_STATE_STANDBY  # HOLD, armed or not
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert _heartbeat_state(bench) == mav.MAV_STATE_ACTIVE
    bench.ep.params["FS_GCS_ENABLE"].value = 1
    bench.send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, 8, 0, 0, 4, 3))
    bench.tick()
    bench.tick(6.0)  # the ground station lost (FS_GCS_TIMEOUT 5 s) ...
    bench.tick(1.6)  # ... for more than FS_TIMEOUT (1.5 s): FS_ACTION 2, HOLD, in a failsafe
    assert bench.ep.mode == MODES["HOLD"] and _heartbeat_state(bench) == mav.MAV_STATE_CRITICAL
    bench.send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, 8, 0, 0, 4, 3))
    bench.tick()
    assert _heartbeat_state(bench) == mav.MAV_STATE_STANDBY  # back: the failsafe is over, still in HOLD
    assert bench.ep.statustexts[-1][1] == "GCS Failsafe Cleared"


def _lose_the_gcs(bench: Bench, fs_gcs_enable: int = 1) -> None:
    """The ground station (system 255) heard once, then silent past FS_GCS_TIMEOUT (5 s): the
    failsafe's condition begins; it acts after FS_TIMEOUT (1.5 s) more."""
    bench.ep.params["FS_GCS_ENABLE"].value = fs_gcs_enable
    bench.send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, 8, 0, 0, 4, 3))
    bench.tick()
    bench.tick(5.0)


def test_the_gcs_failsafe_acts_fs_timeout_after_the_ground_station_is_lost_armed_or_not(bench: Bench) -> None:
    # Rover's failsafe_trigger has no arming check: a disarmed vehicle in MANUAL goes to HOLD too
    assert bench.set_mode("MANUAL") == mav.MAV_RESULT_ACCEPTED
    _lose_the_gcs(bench)  # lost at 5.02 s (5.0 s of silence: FS_GCS_TIMEOUT reached)
    bench.tick(1.5)  # 1.5 s of it: not more than FS_TIMEOUT
    assert bench.ep.mode == MODES["MANUAL"] and bench.ep.system_status() == mav.MAV_STATE_ACTIVE
    bench.tick(0.1)
    assert bench.ep.mode == MODES["HOLD"] and bench.ep.system_status() == mav.MAV_STATE_CRITICAL
    assert bench.ep.statustexts[-1][1] == "GCS Failsafe" and not bench.ep.armed


@pytest.mark.parametrize(
    ("action", "points", "mode", "armed"),
    [(0, 300, "MANUAL", True), (1, 300, "RTL", True), (2, 300, "HOLD", True), (3, 300, "SMART_RTL", True),
     (3, 0, "RTL", True), (4, 300, "SMART_RTL", True), (4, 0, "HOLD", True), (5, 300, "MANUAL", False),
     (6, 300, "HOLD", True)],
)  # fmt: skip
def test_the_gcs_failsafe_takes_fs_action(bench: Bench, action: int, points: int, mode: str, armed: bool) -> None:
    # SRTL_POINTS 0 as the autopilot starts (its first tick): no way back kept, so SmartRTL cannot
    # start and 3 falls to RTL, 4 to HOLD; 6 is LOITER or HOLD, and lfctl's vehicle has no
    # LOITER; 5 disarms
    bench.ep.params["SRTL_POINTS"].value = points
    assert bench.set_mode("MANUAL") == mav.MAV_RESULT_ACCEPTED
    bench.ep.set_armed(True)
    bench.ep.params["FS_ACTION"].value = action
    _lose_the_gcs(bench)
    bench.tick(1.6)
    assert (bench.ep.mode, bench.ep.armed) == (MODES[mode], armed)
    assert bench.ep.system_status() == mav.MAV_STATE_CRITICAL  # it acted, even when the action is nothing


def test_the_gcs_failsafe_waits_in_rtl_and_in_hold_and_acts_when_the_mode_changes(bench: Bench) -> None:
    assert bench.set_mode("RTL") == mav.MAV_RESULT_ACCEPTED
    _lose_the_gcs(bench)
    bench.tick(10.0)
    assert bench.ep.mode == MODES["RTL"] and _heartbeat_state(bench) == mav.MAV_STATE_ACTIVE
    assert not any(t == "GCS Failsafe" for _, t in bench.ep.statustexts)
    assert bench.ep.set_mode(MODES["MANUAL"])  # the ground station is still lost: it acts now
    bench.tick()
    assert bench.ep.mode == MODES["HOLD"] and _heartbeat_state(bench) == mav.MAV_STATE_CRITICAL


def test_a_gcs_failsafe_that_only_waited_clears_without_a_word(bench: Bench) -> None:
    assert bench.ep.mode == MODES["HOLD"]
    _lose_the_gcs(bench)
    bench.tick(10.0)  # in HOLD: it waits, never acts
    bench.send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, 8, 0, 0, 4, 3))
    bench.tick()
    texts = [t for _, t in bench.ep.statustexts]
    assert "GCS Failsafe" not in texts and "GCS Failsafe Cleared" not in texts
    assert bench.ep.system_status() == mav.MAV_STATE_STANDBY


def test_fs_gcs_enable_0_during_a_failsafe_leaves_it_as_it_was_until_a_reboot(bench: Bench) -> None:
    # Rover's gcs_failsafe_check returns before failsafe_trigger with the failsafe off: the
    # ground station heard again clears nothing; a reboot starts afresh
    assert bench.set_mode("MANUAL") == mav.MAV_RESULT_ACCEPTED
    _lose_the_gcs(bench)
    bench.tick(1.6)
    assert bench.ep.system_status() == mav.MAV_STATE_CRITICAL
    bench.ep.params["FS_GCS_ENABLE"].value = 0
    bench.send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, 8, 0, 0, 4, 3))
    bench.tick()
    assert bench.ep.system_status() == mav.MAV_STATE_CRITICAL
    assert bench.command(mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == mav.MAV_RESULT_ACCEPTED
    bench.tick(3.0)
    bench.tick()
    assert not bench.ep.rebooting and bench.ep.system_status() == mav.MAV_STATE_STANDBY
    bench.ep.params["FS_GCS_ENABLE"].value = 1
    bench.tick(10.0)  # the ground station not heard since the reboot: no failsafe
    assert bench.ep.system_status() == mav.MAV_STATE_STANDBY and bench.ep.mode == MODES["HOLD"]


def test_fs_options_bit_0_lets_the_gcs_failsafe_act_in_hold(bench: Bench) -> None:
    bench.ep.params["FS_OPTIONS"].value = 1
    bench.ep.params["FS_ACTION"].value = 1  # RTL
    bench.ep.set_armed(True)
    assert bench.ep.mode == MODES["HOLD"]
    _lose_the_gcs(bench)
    bench.tick(1.6)
    assert bench.ep.mode == MODES["RTL"]


def test_fs_gcs_enable_2_lets_a_mission_in_auto_go_on(bench: Bench) -> None:
    assert upload(bench, good_mission()) == mav.MAV_MISSION_ACCEPTED
    assert bench.set_mode("AUTO") == mav.MAV_RESULT_ACCEPTED
    _lose_the_gcs(bench, fs_gcs_enable=2)
    bench.tick(1.6)
    assert bench.ep.mode == MODES["AUTO"] and _heartbeat_state(bench) == mav.MAV_STATE_CRITICAL
    texts = [t for _, t in bench.ep.statustexts]
    assert texts[-2:] == ["GCS Failsafe", "Failsafe - Continuing Auto Mode"]


def test_the_gcs_failsafe_drops_every_rc_override(bench: Bench) -> None:
    bench.ep.params["RC_OVERRIDE_TIME"].value = -1  # kept until released
    bench.ep.params["FS_ACTION"].value = 0  # nothing but the failsafe's own work
    assert bench.set_mode("MANUAL") == mav.MAV_RESULT_ACCEPTED
    bench.send(mav.MAVLink_rc_channels_override_message(1, 1, 1900, 0, 1715, 0, 0, 0, 0, 0))
    _lose_the_gcs(bench)  # (the sticks count as a heartbeat: silent from the heartbeat after them)
    assert bench.ep.pilot_input().active
    bench.tick(1.6)
    assert not bench.ep.pilot_input().active and bench.ep.mode == MODES["MANUAL"]


def test_only_sysid_mygcs_keeps_the_ground_station_alive(bench: Bench) -> None:
    # Rover's handle_heartbeat: a HEARTBEAT from SYSID_MYGCS, of any type; another system's
    # ground station heartbeat is not the vehicle's ground station
    assert bench.set_mode("MANUAL") == mav.MAV_RESULT_ACCEPTED
    _lose_the_gcs(bench)
    other = mav.MAVLink(None, srcSystem=245, srcComponent=190)  # MAVSDK's own system id
    for _ in range(4):
        bench.raw(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, 8, 0, 0, 4, 3).pack(other))
        bench.tick(0.5)
    assert bench.ep.mode == MODES["HOLD"]
    bench.ep.params["SYSID_MYGCS"].value = 245
    bench.raw(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_ONBOARD_CONTROLLER, 8, 0, 0, 4, 3).pack(other))
    bench.tick()
    assert bench.ep.statustexts[-1][1] == "GCS Failsafe Cleared"


def test_a_message_not_sent_is_refused_without_a_text_when_requested_once(bench: Bench) -> None:
    # QGroundControl asks for COMPONENT_METADATA (397) and AVAILABLE_MODES (435) on connecting
    for msg_id in (397, 435):
        request = (msg_id, 0, 0, 0, 0, 0, 0)
        bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, *request))
        out = bench.tick()
        (ack,) = [m for m in out if m.get_type() == "COMMAND_ACK"]
        assert ack.result == mav.MAV_RESULT_FAILED and _count(out, "STATUSTEXT") == 0
    # a stream asked for: ArduPilot says it has no such message
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, 397, 1e6) == mav.MAV_RESULT_DENIED
    assert any("No ap_message for mavlink id (397)" in t for _, t in bench.ep.statustexts)


def test_extended_sys_state_is_sent_when_asked_for(bench: Bench) -> None:
    # QGroundControl asks for it (and BATTERY_STATUS's absence makes it ask every 10 s)
    out = [m for _ in range(100) for m in bench.tick(0.02)]
    assert _count(out, "EXTENDED_SYS_STATE") == 0  # not streamed by default
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, 500_000) == 0
    out = [m for _ in range(100) for m in bench.tick(0.02)]
    states = [m for m in out if m.get_type() == "EXTENDED_SYS_STATE"]
    assert 3 <= len(states) <= 5 and states[-1].landed_state == mav.MAV_LANDED_STATE_UNDEFINED
    assert not bench.ep.statustexts or all("No ap_message" not in t for _, t in bench.ep.statustexts)


def test_a_stopped_message_is_not_sent_once_more(bench: Bench) -> None:
    bench.tick()  # every stream sent once; the next ATTITUDE and GLOBAL_POSITION_INT due in 0.1 s
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 30, -1, 0, 0, 0, 0, 0))
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_POSITION, 0, 0))
    out = bench.tick()  # the tick that takes both
    assert _count(out, "COMMAND_ACK") == 1
    assert _count(out, "ATTITUDE") == _count(out, "GLOBAL_POSITION_INT") == 0


def test_sys_status_says_the_battery_is_not_measured(bench: Bench) -> None:
    (status,) = [m for m in bench.tick() if m.get_type() == "SYS_STATUS"]
    # as a Rover with no battery monitor: its voltage 0 (MAVSDK would read UINT16_MAX as 65.535 V)
    assert (status.voltage_battery, status.current_battery, status.battery_remaining) == (0, -1, -1)


def test_nav_controller_output_as_rover_in_its_autopilot_modes(bench: Bench) -> None:
    # MAVProxy's console (distance and bearing to the waypoint) and QGroundControl read it
    from lfctl.link.endpoint import NavReport

    def navs(seconds: float = 2.0) -> list[object]:
        out = [m for _ in range(int(seconds / 0.02)) for m in bench.tick(0.02)]
        return [m for m in out if m.get_type() == "NAV_CONTROLLER_OUTPUT"]

    def stopped(got: list[object]) -> bool:  # GUIDED stopped: ModeGuided's Stop submode, all 0
        return bool(got) and all(
            (n.nav_bearing, n.target_bearing, n.wp_dist, n.xtrack_error) == (0, 0, 0, 0)  # type: ignore[attr-defined]
            for n in got
        )

    report = NavReport(math.radians(-10.6), math.radians(350.2), 12.7, -0.4, (12.0, -2.0))  # 0.4 m left of its leg
    bench.ep.steering(report)
    assert navs() == []  # HOLD: not an autopilot mode, as on Rover
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert stopped(navs())  # the report was for HOLD: not sent once the mode changed
    bench.ep.steering(report)
    got = navs()
    assert len(got) == 2  # 1 Hz in 2 s, in EXTENDED_STATUS
    n = got[-1]
    assert (n.nav_bearing, n.target_bearing, n.wp_dist) == (349, 350, 12)  # whole degrees and metres
    assert n.xtrack_error == pytest.approx(0.4)  # Rover's sign: positive left of the track
    assert n.nav_roll == n.nav_pitch == n.aspd_error == n.alt_error == 0
    # and where it is going, for MAVProxy's map: the place only, as Rover sends it
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, 87, 0, 0, 0, 0, 0, 0))
    (target,) = [m for m in bench.tick() if m.get_type() == "POSITION_TARGET_GLOBAL_INT"]
    lat, lon, alt = ned_to_geodetic(12.0, -2.0, 0.0, *HOME)
    assert (target.lat_int, target.lon_int) == (round(lat * 1e7), round(lon * 1e7))
    assert target.alt == pytest.approx(alt, abs=0.01) and target.coordinate_frame == mav.MAV_FRAME_GLOBAL
    assert target.type_mask == 0xFDF8  # velocities, accelerations, yaw and yaw rate ignored
    bench.ep.steering(NavReport(0.0, 0.0, 1e6, 0.0, (1e6, 0.0)))
    assert navs()[-1].wp_dist == 0xFFFF  # at most the field's largest
    bench.ep.steering(NavReport(0.0, 0.0, NAN, 0.0, (NAN, 0.0)))
    out = [m for _ in range(50) for m in bench.tick(0.02)]
    assert _count(out, "NAV_CONTROLLER_OUTPUT") == _count(out, "POSITION_TARGET_GLOBAL_INT") == 0
    assert bench.ep.stats.handler_errors == 0
    bench.ep.steering(None)
    assert stopped(navs())  # no destination: GUIDED stopped, as Rover reports it
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_EXTENDED_STATUS, 10, 1))
    bench.tick()
    bench.ep.steering(NavReport(0.0, 0.0, 3.0, 0.0, (3.0, 0.0)))
    assert 16 <= len(navs(2.0)) <= 21  # the group's rate (10 Hz, on 50 Hz ticks)
    for change in (lambda: bench.ep.set_armed(False), lambda: bench.command(mav.MAV_CMD_DO_SET_REVERSE, 1)):
        bench.ep.set_armed(True)
        bench.ep.steering(NavReport(0.0, 0.0, 3.0, 0.0, (3.0, 0.0)))
        change()
        assert stopped(navs(0.2))  # what it steered for changed: nothing stale goes out


def test_qgroundcontrols_connect_sequence_gets_every_answer_and_no_warning(bench: Bench) -> None:
    # QGroundControl's ArduPilot start-up (InitialConnectStateMachine, APMFirmwarePlugin's
    # stream rates, sent again every 10 s while no BATTERY_STATUS comes), over one minute
    def command(cmd: int, *p: float) -> None:
        bench.send(mav.MAVLink_command_long_message(1, 1, cmd, 0, *p, *([0.0] * (7 - len(p)))))

    def stream_rates() -> None:
        for group, hz in ((1, 2), (2, 2), (3, 2), (6, 3), (10, 10), (11, 10), (12, 3)):
            bench.send(mav.MAVLink_request_data_stream_message(1, 1, group, hz, 1))
        command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_HOME_POSITION, 1e6)
        command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, 1e6)

    stream_rates()
    command(mav.MAV_CMD_REQUEST_MESSAGE, mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    command(mav.MAV_CMD_REQUEST_MESSAGE, 397)  # COMPONENT_METADATA
    command(mav.MAV_CMD_REQUEST_MESSAGE, 435)  # AVAILABLE_MODES
    bench.send(mav.MAVLink_param_request_list_message(1, 1))
    out: list[object] = []
    for k in range(60 * 50):
        if k and k % 500 == 0:  # every 10 s
            stream_rates()
        out += bench.tick(0.02)
    acks = {}
    for m in out:
        if m.get_type() == "COMMAND_ACK":
            acks.setdefault((m.command, m.result), 0)
            acks[m.command, m.result] += 1
    assert acks[mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAV_RESULT_ACCEPTED] == 12  # 6 times, 2 messages
    assert acks[mav.MAV_CMD_REQUEST_MESSAGE, mav.MAV_RESULT_ACCEPTED] == 1
    assert acks[mav.MAV_CMD_REQUEST_MESSAGE, mav.MAV_RESULT_FAILED] == 2  # not sent by a Rover either
    texts = [m for m in out if m.get_type() == "STATUSTEXT"]
    assert [m.severity for m in texts] == [mav.MAV_SEVERITY_INFO] * 2  # the banner, no warning
    assert texts[0].text.startswith("lfctl V") and texts[1].text == "lfctl sim: v, sysid 1"
    assert _count(out, "AUTOPILOT_VERSION") == 1 and _count(out, "PARAM_VALUE") == len(bench.ep.params)
    # the rates it asked for (EXTRA2 10 Hz, EXTRA1 10 Hz, POSITION 3 Hz, EXTENDED_SYS_STATE 1 Hz), on 50 Hz ticks
    for name, hz in (("VFR_HUD", 10), ("ATTITUDE", 10), ("GLOBAL_POSITION_INT", 3), ("EXTENDED_SYS_STATE", 1)):
        assert 0.85 * 60 * hz <= _count(out, name) <= 60 * hz + 6, name  # each re-init may send one more


# -- the ground station's sticks (RC_CHANNELS_OVERRIDE, MANUAL_CONTROL) -------------------------
def test_sticks_are_taken_from_sysid_mygcs_only_and_another_sender_is_told_once(bench: Bench) -> None:
    mavsdk = mav.MAVLink(None, srcSystem=245, srcComponent=190)  # MAVSDK's default system id
    for _ in range(3):
        bench.raw(mav.MAVLink_manual_control_message(1, 0, 0, 800, 0, 0).pack(mavsdk))
        bench.tick()
    assert not bench.ep.pilot_input().active
    texts = [t for _, t in bench.ep.statustexts if "ignored" in t]
    assert texts == ["Manual control from 245 ignored: SYSID_MYGCS 255"]
    bench.send(mav.MAVLink_param_set_message(1, 1, b"SYSID_MYGCS", 245, mav.MAV_PARAM_TYPE_INT16))
    bench.tick()
    bench.raw(mav.MAVLink_manual_control_message(1, 0, 0, 800, 0, 0).pack(mavsdk))
    bench.tick()
    assert bench.ep.pilot_input().throttle == 0.78  # z 800 -> 1820 us: 100 x 290 / 370 = 78.4 %


def test_manual_control_aimed_elsewhere_is_not_taken_and_a_target_of_0_is_not_everyone(bench: Bench) -> None:
    for target in (0, 2):
        bench.send(mav.MAVLink_manual_control_message(target, 0, 500, 500, 0, 0))
        bench.tick()
    assert not bench.ep.pilot_input().active and bench.ep.stats.other_sysid == 2
    bench.send(mav.MAVLink_rc_channels_override_message(2, 1, 1700, 0, 1700, 0, 0, 0, 0, 0))
    bench.tick()
    assert not bench.ep.pilot_input().active  # RC override for vehicle 2


def test_sticks_keep_the_ground_station_alive_and_time_out_after_rc_override_time(bench: Bench) -> None:
    bench.ep.params["FS_GCS_ENABLE"].value = 1
    assert bench.set_mode("MANUAL") == mav.MAV_RESULT_ACCEPTED
    bench.ep.set_armed(True)
    for _ in range(8):  # 8 s of sticks and no heartbeat: no failsafe
        bench.send(mav.MAVLink_rc_channels_override_message(1, 1, 1900, 0, 1715, 0, 0, 0, 0, 0))
        bench.tick(1.0)
    pilot = bench.ep.pilot_input()
    assert bench.ep.mode == MODES["MANUAL"] and pilot.steering == 1.0 and pilot.throttle == pytest.approx(0.5)
    bench.tick(2.9)
    assert bench.ep.pilot_input().active
    bench.tick(0.2)  # RC_OVERRIDE_TIME (3 s) since the last: centred sticks
    assert not bench.ep.pilot_input().active
    bench.send(mav.MAVLink_param_set_message(1, 1, b"RC_OVERRIDE_TIME", -1, mav.MAV_PARAM_TYPE_REAL32))
    bench.send(mav.MAVLink_rc_channels_override_message(1, 1, 1900, 0, 1715, 0, 0, 0, 0, 0))
    bench.tick(0.02)
    bench.tick(5.0)  # -1: the override is kept, but the ground station is lost (FS_GCS_TIMEOUT 5 s) ...
    assert bench.ep.pilot_input().active and bench.ep.mode == MODES["MANUAL"]
    bench.tick(1.6)  # ... and FS_TIMEOUT later the failsafe holds and drops the override
    assert not bench.ep.pilot_input().active and bench.ep.mode == MODES["HOLD"]


def test_rc_channels_reports_the_live_overrides_at_the_rc_channels_streams_rate(bench: Bench) -> None:
    bench.send(mav.MAVLink_rc_channels_override_message(1, 1, 1700, 65535, 1900, 0, 0, 0, 0, 0))
    out = [m for _ in range(100) for m in bench.tick(0.02)]  # 2 s at the default 1 Hz
    rc = [m for m in out if m.get_type() == "RC_CHANNELS"]
    assert len(rc) == 2 and (rc[-1].chan1_raw, rc[-1].chan2_raw, rc[-1].chan3_raw) == (1700, 0, 1900)
    assert rc[-1].chancount == 0 and rc[-1].rssi == 255  # no receiver: none counted as received
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_RC_CHANNELS, 5, 1))
    out = [m for _ in range(100) for m in bench.tick(0.02)]  # 2 s at 5 Hz, past RC_OVERRIDE_TIME
    rc = [m for m in out if m.get_type() == "RC_CHANNELS"]
    assert 9 <= len(rc) <= 11 and rc[0].chan1_raw == 1700 and rc[-1].chan1_raw == rc[-1].chan3_raw == 0


def test_sticks_ignored_texts_are_rate_limited_and_told_again_for_a_new_sysid_mygcs(bench: Bench) -> None:
    for sysid in range(1, 101):  # a burst from 100 senders: one text
        bench.raw(mav.MAVLink_rc_channels_override_message(1, 1, 1700, 0, 0, 0, 0, 0, 0, 0).pack(
            mav.MAVLink(None, srcSystem=sysid, srcComponent=1)))  # fmt: skip
    bench.tick()
    assert sum("ignored" in t for _, t in bench.ep.statustexts) == 1
    bench.ep.params["SYSID_MYGCS"].value = 200
    bench.tick(3.0)
    bench.raw(mav.MAVLink_rc_channels_override_message(1, 1, 1700, 0, 0, 0, 0, 0, 0, 0).pack(
        mav.MAVLink(None, srcSystem=1, srcComponent=1)))  # fmt: skip
    bench.tick()
    assert [t for _, t in bench.ep.statustexts if "ignored" in t][-1] == "RC override from 1 ignored: SYSID_MYGCS 200"


def test_manual_control_keeps_the_ground_station_alive_and_any_stick_value_is_safe(bench: Bench) -> None:
    bench.ep.params["FS_GCS_ENABLE"].value = 1
    bench.ep.set_armed(True)
    assert bench.set_mode("MANUAL") == mav.MAV_RESULT_ACCEPTED
    bench.send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, 8, 0, 0, 4, 3))
    bench.tick()
    for y in (-32768, 32766, -3750, 0, -1000, 1000, 500, -500):  # 8 s of joystick, no heartbeat
        bench.send(mav.MAVLink_manual_control_message(1, 0, y, y, 0, 0))
        bench.tick(1.0)
    assert bench.ep.mode == MODES["MANUAL"] and bench.ep.stats.handler_errors == 0
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_RC_CHANNELS, 10, 1))
    bench.send(mav.MAVLink_manual_control_message(1, 0, -32768, 0, 0, 0))
    out = [m for _ in range(10) for m in bench.tick(0.05)]
    (rc,) = [m for m in out if m.get_type() == "RC_CHANNELS"][-1:]
    assert rc.chan1_raw == (1100 - 12707) & 0xFFFF and bench.ep.pilot_input().steering == -1.0
    bench.tick(6.0)  # nothing from the ground station for FS_GCS_TIMEOUT ...
    bench.tick(1.6)  # ... and FS_TIMEOUT more: HOLD
    assert bench.ep.mode == MODES["HOLD"]


def test_an_rc_override_to_system_0_is_taken(bench: Bench) -> None:
    bench.send(mav.MAVLink_rc_channels_override_message(0, 0, 65535, 65535, 1715, 65535, 0, 0, 0, 0))
    bench.tick()
    assert bench.ep.pilot_input().throttle == 0.5


# -- commands and parameters as Rover answers them --------------------------------------------
def test_force_arm_takes_ardupilots_magic_value_and_mavlinks(bench: Bench) -> None:
    assert bench.set_mode("RTL") == mav.MAV_RESULT_ACCEPTED
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1, 0) == mav.MAV_RESULT_FAILED  # RTL: not armable
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1, 2989) == mav.MAV_RESULT_ACCEPTED  # `arm throttle force`
    assert bench.ep.armed and bench.ep.statustexts[-1][1] == "Throttle armed"
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED
    # MAVLink's force value (MAVSDK's arm_force sends it) forces an arm too, as on Rover 4.6
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1, 21196) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.armed
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 21196) == mav.MAV_RESULT_ACCEPTED
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1, 1) == mav.MAV_RESULT_FAILED  # not a force value
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 2) == mav.MAV_RESULT_UNSUPPORTED


def test_choosing_the_mode_the_vehicle_is_in_changes_nothing(bench: Bench) -> None:
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    x, y = (int(round(v * 1e7)) for v in ned_to_geodetic(5.0, 5.0, 0.0, *HOME)[:2])
    bench.send(mav.MAVLink_command_int_message(1, 1, 0, mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, 0, x, y, 0))
    bench.tick()
    assert bench.ep.guided is not None
    modes_before = list(bench.ep.modes)
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.guided is not None and bench.ep.modes == modes_before  # the target kept, no mode change


def test_an_autopilot_mode_starts_forwards_at_its_default_speed(bench: Bench) -> None:
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert bench.command(mav.MAV_CMD_DO_CHANGE_SPEED, 1, 0.7) == mav.MAV_RESULT_FAILED  # stopped: no speed to set
    x, y = (int(round(v * 1e7)) for v in ned_to_geodetic(5.0, 5.0, 0.0, *HOME)[:2])
    bench.send(mav.MAVLink_command_int_message(1, 1, 0, mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, 0, x, y, 0))
    bench.tick()
    assert bench.command(mav.MAV_CMD_DO_CHANGE_SPEED, 1, 0.7) == mav.MAV_RESULT_ACCEPTED
    assert bench.command(mav.MAV_CMD_DO_SET_REVERSE, 1) == mav.MAV_RESULT_ACCEPTED
    assert bench.set_mode("HOLD") == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.reversed and bench.ep.desired_speed_mps == pytest.approx(0.7)  # HOLD: not an autopilot mode
    assert bench.set_mode("RTL") == mav.MAV_RESULT_ACCEPTED
    assert not bench.ep.reversed and bench.ep.desired_speed_mps is None  # Mode::init_reversed_flag, RTL's _enter
    assert bench.command(mav.MAV_CMD_DO_CHANGE_SPEED, 1, 0.3) == mav.MAV_RESULT_ACCEPTED  # RTL takes a speed


def _from_network(bench: Bench, msg: object, sender: mav.MAVLink) -> None:
    """``msg`` from ``sender``, as if it came over UDP (the endpoint's other channel)."""
    bench.a.inbox.append((msg.pack(sender), ("127.0.0.1", 14550)))  # type: ignore[attr-defined]


def test_what_is_for_another_component_is_acted_on_as_rover_routes_it(bench: Bench) -> None:
    # MAVLink_routing::check_and_forward: a component Rover has heard on another channel gets
    # the message passed on, not acted on; one it has no route to, or a route on the channel
    # the message came on, leaves it to the autopilot (a COMMAND_LONG to component 25 is ACKed)
    companion = mav.MAVLink(None, srcSystem=1, srcComponent=191)
    _from_network(bench, mav.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3), companion)
    bench.send(mav.MAVLink_command_long_message(1, 191, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0))
    bench.ep.routed_components = {100}  # the vehicle's camera, reached on its own channel
    bench.send(mav.MAVLink_param_set_message(1, 100, b"WP_SPEED", 3.0, mav.MAV_PARAM_TYPE_REAL32))
    out = bench.tick()
    assert not bench.ep.armed and bench.ep.param("WP_SPEED") == 2.0
    assert not [m for m in out if m.get_type() in ("COMMAND_ACK", "PARAM_VALUE")]
    assert bench.command_to(25, mav.MAV_CMD_RUN_PREARM_CHECKS) == mav.MAV_RESULT_ACCEPTED  # no route to 25
    bench.send(mav.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3))  # the ground station, on the memory channel
    ground = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    _from_network(bench, mav.MAVLink_command_long_message(1, 191, 400, 0, 1, 0, 0, 0, 0, 0, 0), ground)
    bench.tick()  # the companion is on that channel: Rover passes nothing on, and acts on it
    assert bench.ep.armed
    # a broadcast to the system, naming a component: passed on to every sender heard elsewhere
    _from_network(bench, mav.MAVLink_command_long_message(0, 25, 400, 0, 0, 0, 0, 0, 0, 0, 0), ground)
    bench.tick()
    assert bench.ep.armed


def test_a_clients_tries_again_of_a_refused_parameter_request_are_said_once(
    bench: Bench, monkeypatch: pytest.MonkeyPatch
) -> None:
    # MAVSDK sends a PARAM_SET or a read five times more when no answer of its liking comes:
    # lfctl's own warning goes out once a second (a Rover says nothing of an unknown name),
    # ArduPilot's read-only refusal each time, as a Rover's
    import lfctl.link.param_server as ps

    now = [100.0]
    monkeypatch.setattr(ps.time, "monotonic", lambda: now[0])

    def texts(*messages: Any) -> list[str]:
        before = len(bench.ep.statustexts)
        for m in messages:
            bench.send(m)
            bench.tick()
        return [t for _s, t in bench.ep.statustexts[before:]]

    nope = mav.MAVLink_param_request_read_message(1, 1, b"NOPE", -1)
    far = mav.MAVLink_param_set_message(1, 1, b"WP_SPEED", 1000.0, mav.MAV_PARAM_TYPE_REAL32)
    assert texts(*[nope] * 6, *[far] * 6) == ["Unknown parameter NOPE", "WP_SPEED rejected: 1000 outside 0..100 m/s"]
    # ... per sender: another client (a second `lfctl gcs`, from another port) is told at once
    from lfctl.link.param_server import ParamServer

    said: list[str] = []
    who = ["127.0.0.1:40001"]
    server = ParamServer(bench.ep.params, lambda m: None, lambda text, sev: said.append(text), lambda: who[0])
    server.request_read(nope)
    server.request_read(nope)
    who[0] = "127.0.0.1:40002"
    server.request_read(nope)
    assert said == ["Unknown parameter NOPE", "Unknown parameter NOPE"]
    now[0] += 1.5  # a request made again later is answered again
    assert texts(nope, mav.MAVLink_param_request_read_message(1, 1, b"NOPE2", -1)) == [
        "Unknown parameter NOPE",
        "Unknown parameter NOPE2",
    ]


def test_param_value_answers_a_set_and_a_read_by_name_with_index_minus_1(bench: Bench) -> None:
    bench.send(mav.MAVLink_param_set_message(1, 1, b"WP_SPEED", 1.5, mav.MAV_PARAM_TYPE_REAL32))
    (echo,) = [m for m in bench.tick() if m.get_type() == "PARAM_VALUE"]
    assert (echo.param_id, echo.param_value, echo.param_index) == ("WP_SPEED", 1.5, 65535)
    bench.send(mav.MAVLink_param_request_read_message(1, 1, b"WP_SPEED", -1))
    (by_name,) = [m for m in bench.tick() if m.get_type() == "PARAM_VALUE"]
    assert by_name.param_index == 65535 and by_name.param_count == len(bench.ep.params)
    bench.send(mav.MAVLink_param_request_read_message(1, 1, b"", 1))
    (by_index,) = [m for m in bench.tick() if m.get_type() == "PARAM_VALUE"]
    assert by_index.param_index == 1 and by_index.param_id == list(bench.ep.params)[1]
    bench.send(mav.MAVLink_param_set_message(1, 1, b"SYSID_THISMAV", 7, mav.MAV_PARAM_TYPE_INT16))
    (kept,) = [m for m in bench.tick() if m.get_type() == "PARAM_VALUE"]
    assert kept.param_value == 1 and bench.ep.statustexts[-1][1] == "Param write denied (SYSID_THISMAV)"


def test_set_home_autopilot_capabilities_and_prearm_checks_answer_as_rover(bench: Bench) -> None:
    assert bench.command(mav.MAV_CMD_DO_SET_HOME, 2, 0, 0, 0, 12.96, 77.67, 900) == mav.MAV_RESULT_FAILED
    assert bench.command(mav.MAV_CMD_DO_SET_HOME, 3, 0, 0, 0, 0, 0, 0) == mav.MAV_RESULT_ACCEPTED  # 0, 0: here
    assert bench.command(mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 0) == mav.MAV_RESULT_FAILED
    assert bench.command(mav.MAV_CMD_RUN_PREARM_CHECKS) == mav.MAV_RESULT_ACCEPTED
    bench.ep.set_armed(True)
    assert bench.command(mav.MAV_CMD_RUN_PREARM_CHECKS) == mav.MAV_RESULT_TEMPORARILY_REJECTED


def test_reboot_is_refused_as_rover_refuses_it(bench: Bench) -> None:
    reboot = mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN
    for param1 in (0, 2, 3, NAN):  # nothing, shut down, into the bootloader: not lfctl's
        assert bench.command(reboot, param1) == mav.MAV_RESULT_UNSUPPORTED
    bench.ep.set_armed(True)
    for param1 in (1, 0, 3):  # armed: anything unforced is FAILED, checked first as on Rover
        assert bench.command(reboot, param1) == mav.MAV_RESULT_FAILED
    assert bench.ep.armed and not bench.ep.rebooting


def _reboot_frames(force: float, *then: object) -> bytes:
    """A reboot (COMMAND_INT, its y the force value) and more frames, in one datagram."""
    gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    reboot = mav.MAVLink_command_int_message(
        1, 1, 0, mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0, 0, 1, 0, 0, 0, 0, int(force), 0
    )
    return b"".join(m.pack(gcs) for m in (reboot, *then))  # type: ignore[attr-defined]


@pytest.mark.parametrize("armed", [False, True])
def test_a_reboot_goes_quiet_then_starts_afresh_keeping_what_a_rover_stores(bench: Bench, armed: bool) -> None:
    assert upload(bench, good_mission()) == mav.MAV_MISSION_ACCEPTED
    assert bench.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 2) == mav.MAV_RESULT_ACCEPTED
    bench.send(mav.MAVLink_param_set_message(1, 1, b"WP_SPEED", 1.5, mav.MAV_PARAM_TYPE_REAL32))
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_POSITION, 5, 1))
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_ATTITUDE, 1e5) == mav.MAV_RESULT_ACCEPTED
    here = dict(zip(("lat", "lon"), ned_to_geodetic(1.0, 2.0, 0.0, *HOME)[:2], strict=True))
    assert (
        bench.command(mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, here["lat"], here["lon"], HOME[2] + 12.5)
        == mav.MAV_RESULT_ACCEPTED
    )  # locked, 12.5 m above the ground
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    bench.send(
        mav.MAVLink_set_position_target_local_ned_message(0, 1, 1, 1, 0b110111111000, 5, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0)
    )
    bench.ep.set_armed(armed)
    bench.tick(10.0)
    assert bench.ep.guided is not None and bench.ep.current_seq == 2 and bench.ep.home_locked
    # one datagram: a reboot (COMMAND_INT; forced when armed, as MAVProxy's `reboot force`),
    # then a mode change and an arm: only the reboot is acted on, the rest is recorded
    arm = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    manual = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_DO_SET_MODE, 0, 1, MODES["MANUAL"], 0, 0, 0, 0, 0)
    bench.raw(_reboot_frames(20190226 if armed else 0, manual, arm))
    (ack,) = [m for m in bench.tick() if m.get_type() == "COMMAND_ACK"]
    assert (ack.command, ack.result) == (mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, mav.MAV_RESULT_ACCEPTED)
    assert bench.ep.rebooting and not bench.ep.armed and bench.ep.mode == MODES["HOLD"]
    # restarting: nothing goes out, nothing is acted on (another arm gets no answer)
    bench.send(arm)
    quiet = [m for _ in range(95) for m in bench.tick(0.02)]
    assert quiet == [] and bench.ep.stats.rebooting == 3 and not bench.ep.armed
    arms = [r for r in bench.records if '"direction": "in"' in r and '"command": 400,' in r]
    assert len(arms) == 2  # recorded as they came, not acted on
    out = [m for _ in range(60) for m in bench.tick(0.02)]
    assert not bench.ep.rebooting
    texts = [m.text for m in out if m.get_type() == "STATUSTEXT"]
    assert texts == ["ArduPilot Ready"]  # AP_Vehicle::setup's last words
    (first, *_) = [m for m in out if m.get_type() == "ATTITUDE"]
    assert first.time_boot_ms < 200  # time_boot_ms from the new start
    assert out[0].get_seq() == 0  # the MAVLink sequence too
    beat = [m for m in out if m.get_type() == "HEARTBEAT"][-1]
    assert beat.custom_mode == MODES["HOLD"] and not beat.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED
    # RAM is new: SET_MESSAGE_INTERVAL's rate gone (ATTITUDE 1 Hz again, not 10 Hz), home
    # unlocked and on the ground, no GUIDED target
    assert 1 <= _count(out, "ATTITUDE") <= 2
    assert not bench.ep.home_locked and bench.ep.guided is None
    home = [m for m in out if m.get_type() == "GLOBAL_POSITION_INT"][-1]
    assert home.relative_alt == 0
    # ... and REQUEST_DATA_STREAM's (POSITION at 5 Hz) too: Rover sets its SRn_ in RAM
    # (persist_streamrates is false), so GLOBAL_POSITION_INT is at its 1 Hz again
    assert 1 <= _count(out, "GLOBAL_POSITION_INT") <= 2
    # storage is kept: the parameter, the mission, with no item under way (MISSION_CURRENT 0:
    # AUTO starts it at item 1)
    assert bench.ep.param("WP_SPEED") == 1.5
    assert len(bench.ep.mission) == len(good_mission()) and bench.ep.current_seq == 0
    assert bench.ep.stats.handler_errors == 0


def test_the_banner_on_request_and_before_a_parameter_list_as_rover(bench: Bench) -> None:
    # MAVProxy's `useralerts check` sends DO_SEND_BANNER; a parameter list starts with it too
    bench.tick()
    assert bench.command(mav.MAV_CMD_DO_SEND_BANNER) == mav.MAV_RESULT_ACCEPTED
    assert [t for _, t in bench.ep.statustexts[-2:]] == [
        f"lfctl V{__version__} (Rover, ArduPilot MAVLink)",
        "lfctl sim: v, sysid 1",
    ]
    bench.send(mav.MAVLink_param_request_list_message(1, 1))
    out = bench.tick()
    kinds = [m.get_type() for m in out if m.get_type() in ("STATUSTEXT", "PARAM_VALUE")]
    assert kinds[:3] == ["STATUSTEXT", "STATUSTEXT", "PARAM_VALUE"]
    texts = [m for m in out if m.get_type() == "STATUSTEXT"]
    assert [m.severity for m in texts] == [mav.MAV_SEVERITY_INFO] * 2
    companion = mav.MAVLink(None, srcSystem=1, srcComponent=191)  # heard over the network: Rover routes to it
    _from_network(bench, mav.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3), companion)
    bench.send(mav.MAVLink_param_request_list_message(1, 191))  # that component's list: nothing
    assert not [m for m in bench.tick() if m.get_type() in ("STATUSTEXT", "PARAM_VALUE")]


def test_gps_global_origin_and_attitude_quaternion_when_asked_for(bench: Bench) -> None:
    first = bench.tick()  # home is set as the autopilot starts: AP_AHRS::set_home sends both, once
    assert [m.get_type() for m in first if m.get_type() in ("HOME_POSITION", "GPS_GLOBAL_ORIGIN")] == [
        "HOME_POSITION",
        "GPS_GLOBAL_ORIGIN",
    ]
    out = [m for _ in range(100) for m in bench.tick(0.02)]
    streamed = ("GPS_GLOBAL_ORIGIN", "ATTITUDE_QUATERNION", "HOME_POSITION")
    assert not [m for m in out if m.get_type() in streamed]  # none streamed: HOME_POSITION is in no group
    bench.send(
        mav.MAVLink_command_int_message(1, 1, 0, mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, 0, 0, 129605000, 776695000, 900)
    )
    said = [m.get_type() for m in bench.tick() if m.get_type() in ("HOME_POSITION", "GPS_GLOBAL_ORIGIN")]
    assert said == ["HOME_POSITION", "GPS_GLOBAL_ORIGIN"]  # set_home again: both
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_GET_HOME_POSITION, 0, 0, 0, 0, 0, 0, 0, 0))
    out = bench.tick()
    (origin,) = [m for m in out if m.get_type() == "GPS_GLOBAL_ORIGIN"]
    (home,) = [m for m in out if m.get_type() == "HOME_POSITION"]
    # the origin stays where local NED is anchored when home moves
    assert (origin.latitude, origin.longitude, origin.altitude) == (129602000, 776690000, 900000)
    assert (home.latitude, home.longitude) == pytest.approx((129605000, 776695000), abs=50)
    msg_id = mav.MAVLINK_MSG_ID_ATTITUDE_QUATERNION
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 100_000) == mav.MAV_RESULT_ACCEPTED
    quats = [m for _ in range(50) for m in bench.tick(0.02) if m.get_type() == "ATTITUDE_QUATERNION"]
    assert 9 <= len(quats) <= 11
    q = quats[-1]
    assert (q.q1, q.q2, q.q3, q.q4) == pytest.approx((math.cos(0.25), 0, 0, math.sin(0.25)))  # yaw 0.5 rad


def test_a_rover_mode_lfctl_does_not_fly_is_named_and_a_failed_change_says_so(bench: Bench) -> None:
    assert bench.set_mode("MANUAL") == mav.MAV_RESULT_ACCEPTED
    bench.send(mav.MAVLink_set_mode_message(1, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 1))
    bench.tick()
    assert [t for _, t in bench.ep.statustexts[-2:]] == ["ACRO mode not supported", "Flight mode change failed"]
    n = len(bench.ep.statustexts)
    assert bench.command(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 16) == mav.MAV_RESULT_FAILED
    assert [t for _, t in bench.ep.statustexts[n:]] == ["Flight mode change failed"]  # INITIALISING never starts
    bench.send(mav.MAVLink_set_mode_message(1, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES["AUTO"]))
    said = [(m.severity, m.text) for m in bench.tick() if m.get_type() == "STATUSTEXT"]  # no mission:
    # ModeAuto::_enter's words at NOTICE, Rover::set_mode's failure at WARNING
    assert said == [
        (mav.MAV_SEVERITY_NOTICE, "No Mission. Can't set AUTO."),
        (mav.MAV_SEVERITY_WARNING, "Flight mode change failed"),
    ]


def test_prearm_checks_as_rovers_with_arming_check_and_the_sys_status_ready_bit(bench: Bench) -> None:
    def prearm_bits() -> tuple[bool, bool, bool]:
        (status,) = [m for m in bench.tick(1.0) if m.get_type() == "SYS_STATUS"][-1:]
        return tuple(  # type: ignore[return-value]
            bool(bits & mav.MAV_SYS_STATUS_PREARM_CHECK)
            for bits in (
                status.onboard_control_sensors_present,
                status.onboard_control_sensors_enabled,
                status.onboard_control_sensors_health,
            )
        )

    def ready() -> bool:
        return prearm_bits() == (True, True, True)

    assert ready()
    bench.send(mav.MAVLink_param_set_message(1, 1, b"WP_SPEED", 0.0, mav.MAV_PARAM_TYPE_REAL32))
    assert not ready()  # QGroundControl: "Not Ready"
    assert bench.command(mav.MAV_CMD_RUN_PREARM_CHECKS) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.statustexts[-1][1] == "PreArm: WP_SPEED too low"
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_FAILED
    assert bench.ep.statustexts[-1][1] == "Arm: WP_SPEED too low" and not bench.ep.armed
    bench.send(mav.MAVLink_param_set_message(1, 1, b"ARMING_CHECK", 3, mav.MAV_PARAM_TYPE_INT32))
    bench.tick()
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_FAILED  # bit 1, all: still checked
    bench.send(mav.MAVLink_param_set_message(1, 1, b"ARMING_CHECK", 64, mav.MAV_PARAM_TYPE_INT32))
    (echo,) = [m for m in bench.tick() if m.get_type() == "PARAM_VALUE"]
    assert echo.param_type == mav.MAV_PARAM_TYPE_INT32  # MAVProxy's `arm check` reads it as a bitmask
    assert ready()  # the parameter checks (32) are off
    assert bench.set_mode("RTL") == mav.MAV_RESULT_ACCEPTED
    assert not ready() and bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_FAILED
    bench.send(mav.MAVLink_param_set_message(1, 1, b"ARMING_CHECK", 0, mav.MAV_PARAM_TYPE_INT32))
    # no checks: the verdict is present but neither enabled nor healthy (GCS_Common's
    # update_sensor_status_flags: only with checks enabled), and Rover arms in RTL too, and warns
    assert prearm_bits() == (True, False, False)
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED and bench.ep.armed
    assert "Warning: Arming Checks Disabled" in [t for _, t in bench.ep.statustexts[-2:]]
    assert prearm_bits() == (True, False, False)  # armed too


@pytest.mark.parametrize("force", [2989.0, 21196.0])
def test_a_forced_arm_does_not_warn_that_the_checks_are_disabled(bench: Bench, force: float) -> None:
    # AP_Arming::arm warns only "if (armed && do_arming_checks && checks_to_perform == 0)": a
    # forced arm (MAVProxy's `arm throttle force`) runs no checks, so it has nothing to warn of
    bench.send(mav.MAVLink_param_set_message(1, 1, b"ARMING_CHECK", 0, mav.MAV_PARAM_TYPE_INT32))
    bench.tick()
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1, force) == mav.MAV_RESULT_ACCEPTED and bench.ep.armed
    assert "Warning: Arming Checks Disabled" not in [t for _, t in bench.ep.statustexts]


def _prearm_times(bench: Bench, text: str, until_s: float) -> list[float]:
    """When ``text`` went out as the bench ticks at 10 Hz up to ``until_s``, s since boot."""
    while bench.t < until_s - 1e-9:
        bench.tick(0.1)
    return [round(t, 1) for t, said in bench.ep.statustexts if said == text]


def test_a_failing_prearm_check_of_rovers_own_is_said_every_30_s_of_the_boot_clock(bench: Bench) -> None:
    # AP_Arming::update runs once a second from boot and displays when more than 30 s have
    # passed since the last display, which moves whether anything failed or not: at 31 s, 62
    # s, 93 s. WP_SPEED (Rover's parameter_checks) is not among the common checks whose turn
    # to failing is said sooner, so WP_SPEED 0 set at 10 s is said first at 31 s
    bench.tick(10.0)
    bench.send(mav.MAVLink_param_set_message(1, 1, b"WP_SPEED", 0.0, mav.MAV_PARAM_TYPE_REAL32))
    assert _prearm_times(bench, "PreArm: WP_SPEED too low", 100.0) == pytest.approx([31.0, 62.0, 93.0], abs=0.11)


def test_a_common_check_that_starts_failing_is_said_within_2_s(bench: Bench) -> None:
    # the fence (AP_Arming's own fence_checks): passing until 40.05 s, failing from then. The
    # update at 41 s runs the checks and sees the turn (report_immediately); the one at 42 s,
    # more than 4 s after the last display (31 s), says it; then every 31 s of the boot clock
    assert _prearm_times(bench, "", 40.0) == []  # (every update run, once a second)
    bench.send(mav.MAVLink_param_set_message(1, 1, b"FENCE_TYPE", 4.0, mav.MAV_PARAM_TYPE_INT8))
    bench.send(mav.MAVLink_param_set_message(1, 1, b"FENCE_ENABLE", 1.0, mav.MAV_PARAM_TYPE_INT8))
    times = _prearm_times(bench, "PreArm: Fences enabled, but none selected", 100.0)
    assert times == pytest.approx([42.0, 73.0], abs=0.11)  # (to a 0.1 s tick)


def test_a_vehicle_failing_a_common_check_from_boot_says_so_first_at_31_s(bench: Bench) -> None:
    # AP_Arming starts with "the checks did not pass" (its RAM is zero at boot): no turn to
    # failing is seen, so the first display is the 30 s one
    bench.send(mav.MAVLink_param_set_message(1, 1, b"FENCE_TYPE", 4.0, mav.MAV_PARAM_TYPE_INT8))
    bench.send(mav.MAVLink_param_set_message(1, 1, b"FENCE_ENABLE", 1.0, mav.MAV_PARAM_TYPE_INT8))
    assert _prearm_times(bench, "PreArm: Fences enabled, but none selected", 40.0) == pytest.approx([31.0], abs=0.11)


def test_guided_takes_a_speed_once_it_has_arrived(bench: Bench) -> None:
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    x, y = (int(round(v * 1e7)) for v in ned_to_geodetic(5.0, 5.0, 0.0, *HOME)[:2])
    bench.send(mav.MAVLink_command_int_message(1, 1, 0, mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, 0, x, y, 0))
    bench.tick()
    bench.ep.guided_reached()  # the simulation drove it there
    assert bench.ep.guided is None  # stopped there
    assert bench.command(mav.MAV_CMD_DO_CHANGE_SPEED, 1, 0.7) == mav.MAV_RESULT_ACCEPTED


def test_messages_for_equipment_not_fitted_are_accepted_and_system_time_is_sent(bench: Bench) -> None:
    # as a Rover with no battery monitor: MAVSDK's set_rate_battery and a request succeed, nothing comes
    battery = mav.MAVLINK_MSG_ID_BATTERY_STATUS
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, battery, 1e6) == mav.MAV_RESULT_ACCEPTED
    assert bench.command(mav.MAV_CMD_REQUEST_MESSAGE, battery) == mav.MAV_RESULT_ACCEPTED
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_GET_MESSAGE_INTERVAL, 0, battery, 0, 0, 0, 0, 0, 0))
    (interval,) = [m for m in bench.tick() if m.get_type() == "MESSAGE_INTERVAL"]
    assert interval.interval_us == 1_000_000
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_RAW_IMU, 1e6) == mav.MAV_RESULT_DENIED
    # SYSTEM_TIME with the EXTRA3 group: the run's start plus the simulation time; the group
    # sets the battery's rate too (Rover's STREAM_EXTRA3), and "default" is the group's rate
    t0 = time.time()
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_EXTRA3, 2, 1))
    bench.tick()
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_SYSTEM_TIME, 1e5) == 0
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_SYSTEM_TIME, 0) == 0
    for msg_id in (battery, mav.MAVLINK_MSG_ID_SYSTEM_TIME):
        bench.send(
            mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_GET_MESSAGE_INTERVAL, 0, msg_id, 0, 0, 0, 0, 0, 0)
        )
        (interval,) = [m for m in bench.tick() if m.get_type() == "MESSAGE_INTERVAL"]
        assert interval.interval_us == 500_000
    times = [m for _ in range(100) for m in bench.tick(0.02) if m.get_type() == "SYSTEM_TIME"]
    assert 3 <= len(times) <= 5
    last = times[-1]
    assert last.time_boot_ms == pytest.approx(bench.t * 1000, abs=510)  # within a period (2 Hz)
    assert last.time_unix_usec / 1e6 - last.time_boot_ms / 1e3 == pytest.approx(t0, abs=5.0)


def test_mavlink_ftp_answers_the_asker_and_only_for_this_vehicle(bench: Bench) -> None:
    def ask(seq: int, opcode: int, name: bytes, target: int = 1, network: int = 0) -> list[Any]:
        payload = list((struct.pack("<HBBBBBBI", seq, 0, opcode, len(name), 0, 0, 0, 0) + name).ljust(251, b"\0"))
        bench.send(mav.MAVLink_file_transfer_protocol_message(network, target, 1, payload))
        return [m for m in bench.tick() if m.get_type() == "FILE_TRANSFER_PROTOCOL"]

    (answer,) = ask(7, 4, b"@PARAM/param.pck?withdefaults=1")  # OpenFileRO: its size
    assert (answer.target_system, answer.target_component) == (255, 190)
    size = len(bench.ep.param_server.packed("withdefaults=1"))
    assert struct.unpack_from("<HBBB", bytes(answer.payload)) == (8, 0, 128, 4)
    assert struct.unpack_from("<I", bytes(answer.payload), 12) == (size,)
    assert ask(8, 1, b"") != []  # TerminateSession
    assert ask(9, 4, b"@PARAM/param.pck", target=2) == []  # another vehicle's
    assert ask(10, 4, b"@PARAM/param.pck", network=3) != []  # the network is not looked at
    (missing,) = ask(11, 14, b"APM/LOGS/00000001.BIN")  # a Rover's log: no such file here
    assert struct.unpack_from("<HBBB", bytes(missing.payload)) == (12, 0, 129, 1) and missing.payload[12] == 10
    # AUTOPILOT_VERSION says MAVLink FTP is served, as a Rover's does
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, 148, 0, 0, 0, 0, 0, 0))
    (version,) = [m for m in bench.tick() if m.get_type() == "AUTOPILOT_VERSION"]
    assert version.capabilities & mav.MAV_PROTOCOL_CAPABILITY_FTP
    # a board's unique id (MAVSDK's hardware_uid): each vehicle its own, the same from run to run
    from lfctl.link.endpoint import _board_uid

    assert list(version.uid2) == _board_uid(bench.ep.name) and any(version.uid2) and len(version.uid2) == 18
    assert _board_uid("follower1") != _board_uid("follower2") and _board_uid("x") == _board_uid("x")


def test_downloaded_frames_are_rovers_for_places_commands_fences_and_rally_points(bench: Bench) -> None:
    lat, lon = (int(round(v * 1e7)) for v in ned_to_geodetic(3.0, 0.0, 0.0, *HOME)[:2])
    rel = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    mission = [
        mav.MAVLink_mission_item_int_message(1, 1, 0, mav.MAV_FRAME_GLOBAL_INT, 16, 0, 1, 0, 0, 0, 0, lat, lon, 900, 0),
        mav.MAVLink_mission_item_int_message(1, 1, 1, rel, 16, 0, 1, 0, 0, 0, 0, lat, lon, 0, 0),
        mav.MAVLink_mission_item_int_message(1, 1, 2, mav.MAV_FRAME_MISSION, 178, 0, 1, 1, 0.5, -1, 0, 0, 0, 0, 0),
        mav.MAVLink_mission_item_int_message(1, 1, 3, rel, 19, 0, 1, 2, 0, 0, 0, lat, lon + 100, 0, 0),
    ]
    assert upload(bench, mission) == mav.MAV_MISSION_ACCEPTED
    frames = [it.frame for it in download(bench, mav.MAV_MISSION_TYPE_MISSION)]  # type: ignore[attr-defined]
    assert frames == [mav.MAV_FRAME_GLOBAL, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, mav.MAV_FRAME_GLOBAL, 3]
    fence = [
        mav.MAVLink_mission_item_int_message(1, 1, k, rel, 5001, 0, 1, 3, 0, 0, 0, lat + dy, lon + dx, 5, 1)
        for k, (dy, dx) in enumerate(((1000, 1000), (1000, -1000), (-1000, 0)))
    ]
    assert upload(bench, fence, mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_ACCEPTED
    back = download(bench, mav.MAV_MISSION_TYPE_FENCE)
    assert {(it.frame, it.z) for it in back} == {(mav.MAV_FRAME_GLOBAL, 0.0)}  # type: ignore[attr-defined]
    # MissionItemProtocol_Fence::get_item_as_mission_item builds each item afresh: param1 (the
    # vertex count, a byte: 3.7 uploaded is 3) and the place, autocontinue 0 (uploaded as 1);
    # a return point's param1 is none (5 uploaded is 0)
    fence = [
        mav.MAVLink_mission_item_int_message(1, 1, k, rel, 5001, 0, 1, 3.7, 4, 0, 0, lat + dy, lon + dx, 5, 1)
        for k, (dy, dx) in enumerate(((1000, 1000), (1000, -1000), (-1000, 0)))
    ] + [mav.MAVLink_mission_item_int_message(1, 1, 3, rel, 5000, 0, 1, 5, 0, 0, 0, lat, lon, 0, 1)]
    assert upload(bench, fence, mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_ACCEPTED
    back = download(bench, mav.MAV_MISSION_TYPE_FENCE)
    got = [(it.autocontinue, it.param1, it.param2) for it in back]  # type: ignore[attr-defined]
    assert got == [(0, 3.0, 0.0)] * 3 + [(0, 0.0, 0.0)]
    rally = [mav.MAVLink_mission_item_int_message(1, 1, 0, rel, 5100, 0, 1, 7, 8, 9, 10, lat, lon, 10.7, 2)]
    assert upload(bench, rally, mav.MAV_MISSION_TYPE_RALLY) == mav.MAV_MISSION_ACCEPTED
    (point,) = download(bench, mav.MAV_MISSION_TYPE_RALLY)
    # MissionItemProtocol_Rally: the place and its altitude alone (an int16: 10.7 m is 10),
    # autocontinue 0
    assert point.frame == 3 and point.autocontinue == 0 and point.z == 10.0  # type: ignore[attr-defined]
    assert (point.param1, point.param2, point.param3, point.param4) == (0.0, 0.0, 0.0, 0.0)  # type: ignore[attr-defined]


def test_a_downloaded_item_has_the_params_rover_keeps_in_their_types(bench: Bench) -> None:
    # AP_Mission keeps each command's params in fields of its own types and gives them back
    # so: a waypoint's wait in 16 bits (2.5 -> 2; its yaw, NaN, and radii not kept), a
    # loiter's direction as the sign of its radius or +-1, a circle's turns and radius in
    # bytes, DO_JUMP's target and count whole, a speed type in a byte, the speed as sent
    lat, lon = (int(round(v * 1e7)) for v in ned_to_geodetic(3.0, 0.0, 0.0, *HOME)[:2])
    rel, nan = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, math.nan
    sent = [
        (16, (0, 0, 0, 0)),
        (16, (2.5, 1.5, 3.0, nan)),  # wait, acceptance radius, pass radius, yaw
        (17, (7.0, 0, -12.7, 0)),  # loiter for ever, counter-clockwise 12.7 m
        (18, (2.9, 0, -300.0, 0.5)),  # two turns (of 2.9), 300 m counter-clockwise, xtrack
        (19, (10.9, 0, 4.0, 0)),  # loiter 10 s, clockwise
        (20, (1, 2, 3, 4)),
        (177, (1.7, 2.9, 5, 0)),  # jump to 1, twice
        (178, (1.6, 0.45, 30.5, 0)),  # ground speed 0.45 m/s, throttle 30.5 %
        (194, (1.0, 0, 0, 0)),
        (112, (2.5, 0, 0, 0)),  # a condition's seconds: a float
        (18, (0.3, 0, -0.5, 0)),  # 0.3 turns in 256ths; counter-clockwise at a radius kept as 0
    ]
    mission = [
        mav.MAVLink_mission_item_int_message(1, 1, k, rel, cmd, 0, 1, *p, lat + k, lon, 0, 0)
        for k, (cmd, p) in enumerate(sent)
    ]
    assert upload(bench, mission) == mav.MAV_MISSION_ACCEPTED
    back = [(it.param1, it.param2, it.param3, it.param4) for it in download(bench, mav.MAV_MISSION_TYPE_MISSION)]  # type: ignore[attr-defined]
    assert back[1:] == [
        (2.0, 0.0, 0.0, 0.0),
        (0.0, 0.0, -12.0, 0.0),
        (2.0, 0.0, -300.0, 1.0),
        (10.0, 0.0, 1.0, 0.0),
        (0.0, 0.0, 0.0, 0.0),
        (1.0, 2.0, 0.0, 0.0),
        (1.0, pytest.approx(0.45), 30.5, 0.0),
        (1.0, 0.0, 0.0, 0.0),
        (2.5, 0.0, 0.0, 0.0),
        (76 / 256, 0.0, 0.0, 0.0),
    ]
    assert math.copysign(1.0, back[-1][2]) == -1.0  # the direction kept apart from the radius: -0
    assert bench.ep.mission[1].param1 == 2.0  # and the vehicle reads them as kept


def test_a_received_mission_is_said_in_rovers_words_and_a_clear_is_silent(bench: Bench) -> None:
    # scripts written for ArduPilot wait for "Flight plan received" after an upload
    assert upload(bench, good_mission(3)) == mav.MAV_MISSION_ACCEPTED
    assert bench.ep.statustexts[-1][1] == "Flight plan received"
    before = len(bench.ep.statustexts)
    bench.send(mav.MAVLink_mission_clear_all_message(1, 1, mav.MAV_MISSION_TYPE_MISSION))
    bench.tick()
    assert not bench.ep.mission and len(bench.ep.statustexts) == before


# -- what real clients sent that lfctl answered wrongly (review against Rover's source) -------------
def test_set_mode_the_message_is_acknowledged_with_command_11_as_rover_does(bench: Bench) -> None:
    # the pymavlink recipe waits for COMMAND_ACK with command == MAVLINK_MSG_ID_SET_MODE
    def set_mode(base: int, custom: int) -> list[int]:
        bench.send(mav.MAVLink_set_mode_message(1, base, custom))
        return [m.result for m in bench.tick() if m.get_type() == "COMMAND_ACK" and m.command == 11]

    custom = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert set_mode(custom, MODES["GUIDED"]) == [mav.MAV_RESULT_ACCEPTED] and bench.ep.mode == MODES["GUIDED"]
    assert set_mode(custom, 1) == [mav.MAV_RESULT_FAILED]  # ACRO: not lfctl's
    assert set_mode(0, MODES["HOLD"]) == [mav.MAV_RESULT_DENIED]  # not a custom mode
    assert set_mode(custom, MODES["AUTO"]) == [mav.MAV_RESULT_FAILED]  # no mission
    assert bench.ep.mode == MODES["GUIDED"]
    bench.send(mav.MAVLink_set_mode_message(7, custom, MODES["HOLD"]))  # another vehicle's
    assert not [m for m in bench.tick() if m.get_type() == "COMMAND_ACK"]


def test_a_timesync_request_is_answered_with_the_autopilots_clock(bench: Bench) -> None:
    bench.tick(1.0)
    bench.send(mav.MAVLink_timesync_message(0, 123456789))
    (answer,) = [m for m in bench.tick(0.5) if m.get_type() == "TIMESYNC"]
    assert answer.ts1 == 123456789 and answer.tc1 == pytest.approx(1.5e9, abs=0.05e9)  # ns since boot
    bench.send(mav.MAVLink_timesync_message(5, 123456789))  # an answer, not a request
    assert not [m for m in bench.tick() if m.get_type() == "TIMESYNC"]


def _square(n: int) -> list[Item]:
    """Home and ``n`` waypoints."""
    return [Item(0, 16)] + [Item(k, 16, x=129602000 + 100 * k) for k in range(1, n + 1)]


def test_a_partial_list_update_replaces_items_in_place_as_mavproxys_wp_changealt_does(bench: Bench) -> None:
    assert upload(bench, _square(4)) == mav.MAV_MISSION_ACCEPTED
    assert bench.ep.set_current(3)
    bench.send(mav.MAVLink_mission_write_partial_list_message(1, 1, 2, 2, 0))
    (req,) = [m for m in bench.tick() if m.get_type() == "MISSION_REQUEST"]
    assert req.seq == 2
    moved = Item(2, 16, x=129609999)
    bench.send(
        mav.MAVLink_mission_item_int_message(1, 1, 2, moved.frame, 16, 0, 1, 0, 0, 0, 0, moved.x, moved.y, 7.0, 0)
    )
    out = bench.tick()
    assert [(m.get_type(), getattr(m, "type", None)) for m in out if m.get_type() == "MISSION_ACK"] == [
        ("MISSION_ACK", mav.MAV_MISSION_ACCEPTED)
    ]
    # Rover's transfer_is_complete says so for a partial update too
    assert [m.text for m in out if m.get_type() == "STATUSTEXT"] == ["Flight plan received"]
    mission = bench.ep.mission
    assert len(mission) == 5 and mission[2].x == 129609999 and mission[2].z == 7.0
    assert [it.x for k, it in enumerate(mission) if k != 2] == [129602000, 129602100, 129602300, 129602400]
    assert bench.ep.current_seq == 3  # the current item stays
    # one past the end adds an item; a range past that, or backwards, is refused as Rover's
    bench.send(mav.MAVLink_mission_write_partial_list_message(1, 1, 5, 5, 0))
    (req,) = [m for m in bench.tick() if m.get_type() == "MISSION_REQUEST"]
    bench.send(mav.MAVLink_mission_item_int_message(1, 1, 5, moved.frame, 16, 0, 1, 0, 0, 0, 0, moved.x, moved.y, 0, 0))
    bench.tick()
    assert len(bench.ep.mission) == 6
    for first, last in ((7, 9), (3, 2), (-1, 2)):
        bench.send(mav.MAVLink_mission_write_partial_list_message(1, 1, first, last, 0))
        out = bench.tick()
        assert [m.type for m in out if m.get_type() == "MISSION_ACK"] == [mav.MAV_MISSION_ERROR]
        assert any(m.get_type() == "STATUSTEXT" and "Flight plan update rejected" in m.text for m in out)
    assert len(bench.ep.mission) == 6
    # an update that stops half way keeps what came (MAVProxy asks to send one past its items)
    bench.send(mav.MAVLink_mission_write_partial_list_message(1, 1, 1, 2, 0))
    bench.tick()
    bench.send(
        mav.MAVLink_mission_item_int_message(1, 1, 1, moved.frame, 16, 0, 1, 0, 0, 0, 0, 129601111, moved.y, 0, 0)
    )
    bench.tick()
    assert bench.ep.mission[1].x == 129601111  # in force at once, as Rover writes it
    out = [m for _ in range(9) for m in bench.tick(1.0)]
    assert [m.type for m in out if m.get_type() == "MISSION_ACK"] == [mav.MAV_MISSION_OPERATION_CANCELLED]
    assert bench.ep.mission[1].x == 129601111 and bench.ep.mission[2].x == 129609999
    bench.send(mav.MAVLink_mission_write_partial_list_message(1, 1, 0, 0, 9))  # a list type that is none
    assert [m.type for m in bench.tick() if m.get_type() == "MISSION_ACK"] == [mav.MAV_MISSION_UNSUPPORTED]


def test_an_old_clients_mission_request_gets_the_float_mission_item(bench: Bench) -> None:
    items = [*_square(2), Item(3, mav.MAV_CMD_DO_DIGICAM_CONTROL, x=0, y=1)]
    assert upload(bench, items) == mav.MAV_MISSION_ACCEPTED
    got = {}
    for seq in (1, 3):
        bench.send(mav.MAVLink_mission_request_message(1, 1, seq, 0))
        (m,) = [m for m in bench.tick() if m.get_type() in ("MISSION_ITEM", "MISSION_ITEM_INT")]
        assert m.get_type() == "MISSION_ITEM"
        got[seq] = m
    # degrees, in the float's precision (about 1e-6 deg there)
    assert got[1].x == pytest.approx(12.9602100, abs=1e-5) and got[1].y == pytest.approx(77.669, abs=1e-5)
    assert (got[3].x, got[3].y) == (0.0, 1.0)  # not a place: as stored
    # uploaded as a float item, the camera command's x and y are taken as they are (not degrees)
    bench.send(mav.MAVLink_mission_count_message(1, 1, 2, 0))
    bench.tick()
    bench.send(mav.MAVLink_mission_item_message(1, 1, 0, 3, 16, 0, 1, 0, 0, 0, 0, 12.96, 77.67, 0, 0))
    bench.tick()
    bench.send(
        mav.MAVLink_mission_item_message(1, 1, 1, 0, mav.MAV_CMD_DO_DIGICAM_CONTROL, 0, 1, 0, 0, 0, 0, 5, 7, 0, 0)
    )
    bench.tick()
    assert (bench.ep.mission[1].x, bench.ep.mission[1].y) == (5, 7)


def test_item_0_restarts_the_mission_and_the_echo_says_what_was_asked(bench: Bench) -> None:
    assert upload(bench, _square(3)) == mav.MAV_MISSION_ACCEPTED
    assert bench.ep.set_current(3)
    restarts = bench.ep.mission_restarts
    bench.send(mav.MAVLink_mission_set_current_message(1, 1, 0))
    (echo,) = [m for m in bench.tick() if m.get_type() == "MISSION_CURRENT"]
    assert (echo.seq, echo.total, echo.mission_state, echo.mission_mode) == (0, 3, mav.MISSION_STATE_NOT_STARTED, 0)
    assert bench.ep.current_seq == 1 and bench.ep.mission_restarts == restarts + 1
    assert bench.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 0) == mav.MAV_RESULT_ACCEPTED
    assert bench.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 4) == mav.MAV_RESULT_DENIED  # no such item
    bench.ep.set_armed(True)
    assert bench.set_mode("AUTO") == mav.MAV_RESULT_ACCEPTED
    bench.send(mav.MAVLink_mission_set_current_message(1, 1, 2))
    (echo,) = [m for m in bench.tick() if m.get_type() == "MISSION_CURRENT"]
    assert (echo.seq, echo.total, echo.mission_state, echo.mission_mode) == (2, 3, mav.MISSION_STATE_ACTIVE, 1)


def test_do_jump_tag_as_a_command_makes_the_tag_current_and_a_missing_tag_fails(bench: Bench) -> None:
    # Rover's handle_command_do_jump_tag: AP_Mission::jump_to_tag, the first JUMP_TAG of the tag
    items = [Item(0, 16), Item(1, 16), Item(2, mav.MAV_CMD_JUMP_TAG, p1=7), Item(3, 16, x=129602100)]
    items += [Item(4, mav.MAV_CMD_JUMP_TAG, p1=7), Item(5, 16, x=129602200)]
    assert upload(bench, items) == mav.MAV_MISSION_ACCEPTED
    assert bench.command(mav.MAV_CMD_DO_JUMP_TAG, 7) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.current_seq == 2
    assert bench.command(mav.MAV_CMD_DO_JUMP_TAG, 8) == mav.MAV_RESULT_FAILED  # no item has it
    for tag in (65536, -1, math.nan):  # not a tag
        assert bench.command(mav.MAV_CMD_DO_JUMP_TAG, tag) == mav.MAV_RESULT_DENIED
    assert bench.ep.current_seq == 2


def test_preflight_storage_2_erases_the_parameters_and_the_reboot_brings_the_defaults(bench: Bench) -> None:
    # QGroundControl's "Reset all to firmware's defaults": Rover's AP_Param::erase_all, said
    # "All parameters reset, reboot board"; the values in force stay until the reboot
    bench.ep.params["WP_SPEED"].value = 0.5
    assert bench.command(mav.MAV_CMD_PREFLIGHT_STORAGE, 1) == mav.MAV_RESULT_DENIED
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_PREFLIGHT_STORAGE, 0, 2, 0, 0, 0, 0, 0, 0))
    out = bench.tick()
    assert [(m.result) for m in out if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_ACCEPTED]
    assert "All parameters reset, reboot board" in [m.text for m in out if m.get_type() == "STATUSTEXT"]
    assert bench.ep.param("WP_SPEED") == 0.5
    bench.send(mav.MAVLink_param_set_message(1, 1, b"WP_RADIUS", 3.5, mav.MAV_PARAM_TYPE_REAL32))
    bench.tick()  # set after the erase: stored, as AP_Param stores it, and kept
    assert bench.command(mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == mav.MAV_RESULT_ACCEPTED
    for _ in range(200):
        bench.tick(0.02)
    assert not bench.ep.rebooting and bench.ep.param("WP_SPEED") == 2.0  # Rover's default
    assert bench.ep.param("WP_RADIUS") == 3.5
    bench.ep.params["WP_SPEED"].value = 0.7
    assert bench.command(mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == mav.MAV_RESULT_ACCEPTED
    for _ in range(200):
        bench.tick(0.02)
    assert bench.ep.param("WP_SPEED") == 0.7  # a plain reboot keeps them


def test_disarming_outside_auto_resets_the_mission_and_in_auto_keeps_its_place(bench: Bench) -> None:
    # Rover's AP_Arming_Rover::disarm: mission.reset() unless the mode is AUTO, so "HOLD,
    # disarm, arm, AUTO" starts the mission again from its first item
    assert upload(bench, _square(3)) == mav.MAV_MISSION_ACCEPTED
    bench.ep.set_armed(True)
    assert bench.set_mode("AUTO") == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.set_current(3)
    restarts = bench.ep.mission_restarts
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED  # in AUTO
    assert (bench.ep.current_seq, bench.ep.mission_restarts) == (3, restarts)
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    assert bench.set_mode("HOLD") == mav.MAV_RESULT_ACCEPTED
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED  # in HOLD
    assert (bench.ep.current_seq, bench.ep.mission_restarts) == (0, restarts + 1)  # no item under way
    assert not bench.ep.mission_complete
    # a finished mission stays finished (AP_Mission::reset keeps the state); AUTO starts it again
    bench.ep.set_armed(True)
    bench.ep.complete_mission()
    bench.ep.set_armed(False)
    assert bench.ep.mission_complete and bench.ep.current_seq == 0
    bench.ep.set_armed(True)
    assert bench.set_mode("AUTO") == mav.MAV_RESULT_ACCEPTED
    assert not bench.ep.mission_complete and bench.ep.current_seq == 1
    assert bench.set_mode("HOLD") == mav.MAV_RESULT_ACCEPTED
    bench.ep.set_armed(False)
    restarts = bench.ep.mission_restarts
    # disarming again while disarmed changes nothing
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.mission_restarts == restarts


def test_do_set_mission_current_tells_the_new_item_at_once_and_a_reset_restarts_a_finished_mission(
    bench: Bench,
) -> None:
    # Rover volunteers MISSION_CURRENT once DO_SET_MISSION_CURRENT is accepted
    # (send_message(MSG_CURRENT_WAYPOINT)), not at the stream's next turn
    assert upload(bench, _square(3)) == mav.MAV_MISSION_ACCEPTED
    bench.tick(5.0)  # past the streamed MISSION_CURRENT
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_DO_SET_MISSION_CURRENT, 0, 2, 0, 0, 0, 0, 0, 0))
    out = bench.tick(0.001)
    assert [m.get_type() for m in out if m.get_type() in ("COMMAND_ACK", "MISSION_CURRENT")] == [
        "COMMAND_ACK",
        "MISSION_CURRENT",
    ]
    assert [m.seq for m in out if m.get_type() == "MISSION_CURRENT"] == [2]
    # a finished mission, reset at item 2: no longer finished, its DO_JUMP counts afresh
    bench.ep.complete_mission()
    restarts = bench.ep.mission_restarts
    assert bench.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 2, 1) == mav.MAV_RESULT_ACCEPTED
    assert not bench.ep.mission_complete and bench.ep.current_seq == 2
    assert bench.ep.mission_restarts == restarts + 1
    # param1 is cast to an unsigned integer, as Rover casts it: 1.9 is item 1, -1 no item
    assert bench.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 1.9) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.current_seq == 1
    assert bench.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, -1) == mav.MAV_RESULT_DENIED


def test_change_speed_results_as_rovers(bench: Bench) -> None:
    x, y = (int(round(v * 1e7)) for v in ned_to_geodetic(5.0, 5.0, 0.0, *HOME)[:2])
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    bench.send(mav.MAVLink_command_int_message(1, 1, 0, mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, 0, x, y, 0))
    bench.tick()
    # too slow for Rover's waypoint navigation (under 0.05 m/s, 0, MAVLink's -1): FAILED
    for speed in (0.01, 0.0, -1.0):
        assert bench.command(mav.MAV_CMD_DO_CHANGE_SPEED, 1, speed) == mav.MAV_RESULT_FAILED
    assert bench.command(mav.MAV_CMD_DO_CHANGE_SPEED, 4, 0.5) == mav.MAV_RESULT_DENIED  # SPEED_TYPE_ENUM_END
    assert bench.command(mav.MAV_CMD_DO_CHANGE_SPEED, 7, 0.5) == mav.MAV_RESULT_ACCEPTED  # any other: ground speed
    assert bench.ep.desired_speed_mps == pytest.approx(0.5)


def test_mission_protocol_details_as_rover(bench: Bench) -> None:
    item_warning = "got MISSION_ITEM; GCS should send MISSION_ITEM_INT"
    request_warning = "got MISSION_REQUEST; use MISSION_REQUEST_INT!"

    def warnings() -> list[str]:
        return [t for _, t in bench.ep.statustexts if t in (item_warning, request_warning)]

    # the float MISSION_ITEM: Rover's warning once a transfer, again in the next one
    assert upload(bench, good_mission(3), as_float=True) == mav.MAV_MISSION_ACCEPTED
    assert warnings() == [item_warning]
    assert upload(bench, good_mission(3), as_float=True) == mav.MAV_MISSION_ACCEPTED
    assert warnings() == [item_warning] * 2
    # the float MISSION_REQUEST: answered, with its warning once
    for seq in (1, 2):
        bench.send(mav.MAVLink_mission_request_message(1, 1, seq, mav.MAV_MISSION_TYPE_MISSION))
        assert _count(bench.tick(), "MISSION_ITEM") == 1
    assert warnings() == [item_warning] * 2 + [request_warning]
    # an item past the list: its count first ("to educate the GCS"), then INVALID_SEQUENCE
    bench.send(mav.MAVLink_mission_request_int_message(1, 1, 99, mav.MAV_MISSION_TYPE_MISSION))
    out = [m for m in bench.tick() if m.get_type() in ("MISSION_COUNT", "MISSION_ACK")]
    assert [m.get_type() for m in out] == ["MISSION_COUNT", "MISSION_ACK"]
    assert out[0].count == 3 and out[1].type == mav.MAV_MISSION_INVALID_SEQUENCE
    # MAV_MISSION_TYPE_ALL is no list Rover keeps: UNSUPPORTED, nothing cleared
    bench.send(mav.MAVLink_mission_clear_all_message(1, 1, mav.MAV_MISSION_TYPE_ALL))
    assert _acks(bench.tick()) == [mav.MAV_MISSION_UNSUPPORTED] and len(bench.ep.mission) == 3


def test_mode_numbers_messages_and_versions_as_rover(bench: Bench) -> None:
    custom = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert bench.command(mav.MAV_CMD_DO_SET_MODE, custom, 2) == mav.MAV_RESULT_FAILED  # Rover has no mode 2
    assert bench.ep.statustexts[-1][1] == "No such mode 2"
    assert bench.command(mav.MAV_CMD_DO_SET_MODE, custom, MODES["GUIDED"]) == mav.MAV_RESULT_ACCEPTED
    assert bench.command(mav.MAV_CMD_DO_SET_MODE, custom, 256 + MODES["HOLD"]) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.mode == MODES["HOLD"]  # the mode number is a byte, as Rover's set_mode takes it
    # REQUEST_MESSAGE of MESSAGE_INTERVAL is GET_MESSAGE_INTERVAL of param2's message
    att = mav.MAVLINK_MSG_ID_ATTITUDE
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, att, 250_000) == mav.MAV_RESULT_ACCEPTED
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, 244, att, 0, 0, 0, 0, 0))
    out = bench.tick()
    (interval,) = [m for m in out if m.get_type() == "MESSAGE_INTERVAL"]
    assert (interval.message_id, interval.interval_us) == (att, 250_000)
    assert [m.result for m in out if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_ACCEPTED]
    # HOME_POSITION without an orientation (NaN) and with the time since boot; the version
    # is an official Rover 4.6.0's word
    bench.tick(1.0)
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_GET_HOME_POSITION, 0, 0, 0, 0, 0, 0, 0, 0))
    (home,) = [m for m in bench.tick() if m.get_type() == "HOME_POSITION"]
    assert all(math.isnan(q) for q in home.q) and home.time_usec == pytest.approx(bench.t * 1e6, abs=1e5)
    request = (mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0)
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, *request))
    (version,) = [m for m in bench.tick() if m.get_type() == "AUTOPILOT_VERSION"]
    assert version.flight_sw_version == 0x040600FF


def test_a_peers_control_characters_are_escaped_in_the_texts_sent_back(bench: Bench) -> None:
    bench.send(mav.MAVLink_param_set_message(1, 1, b"\x1b[2J\x1b]0;X\x07", 1.0, mav.MAV_PARAM_TYPE_REAL32))
    (text,) = [m for m in bench.tick() if m.get_type() == "STATUSTEXT"]
    assert text.text == r"Unknown parameter \x1b[2J\x1b]0;X\x07"  # MAVProxy prints it as it comes


# -- REQUEST_MESSAGE, SET_MESSAGE_INTERVAL and reboots as Rover's GCS_Common answers them ------


def _answer(bench: Bench, msg: object) -> tuple[int, list[object]]:
    """Send one command; its ACK's result and everything else that came back with it."""
    bench.send(msg)
    out = bench.tick()
    (ack,) = [m for m in out if m.get_type() == "COMMAND_ACK"]  # type: ignore[attr-defined]
    return int(ack.result), [m for m in out if m.get_type() != "COMMAND_ACK"]  # type: ignore[attr-defined]


def _request(bench: Bench, msg_id: float, param2: float = 0.0) -> tuple[int, list[object]]:
    return _answer(
        bench, mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, msg_id, param2, 0, 0, 0, 0, 0)
    )


def _interval_of(bench: Bench, msg_id: int) -> tuple[int, int]:
    """GET_MESSAGE_INTERVAL: the ACK's result and MESSAGE_INTERVAL's interval, us."""
    result, out = _answer(
        bench, mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_GET_MESSAGE_INTERVAL, 0, msg_id, 0, 0, 0, 0, 0, 0)
    )
    (interval,) = [m for m in out if m.get_type() == "MESSAGE_INTERVAL"]  # type: ignore[attr-defined]
    assert interval.message_id == msg_id  # type: ignore[attr-defined]
    return result, int(interval.interval_us)  # type: ignore[attr-defined]


def _reached(out: list[object]) -> list[int]:
    return [int(m.seq) for m in out if m.get_type() == "MISSION_ITEM_REACHED"]  # type: ignore[attr-defined]


def test_mission_item_reached_is_sent_again_when_asked_for_as_rover(bench: Bench) -> None:
    reached = mav.MAVLINK_MSG_ID_MISSION_ITEM_REACHED
    bench.tick()
    # Rover maps it (MSG_MISSION_ITEM_REACHED) and sends its channel's last index, which is
    # AP_MISSION_CMD_INDEX_NONE (65535) until an item is reached
    result, out = _request(bench, reached)
    assert (result, _reached(out)) == (mav.MAV_RESULT_ACCEPTED, [0xFFFF])
    assert upload(bench, good_mission(4)) == mav.MAV_MISSION_ACCEPTED
    bench.ep.reached(1)
    bench.ep.item_done(2)  # a DO command done: the last one reached too
    assert _reached(bench.tick()) == [1, 2]  # each told as it is done
    result, out = _request(bench, reached)
    assert (result, _reached(out)) == (mav.MAV_RESULT_ACCEPTED, [2])
    # not streamed unless asked for (-1), and streamed at the rate asked for
    assert _interval_of(bench, reached) == (mav.MAV_RESULT_ACCEPTED, -1)
    assert not _reached([m for _ in range(60) for m in bench.tick(0.02)])
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, reached, 200_000) == mav.MAV_RESULT_ACCEPTED
    assert _interval_of(bench, reached) == (mav.MAV_RESULT_ACCEPTED, 200_000)
    streamed = _reached([m for _ in range(50) for m in bench.tick(0.02)])
    assert streamed == [2] * len(streamed) and 4 <= len(streamed) <= 6
    # a reboot starts the channel afresh: none reached yet
    assert bench.command(mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == mav.MAV_RESULT_ACCEPTED
    for _ in range(150):
        bench.tick(0.02)
    assert not bench.ep.rebooting
    result, out = _request(bench, reached)
    assert (result, _reached(out)) == (mav.MAV_RESULT_ACCEPTED, [0xFFFF])


def test_guided_arrival_is_the_last_item_reached(bench: Bench) -> None:
    bench.tick()
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    x, y = (int(round(v * 1e7)) for v in ned_to_geodetic(5.0, 5.0, 0.0, *HOME)[:2])
    bench.send(mav.MAVLink_command_int_message(1, 1, 0, mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, 0, x, y, 0))
    bench.tick()
    bench.ep.guided_reached()
    assert _reached(bench.tick()) == [0]  # Rover's word for a GUIDED arrival
    result, out = _request(bench, mav.MAVLINK_MSG_ID_MISSION_ITEM_REACHED)
    assert (result, _reached(out)) == (mav.MAV_RESULT_ACCEPTED, [0])


def test_param_value_is_rovers_parameter_stream(bench: Bench) -> None:
    pv = mav.MAVLINK_MSG_ID_PARAM_VALUE
    bench.tick()
    # Rover maps PARAM_VALUE to its parameter stream (MSG_NEXT_PARAM), which has nothing to
    # send when no list is under way; param2 is not a parameter index to it
    for index in (0.0, 3.0):
        result, out = _request(bench, pv, index)
        assert result == mav.MAV_RESULT_ACCEPTED
        assert _count(out, "PARAM_VALUE") == 0
    # its rate: SRn_PARAMS' 10 Hz; never stopped (-1 is the default), never slower than 1 s;
    # faster is kept, in whole ms (Rover's set_ap_message_interval), down to 0.8 x the loop
    # rate: 25 ms at SCHED_LOOP_RATE 50 Hz; faster is DENIED (set_message_interval) and the
    # rate kept
    assert _interval_of(bench, pv) == (mav.MAV_RESULT_ACCEPTED, 100_000)
    cases = ((250_000, 250_000), (5e6, 1_000_000), (25_000, 25_000), (25_900, 25_000))
    for asked, kept in (*cases, (-1, 100_000), (0, 100_000)):
        assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, pv, asked) == mav.MAV_RESULT_ACCEPTED
        assert _interval_of(bench, pv) == (mav.MAV_RESULT_ACCEPTED, kept)
    for asked in (24_999, 5_500, 300):
        assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, pv, asked) == mav.MAV_RESULT_DENIED
        assert _interval_of(bench, pv) == (mav.MAV_RESULT_ACCEPTED, 100_000)
    assert not any("No ap_message" in text for _t, text in bench.ep.statustexts)
    # REQUEST_MESSAGE of MESSAGE_INTERVAL answers for it as GET_MESSAGE_INTERVAL does
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, pv, 400_000) == mav.MAV_RESULT_ACCEPTED
    result, out = _request(bench, mav.MAVLINK_MSG_ID_MESSAGE_INTERVAL, pv)
    (interval,) = [m for m in out if m.get_type() == "MESSAGE_INTERVAL"]  # type: ignore[attr-defined]
    assert (result, interval.message_id, interval.interval_us) == (mav.MAV_RESULT_ACCEPTED, pv, 400_000)  # type: ignore[attr-defined]
    # a parameter list still goes out whole, each PARAM_VALUE once
    bench.send(mav.MAVLink_param_request_list_message(1, 1))
    listed = [m for m in bench.tick() if m.get_type() == "PARAM_VALUE"]  # type: ignore[attr-defined]
    assert len(listed) == len(bench.ep.params)


@pytest.mark.parametrize("long", [True, False])
def test_set_message_interval_with_a_response_target_is_denied(bench: Bench, long: bool) -> None:
    att = mav.MAVLINK_MSG_ID_ATTITUDE
    for target in (1, 2, -1, NAN):  # Rover: anything but 0 (this link) is DENIED, first
        assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, att, 2e5, target, long=long) == mav.MAV_RESULT_DENIED
    assert bench.ep._rates.intervals[att] == pytest.approx(1.0)  # the rate is untouched
    texts = len(bench.ep.statustexts)
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, 12345, 1e5, 1, long=long) == mav.MAV_RESULT_DENIED
    assert len(bench.ep.statustexts) == texts  # refused before the message is looked up
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, att, 1e6, 0, long=long) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep._rates.intervals[att] == pytest.approx(1.0)


def test_a_reboot_for_another_component_is_denied(bench: Bench) -> None:
    reboot = mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN
    bench.tick()
    # no route to component 25 or 191: the autopilot acts on it, and Rover's
    # handle_preflight_reboot refuses a reboot not meant for it (nor for all)
    for component in (25, 191):
        assert bench.command_to(component, reboot, 1) == mav.MAV_RESULT_DENIED
    bench.send(mav.MAVLink_command_int_message(1, 25, 0, reboot, 0, 0, 1, 0, 0, 0, 0, 0, 0))
    assert [m.result for m in bench.tick() if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_DENIED]  # type: ignore[attr-defined]
    bench.ep.set_armed(True)  # checked before the armed check: DENIED, not FAILED, forced or not
    assert bench.command_to(25, reboot, 1) == mav.MAV_RESULT_DENIED
    assert bench.command_to(25, reboot, 1, 0, 0, 0, 0, 20190226) == mav.MAV_RESULT_DENIED
    assert not bench.ep.rebooting and bench.ep.armed
    bench.ep.set_armed(False)
    assert bench.command_to(25, reboot, 3) == mav.MAV_RESULT_DENIED  # before param1 is looked at
    assert bench.command_to(0, reboot, 1) == mav.MAV_RESULT_ACCEPTED  # to all: the autopilot too
    assert bench.ep.rebooting


@pytest.mark.parametrize(
    ("msg_id", "name"),
    [
        (mav.MAVLINK_MSG_ID_MISSION_CURRENT, "MISSION_CURRENT"),
        (mav.MAVLINK_MSG_ID_HOME_POSITION, "HOME_POSITION"),
        (mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, "EXTENDED_SYS_STATE"),
        (mav.MAVLINK_MSG_ID_SYS_STATUS, "SYS_STATUS"),
        (mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, "GPS_GLOBAL_ORIGIN"),
        (mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION, "AUTOPILOT_VERSION"),
        (mav.MAVLINK_MSG_ID_SYSTEM_TIME, "SYSTEM_TIME"),
        (mav.MAVLINK_MSG_ID_MISSION_ITEM_REACHED, "MISSION_ITEM_REACHED"),
        (mav.MAVLINK_MSG_ID_BATTERY_STATUS, None),  # no battery monitor: accepted, nothing comes
        (mav.MAVLINK_MSG_ID_PARAM_VALUE, None),  # no parameter list under way
    ],
)
def test_messages_a_ground_station_requests_are_answered_as_rover(bench: Bench, msg_id: int, name: str | None) -> None:
    bench.tick()  # every stream's first message has gone out; none is due again for 0.1 s
    result, out = _request(bench, msg_id)
    assert result == mav.MAV_RESULT_ACCEPTED
    sent = [m.get_type() for m in out]  # type: ignore[attr-defined]
    assert sent == ([name] if name else [])


# -- the fence in the pre-arm checks, as Rover's AP_Arming::fence_checks / AC_Fence::pre_arm_check


def _sys_status(bench: Bench) -> object:
    (status,) = [m for m in bench.tick(1.0) if m.get_type() == "SYS_STATUS"][-1:]
    return status


def test_arming_outside_an_enabled_fence_fails_as_rover_whatever_arming_check_selects(bench: Bench) -> None:
    assert upload(bench, fence_square(5.0), mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_ACCEPTED
    bench.ep.params["FENCE_ENABLE"].value = 1
    bench.state = dict(STATE, north_m=7.0, east_m=1.0)  # outside the square
    status = _sys_status(bench)
    assert not status.onboard_control_sensors_health & mav.MAV_SYS_STATUS_PREARM_CHECK  # type: ignore[attr-defined]
    assert bench.command(mav.MAV_CMD_RUN_PREARM_CHECKS) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.statustexts[-1][1] == "PreArm: Vehicle breaching Polygon fence"
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_FAILED
    assert bench.ep.statustexts[-1][1] == "Arm: Vehicle breaching Polygon fence" and not bench.ep.armed
    # no ARMING_CHECK bit turns the fence's check off (0 turns every check off, as on Rover)
    bench.ep.params["ARMING_CHECK"].value = 64
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_FAILED
    # outside the FENCE_RADIUS circle (round home, put here) too: both named, in AC_Fence's order
    bench.state = dict(STATE)
    bench.tick()
    assert bench.command(mav.MAV_CMD_DO_SET_HOME, 1) == mav.MAV_RESULT_ACCEPTED
    bench.ep.params["FENCE_RADIUS"].value = 30.0
    bench.state = dict(STATE, north_m=40.0, east_m=0.0)
    bench.tick()
    assert bench.command(mav.MAV_CMD_RUN_PREARM_CHECKS) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.statustexts[-1][1] == "PreArm: Vehicle breaching Circle and Polygon fences"
    # back inside: it arms
    bench.state = dict(STATE, north_m=1.0, east_m=1.0)
    bench.tick()
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED and bench.ep.armed
    # a fence switched off is not checked
    bench.ep.set_armed(False)
    bench.ep.params["FENCE_ENABLE"].value = 0
    bench.state = dict(STATE, north_m=7.0, east_m=1.0)
    bench.tick()
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED


def test_an_enabled_fence_with_nothing_to_check_or_a_circle_inside_the_margin_fails_prearm(bench: Bench) -> None:
    bench.ep.params["FENCE_TYPE"].value = 4  # polygons only, none uploaded
    bench.ep.params["FENCE_ENABLE"].value = 1
    bench.tick()
    assert bench.ep.prearm_failures() == ["Fences enabled, but none selected"]
    assert bench.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_FAILED
    assert bench.ep.statustexts[-1][1] == "Arm: Fences enabled, but none selected"
    # an inclusion circle narrower than FENCE_MARGIN (2 m)
    lat, lon = int(HOME[0] * 1e7), int(HOME[1] * 1e7)
    circle = [Item(0, mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, p1=1.5, x=lat, y=lon, frame=mav.MAV_FRAME_GLOBAL_INT)]
    assert upload(bench, circle, mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_ACCEPTED
    bench.tick()
    assert bench.ep.prearm_failures()[0] == "Polygon fence margin is less than inclusion circle radius"
    bench.ep.params["FENCE_MARGIN"].value = 1.0
    bench.state = dict(STATE, north_m=0.5, east_m=0.5)
    bench.tick()
    assert bench.ep.prearm_failures() == []


@pytest.mark.parametrize(("action", "enabled"), [(0, False), (1, True), (2, True)])
def test_sys_status_says_the_fence_is_enabled_only_when_it_acts_as_rover(
    bench: Bench, action: int, enabled: bool
) -> None:
    # AC_Fence::sys_status_enabled: FENCE_ACTION 0 (report only) is not enabled
    bench.ep.params["FENCE_ENABLE"].value = 1
    bench.ep.params["FENCE_ACTION"].value = action
    status = _sys_status(bench)
    assert bool(status.onboard_control_sensors_enabled & mav.MAV_SYS_STATUS_GEOFENCE) == enabled  # type: ignore[attr-defined]
    assert status.onboard_control_sensors_present & mav.MAV_SYS_STATUS_GEOFENCE  # type: ignore[attr-defined]
    bench.ep.params["FENCE_ENABLE"].value = 0
    status = _sys_status(bench)
    assert not status.onboard_control_sensors_enabled & mav.MAV_SYS_STATUS_GEOFENCE  # type: ignore[attr-defined]


@pytest.mark.parametrize(
    "mission_type", [mav.MAV_MISSION_TYPE_MISSION, mav.MAV_MISSION_TYPE_FENCE, mav.MAV_MISSION_TYPE_RALLY]
)
def test_an_upload_is_asked_for_with_mission_request_and_mission_item_int_is_taken_silently(
    bench: Bench, mission_type: int
) -> None:
    # as Rover's MissionItemProtocol::queued_request_send: MISSION_REQUEST (40), never _INT;
    # the MISSION_ITEM_INT a ground station answers with draws no float-item warning
    rally = [Item(k, mav.MAV_CMD_NAV_RALLY_POINT, x=129602100 + k, frame=mav.MAV_FRAME_GLOBAL_INT) for k in range(2)]
    items = {mav.MAV_MISSION_TYPE_MISSION: good_mission(3), mav.MAV_MISSION_TYPE_FENCE: fence_square()}.get(
        mission_type, rally
    )
    bench.send(mav.MAVLink_mission_count_message(1, 1, len(items), mission_type))
    asked, result = [], None
    for _ in range(len(items) + 3):
        for m in bench.tick():
            assert m.get_type() != "MISSION_REQUEST_INT"
            if m.get_type() == "MISSION_ACK":
                result = m.type
            if m.get_type() == "MISSION_REQUEST":
                assert (m.target_system, m.target_component, m.mission_type) == (255, 190, mission_type)
                asked.append(m.seq)
                it = items[m.seq]
                bench.send(
                    mav.MAVLink_mission_item_int_message(
                        1, 1, it.seq, it.frame, it.command, 0, 1, it.param1, it.param2, it.param3, it.param4,
                        it.x, it.y, it.z, mission_type,
                    )
                )  # fmt: skip
    assert asked == list(range(len(items))) and result == mav.MAV_MISSION_ACCEPTED
    assert not [t for _, t in bench.ep.statustexts if "MISSION_ITEM" in t]


def test_upload_texts_are_rovers_fence_and_rally_silent_and_an_empty_mission_upload_received(bench: Bench) -> None:
    # MissionItemProtocol_*::complete: the mission says "Flight plan received" (a count of 0
    # completes an upload at once, and says it too); a fence or rally upload ends silently,
    # and a MISSION_CLEAR_ALL of any list is only ACKed
    def texts_of(action: object) -> list[str]:
        before = len(bench.ep.statustexts)
        if callable(action):
            action()
        else:
            bench.send(action)
            bench.tick()
        return [t for _, t in bench.ep.statustexts[before:]]

    rally = [Item(0, mav.MAV_CMD_NAV_RALLY_POINT, x=129602100, y=776690100, frame=mav.MAV_FRAME_GLOBAL_INT)]
    assert texts_of(lambda: upload(bench, fence_square(), mav.MAV_MISSION_TYPE_FENCE)) == []
    assert texts_of(lambda: upload(bench, rally, mav.MAV_MISSION_TYPE_RALLY)) == []
    assert not bench.ep.fence.empty and len(bench.ep.rally) == 1
    for mtype in (mav.MAV_MISSION_TYPE_FENCE, mav.MAV_MISSION_TYPE_RALLY):
        assert texts_of(mav.MAVLink_mission_clear_all_message(1, 1, mtype)) == []
    assert bench.ep.fence.empty and not bench.ep.rally
    assert texts_of(lambda: upload(bench, good_mission(3))) == ["Flight plan received"]
    assert texts_of(mav.MAVLink_mission_count_message(1, 1, 0, mav.MAV_MISSION_TYPE_MISSION)) == [
        "Flight plan received"
    ]
    assert not bench.ep.mission
    assert texts_of(mav.MAVLink_mission_count_message(1, 1, 0, mav.MAV_MISSION_TYPE_FENCE)) == []


def test_nav_controller_output_in_guided_without_a_place_as_rovers_mode_guided(bench: Bench) -> None:
    # ModeGuided reports in every submode (an autopilot mode): stopped, turn rate and speed:
    # all 0; heading and speed: that heading as wrap_180, whole degrees; HOLD and MANUAL: none
    def last_nav() -> object | None:
        out = [m for _ in range(60) for m in bench.tick(0.02)]  # (1 Hz: at least one in 1.2 s)
        navs = [m for m in out if m.get_type() == "NAV_CONTROLLER_OUTPUT"]
        return navs[-1] if navs else None

    for mode in ("HOLD", "MANUAL"):
        assert bench.set_mode(mode) == mav.MAV_RESULT_ACCEPTED
        assert last_nav() is None
    bench.ep.set_armed(True)
    assert bench.set_mode("GUIDED") == mav.MAV_RESULT_ACCEPTED
    n = last_nav()
    assert n is not None and (n.nav_bearing, n.target_bearing, n.wp_dist, n.xtrack_error) == (0, 0, 0, 0)  # type: ignore[attr-defined]
    q = (math.cos(math.radians(175.25)), 0.0, 0.0, math.sin(math.radians(175.25)))  # heading 350.5 deg
    bench.send(mav.MAVLink_set_attitude_target_message(0, 1, 1, 0b00000111, q, 0, 0, 0, 0.5))
    n = last_nav()
    assert n is not None and (n.nav_bearing, n.target_bearing, n.wp_dist, n.xtrack_error) == (-9, 0, 0, 0)  # type: ignore[attr-defined]
    bench.tick(3.5)  # not renewed within 3 s: stopped
    n = last_nav()
    assert n is not None and n.nav_bearing == 0  # type: ignore[attr-defined]
    bench.send(mav.MAVLink_set_attitude_target_message(0, 1, 1, 0b00000011, (1, 0, 0, 0), 0, 0, 0.25, 0.5))
    n = last_nav()
    assert bench.ep.guided is not None and bench.ep.guided.kind == "rate"
    assert n is not None and (n.nav_bearing, n.target_bearing, n.wp_dist, n.xtrack_error) == (0, 0, 0, 0)  # type: ignore[attr-defined]


def test_a_downloaded_command_without_a_place_has_x_y_z_0_and_only_the_params_rover_keeps(bench: Bench) -> None:
    # AP_Mission::mission_cmd_to_mavlink_int fills a zeroed packet with the command's own
    # fields: a command that stores no place comes back with x = y = z = 0 (a NaN z too),
    # but for the camera's and gimbal's numbers kept there; params it has no room for are 0
    lat, lon = int(HOME[0] * 1e7), int(HOME[1] * 1e7)
    nan = math.nan
    sent = [
        (16, (0, 0, 0, 0), (lat, lon, 5.0)),
        (177, (1, 2, 0, 0), (lat, lon, nan)),  # DO_JUMP
        (178, (1, 0.5, 40, 0), (123, 456, 7.0)),  # DO_CHANGE_SPEED
        (112, (2.0, 0, 0, 0), (9, 9, 9.0)),  # CONDITION_DELAY
        (183, (5, 1500, 7, 8), (1, 2, 3.0)),  # DO_SET_SERVO: channel and PWM only
        (203, (1, 2, 3, 4), (5, 6, 7.0)),  # DO_DIGICAM_CONTROL: x (shoot) and y (id) kept
        (179, (0, 0, 0, 0), (lat, lon + 10, 2.0)),  # DO_SET_HOME stores a place: kept
    ]
    mission = [
        mav.MAVLink_mission_item_int_message(1, 1, k, mav.MAV_FRAME_GLOBAL_INT, cmd, 0, 1, *p, *xyz, 0)
        for k, (cmd, p, xyz) in enumerate(sent)
    ]
    assert upload(bench, mission) == mav.MAV_MISSION_ACCEPTED
    back = download(bench, mav.MAV_MISSION_TYPE_MISSION)
    got = [(it.x, it.y, it.z) for it in back[1:]]  # type: ignore[attr-defined]
    assert got == [(0, 0, 0.0), (0, 0, 0.0), (0, 0, 0.0), (0, 0, 0.0), (5, 6, 0.0), (lat, lon + 10, 2.0)]
    assert (back[4].param3, back[4].param4) == (0.0, 0.0)  # type: ignore[attr-defined]
    assert (back[4].param1, back[4].param2) == (5.0, 1500.0)  # type: ignore[attr-defined]


def test_the_safety_switch_of_a_board_without_one_as_rover_answers(bench: Bench) -> None:
    # MAVProxy's `arm safetyoff`: MAV_CMD_DO_SET_SAFETY_SWITCH_STATE, then SET_MODE with base_mode 128
    def set_mode_ack(custom: int) -> int:
        bench.send(mav.MAVLink_set_mode_message(1, mav.MAV_MODE_FLAG_DECODE_POSITION_SAFETY, custom))
        (ack,) = [m for m in bench.tick() if m.get_type() == "COMMAND_ACK"]
        return int(ack.result)

    assert set_mode_ack(0) == mav.MAV_RESULT_ACCEPTED  # off: the outputs are live already
    assert set_mode_ack(1) == mav.MAV_RESULT_FAILED  # on: there is no switch to turn on
    # neither: _set_mode_common's "invalid parameters", by message and by command alike
    assert set_mode_ack(2) == mav.MAV_RESULT_DENIED and set_mode_ack(7) == mav.MAV_RESULT_DENIED
    assert bench.command(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_DECODE_POSITION_SAFETY, 2) == mav.MAV_RESULT_DENIED
    cmd = mav.MAV_CMD_DO_SET_SAFETY_SWITCH_STATE
    assert bench.command(cmd, mav.SAFETY_SWITCH_STATE_DANGEROUS) == mav.MAV_RESULT_ACCEPTED
    assert bench.command(cmd, mav.SAFETY_SWITCH_STATE_SAFE) == mav.MAV_RESULT_FAILED
    assert bench.command(cmd, 7) == mav.MAV_RESULT_DENIED
    assert bench.ep.mode == MODES["HOLD"]  # no mode change came of it


def test_mission_current_names_no_item_until_auto_and_the_navigation_item_a_set_lands_on(bench: Bench) -> None:
    # Rover's get_current_nav_index: 0 after an upload; set_current_cmd on a DO item (mission not
    # running) loads the navigation command after it, and the DO runs first when AUTO starts
    items = [*good_mission(2), Item(2, mav.MAV_CMD_DO_CHANGE_SPEED, p1=1, p2=0.7), good_mission(4)[3]]
    assert upload(bench, items) == mav.MAV_MISSION_ACCEPTED

    def current() -> int:
        return [m for m in bench.tick(1.1) if m.get_type() == "MISSION_CURRENT"][-1].seq

    assert current() == 0
    assert bench.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 2) == mav.MAV_RESULT_ACCEPTED
    assert current() == 3 and bench.ep.current_seq == 2  # told: the waypoint; kept: the DO before it
    assert bench.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 1) == mav.MAV_RESULT_ACCEPTED
    assert current() == 1


def test_a_log_list_is_answered_at_once_with_no_logs(bench: Bench) -> None:
    # MAVLink's answer when there are none (QGroundControl's Onboard Logs waited out its timeout)
    bench.send(mav.MAVLink_log_request_list_message(1, 1, 0, 0xFFFF))
    (entry,) = [m for m in bench.tick() if m.get_type() == "LOG_ENTRY"]
    assert (entry.id, entry.num_logs, entry.last_log_num, entry.size) == (0, 0, 0, 0)
    bench.send(mav.MAVLink_log_request_list_message(2, 1, 0, 0xFFFF))  # another vehicle's
    assert not [m for m in bench.tick() if m.get_type() == "LOG_ENTRY"]


def test_a_companions_report_is_routed_to_the_network_but_never_back_to_its_sender(bench: Bench) -> None:
    # Rover's routing never sends a message back where it came from: a companion on the
    # network (lfctl follow) had its own STATUSTEXTs echoed back to it; the ground station
    # there still gets them
    forwarded: list[tuple[bytes, object]] = []
    bench.ep.network = Network(send=lambda data, exclude=(): forwarded.append((data, exclude)) or 1)
    companion = mav.MAVLink(None, srcSystem=1, srcComponent=191)
    text = mav.MAVLink_statustext_message(mav.MAV_SEVERITY_INFO, b"rover: target lost")
    bench.a.inbox.append((text.pack(companion), ("memory", 0)))  # the in-memory companion's
    bench.tick()
    assert [exclude for _d, exclude in forwarded] == [()]  # to every peer on the network
    _from_network(bench, text, companion)
    _from_network(bench, mav.MAVLink_named_value_float_message(0, b"rng_err", 0.2), companion)
    bench.tick()
    assert [exclude for _d, exclude in forwarded[1:]] == [(("127.0.0.1", 14550),)] * 2  # to all but the sender


def test_each_network_peer_is_a_channel_so_a_ground_station_reaches_a_companion_there(bench: Bench) -> None:
    # a rehearsal: lfctl follow's companion (191) and its camera (100) on one peer of the UDP
    # port, a ground station on another; as a Rover passes messages between its links, what
    # one addresses to the other goes there and is not acted on by the autopilot
    passed: list[tuple[str, object]] = []
    broadcast: list[object] = []
    rover_side, ground_side = ("127.0.0.1", 40001), ("127.0.0.1", 40002)
    bench.ep.network = Network(
        send_to=_sends_of(("PARAM_REQUEST_READ", "COMMAND_LONG", "COMMAND_ACK", "PARAM_VALUE"), passed),
        send=lambda data, exclude=(): broadcast.append(*exclude) or 1,
        peers=[rover_side, ground_side],
    )
    companion = mav.MAVLink(None, srcSystem=1, srcComponent=191)
    camera = mav.MAVLink(None, srcSystem=1, srcComponent=100)
    ground = mav.MAVLink(None, srcSystem=255, srcComponent=190)

    def comes(msg: object, sender: mav.MAVLink, addr: tuple[str, int]) -> list[object]:
        bench.a.inbox.append((msg.pack(sender), addr))  # type: ignore[attr-defined]
        return [m for m in bench.tick() if m.get_type() in ("PARAM_VALUE", "COMMAND_ACK", "STATUSTEXT")]

    comes(mav.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3), companion, rover_side)
    comes(mav.MAVLink_heartbeat_message(30, 8, 0, 0, 4, 3), camera, rover_side)
    comes(mav.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3), ground, ground_side)
    # every HEARTBEAT to every other peer (MAVLink_routing::handle_heartbeat): the companion's
    # and the camera's to the ground station, the ground station's to the companion
    assert broadcast == [rover_side, rover_side, ground_side] and passed == []
    # the ground station asks the companion for LFC_RANGE and the camera for its stream
    answered = comes(mav.MAVLink_param_request_read_message(1, 191, b"LFC_RANGE", -1), ground, ground_side)
    info = mav.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION
    request = mav.MAVLink_command_long_message(1, 100, mav.MAV_CMD_REQUEST_MESSAGE, 0, info, 0, 0, 0, 0, 0, 0)
    answered += comes(request, ground, ground_side)
    assert answered == []  # the autopilot left them to the components they are for
    assert passed == [("PARAM_REQUEST_READ", rover_side), ("COMMAND_LONG", rover_side)]
    # the camera's answer goes back to the ground station, and only there
    ack = mav.MAVLink_command_ack_message(mav.MAV_CMD_REQUEST_MESSAGE, 0, 0, 0, 255, 190)
    comes(ack, camera, rover_side)
    assert passed[-1] == ("COMMAND_ACK", ground_side)
    # one for a component on the sender's own peer is not sent back there (nor anywhere)
    del passed[:]
    comes(mav.MAVLink_command_ack_message(400, 0, 0, 0, 1, 191), camera, rover_side)
    assert passed == []
    # what is for the autopilot is acted on here and passed on to no one; its answer goes to the
    # ground station alone, as a Rover answers on the link a request came on
    del passed[:]
    arm = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    assert [m for m in comes(arm, ground, ground_side) if m.get_type() == "COMMAND_ACK"] == []
    assert bench.ep.armed and passed == [("COMMAND_ACK", ground_side)]
    del passed[:]
    # the companion's own command is answered to it alone (MAVProxy on the port printed
    # "Got COMMAND_ACK" for commands lfctl follow sent)
    mode = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_DO_SET_MODE, 0, 1, 15, 0, 0, 0, 0, 0)
    comes(mode, companion, rover_side)
    assert passed == [("COMMAND_ACK", rover_side)]
    del passed[:]
    # a request to every component of the vehicle: acted on here and passed on to the companion's peer
    # (its answer to the ground station alone, as Rover answers a read on the asking link)
    comes(mav.MAVLink_param_request_read_message(1, 0, b"WP_SPEED", -1), ground, ground_side)
    assert passed == [("PARAM_REQUEST_READ", rover_side), ("PARAM_VALUE", ground_side)]


def test_a_full_route_table_makes_room_for_a_new_peer_once_old_ones_are_idle(bench: Bench) -> None:
    # lfctl follow started again and again, each time from a new port: the routes its earlier
    # runs left must not keep the latest one from being learnt (a table full of live routes
    # still takes nothing more, as Rover's)
    passed: list[object] = []
    bench.ep.network = Network(send_to=lambda data, addr: passed.append(addr))
    companion = mav.MAVLink(None, srcSystem=1, srcComponent=191)
    ground = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    heartbeat = mav.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3)
    read = mav.MAVLink_param_request_read_message(1, 191, b"LFC_RANGE", -1)
    for port in range(41000, 41000 + MAX_ROUTES):
        bench.a.inbox.append((heartbeat.pack(companion), ("127.0.0.1", port)))
    bench.tick()
    latest = ("127.0.0.1", 42000)
    bench.a.inbox.append((heartbeat.pack(companion), latest))
    bench.a.inbox.append((read.pack(ground), ("127.0.0.1", 14550)))
    bench.tick()
    assert latest not in passed and len(passed) == MAX_ROUTES  # full of live routes: not learnt
    del passed[:]
    bench.tick(dt=ROUTE_IDLE_S + 1.0)  # the earlier ones go quiet
    bench.a.inbox.append((heartbeat.pack(companion), latest))
    bench.a.inbox.append((read.pack(ground), ("127.0.0.1", 14550)))
    bench.tick()
    assert passed == [latest]


def test_a_relay_looping_the_port_into_itself_gets_nothing_round_twice(bench: Bench) -> None:
    # a relay sending the port's output back into it (MAVProxy with --master and --out both on
    # the port): the autopilot's ACKs, and lfctl follow's camera HEARTBEAT, went round for ever
    passed: list[object] = []
    bench.ep.network = Network(
        send_to=lambda data, addr: passed.append(addr), send=lambda data, exclude=(): passed.append(*exclude) or 2
    )
    follow, ground, relay = ("127.0.0.1", 40001), ("127.0.0.1", 40002), ("127.0.0.1", 40003)
    gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    bench.a.inbox.append((mav.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(gcs), ground))
    bench.tick()
    assert passed == [ground]  # its HEARTBEAT to every other peer, as Rover's handle_heartbeat
    del passed[:]
    own = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    for msg in (mav.MAVLink_command_ack_message(400, 0, 0, 0, 255, 190), mav.MAVLink_sys_status_message(*[0] * 13)):
        bench.a.inbox.append((msg.pack(own), relay))
    bench.tick()
    assert passed == []  # the autopilot's own id: never passed on
    beat = mav.MAVLink_heartbeat_message(30, 8, 0, 0, 4, 3).pack(mav.MAVLink(None, srcSystem=1, srcComponent=100))
    bench.a.inbox.append((beat, follow))
    bench.tick()
    assert passed == [follow]  # to every peer but follow
    for _ in range(3):  # the relay sends it back, lap after lap
        bench.a.inbox.append((beat, relay))
        bench.tick()
    assert passed == [follow]
    bench.tick(dt=PASSED_ON_MEMORY_S + 0.1)
    bench.a.inbox.append((beat, follow))  # the same bytes a second on: passed on again
    bench.tick()
    assert passed == [follow, follow]


def test_a_flood_from_one_peer_is_not_multiplied_past_a_limit_nor_starves_another(bench: Bench) -> None:
    passed: list[object] = []
    bench.ep.network = Network(
        send_to=lambda data, addr: passed.append(addr),
        send=lambda data, exclude=(): passed.append(*exclude) or MAX_PEERS,
    )
    flood, ground, follow = ("127.0.0.1", 40003), ("127.0.0.1", 40002), ("127.0.0.1", 40001)
    companion = mav.MAVLink(None, srcSystem=1, srcComponent=191)
    camera = mav.MAVLink(None, srcSystem=1, srcComponent=100)  # (the flood's: another component's)
    gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    bench.a.inbox.append((mav.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3).pack(companion), follow))
    bench.tick()
    del passed[:]
    k = 0
    for _ in range(MAX_DATAGRAMS_PER_TICK - 1):
        frames = []
        for _ in range(20):  # distinct packets (their values differ): none is a repeat
            k += 1
            frames.append(pack_next(mav.MAVLink_named_value_float_message(k, b"rng_err", k / 10), camera))
        bench.a.inbox.append((b"".join(frames), flood))
    read = mav.MAVLink_param_request_read_message(1, 191, b"LFC_RANGE", -1)
    bench.a.inbox.append((read.pack(gcs), ground))  # the ground station's, behind the flood
    before = bench.ep.stats.messages
    bench.tick()
    handled = bench.ep.stats.messages - before
    broadcasts = MAX_PASSED_ON_PER_TICK // MAX_PEERS
    assert handled > MAX_PASSED_ON_PER_TICK and passed.count(flood) == broadcasts
    assert passed[-1] == follow  # the ground station's request still went through
    assert bench.ep.stats.not_passed_on == handled - 1 - broadcasts


def test_a_route_gone_quiet_is_gone(bench: Bench) -> None:
    # lfctl follow stopped: a ground station's request to its component is no longer sent to
    # where it was, and the autopilot answers it as one it has no route to
    follow, ground = ("127.0.0.1", 40001), ("127.0.0.1", 40002)
    passed: list[tuple[str, object]] = []
    bench.ep.network = Network(send_to=_sends_of(("PARAM_REQUEST_READ", "PARAM_VALUE"), passed), peers=[follow, ground])
    companion = mav.MAVLink(None, srcSystem=1, srcComponent=191)
    gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    bench.a.inbox.append((mav.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3).pack(companion), follow))
    bench.tick()
    read = mav.MAVLink_param_request_read_message(1, 191, b"WP_SPEED", -1)
    bench.a.inbox.append((read.pack(gcs), ground))
    bench.tick()
    assert passed == [("PARAM_REQUEST_READ", follow)]  # to the companion, not answered here
    bench.tick(dt=ROUTE_IDLE_S + 1.0)
    bench.a.inbox.append((read.pack(gcs), ground))
    bench.tick()
    assert passed[1:] == [("PARAM_VALUE", ground)]  # the autopilot's answer, to the asker


def test_a_udp_link_sends_to_every_peer_but_the_one_excluded() -> None:
    import socket

    from lfctl.link.transport import UdpLink

    link = UdpLink(("127.0.0.1", 0))
    a, b = (socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(2))
    try:
        for s in (a, b):
            s.bind(("127.0.0.1", 0))
            s.settimeout(1.0)
            s.sendto(b"hello", ("127.0.0.1", link.port))
        time.sleep(0.05)
        for _data, addr in link.recv():  # both heard: peers (as MAVLink from them makes them)
            link.accept_peer(addr)
        link.send(b"report", exclude=[a.getsockname()])
        assert b.recv(64) == b"report"
        a.settimeout(0.2)
        with pytest.raises(TimeoutError):
            a.recv(64)
    finally:
        a.close()
        b.close()
        link.close()


class PeerCapture:
    """Each network peer's packets as the endpoint sends them, parsed peer by peer."""

    def __init__(self, bench: Bench, peers: list[tuple[str, int]]) -> None:
        self.got: dict[object, list[Any]] = {p: [] for p in peers}
        self._parsers = {p: mav.MAVLink(None) for p in peers}
        bench.ep.network = Network(send_to=self._sent, peers=list(peers))

    def _sent(self, data: bytes, addr: object) -> None:
        self.got[addr] += [m for m in self._parsers[addr].parse_buffer(data) or [] if m.get_type() != "BAD_DATA"]

    def count(self, peer: object, kind: str) -> int:
        return sum(m.get_type() == kind for m in self.got[peer])


def _peer_sends(bench: Bench, msg: object, sender: mav.MAVLink, addr: tuple[str, int]) -> list[Any]:
    bench.a.inbox.append((msg.pack(sender), addr))  # type: ignore[attr-defined]
    return bench.tick()


#: a rehearsal's two peers: lfctl follow's companion (1/191) and MAVProxy (255/190)
FOLLOW, MAVPROXY = ("127.0.0.1", 40001), ("127.0.0.1", 40002)
GPI = mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT


def _cmd(command: int, *p: float) -> Any:
    return mav.MAVLink_command_long_message(1, 1, command, 0, *p, *([0.0] * (7 - len(p))))


def _rehearsal(bench: Bench, gpi_us: float, group: int, hz: int, *more: tuple[str, int]) -> tuple[PeerCapture, Any]:
    """FOLLOW asks for GLOBAL_POSITION_INT every ``gpi_us``, MAVPROXY for ``group`` at ``hz``
    (the peers ``more`` ask nothing); what each peer gets, and MAVProxy's codec."""
    cap = PeerCapture(bench, [FOLLOW, MAVPROXY, *more])
    gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    _peer_sends(bench, _cmd(mav.MAV_CMD_SET_MESSAGE_INTERVAL, GPI, gpi_us), _companion(), FOLLOW)
    _peer_sends(bench, mav.MAVLink_request_data_stream_message(1, 1, group, hz, 1), gcs, MAVPROXY)
    return cap, gcs


def _companion() -> Any:
    """lfctl follow's companion's codec (a new one each time: a sequence of its own)."""
    return mav.MAVLink(None, srcSystem=1, srcComponent=191)


def _interval_heard(bench: Bench, cap: PeerCapture, peer: tuple[str, int], sender: Any, msg_id: int) -> int:
    """The interval ``peer`` is told for ``msg_id`` when it asks (GET_MESSAGE_INTERVAL), us."""
    before = len(cap.got[peer])
    _peer_sends(bench, _cmd(mav.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id), sender, peer)
    (answer,) = [m for m in cap.got[peer][before:] if m.get_type() == "MESSAGE_INTERVAL"]
    return int(answer.interval_us)


def test_each_network_peer_keeps_its_own_stream_rates_as_each_rover_link_does(bench: Bench) -> None:
    # a rehearsal's port: lfctl follow asks for its odometry at 20 Hz, MAVProxy for every group
    # at 4 Hz as it connects; on a Rover each link has its own SRn_ rates, and a simulated
    # vehicle's peers are its links: neither slows the other, and a peer that asked for
    # nothing (and the in-memory link) keeps the defaults
    quiet = ("127.0.0.1", 40003)
    cap, gcs = _rehearsal(bench, 50000, mav.MAV_DATA_STREAM_ALL, 4, quiet)
    for p in cap.got.values():
        p.clear()
    memory = []
    for _ in range(100):  # 2 s
        memory += bench.tick(0.02)
    counts = [cap.count(p, "GLOBAL_POSITION_INT") for p in (FOLLOW, MAVPROXY, quiet)]
    assert counts == [40, 8, 2]  # 20 Hz, 4 Hz, Rover's default 1 Hz
    assert sum(m.get_type() == "GLOBAL_POSITION_INT" for m in memory) == 2
    assert cap.count(FOLLOW, "ATTITUDE") == 2 and cap.count(MAVPROXY, "ATTITUDE") == 8  # (1 Hz; 4 Hz)
    assert all(cap.count(p, "HEARTBEAT") == 2 for p in cap.got)  # in no group: 1 Hz for each
    # each asks what its rate is and hears its own
    for peer, sender, us in ((FOLLOW, _companion(), 50000), (MAVPROXY, gcs, 250000), (quiet, gcs, 1_000_000)):
        assert _interval_heard(bench, cap, peer, sender, GPI) == us, peer
    # the parameter stream's rate too (the link's SRn_PARAMS)
    pv = mav.MAVLINK_MSG_ID_PARAM_VALUE
    _peer_sends(bench, _cmd(mav.MAV_CMD_SET_MESSAGE_INTERVAL, pv, 30000), gcs, MAVPROXY)
    assert [_interval_heard(bench, cap, peer, gcs, pv) for peer in (MAVPROXY, quiet)] == [30000, 100000]


def test_a_peer_that_gets_only_its_own_packets_sees_no_gap_in_their_sequence(bench: Bench) -> None:
    # a Rover numbers its packets per link: with its own rates (and answers to it alone) a
    # ground station that counted one sequence with the other peers' would see most of its
    # packets as lost (MAVProxy's and QGroundControl's link quality)
    cap, gcs = _rehearsal(bench, 25000, mav.MAV_DATA_STREAM_ALL, 2)
    follow, mavproxy = FOLLOW, MAVPROXY
    _peer_sends(bench, _cmd(mav.MAV_CMD_GET_MESSAGE_INTERVAL, GPI), gcs, mavproxy)
    _peer_sends(bench, _cmd(mav.MAV_CMD_REQUEST_MESSAGE, 148), gcs, mavproxy)
    memory = []
    for _ in range(300):  # 6 s: past 256 packets on the busy peer
        memory += bench.tick(0.02)
    assert len(cap.got[follow]) > 300
    for peer, got in [*cap.got.items(), ("memory", memory)]:
        seqs = [m.get_seq() for m in got]
        assert peer == "memory" or seqs[0] == 0
        assert all((b - a) % 256 == 1 for a, b in itertools.pairwise(seqs)), peer
    # answers to mavproxy's requests went to it alone, as a Rover answers on the asking link
    for kind in ("COMMAND_ACK", "MESSAGE_INTERVAL", "AUTOPILOT_VERSION"):
        assert (cap.count(mavproxy, kind), cap.count(follow, kind)) == ((1, 0) if kind != "COMMAND_ACK" else (2, 1))


def test_a_reboot_starts_every_peers_rates_and_sequence_afresh(bench: Bench) -> None:
    # Rover saves no link's rates (SRn_ set in RAM: persist_streamrates is false; and
    # SET_MESSAGE_INTERVAL's are in RAM), and every channel counts its packets from 0 again
    cap, gcs = _rehearsal(bench, 50000, mav.MAV_DATA_STREAM_POSITION, 5)
    follow, mavproxy = FOLLOW, MAVPROXY
    reboot = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0, 1, 0, 0, 0, 0, 0, 0)
    _peer_sends(bench, reboot, gcs, mavproxy)
    for p in cap.got.values():
        p.clear()
    for _ in range(200):
        bench.tick(0.02)
    assert not bench.ep.rebooting
    assert [got[0].get_seq() for got in cap.got.values()] == [0, 0]  # the first packets after the restart
    for p in cap.got.values():
        p.clear()
    for _ in range(100):
        bench.tick(0.02)
    assert [cap.count(p, "GLOBAL_POSITION_INT") for p in (follow, mavproxy)] == [2, 2]  # both 1 Hz again


def test_rates_are_kept_for_at_most_max_peers_and_not_sent_to_a_peer_out_of_reach(bench: Bench) -> None:
    peers = [("127.0.0.1", 41000 + i) for i in range(MAX_PEERS + 1)]
    cap = PeerCapture(bench, peers)
    gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    stop = mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_ALL, 0, 0)
    for peer in peers[:-1]:  # each stops its groups
        _peer_sends(bench, stop, gcs, peer)
    _peer_sends(bench, mav.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3), gcs, peers[0])  # the first speaks again
    _peer_sends(bench, stop, gcs, peers[-1])  # the last one's rates: the second's make room (heard longest ago)
    assert len(bench.ep._peer_rates) == MAX_PEERS and peers[1] not in bench.ep._peer_rates
    for p in cap.got.values():
        p.clear()
    bench.ep.network.peers = peers[:-1]  # type: ignore[union-attr]  # the latest one no longer reached
    for _ in range(100):
        bench.tick(0.02)
    assert cap.count(peers[1], "GLOBAL_POSITION_INT") == 2  # its rates made room: the defaults (1 Hz) again
    assert all(cap.count(p, "GLOBAL_POSITION_INT") == 0 for p in (peers[0], *peers[2:]))
    assert cap.got[peers[-1]] == []  # nothing at all out of reach


def test_a_parameter_read_or_list_is_answered_to_its_asker_and_a_set_to_every_peer(bench: Bench) -> None:
    # as Rover: a list and a read go out on the asking link (GCS_MAVLINK's queued parameters,
    # param_replies' chan), a set's new value to every active link (GCS::send_parameter_value)
    follow, mavproxy = ("127.0.0.1", 40001), ("127.0.0.1", 40002)
    cap = PeerCapture(bench, [follow, mavproxy])
    gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    memory = _peer_sends(bench, mav.MAVLink_param_request_read_message(1, 1, b"WP_SPEED", -1), gcs, mavproxy)
    assert (cap.count(mavproxy, "PARAM_VALUE"), cap.count(follow, "PARAM_VALUE")) == (1, 0)
    assert not [m for m in memory if m.get_type() == "PARAM_VALUE"]
    _peer_sends(bench, mav.MAVLink_param_request_list_message(1, 1), gcs, mavproxy)
    assert cap.count(mavproxy, "PARAM_VALUE") == 1 + len(bench.ep.params) and cap.count(follow, "PARAM_VALUE") == 0
    assert cap.count(follow, "STATUSTEXT") == 0  # (the banner before the list too)
    _peer_sends(bench, _cmd(mav.MAV_CMD_DO_SEND_BANNER), gcs, mavproxy)  # (MAVProxy's `useralerts check`)
    assert cap.count(follow, "STATUSTEXT") == 0 and cap.count(mavproxy, "STATUSTEXT") == 4
    # ... and so does opening the parameter file by MAVLink FTP (MAVProxy's `param fetch`)
    from lfctl.link.ftp import OP_OPEN_RO

    path = b"@PARAM/param.pck"
    head = struct.pack("<HBBBBBBI", 1, 0, OP_OPEN_RO, len(path), 0, 0, 0, 0)
    _peer_sends(
        bench, mav.MAVLink_file_transfer_protocol_message(0, 1, 1, list((head + path).ljust(251, b"\0"))), gcs, mavproxy
    )
    assert cap.count(mavproxy, "FILE_TRANSFER_PROTOCOL") == 1 and cap.count(mavproxy, "STATUSTEXT") == 6
    assert cap.count(follow, "STATUSTEXT") == 0 and cap.count(follow, "FILE_TRANSFER_PROTOCOL") == 0
    memory = _peer_sends(
        bench, mav.MAVLink_param_set_message(1, 1, b"WP_SPEED", 1.5, mav.MAV_PARAM_TYPE_REAL32), gcs, mavproxy
    )
    assert cap.count(follow, "PARAM_VALUE") == 1 and [
        m.param_value for m in memory if m.get_type() == "PARAM_VALUE"
    ] == [1.5]


def test_the_record_says_which_peer_a_packet_went_to_alone_and_its_bytes_match_its_fields(bench: Bench) -> None:
    # each per-peer packing rewrote the message's header after the record's bytes were taken
    # (its seq disagreed with them), and a peer's own stream read as the vehicle's: `lfctl
    # audit` summed every schedule's GLOBAL_POSITION_INT into one rate no peer got
    import base64

    follow, quiet = ("127.0.0.1", 40001), ("127.0.0.1", 40002)
    PeerCapture(bench, [follow, quiet])
    gpi = mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
    fast = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, gpi, 50000, 0, 0, 0, 0, 0)
    _peer_sends(bench, fast, mav.MAVLink(None, srcSystem=1, srcComponent=191), follow)
    del bench.records[:]
    for _ in range(50):  # 1 s
        bench.tick(0.02)
    out = [r for r in map(json.loads, bench.records) if r["direction"] == "out"]
    assert all(base64.b64decode(r["raw"])[4] == r["seq"] for r in out)  # MAVLink 2: seq is byte 4
    gpis = [r.get("to") for r in out if r["name"] == "GLOBAL_POSITION_INT"]
    assert gpis.count("127.0.0.1:40001") == 20 and gpis.count(None) == 1  # its own 20 Hz; everyone's 1 Hz


def test_sys_status_reports_the_controllers_as_rovers_mode_runs_them(bench: Bench) -> None:
    # GCS_Rover::update_vehicle_sensor_status_flags: the four controllers always present;
    # rate and attitude where the mode is attitude_stabilized, yaw and position where it is an
    # autopilot mode: none of them in HOLD or MANUAL, all four in GUIDED, AUTO, RTL, SmartRTL
    controllers = (
        mav.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
        | mav.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
        | mav.MAV_SYS_STATUS_SENSOR_YAW_POSITION
        | mav.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
    )

    def bits() -> tuple[int, int, int]:
        (status,) = [m for m in bench.tick(1.0) if m.get_type() == "SYS_STATUS"][-1:]
        return (
            status.onboard_control_sensors_present & controllers,
            status.onboard_control_sensors_enabled & controllers,
            status.onboard_control_sensors_health & controllers,
        )

    assert bits() == (controllers, 0, 0)  # HOLD
    for mode, expected in (("GUIDED", controllers), ("RTL", controllers), ("MANUAL", 0)):
        assert bench.set_mode(mode) == mav.MAV_RESULT_ACCEPTED
        assert bits() == (controllers, expected, expected), mode


def test_fence_status_counts_each_fence_breached_and_times_the_first_of_a_run(bench: Bench) -> None:
    # AC_Fence::record_breach, once for each fence newly breached: the count goes up by one
    # for each, and the time is taken only when no fence was breached before (the circle's
    # backup circle breached again farther out counts, but does not move the time)
    ep = bench.ep
    assert upload(bench, fence_square(5.0), mav.MAV_MISSION_TYPE_FENCE) == mav.MAV_MISSION_ACCEPTED
    ep.params["FENCE_TYPE"].value, ep.params["FENCE_RADIUS"].value, ep.params["FENCE_ENABLE"].value = 6, 8.0, 1
    ep.params["FENCE_ACTION"].value = 0  # report only: no mode change, no manual recovery
    bench.state = dict(STATE, north_m=0.0, east_m=0.0)
    bench.tick()
    ep.set_armed(True)  # home stays here
    bench.tick(1.0, state=dict(STATE, north_m=20.0, east_m=0.0))  # out of both at once
    assert (ep.fence_breaches, ep.fence_breach) == (2, "circle")
    first_ms = ep._fence_breach_ms
    bench.tick(1.0, state=dict(STATE, north_m=41.0, east_m=0.0))  # past the backup circle (20 + 20 m)
    assert ep.fence_breaches == 3 and ep._fence_breach_ms == first_ms
    (status,) = [
        m for m in bench.tick(1.0, state=dict(STATE, north_m=41.0, east_m=0.0)) if m.get_type() == "FENCE_STATUS"
    ]
    assert (status.breach_count, status.breach_time) == (3, first_ms)


@pytest.mark.parametrize(
    ("p1", "fences", "said"),
    [
        (1.0, 6, ["Circle and Polygon fences enabled"]),
        (0.0, 0, ["Circle and Polygon fences disabled"]),
        (2.0, 6, ["Min Alt fence disabled"]),
        (3.0, 6, []),
    ],
)
def test_a_missions_fence_enable_is_ap_missions_and_says_what_it_changed(
    bench: Bench, p1: float, fences: int, said: list[str]
) -> None:
    # AP_Mission::start_command_fence, not the ground station's command: 0 and 1 turn every
    # configured fence off or on (enable_configured: the polygon too, none uploaded), said at
    # NOTICE for the fences changed (print_fence_message); 2 the floor off, said; else nothing
    ep = bench.ep
    ep.params["FENCE_TYPE"].value = 6
    if p1 != 1.0:
        ep.params["FENCE_ENABLE"].value = 1
    bench.tick()
    before = len(ep.statustexts)
    ep.run_mission_item(Item(2, mav.MAV_CMD_DO_FENCE_ENABLE, p1=p1), verified=False)  # type: ignore[arg-type]
    texts = [(m.severity, m.text) for m in bench.tick() if m.get_type() == "STATUSTEXT"]
    assert texts == [(mav.MAV_SEVERITY_NOTICE, text) for text in said]
    assert [t for _, t in ep.statustexts[before:]] == said
    assert ep.fences_enabled == fences
    ep.run_mission_item(Item(3, mav.MAV_CMD_DO_FENCE_ENABLE, p1=p1), verified=False)  # type: ignore[arg-type]
    if p1 in (0.0, 1.0):  # again: nothing changes, nothing is said
        assert [t for _, t in ep.statustexts[before:]] == said


@pytest.mark.parametrize(
    ("limit_km", "incl_home", "at", "goes_to"),
    [
        (0.5, 1, (1300.0, 0.0), "home"),  # the rally point 700 m away: past RALLY_LIMIT_KM, home
        (0.0, 1, (1300.0, 0.0), "rally"),  # no limit: the nearer of the two
        (1.0, 1, (1300.0, 0.0), "rally"),
        (1.0, 1, (900.0, 0.0), "home"),  # home 900 m, the rally point 1100 m: home is nearer
        (2.0, 0, (900.0, 0.0), "rally"),  # home not considered: the rally point within the limit
        (0.5, 0, (900.0, 0.0), "home"),  # ... unless it is past the limit
    ],
)
def test_rtl_takes_a_rally_point_as_rover_weighs_it_against_home(
    bench: Bench, limit_km: float, incl_home: int, at: tuple[float, float], goes_to: str
) -> None:
    # AP_Rally::calc_best_rally_or_home_location (Rover: RALLY_LIMIT_KM 0.5, RALLY_INCL_HOME 1):
    # the nearest rally point past the limit is none; with home included, home unless the
    # rally point is strictly nearer. A rally point 2 km north of home
    lat, lon, _alt = ned_to_geodetic(2000.0, 0.0, 0.0, *HOME)
    far = Item(0, mav.MAV_CMD_NAV_RALLY_POINT, x=round(lat * 1e7), y=round(lon * 1e7), frame=mav.MAV_FRAME_GLOBAL_INT)
    unset = Item(1, mav.MAV_CMD_NAV_RALLY_POINT, x=0, y=0, frame=mav.MAV_FRAME_GLOBAL_INT)  # skipped, as Rover's
    assert upload(bench, [far, unset], mav.MAV_MISSION_TYPE_RALLY) == mav.MAV_MISSION_ACCEPTED
    bench.state = {**STATE, "north_m": 0.0, "east_m": 0.0}
    bench.tick()  # home here
    bench.ep.params["RALLY_LIMIT_KM"].value, bench.ep.params["RALLY_INCL_HOME"].value = limit_km, incl_home
    n, e = bench.ep.rtl_destination(*at)
    assert (n, e) == pytest.approx((0.0, 0.0) if goes_to == "home" else (2000.0, 0.0), abs=0.5)


@pytest.mark.parametrize(("speed", "cog"), [(1.0, 3000), (-1.0, 21000), (0.0, 3000)])
def test_gps_raw_ints_course_is_the_way_the_vehicle_moves(bench: Bench, speed: float, cog: int) -> None:
    # AP_GPS::send_mavlink_gps_raw sends the GPS's ground course: nose at 30 deg, forwards 30
    # deg; backing up at 1 m/s it moves towards 210 deg, as GLOBAL_POSITION_INT's vx, vy say
    bench.state = {**STATE, "yaw_rad": math.radians(30.0), "speed_mps": speed}
    request = (mav.MAVLINK_MSG_ID_GPS_RAW_INT, 0, 0, 0, 0, 0, 0)
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, *request))
    (gps,) = [m for m in bench.tick(0.001) if m.get_type() == "GPS_RAW_INT"][-1:]
    assert (gps.cog, gps.vel) == (cog, round(abs(speed) * 100))


@pytest.mark.parametrize("msg_id", [mav.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED, mav.MAVLINK_MSG_ID_ATTITUDE_TARGET])
def test_targets_rover_has_no_sender_for_are_accepted_and_nothing_comes(bench: Bench, msg_id: int) -> None:
    # GCS_Common maps both to ap_messages, and a rover's senders for them are GCS_MAVLINK's
    # empty ones (Rover overrides only send_position_target_global_int): ACCEPTED, nothing sent
    assert bench.command(mav.MAV_CMD_REQUEST_MESSAGE, msg_id) == mav.MAV_RESULT_ACCEPTED
    assert bench.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 100_000) == mav.MAV_RESULT_ACCEPTED
    out = [m for _ in range(100) for m in bench.tick(0.02)]
    assert not [m for m in out if m.get_msgId() == msg_id]


def test_a_timesync_request_is_answered_on_the_askers_link_alone(bench: Bench) -> None:
    # Rover's handle_timesync answers with mavlink_msg_timesync_send(chan, ...): the link the
    # request came on; the other ground station and the companion get no answer to it
    asker, other = ("127.0.0.1", 40001), ("127.0.0.1", 40002)
    cap = PeerCapture(bench, [asker, other])
    gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    _peer_sends(bench, mav.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3), gcs, other)  # (heard: a peer)
    _peer_sends(bench, mav.MAVLink_timesync_message(0, 123456789), gcs, asker)
    assert (cap.count(asker, "TIMESYNC"), cap.count(other, "TIMESYNC")) == (1, 0)


def test_broadcasts_from_any_sender_and_messages_for_another_system_go_where_rover_sends_them(bench: Bench) -> None:
    # MAVLink_routing::check_and_forward: a message to no one in particular goes to every other
    # link (a ground station's STATUSTEXT reaches the companion), but never a radio's
    # RADIO_STATUS nor ADSB_VEHICLE; one for another system to every link that system was
    # heard on, whatever component it names (system 2 heard only as 2/100, a command to 2/1)
    ground, companion, other_vehicle = ("127.0.0.1", 40001), ("127.0.0.1", 40002), ("127.0.0.1", 40003)
    cap = PeerCapture(bench, [ground, companion, other_vehicle])

    def fan_out(data: bytes, exclude: tuple[object, ...] = ()) -> int:  # the UDP side's send to all
        to = [p for p in cap.got if p not in exclude]
        for p in to:
            cap._sent(data, p)
        return len(to)

    bench.ep.network.send = fan_out  # type: ignore[union-attr]
    gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    _peer_sends(
        bench,
        mav.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3),
        mav.MAVLink(None, srcSystem=1, srcComponent=191),
        companion,
    )
    _peer_sends(
        bench,
        mav.MAVLink_heartbeat_message(30, 8, 0, 0, 4, 3),
        mav.MAVLink(None, srcSystem=2, srcComponent=100),
        other_vehicle,
    )
    for p in cap.got.values():
        p.clear()
    _peer_sends(bench, mav.MAVLink_statustext_message(6, b"hello", 0, 0), gcs, ground)
    _peer_sends(bench, mav.MAVLink_radio_status_message(200, 190, 100, 0, 0, 0, 0), gcs, ground)
    assert [cap.count(p, "STATUSTEXT") for p in (ground, companion, other_vehicle)] == [0, 1, 1]
    assert all(cap.count(p, "RADIO_STATUS") == 0 for p in cap.got)
    arm = mav.MAVLink_command_long_message(2, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    _peer_sends(bench, arm, gcs, ground)
    assert [cap.count(p, "COMMAND_LONG") for p in (ground, companion, other_vehicle)] == [0, 0, 1]
    assert not bench.ep.armed  # not this vehicle's


def test_a_downloaded_items_current_flag_is_set_as_rovers_get_item_sets_it(bench: Bench) -> None:
    # MissionItemProtocol_Waypoints::get_item: current = (cmd.id == the navigation command's
    # index), so neither home at rest nor an item set current (here a DO item, whose next
    # navigation item MISSION_CURRENT names) is flagged; a nav index of 16 flags waypoints
    items = [*good_mission(2), Item(2, mav.MAV_CMD_DO_CHANGE_SPEED, p1=1, p2=0.5), *good_mission(4)[3:]]
    assert upload(bench, items) == mav.MAV_MISSION_ACCEPTED
    assert [m.current for m in download(bench, mav.MAV_MISSION_TYPE_MISSION)] == [0, 0, 0, 0]  # type: ignore[attr-defined]
    assert bench.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 2) == mav.MAV_RESULT_ACCEPTED  # MAVSDK's way
    assert bench.ep.mission_current == 3
    assert [m.current for m in download(bench, mav.MAV_MISSION_TYPE_MISSION)] == [0, 0, 0, 0]  # type: ignore[attr-defined]
    many = [*good_mission(18)]
    assert upload(bench, many) == mav.MAV_MISSION_ACCEPTED
    assert bench.command(mav.MAV_CMD_DO_SET_MISSION_CURRENT, 16) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.mission_current == 16
    assert {m.current for m in download(bench, mav.MAV_MISSION_TYPE_MISSION)} == {1}  # type: ignore[attr-defined]
