"""LOS waypoint guidance, paper eq. 12-16, with hand-worked numbers."""

from __future__ import annotations

import math

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from lfctl.guidance.los import (
    WaypointFollower,
    cross_track_m,
    distance_to_go_m,
    heading_error_rad,
    los_angle_rad,
    los_heading_rad,
    path_angle_rad,
)


def test_eq12_los_angle_points_at_next_waypoint() -> None:
    assert los_angle_rad(0.0, 0.0, 1.0, 1.0) == pytest.approx(math.radians(45))  # north-east
    assert los_angle_rad(0.0, 0.0, 0.0, -2.0) == pytest.approx(math.radians(-90))  # due west
    assert los_angle_rad(1.0, 1.0, -1.0, 1.0) == pytest.approx(math.pi)  # due south: atan2, not atan


def test_eq13_path_angle_of_the_segment() -> None:
    assert path_angle_rad(0.0, 0.0, 4.0, 4.0) == pytest.approx(math.radians(45))
    assert path_angle_rad(4.0, 4.0, 4.0, 0.0) == pytest.approx(math.radians(-90))


def test_eq14_is_a_heading_error_wrapped() -> None:
    assert heading_error_rad(math.radians(170), math.radians(-170)) == pytest.approx(math.radians(-20))


def test_eq15_distance_to_go() -> None:
    assert distance_to_go_m(1.0, 2.0, 4.0, 6.0) == pytest.approx(5.0)


def test_eq16_cross_track_sign_right_of_path_is_positive() -> None:
    # path due north along east = 0; vehicle 1 m east (right of the path), 5 m before the waypoint
    s = distance_to_go_m(5.0, 1.0, 10.0, 0.0)
    los = los_angle_rad(5.0, 1.0, 10.0, 0.0)
    e = cross_track_m(s, los, path_angle_rad(0.0, 0.0, 10.0, 0.0))
    assert e == pytest.approx(1.0)  # S sin(psi_d - psi_los) is the perpendicular distance
    left = cross_track_m(distance_to_go_m(5.0, -1.0, 10.0, 0.0), los_angle_rad(5.0, -1.0, 10.0, 0.0), 0.0)
    assert left == pytest.approx(-1.0)


def test_lookahead_heading_steers_back_to_the_path() -> None:
    # right of a northbound path by 1 m with 1 m lookahead: steer 45 deg left
    assert los_heading_rad(0.0, 1.0, 1.0) == pytest.approx(math.radians(-45))
    assert los_heading_rad(0.0, -1.0, 1.0) == pytest.approx(math.radians(45))


@given(st.floats(-math.pi, math.pi), st.floats(-50.0, 50.0), st.floats(0.1, 20.0))
def test_los_heading_is_wrapped(path_heading_rad: float, cross_track: float, lookahead_m: float) -> None:
    assert -math.pi < los_heading_rad(path_heading_rad, cross_track, lookahead_m) <= math.pi


def test_waypoints_switch_inside_the_acceptance_radius() -> None:
    wf = WaypointFollower([(4.0, 0.0), (4.0, 4.0)], acceptance_radius_m=0.3, lookahead_m=None)
    out = wf.step(3.5, 0.0, 0.0)
    assert out.active_index == 0 and out.reached == () and out.heading_cmd_rad == pytest.approx(0.0)
    out = wf.step(3.8, 0.1, 0.0)
    assert out.reached == (0,) and out.active_index == 1
    assert out.heading_cmd_rad == pytest.approx(los_angle_rad(3.8, 0.1, 4.0, 4.0))
    out = wf.step(4.0, 3.9, math.pi / 2)
    assert out.reached == (1,) and out.done and wf.done


def test_a_passed_waypoint_counts_as_reached_so_the_vehicle_never_circles_back() -> None:
    wf = WaypointFollower([(4.0, 0.0), (4.0, 4.0)], acceptance_radius_m=0.3, lookahead_m=1.0)
    out = wf.step(4.2, 0.6, 0.0)  # 0.63 m off the waypoint but past its perpendicular
    assert out.reached == (0,) and out.active_index == 1


def test_a_stop_point_is_driven_onto_not_reached_at_the_radius() -> None:
    # Rover's AR_WPNav: a waypoint it stops at is reached once the vehicle has come along the
    # track to it (and is inside WP_RADIUS or past it); a point it drives through, at the radius
    wf = WaypointFollower([(4.0, 0.0), (4.0, 4.0)], acceptance_radius_m=2.0, lookahead_m=1.0, stops={0}.__contains__)
    assert wf.step(2.5, 0.0, 0.0).reached == ()  # 1.5 m short: inside the radius, not arrived
    assert wf.step(3.9, 0.3, 0.0).reached == ()  # 0.1 m along the track short
    out = wf.step(3.96, 0.3, 0.0)  # 0.04 m short (within ARRIVAL_M), 0.3 m to the side
    assert out.reached == (0,) and out.active_index == 1
    out = wf.step(4.0, 2.5, math.pi / 2)  # waypoint 1 is driven through: reached at the radius
    assert out.reached == (1,) and out.done


