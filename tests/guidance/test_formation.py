"""The formation controller: track-state behaviour, the target filter, the P baseline."""

from __future__ import annotations

import dataclasses
import math

import pytest

from lfctl.guidance.formation import FormationController, FormationSettings, Odometry
from lfctl.vision.track_state import RelativeMeasurement, TrackStatus

DT = 0.05


def meas(t: float, rng: float, brg: float = 0.0) -> RelativeMeasurement:
    return RelativeMeasurement(t, TrackStatus.TRACKING, rng, brg, 1.0)


def test_target_ahead_beyond_range_drives_forward_straight() -> None:
    ctl = FormationController(FormationSettings(range_cmd_m=1.5))
    out = ctl.step(meas(0.0, 2.5), Odometry(0.0, 0.0, 0.0, 0.0, 0.0))
    assert out.status is TrackStatus.TRACKING
    assert out.speed_mps > 0.2 and out.yaw_rate_radps == pytest.approx(0.0, abs=1e-9)
    assert out.range_est_m == pytest.approx(2.5)


@pytest.mark.parametrize("field", ["t_s", "north_m", "east_m", "yaw_rad", "speed_mps"])
def test_odometry_that_is_not_a_number_is_refused_and_leaves_the_filter_as_it_was(field: str) -> None:
    ctl = FormationController(FormationSettings(range_cmd_m=1.5))
    ctl.step(meas(0.0, 2.5), Odometry(0.0, 0.0, 0.0, 0.0, 0.0))
    good = ctl.step(meas(DT, 2.5), Odometry(DT, 0.0, 0.0, 0.0, 0.0))
    bad = {"t_s": 2 * DT, "north_m": 0.0, "east_m": 0.0, "yaw_rad": 0.0, "speed_mps": 0.0, field: math.nan}
    with pytest.raises(ValueError, match=f"odometry {field} is nan"):
        ctl.step(meas(2 * DT, 2.5), Odometry(**bad))
    out = ctl.step(meas(2 * DT, 2.5), Odometry(2 * DT, 0.0, 0.0, 0.0, 0.0))
    assert math.isfinite(out.speed_mps) and math.isfinite(out.yaw_rate_radps)
    assert out.range_est_m == pytest.approx(good.range_est_m, abs=1e-6)


def test_target_on_the_right_turns_right() -> None:
    ctl = FormationController(FormationSettings(range_cmd_m=1.5))
    out = ctl.step(meas(0.0, 1.5, math.radians(20)), Odometry(0.0, 0.0, 0.0, 0.0, 0.0))
    assert out.yaw_rate_radps > 0


def test_filter_estimates_a_moving_target_velocity() -> None:
    ctl = FormationController(FormationSettings(range_cmd_m=1.5))
    out = None
    for k in range(200):  # target moving north at 0.3 m/s, follower still at the origin
        t = k * DT
        out = ctl.step(meas(t, 2.0 + 0.3 * t), Odometry(t, 0.0, 0.0, 0.0, 0.0))
    assert out is not None
    assert out.target_vel_ned_mps[0] == pytest.approx(0.3, abs=0.01)
    assert out.target_vel_ned_mps[1] == pytest.approx(0.0, abs=0.01)


def test_coast_then_slow_down_then_lost() -> None:
    s = FormationSettings(range_cmd_m=1.5, coast_s=2.0, slowdown_s=1.0, search_yaw_rate_radps=0.0)
    ctl = FormationController(s)
    for k in range(40):  # moving target, tracked for 2 s
        t = k * DT
        ctl.step(meas(t, 2.0 + 0.3 * t), Odometry(t, 0.0, 0.0, 0.0, 0.0))
    t0 = 39 * DT
    seen = {}
    for k in range(1, 80):
        t = t0 + k * DT
        out = ctl.step(RelativeMeasurement(t, TrackStatus.OCCLUDED), Odometry(t, 0.0, 0.0, 0.0, 0.0))
        seen[round(k * DT, 2)] = out
    assert seen[1.0].status is TrackStatus.OCCLUDED and seen[1.0].speed_mps > 0.2  # coasting at full control
    assert seen[2.5].status is TrackStatus.OCCLUDED and 0 < seen[2.5].speed_mps < seen[1.0].speed_mps  # slowing
    assert seen[3.5].status is TrackStatus.LOST and seen[3.5].speed_mps == 0.0 and seen[3.5].yaw_rate_radps == 0.0
    # seen again: tracking resumes at once
    out = ctl.step(meas(t0 + 4.0, 2.0), Odometry(t0 + 4.0, 0.0, 0.0, 0.0, 0.0))
    assert out.status is TrackStatus.TRACKING and out.speed_mps > 0


