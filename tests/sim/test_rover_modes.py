"""A ground station's commands move the simulated vehicles as they would move ArduPilot
Rovers: "go here" in GUIDED (DO_REPOSITION, a MISSION_ITEM with current = 2), RTL to home
or the nearest rally point, SmartRTL back along the way, a fence breach sending the leader
home. Closed loop in lockstep, commands sent mid-run through the leader's link."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav
from support import LEADER_AND_FOLLOWER

from lfctl.config import parse_config
from lfctl.frames import ned_to_geodetic
from lfctl.sim.links import Links
from lfctl.sim.runner import RunReport, run_scenario

pytestmark = pytest.mark.fmu

SCENARIO = (
    """
name = "modes"
[sim]
duration_s = 40.0
"""
    + LEADER_AND_FOLLOWER
    + """
[mission]
waypoints = [[6.0, 0.0], [6.0, 6.0]]
cruise_speed_mps = 0.4
[guidance]
max_speed_mps = 0.5
"""
)


def run_with(
    commands: dict[float, Callable[[Links], None]],
    duration_s: float = 40.0,
    record_to: Path | None = None,
    scenario: str = SCENARIO,
) -> tuple[RunReport, Links]:
    """Run the scenario, sending ``commands[t]`` from a ground station at simulation time t."""
    cfg = parse_config(scenario, "modes")
    cfg = dataclasses.replace(cfg, sim=dataclasses.replace(cfg.sim, duration_s=duration_s))
    links: list[Links] = []
    pending = sorted(commands.items())
    steps = [0]

    def stop() -> bool:
        steps[0] += 1
        t = steps[0] * cfg.sim.dt_s
        while pending and t >= pending[0][0]:
            pending.pop(0)[1](links[0])
        return False

    return run_scenario(cfg, on_links=links.append, stop=stop, record_to=record_to), links[0]


GCS = mav.MAVLink(None, srcSystem=255, srcComponent=190)


def send(links: Links, msg: object) -> None:
    links.peers[0].send(msg.pack(GCS))  # type: ignore[attr-defined]


def mode(name: str) -> Callable[[Links], None]:
    from lfctl.link.endpoint import MODES

    return lambda links: send(
        links,
        mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_DO_SET_MODE, 0, 1, MODES[name], 0, 0, 0, 0, 0),
    )


def latlon(links: Links, north_m: float, east_m: float) -> tuple[int, int]:
    lat, lon, _ = ned_to_geodetic(north_m, east_m, 0.0, *links.home)
    return int(round(lat * 1e7)), int(round(lon * 1e7))


def leader_at(rep: RunReport, t_s: float) -> np.ndarray:
    k = int(np.argmin(np.abs(rep.result.t_s - t_s)))
    return rep.result.pos_ned_m[k, 0]


def reposition(north_m: float, east_m: float) -> Callable[[Links], None]:
    """A ground station's "go here" (DO_REPOSITION, switching to GUIDED) to a point from home."""

    def goto(links: Links) -> None:
        x, y = latlon(links, north_m, east_m)
        send(
            links,
            mav.MAVLink_command_int_message(
                1, 1, mav.MAV_FRAME_GLOBAL_INT, mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 1, 0, 0, x, y, 0
            ),
        )

    return goto


def test_reposition_in_guided_drives_the_leader_there_and_it_stops() -> None:
    rep, _links = run_with({5.0: reposition(-3.0, 4.0)}, duration_s=45.0)
    assert rep.leader_modes[0][0] == "AUTO" and any(name == "GUIDED" for name, _s in rep.leader_modes)
    end = leader_at(rep, 45.0)
    assert math.hypot(end[0] + 3.0, end[1] - 4.0) <= 0.5  # within WP_RADIUS-ish of the target
    assert rep.result.final.vehicle(0).speed_mps == pytest.approx(0.0, abs=0.02)  # and stopped there


def test_a_guided_mission_item_is_a_go_here_too() -> None:
    def goto(links: Links) -> None:
        x, y = latlon(links, 2.0, -3.0)
        send(
            links,
            mav.MAVLink_mission_item_int_message(
                1, 1, 0, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 16, 2, 1, 0, 0, 0, 0, x, y, 0, 0
            ),
        )

    rep, _links = run_with({4.0: mode("GUIDED"), 4.5: goto}, duration_s=40.0)
    end = leader_at(rep, 40.0)
    assert math.hypot(end[0] - 2.0, end[1] + 3.0) <= 0.5


