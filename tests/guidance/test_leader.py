"""The leader's autopilot on a simple vehicle: where it stops, and how long it takes."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lfctl.guidance.leader import AutopilotSettings, LeaderAutopilot

DT = 0.02


def drive(ap: LeaderAutopilot, seconds: float, lag_s: float = 0.3) -> tuple[list[tuple[float, float, float]], dict]:
    """A unicycle whose speed follows the command with a first-order lag: its path (t, n, e)
    and where each waypoint was reached (index -> (t, n, e))."""
    n = e = yaw = v = 0.0
    path, reached = [], {}
    for k in range(int(seconds / DT)):
        t = k * DT
        out = ap.step(t, n, e, yaw, DT)
        for i in out.los.reached:
            reached[i] = (t, n, e)
        v += (out.speed_mps - v) * DT / lag_s
        yaw += out.yaw_rate_radps * DT
        n += v * math.cos(yaw) * DT
        e += v * math.sin(yaw) * DT
        path.append((t, n, e))
    return path, reached


@pytest.mark.parametrize("radius", [0.0, 0.3, 2.0])
def test_the_last_waypoint_is_driven_onto_whatever_the_radius(radius: float) -> None:
    # Rover stops on its last waypoint: WP_RADIUS says when it counts as reached, not where
    # it stops (at 2 m it stopped 1.86 m short of the point)
    ap = LeaderAutopilot([(6.0, 0.0)], AutopilotSettings(cruise_speed_mps=1.0, acceptance_radius_m=radius), (0.0, 0.0))
    path, reached = drive(ap, 20.0)
    assert ap.done and 0 in reached
    _, n, e = path[-1]
    assert math.hypot(n - 6.0, e) < 0.1


def test_a_wait_begins_on_its_waypoint_and_the_route_goes_on_after_it() -> None:
    s = AutopilotSettings(cruise_speed_mps=1.0, acceptance_radius_m=2.0)
    ap = LeaderAutopilot([(5.0, 0.0, 3.0), (5.0, 5.0)], s, (0.0, 0.0))
    path, reached = drive(ap, 30.0)
    t0, n, e = reached[0]
    assert math.hypot(n - 5.0, e) < 0.1  # the wait began on the point, not 2 m short of it
    still = [(n, e) for t, n, e in path if t0 + 1.0 <= t <= t0 + 3.0]  # (the speed's lag run out)
    assert max(math.dist(p, still[0]) for p in still) < 0.01  # and stood there
    assert 1 in reached and ap.done


def test_a_waypoint_driven_through_is_reached_at_the_radius() -> None:
    s = AutopilotSettings(cruise_speed_mps=1.0, acceptance_radius_m=2.0)
    ap = LeaderAutopilot([(5.0, 0.0), (5.0, 5.0)], s, (0.0, 0.0))
    _, reached = drive(ap, 30.0)
    _, n, e = reached[0]
    assert 1.5 < math.hypot(n - 5.0, e) <= 2.0  # turned for the next leg at the radius


def test_a_stop_asked_for_without_a_wait_stops_there_too() -> None:
    # a NAV_LOITER_TIME of 0 s: Rover stops on it (always_stop_at_destination), then goes on
    s = AutopilotSettings(cruise_speed_mps=1.0, acceptance_radius_m=2.0)
    ap = LeaderAutopilot([(5.0, 0.0), (10.0, 0.0)], s, (0.0, 0.0), stop_at={0})
    path, reached = drive(ap, 30.0)
    t0, n, e = reached[0]
    assert math.hypot(n - 5.0, e) < 0.1
    slowest = min(math.dist(a[1:], b[1:]) / DT for a, b in itertools.pairwise(path) if abs(a[0] - t0) < 0.5)
    assert slowest < 0.35  # it slowed there from its 1 m/s (to the creep speed, and the lag's)
    assert ap.done


@settings(max_examples=40, deadline=None)
@given(
    st.floats(-8.0, 8.0),
    st.floats(-8.0, 8.0),
    st.floats(0.0, 3.0),
    st.floats(0.2, 1.5),
)
def test_every_route_ends_on_its_last_point(north: float, east: float, radius: float, speed: float) -> None:
    # whatever the radius and speed, the vehicle arrives (the creep speed drives the last
    # centimetres) and stops within a few centimetres of the point
    if math.hypot(north, east) < 0.5:
        return
    s = AutopilotSettings(cruise_speed_mps=speed, acceptance_radius_m=radius)
    ap = LeaderAutopilot([(north, east)], s, (0.0, 0.0))
    path, _ = drive(ap, 120.0)
    assert ap.done
    _, n, e = path[-1]
    assert math.hypot(n - north, e - east) < 0.15


def test_a_stop_point_behind_the_vehicle_after_a_sharp_turn_is_driven_back_to() -> None:
    # (10, 0) is reached 2 m before it, at (8, 0); the last point (9, 0) lies on a leg back
    # from (10, 0), which the vehicle is already past: it stopped 0.85 m short, taking it as passed
    s = AutopilotSettings(cruise_speed_mps=1.0, acceptance_radius_m=2.0)
    ap = LeaderAutopilot([(10.0, 0.0), (9.0, 0.0)], s, (0.0, 0.0))
    path, reached = drive(ap, 40.0)
    assert ap.done and set(reached) == {0, 1}
    _, n, e = path[-1]
    assert math.hypot(n - 9.0, e) < 0.1