def lose_target(brg_deg: float, search_degps: float = 45.0) -> tuple[FormationController, float]:
    """A controller that tracked a still target at ``brg_deg`` for 1 s, then lost it for good
    (OCCLUDED frames past the coast and slow-down): the controller and the time it is LOST."""
    s = FormationSettings(coast_s=1.0, slowdown_s=0.5, search_yaw_rate_radps=math.radians(search_degps))
    ctl = FormationController(s)
    for k in range(20):
        ctl.step(meas(k * DT, 2.0, math.radians(brg_deg)), Odometry(k * DT, 0.0, 0.0, 0.0, 0.0))
    return ctl, 19 * DT + 1.5


def turn_in_place(ctl: FormationController, t0: float, seconds: float) -> list[tuple[float, float, float]]:
    """Step a LOST controller whose vehicle turns exactly as commanded: (t, yaw, yaw rate)."""
    yaw, out = 0.0, []
    for k in range(1, round(seconds / DT) + 1):
        t = t0 + k * DT
        o = ctl.step(RelativeMeasurement(t, TrackStatus.OCCLUDED), Odometry(t, 0.0, 0.0, yaw, 0.0))
        assert o.status is TrackStatus.LOST and o.speed_mps == 0.0
        out.append((t, yaw, o.yaw_rate_radps))
        yaw = math.remainder(yaw + o.yaw_rate_radps * DT, 2 * math.pi)
    return out


@pytest.mark.parametrize(("brg_deg", "side"), [(20.0, 1.0), (-20.0, -1.0), (0.0, 1.0)])
def test_lost_looks_round_one_full_turn_towards_the_targets_side_then_holds(brg_deg: float, side: float) -> None:
    ctl, t_lost = lose_target(brg_deg)
    steps = turn_in_place(ctl, t_lost, 10.0)
    rate = math.radians(45.0)
    turning = [s for s in steps if s[2] != 0.0]
    assert {s[2] for s in turning} == {side * rate}  # one way, at the search rate
    # 360 deg at 45 deg/s: 8 s, to the step (the turn is counted from the odometry)
    assert len(turning) * DT == pytest.approx(8.0, abs=DT)
    assert all(s[2] == 0.0 for s in steps[len(turning) :])  # then holds, however long it waits
    assert steps[len(turning)][1] == pytest.approx(0.0, abs=rate * DT)  # facing where it began


def test_a_search_on_a_vehicle_that_does_not_turn_ends_at_twice_a_turns_time() -> None:
    """Car steering, a stalled rover, a frozen attitude: the yaw never moves, and the turn is
    not commanded for ever (8 s a turn at 45 deg/s: given up after 16 s)."""
    ctl, t_lost = lose_target(20.0)
    rates = []
    for k in range(1, round(30.0 / DT)):
        t = t_lost + k * DT
        rates.append(ctl.step(RelativeMeasurement(t, TrackStatus.OCCLUDED), Odometry(t, 0.0, 0.0, 0.0, 0.0)))
    turning = [o for o in rates if o.yaw_rate_radps != 0.0]
    assert len(turning) * DT == pytest.approx(16.0, abs=2 * DT)
    assert all(o.yaw_rate_radps == 0.0 for o in rates[len(turning) :])


def test_a_turn_the_other_way_is_no_progress() -> None:
    ctl, t_lost = lose_target(20.0)  # the search turns right
    yaw = 0.0
    for k in range(1, round(9.0 / DT)):  # 9 s of the vehicle turning left at the search rate
        t = t_lost + k * DT
        out = ctl.step(RelativeMeasurement(t, TrackStatus.OCCLUDED), Odometry(t, 0.0, 0.0, yaw, 0.0))
        assert out.yaw_rate_radps > 0.0  # still asking for its turn to the right
        yaw = math.remainder(yaw - math.radians(45.0) * DT, 2 * math.pi)


def test_a_longer_coast_set_during_a_search_does_not_bring_a_long_unseen_target_back() -> None:
    import dataclasses

    ctl, t_lost = lose_target(20.0)
    turn_in_place(ctl, t_lost, 1.0)
    ctl.settings = dataclasses.replace(ctl.settings, coast_s=10.0)  # a ground station's LFC_COAST
    t = t_lost + 1.0 + DT
    out = ctl.step(RelativeMeasurement(t, TrackStatus.OCCLUDED), Odometry(t, 0.0, 0.0, 0.0, 0.0))
    assert out.status is TrackStatus.LOST and out.speed_mps == 0.0 and out.yaw_rate_radps > 0.0