def test_a_zero_radius_reaches_a_waypoint_by_passing_it() -> None:
    # WP_RADIUS 0 is in Rover's range: only the perpendicular (or the point itself) reaches
    wf = WaypointFollower([(4.0, 0.0), (4.0, 4.0)], acceptance_radius_m=0.0, lookahead_m=1.0, stops={1}.__contains__)
    assert wf.step(3.99, 0.0, 0.0).reached == ()
    assert wf.step(4.01, 0.05, 0.0).reached == (0,)
    assert wf.step(4.0, 3.999, math.pi / 2).reached == ()
    assert wf.step(4.0, 4.0, math.pi / 2).reached == (1,)  # on the point


def test_a_waypoint_on_the_segments_start_is_reached_at_once() -> None:
    # a repeated waypoint, passed wide of the radius: nothing to drive back to
    wf = WaypointFollower([(4.0, 0.0), (4.0, 0.0), (8.0, 0.0)], acceptance_radius_m=0.3, lookahead_m=1.0)
    out = wf.step(4.5, 1.0, 0.0)  # past the first's perpendicular, 1.1 m from the point
    assert out.reached == (0, 1) and out.active_index == 2


def test_invalid_settings_are_named() -> None:
    with pytest.raises(ValueError, match=r"acceptance_radius_m must be >= 0, got -0\.1"):
        WaypointFollower([(1.0, 1.0)], -0.1, None)
    with pytest.raises(ValueError, match="acceptance_radius_m must be >= 0, got nan"):
        WaypointFollower([(1.0, 1.0)], math.nan, None)
    with pytest.raises(ValueError, match="lookahead_m must be > 0 or None, got -1"):
        WaypointFollower([(1.0, 1.0)], 0.3, -1.0)


@pytest.mark.parametrize("field", ["north_m", "east_m", "heading_rad"])
@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_a_position_or_heading_that_is_not_a_number_is_refused_and_reaches_nothing(field: str, bad: float) -> None:
    # Wrong, a NaN position finished the route in one step: every comparison with NaN is
    # false, so no waypoint was "not yet reached" (all three reached, done, the leader stopped).
    wf = WaypointFollower([(5.0, 0.0), (5.0, 5.0), (0.0, 5.0)], 0.3, 0.8)
    pose = {"north_m": 0.0, "east_m": 0.0, "heading_rad": 0.0, field: bad}
    with pytest.raises(ValueError, match=f"waypoint guidance's {field} is"):
        wf.step(**pose)
    assert (wf.index, wf.done) == (0, False)


def test_eq16_cross_track_by_hand_on_a_southbound_path_across_the_back() -> None:
    # Wrong, on a path heading south (psi_d = pi) the difference psi_d - psi_los, near 2 pi
    # unwrapped, would put a vehicle on the wrong side or the wrong distance.
    # By hand: path (10, 0) -> (0, 0): psi_d = atan2(0, -10) = pi. Vehicle at (5, 1): 1 m east
    # of a southbound path is its left. psi_los = atan2(-1, -5) = -pi + atan(0.2) = -2.944197.
    # psi_d - psi_los = 6.085790, wrapped: -0.197396 (= -atan 0.2); S = sqrt(26) = 5.099020;
    # e = 5.099020 sin(-0.197396) = 5.099020 * -0.196116 = -1.0 (left: negative).
    s = distance_to_go_m(5.0, 1.0, 0.0, 0.0)
    los = los_angle_rad(5.0, 1.0, 0.0, 0.0)
    path = path_angle_rad(10.0, 0.0, 0.0, 0.0)
    assert (s, los, path) == pytest.approx((5.099020, -2.944197, math.pi), abs=1e-6)
    assert cross_track_m(s, los, path) == pytest.approx(-1.0, abs=1e-9)


@given(*[st.floats(-100.0, 100.0)] * 6)
def test_eq16_cross_track_is_the_signed_distance_from_the_segments_line(
    pn: float, pe: float, wn: float, we: float, n: float, e: float
) -> None:
    # In any quadrant and across the +-pi wrap: S sin(psi_d - psi_los) is the distance from the
    # line through the segment, positive on its right. Worked independently: the right-hand
    # normal of a unit direction (t_n, t_e) in NED is (-t_e, t_n).
    length = math.hypot(wn - pn, we - pe)
    assume(length > 1e-3)
    tn, te = (wn - pn) / length, (we - pe) / length
    want = (n - pn) * -te + (e - pe) * tn
    s = distance_to_go_m(n, e, wn, we)
    got = cross_track_m(s, los_angle_rad(n, e, wn, we), path_angle_rad(pn, pe, wn, we))
    assert got == pytest.approx(want, abs=1e-7 * max(1.0, s))
