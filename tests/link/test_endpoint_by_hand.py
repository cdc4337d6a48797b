"""The vehicle endpoint's answers to a ground station, worked by hand: tests written from
mutation testing of lfctl/link/endpoint.py, each for a change to the code that no other test
noticed. Each number is worked from ArduPilot Rover's behaviour (GCS_Common.cpp,
GCS_MAVLink_Rover.cpp, AP_Mission, AP_Arming) or, where lfctl sets its own limit, from that
limit's definition; the comments say which.

The endpoint runs in memory, driven by a ground station's pymavlink codec, as in
test_endpoint_rover.py. Home is at 12.9602 N 77.6690 E, 900 m above mean sea level."""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav
from test_endpoint_rover import upload

from lfctl.link.endpoint import MODES, REBOOT_S, VehicleEndpoint
from lfctl.link.mission import MissionItem
from lfctl.link.transport import MemoryLink

HOME = (12.9602, 77.6690, 900.0)
STATE = {"north_m": 1.0, "east_m": 2.0, "yaw_rad": 0.5, "speed_mps": 0.2, "yaw_rate_radps": 0.0}
NAN = math.nan
PARAM_VALUE_ID = mav.MAVLINK_MSG_ID_PARAM_VALUE  # 22


class Bench:
    """An endpoint in memory and a ground station's codec (255/190) on the other end."""

    def __init__(self) -> None:
        self.a, self.b = MemoryLink.pair("ep", "gcs")
        self.ep = VehicleEndpoint("v", 1, self.a, HOME)
        self.gcs = mav.MAVLink(None, srcSystem=255, srcComponent=190)
        self.parser = mav.MAVLink(None)
        self.parser.robust_parsing = True
        self.t = 0.0
        self.seen: list[Any] = []  # every message the endpoint sent, in order

    def send(self, msg: Any) -> None:
        self.b.send(msg.pack(self.gcs))

    def tick(self, dt: float = 0.02) -> list[Any]:
        self.t += dt
        self.ep.tick(self.t, STATE)
        out = []
        for data, _addr in self.b.recv(100000):
            out += [m for m in (self.parser.parse_buffer(data) or []) if m.get_type() != "BAD_DATA"]
        self.seen += out
        return out

    def answers(self, msg: Any, kind: str) -> list[Any]:
        self.send(msg)
        return [m for m in self.tick() if m.get_type() == kind]

    def command_long(self, cmd: int, *p: float) -> int:
        params = [*p, *([0.0] * (7 - len(p)))]
        (ack,) = [m for m in self.answers(mav.MAVLink_command_long_message(1, 1, cmd, 0, *params), "COMMAND_ACK")]
        return int(ack.result)

    def command_int(self, cmd: int, frame: int, x: int, y: int, z: float, *p: float) -> int:
        params = [*p, *([0.0] * (4 - len(p)))]
        msg = mav.MAVLink_command_int_message(1, 1, frame, cmd, 0, 0, *params, x, y, z)
        (ack,) = [m for m in self.answers(msg, "COMMAND_ACK")]
        return int(ack.result)

    def texts(self, msgs: list[Any]) -> list[tuple[int, str]]:
        return [(m.severity, m.text) for m in msgs if m.get_type() == "STATUSTEXT"]


class Peers:
    """An endpoint's network side: each peer's packets as the endpoint sends them, parsed peer
    by peer; :meth:`ask` puts a COMMAND_LONG from a peer (its own codec) in the endpoint's
    inbox and runs one tick."""

    def __init__(self, bench: Bench, *peers: Any) -> None:
        self.bench, self.peers = bench, list(peers)
        self.got: dict[Any, list[Any]] = {p: [] for p in peers}
        self._parsers = {p: mav.MAVLink(None) for p in peers}
        self._codecs = {p: mav.MAVLink(None, srcSystem=250 - k, srcComponent=190) for k, p in enumerate(peers)}
        bench.ep.network = self

    def send_to(self, data: bytes, addr: Any) -> None:
        self.got[addr] += [m for m in self._parsers[addr].parse_buffer(data) or [] if m.get_type() != "BAD_DATA"]

    def send(self, data: bytes, exclude: Any = ()) -> int:
        return 0

    def reachable(self) -> list[Any]:
        return list(self.peers)

    def ask(self, peer: Any, cmd: int, *p: float) -> list[Any]:
        """The messages ``peer`` gets in the tick that handles its command."""
        before = len(self.got[peer])
        msg = mav.MAVLink_command_long_message(1, 1, cmd, 0, *p, *([0.0] * (7 - len(p))))
        self.bench.a.inbox.append((msg.pack(self._codecs[peer]), peer))
        self.bench.tick()
        return self.got[peer][before:]

    def interval(self, peer: Any, msg_id: int) -> int:
        """The interval ``peer`` is told for ``msg_id`` (GET_MESSAGE_INTERVAL), us."""
        answers = self.ask(peer, mav.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id)
        (answer,) = [m for m in answers if m.get_type() == "MESSAGE_INTERVAL"]
        return int(answer.interval_us)


PEER_A, PEER_B = ("127.0.0.1", 40001), ("127.0.0.1", 40002)


@pytest.fixture
def bench() -> Bench:
    return Bench()


def upload_float(
    bench: Bench, items: list[tuple[int, float, float]], mission_type: int = 0, param1: float = 0.0
) -> int:
    """Upload (command, x, y) items as the float MISSION_ITEM (test_endpoint_rover's upload,
    which sends x and y / 1e7); the final MISSION_ACK's type."""
    frame = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT
    its = [
        SimpleNamespace(seq=k, frame=frame, command=cmd, param1=param1, param2=0.0, param3=0.0, param4=0.0,
                        x=x * 1e7, y=y * 1e7, z=0.0)
        for k, (cmd, x, y) in enumerate(items)
    ]  # fmt: skip
    return upload(bench, its, mission_type, as_float=True)  # type: ignore[arg-type]


# --- MISSION_ITEM (float): AP_Mission::convert_MISSION_ITEM_to_MISSION_ITEM_INT ---------------


def test_a_float_mission_items_degrees_are_stored_as_degE7(bench: Bench) -> None:
    # a waypoint's x, y are degrees, multiplied by 1e7 and rounded (12.5 and 77.25 are exact in
    # a float32): 12.5 * 1e7 = 125 000 000, 77.25 * 1e7 = 772 500 000
    wp = mav.MAV_CMD_NAV_WAYPOINT
    assert upload_float(bench, [(wp, 12.5, 77.25), (wp, 12.5, 77.25)]) == mav.MAV_MISSION_ACCEPTED
    assert (bench.ep.mission[1].x, bench.ep.mission[1].y) == (125_000_000, 772_500_000)
    # MissionItemProtocol_Waypoints::complete: send_text(MAV_SEVERITY_INFO, "Flight plan received")
    assert (mav.MAV_SEVERITY_INFO, "Flight plan received") in bench.texts(bench.seen)


@pytest.mark.parametrize(
    ("x", "y", "result"),
    [
        # check_lat: |lat| <= 90 degrees; check_lng: |lng| <= 180 degrees (90.5, 180.5 exact in float32)
        (90.5, 77.25, mav.MAV_MISSION_INVALID_PARAM5_X),
        (12.5, 180.5, mav.MAV_MISSION_INVALID_PARAM6_Y),
    ],
)
def test_a_float_waypoint_off_the_globe_is_refused_by_its_field(bench: Bench, x: float, y: float, result: int) -> None:
    wp = mav.MAV_CMD_NAV_WAYPOINT
    assert upload_float(bench, [(wp, 12.5, 77.25), (wp, x, y)]) == result


def test_a_float_waypoint_at_180_degrees_east_is_on_the_globe(bench: Bench) -> None:
    # check_lng: |lng| <= 180 degrees, 180 itself included: 180 * 1e7 = 1 800 000 000 degE7
    wp = mav.MAV_CMD_NAV_WAYPOINT
    assert upload_float(bench, [(wp, 12.5, 77.25), (wp, 12.5, 180.0)]) == mav.MAV_MISSION_ACCEPTED
    assert bench.ep.mission[1].y == 1_800_000_000


def test_a_float_waypoint_at_the_north_pole_is_on_the_globe(bench: Bench) -> None:
    # check_lat: |lat| <= 90 degrees, 90 itself included: 90 * 1e7 = 900 000 000 degE7
    wp = mav.MAV_CMD_NAV_WAYPOINT
    assert upload_float(bench, [(wp, 12.5, 77.25), (wp, 90.0, 77.25)]) == mav.MAV_MISSION_ACCEPTED
    assert bench.ep.mission[1].x == 900_000_000