def test_lost_holds_still_with_no_search_rate() -> None:
    ctl, t_lost = lose_target(20.0, search_degps=0.0)
    assert {s[2] for s in turn_in_place(ctl, t_lost, 3.0)} == {0.0}


def test_the_search_waits_for_the_coast_and_starts_again_after_a_new_loss() -> None:
    ctl, t_lost = lose_target(20.0)
    # a sensor LOST straight after a sighting: stopped, not turning, until coast + slow-down
    t = t_lost - 1.5 + DT
    out = ctl.step(RelativeMeasurement(t, TrackStatus.LOST), Odometry(t, 0.0, 0.0, 0.0, 0.0))
    assert out.status is TrackStatus.LOST and (out.speed_mps, out.yaw_rate_radps) == (0.0, 0.0)
    turn_in_place(ctl, t_lost, 10.0)  # the whole turn, done
    # seen again on the left, then lost again: a new turn, to the left
    t = t_lost + 10.0 + DT
    ctl.step(meas(t, 2.0, math.radians(-30.0)), Odometry(t, 0.0, 0.0, 0.0, 0.0))
    steps = turn_in_place(ctl, t + 1.5, 2.0)
    assert steps[0][2] == pytest.approx(-math.radians(45.0))


def test_sensor_lost_stops_at_once() -> None:
    ctl = FormationController(FormationSettings())
    ctl.step(meas(0.0, 2.0), Odometry(0.0, 0.0, 0.0, 0.0, 0.0))
    out = ctl.step(RelativeMeasurement(DT, TrackStatus.LOST), Odometry(DT, 0.0, 0.0, 0.0, 0.0))
    assert out.status is TrackStatus.LOST and (out.speed_mps, out.yaw_rate_radps) == (0.0, 0.0)


def test_no_measurement_yet_is_lost_and_still() -> None:
    out = FormationController(FormationSettings()).step(None, Odometry(0.0, 0.0, 0.0, 0.0, 0.0))
    assert out.status is TrackStatus.LOST and out.speed_mps == 0.0


def test_delayed_measurement_is_placed_with_the_odometry_of_its_time() -> None:
    ctl = FormationController(FormationSettings())
    # the follower drove 0.3 m north since the image was taken: the target is 0.3 m closer now
    ctl.step(None, Odometry(0.0, 0.0, 0.0, 0.0, 0.3))
    out = ctl.step(meas(0.0, 2.0), Odometry(1.0, 0.3, 0.0, 0.0, 0.3))
    assert out.range_est_m == pytest.approx(1.7)


@pytest.mark.parametrize("law", ["smc", "p", "trail"])
def test_at_the_slot_with_a_still_target_every_law_holds_still(law: str) -> None:
    ctl = FormationController(FormationSettings(range_cmd_m=1.5, controller=law))
    out = None
    for k in range(100):
        out = ctl.step(meas(k * DT, 1.5), Odometry(k * DT, 0.0, 0.0, 0.0, 0.0))
    assert out is not None
    assert abs(out.speed_mps) < 0.01 and abs(out.yaw_rate_radps) < 0.01


def test_a_waypoint_with_a_wait_is_reported_reached_once() -> None:
    from lfctl.guidance.leader import AutopilotSettings, LeaderAutopilot

    ap = LeaderAutopilot([(1.0, 0.0, 5.0), (1.0, 2.0)], AutopilotSettings(), (0.0, 0.0))
    reached = []
    for k in range(100):  # at the waypoint, waiting out its 5 s
        reached.extend(ap.step(k * 0.05, 1.0, 0.0, 0.0, 0.05).los.reached)
    assert reached == [0]


def test_target_estimator_one_predict_and_update_by_hand() -> None:
    from lfctl.guidance.formation import TargetEstimator

    est = TargetEstimator(meas_sigma_m=0.1, accel_sigma_mps2=0.3)
    est.init(1.0, 2.0)  # P0 = diag(0.01, 0.01, 0.25, 0.25)
    est.predict(0.5)
    # Q = 0.09 [[dt^4/4, dt^3/2], [dt^3/2, dt^2]] = [[0.00140625, 0.005625], [0.005625, 0.0225]]
    # P_pp = 0.01 + dt^2 0.25 + 0.00140625, P_pv = dt 0.25 + 0.005625, P_vv = 0.25 + 0.0225
    P = est.kf.P
    assert (P[0, 0], P[0, 2], P[2, 2]) == pytest.approx((0.07390625, 0.130625, 0.2725))
    est.update(1.2, 2.0)
    # S = P_pp + 0.01; K = (P_pp, P_pv) / S; x = x + K 0.2
    S = 0.07390625 + 0.01
    assert est.position == pytest.approx((1.0 + 0.2 * 0.07390625 / S, 2.0))
    assert est.velocity == pytest.approx((0.2 * 0.130625 / S, 0.0))