def test_a_guided_target_off_the_earth_is_refused_by_name_and_one_far_south_is_driven_to() -> None:
    # 1e38 m north once ended the run: the destination's latitude did not fit
    # POSITION_TARGET_GLOBAL_INT (struct.error in the telemetry, "internal error")
    def far(x: float, y: float, frame: int = mav.MAV_FRAME_LOCAL_NED) -> Callable[[Links], None]:
        mask = 0b110111111000  # the position only
        msg = mav.MAVLink_set_position_target_local_ned_message(0, 1, 1, frame, mask, x, y, 0, 0, 0, 0, 0, 0, 0, 0, 0)
        return lambda links: send(links, msg)

    sent: list[object] = []

    def watch(links: Links) -> None:
        links.endpoints[0].tap = lambda d, m, raw: sent.append(m) if d == "out" else None

    rep, links = run_with(
        {
            1.0: watch,
            4.0: mode("GUIDED"),
            4.5: far(1e38, 0.0),
            5.0: far(3e37, -3e37, mav.MAV_FRAME_BODY_OFFSET_NED),
            5.5: far(-1e9, 1e9, mav.MAV_FRAME_LOCAL_OFFSET_NED),
            6.0: far(-9.9e6, 0.0),  # 89 deg south of home: on the Earth
        },
        duration_s=8.0,
    )
    ep = links.endpoints[0]
    texts = [t for _t, t in ep.statustexts if "off the Earth" in t]
    assert len(texts) == 3, texts  # the body frame's is turned by the leader's heading
    assert texts[0] == "Ignoring SET_POSITION_TARGET_LOCAL_NED; target 1e+38 m N 0 m E is off the Earth"
    assert texts[2] == "Ignoring SET_POSITION_TARGET_LOCAL_NED; target -1e+09 m N 1e+09 m E is off the Earth"
    assert ep.stats.send_errors == 0 and ep.stats.handler_errors == 0
    assert ep.guided is not None and ep.guided.north_m == -9.9e6  # the one on the Earth is taken
    targets = [m for m in sent if m.get_type() == "POSITION_TARGET_GLOBAL_INT"]  # type: ignore[attr-defined]
    assert targets and targets[-1].lat_int < -75e7  # type: ignore[attr-defined]  # and flown towards
    assert rep.leader_modes[-1][0] == "GUIDED"


def test_rtl_returns_to_the_nearest_of_home_and_the_rally_points() -> None:
    def rally(links: Links) -> None:
        x, y = latlon(links, 6.0, 2.0)  # nearer than home once the leader is at the first waypoint
        ep = links.endpoints[0]
        from lfctl.link.mission import MissionItem
        from lfctl.link.mission_server import RALLY

        ep.missions.store(RALLY, [MissionItem(0, mav.MAV_FRAME_GLOBAL_INT, mav.MAV_CMD_NAV_RALLY_POINT, x=x, y=y)])

    def rtl(links: Links) -> None:
        send(links, mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0, 0, 0, 0, 0, 0, 0, 0))

    home_run, _links = run_with({12.0: rtl}, duration_s=45.0)
    end = leader_at(home_run, 45.0)
    assert math.hypot(*end) <= 0.5  # home: where it armed
    rally_run, _links = run_with({1.0: rally, 16.0: rtl}, duration_s=40.0)
    end = leader_at(rally_run, 40.0)
    assert math.hypot(end[0] - 6.0, end[1] - 2.0) <= 0.5


def test_smart_rtl_goes_back_the_way_it_came() -> None:
    rep, _links = run_with({34.0: mode("SMART_RTL")}, duration_s=80.0)
    assert any(name == "SMART_RTL" for name, _s in rep.leader_modes)
    track = rep.result.pos_ned_m[:, 0]
    after = rep.result.t_s >= 40.0
    # on the way back it passes the first waypoint (6, 0) again, unlike a straight RTL (which
    # passes 4.2 m from it); its breadcrumbs are SRTL_ACCURACY (2 m) apart, taken at 3 Hz, so
    # the corner is cut by up to about 1.4 m
    assert np.min(np.hypot(track[after, 0] - 6.0, track[after, 1])) <= 1.5
    assert math.hypot(*track[-1]) <= 0.8


