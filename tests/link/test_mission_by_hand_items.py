"""Mission items by hand, with ArduPilot's semantics: loiters as AP_Mission stores them
(radii in a byte, over 255 m in tens of metres; the direction and cross-track flags), the
upload checks of validate_item, home as item 0, the frames of WPL and .plan files, a plan's
fence, which items are places, and the legs of a mission with a DO_JUMP."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.link.mission import (
    CIRCLE_INCLUSION,
    DO_CHANGE_SPEED,
    DO_JUMP,
    DO_SET_REVERSE,
    NAV_DELAY,
    NAV_LOITER_TIME,
    NAV_LOITER_TURNS,
    NAV_LOITER_UNLIM,
    NAV_RETURN_TO_LAUNCH,
    NAV_WAYPOINT,
    POLYGON_INCLUSION,
    SPEED_MAX_MPS,
    MissionItem,
    as_stored,
    home_item,
    is_nav,
    load_mission_file,
    validate_item,
    walk_mission,
    watched_items,
)

REL = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
HOME = (12.96, 77.67, 900.0)


def place(seq: int, command: int, p1: float = 0.0, p2: float = 0.0, p3: float = 0.0, p4: float = 0.0) -> MissionItem:
    # a place near home (12.9601 N, 77.6701 E, 10 m above home)
    return MissionItem(seq, REL, command, p1, p2, p3, p4, 129601000, 776701000, 10.0)


def do(seq: int, command: int, p1: float = 0.0, p2: float = 0.0) -> MissionItem:
    return MissionItem(seq, mav.MAV_FRAME_MISSION, command, p1, p2)


# --- as_stored: loiters (AP_Mission::mavlink_int_to_mission_cmd and back) ---------------


@pytest.mark.parametrize(
    ("radius", "stored"),
    [
        (255.0, 255.0),  # up to 255 m: the byte holds it in metres
        (256.0, 250.0),  # over: tens of metres, 256 * 0.1 = 25.6 cut to 25: 250 m
        (3000.0, 2550.0),  # 300 tens, held at the byte's 255: 2550 m
        (-2.7, -2.0),  # counter-clockwise: the sign is the direction flag, the radius cut to 2
    ],
)
def test_a_loiter_circles_radius_is_stored_in_a_byte_and_over_255_m_in_tens(radius: float, stored: float) -> None:
    # Wrong, a NAV_LOITER_TURNS of 256 m or more would be stored and driven at the wrong radius
    # (or not refused by a byte that cannot hold it), or in the wrong direction.
    it = as_stored(place(1, NAV_LOITER_TURNS, 2.0, 0.0, radius, 0.0))
    assert it.param3 == stored
    assert it.param1 == 2.0  # two whole turns


def test_a_loiters_cross_track_flag_is_set_only_by_a_positive_param4() -> None:
    # Wrong, a circle or timed loiter asked for no cross-track exit would be given one.
    # By hand: AP_Mission's loiter_xtrack = (param4 > 0): 0 -> 0.0, 0.5 -> 1.0.
    assert as_stored(place(1, NAV_LOITER_TURNS, 1.0, 0.0, 5.0, 0.0)).param4 == 0.0
    assert as_stored(place(1, NAV_LOITER_TURNS, 1.0, 0.0, 5.0, 0.5)).param4 == 1.0
    assert as_stored(place(1, NAV_LOITER_TIME, 10.0, 0.0, 5.0, 0.0)).param4 == 0.0
    assert as_stored(place(1, NAV_LOITER_TIME, 10.0, 0.0, 5.0, 0.5)).param4 == 1.0


def test_a_timed_loiters_wait_is_a_16_bit_whole_number_and_its_direction_plus_or_minus_one() -> None:
    # Wrong, a NAV_LOITER_TIME of over 65535 s would wrap or keep its fraction, or its
    # direction would be lost.
    # By hand: p1 = 70000 -> held at 65535; 2.5 -> 2 (cut); param3 -3 -> -1 (counter-clockwise).
    it = as_stored(place(1, NAV_LOITER_TIME, 70000.0, 0.0, -3.0, 0.0))
    assert (it.param1, it.param2, it.param3, it.param4) == (65535.0, 0.0, -1.0, 0.0)
    assert as_stored(place(1, NAV_LOITER_TIME, 2.5, 0.0, 3.0, 0.0)).param1 == 2.0


def test_an_endless_loiters_radius_is_cut_to_whole_metres_with_its_direction_kept() -> None:
    # Wrong, a loiter for ever of radius 0 would be stored as 1 m, or a counter-clockwise one
    # under 1 m would come back clockwise.
    # By hand: p1 = |param3| in 16 bits, the flag param3 < 0: 0 -> 0.0; 3.6 -> 3.0;
    # -0.5 -> |0| with the flag: -0.0 (as ArduPilot gives it back, -(0.0)).
    assert as_stored(place(1, NAV_LOITER_UNLIM, 0.0, 0.0, 0.0, 0.0)).param3 == 0.0
    assert as_stored(place(1, NAV_LOITER_UNLIM, 0.0, 0.0, 3.6, 0.0)).param3 == 3.0
    ccw = as_stored(place(1, NAV_LOITER_UNLIM, 0.0, 0.0, -0.5, 0.0)).param3
    assert ccw == 0.0 and math.copysign(1.0, ccw) == -1.0


# --- validate_item ----------------------------------------------------------------------


def test_a_jump_back_to_item_one_is_accepted_and_a_jump_to_home_is_not() -> None:
    # Wrong, the most common loop (a DO_JUMP back to the first waypoint) would be refused.
    # By hand: 1 <= 1 < 3: accepted; 0 (home) is not a target: MAV_MISSION_ERROR.
    assert validate_item(do(2, DO_JUMP, 1.0, 2.0), 3) == mav.MAV_MISSION_ACCEPTED
    assert validate_item(do(2, DO_JUMP, 0.0, 2.0), 3) == mav.MAV_MISSION_ERROR


def test_only_a_speed_change_is_refused_for_a_param2_over_the_speed_limit() -> None:
    # Wrong, a 101 m/s DO_CHANGE_SPEED would be taken, or a waypoint with any param2 over
    # 100 (its acceptance radius, unused by Rover) refused.
    assert validate_item(do(1, DO_CHANGE_SPEED, 1.0, SPEED_MAX_MPS + 1.0), 2) == mav.MAV_MISSION_INVALID_PARAM2
    assert validate_item(do(1, DO_CHANGE_SPEED, 1.0, SPEED_MAX_MPS), 2) == mav.MAV_MISSION_ACCEPTED
    assert validate_item(place(1, NAV_WAYPOINT, 0.0, 1000.0), 2) == mav.MAV_MISSION_ACCEPTED


def test_a_delay_until_a_time_of_day_takes_whole_minutes_up_to_59() -> None:
    # Wrong, a NAV_DELAY to minute 60 or 30.5 would be stored and wait for a time that is not.
    # By hand: param1 -1 (a time of day), hour 12: minute 59 and -1 (any) accepted; 60, -2
    # and 30.5 refused as param3.
    def delay(minute: float) -> MissionItem:
        return MissionItem(1, mav.MAV_FRAME_MISSION, NAV_DELAY, -1.0, 12.0, minute, 0.0)

    assert validate_item(delay(59.0), 2) == mav.MAV_MISSION_ACCEPTED
    assert validate_item(delay(-1.0), 2) == mav.MAV_MISSION_ACCEPTED
    for bad in (60.0, -2.0, 30.5):
        assert validate_item(delay(bad), 2) == mav.MAV_MISSION_INVALID_PARAM3, bad


def test_a_place_at_the_poles_and_the_antimeridian_is_accepted_and_one_past_them_is_not() -> None:
    # Wrong, a place at exactly 90 deg or -180 deg would be refused, or one past them taken.
    # By hand: degE7: 900000000 is 90 deg (in), 900000001 is past it; -1800000000 is -180 (in).
    def at(x: int, y: int) -> MissionItem:
        return MissionItem(1, REL, NAV_WAYPOINT, x=x, y=y, z=10.0)

    assert validate_item(at(900000000, -1800000000), 2) == mav.MAV_MISSION_ACCEPTED
    assert validate_item(at(-900000000, 1800000000), 2) == mav.MAV_MISSION_ACCEPTED
    assert validate_item(at(900000001, 0), 2) == mav.MAV_MISSION_INVALID_PARAM5_X
    assert validate_item(at(0, -1800000001), 2) == mav.MAV_MISSION_INVALID_PARAM6_Y


# --- home_item, is_nav --------------------------------------------------------------------


def test_home_is_item_0_a_waypoint_in_degrees_e7() -> None:
    # Wrong, home would be off by 1e-7 of its value (1.3 m north, 8.6 m east here) or at
    # longitude 0.
    # By hand: 12.96 * 1e7 = 129600000, 77.67 * 1e7 = 776700000, 900 m.
    h = home_item(*HOME)
    assert (h.seq, h.frame, h.command) == (0, mav.MAV_FRAME_GLOBAL_INT, NAV_WAYPOINT)
    assert (h.x, h.y, h.z) == (129600000, 776700000, 900.0)


def test_a_waypoint_is_a_place_and_a_speed_change_is_not() -> None:
    # Wrong, the mission summary would count DO commands as waypoints and waypoints as none.
    assert is_nav(place(1, NAV_WAYPOINT)) is True
    assert is_nav(do(1, DO_CHANGE_SPEED, 1.0, 0.5)) is False


# --- file loading -------------------------------------------------------------------------


def test_a_waypoint_files_frame_column_is_read_and_its_float_frames_taken_as_int_ones() -> None:
    # Wrong, a planned mission's altitude frame would be misread (the frame taken from the
    # command column, or left a frame the int items do not use).
    # By hand: WPL columns are seq, current, frame, command, p1-p4, lat, lon, alt, autocontinue;
    # frame 3 (GLOBAL_RELATIVE_ALT) -> 6 (its _INT), frame 0 (GLOBAL) -> 5 (GLOBAL_INT).
    rows = [
        ["0", "1", "0", "16", "0", "0", "0", "0", "12.96", "77.67", "900", "1"],
        ["1", "0", "3", "16", "0", "0", "0", "0", "12.9601", "77.6701", "10", "1"],
    ]
    text = "QGC WPL 110\n" + "".join("\t".join(row) + "\n" for row in rows)
    home, wp = load_mission_file("m.waypoints", text).mission
    assert (home.frame, home.command) == (mav.MAV_FRAME_GLOBAL_INT, NAV_WAYPOINT)
    assert (wp.frame, wp.command) == (mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, NAV_WAYPOINT)
    assert (wp.x, wp.y, wp.z) == (129601000, 776701000, 10.0)


@pytest.mark.parametrize("name", ["m.waypoints", "m.plan"])
def test_a_mission_file_opening_with_a_byte_order_mark_reads_as_without(name: str) -> None:
    # Windows editors save UTF-8 with a BOM (U+FEFF) in front; it is no part of either format
    row = ["0", "1", "0", "16", "0", "0", "0", "0", "12.96", "77.67", "900", "1"]
    text = "QGC WPL 110\n" + "\t".join(row) + "\n" if name.endswith(".waypoints") else plan([])
    assert load_mission_file(name, "\ufeff" + text) == load_mission_file(name, text)


def plan(items: list[dict], fence: dict | None = None) -> str:
    import json

    doc: dict = {"fileType": "Plan", "version": 1, "mission": {"plannedHomePosition": list(HOME), "items": items}}
    if fence is not None:
        doc["geoFence"] = fence
    return json.dumps(doc)


def test_a_plans_frame_3_item_loads_relative_to_home() -> None:
    # Wrong, a QGroundControl waypoint above home would be taken in the float frame 3.
    item = {"type": "SimpleItem", "command": 16, "frame": 3, "params": [0, 0, 0, 0, 12.9601, 77.6701, 10]}
    _home, wp = load_mission_file("m.plan", plan([item])).mission
    assert (wp.frame, wp.command, wp.x, wp.y, wp.z) == (REL, NAV_WAYPOINT, 129601000, 776701000, 10.0)


def test_a_plans_inclusion_polygon_and_a_half_metre_circle_are_keep_in_fence_items() -> None:
    # Wrong, a keep-in fence would be uploaded as a keep-out one, its vertex count or
    # params wrong, or a 0.5 m circle refused.
    # By hand: 3 vertices: 3 POLYGON_VERTEX_INCLUSION items, param1 3 (the count), params
    # 2-4 0; then the circle, param1 its radius 0.5.
    triangle = [[12.96, 77.67], [12.961, 77.67], [12.96, 77.671]]
    fence = {
        "version": 2,
        "polygons": [{"inclusion": True, "polygon": triangle}],
        "circles": [{"inclusion": True, "circle": {"center": [12.96, 77.67], "radius": 0.5}}],
    }
    got = load_mission_file("m.plan", plan([], fence)).fence
    assert [it.command for it in got] == [POLYGON_INCLUSION] * 3 + [CIRCLE_INCLUSION]
    for it in got[:3]:
        assert (it.param1, it.param2, it.param3, it.param4) == (3.0, 0.0, 0.0, 0.0)
    assert [(it.x, it.y) for it in got[:3]] == [(129600000, 776700000), (129610000, 776700000), (129600000, 776710000)]
    assert (got[3].param1, got[3].x, got[3].y) == (0.5, 129600000, 776700000)


# --- walk_mission ---------------------------------------------------------------------------


def test_a_jump_back_repeated_once_drives_the_loop_twice_then_goes_on() -> None:
    # Wrong, a mission's loop would be driven the wrong number of times (or for ever), and a
    # resumed mission would count its jumps from the wrong place.
    # By hand: home, WP1, WP2, DO_JUMP(to 1, once), WP3: WP1, WP2, (jump) WP1, WP2, (the jump
    # spent) WP3. The times it has been taken: none before it is met, 1 after.
    home = home_item(*HOME)
    wp1, wp2 = place(1, NAV_WAYPOINT), MissionItem(2, REL, NAV_WAYPOINT, x=129602000, y=776701000, z=10.0)
    wp3 = MissionItem(4, REL, NAV_WAYPOINT, x=129602000, y=776702000, z=10.0)
    legs, tail = walk_mission([home, wp1, wp2, do(3, DO_JUMP, 1.0, 1.0), wp3], HOME)
    assert [leg.seq for leg in legs] == [1, 2, 1, 2, 4] and tail == ()
    assert [leg.jumps for leg in legs] == [(), (), ((3, 1),), ((3, 1),), ((3, 1),)]
    assert legs[2].jumped == ((3, 1, 1),)
    assert (legs[2].north_m, legs[2].east_m) == (legs[0].north_m, legs[0].east_m)
    # repeated 0 times: straight through
    legs, _ = walk_mission([home, wp1, wp2, do(3, DO_JUMP, 1.0, 0.0), wp3], HOME)
    assert [leg.seq for leg in legs] == [1, 2, 4]


def test_a_jump_taken_after_a_do_command_is_said_after_it() -> None:
    # Wrong, the "Mission: 3 Jump 1/1" text would be put before the speed change met first.
    # By hand: WP1, DO_CHANGE_SPEED (met: 0 jumps taken so far), DO_JUMP forward to 5 (once),
    # WP (skipped), WP2: WP2's leg has the speed change, the jump taken, and jumps_first 0.
    home = home_item(*HOME)
    speed = do(2, DO_CHANGE_SPEED, 1.0, 0.5)
    items = [home, place(1, NAV_WAYPOINT), speed, do(3, DO_JUMP, 5.0, 1.0), place(4, NAV_WAYPOINT)]
    items.append(place(5, NAV_WAYPOINT))
    legs, _ = walk_mission(items, HOME)
    assert [leg.seq for leg in legs] == [1, 5]
    assert legs[1].before == (speed,) and legs[1].jumped == ((3, 1, 1),) and legs[1].jumps_first == 0


def test_a_skipped_take_off_ends_the_run_of_do_commands_begun_before_it() -> None:
    # Wrong, a Rover's DO commands after a skipped take-off would be run with the leg (they
    # wait for the next), or the walk would fail on the take-off.
    # By hand (AP_Mission::get_next_do_cmd): DO_CHANGE_SPEED found, then NAV_TAKEOFF (tried and
    # skipped) stops the search: DO_SET_REVERSE is not in WP2's leg.
    home = home_item(*HOME)
    speed, takeoff = do(2, DO_CHANGE_SPEED, 1.0, 0.5), place(3, mav.MAV_CMD_NAV_TAKEOFF)
    items = [home, place(1, NAV_WAYPOINT), speed, takeoff, do(4, DO_SET_REVERSE, 1.0), place(5, NAV_WAYPOINT)]
    legs, _ = walk_mission(items, HOME)
    assert [leg.seq for leg in legs] == [1, 5]
    assert legs[1].before == (speed, takeoff)


def test_the_waits_and_an_rtl_without_a_return_point() -> None:
    # Wrong, a waypoint's 40000 s wait (over Rover's signed 16 bits) would wait, half a second
    # of NAV_DELAY would be dropped, or RTL with no rally point would not go home.
    # By hand: whole seconds under 32768: 2.5 -> 2.0; 40000 -> 0.0; NAV_DELAY 0.5 s -> 0.5;
    # RTL -> the local origin (0, 0).
    home = home_item(*HOME)
    delay = MissionItem(3, mav.MAV_FRAME_MISSION, NAV_DELAY, 0.5, -1.0, -1.0, -1.0)
    items = [home, place(1, NAV_WAYPOINT, 2.5), place(2, NAV_WAYPOINT, 40000.0), delay]
    items.append(MissionItem(4, mav.MAV_FRAME_MISSION, NAV_RETURN_TO_LAUNCH))
    legs, _ = walk_mission(items, HOME)
    assert [leg.hold_s for leg in legs] == [2.0, 0.0, 0.5, 0.0]
    assert (legs[3].north_m, legs[3].east_m) == (0.0, 0.0)
    assert (legs[2].north_m, legs[2].east_m) == (legs[1].north_m, legs[1].east_m)  # the delay waits where it is


@pytest.mark.parametrize("command", [NAV_LOITER_UNLIM, NAV_LOITER_TURNS])
def test_a_loiter_radius_of_minus_zero_is_clockwise_as_ardupilot_reads_it(command: int) -> None:
    # AP_Mission sets the counter-clockwise flag from param3 < 0, which -0.0 is not: a
    # downloaded counter-clockwise loiter under 1 m (given back as -0) uploaded again is
    # clockwise on a Rover. lfctl kept -0 as counter-clockwise.
    turns = 1.0 if command == NAV_LOITER_TURNS else 0.0
    cw = as_stored(place(1, command, turns, 0.0, -0.0, 0.0)).param3
    assert cw == 0.0 and math.copysign(1.0, cw) == 1.0
    ccw = as_stored(place(1, command, turns, 0.0, -0.5, 0.0)).param3
    assert ccw == 0.0 and math.copysign(1.0, ccw) == -1.0


# --- watched_items: what AP_Mission_ChangeDetector compares ------------------------------


def test_the_watched_items_follow_a_jump_with_repeats_left_each_time_and_are_compared_as_stored() -> None:
    # Wrong, a Rover would restart the waypoint under way on edits it does not see, or miss
    # ones it does. By hand (get_next_nav_cmd from item 1, three times): WP1; from 2 the jump
    # (taken 0 of 1) back to WP1; from 2 again WP1: items 1, 1, 1. With the jump taken once:
    # WP1, then past the spent jump WP3, then none (2 items).
    home = home_item(*HOME)
    wp1, wp3 = place(1, NAV_WAYPOINT), place(3, NAV_WAYPOINT)
    items = [home, wp1, do(2, DO_JUMP, 1.0, 1.0), wp3]
    assert [w[0] for w in watched_items(items, 1)] == [1, 1, 1]
    assert [w[0] for w in watched_items(items, 1, ((2, 1),))] == [1, 3]
    # a jump for ever to itself ends the search (met twice): nothing after it
    assert [w[0] for w in watched_items([home, wp1, do(2, DO_JUMP, 2.0, -1.0), wp3], 1)] == [1]
    # as stored: GLOBAL_RELATIVE_ALT and its _INT form alike; 10.004 m is 1000 cm as 10 m is;
    # 10.01 m is not; GLOBAL is another reference
    one = watched_items([home, wp1], 1)
    assert watched_items([home, replace(wp1, frame=mav.MAV_FRAME_GLOBAL_RELATIVE_ALT)], 1) == one
    assert watched_items([home, replace(wp1, z=10.004)], 1) == one
    assert watched_items([home, replace(wp1, z=10.01)], 1) != one
    assert watched_items([home, replace(wp1, frame=mav.MAV_FRAME_GLOBAL_INT)], 1) != one
    # DO commands are not watched: a speed change between the waypoints changes nothing
    assert watched_items([home, wp1, do(2, DO_CHANGE_SPEED, 1.0, 0.5), wp3], 1) == watched_items(
        [home, wp1, do(2, DO_CHANGE_SPEED, 1.0, 0.9), wp3], 1
    )
