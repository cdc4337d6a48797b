"""Each vehicle's autopilot (lfctl/sim/driver.py) worked by hand, step by step, against
ArduPilot Rover's source: an endpoint in memory, the vehicle put where each step needs it
(no FMU, no closed loop), and the driver's commands, words and NAV_CONTROLLER_OUTPUT read
after each step. What the closed-loop tests (test_rover_modes.py, test_mission_items.py)
leave unpinned, found by a mutation audit of driver.py: CONDITION_DISTANCE, GUIDED heading
and rate targets, RTL beside SmartRTL's way back, a disarmed vehicle, MANUAL at zero
throttle, circles (their centre, speed, warnings), edits in place, the recorder's reached
events. Where lfctl differs from Rover the test says what Rover does and is an xfail
naming the Rover source."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav
from support import LEADER_AND_FOLLOWER

from lfctl.config import parse_config
from lfctl.link.endpoint import MODES, WP_SPEED_MIN_MPS, VehicleEndpoint
from lfctl.link.guided import GuidedTarget, global_to_local
from lfctl.link.mission import MissionItem, local_mission
from lfctl.link.mission_server import MISSION
from lfctl.link.transport import MemoryLink
from lfctl.sim.driver import VehicleDriver, autopilot_settings, condition_delay_s, speed_max
from lfctl.sim.world import WorldState

HOME = (12.9602, 77.6690, 900.0)
STEP_S = 0.1  # the guidance period the driver is built with
SCENARIO = (
    """
name = "by-hand"
"""
    + LEADER_AND_FOLLOWER
    + """
[mission]
waypoints = [[6.0, 0.0]]
cruise_speed_mps = 0.4
[guidance]
max_speed_mps = 0.5
"""
)


GCS = mav.MAVLink(None, srcSystem=255, srcComponent=190)
STILL = {"north_m": 0.0, "east_m": 0.0, "yaw_rad": 0.0, "speed_mps": 0.0, "yaw_rate_radps": 0.0}


def bench_and_gcs(
    mode: str, armed: bool = True, scripted: bool = False, scenario: str = SCENARIO
) -> tuple[VehicleDriver, VehicleEndpoint, MemoryLink]:
    """A vehicle's driver, its endpoint (in ``mode``) and a ground station's end of its
    link; nothing else running."""
    cfg = parse_config(scenario, "by-hand")
    link, gcs = MemoryLink.pair("ep", "gcs")
    ep = VehicleEndpoint("leader", 1, link, HOME, mode=mode, armed=armed)
    return VehicleDriver(cfg, ep, 0, HOME, STEP_S, scripted=scripted), ep, gcs


def bench(
    mode: str, armed: bool = True, scripted: bool = False, scenario: str = SCENARIO
) -> tuple[VehicleDriver, VehicleEndpoint]:
    """A vehicle's driver and its endpoint (in ``mode``), nothing else running."""
    drv, ep, _gcs = bench_and_gcs(mode, armed, scripted, scenario)
    return drv, ep


def send(ep: VehicleEndpoint, gcs: MemoryLink, *msgs: object) -> None:
    """A ground station's messages, handled at the endpoint's next tick (20 ms on)."""
    for m in msgs:
        gcs.send(m.pack(GCS))  # type: ignore[attr-defined]
    ep.tick(ep.t_s + 0.02, STILL)


def rewrite(ep: VehicleEndpoint, gcs: MemoryLink, it: MissionItem) -> None:
    """MAVProxy's edit of one item in place: MISSION_WRITE_PARTIAL_LIST, then the item."""
    send(ep, gcs, mav.MAVLink_mission_write_partial_list_message(1, 1, it.seq, it.seq, 0))
    send(ep, gcs, mav.MAVLink_mission_item_int_message(
        1, 1, it.seq, it.frame, it.command, 0, 1, it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, 0,
    ))  # fmt: skip
    kept = ep.mission[it.seq]  # (as AP_Mission stores it)
    assert (kept.command, kept.param1, kept.x, kept.y) == (it.command, it.param1, it.x, it.y) and ep.mission_edits > 0


def at(north_m: float, east_m: float, yaw_rad: float = 0.0, t_s: float = 0.0) -> WorldState:
    """The world with the vehicle (alone) at (north, east), heading ``yaw_rad``, stopped."""
    return WorldState(t_s, ("leader",), np.array([[north_m, east_m]]), np.array([yaw_rad]), np.zeros(1), np.zeros(1))


def item(command: int, p1: float = 0.0, p2: float = 0.0) -> MissionItem:
    return MissionItem(0, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command, p1, p2)


def store(ep: VehicleEndpoint, *parts: MissionItem | tuple[float, float]) -> None:
    """Make the items the vehicle's mission (a place (north, east) is a waypoint there), as
    a ground station's upload stores it."""
    items = local_mission([], HOME)
    for part in parts:
        it = local_mission([part], HOME)[1] if isinstance(part, tuple) else part
        items.append(dataclasses.replace(it, seq=len(items)))
    ep.missions.store(MISSION, items, 255, 190, uploaded=True)


def circle_at(north_m: float, east_m: float, radius_m: float = 2.0, turns: float = 1.0) -> MissionItem:
    """A NAV_LOITER_TURNS round (north, east)."""
    centre = local_mission([(north_m, east_m)], HOME)[1]
    return MissionItem(0, centre.frame, mav.MAV_CMD_NAV_LOITER_TURNS, turns, 0.0, radius_m, x=centre.x, y=centre.y)


def said(ep: VehicleEndpoint) -> list[str]:
    return [text for _t, text in ep.statustexts]


# -- CONDITION_DISTANCE --------------------------------------------------------------------------


def test_a_condition_distance_holds_the_do_commands_after_it_until_that_near_the_next_waypoint() -> None:
    # Rover's ModeAuto::do_within_distance keeps param1 in its int32 condition_value (4.9 m:
    # 4 m); verify_within_distance lets the items after it go once get_distance_to_destination()
    # < 4 (4 itself holds), the distance to the navigation item it comes before (6 m north). The
    # DO_CHANGE_SPEED behind it waits till then; the driving does not.
    drv, ep = bench("AUTO")
    store(ep, item(mav.MAV_CMD_CONDITION_DISTANCE, 4.9), item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3), (6.0, 0.0))
    t = 0.0
    wp_north, wp_east = global_to_local(ep.mission[3].x, ep.mission[3].y, HOME)  # (6, 0) as stored
    for north in (0.0, 0.5, 1.0, 1.5, 1.9, wp_north - 4.0):  # 6 to 4.1 m to go, then 4: held
        t += STEP_S
        speed, _rate = drv.update(t, at(north, wp_east, t_s=t))
        assert speed > 0.0  # it drives on meanwhile
        assert ep.desired_speed_mps is None and "speed: 0.3 m/s" not in said(ep), north
    t += STEP_S
    drv.update(t, at(2.1, wp_east, t_s=t))  # 3.9 m to go: under 4 (not under 4.9)
    assert ep.desired_speed_mps == 0.3 and "speed: 0.3 m/s" in said(ep)


def test_a_condition_distance_is_measured_from_where_the_leg_begins_not_from_the_last_one() -> None:
    # the same, with the condition before the second waypoint: as that leg begins (Rover's
    # Mode::set_desired_location sets _distance_to_destination afresh) the distance is the
    # new leg's, 6 m, not what was left of the first leg when its waypoint was reached
    drv, ep = bench("AUTO")
    store(
        ep,
        (2.0, 0.0),
        item(mav.MAV_CMD_CONDITION_DISTANCE, 3.0),
        item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3),
        (2.0, 6.0),
    )
    t = 0.0
    for north in (0.0, 1.0, 2.0, 2.0):  # to the first waypoint and onto it (WP_RADIUS 2 m)
        t += STEP_S
        drv.update(t, at(north, 0.0, t_s=t))
    assert "Reached waypoint #1" in said(ep) and "Finished active loiter" not in said(ep)  # (a NAV_LOITER_TIME's)
    assert ep.desired_speed_mps is None and ep.current_seq == 4  # the second leg: held
    t += STEP_S
    drv.update(t, at(2.0, 3.5, t_s=t))  # 2.5 m to go: under 3
    assert ep.desired_speed_mps == 0.3


# -- RTL beside SmartRTL ------------------------------------------------------------------------


def test_rtl_leaves_smartrtls_way_back_as_it_was() -> None:
    # only SmartRTL uses up its way back (ModeSmartRTL::update's pop_point); Rover's ModeRTL
    # drives to home or a rally point and never touches the path AP_SmartRTL keeps
    drv, ep = bench("RTL")
    way = [(0.0, 0.0), (3.0, 0.0), (3.0, 3.0), (5.0, 3.0)]
    ep.path[:] = way
    for k in range(1, 6):
        drv.update(k * STEP_S, at(5.0, 3.0, yaw_rad=math.pi, t_s=k * STEP_S))
    assert ep.path == way
    assert drv.command[0] > 0.0  # it drives home meanwhile


# -- a disarmed vehicle --------------------------------------------------------------------------