def test_a_speed_change_on_the_way_back_keeps_the_way_back() -> None:
    # DO_CHANGE_SPEED part-way through SmartRTL (at 50 s, past the corner at (6, 0)): the
    # same way home, slower, as Rover's ModeSmartRTL::set_desired_speed; not from its start again
    def slower(links: Links) -> None:
        send(links, mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_DO_CHANGE_SPEED, 0, 1, 0.3, 0, 0, 0, 0, 0))

    rep, _links = run_with({34.0: mode("SMART_RTL"), 50.0: slower}, duration_s=80.0)
    t, track = rep.result.t_s, rep.result.pos_ned_m[:, 0]
    # never back up the second leg towards (6, 6): east only falls from the change on
    assert np.max(np.diff(track[t >= 50.0, 1])) <= 0.01 and np.max(track[t >= 50.0, 1]) <= 2.0
    assert np.median(np.abs(rep.result.speed_mps[(t > 53.0) & (t < 60.0), 0])) == pytest.approx(0.3, abs=0.02)
    assert math.hypot(*track[-1]) <= 0.8


def test_a_speed_set_after_the_mission_ends_does_not_fly_its_last_leg_again() -> None:
    # a ground station loads its parameter file once the mission is done: WP_SPEED comes back
    # as float32 (0.4 -> 0.4000000059604645); AUTO stays where it ended, each waypoint once
    def wp_speed(links: Links) -> None:
        send(links, mav.MAVLink_param_set_message(1, 1, b"WP_SPEED", 0.4, mav.MAV_PARAM_TYPE_REAL32))

    def clear(links: Links) -> None:
        send(links, mav.MAVLink_mission_clear_all_message(1, 1, mav.MAV_MISSION_TYPE_MISSION))

    rep, _links = run_with({45.0: wp_speed, 47.0: clear}, duration_s=50.0)
    # counted against the mission flown, not the (cleared) one at the end: 2 of 2, not 2 of 0
    assert [i for i, _t in rep.waypoints_reached] == [0, 1] and rep.n_waypoints == 2
    assert all(t < 45.0 for _i, t in rep.waypoints_reached)
    assert math.hypot(*(leader_at(rep, 50.0) - leader_at(rep, 44.0))) <= 0.05


def test_a_second_mission_is_counted_on_its_own_in_the_summary_and_the_audit(tmp_path: Path) -> None:
    # the scenario's 2 waypoints flown, then a client's mission of 1 replaces it: the vehicle
    # stays where it finished (AP_Mission's state stays MISSION_COMPLETE over an upload) until
    # AUTO is entered again, which flies the new one from its first item: 1/1 (every arrival
    # listed), not "2/1"; the audit of the run's log says the same
    from lfctl.link.mission import local_mission
    from lfctl.link.mission_server import MISSION
    from lfctl.record.audit import audit

    def replace(links: Links) -> None:
        links.endpoints[0].missions.store(MISSION, local_mission([(0.0, 3.0)], links.home), 255, 190, uploaded=True)

    commands = {34.0: replace, 38.0: mode("HOLD"), 38.5: mode("AUTO")}
    rep, _links = run_with(commands, duration_s=65.0, record_to=tmp_path / "m.mcap")
    assert [i for i, _t in rep.waypoints_reached] == [0, 1, 0]
    assert math.hypot(*(leader_at(rep, 38.0) - leader_at(rep, 34.0))) <= 0.05  # still, until AUTO again
    assert (rep.n_reached, rep.n_waypoints) == (1, 1)
    fig = audit(tmp_path / "m.mcap").figures
    assert (fig["waypoints_reached"], fig["waypoints"]) == (1, 1) and len(fig["mission"]) == 3


def test_nothing_reached_after_a_clear_counts_against_the_cleared_mission_in_both(tmp_path: Path) -> None:
    from lfctl.record.audit import audit

    def clear(links: Links) -> None:
        send(links, mav.MAVLink_mission_clear_all_message(1, 1, mav.MAV_MISSION_TYPE_MISSION))

    rep, _links = run_with({1.0: mode("HOLD"), 2.0: clear}, duration_s=4.0, record_to=tmp_path / "c.mcap")
    fig = audit(tmp_path / "c.mcap").figures
    assert (rep.n_reached, rep.n_waypoints) == (fig["waypoints_reached"], fig["waypoints"]) == (0, 0)
    assert fig["mission_changes_s"] == [pytest.approx(2.0, abs=0.1)]