def test_a_float_waypoint_whose_longitude_is_not_a_number_is_an_invalid_y(bench: Bench) -> None:
    # a NaN longitude is no longitude: MAV_MISSION_INVALID_PARAM6_Y, and the handler does not fail
    wp = mav.MAV_CMD_NAV_WAYPOINT
    assert upload_float(bench, [(wp, 12.5, 77.25), (wp, 12.5, NAN)]) == mav.MAV_MISSION_INVALID_PARAM6_Y
    assert bench.ep.stats.handler_errors == 0


def test_a_fence_uploaded_as_float_items_downloads_again(bench: Bench) -> None:
    # a circle of 50 m uploaded with MISSION_ITEM (degrees) comes back with MISSION_ITEM_INT in
    # degE7: 12.5 * 1e7 = 125 000 000, 77.25 * 1e7 = 772 500 000, and nothing fails to go out
    fence, circle = mav.MAV_MISSION_TYPE_FENCE, mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION
    assert upload_float(bench, [(circle, 12.5, 77.25)], fence, param1=50.0) == mav.MAV_MISSION_ACCEPTED
    (item,) = bench.answers(mav.MAVLink_mission_request_int_message(1, 1, 0, fence), "MISSION_ITEM_INT")
    assert (item.command, item.param1, item.x, item.y) == (circle, 50.0, 125_000_000, 772_500_000)
    assert bench.ep.stats.send_errors == 0


def test_a_float_camera_items_x_and_y_are_cut_to_whole_numbers(bench: Bench) -> None:
    # convert_MISSION_ITEM_to_MISSION_ITEM_INT: DO_DIGICAM_CONTROL's x, y are not a place:
    # mav_cmd.x = packet.x, a float assigned to an int32, cut toward zero: 5.75 is 5, -7.75 is -7
    digicam = mav.MAV_CMD_DO_DIGICAM_CONTROL
    assert (
        upload_float(bench, [(mav.MAV_CMD_NAV_WAYPOINT, 12.5, 77.25), (digicam, 5.75, -7.75)])
        == mav.MAV_MISSION_ACCEPTED
    )
    assert (bench.ep.mission[1].x, bench.ep.mission[1].y) == (5, -7)


def test_a_float_fence_item_that_is_not_a_number_is_refused_in_the_fences_ack(bench: Bench) -> None:
    # convert_MISSION_ITEM_to_MISSION_ITEM_INT copies mission_type before it checks x, and
    # handle_mission_item acks with that type: a fence item's refusal is a fence ACK (type 1)
    fence = mav.MAV_MISSION_TYPE_FENCE
    bench.send(mav.MAVLink_mission_count_message(1, 1, 1, fence))
    bench.tick()
    item = mav.MAVLink_mission_item_message(
        1, 1, 0, 0, mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, 0, 1, 50, 0, 0, 0, NAN, 77.25, 0, fence
    )
    (ack,) = bench.answers(item, "MISSION_ACK")
    assert (ack.type, ack.mission_type) == (mav.MAV_MISSION_INVALID_PARAM5_X, fence)


# --- message intervals: GCS_MAVLINK::handle_command_{set,get}_message_interval -----------------


def test_heartbeats_interval_can_be_set_as_message_id_0(bench: Bench) -> None:
    # HEARTBEAT is message 0: a rate for it is taken (id 0 is a message, not "none")
    hb = mav.MAVLINK_MSG_ID_HEARTBEAT
    assert hb == 0
    assert bench.command_long(mav.MAV_CMD_SET_MESSAGE_INTERVAL, hb, 500_000) == mav.MAV_RESULT_ACCEPTED
    (answer,) = bench.answers(
        mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_GET_MESSAGE_INTERVAL, 0, hb, 0, 0, 0, 0, 0, 0),
        "MESSAGE_INTERVAL",
    )
    assert (answer.message_id, answer.interval_us) == (0, 500_000)


def test_the_largest_24_bit_id_is_a_message_not_sent_and_fails(bench: Bench) -> None:
    # GCS_MAVLINK::handle_command_get_message_interval: an id >= 2 << 15 (65 536) gets
    # MESSAGE_INTERVAL(id, 0) and FAILED; MESSAGE_INTERVAL's message_id is a uint16, so
    # 2**24 - 1 = 16 777 215 goes out as 16 777 215 & 0xFFFF = 65 535
    get = mav.MAV_CMD_GET_MESSAGE_INTERVAL
    bench.send(mav.MAVLink_command_long_message(1, 1, get, 0, 2**24 - 1, 0, 0, 0, 0, 0, 0))
    out = bench.tick()
    assert [m.result for m in out if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_FAILED]
    assert [(m.message_id, m.interval_us) for m in out if m.get_type() == "MESSAGE_INTERVAL"] == [(65535, 0)]


def test_an_id_past_24_bits_fails_with_a_message_interval_of_0_as_on_rover(bench: Bench) -> None:
    # GCS_MAVLINK::handle_command_get_message_interval: mavlink_id = (uint32_t)param1 =
    # 16 777 216 >= 2 << 15: mavlink_msg_message_interval_send(chan, mavlink_id, 0) and FAILED;
    # the uint16 field carries 16 777 216 & 0xFFFF = 0
    get = mav.MAV_CMD_GET_MESSAGE_INTERVAL
    bench.send(mav.MAVLink_command_long_message(1, 1, get, 0, 2**24, 0, 0, 0, 0, 0, 0))
    out = bench.tick()
    assert [m.result for m in out if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_FAILED]
    assert [(m.message_id, m.interval_us) for m in out if m.get_type() == "MESSAGE_INTERVAL"] == [(0, 0)]


def test_a_message_the_vehicle_lacks_is_said_at_info_severity(bench: Bench) -> None:
    # GCS_MAVLINK::set_message_interval: GCS_SEND_TEXT(MAV_SEVERITY_INFO, "No ap_message for mavlink id
    # (%u)") and DENIED (the text in SITL, which a simulated vehicle is)
    # (message 140, ACTUATOR_CONTROL_TARGET, is one ArduPilot has no ap_message for)
    msg = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 140, 100_000, 0, 0, 0, 0, 0)
    bench.send(msg)
    out = bench.tick()
    assert [m.result for m in out if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_DENIED]
    assert (mav.MAV_SEVERITY_INFO, "No ap_message for mavlink id (140)") in bench.texts(out)
    # the largest 24-bit id, 2**24 - 1 = 16 777 215, is one too: said the same way
    msg = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 2**24 - 1, 100_000, 0, 0, 0, 0, 0)
    bench.send(msg)
    out = bench.tick()
    assert [m.result for m in out if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_DENIED]
    assert (mav.MAV_SEVERITY_INFO, "No ap_message for mavlink id (16777215)") in bench.texts(out)


# --- arming: AP_Arming_Rover -----------------------------------------------------------------


def test_disarming_says_throttle_disarmed_in_rovers_words(bench: Bench) -> None:
    # AP_Arming_Rover::arm / disarm: "Throttle armed", "Throttle disarmed" (INFO)
    arm = mav.MAV_CMD_COMPONENT_ARM_DISARM
    bench.send(mav.MAVLink_command_long_message(1, 1, arm, 0, 1, 0, 0, 0, 0, 0, 0))
    assert (mav.MAV_SEVERITY_INFO, "Throttle armed") in bench.texts(bench.tick())
    bench.send(mav.MAVLink_command_long_message(1, 1, arm, 0, 0, 0, 0, 0, 0, 0, 0))
    assert (mav.MAV_SEVERITY_INFO, "Throttle disarmed") in bench.texts(bench.tick())


# --- DO_SET_HOME's place: GCS_MAVLINK::location_from_command_t, check_latlng ------------------

GLOBAL_INT, RELATIVE_INT = mav.MAV_FRAME_GLOBAL_INT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
LAT_E7 = 129_602_000


def test_a_home_a_hair_past_180_degrees_east_is_off_the_globe(bench: Bench) -> None:
    # check_lng: |lng| <= 180 * 1e7 degE7; 1 800 000 001 degE7 is 180.0000001 degrees: DENIED
    home = mav.MAV_CMD_DO_SET_HOME
    assert bench.command_int(home, GLOBAL_INT, LAT_E7, 1_800_000_001, 900.0) == mav.MAV_RESULT_DENIED
    assert bench.command_int(home, GLOBAL_INT, LAT_E7, -1_800_000_001, 900.0) == mav.MAV_RESULT_DENIED
    # check_lat: |lat| <= 90 * 1e7 degE7; 900 000 001 is 90.0000001 degrees: DENIED too
    assert bench.command_int(home, GLOBAL_INT, 900_000_001, HOME_LON_E7, 900.0) == mav.MAV_RESULT_DENIED
    assert not bench.ep.home_locked
    assert bench.command_int(home, GLOBAL_INT, LAT_E7, 1_800_000_000, 900.0) == mav.MAV_RESULT_ACCEPTED


