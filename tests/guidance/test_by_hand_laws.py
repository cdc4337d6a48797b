"""The trail law and a live law change by hand, the trail's cursor after a back-up, and the
leader's autopilot details (one waypoint a step, its LOS lookahead, where it stops, the wait
left, the heading feed-forward and the speed's cosine squared).

Each test says what a user would see if the number were wrong, and the number worked by hand
from the code's equations (in the comments); the closed-loop ones are noiseless (nothing random)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import pytest

from lfctl.frames import wrap_pi
from lfctl.guidance.formation import FormationController, FormationOutput, FormationSettings, Odometry
from lfctl.guidance.leader import AutopilotSettings, LeaderAutopilot
from lfctl.guidance.smc import RangeGains
from lfctl.guidance.trail import Trail
from lfctl.vision.track_state import RelativeMeasurement, TrackStatus

DT = 0.05


class Unicycle:
    """A follower driven by its controller's commands, fed noiseless fixes of ``target(t)``
    (None: no fix that step)."""

    def __init__(self, ctl: FormationController, n: float, e: float, yaw: float) -> None:
        self.ctl, self.n, self.e, self.yaw, self.v = ctl, n, e, yaw, 0.0

    def odom(self, t: float) -> Odometry:
        return Odometry(t, self.n, self.e, self.yaw, self.v)

    def step(self, t: float, target: tuple[float, float] | None) -> FormationOutput:
        meas = None
        if target is not None:
            tn, te = target
            rng = math.hypot(tn - self.n, te - self.e)
            brg = wrap_pi(math.atan2(te - self.e, tn - self.n) - self.yaw)
            meas = RelativeMeasurement(t, TrackStatus.TRACKING, rng, brg, 1.0)
        out = self.ctl.step(meas, self.odom(t))
        self.v = out.speed_mps
        self.n += self.v * math.cos(self.yaw) * DT
        self.e += self.v * math.sin(self.yaw) * DT
        self.yaw += out.yaw_rate_radps * DT
        return out

    def run(self, target: Callable[[float], tuple[float, float]], k0: int, k1: int) -> None:
        for k in range(k0, k1):
            self.step(k * DT, target(k * DT))


def north(t: float) -> tuple[float, float]:
    return 0.3 * t, 0.0  # a target driving north at 0.3 m/s


# --- formation.py: a live law change (LFC_LAW) --------------------------------------------


def test_a_law_changed_live_back_to_trail_starts_a_fresh_trail_where_the_follower_is() -> None:
    # Wrong, a follower switched back to the trail law would drive the stale trail from before
    # the switch (here the straight north leg, not the corner the target turned since), or its
    # trail would restart every step and never grow (the law read as changed at each one).
    # By hand: trail 0-4 s, smc 4-8 s (the target turns east at 6 s), trail again from 8 s: the
    # trail restarts at 8 s from the follower's own position (slot bearing 0: no offset), then
    # grows a point every 0.05 m the target drives: 0.3 m/s * 3 s = 0.9 m, about 18 points.
    def corner(t: float) -> tuple[float, float]:
        return (0.3 * t, 0.0) if t < 6.0 else (1.8, 0.3 * (t - 6.0))

    trail = FormationSettings(range_cmd_m=1.5, controller="trail")
    car = Unicycle(FormationController(trail), -1.5, 0.0, 0.0)
    car.run(corner, 0, 80)
    assert len(car.ctl.trail.points) > 10  # the first trail grew
    car.ctl.settings = dataclasses.replace(trail, controller="smc")
    car.run(corner, 80, 160)
    car.ctl.settings = trail
    at_switch = (car.n, car.e)
    car.run(corner, 160, 161)
    assert car.ctl.trail.points[0] == pytest.approx(at_switch, abs=1e-9)
    car.run(corner, 161, 220)
    assert car.ctl.trail.points[0] == pytest.approx(at_switch, abs=1e-9)
    assert len(car.ctl.trail.points) > 10


# --- formation.py: the trail law (_trail) ---------------------------------------------------


def test_a_trail_slot_at_30_degrees_is_held_its_range_cos_30_along_the_trail() -> None:
    # Wrong, a 30 deg trail slot would sit 1.73 m back along the trail (1.5 / cos 30) instead
    # of 1.30 m, a range of 1.89 m instead of 1.5.
    # By hand: gap_cmd = 1.5 cos 30 = 1.299 m along the trail, offset 1.5 sin 30 = 0.75 m to
    # its left; in a straight line hypot(1.299, 0.75) = 1.5 m.
    st = FormationSettings(range_cmd_m=1.5, bearing_cmd_rad=math.radians(30.0), controller="trail")
    car = Unicycle(FormationController(st), -1.5 * math.cos(math.radians(30.0)), -0.75, 0.0)
    car.run(north, 0, 600)
    tn, te = north(600 * DT)
    assert tn - car.n == pytest.approx(1.5 * math.cos(math.radians(30.0)), abs=0.03)
    assert te - car.e == pytest.approx(0.75, abs=0.03)
    assert math.hypot(tn - car.n, te - car.e) == pytest.approx(1.5, abs=0.03)


def test_the_trail_grows_from_fresh_fixes_of_a_moving_target_and_not_while_it_is_hidden() -> None:
    # Wrong, the filter's guess while the target is hidden would go into its trail (a corner
    # turned out of sight would be driven as an overshoot), or a moving target leave none.
    # By hand: a target going north at 0.3 m/s: a point each 0.05 m, 6 a second while seen;
    # none for the 1 s it is hidden (the filter coasts 0.3 m meanwhile).
    car = Unicycle(FormationController(FormationSettings(range_cmd_m=1.5, controller="trail")), -1.5, 0.0, 0.0)
    car.run(north, 0, 100)
    seen = len(car.ctl.trail.points)
    assert seen > 20
    for k in range(100, 120):
        out = car.step(k * DT, None)
        assert out.status is TrackStatus.OCCLUDED
    assert len(car.ctl.trail.points) == seen


def test_a_target_creeping_too_slowly_for_the_filter_to_tell_from_still_adds_nothing_to_the_trail() -> None:
    # Wrong, the trail would grow from the estimate of a target the filter takes as still (as
    # a standing target's estimate wanders with its noise), and the follower drive that wander.
    # By hand: the filter's velocity sigma settles near 0.044 m/s; 0.02 m/s is
    # (0.02 / 0.044)^2 = 0.21 < 2^2 sigma-squared: taken as 0, so no point is added, though
    # in 20 s the target creeps 0.4 m, 8 spacings of 0.05 m. The trail stays its 2 points.
    def creep(t: float) -> tuple[float, float]:
        return 0.02 * t, 0.0

    car = Unicycle(FormationController(FormationSettings(range_cmd_m=1.5, controller="trail")), -1.5, 0.0, 0.0)
    for k in range(400):
        out = car.step(k * DT, creep(k * DT))
        assert out.target_vel_ned_mps == (0.0, 0.0)
    assert len(car.ctl.trail.points) == 2


def test_a_trail_slot_under_a_metre_keeps_its_trail() -> None:
    # Wrong, with a slot under about 1 m the trail would restart every step (its gap taken
    # as negative) and the follower cut every corner.
    # By hand: slot 0.8 m: the gap along the trail is about 0.8 > 0: no restart; the trail
    # grows from 2 points to about 0.3 * 10 / 0.05 = 60.
    car = Unicycle(FormationController(FormationSettings(range_cmd_m=0.8, controller="trail")), -0.8, 0.0, 0.0)
    car.run(north, 0, 200)
    assert len(car.ctl.trail.points) > 40
    assert car.ctl.trail.points[0] == pytest.approx((-0.8, 0.0), abs=1e-9)
    assert math.hypot(north(200 * DT)[0] - car.n, car.e) == pytest.approx(0.8, abs=0.03)


def test_a_trail_started_at_a_turned_heading_starts_the_slots_offset_to_the_followers_side() -> None:
    # Wrong, a follower facing anywhere but north would start its trail on the wrong side or
    # at the wrong distance, and swing across to it.
    # By hand: bearing 20 deg: offset = -1.5 sin 20 = -0.513030 (the trail right of the
    # follower). Facing 60 deg: start = (0 + offset sin 60, 0 - offset cos 60)
    # = (-0.444297, 0.256515). Facing 90 deg (the report's case): (-0.513030, 0).
    for yaw, start in ((math.pi / 3, (-0.444297, 0.256515)), (math.pi / 2, (-0.513030, 0.0))):
        st = FormationSettings(controller="trail", bearing_cmd_rad=math.radians(20.0))
        ctl = FormationController(st)
        ctl.step(RelativeMeasurement(0.0, TrackStatus.TRACKING, 2.0, 0.0, 1.0), Odometry(0.0, 0.0, 0.0, yaw, 0.0))
        assert ctl.trail.points[0] == pytest.approx(start, abs=1e-6)
        # and its end is the target, 2 m ahead
        assert ctl.trail.points[1] == pytest.approx((2.0 * math.cos(yaw), 2.0 * math.sin(yaw)), abs=1e-9)


def test_a_follower_further_than_its_slot_in_a_straight_line_does_not_back_along_the_trail() -> None:
    # Wrong, a follower that cut a corner, 1.7 m from a still target due north of it, would
    # back away along the trail (the gap along it short) and away from the target.
    # By hand: trail (0,0) -> (2,0) -> (2,2), the target still at its end (2, 2); the follower
    # at (0.3, 2) facing north is located at the end of the east leg: gap 0 < 1.5. The law
    # along the trail asks -0.25, held at -0.15, but 1.7 m > 1.5 m in a straight line: 0.0.
    st = FormationSettings(range_cmd_m=1.5, controller="trail", range=RangeGains(min_speed_mps=-0.15))
    ctl = FormationController(st)
    ctl.estimator.init(2.0, 2.0)
    ctl.trail.reset((0.0, 0.0), (2.0, 0.0), 0.0)
    ctl.trail.extend(2.0, 2.0)
    ctl._trail_restart = False
    speed, _ = ctl._trail(2.0, 2.0, 0.0, 0.0, Odometry(0.0, 0.3, 2.0, 0.0, 0.0), 0.1, False)
    assert speed == 0.0


# --- trail.py: the cursor after a back-up ---------------------------------------------------


def test_a_target_backing_up_three_segments_brings_the_cursor_back_to_the_last_segment() -> None:
    # Wrong, after a back-up the cursor would point past the trail's last segment (the aim
    # then starts past the end) or a segment short of it.
    # By hand: spacing 1, points (0,0)..(5,0); the follower located at (4.5, 0): segment 4.
    # The target at (2.5, 0) backs past (5,0), (4,0), (3,0) (each behind the end along the
    # last segment), leaving (0,0), (1,0), (2,0): cursor min(4, 3 - 2) = 1.
    t = Trail(spacing_m=1.0)
    t.reset((0.0, 0.0), (1.0, 0.0), 0.0)
    for n in (2.0, 3.0, 4.0, 5.0):
        t.extend(n, 0.0)
    assert t.locate(4.5, 0.0).s_m == pytest.approx(4.5) and t.cursor == 4
    t.extend(2.5, 0.0)
    assert t.points == [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)]
    assert t.cursor == len(t.points) - 2 == 1
    assert t.aim(1.5, 0.0, 0.3) == pytest.approx((2.0, 0.0))


# --- leader.py ------------------------------------------------------------------------------


def test_one_waypoint_a_step_reaches_only_the_first_of_two_within_reach() -> None:
    # Wrong, a mission's items waiting where the one before ended would be passed in one step
    # (none of them would begin, change its wait or speed), or kept to one when not asked.
    # By hand: (0,1) and again (0,1) (a segment of no length), then (0,3); on (0,1): one a
    # step: (0,); all: (0, 1).
    route = [(0.0, 1.0), (0.0, 1.0), (0.0, 3.0)]
    one = LeaderAutopilot(route, AutopilotSettings(), (0.0, 0.0), one_per_step=True)
    assert one.step(0.0, 0.0, 1.0, math.pi / 2, 0.1).los.reached == (0,)
    assert one.step(0.1, 0.0, 1.0, math.pi / 2, 0.1).los.reached == (1,)
    every = LeaderAutopilot(route, AutopilotSettings(), (0.0, 0.0))
    assert every.step(0.0, 0.0, 1.0, math.pi / 2, 0.1).los.reached == (0, 1)


def test_the_leader_stops_on_its_last_and_waiting_waypoints_and_on_no_other_index() -> None:
    # Wrong, the leader would be told it stops at waypoints that do not exist.
    ap = LeaderAutopilot([(0.0, 1.0, 2.0), (0.0, 2.0), (0.0, 3.0)], AutopilotSettings(), (0.0, 0.0), stop_at={1})
    assert [ap.stops_at(i) for i in (-1, 0, 1, 2, 3)] == [False, True, True, True, False]
    plain = LeaderAutopilot([(0.0, 1.0), (0.0, 2.0)], AutopilotSettings(), (0.0, 0.0))
    assert [plain.stops_at(i) for i in (-1, 0, 1, 2)] == [False, False, True, False]


def test_the_wait_left_counts_down_while_waiting() -> None:
    # Wrong, a ground station would see the wait left grow instead of shrink.
    # By hand: reached at 0 s with a 0.5 s wait: until 0.5 s; at 0.2 s, 0.3 s left.
    ap = LeaderAutopilot([(0.0, 1.0, 0.5), (0.0, 3.0)], AutopilotSettings(), (0.0, 0.0))
    ap.step(0.0, 0.0, 1.0, math.pi / 2, 0.1)
    out = ap.step(0.2, 0.0, 1.0, math.pi / 2, 0.1)
    assert out.speed_mps == 0.0 and out.holding_s == pytest.approx(0.3, abs=1e-12)


def test_the_leaders_heading_is_los_with_its_lookahead_and_the_command_turn_fed_forward() -> None:
    # Wrong, the leader would chase the waypoint (pure pursuit) instead of its path, or steer
    # without (or with too much of) the commanded heading's own turn rate.
    # By hand: (0,0) -> (10,0) north, lookahead 0.8. At (0,0), heading 0: on the path, command
    # 0, no error: 0 rad/s. At (0, 0.1) 0.1 s later: 0.1 m right: command -atan(0.1 / 0.8)
    # = -0.124355 (pure pursuit: -atan(0.1 / 10) = -0.0100); its rate -1.24355 rad/s fed
    # forward held at -0.5; the error's rate the same -1.24355: s = -0.124355 + 0.1 * -1.24355
    # = -0.248710; r = -0.5 + 1.0 * (-0.248710 / 0.35) = -1.210600 (within 1.5).
    ap = LeaderAutopilot([(10.0, 0.0), (20.0, 0.0)], AutopilotSettings(), (0.0, 0.0))
    assert ap.step(0.0, 0.0, 0.0, 0.0, 0.1).yaw_rate_radps == 0.0
    out = ap.step(0.1, 0.0, 0.1, 0.0, 0.1)
    cmd = -math.atan2(0.1, 0.8)
    assert out.los.heading_cmd_rad == pytest.approx(cmd, abs=1e-12)
    assert out.yaw_rate_radps == pytest.approx(-0.5 + (cmd + 0.1 * cmd / 0.1) / 0.35, abs=1e-9)
    assert out.yaw_rate_radps == pytest.approx(-1.210600, abs=1e-6)
    # the mirror image, 0.1 m left: +1.210600 (the feed-forward held at +0.5)
    ap = LeaderAutopilot([(10.0, 0.0), (20.0, 0.0)], AutopilotSettings(), (0.0, 0.0))
    ap.step(0.0, 0.0, 0.0, 0.0, 0.1)
    assert ap.step(0.1, 0.0, -0.1, 0.0, 0.1).yaw_rate_radps == pytest.approx(1.210600, abs=1e-6)


def test_the_leader_slows_with_the_square_of_the_cosine_of_its_heading_error() -> None:
    # Wrong, a leader turning onto its leg would drive it too fast (cos * 2: faster than cruise).
    # By hand: 10 m from the next waypoint (no turn slow-down: blend 0), not a stop, heading
    # error -0.5 rad: 0.3 cos^2(0.5) = 0.231045.
    ap = LeaderAutopilot([(10.0, 0.0), (20.0, 0.0)], AutopilotSettings(), (0.0, 0.0))
    out = ap.step(0.0, 0.0, 0.0, 0.5, 0.1)
    assert out.speed_mps == pytest.approx(0.3 * math.cos(0.5) ** 2, rel=1e-12)
    assert out.speed_mps == pytest.approx(0.231045, abs=1e-6)