def test_a_fence_breach_sends_the_leader_home() -> None:
    def fence(links: Links) -> None:
        ep = links.endpoints[0]
        ep.params["FENCE_ENABLE"].value = 1
        ep.params["FENCE_TYPE"].value = 2  # the circle around home
        ep.params["FENCE_RADIUS"].value = 4.0  # a test yard (below Rover's 30 m minimum): the route leaves it

    rep, links = run_with({0.5: fence}, duration_s=60.0)
    assert "RTL" in [name for name, _s in rep.leader_modes]
    assert links.endpoints[0].fence_breaches >= 1  # (breached, counted; Rover says nothing of it)
    assert "Manual recovery started" in [text for _t, text in links.endpoints[0].statustexts]
    assert math.hypot(*leader_at(rep, 60.0)) <= 0.8


def test_vfr_hud_throttle_follows_each_vehicles_speed_command() -> None:
    # the run sets each vehicle's CRUISE_SPEED to its WP_SPEED: cruising, the throttle reads
    # CRUISE_THROTTLE (50 %); a ground station then stops the leader in HOLD
    seen: dict[float, list[tuple[int, float, float]]] = {}

    def sample(t: float) -> Callable[[Links], None]:
        def at(links: Links) -> None:
            seen[t] = [
                (ep.throttle_pct(), ep.state["speed_cmd_mps"], ep.param("CRUISE_SPEED")) for ep in links.endpoints
            ]

        return at

    run_with({5.0: sample(5.0), 8.0: mode("HOLD"), 10.0: sample(10.0)}, duration_s=11.0)
    (lead, command, cruise), (follower, f_command, f_cruise) = seen[5.0]
    assert (cruise, f_cruise) == (0.4, 0.5)  # [mission] cruise_speed_mps, [guidance] max_speed_mps
    assert command == pytest.approx(0.4, abs=0.02) and lead == 50  # AUTO, mid-leg at its cruise
    assert f_command > 0.05 and follower == int(f_command * 50 / 0.5)  # following: what its command needs
    assert seen[10.0][0][0] == 0  # HOLD: commanded to stop


def test_nav_controller_output_follows_the_leaders_destination() -> None:
    seen: dict[float, tuple[object, float, float, object]] = {}
    targets: dict[float, tuple[float, float] | None] = {}

    def sample(t: float) -> Callable[[Links], None]:
        def at(links: Links) -> None:
            ep = links.endpoints[0]
            seen[t] = (wire_nav(links), ep.state["north_m"], ep.state["east_m"], links.endpoints[1].nav)
            targets[t] = target_ned(links)

        return at

    goal = (1.0, 4.0)  # GUIDED "go here" (DO_REPOSITION) after the second leg has begun
    run_with(
        {
            4.0: sample(4.0),
            **{t: sample(t) for t in (18.0, 19.0, 20.0, 21.0, 22.0)},
            24.0: mode("GUIDED"),
            24.1: lambda links: send(
                links,
                mav.MAVLink_command_int_message(
                    1, 1, mav.MAV_FRAME_GLOBAL_INT, mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, 0,
                    *latlon(links, *goal), 0,
                ),
            ),
            26.0: sample(26.0),
            27.0: mode("HOLD"),
            28.0: sample(28.0),
        },
        duration_s=29.0,
    )  # fmt: skip
    nav, n, e, follower = seen[4.0]
    assert nav is not None and follower is None  # AUTO; the follower drives on setpoints
    assert nav.wp_dist == int(math.hypot(6.0 - n, 0.0 - e))  # to waypoint (6, 0), whole metres
    assert nav.target_bearing in (0, 359) and nav.nav_bearing in (0, 1, 358, 359)
    offsets = []
    for t in (18.0, 19.0, 20.0, 21.0, 22.0):  # on the second leg, (6, 0) to (6, 6), heading east
        nav, n, e, _ = seen[t]
        assert nav is not None and nav.target_bearing in range(60, 121)
        # Rover's sign: + left (north) of the leg; the guidance ran up to 1/20 s before
        assert nav.xtrack_error == pytest.approx(n - 6.0, abs=0.005)
        offsets.append(abs(n - 6.0))
    assert max(offsets) > 0.02  # off the leg by more than the tolerance: the sign is tested
    nav, n, e, _ = seen[26.0]
    assert nav is not None and nav.wp_dist == int(math.hypot(goal[0] - n, goal[1] - e))
    assert seen[28.0][0] is None  # HOLD: no destination, nothing sent
    # where it is going (POSITION_TARGET_GLOBAL_INT): the waypoint, the next one, the goal, none
    assert targets[4.0] == pytest.approx((6.0, 0.0), abs=0.01)
    assert targets[20.0] == pytest.approx((6.0, 6.0), abs=0.01)
    assert targets[26.0] == pytest.approx(goal, abs=0.01) and targets[28.0] is None


