"""Waypoint guidance (los.py) and the leader's autopilot (leader.py) worked by hand where the
full mutation run of the two modules found nothing pinning them: routes that start away from
home, a short leg overshot, mission items on one point, the output once done, the turn at the
next waypoint, waits and the speed near a stop.

Each test says what a user would see if the number were wrong, and the number worked by hand
from the code's equations and docstrings (in the comments)."""

from __future__ import annotations

import math

import pytest

from lfctl.guidance.leader import AutopilotSettings, LeaderAutopilot
from lfctl.guidance.los import WaypointFollower, along_track_m

# --- los.py -------------------------------------------------------------------------------


def test_the_distance_along_a_segment_away_from_east_zero_counts_its_own_east_extent() -> None:
    # Wrong, on any leg not starting at east 0 the leader would misjudge how far along it is.
    # By hand: the leg (0, 2) -> (2, 2) runs 2 m north; (1, 3) is (1, 1) from its start:
    # (1 * 2 + 1 * 0) / 2 = 1 m along.
    assert along_track_m(1.0, 3.0, (0.0, 2.0), (2.0, 2.0)) == pytest.approx(1.0, abs=1e-12)


def test_a_lookahead_of_zero_is_refused() -> None:
    # Wrong, a lookahead of 0 would be accepted and steer bang-bang (atan2(e, 0) = +-90 deg).
    with pytest.raises(ValueError, match="lookahead_m"):
        WaypointFollower([(1.0, 0.0)], 0.3, 0.0)


def test_a_route_starting_away_from_home_runs_its_first_leg_from_the_start() -> None:
    # Wrong, a leader starting anywhere but home would steer its first leg from the wrong
    # point and count a waypoint it overshot as not reached.
    # By hand: start (2, 1), first waypoint (2, 5): the leg runs 4 m east, path angle pi/2;
    # on it at the start: no cross-track, 4 m to go.
    route = [(2.0, 5.0), (6.0, 5.0)]
    out = WaypointFollower(route, 0.3, 0.8, (2.0, 1.0)).step(2.0, 1.0, math.pi / 2)
    assert (out.heading_cmd_rad, out.path_angle_rad, out.los_angle_rad) == pytest.approx((math.pi / 2,) * 3, abs=1e-12)
    assert (out.cross_track_m, out.distance_to_go_m) == pytest.approx((0.0, 4.0), abs=1e-12)
    # The same through the leader's autopilot.
    ap = LeaderAutopilot(route, AutopilotSettings(), (2.0, 1.0))
    assert ap.step(0.0, 2.0, 1.0, math.pi / 2, 0.1).los.path_angle_rad == pytest.approx(math.pi / 2, abs=1e-12)
    # At (2.5, 5.5), overshot: 0.707 m from (2, 5) (outside 0.3) but 4.5 m along a 4 m leg:
    # past its perpendicular, reached; 0.5 m along the 4 m leg to (6, 5): not that one.
    out = WaypointFollower(route, 0.3, 0.8, (2.0, 1.0)).step(2.5, 5.5, math.pi / 2)
    assert (out.reached, out.active_index) == ((0,), 1)


def test_a_short_leg_overshot_is_passed_not_driven_back_to() -> None:
    # Wrong, a leader that overshot a short leg would turn back to its waypoint (the wide turn
    # circling back the docstring rules out).
    # By hand: (0, 2), (0.4, 2), (5, 2); at (1, 2): 2 m along the first 2 m leg (passed), then
    # 1 m along the 0.4 m leg (passed), 0.6 m along the 4.6 m third: reached (0, 1), active 2.
    out = WaypointFollower([(0.0, 2.0), (0.4, 2.0), (5.0, 2.0)], 0.3, 0.8).step(1.0, 2.0, 0.0)
    assert (out.reached, out.active_index) == ((0, 1), 2)


def test_a_stop_on_the_point_just_reached_is_reached_at_once() -> None:
    # Wrong, a mission item waiting where the one before ended (a LOITER_TIME on the waypoint)
    # would be driven onto again from where the leader is, as if it were a new leg.
    # By hand: (0, 1), then a stop at (0, 1) again, then (0, 3); at (0, 0.8): inside 0.3 of the
    # first (0.2 m); the stop's leg has no length: reached at once. (0, 3): -0.2 m along: not.
    wf = WaypointFollower([(0.0, 1.0), (0.0, 1.0), (0.0, 3.0)], 0.3, 0.8, stops=lambda i: i == 1)
    out = wf.step(0.0, 0.8, math.pi / 2)
    assert (out.reached, out.active_index) == ((0, 1), 2)