@pytest.mark.parametrize(("lat", "lon"), [(12.9602, NAN), (NAN, 77.669)])
def test_a_command_long_home_half_of_whose_place_is_not_a_number_is_denied(
    bench: Bench, lat: float, lon: float
) -> None:
    # param5 (latitude) or param6 (longitude) NaN: no place (one of them alone is not one),
    # DENIED, and the handler does not fail on it
    home = mav.MAV_CMD_DO_SET_HOME
    assert bench.command_long(home, 0, 0, 0, 0, lat, lon, 900.0) == mav.MAV_RESULT_DENIED
    assert not bench.ep.home_locked and bench.ep.stats.handler_errors == 0


def test_an_altitude_of_83_km_exactly_is_still_a_location(bench: Bench) -> None:
    # location_from_command_t: fabsf(z) > LOCATION_ALT_MAX_M (83 000 m) is DENIED, so 83 000 m
    # itself is taken; the next float32 above it, 83 000 + 2**-7 = 83 000.0078125, is not
    home, lon_e7 = mav.MAV_CMD_DO_SET_HOME, 776_690_000
    assert bench.command_int(home, RELATIVE_INT, LAT_E7, lon_e7, 83_000.0078125) == mav.MAV_RESULT_DENIED
    assert bench.command_int(home, RELATIVE_INT, LAT_E7, lon_e7, 83_000.0) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.home_up_m == 83_000.0  # above the home it had (0 m above the ground)


# --- the current mission item: AP_Mission::set_current_cmd -----------------------------------


def square_mission(bench: Bench, n: int = 3) -> None:
    """Home and ``n`` waypoints stored, item 1 current."""
    wp, frame = mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    bench.ep.store_mission([MissionItem(k, frame, wp, x=LAT_E7 + 100 * k, y=776_690_000) for k in range(n + 1)])


def test_a_new_current_item_mid_mission_keeps_the_jump_counts(bench: Bench) -> None:
    # set_current_cmd resets the jump tracking only for index 0 or a mission that is
    # complete; MISSION_SET_CURRENT to item 2 of a mission under way is not a restart
    square_mission(bench)
    restarts = bench.ep.mission_restarts
    echoes = bench.answers(mav.MAVLink_mission_set_current_message(1, 1, 2), "MISSION_CURRENT")
    assert [m.seq for m in echoes][-1] == 2 and bench.ep.current_seq == 2
    assert bench.ep.mission_restarts == restarts
    assert bench.ep.set_current(3) and bench.ep.mission_restarts == restarts
    assert bench.ep.set_current(3, reset=True) and bench.ep.mission_restarts == restarts + 1


def test_each_new_current_item_bumps_the_mission_version(bench: Bench) -> None:
    # mission_version "bumps when the mission or the current item changes": the simulation
    # rebuilds the route when it sees a version it has not seen, so it only ever goes up
    seen = [bench.ep.mission_version]
    square_mission(bench)  # a new mission is a change too
    assert bench.ep.mission_version > max(seen)
    seen.append(bench.ep.mission_version)
    for seq in (2, 3, 1):
        assert bench.ep.set_current(seq)
        assert bench.ep.mission_version > max(seen)
        seen.append(bench.ep.mission_version)


# --- each network peer's own rates: a Rover's links each keep their own ----------------------


def test_one_peers_parameter_stream_rate_is_its_own(bench: Bench) -> None:
    # peer A asks PARAM_VALUE every 500 ms (Rover: whole ms, at most 1000 ms: 500 ms kept);
    # peer B, which asked nothing, still hears the default 100 ms = 100 000 us
    peers = Peers(bench, PEER_A, PEER_B)
    peers.ask(PEER_A, mav.MAV_CMD_SET_MESSAGE_INTERVAL, PARAM_VALUE_ID, 500_000)
    assert peers.interval(PEER_A, PARAM_VALUE_ID) == 500_000
    assert peers.interval(PEER_B, PARAM_VALUE_ID) == 100_000


def test_a_mission_of_home_and_one_waypoint_is_a_mission(bench: Bench) -> None:
    # GCS_MAVLINK::mission_state: NO_MISSION only when !mission.present(), which is
    # num_commands() > 1; home and 1 waypoint is 2 commands: NOT_STARTED, and total excludes
    # home: 2 - 1 = 1
    square_mission(bench, n=1)
    echoes = bench.answers(mav.MAVLink_mission_set_current_message(1, 1, 1), "MISSION_CURRENT")
    assert (echoes[-1].seq, echoes[-1].total, echoes[-1].mission_state) == (1, 1, mav.MISSION_STATE_NOT_STARTED)


# --- COMMAND_ACK and the commands whose answer is a message ----------------------------------


def test_a_command_ack_goes_back_to_the_asker_with_no_progress(bench: Bench) -> None:
    # mavlink_msg_command_ack_send(chan, command, result, 0, 0, msg.sysid, msg.compid):
    # progress 0, result_param2 0, the target the sender (255, 190)
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_DO_SEND_BANNER, 0, 0, 0, 0, 0, 0, 0, 0))
    (ack,) = [m for m in bench.tick() if m.get_type() == "COMMAND_ACK"]
    assert (ack.command, ack.result, ack.progress, ack.result_param2) == (
        mav.MAV_CMD_DO_SEND_BANNER, mav.MAV_RESULT_ACCEPTED, 0, 0
    )  # fmt: skip
    assert (ack.target_system, ack.target_component) == (255, 190)


def test_asking_for_the_autopilots_capabilities_sends_its_version(bench: Bench) -> None:
    # MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES with param1 1: ACCEPTED and AUTOPILOT_VERSION sent
    cmd = mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES
    bench.send(mav.MAVLink_command_long_message(1, 1, cmd, 0, 1, 0, 0, 0, 0, 0, 0))
    out = bench.tick() + bench.tick()
    assert [m.result for m in out if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_ACCEPTED]
    (version,) = [m for m in out if m.get_type() == "AUTOPILOT_VERSION"]
    assert bench.ep.stats.handler_errors == 0
    assert list(version.flight_custom_version) == [0] * 8  # none given
    # where a Rover puts its firmware's git hash (8 ASCII characters), what the endpoint is given
    assert VehicleEndpoint("v", 1, MemoryLink("v"), HOME, custom_version="f30f646e").custom_version == list(b"f30f646e")
    bench.ep.custom_version = list(b"f30f646e")
    bench.send(mav.MAVLink_command_long_message(1, 1, cmd, 0, 1, 0, 0, 0, 0, 0, 0))
    (version,) = [m for m in bench.tick() + bench.tick() if m.get_type() == "AUTOPILOT_VERSION"]
    assert bytes(version.flight_custom_version) == b"f30f646e"


@pytest.mark.parametrize(("first", "last"), [(1, 0), (0, 2), (1, 3)])
def test_mission_start_from_a_chosen_item_is_denied(bench: Bench, first: float, last: float) -> None:
    # GCS_MAVLINK::handle_command_mission_start: !is_zero(param1) || !is_zero(param2) is
    # DENIED (first / last item not supported); the mode stays HOLD
    square_mission(bench)
    assert bench.command_long(mav.MAV_CMD_MISSION_START, first, last) == mav.MAV_RESULT_DENIED
    assert bench.ep.mode == MODES["HOLD"]
    # param3 .. param7 are not read: a NaN there changes nothing
    assert bench.command_long(mav.MAV_CMD_MISSION_START, 0, 0, NAN) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.mode == MODES["AUTO"]


def test_a_mission_start_whose_first_item_is_below_flt_epsilon_is_item_0(bench: Bench) -> None:
    # Rover/GCS_Mavlink.cpp, MAV_CMD_MISSION_START: if (!is_zero(packet.param1) || !is_zero(packet.param2))
    # DENIED; AP_Math's is_zero(x) is fabsf(x) < FLT_EPSILON = 1.19e-7, and 1e-9 (a float32 too,
    # about 1.0000000e-9) is below it: AUTO is entered, ACCEPTED
    square_mission(bench)
    assert bench.command_long(mav.MAV_CMD_MISSION_START, 1e-9, 0) == mav.MAV_RESULT_ACCEPTED


# --- stream rates: SET_MESSAGE_INTERVAL's 0 and its bounds, REQUEST_DATA_STREAM ---------------

VFR_HUD_ID = mav.MAVLINK_MSG_ID_VFR_HUD  # 74, streamed at 1 Hz by default (SRn_EXTRA2's 1)


def interval_of(bench: Bench, msg_id: int) -> int:
    msg = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_GET_MESSAGE_INTERVAL, 0, msg_id, 0, 0, 0, 0, 0, 0)
    (answer,) = bench.answers(msg, "MESSAGE_INTERVAL")
    return int(answer.interval_us)