def wire_nav(links: Links, msg_id: int = mav.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT) -> object | None:
    """The leader's NAV_CONTROLLER_OUTPUT (or ``msg_id``) as it would go out now, decoded
    (None: not sent)."""
    links.peers[0].recv()  # what the run sent before
    links.endpoints[0]._send_by_id(msg_id)
    parser = mav.MAVLink(None)
    got = [m for data, _ in links.peers[0].recv() for m in parser.parse_buffer(data) or []]
    return got[-1] if got else None


def target_ned(links: Links) -> tuple[float, float] | None:
    """The leader's POSITION_TARGET_GLOBAL_INT as it would go out now, in local NED."""
    from lfctl.link.guided import global_to_local

    m = wire_nav(links, mav.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT)
    return None if m is None else global_to_local(m.lat_int, m.lon_int, links.home)


def test_the_nav_report_is_the_waypoint_guidances_and_a_reversed_body_heads_the_other_way() -> None:
    from lfctl.guidance.los import LosOutput
    from lfctl.sim.driver import _nav_report

    los = LosOutput(0.3, 0.2, 0.5, 0.25, 4.0, 1, (), False)
    from lfctl.link.endpoint import NavReport

    assert _nav_report(los, False, [(5.0, 6.0)]) == NavReport(0.3, 0.5, 4.0, 0.25, (5.0, 6.0))
    reversed_ = _nav_report(los, True, [(5.0, 6.0)])
    assert reversed_ is not None and reversed_.nav_bearing_rad == pytest.approx(0.3 + math.pi)
    assert _nav_report(los, False, []) is None  # no waypoints, no destination


def test_a_mission_of_home_alone_in_auto_stops_the_leader_and_reports_no_destination() -> None:
    # a ground station may upload a mission of item 0 alone (MISSION_COUNT 1) once one is done
    from lfctl.link.endpoint import MODES

    seen: dict[str, object] = {}

    def home_only(links: Links) -> None:
        ep = links.endpoints[0]
        ep.store_mission([ep._home_item()])

    def look(links: Links) -> None:
        ep = links.endpoints[0]
        seen.update(mode=ep.mode, nav=ep.nav, target=wire_nav(links, mav.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT))

    report, _ = run_with({2.0: home_only, 3.0: look}, duration_s=4.0)
    assert seen == {"mode": MODES["AUTO"], "nav": None, "target": None}
    assert abs(report.result.final.speed_mps[0]) < 0.05  # nothing to drive to: it has stopped


