"""The formation controller worked by hand where the full mutation run of formation.py
found nothing pinning it: the output before the first sighting and after a LOST, a follower
away from the origin, the P law's 90 deg boundary, a sensor's NaNs, a delayed fix of a moving
target, the camera's pace, the slow-down's length, the filter's sigma and significance tests,
bearing-only fixes off the north axis, a slot's bearing changed live under the trail law, the
still-target holds' 2-sigma gates and the trail law's back-away from a target too near.

Each test says what a user would see if the number were wrong, and the number worked by hand
from the code's equations and docstrings (in the comments); nothing random."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from lfctl.guidance.formation import FormationController, FormationSettings, Odometry, TargetEstimator
from lfctl.guidance.smc import RangeGains
from lfctl.vision.track_state import RelativeMeasurement, TrackStatus

STILL = Odometry(0.0, 0.0, 0.0, 0.0, 0.0)  # a follower at the origin facing north, standing


def fix(t: float, rng: float | None, brg: float = 0.0, **kw: object) -> RelativeMeasurement:
    return RelativeMeasurement(t, TrackStatus.TRACKING, rng, brg, 1.0, **kw)  # type: ignore[arg-type]


def at(t: float) -> Odometry:
    return Odometry(t, 0.0, 0.0, 0.0, 0.0)  # STILL at time t


# --- the output before the first sighting and after a LOST ----------------------------------


def test_a_controller_that_never_saw_its_target_is_lost_and_commands_nothing() -> None:
    # Wrong, a follower switched on with no target in view would turn (yaw rate 1) or report
    # a target velocity it never estimated, or say no status at all before its first step.
    # By hand: no measurement, no filter: LOST, speed 0, yaw rate 0, velocity (0, 0), no range.
    ctl = FormationController(FormationSettings())
    assert ctl.status is TrackStatus.LOST
    out = ctl.step(None, STILL)
    assert (out.speed_mps, out.yaw_rate_radps) == (0.0, 0.0)
    assert out.target_vel_ned_mps == (0.0, 0.0)
    assert (out.range_est_m, out.bearing_est_rad) == (None, None)


def test_a_target_lost_after_tracking_reports_the_filters_last_velocity() -> None:
    # Wrong, a recorder or ground station would get no velocity for a target the sensor lost.
    # By hand: noiseless fixes of a target going north at 0.3 m/s for 3 s: the filter's
    # velocity about (0.3, 0); the sensor then says LOST: stop, no range, and the velocity the
    # filter runs on with (a prediction keeps it).
    ctl = FormationController(FormationSettings())
    for k in range(31):
        t = 0.1 * k
        ctl.step(fix(t, 2.0 + 0.3 * t), at(t))
    out = ctl.step(RelativeMeasurement(3.1, TrackStatus.LOST), at(3.1))
    assert out.status is TrackStatus.LOST
    assert (out.speed_mps, out.range_est_m) == (0.0, None)
    assert out.target_vel_ned_mps == ctl.estimator.velocity
    assert out.target_vel_ned_mps == pytest.approx((0.3, 0.0), abs=0.02)


# --- a follower away from the origin ------------------------------------------------------


def test_a_follower_away_from_the_origin_and_turned_sees_and_drives_for_its_target() -> None:
    # Wrong, a follower anywhere but at (0, 0) facing north would misjudge its target's range
    # and bearing and drive the range law on the wrong offset.
    # By hand: follower at (10, 5) facing east (pi/2), still; the target seen 2 m off, 30 deg
    # right: body (2 cos 30, 2 sin 30) = (1.7321, 1) turned by pi/2: NED (-1, 1.7321), the
    # target at (9, 6.7321). Range 2, bearing pi/6. Range law: S = 2, s = 0.5 > Phi: sat 1;
    # numerator 0.25 * 2 = 0.5; cos(beta) = (dx cos 90 + dy sin 90) / S = 1.7321 / 2 = cos 30;
    # U = 0.5 / (2 cos 30) = 0.288675. Bearing law: e = pi/6, first step (rate 0), no LOS rate
    # (both still): 1.2 sat(0.5236 / 0.25) = 1.2.
    ctl = FormationController(FormationSettings())
    out = ctl.step(fix(0.0, 2.0, math.pi / 6), Odometry(0.0, 10.0, 5.0, math.pi / 2, 0.0))
    assert ctl.estimator.position == pytest.approx((9.0, 5.0 + math.sqrt(3.0)), abs=1e-12)
    assert (out.range_est_m, out.bearing_est_rad) == pytest.approx((2.0, math.pi / 6), abs=1e-12)
    assert out.speed_mps == pytest.approx(0.25 / math.cos(math.pi / 6), abs=1e-12)
    assert out.speed_mps == pytest.approx(0.288675, abs=1e-6)
    assert out.yaw_rate_radps == pytest.approx(1.2, abs=1e-12)


# --- settings and the law that holds a slot -------------------------------------------------


@pytest.mark.parametrize("bearing", [math.pi / 2, -math.pi / 2, math.pi, -math.pi])
def test_a_slot_at_90_degrees_or_straight_ahead_of_the_target_is_held_by_the_p_law(bearing: float) -> None:
    # Wrong, a slot exactly abeam would be left to the range law (its cos(beta) singularity),
    # or the -pi..pi a bearing may take (the settings' own message) would refuse pi itself.
    # By hand: |bearing| >= SMC_MAX_BEARING_RAD = radians(90): the "p" law, and named so.
    ctl = FormationController(FormationSettings(bearing_cmd_rad=bearing))
    out = ctl.step(fix(0.0, 2.0), STILL)
    assert out.status is TrackStatus.TRACKING
    assert out.law == "p"


# --- what the sensor says -----------------------------------------------------------------


def test_a_sensors_nan_range_or_bearing_or_an_occluded_report_is_no_sighting() -> None:
    # Wrong, a sensor's garbage (NaN) would start the filter at NaN for good, or an occluded
    # report carrying its last range would count as the target seen.
    # By hand: no filter yet, so only a measurement with a number for both range and bearing
    # and TRACKING status starts it; each of these leaves the controller LOST.
    nan = math.nan
    for meas in (
        fix(0.0, 2.0, nan),  # no bearing
        fix(0.0, nan, 0.0),  # no range: bearing-only, which cannot start a filter
        fix(0.0, math.inf, 0.0),
        RelativeMeasurement(0.0, TrackStatus.OCCLUDED, 2.0, 0.0, 1.0),
    ):
        ctl = FormationController(FormationSettings())
        out = ctl.step(meas, STILL)
        assert out.status is TrackStatus.LOST, meas
        assert not ctl.estimator.initialised, meas


def test_a_delayed_fix_of_a_moving_target_is_brought_forward_by_its_velocity() -> None:
    # Wrong, a camera's late frame of a moving target would be fused where the target was, or
    # pushed the wrong way, dragging the estimate back by speed * latency.
    # By hand: the filter at (2, 0) moving (0.3, 0.4) m/s, its position variance huge (1e4 m^2:
    # a fix sets it). Guidance at 0.3 s, the frame from 0.1 s: the follower was at the origin,
    # so the fix is (2, 0) then; brought forward 0.2 s: (2 + 0.3 * 0.2, 0 + 0.4 * 0.2) =
    # (2.06, 0.08), where the prediction is: no innovation, the estimate stays (2.06, 0.08).
    # (Unshifted, it would be (2, 0); shifted the wrong way, (1.94, ...) or (..., -0.08).)
    ctl = FormationController(FormationSettings())
    ctl.step(fix(0.0, 2.0), at(0.0))
    ctl.step(None, at(0.1))
    ctl.estimator.kf.x = np.array([2.0, 0.0, 0.3, 0.4])
    ctl.estimator.kf.P = np.diag([1e4, 1e4, 1e-12, 1e-12])
    out = ctl.step(fix(0.1, 2.0), at(0.3))
    assert out.status is TrackStatus.TRACKING
    assert ctl.estimator.position == pytest.approx((2.06, 0.08), abs=1e-6)


def test_a_gap_over_three_camera_periods_is_an_occlusion_not_the_cameras_pace() -> None:
    # Wrong, one long gap between frames would be taken as the camera's pace, and a camera
    # that then stops would count as tracking (its last frame handed again) for far longer.
    # By hand: frames at 0, 0.1, 0.2 s: pace 0.1 s. The next at 0.55 s, 0.35 s on: more than
    # 3 x 0.1, not the pace (it stays 0.1). That frame handed again is tracking while the next
    # is due, 2 x 0.1 = 0.2 s: at 0.7 s (0.15 s on) TRACKING; at 0.8 s (0.25 s) OCCLUDED.
    # (Taken as the pace, 0.35 s: due for 0.7 s, still TRACKING at 0.8 s.)
    ctl = FormationController(FormationSettings())
    for t in (0.0, 0.1, 0.2, 0.55):
        assert ctl.step(fix(t, 2.0), at(t)).status is TrackStatus.TRACKING
    assert ctl.step(fix(0.55, 2.0), at(0.7)).status is TrackStatus.TRACKING
    assert ctl.step(fix(0.55, 2.0), at(0.8)).status is TrackStatus.OCCLUDED


def test_before_a_second_frame_one_handed_again_is_tracking_for_two_steps_and_not_slowed() -> None:
    # Wrong, with no coast set a frame handed again would count as tracking for too long, or
    # a tracking follower would be slowed as if the target were hidden.
    # By hand: coast 0. A still target 5 m ahead: range law S = 5, s = 3.5, sat 1: U = 0.25
    # (every step: the filter's velocity stays exactly 0). The one frame (0 s) handed again at
    # 0.15 s: due = max(coast 0, 2 x 0.15) = 0.3 >= 0.15: TRACKING, 0.25 (no slow-down while
    # tracking). At 0.25 s, 0.1 s after the step before: due = 0.2 < 0.25: OCCLUDED, and past
    # the coast: slowed by 1 - 0.25 / 1 (slowdown_s) = 0.75: 0.1875.
    ctl = FormationController(FormationSettings(coast_s=0.0))
    assert ctl.step(fix(0.0, 5.0), at(0.0)).speed_mps == pytest.approx(0.25, abs=1e-12)
    out = ctl.step(fix(0.0, 5.0), at(0.15))
    assert out.status is TrackStatus.TRACKING
    assert (out.speed_mps, out.yaw_rate_radps) == pytest.approx((0.25, 0.0), abs=1e-12)
    out = ctl.step(fix(0.0, 5.0), at(0.25))
    assert out.status is TrackStatus.OCCLUDED
    assert out.speed_mps == pytest.approx(0.25 * 0.75, abs=1e-12)


def test_the_slow_down_after_the_coast_takes_slowdown_s_and_scales_the_yaw_rate_too() -> None:
    # Wrong, a 2 s slow-down would be over at once (a follower stopping dead after the coast),
    # or the yaw rate be replaced by the slow-down's factor instead of scaled by it.
    # By hand: coast 2 s, slow-down 2 s; a still target 5 m off, 0.1 rad right, seen at 0 s.
    # Range law: S = 5, s = 3.5, sat 1: U = 0.25 * 5 / (5 cos 0.1) = 0.251256. Bearing law:
    # e = 0.1 every step (rate 0), no LOS rate: 1.2 sat(0.1 / 0.25) = 0.48. At 2 s: within the
    # coast, full. At 3 s: factor 1 - (3 - 2) / 2 = 0.5: (0.125628, 0.24).
    ctl = FormationController(FormationSettings(coast_s=2.0, slowdown_s=2.0))
    ctl.step(fix(0.0, 5.0, 0.1), at(0.0))
    ctl.step(None, at(1.0))
    out = ctl.step(None, at(2.0))
    assert out.status is TrackStatus.OCCLUDED
    assert (out.speed_mps, out.yaw_rate_radps) == pytest.approx((0.25 / math.cos(0.1), 0.48), abs=1e-12)
    out = ctl.step(None, at(3.0))
    assert out.status is TrackStatus.OCCLUDED
    assert (out.speed_mps, out.yaw_rate_radps) == pytest.approx((0.125 / math.cos(0.1), 0.24), abs=1e-12)
    assert out.speed_mps == pytest.approx(0.125628, abs=1e-6)


# --- the target's filter ------------------------------------------------------------------


def test_a_velocity_is_significant_only_beyond_n_sigma_of_its_own_uncertainty() -> None:
    # Wrong, the follower would feed forward a still target's noise (a gate too low) or ignore
    # a slow target (too high), or an n_sigma asked for would not be the one used.
    # By hand: velocity (0.25, 0), P_vv = 0.01 I: v' P_vv^-1 v = 0.0625 / 0.01 = 6.25.
    # Default n_sigma 2: 6.25 > 4: the velocity. n_sigma 3: 6.25 < 9: zero. At exactly two
    # sigma, (1, 0) with P_vv = 0.25 I: 1 / 0.25 = 4, within 2 sigma: zero.
    est = TargetEstimator(0.03, 0.3)
    est.init(0.0, 0.0)
    est.kf.x = np.array([0.0, 0.0, 0.25, 0.0])
    est.kf.P = np.diag([0.0009, 0.0009, 0.01, 0.01])
    assert est.significant_velocity() == (0.25, 0.0)
    assert est.significant_velocity(3.0) == (0.0, 0.0)
    est.kf.x = np.array([0.0, 0.0, 1.0, 0.0])
    est.kf.P = np.diag([0.0009, 0.0009, 0.25, 0.25])
    assert est.significant_velocity() == (0.0, 0.0)


def test_the_range_and_bearing_sigma_are_the_covariance_along_and_across_the_sight_line() -> None:
    # Wrong, the still-target holds would use the wrong noise: a bearing sigma not divided by
    # the range, the covariance's cross term counted the wrong way, or an infinite sigma at 1 m.
    # By hand: P_pos = [[0.02, 0.01], [0.01, 0.02]]. Along (2, 2): u = (1, 1) / sqrt 2,
    # u' P u = (0.02 + 0.01 + 0.01 + 0.02) / 2 = 0.03: sigma_r = sqrt(0.03) = 0.173205;
    # across, (-1, 1) / sqrt 2: (0.02 - 0.01 - 0.01 + 0.02) / 2 = 0.01: sigma_b = 0.1 / (2 sqrt 2)
    # = 0.0353553 rad. Along (1, 0): sqrt(0.02) = 0.141421 both (range 1). On it: infinite.
    est = TargetEstimator(0.03, 0.3)
    est.init(0.0, 0.0)
    est.kf.P = np.array([[0.02, 0.01, 0.0, 0.0], [0.01, 0.02, 0.0, 0.0], [0.0, 0.0, 0.25, 0.0], [0.0, 0.0, 0.0, 0.25]])
    assert est.range_bearing_sigma(2.0, 2.0) == pytest.approx(
        (math.sqrt(0.03), 0.1 / (2.0 * math.sqrt(2.0))), rel=1e-12
    )
    assert est.range_bearing_sigma(2.0, 2.0) == pytest.approx((0.173205, 0.0353553), abs=1e-6)
    assert est.range_bearing_sigma(1.0, 0.0) == pytest.approx((math.sqrt(0.02), math.sqrt(0.02)), rel=1e-12)
    assert est.range_bearing_sigma(0.0, 0.0) == (math.inf, math.inf)


def test_the_filters_cached_motion_model_cannot_be_written_through() -> None:
    # Wrong, code writing into the filter's F or Q in place would change the model every
    # later step of that length shares (they are cached per step length, read-only).
    est = TargetEstimator(0.03, 0.3)
    est.init(0.0, 0.0)
    est.predict(0.1)
    for a in (est.kf.F, est.kf.Q):
        with pytest.raises(ValueError, match="read-only"):
            a[0, 0] = 2.0
    # and the model is F = [[I, dt I], [0, I]]
    assert est.kf.F[0, 2] == 0.1 and est.kf.F[1, 3] == 0.1


def test_the_odometry_kept_for_delayed_fixes_is_bounded() -> None:
    # Wrong, a long run would keep every odometry sample (memory growing, and each delayed fix
    # searching all of them for the nearest time).
    ctl = FormationController(FormationSettings())
    for k in range(1000):
        ctl.step(None, at(0.05 * k))
    assert len(ctl._odom) < 1000
    assert ctl._odom[-1].t_s == 0.05 * 999


# --- bearing-only fixes -------------------------------------------------------------------


def bearing_only(
    ctl: FormationController, odom: Odometry, origin: tuple[float, float] = (0.2, 0.1), back: float = 0.3
) -> tuple[float, float, np.ndarray]:
    return ctl._bearing_fix(fix(0.0, None, 0.0, origin_body_m=origin, seen_back_m=back), 0.0, odom)


def test_a_bearing_only_sighting_of_a_target_moving_north_trusts_the_banners_offset() -> None:
    # Wrong, a target moving due north (no east speed) would be taken as still and the
    # banner's offset given its whole length as sideways variance, not a fifth.
    # By hand: the filter at (2, 0) moving north at 0.5 (P 1e-4 I: clearly moving); heading 0,
    # banner 0.3 m behind: seen point (1.7, 0); camera (0.2, 0.1): rng = hypot(1.5, -0.1) =
    # 1.50333; fix (0.2 + rng + 0.3, 0.1) = (2.00333, 0.1); R_cross = (0.02 rng)^2 + (0.2 * 0.3)^2
    # = 0.000904 + 0.0036 = 0.004504.
    ctl = FormationController(FormationSettings())
    ctl.estimator.init(2.0, 0.0)
    ctl.estimator.kf.x[2] = 0.5
    ctl.estimator.kf.P = 1e-4 * np.eye(4)
    n, e, cov = bearing_only(ctl, STILL)
    rng = math.hypot(1.5, -0.1)
    assert (n, e) == pytest.approx((0.5 + rng, 0.1), abs=1e-9)
    assert cov == pytest.approx(np.array([[0.25, 0.0], [0.0, (0.02 * rng) ** 2 + 0.06**2]]), abs=1e-12)
    assert cov[1, 1] == pytest.approx(0.004504, abs=1e-6)


def test_a_bearing_only_sighting_of_a_still_target_lays_the_banner_along_an_east_facing_follower() -> None:
    # Wrong, a still target's banner would be placed behind it along north whatever way the
    # follower (and so the target, in formation) faces.
    # By hand: the follower at the origin facing east; the filter at (0, 2), still. Camera
    # (0.2 forward, 0.1 right) turned by pi/2: NED (-0.1, 0.2). Banner 0.3 m behind along east:
    # seen point (0, 1.7). rng = hypot(0 - (-0.1), 1.7 - 0.2) = hypot(0.1, 1.5) = 1.50333. The
    # sight line is east, u = (0, 1): fix = (-0.1, 0.2 + rng + 0.3) = (-0.1, 2.00333);
    # R = 0.25 u u' + k v v' (v = (-1, 0)) = diag(k, 0.25), k = (0.02 rng)^2 + 0.3^2 = 0.090904.
    # (The banner laid along north: seen point (-0.3, 2), the fix (0.2, 2.0111).)
    ctl = FormationController(FormationSettings())
    ctl.estimator.init(0.0, 2.0)
    n, e, cov = bearing_only(ctl, Odometry(0.0, 0.0, 0.0, math.pi / 2, 0.0))
    rng = math.hypot(0.1, 1.5)
    assert (n, e) == pytest.approx((-0.1, 0.5 + rng), abs=1e-9)
    assert (n, e) == pytest.approx((-0.1, 2.003330), abs=1e-6)
    assert cov == pytest.approx(np.array([[(0.02 * rng) ** 2 + 0.09, 0.0], [0.0, 0.25]]), abs=1e-12)


def test_a_bearing_only_sighting_of_a_near_target_keeps_its_distance_down_to_a_decimetre() -> None:
    # Wrong, a bearing-only fix of a target under a metre away (a 0.6 m slot) would be put
    # further off than the filter has it.
    # By hand: camera on the reference point, no banner offset, sight line north. The filter
    # at (0.8, 0): rng = 0.8, fix (0.8, 0), R = diag(0.25, (0.02 * 0.8)^2 = 0.000256). At
    # (0.05, 0): rng = max(0.1, 0.05) = 0.1, fix (0.1, 0).
    ctl = FormationController(FormationSettings(range_cmd_m=0.6))
    ctl.estimator.init(0.8, 0.0)
    n, e, cov = bearing_only(ctl, STILL, (0.0, 0.0), 0.0)
    assert (n, e) == pytest.approx((0.8, 0.0), abs=1e-12)
    assert cov == pytest.approx(np.diag([0.25, 0.000256]), abs=1e-12)
    ctl.estimator.init(0.05, 0.0)
    n, e, _ = bearing_only(ctl, STILL, (0.0, 0.0), 0.0)
    assert (n, e) == pytest.approx((0.1, 0.0), abs=1e-12)


# --- the still-target holds' 2-sigma gates --------------------------------------------------


def still_at(ctl: FormationController, n: float, e: float) -> None:
    ctl.estimator.init(n, e)
    ctl.estimator.kf.P = np.diag([0.01, 0.01, 0.25, 0.25])  # sigma 0.1 m every way


def test_the_range_laws_hold_for_a_still_target_gates_at_two_sigma_of_range_and_bearing() -> None:
    # Wrong, a follower a little off its slot behind a parked leader would stay there (a gate
    # wider than 2 sigma) instead of closing it.
    # By hand: position sigma 0.1 m. Target 1.75 m ahead: |1.75 - 1.5| = 0.25 > 2 x 0.1: no
    # hold; S = 1.75, s = 0.25 = Phi: sat 1: U = 0.25 * 1.75 / 1.75 = 0.25; no bearing error: 0.
    ctl = FormationController(FormationSettings())
    still_at(ctl, 1.75, 0.0)
    assert ctl._smc(1.75, 0.0, 0.0, 0.0, 1.75, 0.0, STILL, 0.1) == pytest.approx((0.25, 0.0), abs=1e-12)
    # At 1.5 m, 0.15 rad right: sigma_b = 0.1 / 1.5 = 0.0667, 0.15 > 2 sigma_b = 0.133: no
    # hold; no range error: speed 0; first step: 1.2 sat(0.15 / 0.25) = 0.72.
    ctl = FormationController(FormationSettings())
    dx, dy = 1.5 * math.cos(0.15), 1.5 * math.sin(0.15)
    still_at(ctl, dx, dy)
    speed, yaw_rate = ctl._smc(dx, dy, 0.0, 0.0, 1.5, 0.15, STILL, 0.1)
    assert speed == pytest.approx(0.0, abs=1e-12)
    assert yaw_rate == pytest.approx(0.72, abs=1e-12)


def test_the_trail_laws_hold_for_a_still_target_gates_at_two_sigma_of_the_gap() -> None:
    # Wrong, a trail follower 25 cm short of its slot behind a parked leader would stay there.
    # By hand: the trail starts at the follower (slot bearing 0) and runs 1.75 m to the target:
    # gap 1.75, |1.75 - 1.5| = 0.25 > 2 x 0.1: no hold; the aim is the target, dead ahead:
    # 0 + 0.25 sat(0.25 / 0.25) = 0.25, cos 0 = 1; no turn: (0.25, 0).
    ctl = FormationController(FormationSettings(controller="trail"))
    still_at(ctl, 1.75, 0.0)
    assert ctl._trail(1.75, 0.0, 0.0, 0.0, STILL, 0.1, False) == pytest.approx((0.25, 0.0), abs=1e-12)


# --- the trail law ------------------------------------------------------------------------


def test_a_slot_set_past_the_trail_limit_and_back_restarts_the_trail() -> None:
    # Wrong, a trail follower whose slot a ground station set wider than 30 deg (the range law
    # then holds it) and back would drive the trail kept from before, not the target's path now.
    # By hand: a follower standing at the origin facing north; the target going north at
    # 0.3 m/s from 2 m ahead; slot bearing 20 deg: offset = -1.5 sin 20 = -0.513030, the trail
    # starting at (0 + offset sin 0, 0 - offset cos 0) = (0, 0.513030). 3 s of trail: it grows
    # (a point each 0.05 m). At 3.1 s 45 deg (the range law), at 3.2 s 20 deg again: a fresh
    # trail of two points, from (0, 0.513030) to the filter's target.
    st = FormationSettings(controller="trail", bearing_cmd_rad=math.radians(20.0))
    ctl = FormationController(st)
    for k in range(31):
        t = 0.1 * k
        ctl.step(fix(t, 2.0 + 0.3 * t), at(t))
    assert len(ctl.trail.points) > 5
    ctl.settings = dataclasses.replace(st, bearing_cmd_rad=math.radians(45.0))
    assert ctl.step(fix(3.1, 2.93), at(3.1)).law == "smc"
    ctl.settings = st
    assert ctl.step(fix(3.2, 2.96), at(3.2)).law == "trail"
    assert len(ctl.trail.points) == 2
    assert ctl.trail.points[0] == pytest.approx((0.0, 1.5 * math.sin(math.radians(20.0))), abs=1e-12)
    assert ctl.trail.points[0] == pytest.approx((0.0, 0.513030), abs=1e-6)
    assert ctl.trail.points[1] == pytest.approx(ctl.estimator.position, abs=1e-12)


def test_an_all_round_sensor_puts_no_limit_on_the_trail_heading() -> None:
    # Wrong, a follower with a 360 deg sensor would still keep its target within 175 deg of
    # its heading (a camera's margin).
    # By hand: view_half_fov_rad = pi: the limit is pi, whatever the banner.
    for banner in (0.0, 0.2):
        assert FormationController(FormationSettings(banner_half_m=banner))._view_limit_rad() == math.pi


def test_a_trail_restarted_on_the_follower_starts_along_its_heading() -> None:
    # Wrong, a trail restarted with the filter's target on the follower would fail or point
    # the wrong way.
    # By hand: the target at the follower (0, 0) facing east: the trail (0, 0) -> 0.05 m east,
    # (0, 0.05); a still target on it: sigma infinite, hold: (0, 0).
    ctl = FormationController(FormationSettings(controller="trail"))
    ctl.estimator.init(0.0, 0.0)
    out = ctl._trail(0.0, 0.0, 0.0, 0.0, Odometry(0.0, 0.0, 0.0, math.pi / 2, 0.0), 0.1, False)
    assert np.array(ctl.trail.points) == pytest.approx(np.array([(0.0, 0.0), (0.0, 0.05)]), abs=1e-12)
    assert out == (0.0, 0.0)


def test_a_trail_restarted_beside_the_follower_counts_the_gap_from_where_it_is_along_it() -> None:
    # Wrong, the first step of a fresh side-slot trail would take the follower for further
    # behind than it is and drive too fast.
    # By hand: slot bearing 20 deg, offset o = -1.5 sin 20 = -0.513030; a still target 2 m
    # ahead; the trail from (0, -o) to (2, 0), length L = hypot(2, o) = 2.064752. The follower
    # is (2, 0) from the target, along the trail (2 * 2 + 0) / L: gap = 4 / L = 1.937279;
    # gap_cmd = 1.5 cos 20 = 1.409539. Phi = 2 (no saturation): along = 0.25 (gap - gap_cmd) / 2
    # = 0.065967. The aim: the target shifted o to the trail's right, heading h = atan2(o, 2):
    # (2 - o sin h, o cos h) = (2 - o^2 / L, 2 o / L) = (1.872527, -0.496941); turn
    # atan2(-0.496941, 1.872527) = -0.259406: speed = along cos(turn) = 0.063760.
    o = -1.5 * math.sin(math.radians(20.0))
    st = FormationSettings(controller="trail", bearing_cmd_rad=math.radians(20.0), range=RangeGains(phi_m=2.0))
    ctl = FormationController(st)
    ctl.estimator.init(2.0, 0.0)
    speed, _ = ctl._trail(2.0, 0.0, 0.0, 0.0, STILL, 0.1, False)
    length = math.hypot(2.0, o)
    gap = 4.0 / length
    turn = math.atan2(2.0 * o / length, 2.0 - o * o / length)
    assert np.array(ctl.trail.points) == pytest.approx(np.array([(0.0, -o), (2.0, 0.0)]), abs=1e-12)
    assert speed == pytest.approx(0.25 * (gap - 1.5 * math.cos(math.radians(20.0))) / 2.0 * math.cos(turn), abs=1e-12)
    assert speed == pytest.approx(0.063760, abs=1e-6)


def test_a_trail_follower_too_near_a_target_ahead_backs_away_as_the_range_law_does() -> None:
    # Wrong, a trail follower within 0.9 m (0.6 of its 1.5 m slot) of a target ahead of it
    # would back off only as the trail's gap asks, and could run into it.
    # By hand: facing 60 deg; a still target 0.6 m off at 115 deg (55 deg right of the heading):
    # ahead, as 0.6 cos 55 = 0.344 > 0.5 x 0.6. The trail restarts from the follower to it:
    # gap 0.6; along = 0.25 sat(-0.9 / 0.25) = -0.25; the aim is the target, a 55 deg turn:
    # -0.25 cos 55 = -0.143394. The range law for 0.9 m: S = 0.6, s = -0.3, sat -1; numerator
    # -0.25 * 0.6 = -0.15, cos(beta) = cos 55: U = -0.15 / (0.6 cos 55) = -0.435862, the lower.
    # Yaw: 55 deg = 0.9599 rad, sat 1: 1.2.
    st = FormationSettings(controller="trail", range=RangeGains(min_speed_mps=-0.5))
    ctl = FormationController(st)
    tn, te = 0.6 * math.cos(math.radians(115.0)), 0.6 * math.sin(math.radians(115.0))
    ctl.estimator.init(tn, te)
    speed, yaw_rate = ctl._trail(tn, te, 0.0, 0.0, Odometry(0.0, 0.0, 0.0, math.pi / 3, 0.0), 0.1, False)
    assert speed == pytest.approx(-0.15 / (0.6 * math.cos(math.radians(55.0))), abs=1e-12)
    assert speed == pytest.approx(-0.435862, abs=1e-6)
    assert yaw_rate == pytest.approx(1.2, abs=1e-12)


def test_a_trail_follower_past_the_near_range_drives_the_trails_gap_even_with_the_target_ahead() -> None:
    # Wrong, a trail follower 1 m from a target ahead (beyond 0.9 m) would be held to the range
    # law's crawl instead of driving the long way round the trail the target went.
    # By hand: the trail (0,0) -> (0.5,0) -> (0.5,1) -> (1,1) -> (1,0), 3 m long, the still
    # target at its end (1, 0), 1 m dead ahead of the follower at its start facing north:
    # gap 3, the aim (0.5, 0) dead ahead: 0.25 sat(1.5 / 0.25) = 0.25 at cos 0; 1 m >= 0.9 m:
    # not too near. (The range law for 0.9 m would ask 0.25 sat(0.1 / 0.25) = 0.1.)
    ctl = FormationController(FormationSettings(controller="trail"))
    ctl.estimator.init(1.0, 0.0)
    ctl.trail.reset((0.0, 0.0), (0.5, 0.0), 0.0)
    for p in ((0.5, 1.0), (1.0, 1.0), (1.0, 0.0)):
        ctl.trail.extend(*p)
    ctl._trail_restart = False
    assert len(ctl.trail.points) == 5
    assert ctl._trail(1.0, 0.0, 0.0, 0.0, STILL, 0.1, False) == pytest.approx((0.25, 0.0), abs=1e-12)


@pytest.mark.parametrize(
    "kw",
    [
        {"origin_body_m": (math.nan, 0.0)},
        {"origin_body_m": (0.0, math.inf)},
        {"seen_back_m": math.nan},
        {"seen_back_m": math.inf},
        {"t_s": math.inf},
        {"t_s": math.nan},
    ],
)
def test_a_measurement_whose_time_or_ray_geometry_is_not_a_number_is_refused(kw: dict[str, object]) -> None:
    # Wrong, a bearing-only sighting with a NaN camera origin or banner offset put the fix, the
    # target's filter and every speed and yaw-rate command after it at NaN while the track
    # still read TRACKING; one stamped at t = inf was fused and every later one was stale.
    fields: dict[str, object] = {"t_s": 0.2, "status": TrackStatus.TRACKING, "bearing_rad": 0.1, "quality": 1.0, **kw}
    name = next(iter(kw))
    with pytest.raises(ValueError, match=f"a measurement's {name} must be a number"):
        RelativeMeasurement(**fields)  # type: ignore[arg-type]
    # a NaN range or bearing stays a sensor's "no sighting", not an error
    RelativeMeasurement(0.2, TrackStatus.TRACKING, math.nan, math.nan, 1.0)


def test_the_target_filters_prediction_by_hand_for_half_a_second() -> None:
    # Wrong, the target's filter would grow its uncertainty with the wrong power of the step,
    # or couple north with east's velocity (the state is [north, east, v_north, v_east]).
    # By hand: meas_sigma 0.03 (R = 0.0009), accel_sigma 0.3 (q = 0.09); init at (1, 2):
    # P0 = diag(0.0009, 0.0009, 0.25, 0.25); velocity set to (0.2, -0.1). dt = 0.5:
    # x = (1 + 0.1, 2 - 0.05, 0.2, -0.1) = (1.1, 1.95, 0.2, -0.1);
    # P[0, 0] = 0.0009 + dt^2 0.25 + q dt^4 / 4 = 0.0009 + 0.0625 + 0.00140625 = 0.06480625;
    # P[0, 2] = dt 0.25 + q dt^3 / 2 = 0.125 + 0.005625 = 0.130625;
    # P[2, 2] = 0.25 + q dt^2 = 0.25 + 0.0225 = 0.2725; north and east uncoupled: P[0, 1] =
    # P[0, 3] = P[1, 2] = 0.
    est = TargetEstimator(0.03, 0.3)
    est.init(1.0, 2.0)
    est.kf.x[2:4] = [0.2, -0.1]
    est.predict(0.5)
    assert est.kf.x == pytest.approx([1.1, 1.95, 0.2, -0.1], abs=1e-12)
    P = est.kf.P
    assert (P[0, 0], P[1, 1]) == pytest.approx((0.06480625, 0.06480625), abs=1e-12)
    assert (P[0, 2], P[1, 3], P[2, 0]) == pytest.approx((0.130625, 0.130625, 0.130625), abs=1e-12)
    assert (P[2, 2], P[3, 3]) == pytest.approx((0.2725, 0.2725), abs=1e-12)
    assert (P[0, 1], P[0, 3], P[1, 2], P[2, 3]) == (0.0, 0.0, 0.0, 0.0)