def test_a_stream_rate_is_a_whole_number_of_ms_as_on_rover(bench: Bench) -> None:
    # GCS_MAVLINK::get_interval_for_stream: 1000 / rate in integers: 3 Hz is 333 ms, told
    # back as 333 000 us (not 333 333)
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_EXTRA2, 3, 1))
    bench.tick()
    assert interval_of(bench, VFR_HUD_ID) == 333_000


def test_an_interval_of_0_puts_back_the_default_rate(bench: Bench) -> None:
    # MAV_CMD_SET_MESSAGE_INTERVAL param2 0: the default rate again; VFR_HUD's is its group's,
    # SRn_EXTRA2's 1 Hz: 1 000 000 us (and -1 stops it: -1 is told back)
    set_interval = mav.MAV_CMD_SET_MESSAGE_INTERVAL
    assert interval_of(bench, VFR_HUD_ID) == 1_000_000
    assert bench.command_long(set_interval, VFR_HUD_ID, -1) == mav.MAV_RESULT_ACCEPTED
    assert interval_of(bench, VFR_HUD_ID) == -1
    assert bench.command_long(set_interval, VFR_HUD_ID, 0) == mav.MAV_RESULT_ACCEPTED
    assert interval_of(bench, VFR_HUD_ID) == 1_000_000


def test_an_interval_over_60_s_is_60_s(bench: Bench) -> None:
    # GCS_Common.cpp set_message_interval: "interval_us > 60000000: interval_ms = 60000":
    # 120 000 000 us asked, 60 000 000 us kept
    set_interval = mav.MAV_CMD_SET_MESSAGE_INTERVAL
    assert bench.command_long(set_interval, VFR_HUD_ID, 120_000_000) == mav.MAV_RESULT_ACCEPTED
    assert interval_of(bench, VFR_HUD_ID) == 60_000_000


TOO_FAST = "Requested rate for message ID {} too fast. Increase SCHED_LOOP_RATE"


def test_an_interval_faster_than_0_8_of_the_loop_rate_is_denied(bench: Bench) -> None:
    # Rover 4.6's set_message_interval: DENIED, with TOO_FAST, when cap_message_interval(ms) > ms;
    # cap_message_interval raises an interval with ms * 800 < the loop period (us) to period /
    # 800. Rover's SCHED_LOOP_RATE is 50 Hz (AP_Scheduler: 400 only for Copter and Sub): a
    # period of 1 000 000 / 50 = 20 000 us. 24 999 us is 24 ms (whole ms): 24 * 800 = 19 200 <
    # 20 000, DENIED and VFR_HUD kept at its 1000 ms; 25 ms: 25 * 800 = 20 000, not under it:
    # ACCEPTED (40 Hz, the fastest)
    set_interval = mav.MAV_CMD_SET_MESSAGE_INTERVAL
    bench.tick()
    seen = len(bench.ep.statustexts)
    assert bench.command_long(set_interval, VFR_HUD_ID, 24_999) == mav.MAV_RESULT_DENIED
    assert [t for _, t in bench.ep.statustexts[seen:]] == [TOO_FAST.format(VFR_HUD_ID)]
    assert interval_of(bench, VFR_HUD_ID) == 1_000_000
    assert bench.command_long(set_interval, VFR_HUD_ID, 25_000) == mav.MAV_RESULT_ACCEPTED
    assert interval_of(bench, VFR_HUD_ID) == 25_000
    # under 1 ms is 1 ms, still too fast; PARAM_VALUE's stream likewise (10 ms: 8 000 < 20 000);
    # -1 (stop) and 0 (the default) are no rate, never too fast
    assert bench.command_long(set_interval, VFR_HUD_ID, 500) == mav.MAV_RESULT_DENIED
    assert bench.command_long(set_interval, PARAM_VALUE_ID, 10_000) == mav.MAV_RESULT_DENIED
    assert bench.command_long(set_interval, VFR_HUD_ID, -1) == mav.MAV_RESULT_ACCEPTED
    assert bench.command_long(set_interval, VFR_HUD_ID, 0) == mav.MAV_RESULT_ACCEPTED
    # a message this vehicle does not send is DENIED for that, with its own text only
    seen = len(bench.ep.statustexts)
    assert bench.command_long(set_interval, 12345, 1000) == mav.MAV_RESULT_DENIED
    assert [t for _, t in bench.ep.statustexts[seen:]] == ["No ap_message for mavlink id (12345)"]


def test_a_faster_loop_rate_takes_a_reboot_and_then_allows_faster_messages(bench: Bench) -> None:
    # SCHED_LOOP_RATE is @RebootRequired (AP_Scheduler::init reads it at boot): set to 400 Hz,
    # 3 ms is still too fast until the autopilot restarts. Then the period is 1 000 000 / 400 =
    # 2 500 us: 3 ms * 800 = 2 400 < 2 500 is raised to int(2 500 / 800.0) = int(3.125) = 3,
    # not more than 3: ACCEPTED (as on Rover); 2 999 us is 2 ms: raised to 3 > 2, DENIED
    set_interval = mav.MAV_CMD_SET_MESSAGE_INTERVAL
    bench.tick()
    bench.ep.params["SCHED_LOOP_RATE"].value = 400
    assert bench.command_long(set_interval, VFR_HUD_ID, 3000) == mav.MAV_RESULT_DENIED
    bench.ep.reboot()
    bench.tick(REBOOT_S + 0.1)
    bench.tick()
    assert bench.command_long(set_interval, VFR_HUD_ID, 3000) == mav.MAV_RESULT_ACCEPTED
    assert interval_of(bench, VFR_HUD_ID) == 3000
    assert bench.command_long(set_interval, VFR_HUD_ID, 2999) == mav.MAV_RESULT_DENIED


def test_a_data_stream_of_50_hz_goes_out_at_40_hz(bench: Bench) -> None:
    # REQUEST_DATA_STREAM at 50 Hz (SRn_'s documented most): 1000 / 50 = 20 ms, which
    # set_ap_message_interval passes through cap_message_interval: 20 * 800 = 16 000 < 20 000
    # (SCHED_LOOP_RATE 50 Hz), so 20 000 / 800 = 25 ms; 10 Hz (100 ms) is kept
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_EXTRA2, 50, 1))
    bench.tick()
    assert interval_of(bench, VFR_HUD_ID) == 25_000
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_EXTRA2, 10, 1))
    bench.tick()
    assert interval_of(bench, VFR_HUD_ID) == 100_000


@pytest.mark.parametrize(
    ("rate", "interval_us"),
    [
        (1000, 25_000),  # 1000 / 1000 = 1 ms, capped to 0.8 x the loop rate as 50 Hz is
        (1001, -1),  # 1000 / 1001 is 0 in integers: not sent (a bigger rate is no faster)
        (32767, -1),
        (32768, -1),  # the int16 Rover keeps it in: -32768; 1000 / -32768 is 0: not sent
        (64535, -1),  # -1001: 0 again
        (64536, 60_000_000),  # -1000: -1 ms, as uint32 past 60 000: 60 s
        (65535, 60_000_000),  # -1: -1000 ms, the same
    ],
)
def test_a_data_stream_rate_is_read_as_rovers_int16_and_integer_division(
    bench: Bench, rate: int, interval_us: int
) -> None:
    # GCS_MAVLINK::handle_request_data_stream keeps req_message_rate (uint16) in an int16_t,
    # and get_interval_for_stream makes it 1000 / rate as uint32, at most 60 000 ms, 0 not sent
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_EXTRA2, rate, 1))
    bench.tick()
    assert interval_of(bench, VFR_HUD_ID) == interval_us


@pytest.mark.parametrize(
    ("target", "start_stop"),
    [
        (7, 1),  # another vehicle's (target_system 7): not this one's to act on
        (1, 2),  # start_stop is 0 or 1: 2 is neither
    ],
)
def test_a_data_stream_request_not_for_this_vehicle_changes_nothing(bench: Bench, target: int, start_stop: int) -> None:
    # EXTRA2 is VFR_HUD's group: 10 Hz asked would be 100 000 us; ignored, it stays 1 000 000 us
    bench.send(mav.MAVLink_request_data_stream_message(target, 1, mav.MAV_DATA_STREAM_EXTRA2, 10, start_stop))
    bench.tick()
    assert interval_of(bench, VFR_HUD_ID) == 1_000_000
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_EXTRA2, 10, 1))
    bench.tick()
    assert interval_of(bench, VFR_HUD_ID) == 100_000  # the same request, for this vehicle: 1 / 10 Hz