def test_a_disarmed_vehicle_is_given_no_command_whatever_it_was_last_told() -> None:
    # AP_MotorsUGV::output_skid_steering: disarmed, both motors are held at trim (or zero
    # PWM) whatever the mode asks, in AUTO as in GUIDED with a fresh rate target (a
    # companion's setpoint, passed through at link ticks)
    drv, ep = bench("AUTO")
    store(ep, (6.0, 0.0))
    drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))
    assert drv.link_command()[0] > 0.0
    ep.armed = False
    assert drv.link_command() == (0.0, 0.0)
    assert drv.update(2 * STEP_S, at(0.0, 0.0, t_s=2 * STEP_S)) == (0.0, 0.0)
    drv, ep = bench("GUIDED")
    ep.guided = GuidedTarget("rate", 0.0, speed_mps=0.3, yaw_rate_radps=0.1)
    assert drv.link_command() == (0.3, 0.1)
    ep.armed = False
    assert drv.link_command() == (0.0, 0.0)


# -- AUTO without a mission ----------------------------------------------------------------------


def test_auto_without_a_mission_stops_a_vehicle_and_only_the_scripted_leader_drives_its_script() -> None:
    # a scenario with no waypoints: its leader drives [script]'s profile (4 s at 0.3 m/s by
    # default); any other vehicle in AUTO with no mission stops, as Rover's ModeAuto does in
    # its Stop submode (a mission finished, then cleared: AP_Mission::clear refuses only a
    # running mission)
    no_mission = 'name = "by-hand"\n' + LEADER_AND_FOLLOWER
    for scripted, expected in ((True, (0.3, 0.0)), (False, (0.0, 0.0))):
        drv, ep = bench("AUTO", scripted=scripted, scenario=no_mission)
        assert not ep.mission
        assert drv.update(1.0, at(0.0, 0.0, t_s=1.0)) == pytest.approx(expected), scripted


# -- GUIDED heading target -----------------------------------------------------------------------


def test_a_guided_heading_target_is_turned_to_at_its_speed_forwards_or_backwards() -> None:
    # Rover's ModeGuided::update, SubMode::HeadingAndSpeed: calc_steering_to_heading (the
    # body's yaw error: AR_AttitudeControl::get_turn_rate_from_heading) and the target's
    # speed, negative backwards (a SET_POSITION_TARGET's vx < 0)
    for speed in (0.3, -0.3):
        for yaw, turn in ((0.0, 1.0), (math.pi, -1.0)):  # heading north: right; south: left
            drv, ep = bench("GUIDED")
            ep.guided = GuidedTarget("heading", 0.0, speed_mps=speed, heading_rad=math.pi / 2)  # east
            got_speed, rate = drv.update(STEP_S, at(0.0, 0.0, yaw_rad=yaw, t_s=STEP_S))
            assert got_speed == speed and rate * turn > 0.0, (speed, yaw)
            assert drv.link_command() == (got_speed, rate)


def test_do_set_reverse_leaves_a_guided_heading_target_driven_forwards() -> None:
    # GCS_MAVLINK_Rover::handle_command_int_packet: MAV_CMD_DO_SET_REVERSE is
    # rover.control_mode->set_reversed(), i.e. g2.wp_nav.set_reversed(): a location target
    # (SubMode::WP, navigate_to_waypoint) is driven backwards; a heading target keeps its
    # own speed and turns the body to its heading (calc_steering_to_heading, calc_throttle)
    drv, ep = bench("GUIDED")
    ep.run_mission_item(item(mav.MAV_CMD_DO_SET_REVERSE, 1.0), verified=False)  # as a ground station's command
    assert ep.reversed
    ep.guided = GuidedTarget("heading", 0.0, speed_mps=0.3, heading_rad=math.pi / 2)
    speed, rate = drv.update(STEP_S, at(0.0, 0.0, yaw_rad=0.0, t_s=STEP_S))
    assert speed == 0.3 and rate > 0.0


# -- before the first step -----------------------------------------------------------------------


def test_before_its_first_step_a_vehicle_is_given_no_command() -> None:
    # the link may tick before guidance first runs: an armed vehicle in AUTO is then told to
    # stand still, not given a command no mode has computed
    drv, ep = bench("AUTO")
    store(ep, (6.0, 0.0))
    assert drv.command == (0.0, 0.0) and drv.link_command() == (0.0, 0.0)


# -- NAV_DELAY -----------------------------------------------------------------------------------


def test_a_nav_delay_of_no_seconds_waits_for_the_time_of_day_in_its_params() -> None:
    # ModeAuto::do_nav_delay: seconds 0 is not > 0, so nav_delay_time_max_ms is
    # AP::rtc().get_time_utc(hour, min, sec, 0): at 00:00:00.1 UTC, 01:00:00 is 3599.9 s off
    # ("Delaying 3599 sec", whole seconds)
    drv, ep = bench("AUTO")
    ep.epoch_us = 1_767_225_600_000_000  # 2026-01-01T00:00:00Z
    store(ep, MissionItem(0, mav.MAV_FRAME_MISSION, mav.MAV_CMD_NAV_DELAY, 0.0, 1.0, 0.0, 0.0), (6.0, 0.0))
    assert drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S)) == (0.0, 0.0)
    assert [s for s in said(ep) if s.startswith("Delaying")] == ["Delaying 3599 sec"]


def test_a_nav_delay_of_one_second_is_a_delay_not_a_time_of_day() -> None:
    # Rover's ModeAuto::do_nav_delay: seconds > 0 is a relative delay ("Delaying 1 sec");
    # only 0 or less waits for the time of day in params 2-4
    drv, ep = bench("AUTO")
    store(ep, item(mav.MAV_CMD_NAV_DELAY, 1.0, -1.0), (6.0, 0.0))
    assert drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S)) == (0.0, 0.0)  # stopped while it waits
    assert "Delaying 1 sec" in said(ep)
    assert [s for s in said(ep) if s.startswith("Delaying")] == ["Delaying 1 sec"]


# -- a DO_CHANGE_SPEED while circling ------------------------------------------------------------


def test_a_missions_speed_change_that_runs_while_circling_is_said_and_is_the_circles_alone() -> None:
    # AP_Mission starts the first DO command before the NAV_LOITER_TURNS (a waypoint speed:
    # set_speed_max), the next once the circle has begun: ModeAuto::set_desired_speed in its
    # Circle submode is ModeCircle::set_desired_speed (true for a speed > 0), so
    # do_change_speed says "speed: 0.3 m/s" (and nothing for a speed of 0) and the
    # waypoints' speed stays 0.5
    drv, ep = bench("AUTO")
    store(
        ep,
        item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.5),
        item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.0),  # not positive: refused, nothing said
        item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3),
        circle_at(3.0, 0.0),
    )
    drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))
    assert [s for s in said(ep) if s.startswith("speed:")] == ["speed: 0.5 m/s", "speed: 0.3 m/s"]
    assert ep.desired_speed_mps == 0.5


# -- MANUAL's full-throttle speed ------------------------------------------------------------------


@pytest.mark.parametrize("cruise_throttle", [100.5, 150.0, 4.9, 0.0])
def test_full_throttle_is_the_cruise_speed_when_the_cruise_throttle_is_not_sane(cruise_throttle: float) -> None:
    # Rover's Mode::calc_speed_max: a cruise throttle over 100 % or under 5 % is not used to
    # project the top speed; the cruise speed is taken as it
    assert speed_max(2.0, cruise_throttle) == 2.0
    assert speed_max(2.0, 100.0) == 2.0 and speed_max(2.0, 50.0) == 4.0 and speed_max(2.0, 5.0) == 30.0


# -- MANUAL at zero throttle ---------------------------------------------------------------------


def test_manual_with_the_throttle_centred_turns_the_way_the_steering_stick_points() -> None:
    # Rover's Mode::get_pilot_input (PILOT_STEER_TYPE 0): the steering is turned round only
    # while the throttle is negative (is_negative(throttle_out)); at zero throttle a right
    # stick turns right, as going forward. Steering 1567 us is 10 % right (test_rover_modes:
    # 10 % of max_yaw_rate_degps); throttle 1500 us is centred: no speed.
    drv, ep, gcs = bench_and_gcs("MANUAL")
    for throttle_us, sign in ((1500, 1.0), (1378, -1.0)):
        send(ep, gcs, mav.MAVLink_rc_channels_override_message(1, 1, 1567, 0, throttle_us, 0, 0, 0, 0, 0))
        speed, rate = drv.update(ep.t_s, at(0.0, 0.0, t_s=ep.t_s))
        assert (speed == 0.0) == (throttle_us == 1500)
        assert rate == pytest.approx(sign * 0.1 * drv.cfg.guidance.max_yaw_rate_radps), throttle_us
        assert drv.link_command() == (speed, rate)
    # sticks moved between guidance steps: the link's next command has them (Rover's MANUAL
    # passes them to the motors every loop)
    send(ep, gcs, mav.MAVLink_rc_channels_override_message(1, 1, 1500, 0, 1622, 0, 0, 0, 0, 0))
    assert drv.command[0] < 0.0 and drv.link_command()[0] > 0.0
    ep.armed = False  # disarmed, the sticks move nothing (AP_MotorsUGV::output_skid_steering)
    assert drv.link_command() == (0.0, 0.0)


# -- a ground station's DO_CHANGE_SPEED while circling ---------------------------------------------


