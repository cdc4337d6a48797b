"""Sliding-mode range and bearing control, paper eq. 17-26 (corrected), hand-worked numbers
and properties."""

from __future__ import annotations

import math

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from lfctl.guidance.smc import (
    BearingGains,
    RangeGains,
    SlidingModeController,
    range_rate_mps,
    sat,
    smc_speed_mps,
    smc_yaw_rate_radps,
)

WIDE = RangeGains(eta_mps=0.25, phi_m=0.25, min_speed_mps=-1.0, max_speed_mps=1.0)


def test_eq20_range_rate_by_hand() -> None:
    # follower at the origin heading north at 0.3 m/s; leader 2 m north moving north at 0.2 m/s
    assert range_rate_mps(2.0, 0.0, 0.2, 0.0, 0.3, 0.0) == pytest.approx(-0.1)
    # leader 2 m east moving east: a northbound follower does not change the range
    assert range_rate_mps(0.0, 2.0, 0.2, 0.0, 0.3, 0.0) == pytest.approx(0.0)


def test_eq23_speed_gives_the_reaching_law_outside_the_boundary_layer() -> None:
    # leader at (3, 4) (S = 5) moving (0.1, 0.2); follower heading along the line of sight
    psi = math.atan2(4.0, 3.0)
    u = smc_speed_mps(3.0, 4.0, 0.1, 0.2, psi, range_cmd_m=4.0, gains=WIDE)
    # (eta S sgn(s) + dx x0' + dy y0') / (dx cos psi + dy sin psi) = (1.25 + 0.3 + 0.8) / 5
    assert u == pytest.approx(0.47)
    assert range_rate_mps(3.0, 4.0, 0.1, 0.2, u, psi) == pytest.approx(-0.25)  # dS/dt = -eta


def test_eq23_inside_the_boundary_layer_the_error_decays_proportionally() -> None:
    psi = math.atan2(4.0, 3.0)
    u = smc_speed_mps(3.0, 4.0, 0.1, 0.2, psi, range_cmd_m=4.9, gains=WIDE)  # s = 0.1 < phi
    assert range_rate_mps(3.0, 4.0, 0.1, 0.2, u, psi) == pytest.approx(-0.25 * 0.1 / 0.25)


def test_eq23_too_close_backs_off_within_the_reverse_limit() -> None:
    gains = RangeGains(eta_mps=0.25, phi_m=0.25, min_speed_mps=-0.15, max_speed_mps=0.5)
    assert smc_speed_mps(1.0, 0.0, 0.0, 0.0, 0.0, range_cmd_m=1.5, gains=gains) == pytest.approx(-0.15)


def test_broadside_singularity_is_guarded() -> None:
    # leader exactly abeam: the printed eq. 23 divides by zero
    u = smc_speed_mps(0.0, 2.0, 0.3, 0.0, 0.0, range_cmd_m=1.5, gains=RangeGains())
    assert math.isfinite(u) and RangeGains().min_speed_mps <= u <= RangeGains().max_speed_mps


def test_eq26_heading_law_turns_toward_a_target_on_the_right() -> None:
    gains = BearingGains(eta_radps=1.0, lam_s=0.0, phi_rad=0.2, max_yaw_rate_radps=2.0)
    assert smc_yaw_rate_radps(0.3, 0.0, gains) == pytest.approx(1.0)  # outside the layer: eta
    assert smc_yaw_rate_radps(-0.1, 0.0, gains) == pytest.approx(-0.5)  # inside: eta e / phi
    # eq. 25: the error rate enters the sliding variable with weight lambda
    g2 = BearingGains(eta_radps=1.0, lam_s=0.5, phi_rad=0.2, max_yaw_rate_radps=2.0)
    assert smc_yaw_rate_radps(0.1, -0.2, g2) == pytest.approx(0.0)


def test_sliding_mode_controller_uses_the_error_rate() -> None:
    ctl = SlidingModeController(BearingGains(eta_radps=1.0, lam_s=0.5, phi_rad=1.0, max_yaw_rate_radps=2.0))
    assert ctl.step(0.2, 0.05) == pytest.approx(0.2)  # first step: no rate yet
    assert ctl.step(0.1, 0.05) == pytest.approx(0.1 + 0.5 * (-2.0))  # rate -2 rad/s


finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)