def test_a_peers_second_rate_keeps_its_first(bench: Bench) -> None:
    # a network peer's rates are its own (its link's); asking for a second message's rate
    # keeps the first one it set: GLOBAL_POSITION_INT at 50 000 us, then ATTITUDE at 200 000 us
    peers = Peers(bench, PEER_A)
    gpi, attitude = mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, mav.MAVLINK_MSG_ID_ATTITUDE
    peers.ask(PEER_A, mav.MAV_CMD_SET_MESSAGE_INTERVAL, gpi, 50_000)
    peers.ask(PEER_A, mav.MAV_CMD_SET_MESSAGE_INTERVAL, attitude, 200_000)
    assert (peers.interval(PEER_A, gpi), peers.interval(PEER_A, attitude)) == (50_000, 200_000)


# --- the fence and GUIDED's places: AC_Fence::check_destination_within_fence ----------------


def fenced(bench: Bench) -> None:
    """A circle fence of 100 m about home (FENCE_TYPE bit 2, the circle), enabled."""
    bench.ep.params["FENCE_TYPE"].value = 2
    bench.ep.params["FENCE_RADIUS"].value = 100
    bench.ep.params["FENCE_ENABLE"].value = 1
    bench.tick()


# 0.01 degree north of home is radians(0.01) * 6 378 137 m = 1113 m out: outside 100 m;
# home itself is 2.2 m from the vehicle (at 1 m N, 2 m E), well inside
FAR_LAT_E7, HOME_LAT_E7, HOME_LON_E7 = 129_702_000, 129_602_000, 776_690_000


def test_a_reposition_outside_the_fence_fails_and_leaves_the_vehicle_in_guided_stopped(bench: Bench) -> None:
    # Rover's handle_command_int_do_reposition: GUIDED entered first, then the place refused
    # by the fence: FAILED, in GUIDED with no target
    fenced(bench)
    repo = mav.MAV_CMD_DO_REPOSITION
    assert bench.command_int(repo, RELATIVE_INT, FAR_LAT_E7, HOME_LON_E7, 0.0, -1, 1) == mav.MAV_RESULT_FAILED
    assert bench.ep.mode == MODES["GUIDED"] and bench.ep.guided is None
    assert bench.command_int(repo, RELATIVE_INT, HOME_LAT_E7, HOME_LON_E7, 0.0, -1, 1) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.guided is not None and bench.ep.guided.kind == "location"


def test_a_guided_go_here_item_outside_the_fence_is_an_error(bench: Bench) -> None:
    # MISSION_ITEM_INT with current 2 in GUIDED: a place outside the fence is refused
    # (MAV_MISSION_ERROR) and no target is taken; inside it is ACCEPTED
    fenced(bench)
    custom = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert bench.command_long(mav.MAV_CMD_DO_SET_MODE, custom, MODES["GUIDED"]) == mav.MAV_RESULT_ACCEPTED

    def go_here(lat_e7: int) -> int:
        item = mav.MAVLink_mission_item_int_message(
            1, 1, 0, RELATIVE_INT, mav.MAV_CMD_NAV_WAYPOINT, 2, 1, 0, 0, 0, 0, lat_e7, HOME_LON_E7, 0, 0
        )
        (ack,) = bench.answers(item, "MISSION_ACK")
        return int(ack.type)

    assert go_here(FAR_LAT_E7) == mav.MAV_MISSION_ERROR and bench.ep.guided is None
    assert go_here(HOME_LAT_E7) == mav.MAV_MISSION_ACCEPTED and bench.ep.guided is not None


# --- DO_CHANGE_SPEED: lfctl's 100 m/s bound --------------------------------------------------


def test_a_speed_of_100_mps_is_taken_and_a_hair_more_is_denied(bench: Bench) -> None:
    # the endpoint's own bound (Rover has none): at most 100 m/s; 100.5 m/s (exact in float32)
    # is DENIED, 100 m/s is taken by AUTO (a mode that takes a speed)
    square_mission(bench)
    assert bench.command_long(mav.MAV_CMD_MISSION_START) == mav.MAV_RESULT_ACCEPTED
    speed = mav.MAV_CMD_DO_CHANGE_SPEED
    assert bench.command_long(speed, mav.SPEED_TYPE_GROUNDSPEED, 100.5) == mav.MAV_RESULT_DENIED
    assert bench.command_long(speed, mav.SPEED_TYPE_GROUNDSPEED, 100.0) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.desired_speed_mps == 100.0


# --- a mode change is told at once; answers queued together all go out ----------------------


def test_a_mode_change_sends_a_heartbeat_at_once(bench: Bench) -> None:
    # Rover::set_mode ends with gcs().send_message(MSG_HEARTBEAT): the new mode goes out in the
    # tick that takes the command, not at the next 1 Hz beat (the last one went out 0.02 s ago)
    assert [m for m in bench.tick() if m.get_type() == "HEARTBEAT"]  # t = 0.02 s: the first beat
    custom = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    bench.send(
        mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_DO_SET_MODE, 0, custom, MODES["MANUAL"], 0, 0, 0, 0, 0)
    )
    beats = [m.custom_mode for m in bench.tick() if m.get_type() == "HEARTBEAT"]  # t = 0.04 s
    assert beats == [MODES["MANUAL"]]


def test_home_asked_for_in_the_tick_of_another_request_keeps_both_answers(bench: Bench) -> None:
    # MAV_CMD_REQUEST_MESSAGE for AUTOPILOT_VERSION (148) and MAV_CMD_GET_HOME_POSITION in one
    # tick: each is answered (AUTOPILOT_VERSION, then HOME_POSITION and GPS_GLOBAL_ORIGIN)
    request = mav.MAV_CMD_REQUEST_MESSAGE
    bench.send(mav.MAVLink_command_long_message(1, 1, request, 0, 148, 0, 0, 0, 0, 0, 0))
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_GET_HOME_POSITION, 0, 0, 0, 0, 0, 0, 0, 0))
    kinds = [m.get_type() for m in bench.tick() + bench.tick()]
    assert kinds.count("AUTOPILOT_VERSION") == 1
    assert kinds.count("HOME_POSITION") >= 1 and kinds.count("GPS_GLOBAL_ORIGIN") >= 1


def test_capabilities_asked_with_param1_other_than_1_fail(bench: Bench) -> None:
    # Rover (GCS_Common): MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES only for param1 == 1, else FAILED
    cmd = mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES
    assert bench.command_long(cmd, 0) == mav.MAV_RESULT_FAILED
    assert bench.command_long(cmd, 2) == mav.MAV_RESULT_FAILED
    assert bench.command_long(cmd, 1) == mav.MAV_RESULT_ACCEPTED


def test_disarming_outside_auto_resets_a_mission_of_one_waypoint_too(bench: Bench) -> None:
    # AP_Arming_Rover::disarm: outside AUTO, mode_auto.mission.reset() for any mission; home
    # and 1 waypoint is a mission (2 commands): after the disarm no item is under way (seq 0)
    # and the mission starts again (mission_restarts one more)
    square_mission(bench, n=1)
    bench.ep.set_armed(True)
    restarts = bench.ep.mission_restarts
    bench.ep.set_armed(False)
    assert bench.ep.mission_restarts == restarts + 1 and bench.ep.current_seq == 0


# --- bounds of a command's whole-number parameter --------------------------------------------


def test_jump_tag_65535_is_a_tag_and_65536_is_not(bench: Bench) -> None:
    # MAV_CMD_DO_JUMP_TAG: a tag is a uint16, 0 .. 65535 (Rover: above UINT16_MAX DENIED); 65535
    # is a tag this mission lacks: FAILED; 65536 is no tag at all: DENIED
    square_mission(bench)
    assert bench.command_long(mav.MAV_CMD_DO_JUMP_TAG, 0) == mav.MAV_RESULT_FAILED  # 0 is a tag too
    assert bench.command_long(mav.MAV_CMD_DO_JUMP_TAG, 65535) == mav.MAV_RESULT_FAILED
    assert bench.command_long(mav.MAV_CMD_DO_JUMP_TAG, 65535, NAN) == mav.MAV_RESULT_FAILED  # param2 is not read
    assert bench.command_long(mav.MAV_CMD_DO_JUMP_TAG, 65536) == mav.MAV_RESULT_DENIED


def test_fence_enable_takes_a_uint16_action(bench: Bench) -> None:
    # MAV_CMD_DO_FENCE_ENABLE's action is read as a uint16 (the endpoint's bound: 0 .. 65535):
    # 65535 is an action lfctl has not (above 2): FAILED; 65536 is not a uint16: DENIED
    fence = mav.MAV_CMD_DO_FENCE_ENABLE
    assert bench.command_long(fence, 65535) == mav.MAV_RESULT_FAILED
    assert bench.command_long(fence, 65536) == mav.MAV_RESULT_DENIED


# --- the fence's pre-arm check: AC_Fence::pre_arm_check_polygon --------------------------------