def test_a_ground_stations_speed_change_while_circling_leaves_the_waypoints_speed_as_it_was() -> None:
    # GCS_MAVLINK_Rover: MAV_CMD_DO_CHANGE_SPEED is control_mode->set_desired_speed; in AUTO's
    # Circle submode that is ModeCircle::set_desired_speed (Rover/mode_auto.cpp
    # ModeAuto::set_desired_speed): AR_WPNav's speed, WP_SPEED here, is not touched
    drv, ep = bench("AUTO")
    store(ep, circle_at(3.0, 0.0), (6.0, 0.0))
    assert drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))[0] == pytest.approx(2.0)  # WP_SPEED round it
    ep.run_mission_item(item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3), verified=False)  # as the command does
    assert ep.desired_speed_mps == 0.3
    speed, _rate = drv.update(2 * STEP_S, at(0.0, 0.0, t_s=2 * STEP_S))
    assert ep.desired_speed_mps is None and ep.speed_mps == ep.param("WP_SPEED")
    assert speed == pytest.approx(0.3)  # the circle's (heading straight for its edge)


# -- a circle "here" -------------------------------------------------------------------------------


def test_a_circle_at_latitude_and_longitude_zero_is_centred_where_the_vehicle_is_as_it_begins() -> None:
    # Rover's ModeAuto::do_circle: circle_center.sanitize(rover.current_loc), so a
    # NAV_LOITER_TURNS at 0, 0 is centred where the vehicle is when the item begins (here
    # (3.5, 0.2), past the waypoint before it at (3, 0), heading 1 rad); the point it steers for
    # (ModeCircle::get_desired_location) is on the circle, the radius (2 m) from there
    drv, ep = bench("AUTO")
    here = MissionItem(0, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_NAV_LOITER_TURNS, 1.0, 0.0, 2.0)
    store(ep, (3.0, 0.0), here)
    drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))
    for k in (2, 3):  # the waypoint reached (WP_RADIUS 2 m), the circle begun; then it steers
        drv.update(k * STEP_S, at(3.5, 0.2, yaw_rad=1.0, t_s=k * STEP_S))
    assert ep.current_seq == 2 and ep.nav is not None
    assert math.dist(ep.nav.destination_ned_m, (3.5, 0.2)) == pytest.approx(2.0, abs=1e-6)
    # on the centre itself, the point is the vehicle's heading (1 rad) from it
    # (ModeCircle::init_target_yaw_rad: the vehicle's yaw when the distance is zero)
    assert ep.nav.destination_ned_m == pytest.approx((3.5 + 2.0 * math.cos(1.0), 0.2 + 2.0 * math.sin(1.0)))
    # NAV_CONTROLLER_OUTPUT's bearing and distance are to that point (ModeCircle::wp_bearing,
    # _distance_to_destination)
    n, e = ep.nav.destination_ned_m
    assert ep.nav.target_bearing_rad == pytest.approx(math.atan2(e - 0.2, n - 3.5))
    assert ep.nav.distance_m == pytest.approx(2.0, abs=1e-6)


# -- SmartRTL uses up its way back point by point ------------------------------------------------


def test_smartrtl_uses_up_only_the_points_it_has_set_out_for() -> None:
    # AP_SmartRTL::pop_point as ModeSmartRTL::update loads each point: the points still to
    # come stay on the way back (a SmartRTL left and entered again goes on with them)
    drv, ep = bench("SMART_RTL")
    ep.path[:] = [(0.0, 0.0), (3.0, 0.0), (3.0, 3.0), (6.0, 3.0)]
    drv.update(STEP_S, at(6.0, 3.0, yaw_rad=-math.pi / 2, t_s=STEP_S))
    # (6, 3) popped and reached where it stands, (3, 3) popped as it sets out for it
    assert ep.path == [(0.0, 0.0), (3.0, 0.0)]
    drv.update(2 * STEP_S, at(3.0, 3.0, yaw_rad=-math.pi, t_s=2 * STEP_S))
    assert ep.path == [(0.0, 0.0)]  # (3, 3) reached: on to (3, 0)


# -- a circle's warnings ---------------------------------------------------------------------------


def test_a_circle_warns_only_when_its_radius_is_raised_or_its_speed_cut() -> None:
    # Rover's ModeCircle::check_config_radius warns when the radius is under TURN_RADIUS (not
    # equal to it); check_config_speed when the speed is over what the turn allows (lfctl's
    # limit here: 0.8 x max_yaw_rate x radius, 2.5 m/s for 2 m at 90 deg/s)
    at_limit = 0.8 * math.radians(90.0) * 2.0  # the limit itself is not over it
    for turn_radius, wp_speed, warned in ((2.0, at_limit, []), (0.9, 4.0, ["Circle: max speed is  2.5"])):
        drv, ep = bench("AUTO")
        ep.params["TURN_RADIUS"].value = turn_radius
        ep.params["WP_SPEED"].value = wp_speed
        store(ep, circle_at(3.0, 0.0, radius_m=2.0), (6.0, 0.0))
        drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))
        assert [s for s in said(ep) if s.startswith("Circle:")] == warned, (turn_radius, wp_speed)


def test_a_speed_change_too_fast_for_the_circle_is_cut_and_said() -> None:
    # the second DO command runs once the circle has begun (the first, a servo, before it):
    # 4 m/s is over the 2 m circle's 2.5 m/s, so Rover's check_config_speed cuts it and says so
    drv, ep = bench("AUTO")
    store(
        ep,
        item(mav.MAV_CMD_DO_SET_SERVO, 5.0, 1900.0),
        item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 4.0),
        circle_at(3.0, 0.0),
    )
    drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))
    assert "speed: 4.0 m/s" in said(ep)  # do_change_speed: set_desired_speed took it
    assert "Circle: max speed is  2.5" in said(ep)


# -- GUIDED rate target, MANUAL sticks between guidance steps ------------------------------------


def test_a_guided_rate_target_is_passed_through_with_no_destination() -> None:
    # ModeGuided::update, SubMode::TurnRateAndSpeed: the turn rate and speed as sent; no
    # desired location (get_desired_location false)
    drv, ep = bench("GUIDED")
    assert drv.update(STEP_S, at(1.0, 2.0, t_s=STEP_S)) == (0.0, 0.0)  # no target yet: start_stop
    ep.guided = GuidedTarget("rate", 0.0, speed_mps=0.3, yaw_rate_radps=-0.2)
    assert drv.update(2 * STEP_S, at(1.0, 2.0, t_s=2 * STEP_S)) == (0.3, -0.2)
    assert ep.nav is None
    # not renewed for GUID_TIMEOUT (3 s): stopped at the link's next tick, before guidance
    # runs again ("target not received last 3secs, stopping")
    ep.tick(3.05, STILL)
    assert drv.link_command() == (0.0, 0.0) and drv.command == (0.3, -0.2)


# -- AUTO's settings from the scenario -----------------------------------------------------------


def test_autos_lookahead_and_cruise_speed_are_the_scenarios() -> None:
    # [mission] lookahead_m > 0 is the LOS lookahead; 0 is pure pursuit of the waypoint (None);
    # the cruise speed is [mission]'s, no faster than [guidance] max_speed_mps
    for lookahead, expected in ((0.8, 0.8), (1.5, 1.5), (0.0, None)):
        cfg = parse_config(SCENARIO.replace("[mission]", f"[mission]\nlookahead_m = {lookahead}"), "by-hand")
        assert autopilot_settings(cfg).lookahead_m == expected, lookahead
    assert autopilot_settings(parse_config(SCENARIO, "by-hand")).cruise_speed_mps == 0.4
    fast = SCENARIO.replace("cruise_speed_mps = 0.4", "cruise_speed_mps = 0.8")
    assert autopilot_settings(parse_config(fast, "by-hand")).cruise_speed_mps == 0.5


# -- a mission edited in place ---------------------------------------------------------------------


def drive(drv: VehicleDriver, ep: VehicleEndpoint, *places: tuple[float, float]) -> None:
    """A guidance step with the vehicle at each place in turn (the endpoint's clock on a step each)."""
    for north, east in places:
        t = ep.t_s + STEP_S
        ep.tick(t, {**STILL, "north_m": north, "east_m": east})
        drv.update(t, at(north, east, t_s=t))


def test_an_edit_of_a_finished_mission_does_not_fly_it_again_even_one_that_changes_its_end() -> None:
    # AP_Mission::replace_cmd writes the item; ModeAuto::update restarts the command under way
    # only while the mission is running (MISSION_RUNNING): a completed mission stays so, and
    # the vehicle stopped, whatever the edit changed (here the servo command after its last
    # waypoint, which a mission under way would be planned again for)
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (2.0, 0.0), (4.0, 0.0), item(mav.MAV_CMD_DO_SET_SERVO, 5.0, 1900.0))
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0), (4.0, 0.0), (4.0, 0.0))
    assert ep.mission_complete and said(ep)[-1] == "Mission Complete"
    before = len(said(ep))
    rewrite(ep, gcs, dataclasses.replace(ep.mission[3], param2=1100.0))
    drive(drv, ep, (4.0, 0.0), (4.0, 0.0))
    assert said(ep)[before:] == ["Flight plan received"]  # the upload's words alone: no item begun
    assert ep.mission_complete and drv.command == (0.0, 0.0)