# -- a bearing-only sighting: the camera's ray to the banner, placed between the reference points ----------
MOUNT_M, BACK_M = (0.12, 0.0), 0.155  # the default camera's mount (forward, right) and banner's offset


@pytest.mark.parametrize("slot_deg", [0.0, 15.0, 30.0, -30.0])
def test_bearing_only_sightings_of_a_still_target_in_its_slot_keep_it_there(slot_deg: float) -> None:
    # follower at the origin facing north; the leader's reference point 1.5 m away at the
    # slot's bearing, facing north too, its banner 0.155 m behind it (south). The camera, 0.12 m
    # ahead of the follower's reference point, sees the banner at (by hand, for 30 deg:
    # leader (1.2990, 0.75), banner (1.1440, 0.75), from the camera (1.0240, 0.75): 36.22 deg)
    b = math.radians(slot_deg)
    lead_n, lead_e = 1.5 * math.cos(b), 1.5 * math.sin(b)
    seen = math.atan2(lead_e - MOUNT_M[1], lead_n - BACK_M - MOUNT_M[0])
    if slot_deg == 30.0:
        assert math.degrees(seen) == pytest.approx(36.22, abs=0.01)
    ctl = FormationController(FormationSettings(range_cmd_m=1.5, bearing_cmd_rad=b))
    still = Odometry(0.0, 0.0, 0.0, 0.0, 0.0)
    out = ctl.step(meas(0.0, 1.5, b), still)  # one fix with a range (between the reference points)
    for k in range(1, 21):  # then 1 s of bearing-only sightings from the camera
        t = k * DT
        sighting = RelativeMeasurement(t, TrackStatus.TRACKING, None, seen, 0.5, MOUNT_M, BACK_M)
        out = ctl.step(sighting, Odometry(t, 0.0, 0.0, 0.0, 0.0))
    assert out.status is TrackStatus.TRACKING
    assert math.degrees(out.bearing_est_rad) == pytest.approx(slot_deg, abs=0.2)  # not the camera's 36 deg
    assert out.range_est_m == pytest.approx(1.5, abs=0.02)
    assert abs(out.yaw_rate_radps) < 0.02  # in its slot: no turn


def test_a_measurement_handed_again_is_not_fused_again_and_a_frozen_one_times_out() -> None:
    s = FormationSettings(range_cmd_m=1.5, coast_s=1.0, slowdown_s=0.5, search_yaw_rate_radps=0.0)
    once, again = FormationController(s), FormationController(s)
    first = meas(0.0, 2.0)
    for k in range(3):  # a camera at a third of the guidance rate: the same sample three steps running
        t = k * DT
        once.step(first if k == 0 else None, Odometry(t, 0.0, 0.0, 0.0, 0.0))
        out = again.step(first, Odometry(t, 0.0, 0.0, 0.0, 0.0))
        assert out.status is TrackStatus.TRACKING  # the latest frame showed it
    assert (again.estimator.kf.P == once.estimator.kf.P).all()  # taken once, as if not handed again
    assert (again.estimator.kf.x == once.estimator.kf.x).all()
    statuses = {}
    for k in range(3, 40):  # the camera stopped: its last sample, handed on and on
        t = k * DT
        statuses[round(t, 2)] = again.step(first, Odometry(t, 0.0, 0.0, 0.0, 0.0)).status
    assert statuses[1.0] is TrackStatus.TRACKING and statuses[1.2] is TrackStatus.OCCLUDED
    assert statuses[1.6] is TrackStatus.LOST  # past the coast and the slow-down: as unseen


@pytest.mark.parametrize("bad_range", [0.0, -1.0])
def test_a_range_of_zero_or_less_is_no_range(bad_range: float) -> None:
    # the bearing alone counts: it cannot start a filter, and in a running one it is a sighting
    ctl = FormationController(FormationSettings(range_cmd_m=1.5))
    assert ctl.step(meas(0.0, bad_range), Odometry(0.0, 0.0, 0.0, 0.0, 0.0)).status is TrackStatus.LOST
    ctl.step(meas(DT, 2.0), Odometry(DT, 0.0, 0.0, 0.0, 0.0))
    out = ctl.step(meas(2 * DT, bad_range), Odometry(2 * DT, 0.0, 0.0, 0.0, 0.0))
    assert out.status is TrackStatus.TRACKING and out.range_est_m == pytest.approx(2.0, abs=0.05)