def test_a_finished_route_reports_the_distance_to_its_last_waypoint_and_no_cross_track() -> None:
    # Wrong, a ground station would be told the leader is on its last waypoint when it stopped
    # short of it, or get a cross-track for a route already done; an empty route would fail.
    # By hand: (0, 0) -> (0, 10), radius 0.3; at (0, 9.8): 0.2 m off, inside: done, 0.2 m to
    # go, cross-track 0, the heading held. An empty route: done at once, 0 m to go.
    out = WaypointFollower([(0.0, 10.0)], 0.3, 1.0).step(0.0, 9.8, 0.3)
    assert out.done and out.reached == (0,)
    assert (out.distance_to_go_m, out.cross_track_m) == pytest.approx((0.2, 0.0), abs=1e-12)
    assert out.cross_track_m == 0.0
    out = WaypointFollower([], 0.3, 1.0).step(1.0, 2.0, 0.5)
    assert out.done and (out.heading_cmd_rad, out.distance_to_go_m) == (0.5, 0.0)


def test_one_waypoint_a_step_steers_to_a_point_on_the_one_just_reached_along_its_sight_line() -> None:
    # Wrong, a leader held to one waypoint a step, its next item on the point it just reached,
    # would steer along north (the angle of a leg of no length) instead of onto the point.
    # By hand: (0, 1), (0, 1), (0, 3); at (0.1, 0.9) the first is 0.1414 m off: reached, and
    # no more this step. The next has no leg: the path is the sight line, atan2(0.1, -0.1) =
    # 3 pi/4; cross-track 0; command 3 pi/4; 0.141421 m to go; not done.
    wf = WaypointFollower([(0.0, 1.0), (0.0, 1.0), (0.0, 3.0)], 0.3, 0.8)
    out = wf.step(0.1, 0.9, 0.0, most=1)
    assert (out.reached, out.active_index) == ((0,), 1)
    angles = (out.heading_cmd_rad, out.path_angle_rad, out.los_angle_rad)
    assert angles == pytest.approx((3 * math.pi / 4,) * 3, abs=1e-12)
    assert (out.cross_track_m, out.distance_to_go_m) == pytest.approx((0.0, math.hypot(0.1, 0.1)), abs=1e-12)
    assert out.done is False


def test_the_turn_at_the_next_waypoint_is_the_change_of_path_angle_and_none_at_the_last() -> None:
    # Wrong, the leader would not slow for the turn at its last-but-one waypoint, or slow for
    # a turn at its last one, or get the turn wrong off a north-going leg.
    # By hand: (0, 0) -> (0, 2) east (pi/2) -> (1, 3) north-east (pi/4): turn |pi/4 - pi/2| =
    # pi/4. Once (0, 2) is reached the active one is the last: 0.
    wf = WaypointFollower([(0.0, 2.0), (1.0, 3.0)], 0.3, 0.8)
    assert wf.next_turn_rad() == pytest.approx(math.pi / 4, abs=1e-12)
    assert wf.step(0.0, 2.0, math.pi / 2).reached == (0,)
    assert wf.next_turn_rad() == 0.0


# --- leader.py ----------------------------------------------------------------------------


def test_a_half_second_wait_makes_its_waypoint_a_stop() -> None:
    # Wrong, the leader would arrive at speed on a waypoint with a wait under a second.
    ap = LeaderAutopilot([(0.0, 1.0, 0.5), (0.0, 2.0), (0.0, 3.0)], AutopilotSettings(), (0.0, 0.0))
    assert [ap.stops_at(i) for i in (0, 1, 2)] == [True, False, True]


def test_while_waiting_the_next_item_on_the_same_point_does_not_begin_and_nothing_turns() -> None:
    # Wrong, a second item waiting on the same point would begin during the first one's wait
    # (the waits overlapping, 3 s in all instead of 5), the leader would turn while it waits,
    # or the wait left be counted from the wrong time.
    # By hand: (0, 1) wait 2 s, (0, 1) wait 3 s, (0, 3); one a step. At 0 s on (0, 1): the
    # first reached, 2 s to wait. At 0.1 s: still waiting, 1.9 s, nothing reached, no turn.
    # At 2 s: the second reached (no leg), wait until 5 s: 3 s left.
    ap = LeaderAutopilot([(0.0, 1.0, 2.0), (0.0, 1.0, 3.0), (0.0, 3.0)], AutopilotSettings(), (0.0, 0.0), True)
    out = ap.step(0.0, 0.0, 1.0, math.pi / 2, 0.1)
    assert (out.los.reached, out.speed_mps, out.yaw_rate_radps, out.holding_s) == ((0,), 0.0, 0.0, 2.0)
    out = ap.step(0.1, 0.0, 1.0, math.pi / 2 - 0.3, 0.1)
    assert (out.los.reached, out.speed_mps, out.yaw_rate_radps) == ((), 0.0, 0.0)
    assert out.holding_s == pytest.approx(1.9, abs=1e-12)
    out = ap.step(2.0, 0.0, 1.0, math.pi / 2, 0.1)
    assert (out.los.reached, out.speed_mps, out.yaw_rate_radps) == ((1,), 0.0, 0.0)
    assert out.holding_s == pytest.approx(3.0, abs=1e-12)