def test_an_edit_of_a_jumps_repeats_under_way_counts_from_the_times_it_has_run() -> None:
    # jump to 1 once; on the second lap the repeats are edited to 2: the jump has run once,
    # 1 < 2, so at waypoint 2 it jumps again ("Mission: 3 Jump 2/2") for a third lap
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (2.0, 0.0), (4.0, 0.0), item(mav.MAV_CMD_DO_JUMP, 1.0, 1.0))
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0), (4.0, 0.0))
    assert "Mission: 3 Jump 1/1" in said(ep) and not ep.mission_complete  # lap 2 under way
    rewrite(ep, gcs, dataclasses.replace(ep.mission[3], param2=2.0))
    drive(drv, ep, (2.0, 0.0), (4.0, 0.0), (4.0, 0.0))
    assert "Mission: 3 Jump 2/2" in said(ep) and not ep.mission_complete


def test_an_edit_of_a_wait_further_on_is_taken_when_its_waypoint_is_reached() -> None:
    # Rover reads each item when it comes to it (AP_Mission::get_next_nav_cmd from storage):
    # waypoint 2 given a 3 s wait while waypoint 1 is under way waits there
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (3.0, 0.0), (6.0, 0.0), (9.0, 0.0))
    drive(drv, ep, (0.0, 0.0))
    rewrite(ep, gcs, dataclasses.replace(ep.mission[2], param1=3.0))
    drive(drv, ep, (0.5, 0.0), (1.5, 0.0), (3.0, 0.0), (4.5, 0.0), (6.0, 0.0), (6.0, 0.0))
    assert "Reached waypoint #2. Loiter for 3 seconds" in said(ep)


# -- RTL's speed ---------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["RTL", "SMART_RTL"])
def test_rtl_and_smartrtl_drive_at_rtl_speed_else_wp_speed(mode: str) -> None:
    # ModeRTL::_enter and ModeSmartRTL::_enter: g2.wp_nav.init(MAX(0, g2.rtl_speed)), which
    # takes WP_SPEED when RTL_SPEED is 0; 10 m out, heading straight home, the speed is it
    for rtl_speed, expected in ((0.3, 0.3), (0.0, 0.7)):
        drv, ep = bench(mode)
        ep.params["WP_SPEED"].value = 0.7
        ep.params["RTL_SPEED"].value = rtl_speed
        ep.path[:] = [(0.0, 0.0), (-10.0, 0.0)]
        speed, _rate = drv.update(STEP_S, at(-10.0, 0.0, yaw_rad=0.0, t_s=STEP_S))
        assert speed == pytest.approx(expected), rtl_speed


# -- GUIDED location target, reversed ----------------------------------------------------------------


def test_do_set_reverse_backs_a_guided_vehicle_to_its_location_target() -> None:
    # ModeGuided SubMode::WP is navigate_to_waypoint, AR_WPNav with set_reversed(true) (the
    # command's Mode::set_reversed): heading south with the place 5 m north, it backs there
    drv, ep = bench("GUIDED")
    ep.run_mission_item(item(mav.MAV_CMD_DO_SET_REVERSE, 1.0), verified=False)
    ep.guided = GuidedTarget("location", 0.0, north_m=5.0, east_m=0.0)
    speed, rate = drv.update(STEP_S, at(0.0, 0.0, yaw_rad=math.pi, t_s=STEP_S))
    assert speed < 0.0 and rate == pytest.approx(0.0, abs=1e-9)
    # NAV_CONTROLLER_OUTPUT: the place is north, the body is steered to head south
    # (AR_WPNav's desired heading is the bearing + 180 deg when reversed)
    assert ep.nav is not None and ep.nav.target_bearing_rad == pytest.approx(0.0, abs=1e-9)
    assert math.cos(ep.nav.nav_bearing_rad) == pytest.approx(-1.0)


# -- CONDITION_DELAY beyond a signed 32-bit number of milliseconds -----------------------------------


def test_a_condition_delay_beyond_32_bits_is_held_at_its_ends() -> None:
    # ModeAuto::do_wait_delay: static_cast<int32_t>(seconds * 1000), which an ARM flight
    # controller's conversion holds at INT32_MAX or INT32_MIN; verify_wait_delay compares it
    # as uint32_t: 2147483.647 s, and 2^31 ms (2147483.648 s) for a delay below -2^31 ms
    assert condition_delay_s(1.0e7) == pytest.approx(2147483.647, abs=1e-6)
    assert condition_delay_s(2147483.647) == pytest.approx(2147483.647, abs=1e-6)
    assert condition_delay_s(-1.0e7) == pytest.approx(2147483.648, abs=1e-6)


def test_moving_the_next_waypoint_restarts_the_waypoint_under_way_as_rover_does() -> None:
    # MAVProxy's `wp move 2` while item 1 is under way: AP_Mission::restart_current_nav_cmd is
    # set_current_cmd(1), which starts item 1 again ("Mission: 1 WP" a second time)
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (3.0, 0.0), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0))
    moved = local_mission([(6.0, 3.0)], HOME)[1]
    rewrite(ep, gcs, dataclasses.replace(ep.mission[2], x=moved.x, y=moved.y))
    drive(drv, ep, (0.2, 0.0))
    assert "Auto mission changed, restarted command" in said(ep)
    assert said(ep).count("Mission: 1 WP") == 2


# -- a circle of no turns ------------------------------------------------------------------------


def test_a_circle_of_no_turns_is_done_at_once_and_the_next_leg_driven_in_the_same_step() -> None:
    # ModeAuto::verify_circle: angle_total / 2 pi >= turns holds at once for 0 turns, so the
    # mission goes straight on to the waypoint after it, and the vehicle drives for it
    drv, ep = bench("AUTO")
    store(ep, circle_at(3.0, 0.0, turns=0.0), (6.0, 0.0))
    speed, _rate = drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))
    assert ep.current_seq == 2 and speed > 0.0
    assert ep.nav is not None and ep.nav.destination_ned_m == pytest.approx((6.0, 0.0), abs=1e-3)  # the waypoint


# -- a finished mission flown again -------------------------------------------------------------------


def test_a_finished_mission_flown_again_takes_its_jumps_again() -> None:
    # AUTO entered after "Mission Complete": AP_Mission::resume of a complete mission is
    # start(), which init_jump_tracking()s: the DO_JUMP is taken again
    drv, ep = bench("AUTO")
    store(ep, (2.0, 0.0), (4.0, 0.0), item(mav.MAV_CMD_DO_JUMP, 1.0, 1.0))
    laps = ((0.0, 0.0), (2.0, 0.0), (4.0, 0.0), (2.0, 0.0), (4.0, 0.0), (4.0, 0.0))
    drive(drv, ep, *laps)
    assert ep.mission_complete and said(ep).count("Mission: 3 Jump 1/1") == 1
    assert ep.set_mode(MODES["HOLD"]) and ep.set_mode(MODES["AUTO"])
    drive(drv, ep, *laps)
    assert said(ep).count("Mission: 3 Jump 1/1") == 2 and said(ep).count("Mission Complete") == 2


# -- more edits in place -----------------------------------------------------------------------------


def test_an_edit_of_the_command_after_the_last_waypoint_is_the_one_run_at_the_end() -> None:
    # AP_Mission reads each item from storage as it comes to it: the servo command after the
    # last waypoint, made a speed change while waypoint 1 is under way, is the speed change
    # that starts as the mission completes
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (2.0, 0.0), (4.0, 0.0), item(mav.MAV_CMD_DO_SET_SERVO, 5.0, 1900.0))
    drive(drv, ep, (0.0, 0.0))
    rewrite(ep, gcs, dataclasses.replace(ep.mission[3], command=mav.MAV_CMD_DO_CHANGE_SPEED, param1=1.0, param2=0.3))
    drive(drv, ep, (1.0, 0.0), (2.0, 0.0), (4.0, 0.0), (4.0, 0.0))
    assert ep.mission_complete and "Mission: 3 ChangeSpeed" in said(ep) and "Mission: 3 SetServo" not in said(ep)


def test_an_edit_while_circling_leaves_the_circle_and_its_words_alone() -> None:
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, circle_at(3.0, 0.0, turns=2.0), (6.0, 0.0), (9.0, 0.0))
    drive(drv, ep, (0.0, 0.0), (1.0, 0.0))
    rewrite(ep, gcs, dataclasses.replace(ep.mission[3], param1=3.0))  # waypoint 3 waits 3 s
    drive(drv, ep, (1.0, 0.0))
    assert said(ep).count("Mission: 1 LoitTurns") == 1


# -- the recorder's reached events --------------------------------------------------------------------


def test_the_reached_callback_names_the_waypoint_the_item_current_after_it_and_the_missions_size() -> None:
    # (t_s, index from 0, the item current once it is done, the mission's items less home,
    # its NAV items, the mission's number): 4 items, 3 places (one with a wait) and a servo
    got: list[tuple[float, int, int, int, int, int]] = []
    cfg = parse_config(SCENARIO, "by-hand")
    link, _gcs = MemoryLink.pair("ep", "gcs")
    ep = VehicleEndpoint("leader", 1, link, HOME, mode="AUTO", armed=True)
    drv = VehicleDriver(cfg, ep, 0, HOME, STEP_S, on_reached=lambda *a: got.append(a))
    store(ep, (2.0, 0.0), item(mav.MAV_CMD_DO_SET_SERVO, 5.0, 1900.0), (4.0, 0.0, 1.0), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0), *[(4.0, 0.0)] * 12, (6.0, 0.0), (6.0, 0.0))
    number = ep.missions.mission_number
    # waypoint 3 waits 1 s there: the item current after it is itself ("Loiter for 1 seconds")
    assert [a[1:] for a in got] == [(0, 3, 4, 3, number), (2, 3, 4, 3, number), (3, 4, 4, 3, number)]
    assert "Reached waypoint #3. Loiter for 1 seconds" in said(ep)