@pytest.mark.parametrize(
    ("fence_type", "radius", "fails"),
    [
        (4, 2.0, False),  # FENCE_TYPE 4: the polygon fences (inclusion circles too)
        (4, 1.5, True),
        (2, 1.5, False),  # FENCE_TYPE 2, the home circle alone: the polygon check is not run
    ],
)
def test_an_inclusion_circle_as_wide_as_the_margin_passes_the_pre_arm_check(
    bench: Bench, fence_type: int, radius: float, fails: bool
) -> None:
    # AC_Fence::pre_arm_check_polygon: nothing to check without the POLYGON bit, else
    # AC_PolyFence_loader::check_inclusion_circle_margin fails for circle.radius < margin:
    # FENCE_MARGIN 2 m, a circle of 2 m passes and one of 1.5 m fails
    bench.ep.params["FENCE_MARGIN"].value = 2.0
    bench.ep.params["FENCE_TYPE"].value = fence_type
    bench.ep.params["FENCE_ENABLE"].value = 1
    circle = MissionItem(0, RELATIVE_INT, mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, radius, x=LAT_E7, y=776_690_000)
    bench.ep.missions.store(mav.MAV_MISSION_TYPE_FENCE, [circle])
    bench.tick()  # (the fences turn on as AC_Fence::update sees FENCE_ENABLE change)
    failure = "Polygon fence margin is less than inclusion circle radius"
    assert (failure in bench.ep.prearm_failures()) is fails


def test_a_negative_interval_other_than_minus_1_is_denied(bench: Bench) -> None:
    # GCS_MAVLINK::set_message_interval: -1 stops the message; any other interval_us < 0 is DENIED
    set_interval = mav.MAV_CMD_SET_MESSAGE_INTERVAL
    assert bench.command_long(set_interval, VFR_HUD_ID, -2) == mav.MAV_RESULT_DENIED
    assert interval_of(bench, VFR_HUD_ID) == 1_000_000


def test_an_interval_is_kept_in_whole_milliseconds_as_on_rover(bench: Bench) -> None:
    # GCS_MAVLINK::set_message_interval: interval_ms = interval_us / 1000 (integer division):
    # 250 500 us is 250 ms; handle_command_get_message_interval tells interval_ms * 1000 = 250 000 us
    assert bench.command_long(mav.MAV_CMD_SET_MESSAGE_INTERVAL, VFR_HUD_ID, 250_500) == mav.MAV_RESULT_ACCEPTED
    assert interval_of(bench, VFR_HUD_ID) == 250_000


def test_an_interval_of_minus_1_and_a_half_is_minus_1_as_on_rover(bench: Bench) -> None:
    # handle_command_set_message_interval: set_message_interval(..., (int32_t)packet.param2);
    # (int32_t)-1.5f truncates toward zero: -1, "stop sending", ACCEPTED; told back as -1
    assert bench.command_long(mav.MAV_CMD_SET_MESSAGE_INTERVAL, VFR_HUD_ID, -1.5) == mav.MAV_RESULT_ACCEPTED
    assert interval_of(bench, VFR_HUD_ID) == -1


def test_a_message_rover_has_no_equipment_for_stays_unsent_at_its_default(bench: Bench) -> None:
    # the endpoint's NOT_FITTED messages (BATTERY_STATUS, 147): ACCEPTED and never sent; its
    # default rate (interval 0) is "not sent", told back as -1
    battery = mav.MAVLINK_MSG_ID_BATTERY_STATUS
    assert bench.command_long(mav.MAV_CMD_SET_MESSAGE_INTERVAL, battery, 0) == mav.MAV_RESULT_ACCEPTED
    assert interval_of(bench, battery) == -1


# --- messages aimed at another vehicle: MAVLink_routing::check_and_forward -------------------

OTHER = 7  # another vehicle's system id


#: what a vehicle answers to the messages below, had they been for it
ANSWERS = {"COMMAND_ACK", "MISSION_CURRENT", "MISSION_ITEM", "MISSION_ITEM_INT", "MISSION_COUNT", "MISSION_ACK"}
ANSWERS |= {"MISSION_REQUEST", "MISSION_REQUEST_INT"}


@pytest.mark.parametrize(
    "msg",
    [
        mav.MAVLink_command_int_message(OTHER, 1, 0, mav.MAV_CMD_DO_SET_MODE, 0, 0, 1, MODES["MANUAL"], 0, 0, 0, 0, 0),
        mav.MAVLink_mission_set_current_message(OTHER, 1, 2),
        mav.MAVLink_mission_request_message(OTHER, 1, 1, 0),
        mav.MAVLink_mission_request_int_message(OTHER, 1, 1, 0),
        mav.MAVLink_mission_request_list_message(OTHER, 1, 0),
        mav.MAVLink_mission_clear_all_message(OTHER, 1, 0),
        mav.MAVLink_mission_count_message(OTHER, 1, 2, 0),
    ],
    ids=["COMMAND_INT", "SET_CURRENT", "REQUEST", "REQUEST_INT", "REQUEST_LIST", "CLEAR_ALL", "COUNT"],
)
def test_a_message_for_another_vehicle_is_not_answered(bench: Bench, msg: Any) -> None:
    # target_system 7 is not this vehicle (1): no answer and nothing changes
    square_mission(bench)
    bench.tick()  # the first tick's streams (MISSION_CURRENT among them) out of the way
    bench.send(msg)
    assert not ANSWERS & {m.get_type() for m in bench.tick()}
    assert bench.ep.mode == MODES["HOLD"] and bench.ep.current_seq == 0 and len(bench.ep.mission) == 4


def test_the_same_item_requests_for_this_vehicle_are_answered(bench: Bench) -> None:
    # the control for the test above: to system 1, MISSION_REQUEST gets the float item and
    # MISSION_REQUEST_INT the int one (item 1: 12.9602 N = 129 602 100 degE7, home + 100)
    square_mission(bench)
    (item,) = bench.answers(mav.MAVLink_mission_request_int_message(1, 1, 1, 0), "MISSION_ITEM_INT")
    assert (item.seq, item.x) == (1, LAT_E7 + 100)
    (item,) = bench.answers(mav.MAVLink_mission_request_message(1, 1, 1, 0), "MISSION_ITEM")
    assert item.seq == 1 and item.x == pytest.approx(12.96021, abs=1e-5)


# --- SET_MODE's answer, and the modes lfctl refuses -----------------------------------------


def test_set_modes_ack_is_rovers_command_ack_11_to_the_sender(bench: Bench) -> None:
    # GCS_MAVLINK::handle_set_mode: mavlink_msg_command_ack_send(chan, MAVLINK_MSG_ID_SET_MODE,
    # result, 0, 0, msg.sysid, msg.compid): progress 0, result_param2 0, to (255, 190)
    custom = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    (ack,) = bench.answers(mav.MAVLink_set_mode_message(1, custom, MODES["MANUAL"]), "COMMAND_ACK")
    assert (ack.command, ack.result, ack.progress, ack.result_param2) == (11, mav.MAV_RESULT_ACCEPTED, 0, 0)
    assert (ack.target_system, ack.target_component) == (255, 190)


def test_follow_is_refused_with_lfctls_reason_then_rovers_words(bench: Bench) -> None:
    # lfctl follows through GUIDED: FOLLOW is refused with its reason, then Rover's
    # "Flight mode change failed" (both WARNING), and the mode stays HOLD
    custom = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    bench.send(
        mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_DO_SET_MODE, 0, custom, MODES["FOLLOW"], 0, 0, 0, 0, 0)
    )
    out = bench.tick()
    assert [m.result for m in out if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_FAILED]
    assert bench.texts(out) == [
        (mav.MAV_SEVERITY_WARNING, "FOLLOW mode not supported: use GUIDED"),
        (mav.MAV_SEVERITY_WARNING, "Flight mode change failed"),
    ]
    assert bench.ep.mode == MODES["HOLD"]


# --- DO_SET_HOME "here": GCS_MAVLINK::handle_command_do_set_home ------------------------------


def test_set_home_here_ignores_the_place_sent_with_it(bench: Bench) -> None:
    # param1 1: home where the vehicle is (1 m N, 2 m E), whatever x, y say (0.01 degree north)
    home = mav.MAV_CMD_DO_SET_HOME
    assert bench.command_int(home, RELATIVE_INT, FAR_LAT_E7, HOME_LON_E7, 0.0, 1) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.home_ned == (STATE["north_m"], STATE["east_m"]) and bench.ep.home_locked