@pytest.mark.parametrize(
    ("change", "said"),
    [
        ({"range_cmd_m": math.nan}, "range_cmd_m must be a number above 0, got nan"),
        ({"range_cmd_m": -1.0}, "range_cmd_m must be a number above 0, got -1.0"),
        ({"controller": "pid"}, "controller must be one of smc, p, trail, got 'pid'"),
        ({"bearing_cmd_rad": 4.0}, r"bearing_cmd_rad must be within -pi..pi, got 4.0"),
        ({"slowdown_s": 0.0}, "slowdown_s must be a number above 0"),
        ({"coast_s": math.inf}, "coast_s must be a number of at least 0, got inf"),
    ],
)
def test_settings_out_of_their_range_are_refused_naming_the_value(change: dict, said: str) -> None:
    # a NaN slot made a NaN speed command; an unknown law ran the P law under its own name
    with pytest.raises(ValueError, match=said):
        FormationSettings(**change)


def test_a_camera_at_half_the_guidance_rate_is_tracking_throughout_even_without_a_coast() -> None:
    # with coast_s 0 each repeated sample read as OCCLUDED: TOTOTO, the speed cut every other step
    s = FormationSettings(range_cmd_m=1.5, coast_s=0.0, slowdown_s=0.5)
    ctl = FormationController(s)
    seen = []
    for k in range(40):  # guidance at 20 Hz, a camera sample every other step (10 Hz)
        t = k * DT
        sample = meas(2 * (k // 2) * DT, 2.0)
        seen.append(ctl.step(sample, Odometry(t, 0.0, 0.0, 0.0, 0.0)).status)
    assert seen == [TrackStatus.TRACKING] * 40
    frozen = [ctl.step(meas(38 * DT, 2.0), Odometry(t, 0.0, 0.0, 0.0, 0.0)).status for t in (2.05, 2.1, 2.2, 2.3)]
    assert frozen == [TrackStatus.TRACKING, TrackStatus.TRACKING, TrackStatus.OCCLUDED, TrackStatus.OCCLUDED]


def test_a_gap_across_an_occlusion_is_not_taken_for_the_cameras_pace() -> None:
    # after 2 s unseen, a frozen camera's last sample must not stay TRACKING for twice that gap
    s = FormationSettings(range_cmd_m=1.5, coast_s=3.0, slowdown_s=0.5)
    ctl = FormationController(s)
    for k in range(10):  # a sample every step
        ctl.step(meas(k * DT, 2.0), Odometry(k * DT, 0.0, 0.0, 0.0, 0.0))
    for k in range(10, 50):  # hidden 2 s
        ctl.step(RelativeMeasurement(k * DT, TrackStatus.OCCLUDED), Odometry(k * DT, 0.0, 0.0, 0.0, 0.0))
    back = meas(50 * DT, 2.0)
    states = [ctl.step(back, Odometry(k * DT, 0.0, 0.0, 0.0, 0.0)).status for k in range(50, 56)]
    # due after 2 x 0.05 s (the step at exactly 0.1 s is on the boundary), not after 2 x 2 s
    assert states[:2] == [TrackStatus.TRACKING] * 2 and states[3:] == [TrackStatus.OCCLUDED] * 3


def test_a_status_or_an_odometry_of_the_wrong_type_is_named() -> None:
    # a string status was read as "not seen"; a tuple odometry gave an AttributeError
    with pytest.raises(TypeError, match=r"status must be a TrackStatus .*got 'tracking'"):
        RelativeMeasurement(0.0, "tracking", 2.0, 0.0)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"odometry must be an Odometry\(t_s, north_m, .*got \(0.0, 0, 0, 0, 0\)"):
        FormationController(FormationSettings()).step(None, (0.0, 0, 0, 0, 0))  # type: ignore[arg-type]


def test_a_lost_target_has_no_range_or_bearing_said() -> None:
    # the filter runs on with the last velocity while the target is unseen: its range for a
    # lost leader grew without end (26.9 m for one 2 m away, on the ground station's rng_err)
    ctl = FormationController(FormationSettings(range_cmd_m=1.5))
    still = Odometry(0.0, 0.0, 0.0, 0.0, 0.0)
    for k in range(20):  # the target walks off at 0.5 m/s, seen
        out = ctl.step(meas(k * DT, 1.5 + 0.5 * k * DT), dataclasses.replace(still, t_s=k * DT))
    assert out.status is TrackStatus.TRACKING and out.range_est_m is not None
    for k in range(20, 400):  # then unseen for 19 s
        out = ctl.step(None, dataclasses.replace(still, t_s=k * DT))
    assert out.status is TrackStatus.LOST
    assert out.range_est_m is None and out.bearing_est_rad is None