# -- WP_RADIUS set on the way -------------------------------------------------------------------------


def test_a_waypoint_radius_set_on_the_way_back_acts_at_once() -> None:
    # AR_WPNav reads WP_RADIUS at each update: on SmartRTL's way back, 1.5 m short of the point
    # it is passing through (3, 0), a radius of 1 m has it still heading there; raised to 2 m,
    # the next step it has passed it and set out for home (the point used up: pop_point)
    drv, ep = bench("SMART_RTL")
    ep.params["WP_RADIUS"].value = 1.0
    ep.path[:] = [(0.0, 0.0), (3.0, 0.0), (6.0, 0.0)]
    drv.update(STEP_S, at(6.0, 0.0, yaw_rad=math.pi, t_s=STEP_S))
    drv.update(2 * STEP_S, at(4.5, 0.0, yaw_rad=math.pi, t_s=2 * STEP_S))
    assert ep.path == [(0.0, 0.0)] and ep.nav is not None and ep.nav.destination_ned_m == (3.0, 0.0)
    ep.params["WP_RADIUS"].value = 2.0
    drv.update(3 * STEP_S, at(4.5, 0.0, yaw_rad=math.pi, t_s=3 * STEP_S))
    assert ep.path == [] and ep.nav is not None and ep.nav.destination_ned_m == (0.0, 0.0)


# -- the slowest waypoint speed ----------------------------------------------------------------------


def test_a_missions_speed_change_to_the_slowest_waypoint_speed_is_taken() -> None:
    # AR_WPNav::set_speed_max refuses a speed under AR_WPNAV_SPEED_MIN (0.05 m/s), not 0.05
    # itself: do_change_speed says it and the waypoints are driven at it
    drv, ep = bench("AUTO")
    store(ep, item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, WP_SPEED_MIN_MPS), (6.0, 0.0))
    drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))
    assert ep.desired_speed_mps == WP_SPEED_MIN_MPS and "speed: 0.1 m/s" in said(ep)  # %.1f of 0.05


# -- a condition while circling -----------------------------------------------------------------------


def test_a_condition_distance_before_a_circle_is_measured_to_the_point_on_the_circle() -> None:
    # in AUTO's Circle submode get_distance_to_destination() is ModeCircle's, the distance to
    # its target point on the circle: the edge nearest, 4 m off for a 2 m circle round (6, 0),
    # which is under the condition's 5 m (the centre, 6 m off, is not)
    drv, ep = bench("AUTO")
    store(
        ep, item(mav.MAV_CMD_CONDITION_DISTANCE, 5.0), item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3), circle_at(6.0, 0.0)
    )
    drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))
    assert "speed: 0.3 m/s" in said(ep)


# -- a new GUIDED place ----------------------------------------------------------------------------


def test_a_new_guided_place_on_the_way_to_another_is_driven_to_instead() -> None:
    # ModeGuided::set_desired_location replaces AR_WPNav's destination
    drv, ep = bench("GUIDED")
    ep.guided = GuidedTarget("location", 0.0, north_m=5.0, east_m=0.0)
    drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))
    assert ep.nav is not None and ep.nav.destination_ned_m == (5.0, 0.0)
    ep.guided = GuidedTarget("location", 0.15, north_m=0.0, east_m=-5.0)
    drv.update(2 * STEP_S, at(0.1, 0.0, t_s=2 * STEP_S))
    assert ep.nav is not None and ep.nav.destination_ned_m == (0.0, -5.0)


# -- a condition with nothing after it -----------------------------------------------------------------


def test_a_condition_with_nothing_after_it_is_still_checked_and_said_done() -> None:
    # AP_Mission::update verifies the running condition each update; ModeAuto's
    # verify_command_callback sends MISSION_ITEM_REACHED for it once verify_within_distance
    # holds, though no DO command waits behind it
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, item(mav.MAV_CMD_CONDITION_DISTANCE, 5.0), (6.0, 0.0))
    parser = mav.MAVLink(None)

    def reached() -> list[int]:
        got = []
        for data, _addr in gcs.recv(100000):
            got += [m.seq for m in parser.parse_buffer(data) or [] if m.get_type() == "MISSION_ITEM_REACHED"]
        return got

    drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))  # 6 m to go: held
    assert reached() == []
    drv.update(2 * STEP_S, at(1.5, 0.0, t_s=2 * STEP_S))  # 4.5 m: done
    assert reached() == [1]


# -- CIRC_SPEED --------------------------------------------------------------------------------------


def test_a_missions_circle_is_driven_at_circ_speed_else_wp_speed() -> None:
    # ModeCircle::_enter: config.speed = CIRC_SPEED if positive, else AR_WPNav's default
    # (WP_SPEED); heading straight for the circle's edge, the speed is it
    for circ_speed, expected in ((0.6, 0.6), (0.0, 0.7)):
        drv, ep = bench("AUTO")
        ep.params["WP_SPEED"].value = 0.7
        ep.params["CIRC_SPEED"].value = circ_speed
        store(ep, circle_at(6.0, 0.0), (9.0, 0.0))
        assert drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))[0] == pytest.approx(expected), circ_speed


# -- a GUIDED place reached -----------------------------------------------------------------------------


def test_a_guided_place_reached_is_said_with_mission_item_reached_0_and_the_vehicle_stops() -> None:
    # ModeGuided::update, SubMode::WP: once AR_WPNav has reached the destination,
    # send_mission_item_reached_message(0) (once) and stop_vehicle()
    drv, ep, gcs = bench_and_gcs("GUIDED")
    ep.guided = GuidedTarget("location", 0.0, north_m=2.0, east_m=0.0)
    parser = mav.MAVLink(None)
    seqs = []
    for k, north in enumerate((0.0, 1.0, 2.0, 2.0, 2.0), start=1):
        drv.update(k * STEP_S, at(north, 0.0, t_s=k * STEP_S))
        for data, _addr in gcs.recv(100000):
            seqs += [m.seq for m in parser.parse_buffer(data) or [] if m.get_type() == "MISSION_ITEM_REACHED"]
    assert seqs == [0] and ep.guided is None and drv.command == (0.0, 0.0)


# -- a new mission, a CONDITION_DELAY far from the waypoint ---------------------------------------------


def test_a_new_mission_uploaded_on_the_way_goes_on_from_the_item_under_way_with_its_jump_counts() -> None:
    # the jump of the mission flown is used up on its second lap, item 2 under way; the same
    # items uploaded again: Rover's upload writes them over the old ones (truncate,
    # replace_cmd; no reset), so item 2 is still under way, unchanged (no restart), and the
    # jump tracking, kept by item number, has item 3 run once of once: the mission ends
    drv, ep = bench("AUTO")
    laps = ((0.0, 0.0), (2.0, 0.0), (4.0, 0.0))
    store(ep, (2.0, 0.0), (4.0, 0.0), item(mav.MAV_CMD_DO_JUMP, 1.0, 1.0))
    drive(drv, ep, *laps, (2.0, 0.0))  # lap 2 under way: the jump used up
    assert said(ep).count("Mission: 3 Jump 1/1") == 1 and ep.current_seq == 2
    before = len(said(ep))
    store(ep, (2.0, 0.0), (4.0, 0.0), item(mav.MAV_CMD_DO_JUMP, 1.0, 1.0))
    assert ep.current_seq == 2 and ep.mission_current == 2
    drive(drv, ep, (3.0, 0.0), (4.0, 0.0), (4.0, 0.0))
    assert said(ep)[before:] == ["Reached waypoint #2", "Mission Complete"]
    assert ep.mission_complete


def test_a_new_mission_uploaded_on_the_way_restarts_the_item_of_that_number_when_it_changed() -> None:
    # item 2 under way; the new mission's item 2 is elsewhere (6, 2): the detector sees the
    # item under way changed, and ModeAuto restarts item 2, the new one
    drv, ep = bench("AUTO")
    store(ep, (2.0, 0.0), (4.0, 0.0))
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0))
    assert ep.current_seq == 2
    store(ep, (2.0, 0.0), (6.0, 2.0), (8.0, 0.0))
    drive(drv, ep, (3.0, 0.0))
    assert said(ep)[-2:] == ["Mission: 2 WP", "Auto mission changed, restarted command"]
    assert ep.nav is not None and ep.nav.destination_ned_m == pytest.approx((6.0, 2.0), abs=0.01)


def test_a_new_mission_too_short_for_the_item_under_way_lets_it_finish_then_completes() -> None:
    # item 3 under way; a mission of one waypoint uploaded: restart_current_nav_cmd fails
    # (item 3 >= num_commands), so Rover says so and drives the item it has to its end;
    # advancing past it finds nothing in the new mission: complete
    drv, ep = bench("AUTO")
    store(ep, (2.0, 0.0), (4.0, 0.0), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0), (4.0, 0.0))
    assert ep.current_seq == 3
    store(ep, (1.0, 1.0))
    drive(drv, ep, (5.0, 0.0))
    assert said(ep)[-1] == "Auto mission changed but failed to restart command"
    assert ep.nav is not None and ep.nav.destination_ned_m == pytest.approx((6.0, 0.0), abs=0.01)
    drive(drv, ep, (6.0, 0.0), (6.0, 0.0))
    assert said(ep)[-2:] == ["Reached waypoint #3", "Mission Complete"] and ep.mission_complete