def test_manual_drives_the_leader_by_the_ground_stations_sticks() -> None:
    # MANUAL, as a ground station's RC override drives a Rover: throttle 1622 us is
    # 100 x (1622 - 1530) / 370 = 24 % (Rover's whole percent) of full throttle, which Rover
    # projects from CRUISE_SPEED 0.4 m/s at CRUISE_THROTTLE 50 % as 0.8 m/s: 0.192 m/s; 1378 us
    # the same backwards. Steering 1567 us (10 % right) turns right going forward and, as a
    # car's steering, left backing up: +-10 % of 90 deg/s commanded, of which the skid-steer
    # rover's skid factor (0.8, its FMU's default) achieves 7.2 deg/s. Sent every second, the
    # sticks stop 3 s after the last.
    forward = mav.MAVLink_rc_channels_override_message(1, 1, 1567, 0, 1622, 0, 0, 0, 0, 0)
    backward = mav.MAVLink_rc_channels_override_message(1, 1, 1567, 0, 1378, 0, 0, 0, 0, 0)
    commands: dict[float, Callable[[Links], None]] = {2.0: mode("MANUAL")}
    for t in range(3, 12):
        commands[float(t)] = lambda links: send(links, forward)
    for t in range(12, 21):
        commands[float(t)] = lambda links: send(links, backward)
    rep, _links = run_with(commands, duration_s=27.0)
    assert [name for name, _s in rep.leader_modes][:2] == ["AUTO", "MANUAL"]
    t, speed, yaw = rep.result.t_s, rep.result.speed_mps[:, 0], np.unwrap(rep.result.yaw_rad[:, 0])
    for legs, sign in (((t >= 6.0) & (t <= 12.0), 1.0), ((t >= 15.0) & (t <= 21.0), -1.0)):
        assert np.median(speed[legs]) == pytest.approx(sign * 0.192, abs=0.005)
        rate = np.polyfit(t[legs], yaw[legs], 1)[0]
        assert math.degrees(rate) == pytest.approx(sign * 7.2, abs=0.3)
    assert np.max(np.abs(speed[t >= 25.0])) < 0.02  # 3 s after the last override: stopped


def test_a_speed_change_in_rtl_takes_effect_and_does_not_outlive_the_mode() -> None:
    # RTL drives at RTL_SPEED, else WP_SPEED (0.4 m/s here); DO_CHANGE_SPEED in RTL changes it
    # at once (Rover's ModeRTL::set_desired_speed); entering AUTO again starts at its default
    def rtl(links: Links) -> None:
        send(links, mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0, 0, 0, 0, 0, 0, 0, 0))

    def slower(links: Links) -> None:
        send(links, mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_DO_CHANGE_SPEED, 0, 1, 0.2, 0, 0, 0, 0, 0))

    rep, links = run_with({14.0: rtl, 22.0: slower, 28.0: mode("AUTO")}, duration_s=29.0)
    t, speed = rep.result.t_s, np.abs(rep.result.speed_mps[:, 0])
    # (it turns back first, slowing in the turn)
    assert np.median(speed[(t > 19.0) & (t < 22.0)]) == pytest.approx(0.4, abs=0.02)
    assert np.median(speed[(t > 24.0) & (t < 28.0)]) == pytest.approx(0.2, abs=0.02)
    assert links.endpoints[0].desired_speed_mps is None  # AUTO entered again: its own speed


def test_system_time_is_on_the_logs_clock(tmp_path) -> None:
    # SYSTEM_TIME's UTC is the run's start plus the simulation time, as the log stamps its
    # messages: a ground station's clock and the log's agree
    import json

    from mcap.reader import make_reader

    cfg = parse_config(SCENARIO, "modes")
    cfg = dataclasses.replace(cfg, sim=dataclasses.replace(cfg.sim, duration_s=4.0))
    links: list[Links] = []
    steps = [0]

    def stop() -> bool:
        steps[0] += 1
        if steps[0] * cfg.sim.dt_s >= 2.0 and steps[0] * cfg.sim.dt_s < 2.0 + cfg.sim.dt_s:
            request = (mav.MAVLINK_MSG_ID_SYSTEM_TIME, 0, 0, 0, 0, 0, 0)
            send(links[0], mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, *request))
        return False

    path = tmp_path / "run.mcap"
    run_scenario(cfg, record_to=path, on_links=links.append, stop=stop)
    with open(path, "rb") as f:
        sent = [
            (message.log_time, json.loads(message.data))
            for _schema, channel, message in make_reader(f).iter_messages(topics=["/mavlink/leader"])
        ]
    times = [(t, r["fields"]) for t, r in sent if r["direction"] == "out" and r.get("name") == "SYSTEM_TIME"]
    # streamed at 1 Hz (the EXTRA3 group's default) and once more when asked for, at 2 s
    assert len(times) == 5
    for log_time_ns, fields in times:
        assert abs(fields["time_unix_usec"] * 1000 - log_time_ns) < 1e6  # within 1 ms
    assert sorted(fields["time_boot_ms"] for _t, fields in times) == pytest.approx([0, 1000, 2000, 2000, 3000], abs=100)


