"""The trail law: the target's path as the follower estimated it, located on by hand, the
range law along it, and a follower closing a square behind a target without cutting its
corners (kinematic loop, no FMU)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lfctl.frames import wrap_pi
from lfctl.guidance.formation import FormationController, FormationSettings, Odometry
from lfctl.guidance.smc import RangeGains
from lfctl.guidance.trail import Trail, trail_speed_mps
from lfctl.metrics import distance_to_path
from lfctl.vision.track_state import RelativeMeasurement, TrackStatus


def l_trail() -> Trail:
    # north 2 m, then east 2 m, a point each 0.5 m
    t = Trail(spacing_m=0.5)
    t.reset((0.0, 0.0), (0.5, 0.0), 0.0)
    for n, e in [(1.0, 0.0), (1.5, 0.0), (2.0, 0.0), (2.0, 0.5), (2.0, 1.0), (2.0, 1.5), (2.0, 2.0)]:
        t.extend(n, e)
    return t


def test_a_point_is_located_by_arc_length_side_and_heading() -> None:
    t = l_trail()
    assert t.s[-1] == pytest.approx(4.0)
    fix = t.locate(1.2, 0.3)  # 0.3 m east of the first leg: right of a trail heading north
    assert (fix.s_m, fix.cross_m, fix.heading_rad) == pytest.approx((1.2, 0.3, 0.0))
    fix = t.locate(2.4, 1.0)  # 0.4 m north of the second leg: left of a trail heading east
    assert (fix.s_m, fix.cross_m, fix.heading_rad) == pytest.approx((3.0, -0.4, math.pi / 2))
    assert t.end_s(2.0, 2.3) == pytest.approx(4.3)  # the target 0.3 m past the last point


def test_the_aim_is_the_first_point_a_lookahead_away_and_ahead() -> None:
    t = l_trail()
    t.locate(1.2, 0.0)
    assert t.aim(1.2, 0.0, 0.6) == pytest.approx((2.0, 0.0))  # 0.8 m on: (1.5, 0) is only 0.3 away
    assert t.aim(1.2, 0.0, 1.0) == pytest.approx((2.0, 1.0))  # (2, 0.5) is 0.94 away
    assert t.aim(1.2, 0.0, 9.0) == pytest.approx((2.0, 2.0))  # none that far: the end
    # 0.5 m to the right of the trail (east of the first leg, south of the second): inside
    # the corner. Level with the corner, at (1.5, 0.5), the shifted points just past it,
    # (1.5, 0.5) itself and (1.5, 1.0), are not a lookahead ahead: it aims along the second leg
    t.locate(1.5, 0.5)
    assert t.aim(1.5, 0.5, 0.6, offset_m=0.5) == pytest.approx((1.5, 1.5))


def test_points_closer_than_the_spacing_are_not_kept_and_the_oldest_go_first() -> None:
    t = Trail(spacing_m=0.1, max_points=4)
    t.reset((0.0, 0.0), (0.05, 0.0), 0.0)  # the target's first place is kept however near
    t.extend(0.1, 0.0)  # 0.05 from the last: not kept
    assert len(t.points) == 2
    for n in (0.25, 0.4, 0.55):
        t.extend(n, 0.0)
    assert t.points == pytest.approx([(0.05, 0.0), (0.25, 0.0), (0.4, 0.0), (0.55, 0.0)]) and t.s[0] == pytest.approx(
        0.05
    )
    assert t.locate(0.45, 0.0).s_m == pytest.approx(0.45)  # arc lengths still count from the start


def test_a_target_on_the_follower_starts_the_trail_along_its_heading() -> None:
    t = Trail(spacing_m=0.1)
    t.reset((1.0, 1.0), (1.0, 1.0), math.pi / 2)  # a fix at range 0: east 0.1 m
    assert t.points == pytest.approx([(1.0, 1.0), (1.0, 1.1)])
    assert t.locate(1.0, 1.0).s_m == pytest.approx(0.0)


def test_a_target_that_backs_up_takes_the_trail_back_with_it() -> None:
    t = l_trail()  # north 2 m, then east 2 m
    t.extend(2.0, 1.2)  # backed 0.8 m west along the second leg
    assert t.points[-1] == pytest.approx((2.0, 1.0)) and t.end_s(2.0, 1.2) == pytest.approx(3.2)
    t.extend(1.0, 0.0)  # and on back down the first leg, past the corner
    assert t.end_s(1.0, 0.0) == pytest.approx(1.0)
    t.extend(-1.0, 0.0)  # behind the trail's start: the first segment is kept, not folded
    assert len(t.points) == 2 and t.end_s(-1.0, 0.0) == pytest.approx(-1.0)


def test_behind_the_trails_start_the_arc_length_is_negative() -> None:
    t = l_trail()
    fix = t.locate(-0.5, 0.1)
    assert (fix.s_m, fix.cross_m) == pytest.approx((-0.5, 0.1))


def test_bad_trails_are_refused() -> None:
    with pytest.raises(ValueError, match="spacing_m"):
        Trail(spacing_m=0.0)
    with pytest.raises(ValueError, match="reset it first"):
        Trail().locate(0.0, 0.0)


@given(st.floats(-1.0, 5.0), st.floats(-2.0, 4.0))
def test_the_place_found_is_the_nearest_on_the_trail(n: float, e: float) -> None:
    t = l_trail()
    fix = t.locate(n, e)
    if n < 0.0:  # behind the start the first segment runs on backwards (its own test)
        return
    nearest = distance_to_path(np.array(t.points), n, e)
    # the point at the arc length found is the trail's nearest; the side is the offset from
    # that segment's line (no more than the distance: less past either end)
    k = t.cursor
    assert distance_to_path(np.array(t.points[k : k + 2]), n, e) == pytest.approx(nearest, abs=1e-9)
    assert t.s[k] - 1e-9 <= fix.s_m <= t.s[k + 1] + 1e-9
    assert abs(fix.cross_m) <= nearest + 1e-9


def test_the_range_law_along_the_trail_by_hand() -> None:
    g = RangeGains(eta_mps=0.25, phi_m=0.25, min_speed_mps=-0.15, max_speed_mps=0.5)
    # 0.1 m behind the slot: the target's 0.3 plus 0.25 x 0.1 / 0.25 = 0.4 m/s
    assert trail_speed_mps(1.6, 1.5, 0.3, 0.0, g) == pytest.approx(0.4)
    # a 60 deg turn still to make halves it
    assert trail_speed_mps(1.6, 1.5, 0.3, math.radians(60), g) == pytest.approx(0.2)
    # far behind: 0.3 + 0.25 = 0.55, saturated to 0.5; past 90 deg it turns in place
    assert trail_speed_mps(3.0, 1.5, 0.3, 0.0, g) == pytest.approx(0.5)
    assert trail_speed_mps(3.0, 1.5, 0.3, math.radians(120), g) == 0.0
    # too close to a still target: backs up, at most the reverse limit
    assert trail_speed_mps(1.0, 1.5, 0.0, 0.0, g) == pytest.approx(-0.15)


def square(t: float, speed: float = 0.3, side: float = 3.0) -> tuple[float, float]:
    """A target driving a square's sides at ``speed``: north, east, south, ... (sharp corners)."""
    s = (speed * t) % (4 * side)
    k, u = int(s // side), s % side
    corners = [(0.0, 0.0), (side, 0.0), (side, side), (0.0, side)]
    (n0, e0), (n1, e1) = corners[k], corners[(k + 1) % 4]
    return n0 + (n1 - n0) * u / side, e0 + (e1 - e0) * u / side


def drive(law: str, seconds: float = 45.0, dt: float = 0.05, bearing_deg: float = 0.0) -> tuple[float, float]:
    """A unicycle follower in a slot 1.5 m from the square's target: its largest path error
    after 5 s (its distance from the target's path less the slot's sideways offset), and its
    last range."""
    b = math.radians(bearing_deg)
    settings = FormationSettings(range_cmd_m=1.5, bearing_cmd_rad=b, controller=law)  # type: ignore[arg-type]
    ctl = FormationController(settings)
    offset = abs(1.5 * math.sin(b))
    n, e, yaw, v = -1.5 * math.cos(b), 1.5 * math.sin(-b), 0.0, 0.0
    worst, path = 0.0, [(-10.0, 0.0), (0.0, 0.0)]
    for k in range(int(seconds / dt)):
        t = k * dt
        tn, te = square(t)
        path.append((tn, te))
        rng = math.hypot(tn - n, te - e)
        brg = wrap_pi(math.atan2(te - e, tn - n) - yaw)
        out = ctl.step(RelativeMeasurement(t, TrackStatus.TRACKING, rng, brg, 1.0), Odometry(t, n, e, yaw, v))
        v = out.speed_mps
        n, e, yaw = n + v * math.cos(yaw) * dt, e + v * math.sin(yaw) * dt, yaw + out.yaw_rate_radps * dt
        if t > 5.0:
            worst = max(worst, abs(distance_to_path(np.array(path[-400:]), n, e) - offset))
    return worst, math.hypot(square(seconds)[0] - n, square(seconds)[1] - e)


def test_a_trail_follower_keeps_to_the_targets_path_where_pursuit_cuts_its_corners() -> None:
    trail, trail_range = drive("trail")
    smc, _ = drive("smc")
    assert smc > 0.4  # the pursuit law cuts each corner (about 0.5 m on this square)
    assert trail < 0.1, trail
    assert 1.0 < trail_range < 1.6  # the gap held along the path (shorter across a corner)


@pytest.mark.parametrize("bearing_deg", [-30.0, 30.0])
def test_a_trail_follower_beside_the_path_keeps_its_offset_round_corners(bearing_deg: float) -> None:
    # -30 deg: 0.75 m right of the path, inside each right-hand corner of the square; 30:
    # outside, where the shifted legs leave a gap round the corner that the follower crosses on
    # a chord, up to 0.75 (1 - cos 45 deg) = 0.22 m inside the arc 0.75 m from the corner
    worst, rng = drive("trail", bearing_deg=bearing_deg)
    assert worst < 0.25, worst
    assert worst < drive("smc", bearing_deg=bearing_deg)[0] / 3  # the pursuit law: 0.33 and 0.75
    assert 0.8 < rng < 2.3  # inside the corner the path is shorter, outside longer


def test_the_trail_law_keeps_the_target_in_a_narrow_camera_view() -> None:
    """A 31 deg half-view, a 0.22 m banner at 1.5 m (4.2 deg) and the 5 deg margin: the
    heading is commanded within 21.8 deg of the target; the bearing law's lag lets the true
    bearing run a few degrees past that, never out of the picture."""
    half = math.radians(31.0)
    settings = FormationSettings(range_cmd_m=1.5, controller="trail", view_half_fov_rad=half, banner_half_m=0.11)
    ctl = FormationController(settings)
    n, e, yaw, v, dt = -1.5, 0.0, 0.0, 0.0, 0.05
    worst = 0.0
    for k in range(int(40.0 / dt)):
        t = k * dt
        tn, te = square(t)
        brg = wrap_pi(math.atan2(te - e, tn - n) - yaw)
        out = ctl.step(
            RelativeMeasurement(t, TrackStatus.TRACKING, math.hypot(tn - n, te - e), brg, 1.0),
            Odometry(t, n, e, yaw, v),
        )
        v = out.speed_mps
        n, e, yaw = n + v * math.cos(yaw) * dt, e + v * math.sin(yaw) * dt, yaw + out.yaw_rate_radps * dt
        if t > 5.0:
            worst = max(worst, abs(brg))
    assert math.radians(21.8) < worst < math.radians(27.0), math.degrees(worst)  # 31 less the banner's 4.2


def follow(
    target,
    seconds: float,
    settings: FormationSettings,
    noise: tuple[float, float] = (0.0, 0.0),
    seed: int = 0,
    change: tuple[float, FormationSettings] | None = None,
    start: tuple[float, float, float] | None = None,
):
    """A unicycle follower starting in its slot behind ``target(t) -> (north, east)`` (its
    settings replaced by ``change`` = (time, settings), as a ground station's would be); the
    range to the target at each step (and the speed commands, as ``follow.speeds``)."""
    rng = np.random.default_rng(seed)
    ctl = FormationController(settings)
    tn, te = target(0.0)
    n, e, yaw = start if start is not None else (tn - settings.range_cmd_m, te, 0.0)
    v, dt = 0.0, 0.05
    ranges = []
    follow.speeds = []
    for k in range(int(seconds / dt)):
        t = k * dt
        if change is not None and abs(t - change[0]) < dt / 2:
            ctl.settings = change[1]
        tn, te = target(t)
        r = math.hypot(tn - n, te - e) + rng.normal(0.0, noise[0])
        b = wrap_pi(math.atan2(te - e, tn - n) - yaw) + rng.normal(0.0, noise[1])
        out = ctl.step(RelativeMeasurement(t, TrackStatus.TRACKING, r, b, 1.0), Odometry(t, n, e, yaw, v))
        v = out.speed_mps
        follow.speeds.append(v)
        n, e, yaw = n + v * math.cos(yaw) * dt, e + v * math.sin(yaw) * dt, yaw + out.yaw_rate_radps * dt
        ranges.append(math.hypot(tn - n, te - e))
    return ranges


TRAIL = FormationSettings(range_cmd_m=1.5, controller="trail", range=RangeGains(min_speed_mps=-0.15))


def test_a_target_that_backs_up_is_backed_away_from() -> None:
    # forward 3 m at 0.3 m/s, back 0.6 m at 0.15 m/s, forward again: the gap along the trail
    # shrinks with it, and the follower backs up as the range law does
    def target(t: float) -> tuple[float, float]:
        s = 0.3 * t if t < 10 else (3.0 - 0.15 * (t - 10) if t < 14 else 2.4 + 0.3 * (t - 14))
        return s, 0.0

    ranges = follow(target, 30.0, TRAIL)
    assert min(ranges) > 1.2 and abs(ranges[-1] - 1.5) < 0.05, (min(ranges), ranges[-1])


def test_behind_a_still_target_a_longer_slot_is_reached_and_held() -> None:
    # the slot raised from 1.5 to 3 m at 2 s behind a target that does not move: the follower
    # backs off 1.5 m and stops (the trail runs on backwards behind its first point)
    longer = (2.0, dataclasses.replace(TRAIL, range_cmd_m=3.0))
    ranges = follow(lambda t: (0.0, 0.0), 30.0, TRAIL, change=longer)
    assert ranges[30] == pytest.approx(1.5, abs=0.01)
    assert abs(ranges[-1] - 3.0) < 0.05 and abs(ranges[-1] - ranges[-40]) < 0.01


def test_past_a_corner_a_longer_slot_is_not_backed_into_for_ever() -> None:
    # 4 m north, 2.5 m east, then still; the slot raised to 3 m once it stands: the follower,
    # round the corner, has to back past it; it stops once 3 m away in a straight line
    def target(t: float) -> tuple[float, float]:
        s = min(0.3 * t, 6.5)
        return (s, 0.0) if s < 4.0 else (4.0, s - 4.0)

    ranges = follow(target, 90.0, TRAIL, change=(40.0, dataclasses.replace(TRAIL, range_cmd_m=3.0)))
    assert 2.9 < ranges[-1] < 3.2 and abs(ranges[-1] - ranges[-100]) < 0.01, ranges[-1]


def test_a_target_first_seen_coming_past_the_follower_is_turned_round_and_followed() -> None:
    # it starts 3 m ahead and 1 m right, driving south past the follower, which faces north
    ranges = follow(lambda t: (3.0 - 0.3 * t, 1.0), 60.0, TRAIL, start=(0.0, 0.0, 0.0))
    assert ranges[-1] == pytest.approx(1.5, abs=0.1) and abs(ranges[-1] - ranges[-100]) < 0.05, ranges[-1]


def test_a_target_that_turns_back_past_the_follower_is_followed_back() -> None:
    # north 4 m, 1 m east, then back south 1 m beside its way up (a survey's line end, lines 1 m
    # apart): it comes back past the follower, beside it (never backed away from), and is
    # followed down its new line
    def target(t: float) -> tuple[float, float]:
        s = 0.3 * t
        return (s, 0.0) if s < 4.0 else ((4.0, s - 4.0) if s < 5.0 else (4.0 - (s - 5.0), 1.0))

    ranges = follow(target, 60.0, TRAIL)
    assert min(ranges) > 0.5 and ranges[-1] == pytest.approx(1.5, abs=0.1), (min(ranges), ranges[-1])


def test_a_slot_too_wide_for_the_trail_is_held_by_the_sliding_mode_law() -> None:
    # a ground station sets 60 deg: the paper's law holds it, the trail starts afresh after
    wide = dataclasses.replace(TRAIL, bearing_cmd_rad=math.radians(-60.0))
    smc = dataclasses.replace(wide, controller="smc")
    straight = lambda t: (0.3 * t, 0.0)  # noqa: E731
    assert follow(straight, 20.0, wide)[-50:] == pytest.approx(follow(straight, 20.0, smc)[-50:])


def test_a_scenario_with_a_slot_too_wide_for_the_trail_is_refused() -> None:
    from lfctl.config import TRAIL_MAX_BEARING_DEG, parse_config
    from lfctl.errors import ConfigError
    from lfctl.guidance.formation import TRAIL_MAX_BEARING_RAD

    assert math.radians(TRAIL_MAX_BEARING_DEG) == TRAIL_MAX_BEARING_RAD  # config may not import guidance
    head = '[[vehicles]]\nname = "leader"\nrole = "leader"\n[[vehicles]]\nname = "f1"\nrole = "follower"\n'
    ok = parse_config(head + "bearing_deg = -30\n[guidance]\ncontroller = 'trail'\n")
    assert ok.guidance.controller == "trail"
    with pytest.raises(ConfigError, match=r"vehicles\[f1\]: a slot at bearing -35 deg is wider than .*at most 30 deg"):
        parse_config(head + "bearing_deg = -35\n[guidance]\ncontroller = 'trail'\n")


def test_a_slot_at_or_past_the_side_is_refused_for_the_sliding_mode_law_and_held_by_p_when_set_live() -> None:
    from lfctl.config import SMC_MAX_BEARING_DEG, parse_config
    from lfctl.errors import ConfigError
    from lfctl.guidance.formation import SMC_MAX_BEARING_RAD

    assert math.radians(SMC_MAX_BEARING_DEG) == SMC_MAX_BEARING_RAD  # config may not import guidance
    head = '[[vehicles]]\nname = "leader"\nrole = "leader"\n[[vehicles]]\nname = "f1"\nrole = "follower"\n'
    assert parse_config(head + "bearing_deg = 89\n").slots()["f1"].bearing_rad == pytest.approx(math.radians(89))
    with pytest.raises(ConfigError, match=r'vehicles\[f1\]: a slot at bearing -90 deg is at or past the side.*use "p"'):
        parse_config(head + "bearing_deg = -90\n")
    assert parse_config(head + "bearing_deg = 120\n[guidance]\ncontroller = 'p'\n").guidance.controller == "p"
    # a ground station sets 100 deg while the sliding-mode law drives (LFC_BEARING): the P law holds it
    abeam = dataclasses.replace(TRAIL, controller="smc", bearing_cmd_rad=math.radians(100.0))
    straight = lambda t: (0.3 * t, 0.0)  # noqa: E731
    p_law = dataclasses.replace(abeam, controller="p")
    assert follow(straight, 10.0, abeam)[-20:] == pytest.approx(follow(straight, 10.0, p_law)[-20:])
    assert follow(straight, 30.0, abeam)[-1] == pytest.approx(1.5, abs=0.15)  # and holds it
