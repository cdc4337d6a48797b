"""A mission's circle (NAV_LOITER_TURNS): the radius as Rover stores it, the guidance field's
heading by hand, the speed limits, and a unicycle driven round it."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from lfctl.guidance.circle import LATERAL_ACCEL_MAX_MPS2, CircleGuidance, circle_radius_m
from lfctl.guidance.smc import BearingGains

GAINS = BearingGains(eta_radps=1.0, lam_s=0.1, phi_rad=0.35, max_yaw_rate_radps=1.5)


def circle(ccw: bool = False, turns: float = 1.0, speed: float = 0.4, start=(3.0, 0.0), yaw: float = 0.0):
    return CircleGuidance((0.0, 0.0), 2.0, ccw, turns, speed, 0.2, 1.0, GAINS, start, yaw)


@pytest.mark.parametrize(
    ("param3", "radius"),
    [
        (2.7, 2.0),
        (-2.7, 2.0),
        (0.4, 0.0),
        (255.0, 255.0),
        (255.5, 250.0),
        (300.0, 300.0),
        (2555.0, 2550.0),
        (1e6, 2550.0),
    ],
)
def test_the_radius_is_kept_in_one_byte_as_ap_mission_keeps_it(param3: float, radius: float) -> None:
    # whole metres up to 255, tens of metres above (at most 255 of them)
    assert circle_radius_m(param3) == radius


def test_the_heading_is_the_tangent_turned_in_by_the_radial_error_over_the_lookahead() -> None:
    # 1 m outside a 2 m circle, north of its centre, lookahead 1 m: the tangent (east for
    # clockwise, west for counter-clockwise) turned 45 deg in
    cw, ccw = circle(), circle(ccw=True)
    cw.on_circle = ccw.on_circle = True
    out = cw.step(3.0, 0.0, math.pi / 2, 0.1)
    assert out.heading_cmd_rad == pytest.approx(3 * math.pi / 4)
    assert out.cross_track_m == pytest.approx(-1.0)  # left of its way (east): outside
    assert out.target_ned_m == pytest.approx((2.0, 0.0)) and out.distance_m == pytest.approx(1.0)
    assert ccw.step(3.0, 0.0, -math.pi / 2, 0.1).heading_cmd_rad == pytest.approx(-3 * math.pi / 4)
    # on the circle: the tangent itself, at the speed asked, turning at speed / radius
    on = circle()
    on.on_circle = True
    out = on.step(0.0, 2.0, math.pi, 0.1)  # east of the centre, heading south: clockwise's tangent
    assert out.heading_cmd_rad == pytest.approx(math.pi) and out.speed_mps == pytest.approx(0.4)
    assert out.yaw_rate_radps == pytest.approx(0.4 / 2.0)  # the feed-forward alone: no error


def test_out_to_the_edge_first_on_the_line_from_the_centre_through_the_vehicle() -> None:
    g = circle(start=(0.0, -5.0))  # west of the centre: the edge at (0, -2)
    out = g.step(0.0, -5.0, math.pi / 2, 0.1)  # heading east, at it
    assert not g.on_circle and out.target_ned_m == pytest.approx((0.0, -2.0))
    assert out.heading_cmd_rad == pytest.approx(math.pi / 2) and out.distance_m == pytest.approx(3.0)
    at_centre = circle(start=(0.0, 0.0), yaw=math.pi / 2)  # at the centre: out the way it heads
    assert at_centre.step(0.0, 0.0, math.pi / 2, 0.1).target_ned_m == pytest.approx((0.0, 2.0))


def test_the_speed_is_limited_by_the_turn_and_zero_turns_are_done_at_once() -> None:
    g = circle(speed=10.0)
    # 0.8 x 1.5 rad/s x 2 m = 2.4 m/s, under Rover's sqrt(0.6 g x 2 m) = 3.43 m/s
    assert g.speed_mps == pytest.approx(2.4) and g.speed_limit_mps() == pytest.approx(2.4)
    assert math.sqrt(LATERAL_ACCEL_MAX_MPS2 * 2.0) == pytest.approx(3.431, abs=1e-3)
    assert not g.set_speed(0.0) and g.speed_mps == pytest.approx(2.4)  # not positive: not taken
    assert not g.set_speed(1.0) and g.speed_mps == 1.0
    assert circle(turns=0.0).done and not circle().done


@given(ccw=st.booleans(), turns=st.integers(1, 3), start_bearing=st.floats(-math.pi, math.pi))
def test_a_unicycle_goes_round_as_many_times_as_asked_and_stays_on_the_circle(
    ccw: bool, turns: int, start_bearing: float
) -> None:
    n, e = 4.0 * math.cos(start_bearing), 4.0 * math.sin(start_bearing)
    yaw, dt = start_bearing + math.pi, 0.05  # facing the centre
    g = circle(ccw=ccw, turns=turns, start=(n, e), yaw=yaw)
    swept, last, steps = 0.0, None, 0
    while not g.done and steps < 20_000:
        out = g.step(n, e, yaw, dt)
        n += out.speed_mps * math.cos(yaw) * dt
        e += out.speed_mps * math.sin(yaw) * dt
        yaw += max(-1.5, min(1.5, out.yaw_rate_radps)) * dt
        if g.on_circle:
            b = math.atan2(e, n)
            if last is not None:
                swept += math.remainder(b - last, 2 * math.pi)
                if g.angle_rad > math.pi / 2:
                    assert abs(math.hypot(n, e) - 2.0) < 0.1
            last = b
        steps += 1
    assert g.done
    assert swept * (-1 if ccw else 1) == pytest.approx(turns * 2 * math.pi, abs=0.1)