# -- a review of GUIDED, RTL and SmartRTL against Rover's source ----------------------------------
def test_smart_rtl_uses_up_its_way_back_and_a_second_one_stays_home() -> None:
    # AP_SmartRTL::pop_point: each point driven to is gone; SmartRTL entered again at home
    # stops there (it drove back out to (6, 6) and home again)
    rep, links = run_with({34.0: mode("SMART_RTL"), 70.0: mode("HOLD"), 72.0: mode("SMART_RTL")}, duration_s=90.0)
    t, track = rep.result.t_s, rep.result.pos_ned_m[:, 0]
    assert math.hypot(*track[np.argmin(np.abs(t - 70.0))]) <= 0.8  # home after the first
    assert np.max(np.hypot(track[t >= 72.0, 0], track[t >= 72.0, 1])) <= 0.9  # and stays
    assert links.endpoints[0].path == []
    said = [s for _t, s in links.endpoints[0].statustexts]
    assert said.count("Reached destination") == 2


def test_smart_rtl_does_not_drive_the_loop_its_way_out_made() -> None:
    # out 8 m, left 4, back 4 and across the first leg at (4, 0) to (4, -3): SmartRTL from
    # there drives to the crossing and home (AP_SmartRTL prunes the loop), not round (8, 4)
    looped = SCENARIO.replace(
        "waypoints = [[6.0, 0.0], [6.0, 6.0]]", "waypoints = [[8.0, 0.0], [8.0, 4.0], [4.0, 4.0], [4.0, -3.0]]"
    )
    rep, links = run_with({62.0: mode("SMART_RTL")}, duration_s=90.0, scenario=looped)
    t, track = rep.result.t_s, rep.result.pos_ned_m[:, 0]
    assert math.hypot(track[np.argmin(np.abs(t - 62.0)), 0] - 4.0, track[np.argmin(np.abs(t - 62.0)), 1] + 3.0) < 0.5
    back = track[t >= 62.0]
    assert np.max(back[:, 0]) < 5.0 and np.max(back[:, 1]) < 1.0  # never out to (8, 0) nor up to (8, 4)
    assert math.hypot(*track[-1]) <= 0.8
    assert "Reached destination" in [s for _t, s in links.endpoints[0].statustexts]


def test_arming_starts_the_way_back_afresh() -> None:
    from lfctl.link.endpoint import MODES

    ep = run_with({}, duration_s=5.0)[1].endpoints[0]
    assert ep.path and ep.path_started
    ep.set_armed(False)
    ep.set_armed(True)  # AP_Arming_Rover::arm: smart_rtl.set_home, the old trips forgotten
    assert ep.path == [] and ep.set_mode(MODES["SMART_RTL"])


def test_rtl_keeps_the_place_it_chose_as_it_began() -> None:
    # ModeRTL::_enter picks home (or a rally point) once: home moved on the way does not turn it
    def rtl(links: Links) -> None:
        send(links, mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0, 0, 0, 0, 0, 0, 0, 0))

    def move_home(links: Links) -> None:
        x, y = latlon(links, 6.0, 6.0)
        send(
            links,
            mav.MAVLink_command_int_message(
                1, 1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, 0, 0, x, y, 0
            ),
        )

    rep, links = run_with({16.0: rtl, 19.0: move_home}, duration_s=50.0)
    assert links.endpoints[0].home_point() == pytest.approx((6.0, 6.0), abs=0.05)
    assert math.hypot(*leader_at(rep, 50.0)) <= 0.3  # the home it set out for


@pytest.mark.parametrize("type_mask", [455, 511])  # velocity + yaw + yaw rate; yaw + yaw rate
def test_a_setpoint_giving_both_yaw_and_yaw_rate_is_ignored_as_rover_ignores_it(type_mask: int) -> None:
    def go(links: Links) -> None:
        send(
            links,
            mav.MAVLink_set_position_target_local_ned_message(
                0, 1, 1, mav.MAV_FRAME_LOCAL_NED, type_mask, 0, 0, 0, 0.3, 0, 0, 0, 0, 0, 1.5, 0.0
            ),
        )

    moves = {2.0: mode("GUIDED"), **{2.5 + 0.2 * k: go for k in range(20)}}
    rep, _links = run_with(moves, duration_s=7.0)
    t = rep.result.t_s
    assert np.max(np.abs(rep.result.speed_mps[t > 3.0, 0])) < 0.02
    yaw = np.unwrap(rep.result.yaw_rad[:, 0])
    assert abs(yaw[-1] - yaw[np.argmin(np.abs(t - 2.5))]) < 0.02