def test_set_home_at_0_0_is_here(bench: Bench) -> None:
    # handle_command_do_set_home: param1 1, or x and y both 0, is "here": param1 0 at 0, 0 puts
    # home where the vehicle is (1 m N, 2 m E), not at 0 N 0 E
    home = mav.MAV_CMD_DO_SET_HOME
    assert bench.command_int(home, RELATIVE_INT, 0, 0, 0.0, 0) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.home_ned == (STATE["north_m"], STATE["east_m"])


# --- partial updates: MISSION_WRITE_PARTIAL_LIST ---------------------------------------------


def partial_update(bench: Bench, mission_type: int, item: Any) -> int:
    """Item ``item.seq`` of a list uploaded again; the MISSION_ACK's type."""
    bench.send(mav.MAVLink_mission_write_partial_list_message(1, 1, item.seq, item.seq, mission_type))
    bench.tick()
    (ack,) = bench.answers(item, "MISSION_ACK")
    return int(ack.type)


def test_each_partial_update_of_the_mission_counts_as_an_edit(bench: Bench) -> None:
    # mission_edits "bumps when items of the mission are changed in place": each edit a new count
    square_mission(bench)
    edits = bench.ep.mission_edits
    for lat in (LAT_E7 + 300, LAT_E7 + 400):
        wp = mav.MAVLink_mission_item_int_message(
            1, 1, 2, RELATIVE_INT, mav.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, 0, lat, HOME_LON_E7, 0, 0
        )
        assert partial_update(bench, 0, wp) == mav.MAV_MISSION_ACCEPTED
        assert bench.ep.mission_edits > edits
        edits = bench.ep.mission_edits


def test_a_partial_update_of_the_fence_and_of_the_rally_points_is_in_force_at_once(bench: Bench) -> None:
    # a fence circle of 50 m at home made 80 m; a rally point at home moved 0.01 degree north,
    # radians(0.01) * 6 378 137 m = 1113.2 m north of home
    fence, rally = mav.MAV_MISSION_TYPE_FENCE, mav.MAV_MISSION_TYPE_RALLY
    circle = mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION
    bench.ep.missions.store(fence, [MissionItem(0, RELATIVE_INT, circle, 50.0, x=HOME_LAT_E7, y=HOME_LON_E7)])
    point = mav.MAV_CMD_NAV_RALLY_POINT
    bench.ep.missions.store(rally, [MissionItem(0, RELATIVE_INT, point, x=HOME_LAT_E7, y=HOME_LON_E7)])
    wider = mav.MAVLink_mission_item_int_message(
        1, 1, 0, RELATIVE_INT, circle, 0, 1, 80.0, 0, 0, 0, HOME_LAT_E7, HOME_LON_E7, 0, fence
    )
    assert partial_update(bench, fence, wider) == mav.MAV_MISSION_ACCEPTED
    assert [r for *_, r in bench.ep.fence.inclusion_circles] == [80.0]
    moved = mav.MAVLink_mission_item_int_message(
        1, 1, 0, RELATIVE_INT, point, 0, 1, 0, 0, 0, 0, FAR_LAT_E7, HOME_LON_E7, 0, rally
    )
    assert partial_update(bench, rally, moved) == mav.MAV_MISSION_ACCEPTED
    ((north, east),) = bench.ep.rally
    assert north == pytest.approx(math.radians(0.01) * 6378137.0, abs=1.0) and east == pytest.approx(0.0, abs=0.01)
    assert bench.ep.stats.handler_errors == 0


# --- MISSION_ITEM_INT with current 2 (go here) and 3 (change altitude) ------------------------


def guided_item(bench: Bench, command: int, current: int, lat_e7: int, p1: float = 0.0, seq: int = 0) -> int:
    """A MISSION_ITEM_INT outside any upload, ``current`` 2 or 3; the MISSION_ACK's type."""
    item = mav.MAVLink_mission_item_int_message(
        1, 1, seq, RELATIVE_INT, command, current, 1, p1, 0, 0, 0, lat_e7, HOME_LON_E7, 0, 0
    )
    (ack,) = bench.answers(item, "MISSION_ACK")
    return int(ack.type)


def test_a_go_here_off_the_globe_is_refused_and_no_target_taken(bench: Bench) -> None:
    # 91 degrees north (910 000 000 degE7) is no place: refused in GUIDED, no target
    custom = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert bench.command_long(mav.MAV_CMD_DO_SET_MODE, custom, MODES["GUIDED"]) == mav.MAV_RESULT_ACCEPTED
    assert guided_item(bench, mav.MAV_CMD_NAV_WAYPOINT, 2, 910_000_000) != mav.MAV_MISSION_ACCEPTED
    assert bench.ep.guided is None


def test_a_go_here_off_the_globe_is_an_invalid_x_as_on_rover(bench: Bench) -> None:
    # GCS_MAVLINK::handle_mission_item, current 2: mavlink_int_to_mission_cmd first, whose
    # check_lat(910 000 000) fails: MAV_MISSION_INVALID_PARAM5_X, before the guided request
    custom = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert bench.command_long(mav.MAV_CMD_DO_SET_MODE, custom, MODES["GUIDED"]) == mav.MAV_RESULT_ACCEPTED
    assert guided_item(bench, mav.MAV_CMD_NAV_WAYPOINT, 2, 910_000_000) == mav.MAV_MISSION_INVALID_PARAM5_X


def test_a_change_altitude_item_is_not_checked_against_the_mission_as_on_rover(bench: Bench) -> None:
    # GCS_MAVLINK::handle_mission_item, current 3: mavlink_int_to_mission_cmd (which reads a
    # DO_JUMP's target without bounds), then handle_change_alt_request and ACCEPTED; the
    # jump-target check is MissionItemProtocol_Waypoints::append_item's, an upload's only.
    # A DO_JUMP (as item 1) to item 2 of a mission of home and 1 waypoint (2 items): ACCEPTED on Rover
    square_mission(bench, n=1)
    assert guided_item(bench, mav.MAV_CMD_DO_JUMP, 3, 0, p1=2, seq=1) == mav.MAV_MISSION_ACCEPTED


# --- MAV_CMD_REQUEST_MESSAGE: GCS_MAVLINK::handle_command_request_message ---------------------


def test_a_heartbeat_can_be_asked_for_as_message_0(bench: Bench) -> None:
    # (uint32_t)param1 = 0 is HEARTBEAT (MSG_HEARTBEAT): ACCEPTED, and one is sent at once
    bench.tick()  # the first tick's beat out of the way
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, 0, 0, 0, 0, 0, 0, 0))
    out = bench.tick()
    assert [m.result for m in out if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_ACCEPTED]
    assert [m.get_type() for m in out].count("HEARTBEAT") == 1
    # the largest 24-bit id, 16 777 215, has no ap_message: FAILED (as Rover's MSG_LAST)
    assert bench.command_long(mav.MAV_CMD_REQUEST_MESSAGE, 2**24 - 1) == mav.MAV_RESULT_FAILED


def test_asking_for_an_id_past_24_bits_fails_as_on_rover(bench: Bench) -> None:
    # handle_command_request_message: mavlink_id_to_ap_message_id((uint32_t)16 777 216) is
    # MSG_LAST: MAV_RESULT_FAILED
    assert bench.command_long(mav.MAV_CMD_REQUEST_MESSAGE, 2**24) == mav.MAV_RESULT_FAILED


@pytest.mark.parametrize(
    "msg_id",
    [
        mav.MAVLINK_MSG_ID_CAMERA_FEEDBACK,
        mav.MAVLINK_MSG_ID_CAMERA_INFORMATION,
        mav.MAVLINK_MSG_ID_CAMERA_SETTINGS,
        mav.MAVLINK_MSG_ID_CAMERA_CAPTURE_STATUS,
        mav.MAVLINK_MSG_ID_GIMBAL_DEVICE_ATTITUDE_STATUS,
        mav.MAVLINK_MSG_ID_AUTOPILOT_STATE_FOR_GIMBAL_DEVICE,
        mav.MAVLINK_MSG_ID_GIMBAL_MANAGER_INFORMATION,
        mav.MAVLINK_MSG_ID_GIMBAL_MANAGER_STATUS,
    ],
)
def test_a_camera_or_gimbal_message_is_accepted_and_not_sent(bench: Bench, msg_id: int) -> None:
    # mavlink_id_to_ap_message_id maps the camera's (AP_CAMERA_ENABLED) and the mount's
    # (HAL_MOUNT_ENABLED) messages, on in Rover's builds: handle_command_request_message and
    # set_mavlink_message_id_interval ACCEPT them, and with no camera or gimbal set up
    # (CAM1_TYPE, MNT1_TYPE 0) nothing is sent; lfctl answered FAILED and DENIED
    bench.tick()
    bench.send(mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, msg_id, 0, 0, 0, 0, 0, 0))
    out = bench.tick() + bench.tick()
    assert [m.result for m in out if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_ACCEPTED]
    assert not [m for m in out if m.get_msgId() == msg_id]
    assert bench.command_long(mav.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 100_000) == mav.MAV_RESULT_ACCEPTED
    assert not [m for m in bench.tick(0.5) + bench.tick(0.5) if m.get_msgId() == msg_id]
    assert interval_of(bench, msg_id) == 100_000