def test_a_new_mission_uploaded_after_the_end_waits_for_auto_to_be_entered_again() -> None:
    # AP_Mission's state stays MISSION_COMPLETE over an upload: nothing is flown (no
    # "Mission: 1 WP", the vehicle stopped, MISSION_CURRENT's state complete) until AUTO is
    # entered again, which starts the new mission from its first item
    drv, ep = bench("AUTO")
    store(ep, (2.0, 0.0))
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0), (2.0, 0.0))
    assert ep.mission_complete
    before = len(said(ep))
    store(ep, (5.0, 0.0), (7.0, 0.0))
    drive(drv, ep, (2.0, 0.0), (2.0, 0.0))
    assert said(ep)[before:] == [] and drv.command == (0.0, 0.0) and ep.mission_complete
    assert ep.set_mode(MODES["HOLD"]) and ep.set_mode(MODES["AUTO"])
    drive(drv, ep, (2.0, 0.0))
    assert said(ep)[before:] == ["Mission: 1 WP"] and drv.command[0] > 0.0


def test_a_condition_delay_lets_the_commands_after_it_go_wherever_the_vehicle_is() -> None:
    # ModeAuto::verify_wait_delay: done once millis() - condition_start > condition_value
    # (0.5 s), however far the waypoint still is (6 m here)
    drv, ep = bench("AUTO")
    store(ep, item(mav.MAV_CMD_CONDITION_DELAY, 0.5), item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3), (6.0, 0.0))
    for k in range(1, 6):  # 0.1 .. 0.5 s: under 0.5 s after it began (at 0.1 s)
        drv.update(k * STEP_S, at(0.0, 0.0, t_s=k * STEP_S))
    assert ep.desired_speed_mps is None
    drv.update(0.7, at(0.0, 0.0, t_s=0.7))
    assert ep.desired_speed_mps == 0.3


# -- HOLD ---------------------------------------------------------------------------------------------


def test_hold_stops_the_vehicle() -> None:
    # Rover's ModeHold::update: stop_vehicle() (throttle to stop, steering centred)
    drv, _ep = bench("HOLD")
    assert drv.update(STEP_S, at(1.0, 1.0, yaw_rad=0.3, t_s=STEP_S)) == (0.0, 0.0)
    assert drv.link_command() == (0.0, 0.0)


# -- an edit of the items ahead, as Rover's AP_Mission_ChangeDetector sees it -------------------------

RESTARTED = "Auto mission changed, restarted command"


def moved_to(it: MissionItem, north_m: float, east_m: float) -> MissionItem:
    """``it`` at another place (local NED, m)."""
    place = local_mission([(north_m, east_m)], HOME)[1]
    return dataclasses.replace(it, x=place.x, y=place.y)


def test_moving_the_waypoint_under_way_restarts_it_for_its_new_place() -> None:
    # the item under way is the first the detector watches: restart_current_nav_cmd starts it
    # again with its new content (do_nav_wp), so the vehicle heads for (0, 3), due east
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (3.0, 0.0), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0))
    rewrite(ep, gcs, moved_to(ep.mission[1], 0.0, 3.0))
    drive(drv, ep, (0.0, 0.0))
    assert said(ep).count(RESTARTED) == 1 and said(ep).count("Mission: 1 WP") == 2
    assert ep.nav is not None and ep.nav.destination_ned_m == pytest.approx((0.0, 3.0), abs=0.01)


def test_an_edit_of_the_fourth_navigation_item_ahead_restarts_nothing_and_is_flown_when_reached() -> None:
    # the detector watches three navigation items (mis_change_detect_cmd_max): from item 1,
    # items 1, 2 and 3; item 4 moved to (12, 3) is read from storage when it comes
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (3.0, 0.0), (6.0, 0.0), (9.0, 0.0), (12.0, 0.0))
    drive(drv, ep, (0.0, 0.0))
    rewrite(ep, gcs, moved_to(ep.mission[4], 12.0, 3.0))
    drive(drv, ep, (1.0, 0.0), (3.0, 0.0), (6.0, 0.0), (9.0, 0.0))
    assert RESTARTED not in said(ep) and said(ep).count("Mission: 1 WP") == 1
    assert ep.current_seq == 4
    assert ep.nav is not None and ep.nav.destination_ned_m == pytest.approx((12.0, 3.0), abs=0.01)


def test_an_edit_of_a_do_command_ahead_restarts_nothing_and_runs_as_edited() -> None:
    # the detector compares navigation items only: the speed change between waypoints 1 and
    # 3, edited from 0.3 to 0.2 m/s, is run as edited when waypoint 3 begins
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (3.0, 0.0), item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0))
    rewrite(ep, gcs, dataclasses.replace(ep.mission[2], param2=0.2))
    drive(drv, ep, (1.0, 0.0), (3.0, 0.0))
    assert RESTARTED not in said(ep) and said(ep).count("Mission: 1 WP") == 1  # waypoint 1 went on
    assert "speed: 0.2 m/s" in said(ep) and "speed: 0.3 m/s" not in said(ep)


def test_a_restart_drops_the_condition_and_do_commands_still_waiting() -> None:
    # waypoint 4 begins behind a 100 s CONDITION_DELAY holding a speed change; moving
    # waypoint 5 (watched) restarts item 4: set_current_cmd(4) clears the DO command running
    # and AP_Mission's search starts at item 4 itself, so neither runs again, however long
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(
        ep, (3.0, 0.0), item(mav.MAV_CMD_CONDITION_DELAY, 100.0), item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3),
        (6.0, 0.0), (9.0, 0.0),
    )  # fmt: skip
    drive(drv, ep, (0.0, 0.0), (3.0, 0.0))
    assert "Mission: 2 CondDelay" in said(ep) and ep.current_seq == 4
    rewrite(ep, gcs, moved_to(ep.mission[5], 9.0, 3.0))
    drive(drv, ep, *[(3.5, 0.0)] * 1100)  # 110 s
    assert said(ep).count(RESTARTED) == 1 and said(ep).count("Mission: 4 WP") == 2
    assert "speed: 0.3 m/s" not in said(ep)


def test_an_edit_while_a_missions_rtl_is_under_way_restarts_nothing() -> None:
    # a mission's RTL runs in ModeAuto's RTL submode: the restart is for the WP submode only
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (3.0, 0.0), item(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0), (3.0, 0.0))
    assert ep.current_seq == 2
    before = said(ep)
    rewrite(ep, gcs, moved_to(ep.mission[3], 6.0, 3.0))
    drive(drv, ep, (3.0, 0.0))  # (home 3 m off, outside WP_RADIUS's 2 m)
    assert said(ep)[len(before) :] == ["Flight plan received"]


def test_a_restart_keeps_the_jump_counts() -> None:
    # on the second lap (item 1 under way, the jump taken once of once) item 2 is moved: item
    # 1 restarts (set_current_cmd of an item other than 0 keeps the jump tracking), so after
    # item 2 the jump is spent and the mission goes on to item 4
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (2.0, 0.0), (4.0, 0.0), item(mav.MAV_CMD_DO_JUMP, 1.0, 1.0), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0), (4.0, 0.0))
    assert "Mission: 3 Jump 1/1" in said(ep) and ep.current_seq == 1
    rewrite(ep, gcs, moved_to(ep.mission[2], 4.0, 1.0))
    drive(drv, ep, (1.0, 0.0), (2.0, 0.0), (4.0, 1.0))
    assert said(ep).count(RESTARTED) == 1 and said(ep).count("Mission: 3 Jump 1/1") == 1
    assert ep.current_seq == 4


def test_a_new_mission_uploaded_in_hold_is_resumed_at_the_item_number_under_way() -> None:
    # AUTO left on item 2; a new mission uploaded in HOLD keeps the number (AP_Mission's
    # _nav_cmd.index), and AUTO's resume re-reads item 2 from the new mission: (6, 2)
    drv, ep = bench("AUTO")
    store(ep, (2.0, 0.0), (4.0, 0.0))
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0))
    assert ep.set_mode(MODES["HOLD"])
    drive(drv, ep, (2.5, 0.0))
    store(ep, (1.0, 1.0), (6.0, 2.0), (8.0, 0.0))
    assert ep.current_seq == 2
    assert ep.set_mode(MODES["AUTO"])
    drive(drv, ep, (2.5, 0.0))
    assert said(ep)[-1] == "Mission: 2 WP"
    assert ep.nav is not None and ep.nav.destination_ned_m == pytest.approx((6.0, 2.0), abs=0.01)


# -- the mission ahead changed: the review against Rover's code (AP_Mission, ModeAuto) ----------------

FAILED = "Auto mission changed but failed to restart command"