def test_a_wait_is_kept_when_an_item_without_one_is_reached_in_the_same_step() -> None:
    # Wrong, a 2 s wait would be cancelled by the 0 s item reached with it.
    # By hand: (0, 1) wait 2 s, (0, 1), (0, 3); on (0, 1) at 0 s: both reached (the second has
    # no leg), the wait until 2 s: standing, 2 s left.
    ap = LeaderAutopilot([(0.0, 1.0, 2.0), (0.0, 1.0), (0.0, 3.0)], AutopilotSettings(), (0.0, 0.0))
    out = ap.step(0.0, 0.0, 1.0, math.pi / 2, 0.1)
    assert out.los.reached == (0, 1)
    assert (out.speed_mps, out.holding_s) == (0.0, 2.0)


def test_a_finished_leader_stands_and_holds_its_heading() -> None:
    # Wrong, a leader at its last waypoint would keep turning, or report no heading.
    # By hand: on (0, 1), its only waypoint, facing 0.7 rad: done; speed, yaw rate, wait 0;
    # the LOS heading is the leader's own.
    ap = LeaderAutopilot([(0.0, 1.0)], AutopilotSettings(), (0.0, 0.0))
    out = ap.step(1.0, 0.0, 1.0, 0.7, 0.1)
    assert out.los.done
    assert (out.speed_mps, out.yaw_rate_radps, out.holding_s) == (0.0, 0.0, 0.0)
    assert out.los.heading_cmd_rad == 0.7


def test_a_step_with_no_time_since_the_last_has_no_feed_forward() -> None:
    # Wrong, a repeated time stamp would divide the command's change by zero.
    # By hand: (0,0) -> (10,0); at (0, 0.1) at the same time as the step before: command
    # -atan(0.1 / 0.8) = -0.124355; no feed-forward, no error rate (dt 0): 1.0 sat(-0.124355 /
    # 0.35) = -0.355300. Speed 0.3 cos^2(0.124355) = 0.3 / (1 + 0.125^2) = 0.295385 (no turn at
    # (10, 0)); no wait.
    ap = LeaderAutopilot([(10.0, 0.0), (20.0, 0.0)], AutopilotSettings(), (0.0, 0.0))
    ap.step(0.0, 0.0, 0.0, 0.0, 0.1)
    out = ap.step(0.0, 0.0, 0.1, 0.0, 0.0)
    cmd = -math.atan2(0.1, 0.8)
    assert out.yaw_rate_radps == pytest.approx(cmd / 0.35, abs=1e-12)
    assert out.yaw_rate_radps == pytest.approx(-0.355300, abs=1e-6)
    assert out.speed_mps == pytest.approx(0.3 * math.cos(cmd) ** 2, abs=1e-12)
    assert out.speed_mps == pytest.approx(0.295385, abs=1e-6)
    assert out.holding_s == 0.0


def test_the_turn_slow_down_is_full_inside_the_radius_and_no_more() -> None:
    # Wrong, inside the radius of a stop (not yet on it) the leader would shed more than
    # turn_slowdown * turn / pi of its cruise speed.
    # By hand: (0, 2) with a 1 s wait (a stop), then (2, 2): a pi/2 turn. At (0, 1.8) facing
    # east: 0.2 m to go, inside 0.3 but 0.2 m short along the leg (more than 0.05): not reached.
    # blend = 1 - (0.2 - 0.3) / 0.8 = 1.125, held at 1: 0.3 (1 - 0.6 * 0.5 * 1) = 0.21; on the
    # path, no heading error; the stop's limit sqrt(2 * 0.3 * 0.2) = 0.346 is higher.
    ap = LeaderAutopilot([(0.0, 2.0, 1.0), (2.0, 2.0)], AutopilotSettings(), (0.0, 0.0))
    out = ap.step(0.0, 0.0, 1.8, math.pi / 2, 0.1)
    assert out.los.reached == ()
    assert out.speed_mps == pytest.approx(0.21, abs=1e-12)