def test_an_interval_for_an_id_past_24_bits_is_named_as_on_rover(bench: Bench) -> None:
    # GCS_MAVLINK::set_message_interval: no ap_message for (uint32_t)16 777 216: in SITL
    # "No ap_message for mavlink id (16777216)" (INFO), and DENIED
    msg = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 2**24, 100_000, 0, 0, 0, 0, 0)
    bench.send(msg)
    out = bench.tick()
    assert [m.result for m in out if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_DENIED]
    assert (mav.MAV_SEVERITY_INFO, "No ap_message for mavlink id (16777216)") in bench.texts(out)


def test_no_mission_is_a_total_of_0_as_on_rover(bench: Bench) -> None:
    # GCS_MAVLINK::send_mission_current: num_commands = mission.num_commands(), less 1 (home)
    # when above 0: home alone (1 command) is a total of 1 - 1 = 0, never UINT16_MAX
    square_mission(bench, n=0)
    (current,) = [m for m in bench.tick() if m.get_type() == "MISSION_CURRENT"]
    assert (current.total, current.mission_state) == (0, mav.MISSION_STATE_NO_MISSION)


def test_the_in_memory_links_rates_are_the_shared_ones_network_peers_read(bench: Bench) -> None:
    # the endpoint's channels: the in-memory link sets the shared schedule, which a network peer
    # that set nothing of its own reads: VFR_HUD at 500 000 us from memory is 500 000 us for it
    peers = Peers(bench, PEER_A)
    assert bench.command_long(mav.MAV_CMD_SET_MESSAGE_INTERVAL, VFR_HUD_ID, 500_000) == mav.MAV_RESULT_ACCEPTED
    assert peers.interval(PEER_A, VFR_HUD_ID) == 500_000


def test_auto_takes_a_mission_of_home_and_one_waypoint(bench: Bench) -> None:
    # ModeAuto::_enter refuses "No Mission. Can't set AUTO." only when !mission.present(), i.e.
    # num_commands() <= 1; home and 1 waypoint is 2 commands: AUTO is entered
    square_mission(bench, n=1)
    custom = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert bench.command_long(mav.MAV_CMD_DO_SET_MODE, custom, MODES["AUTO"]) == mav.MAV_RESULT_ACCEPTED
    assert bench.ep.mode == MODES["AUTO"]


def test_arming_is_told_in_a_heartbeat_at_once(bench: Bench) -> None:
    # the endpoint's set_armed: "tell the ground stations now": the tick that takes the arm
    # command sends a HEARTBEAT with MAV_MODE_FLAG_SAFETY_ARMED (128) set, not at the next 1 Hz beat
    bench.tick()  # t = 0.02 s: the first beat
    arm = mav.MAV_CMD_COMPONENT_ARM_DISARM
    bench.send(mav.MAVLink_command_long_message(1, 1, arm, 0, 1, 0, 0, 0, 0, 0, 0))
    beats = [m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED for m in bench.tick() if m.get_type() == "HEARTBEAT"]
    assert beats == [mav.MAV_MODE_FLAG_SAFETY_ARMED]


def test_an_uploaded_fence_is_not_present_unless_fence_type_selects_it(bench: Bench) -> None:
    # AC_Fence::present: the polygon fences count only with FENCE_TYPE's POLYGON bit (4); with
    # FENCE_TYPE 0 an uploaded circle is no fence, and DO_FENCE_ENABLE 1 FAILS
    circle = MissionItem(0, RELATIVE_INT, mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, 50.0, x=HOME_LAT_E7, y=HOME_LON_E7)
    bench.ep.missions.store(mav.MAV_MISSION_TYPE_FENCE, [circle])
    bench.ep.params["FENCE_TYPE"].value = 0
    assert bench.command_long(mav.MAV_CMD_DO_FENCE_ENABLE, 1) == mav.MAV_RESULT_FAILED
    bench.ep.params["FENCE_TYPE"].value = 4
    assert bench.command_long(mav.MAV_CMD_DO_FENCE_ENABLE, 1) == mav.MAV_RESULT_ACCEPTED


def test_a_finished_missions_current_item_says_complete(bench: Bench) -> None:
    # GCS_MAVLINK::mission_state: AP_Mission's MISSION_COMPLETE is MISSION_STATE_COMPLETE (4);
    # MISSION_CURRENT streams at 1 Hz: 60 ticks of 0.02 s = 1.2 s hold at least one
    square_mission(bench)
    bench.ep.complete_mission()
    states = [m.mission_state for _ in range(60) for m in bench.tick() if m.get_type() == "MISSION_CURRENT"]
    assert states and set(states) == {mav.MISSION_STATE_COMPLETE}
    assert bench.ep.stats.send_errors == 0


def test_a_data_stream_request_with_start_stop_0_stops_the_group(bench: Bench) -> None:
    # REQUEST_DATA_STREAM start_stop 0 stops the group whatever rate it names: EXTRA2
    # (VFR_HUD's group) at "10 Hz" with start_stop 0: VFR_HUD stopped, told back as -1
    bench.send(mav.MAVLink_request_data_stream_message(1, 1, mav.MAV_DATA_STREAM_EXTRA2, 10, 0))
    bench.tick()
    assert interval_of(bench, VFR_HUD_ID) == -1


def test_mission_start_without_a_mission_fails(bench: Bench) -> None:
    # Rover's MAV_CMD_MISSION_START: rover.set_mode(mode_auto) refused ("No Mission. Can't set
    # AUTO.", no mission present) is MAV_RESULT_FAILED, and the mode stays HOLD
    assert bench.command_long(mav.MAV_CMD_MISSION_START, 0, 0) == mav.MAV_RESULT_FAILED
    assert bench.ep.mode == MODES["HOLD"]


def test_smartrtl_before_any_arming_says_no_path_was_recorded(bench: Bench) -> None:
    # the endpoint's SmartRTL refusal: never armed, no way back was ever begun: "no path
    # recorded" (WARNING), then Rover's "Flight mode change failed"; after an arming whose way
    # was not kept it would say "no path kept" (test_smartrtl.py)
    custom = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    cmd = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_DO_SET_MODE, 0, custom, MODES["SMART_RTL"], 0, 0, 0, 0, 0)
    bench.send(cmd)
    out = bench.tick()
    assert [m.result for m in out if m.get_type() == "COMMAND_ACK"] == [mav.MAV_RESULT_FAILED]
    assert bench.texts(out) == [
        (mav.MAV_SEVERITY_WARNING, "SmartRTL unavailable: no path recorded"),
        (mav.MAV_SEVERITY_WARNING, "Flight mode change failed"),
    ]


# --- a whole mission uploaded over the one in force (MissionItemProtocol: truncate, replace, add) ---


def test_an_upload_keeps_the_item_number_under_way_and_a_finished_state_a_clear_does_not(bench: Bench) -> None:
    # Rover's upload writes over the old items (AP_Mission::truncate, replace_cmd, add_cmd),
    # nothing reset: MISSION_CURRENT's seq stays 2, by the mission protocol (a count of 0
    # too) as by MAVLink FTP; a finished mission stays finished (MISSION_STATE_COMPLETE);
    # MISSION_CLEAR_ALL (not running) clears the item under way (AP_Mission::clear)
    wp, frame = mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    items = [MissionItem(k, frame, wp, x=LAT_E7 + 100 * k, y=776_690_000) for k in range(4)]
    square_mission(bench)
    assert bench.ep.set_current(2)
    assert upload(bench, items) == mav.MAV_MISSION_ACCEPTED
    assert bench.ep.current_seq == 2
    assert upload(bench, []) == mav.MAV_MISSION_ACCEPTED
    assert bench.ep.current_seq == 2 and bench.ep.mission == []
    assert upload(bench, items) == mav.MAV_MISSION_ACCEPTED
    bench.ep.complete_mission()
    assert upload(bench, items[:3]) == mav.MAV_MISSION_ACCEPTED
    assert bench.ep.mission_complete and bench.ep.current_seq == 2
    asked = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, 42, 0, 0, 0, 0, 0, 0)
    (current,) = bench.answers(asked, "MISSION_CURRENT")
    assert (current.seq, current.mission_state) == (2, mav.MISSION_STATE_COMPLETE)
    (ack,) = bench.answers(mav.MAVLink_mission_clear_all_message(1, 1, 0), "MISSION_ACK")
    assert ack.type == mav.MAV_MISSION_ACCEPTED and bench.ep.current_seq == 0