def test_restart_text_comes_after_the_restarted_items_own_words() -> None:
    # ModeAuto::update: if (mission.restart_current_nav_cmd()) GCS_SEND_TEXT(...restarted...):
    # the restart (set_current_cmd -> advance_current_nav_cmd -> start_command's
    # "Mission: 1 WP") runs first, the text is sent once it returned true
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (3.0, 0.0), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0))
    b = len(said(ep))
    rewrite(ep, gcs, moved_to(ep.mission[2], 6.0, 3.0))
    drive(drv, ep, (0.2, 0.0))
    assert said(ep)[b:] == ["Flight plan received", "Mission: 1 WP", RESTARTED]


def test_last_item_under_way_made_a_do_command_completes_and_fails_the_restart() -> None:
    # restart_current_nav_cmd -> set_current_cmd(2) -> advance_current_nav_cmd(2): item 2 is a
    # DO command (started, "Mission: 2 ChangeSpeed", "speed: 0.3 m/s"), no navigation item
    # follows: false -> complete() ("Mission Complete") and set_current_cmd returns false, so
    # ModeAuto says "... but failed to restart command", after the rest
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (2.0, 0.0), (4.0, 0.0))
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0))
    b = len(said(ep))
    rewrite(ep, gcs, dataclasses.replace(item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3), seq=2))
    drive(drv, ep, (2.5, 0.0))
    assert said(ep)[b:] == [
        "Flight plan received",
        "Mission: 2 ChangeSpeed",
        "speed: 0.3 m/s",
        "Mission Complete",
        FAILED,
    ]


def test_item_under_way_made_a_jump_to_itself_for_ever_fails_the_restart() -> None:
    # advance_current_nav_cmd(2): get_next_cmd follows the jump to itself until max_loops
    # (64) and returns false: complete(), then "failed to restart command"
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (2.0, 0.0), (4.0, 0.0), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0))
    b = len(said(ep))
    rewrite(ep, gcs, dataclasses.replace(item(mav.MAV_CMD_DO_JUMP, 2.0, -1.0), seq=2))
    drive(drv, ep, (2.5, 0.0))
    assert said(ep)[b:] == ["Flight plan received", "Mission Complete", FAILED]


def test_a_do_command_waiting_behind_a_condition_runs_as_edited() -> None:
    # item 3 (speed 0.3) waits behind a 3 s CONDITION_DELAY while waypoint 4 is driven; it is
    # edited to 0.2 (not a navigation item: no restart). When the delay is done,
    # advance_current_do_cmd -> get_next_do_cmd reads item 3 from storage: 0.2
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(
        ep, (2.0, 0.0), item(mav.MAV_CMD_CONDITION_DELAY, 3.0), item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3), (12.0, 0.0)
    )
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0))
    assert ep.current_seq == 4
    b = len(said(ep))
    rewrite(ep, gcs, dataclasses.replace(ep.mission[3], param2=0.2))
    drive(drv, ep, *[(2.5, 0.0)] * 40)
    assert RESTARTED not in said(ep)
    assert "speed: 0.2 m/s" in said(ep)[b:] and ep.desired_speed_mps == pytest.approx(0.2)


def test_an_upload_of_no_items_while_auto_drives_fails_the_restart_and_drives_on() -> None:
    # MISSION_COUNT 0: truncate(0) (_cmd_total 0); the detector finds no navigation item
    # (num_cmds 0 != cmd_count): restart_current_nav_cmd fails (index >= num_commands());
    # AP_Mission::update returns at once with _cmd_total 0, so the mission never completes,
    # and ModeAuto's WP submode drives on to the waypoint it had
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (2.0, 0.0), (4.0, 0.0))
    drive(drv, ep, (0.0, 0.0), (1.0, 0.0))
    assert ep.current_seq == 2
    b = len(said(ep))
    send(ep, gcs, mav.MAVLink_mission_count_message(1, 1, 0, 0))
    drive(drv, ep, (1.2, 0.0))
    assert said(ep)[b:] == ["Flight plan received", FAILED]
    assert drv.command[0] > 0.0 and not ep.mission_complete


def test_auto_entered_again_after_an_upload_resumes_at_the_do_command_that_held() -> None:
    # HOLD left with item 4 under way and the CONDITION_DELAY (item 2) still loaded as the
    # DO command; a new mission of four waypoints uploaded; AUTO: AP_Mission::resume ->
    # set_current_cmd(_do_cmd.index = 2) -> advance_current_nav_cmd(2): item 2 of the new
    # mission is a waypoint, started: "Mission: 2 WP", driven to (2, 5)
    drv, ep = bench("AUTO")
    store(
        ep,
        (2.0, 0.0),
        item(mav.MAV_CMD_CONDITION_DELAY, 100.0),
        item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3),
        (8.0, 0.0),
    )
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0), (2.5, 0.0))
    assert ep.current_seq == 4
    assert ep.set_mode(MODES["HOLD"])
    drive(drv, ep, (2.5, 0.0))
    store(ep, (1.0, 5.0), (2.0, 5.0), (3.0, 5.0), (4.0, 5.0))
    b = len(said(ep))
    assert ep.set_mode(MODES["AUTO"])
    drive(drv, ep, (2.5, 0.0))
    assert said(ep)[b:] == ["Mission: 2 WP"] and ep.current_seq == 2


def test_an_edit_past_a_jump_not_yet_used_up_restarts_nothing() -> None:
    # 1 wp, 2 DO_JUMP->1 x1, 3 wp, 4 wp; item 1 under way on lap 1. The detector's window is
    # three get_next_nav_cmd calls, which never count jumps (increment false): 1, 1, 1.
    # Item 3 is not in it: moving it restarts nothing
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (2.0, 0.0), item(mav.MAV_CMD_DO_JUMP, 1.0, 1.0), (4.0, 0.0), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0))
    assert ep.current_seq == 1
    b = len(said(ep))
    rewrite(ep, gcs, moved_to(ep.mission[3], 4.0, 2.0))
    drive(drv, ep, (0.5, 0.0))
    assert RESTARTED not in said(ep)[b:]


def test_a_frame_change_rover_stores_the_same_restarts_nothing() -> None:
    # mavlink_int_to_mission_cmd: GLOBAL_RELATIVE_ALT and GLOBAL_RELATIVE_ALT_INT both set
    # relative_alt = 1: the stored command is the same, the detector sees no change
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (3.0, 0.0), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0))
    b = len(said(ep))
    rewrite(ep, gcs, dataclasses.replace(ep.mission[1], frame=mav.MAV_FRAME_GLOBAL_RELATIVE_ALT))
    drive(drv, ep, (0.5, 0.0))
    assert RESTARTED not in said(ep)[b:]


def test_an_altitude_change_under_a_centimetre_restarts_nothing() -> None:
    # cmd.content.location.alt = packet.z * 100.0f, an integer (cm): +1 mm stores the same
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (3.0, 0.0), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0))
    b = len(said(ep))
    rewrite(ep, gcs, dataclasses.replace(ep.mission[1], z=ep.mission[1].z + 0.001))
    drive(drv, ep, (0.5, 0.0))
    assert RESTARTED not in said(ep)[b:]


# -- NAV_SET_YAW_SPEED and NAV_GUIDED_ENABLE in a mission -------------------------------------------


def heard(gcs: MemoryLink) -> list[str]:
    """What a ground station has heard since it last listened, in order: each STATUSTEXT's
    text, and "REACHED n" for each MISSION_ITEM_REACHED."""
    parser, got = mav.MAVLink(None), []
    for data, _addr in gcs.recv(100000):
        for m in parser.parse_buffer(data) or []:
            if m.get_type() == "STATUSTEXT":
                got.append(m.text)
            elif m.get_type() == "MISSION_ITEM_REACHED":
                got.append(f"REACHED {m.seq}")
    return got


def test_a_missions_set_yaw_speed_turns_to_the_heading_at_its_speed_then_stops_and_is_done() -> None:
    # Rover's do_nav_set_yaw_speed: absolute (param3 0), _desired_yaw_cd = 90 * 100 = 9000;
    # _desired_speed = 0.3 (within WP_SPEED). The HeadingAndSpeed submode steers to it at that
    # speed and sets _reached_heading once fabsf(9000 - yaw_sensor) < 500: at 80 deg (8000) it
    # is not, at 86 deg (8600) it is; then stop_vehicle(). verify_nav_set_yaw_speed returns
    # it at the mission's next update: MISSION_ITEM_REACHED 2, then "Mission: 3 WP".
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (2.0, 0.0), item(mav.MAV_CMD_NAV_SET_YAW_SPEED, 90.0, 0.3), (2.0, 4.0))
    drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))
    drv.update(2 * STEP_S, at(2.0, 0.0, t_s=2 * STEP_S))  # waypoint 1 reached; item 2 begins
    assert heard(gcs)[-3:] == ["Reached waypoint #1", "REACHED 1", "Mission: 2 SetYawSpd"]
    speed, rate = drv.update(3 * STEP_S, at(2.0, 0.0, math.radians(80.0), t_s=3 * STEP_S))
    assert speed == pytest.approx(0.3) and rate > 0.0 and ep.current_seq == 2
    speed, rate = drv.update(4 * STEP_S, at(2.0, 0.0, math.radians(86.0), t_s=4 * STEP_S))
    assert speed == pytest.approx(0.3) and ep.current_seq == 2  # reached as it steers: checked next
    assert heard(gcs) == []
    speed, _rate = drv.update(5 * STEP_S, at(2.0, 0.0, math.radians(86.0), t_s=5 * STEP_S))
    assert heard(gcs) == ["REACHED 2", "Mission: 3 WP"] and ep.current_seq == 3 and speed > 0.0