@given(finite, finite, st.floats(-5, 5), st.floats(-5, 5), st.floats(-10, 10), st.floats(0.1, 20))
def test_speed_command_always_within_limits(
    dx: float, dy: float, vx: float, vy: float, psi: float, rcmd: float
) -> None:
    g = RangeGains(min_speed_mps=-0.15, max_speed_mps=0.5)
    u = smc_speed_mps(dx, dy, vx, vy, psi, rcmd, g)
    assert math.isfinite(u) and -0.15 <= u <= 0.5


@given(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3), st.floats(-1e3, 1e3))
def test_yaw_rate_command_always_within_limits(err: float, rate: float, ff: float) -> None:
    g = BearingGains(max_yaw_rate_radps=1.5)
    assert abs(smc_yaw_rate_radps(err, rate, g, ff)) <= 1.5


@given(st.floats(-1e6, 1e6))
def test_sat_is_bounded_and_odd(x: float) -> None:
    assert -1.0 <= sat(x) <= 1.0 and sat(-x) == -sat(x)


def test_gains_reject_bad_values() -> None:
    with pytest.raises(ValueError, match="eta_mps must be > 0"):
        RangeGains(eta_mps=0.0)
    with pytest.raises(ValueError, match=r"min_speed_mps 1\.0 must be <= max_speed_mps 0\.5"):
        RangeGains(min_speed_mps=1.0, max_speed_mps=0.5)
    with pytest.raises(ValueError, match="lam_s must be >= 0"):
        BearingGains(lam_s=-1.0)


def test_the_bearing_laws_rate_is_not_a_difference_over_almost_no_time() -> None:
    # a 0.1 rad change over 1e-9 s read as a rate of 1e8 rad/s: the full-scale turn
    from lfctl.guidance.smc import MIN_RATE_DT_S, BearingGains, SlidingModeController

    over_nothing, over_a_step = SlidingModeController(BearingGains()), SlidingModeController(BearingGains())
    over_nothing.step(0.0, 0.05)
    over_a_step.step(0.0, 0.05)
    assert over_nothing.step(0.1, 1e-9) == SlidingModeController(BearingGains()).step(0.1, 0.05)  # as a first step
    assert over_a_step.step(0.1, MIN_RATE_DT_S) != over_nothing.step(0.1, 0.05)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_the_bearing_law_refuses_an_error_or_feed_forward_that_is_not_a_number(bad: float) -> None:
    # Wrong, a NaN error was the yaw-rate command (clamp lets NaN through), and kept as the
    # previous error it made the next step's command NaN too, whatever that step's error.
    ctl = SlidingModeController(BearingGains())
    ctl.step(0.1, 0.05)
    with pytest.raises(ValueError, match="bearing law's error is"):
        ctl.step(bad, 0.05)
    with pytest.raises(ValueError, match="bearing law's feed-forward is"):
        ctl.step(0.1, 0.05, bad)
    # the refused steps left the memory as it was: error 0.1 then 0.1, rate 0; by hand
    # sigma = 0.1, sat(0.1 / 0.25) = 0.4, r = 1.2 * 0.4 = 0.48
    assert ctl.step(0.1, 0.05) == pytest.approx(0.48, abs=1e-12)


@pytest.mark.parametrize(
    "make",
    [
        lambda: RangeGains(eta_mps=math.inf),
        lambda: RangeGains(phi_m=math.inf),
        lambda: RangeGains(min_cos_bearing=math.inf),
        lambda: RangeGains(min_speed_mps=-math.inf),
        lambda: RangeGains(max_speed_mps=math.inf),
        lambda: BearingGains(eta_radps=math.inf),
        lambda: BearingGains(phi_rad=math.inf),
        lambda: BearingGains(lam_s=math.inf),
        lambda: BearingGains(max_yaw_rate_radps=math.inf),
    ],
)
def test_gains_refuse_an_infinite_value(make: object) -> None:
    # Wrong, RangeGains(eta_mps=inf) on the slot commanded speed inf * sat(0) = NaN, and
    # BearingGains(eta_radps=inf) or lam_s=inf a NaN yaw rate with no error or no error rate.
    with pytest.raises(ValueError, match="finite"):
        make()  # type: ignore[operator]