def test_a_reposition_outside_the_fence_leaves_the_vehicle_in_guided_stopped() -> None:
    # handle_command_int_do_reposition enters GUIDED first; the place outside the fence then
    # FAILS (it stayed in AUTO and drove on)
    from lfctl.link.endpoint import MODES

    def fence(links: Links) -> None:
        for name, value in ((b"FENCE_TYPE", 2.0), (b"FENCE_RADIUS", 30.0), (b"FENCE_ENABLE", 1.0)):
            send(links, mav.MAVLink_param_set_message(1, 1, name, value, mav.MAV_PARAM_TYPE_REAL32))

    def away(links: Links) -> None:
        x, y = latlon(links, 60.0, 0.0)
        send(
            links,
            mav.MAVLink_command_int_message(
                1, 1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 1, 0, 0, x, y, 0
            ),
        )

    rep, links = run_with({1.0: fence, 5.0: away}, duration_s=12.0)
    ep = links.endpoints[0]
    assert ep.mode == MODES["GUIDED"] and ep.guided is None
    assert abs(rep.result.final.vehicle(0).speed_mps) < 0.02


def test_auto_entered_disarmed_starts_the_mission_and_the_vehicle_stays_still() -> None:
    # Rover's ModeAuto runs the mission from the moment AUTO is entered, armed or not
    # (ModeAuto::update starts it, AP_Mission says "Mission: 1 WP"): a ground station sees
    # the item under way before it arms; the disarmed motors do not move the vehicle
    def disarm(links: Links) -> None:
        send(links, mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0))

    rep, links = run_with({0.5: mode("HOLD"), 1.0: disarm, 2.0: mode("AUTO")}, duration_s=5.0)
    ep = links.endpoints[0]
    assert not ep.armed and rep.leader_modes[-1][0] == "AUTO"
    assert (2.0, "Mission: 1 WP") in [(round(t, 1), text) for t, text in ep.statustexts if t >= 2.0]
    assert ep.current_seq == 1  # MISSION_CURRENT names item 1, as Rover's
    assert rep.result.final.vehicle(0).speed_mps == pytest.approx(0.0, abs=0.02)
    assert math.hypot(*(leader_at(rep, 5.0) - leader_at(rep, 2.0))) < 0.05


@pytest.mark.parametrize("where", ["GUIDED", "RTL"])
def test_a_disarmed_vehicle_in_guided_or_rtl_reports_where_it_would_steer_and_stays_still(where: str) -> None:
    # Rover's mode update runs every loop, armed or not: a ground station sees the distance
    # and bearing to the place (NAV_CONTROLLER_OUTPUT) as soon as it gives the place, before
    # it arms; the disarmed motors do not move the vehicle
    def disarm(links: Links) -> None:
        send(links, mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0))

    seen: list[object] = []
    commands = {3.0: mode("HOLD"), 3.5: disarm, 4.0: reposition(-3.0, 4.0) if where == "GUIDED" else mode("RTL")}
    commands[5.0] = lambda links: seen.append(links.endpoints[0].nav)
    rep, links = run_with(commands, duration_s=6.0)
    ep = links.endpoints[0]
    assert not ep.armed and rep.leader_modes[-1][0] == where
    nav = seen[0]
    assert nav is not None  # (None: nothing sent)
    here = leader_at(rep, 5.0)
    if where == "GUIDED":
        assert nav.distance_m > 0.2  # not there yet, and says how far
    else:  # home follows a disarmed vehicle (Rover's update_home): RTL's place is where it is
        assert nav.distance_m < 0.05
    assert nav.distance_m == pytest.approx(math.hypot(*(here - np.array(nav.destination_ned_m))), abs=0.05)
    assert math.hypot(*(leader_at(rep, 6.0) - leader_at(rep, 4.0))) < 0.05


def test_the_simulators_vehicles_carry_lfcts_code_digest_where_a_rover_has_its_git_hash() -> None:
    # AUTOPILOT_VERSION's flight_custom_version: QGroundControl shows it as the firmware's git hash
    from lfctl.data import loaded_code

    _rep, links = run_with({}, duration_s=0.1)
    assert bytes(links.endpoints[0].custom_version).decode("ascii") == loaded_code()[:8]