def test_a_relative_set_yaw_speed_below_zero_degrees_is_never_reached_and_its_speed_is_limited() -> None:
    # param3 1: wrap_180_cd(yaw_sensor + angle * 100) = wrap_180_cd(1000 - 10000) = -9000 from
    # 10 deg. Rover compares it with yaw_sensor (0-36000) unwrapped: pointing at -90 deg
    # (27000) the difference is 36000, so _reached_heading never holds and the item never
    # ends. Its speed is constrain_float(-3, -WP_SPEED, WP_SPEED): backwards at WP_SPEED.
    drv, ep, gcs = bench_and_gcs("AUTO")
    wp_speed = ep.param("WP_SPEED")
    store(ep, MissionItem(0, mav.MAV_FRAME_MISSION, mav.MAV_CMD_NAV_SET_YAW_SPEED, -100.0, -3.0, 1.0), (2.0, 0.0))
    drv.update(STEP_S, at(0.0, 0.0, math.radians(10.0), t_s=STEP_S))
    for k in range(2, 6):
        speed, _rate = drv.update(k * STEP_S, at(0.0, 0.0, math.radians(-90.0), t_s=k * STEP_S))
        assert speed == pytest.approx(-wp_speed)
    assert ep.current_seq == 1 and "REACHED 1" not in heard(gcs)


def test_a_missions_guided_enable_of_zero_is_done_at_the_next_update_and_one_is_passed_over() -> None:
    # do_nav_guided_enable starts guided only for cmd.p1 > 0; verify_nav_guided_enable returns
    # true for p1 0 (MISSION_ITEM_REACHED 2 at the mission's next update). p1 1 would wait for
    # an offboard computer's targets, which lfctl does not take in AUTO: passed over, as before.
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (2.0, 0.0), item(mav.MAV_CMD_NAV_GUIDED_ENABLE, 0.0), (2.0, 4.0))
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0))
    assert heard(gcs)[-2:] == ["REACHED 1", "Mission: 2 GuidedEnable"] and ep.current_seq == 2
    drive(drv, ep, (2.0, 0.0))
    assert heard(gcs) == ["REACHED 2", "Mission: 3 WP"] and ep.current_seq == 3
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (2.0, 0.0), item(mav.MAV_CMD_NAV_GUIDED_ENABLE, 1.0), (2.0, 4.0))
    drive(drv, ep, (0.0, 0.0), (2.0, 0.0))
    assert heard(gcs)[-3:] == ["REACHED 1", "Mission: 2 GuidedEnable", "Mission: 3 WP"] and ep.current_seq == 3


# -- a DO_CHANGE_SPEED straight after a circle ------------------------------------------------------


def test_the_first_speed_change_after_a_circle_is_the_circles_and_the_next_the_waypoints() -> None:
    # AP_Mission::advance_current_nav_cmd, after the circle is verified, starts the first DO
    # command (do_change_speed) before the waypoint: ModeAuto's submode is still Circle, so
    # set_desired_speed goes to ModeCircle ("speed: 0.3 m/s" said, the waypoints' speed not
    # set). The one after it starts once the waypoint's do_nav_wp has made the submode WP:
    # set_speed_max(0.25), the waypoints' speed.
    drv, ep = bench("AUTO")
    store(
        ep,
        circle_at(3.0, 0.0, turns=0.0),
        item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3),
        (9.0, 0.0),
        item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.25),
        (12.0, 0.0),
    )
    drv.update(STEP_S, at(0.0, 0.0, t_s=STEP_S))  # no turns: done at once, waypoint 3 begun
    assert ep.current_seq == 3 and "speed: 0.3 m/s" in said(ep) and ep.desired_speed_mps is None
    drive(drv, ep, (9.0, 0.0))
    assert ep.current_seq == 5 and ep.desired_speed_mps == 0.25


# -- MIS_RESTART ---------------------------------------------------------------------------------------


def test_mis_restart_1_starts_the_mission_from_its_first_item_when_auto_is_entered() -> None:
    # AP_Mission's MIS_RESTART (AP_Int8, default 0: resume); ModeAuto::update calls
    # start_or_resume(): with _restart == 1 start(), from item 1 with the jump counts reset
    for restart, current in ((0.0, 2), (1.0, 1)):
        drv, ep, gcs = bench_and_gcs("AUTO")
        send(ep, gcs, mav.MAVLink_param_set_message(1, 1, b"MIS_RESTART", restart, mav.MAV_PARAM_TYPE_INT8))
        assert ep.param("MIS_RESTART") == restart
        store(ep, (2.0, 0.0), (4.0, 0.0), (6.0, 0.0))
        drive(drv, ep, (0.0, 0.0), (2.0, 0.0))  # waypoint 1 reached: 2 under way
        assert ep.current_seq == 2
        assert ep.set_mode(MODES["HOLD"]) and ep.set_mode(MODES["AUTO"])
        drive(drv, ep, (-1.0, 0.0))  # (3 m from waypoint 1, 5 from 2: neither reached)
        assert ep.current_seq == current, restart
        assert said(ep)[-1] == f"Mission: {current} WP"


# -- the DO commands Rover's mode checks ----------------------------------------------------------------


def test_roi_is_said_done_and_control_video_skipped_as_rovers_verify_command_has_them() -> None:
    # ModeAuto::verify_command: DO_SET_ROI (and ROI_LOCATION, ROI_NONE in the newest source) is
    # one of its "do commands (always return true)": MISSION_ITEM_REACHED 2. DO_CONTROL_VIDEO is
    # in neither AP_Mission's verify list nor Rover's: "Skipping invalid cmd #200" and
    # MISSION_ITEM_REACHED 2. DO_SET_SERVO is AP_Mission's own: no MISSION_ITEM_REACHED.
    for command, words, done in (
        (mav.MAV_CMD_DO_SET_ROI, ["Mission 2: DO_SET_ROI not fitted"], ["REACHED 2"]),
        (mav.MAV_CMD_DO_SET_ROI_NONE, ["Mission 2: DO_SET_ROI_NONE not fitted"], ["REACHED 2"]),
        (mav.MAV_CMD_DO_CONTROL_VIDEO, [], ["Skipping invalid cmd #200", "REACHED 2"]),
        (mav.MAV_CMD_DO_SET_SERVO, ["Mission 2: DO_SET_SERVO not fitted"], []),
    ):
        drv, ep, gcs = bench_and_gcs("AUTO")
        store(ep, (2.0, 0.0), item(command, 5.0), (2.0, 6.0))
        drive(drv, ep, (0.0, 0.0))
        heard(gcs)
        drive(drv, ep, (2.0, 0.0))
        got = heard(gcs)
        start = got.index("Mission: 3 WP")
        assert got[start - len(words) : start] == words, command
        assert got[start + 1 :] == done, command


# -- NAV_LOITER_UNLIM with a radius ------------------------------------------------------------------


def test_a_loiter_for_ever_with_a_radius_says_it_as_a_wait() -> None:
    # mavlink_int_to_mission_cmd: NAV_LOITER_UNLIM's cmd.p1 = fabsf(param3) (5); do_nav_wp reads
    # cmd.p1 as loiter_duration; verify_nav_wp then says "Reached waypoint #1. Loiter for 5
    # seconds", though verify_loiter_unlimited never ends the item
    drv, ep = bench("AUTO")
    place = local_mission([(3.0, 0.0)], HOME)[1]
    store(ep, dataclasses.replace(place, command=mav.MAV_CMD_NAV_LOITER_UNLIM, param3=-5.0), (6.0, 0.0))
    drive(drv, ep, (0.0, 0.0), (3.0, 0.0), (3.0, 0.0))
    assert "Reached waypoint #1. Loiter for 5 seconds" in said(ep) and ep.current_seq == 1


# -- the first DO command's check ----------------------------------------------------------------------


def test_a_skipped_do_command_is_checked_after_the_next_waypoint_has_started() -> None:
    # AP_Mission::update: advance_current_nav_cmd starts the DO command ("Mission: 2
    # MountControl") and then the waypoint ("Mission: 3 WP"); only then does verify_command
    # (_do_cmd) reach Rover's default: "Skipping invalid cmd #205", MISSION_ITEM_REACHED 2. After
    # the last waypoint the mission completes before any check: nothing is skipped or done.
    drv, ep, gcs = bench_and_gcs("AUTO")
    store(ep, (2.0, 0.0), item(mav.MAV_CMD_DO_MOUNT_CONTROL), (2.0, 4.0), item(mav.MAV_CMD_DO_MOUNT_CONTROL))
    drive(drv, ep, (0.0, 0.0))
    heard(gcs)
    drive(drv, ep, (2.0, 0.0))
    assert heard(gcs) == [
        "Reached waypoint #1",
        "REACHED 1",
        "Mission: 2 MountControl",
        "Mission: 3 WP",
        "Skipping invalid cmd #205",
        "REACHED 2",
    ]
    drive(drv, ep, (2.0, 2.0), (2.0, 4.0))
    assert heard(gcs)[-3:] == ["REACHED 3", "Mission: 4 MountControl", "Mission Complete"]