def test_eq23_by_hand_for_a_follower_heading_east_and_a_leader_moving_off_the_sight_line() -> None:
    # Wrong, the range law would mix the leader's velocity or the follower's heading into the
    # wrong axis (the printed eq. 21-23 swap sin and cos) once neither points along north.
    # By hand: leader 1 m north and 2 m east (S = sqrt(5) = 2.236068), moving 0.2 north and
    # 0.1 east; follower heading east (psi = pi/2); slot 1.5 m: s = 0.736068 > Phi, sat = 1.
    # numerator = 0.25 * 2.236068 + 1 * 0.2 + 2 * 0.1 = 0.559017 + 0.4 = 0.959017;
    # denominator = 1 * cos(pi/2) + 2 * sin(pi/2) = 2; U = 0.479508 m/s.
    # Check with eq. 20: dS/dt = (1 (0.2 - U * 0) + 2 (0.1 - U)) / S = (0.4 - 0.959017) / 2.236068
    # = -0.559017 / 2.236068 = -0.25 = -eta.
    u = smc_speed_mps(1.0, 2.0, 0.2, 0.1, math.pi / 2, 1.5, WIDE)
    assert u == pytest.approx(0.479508, abs=1e-6)
    assert range_rate_mps(1.0, 2.0, 0.2, 0.1, 0.479508, math.pi / 2) == pytest.approx(-0.25, abs=1e-5)


def test_eq26_by_hand_with_the_equivalent_control_and_the_yaw_rate_limit() -> None:
    # Wrong, the feed-forward would be dropped or scaled, or the limit not applied after it.
    # By hand (eta 1.2, lambda 0.1, Phi 0.25, limit 1.5): e = 0.05, de/dt = 0.5: s = 0.05 + 0.05
    # = 0.1; sat(0.1 / 0.25) = 0.4; r = 0.3 + 1.2 * 0.4 = 0.78. With e = 1 (sat 1) and r_eq = 1:
    # 1 + 1.2 = 2.2, clipped to 1.5; with r_eq = -1 and e = -1: -2.2, clipped to -1.5.
    g = BearingGains(eta_radps=1.2, lam_s=0.1, phi_rad=0.25, max_yaw_rate_radps=1.5)
    assert smc_yaw_rate_radps(0.05, 0.5, g, 0.3) == pytest.approx(0.78, abs=1e-12)
    assert smc_yaw_rate_radps(1.0, 0.0, g, 1.0) == 1.5
    assert smc_yaw_rate_radps(-1.0, 0.0, g, -1.0) == -1.5


def test_the_bearing_laws_error_rate_across_the_back_is_the_short_way_round() -> None:
    # Wrong, an error going from 3.1 to -3.1 rad (the target crossing straight behind) would read
    # as a rate of -62 rad/s instead of +0.83.
    # By hand: wrap(-3.1 - 3.1) = -6.2 + 2 pi = 0.0831853; over 0.1 s: 0.831853 rad/s.
    # eta 1, lambda 1, Phi 10: s = -3.1 + 0.831853 = -2.268147; sat(-0.2268147); r = -0.2268147.
    # (The long way: s = -3.1 - 62 = -65.1, sat -1, r = -1.)
    ctl = SlidingModeController(BearingGains(eta_radps=1.0, lam_s=1.0, phi_rad=10.0, max_yaw_rate_radps=5.0))
    ctl.step(3.1, 0.1)
    assert ctl.step(-3.1, 0.1) == pytest.approx(-0.2268147, abs=1e-7)


@given(
    st.floats(-100, 100),
    st.floats(-100, 100),
    st.floats(-2, 2),
    st.floats(-2, 2),
    st.floats(-10, 10),
    st.floats(0.1, 20),
)
def test_eq23_speed_makes_eq20_obey_the_reaching_law_wherever_it_is_not_limited(
    dx: float, dy: float, vx: float, vy: float, psi: float, rcmd: float
) -> None:
    # Whatever the geometry (any heading, any quadrant, the leader moving any way), the speed
    # eq. 23 commands, put into eq. 20, gives dS/dt = -eta sat((S - S_com) / Phi), unless the
    # speed limit or the |cos beta| floor (the broadside guard) changed it.
    gains = RangeGains(eta_mps=0.25, phi_m=0.25, min_speed_mps=-100.0, max_speed_mps=100.0)
    s = math.hypot(dx, dy)
    assume(s > 1e-3 and abs(dx * math.cos(psi) + dy * math.sin(psi)) / s >= gains.min_cos_bearing)
    u = smc_speed_mps(dx, dy, vx, vy, psi, rcmd, gains)
    assume(abs(u) < 100.0)
    want = -gains.eta_mps * sat((s - rcmd) / gains.phi_m)
    assert range_rate_mps(dx, dy, vx, vy, u, psi) == pytest.approx(want, abs=1e-7 * (1.0 + abs(u)))
