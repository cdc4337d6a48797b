"""SmartRTL's way back cleaned as a Rover cleans it (AP_SmartRTL): simplification at half
SRTL_ACCURACY, loops pruned at 0.99 of it, hand-worked; and the endpoint's SRTL_ parameters,
cleanup on entering SmartRTL and giving up when the points run out."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mav
from test_endpoint_rover import Bench

from lfctl.link.endpoint import MODES, SRTL_SAVE_PERIOD_S, SRTL_TIMEOUT_S
from lfctl.link.smartrtl import clean, leg_distances, prune_loops, simplify


def test_simplify_drops_points_near_the_line_between_those_kept() -> None:
    pts = [(0.0, 0.0), (1.0, 0.4), (2.0, 0.0), (3.0, 0.0)]
    # (1, 0.4) is 0.4 m off the chord (0, 0)-(3, 0): dropped within 0.5, kept within 0.3;
    # then (2, 0) is 0.196 m off (1, 0.4)-(3, 0) (|(1, -0.4) x (2, -0.4)| / |(2, -0.4)|)
    assert simplify(pts, 0.5) == [(0.0, 0.0), (3.0, 0.0)]
    assert simplify(pts, 0.3) == [(0.0, 0.0), (1.0, 0.4), (3.0, 0.0)]
    assert simplify(pts, 0.19) == pts
    assert simplify(pts[:2], 10.0) == pts[:2]


def test_a_leg_that_crosses_an_earlier_one_cuts_the_loop_at_the_crossing() -> None:
    # out east 4 m, north 2, back west 2, then south across the first leg at (2, 0)
    way = [(0.0, 0.0), (4.0, 0.0), (4.0, 2.0), (2.0, 2.0), (2.0, -2.0)]
    assert prune_loops(way, 1.98) == [(0.0, 0.0), (2.0, 0.0), (2.0, -2.0)]


def test_legs_that_pass_within_the_delta_are_joined_midway_between_their_closest_points() -> None:
    way = [(0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (2.0, 3.0), (2.0, 1.5)]
    # the last leg ends 1.5 m from (2, 0) on the first: joined at (2, 0.75)
    assert prune_loops(way, 1.98) == [(0.0, 0.0), (2.0, 0.75), (2.0, 1.5)]
    # 1.5 m is not within 1.4 m: nothing cut
    assert prune_loops(way, 1.4) == way


def test_neighbouring_legs_are_never_a_loop() -> None:
    v = [(0.0, 0.0), (4.0, 0.0), (0.0, 0.5)]  # a sharp turn: its two legs touch at the turn
    assert prune_loops(v, 1.98) == v
    assert clean(v, 2.0) == v


def test_the_largest_loop_a_leg_closes_is_cut() -> None:
    # two loops, the second inside the first's span: the last leg meets the first leg, so
    # everything between goes
    way = [(0.0, 0.0), (6.0, 0.0), (6.0, 3.0), (4.0, 3.0), (4.0, 1.0), (5.0, 1.0), (5.0, 4.0), (2.0, 4.0), (2.0, -2.0)]
    assert prune_loops(way, 0.5) == [(0.0, 0.0), (2.0, 0.0), (2.0, -2.0)]


points = st.lists(
    st.tuples(st.floats(-50, 50, allow_nan=False), st.floats(-50, 50, allow_nan=False)), min_size=0, max_size=40
)


def _length(way: list[tuple[float, float]]) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise(way))


@settings(max_examples=200, deadline=None)
@given(points, st.floats(0.1, 10.0))
def test_a_cleaned_way_starts_and_ends_where_it_did_and_is_no_longer(way: list, accuracy: float) -> None:
    out = clean(way, accuracy)
    assert len(out) <= len(way)
    if way:
        assert out[0] == way[0] and out[-1] == way[-1]  # home, and where the vehicle last was
    assert _length(out) <= _length(way) + 1e-6


def _rovers_pruning(way: list[tuple[float, float]], delta: float, max_loops: int | None = None) -> list:
    """Rover's loop pruning written out step by step, one pair of legs at a time, as
    AP_SmartRTL's detect_loops, add_loop, loops_overlap and remove_points_by_loops run it
    (the loop buffer, the i < 4 stop, squared lengths): the reference for prune_loops."""
    n = len(way)
    if n < 4:
        return list(way)
    loops: list[list] = []  # [start, end, joint, size]

    def sq(a: tuple[float, float], b: tuple[float, float]) -> np.float32:  # single precision, as Rover's
        dn, de = np.float32(a[0]) - np.float32(b[0]), np.float32(a[1]) - np.float32(b[1])
        return np.float32(dn * dn + de * de)

    def overlap(a: list, b: list) -> bool:
        if (a[0] >= b[0] and a[1] <= b[1]) or (b[0] >= a[0] and b[1] <= a[1]):
            return True
        return (b[0] <= a[0] <= b[1]) != (b[0] <= a[1] <= b[1])

    i, j = n - 1, 0
    while True:
        j += 1
        if j > i - 2:
            j, i = 1, i - 1
            if i < 4:
                break
        d, m = leg_distances(way[i], way[i - 1], way[j - 1], way[j])
        if d[0] < delta:
            if max_loops is not None and len(loops) >= max_loops:
                break
            start, end, joint = j, i - 1, (float(m[0, 0]), float(m[0, 1]))
            size = sq(joint, way[start]) + sq(joint, way[end])
            for k in range(start, end):
                size += sq(way[k], way[k + 1])
            new = [start, end, joint, size]
            over = [lp for lp in loops if overlap(lp, new)]
            if not over or sum(lp[3] for lp in over) <= size:
                loops = [lp for lp in loops if lp not in over] + [new]
            j = i
    out = list(way)
    for k in range(len(loops) - 1, -1, -1):
        start, end, joint, _size = loops[k]
        cut = end - start
        out = [*out[:start], joint, *out[end + 1 :]]
        for lp in loops[:k]:
            lp[0] -= cut if lp[0] >= end else 0
            lp[1] -= cut if lp[1] >= end else 0
    return out


@settings(max_examples=300, deadline=None)
@given(points, st.floats(0.1, 10.0), st.one_of(st.none(), st.integers(1, 4)))
def test_pruning_cuts_what_rovers_step_by_step_pruning_cuts(way: list, delta: float, max_loops: int | None) -> None:
    assert prune_loops(way, delta, max_loops) == pytest.approx(_rovers_pruning(way, delta, max_loops))


def test_a_random_walk_is_pruned_as_rover_prunes_it() -> None:
    # tangled ways, where which legs meet first matters (fixed draws)
    import numpy as np

    rng = np.random.default_rng(7)
    for _ in range(200):
        way = [tuple(map(float, q)) for q in np.cumsum(rng.normal(0, 1.5, (60, 2)), axis=0)]
        assert prune_loops(way, 1.98, 15) == pytest.approx(_rovers_pruning(way, 1.98, 15))


def test_the_distance_between_two_legs_as_rover_measures_it() -> None:
    d, m = leg_distances((2.0, 1.5), (2.0, 3.0), (0.0, 0.0), (4.0, 0.0))  # an end to the other's middle
    assert d[0] == pytest.approx(1.5) and tuple(m[0]) == pytest.approx((2.0, 0.75))
    d, m = leg_distances((0.0, 0.0), (4.0, 4.0), (0.0, 4.0), (4.0, 0.0))  # they cross at (2, 2)
    assert d[0] == 0.0 and tuple(m[0]) == pytest.approx((2.0, 2.0))
    d, _m = leg_distances((0.0, 0.0), (4.0, 0.0), (5.0, 1.0), (9.0, 1.0))  # parallel: never meet
    assert d[0] == math.inf


# -- the endpoint ------------------------------------------------------------------------------
def _drive(b: Bench, way: list[tuple[float, float]], step_m: float = 0.5) -> None:
    """Tick the vehicle along ``way`` in steps of about ``step_m``, a step each breadcrumb
    period (Rover's 3 Hz: 1.5 m/s with the default step)."""
    for (n0, e0), (n1, e1) in itertools.pairwise(way):
        k = max(1, int(math.dist((n0, e0), (n1, e1)) / step_m))
        for i in range(1, k + 1):
            n, e = n0 + (n1 - n0) * i / k, e0 + (e1 - e0) * i / k
            state = {"north_m": n, "east_m": e, "yaw_rad": 0.0, "speed_mps": 1.0, "yaw_rate_radps": 0.0}
            b.tick(dt=SRTL_SAVE_PERIOD_S, state=state)


def _armed(**params: float) -> Bench:
    b = Bench()
    for name, value in params.items():
        b.ep.params[name].value = value
    b.state = {"north_m": 0.0, "east_m": 0.0, "yaw_rad": 0.0, "speed_mps": 0.0, "yaw_rate_radps": 0.0}
    b.tick()
    assert b.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    return b


def test_entering_smartrtl_cleans_the_loop_out_of_the_way_back() -> None:
    b = _armed()
    _drive(b, [(0.0, 0.0), (20.0, 0.0), (20.0, 10.0), (10.0, 10.0), (10.0, -10.0)])
    recorded = list(b.ep.path)
    assert len(recorded) > 20  # a point each 2 m (SRTL_ACCURACY)
    assert b.set_mode("SMART_RTL") == mav.MAV_RESULT_ACCEPTED
    # the way back: from (10, -10) to where it crossed its first leg, and home
    assert b.ep.path == [(0.0, 0.0), pytest.approx((10.0, 0.0), abs=0.01), b.ep.path[-1]]
    assert b.ep.path[-1] == recorded[-1]


def test_srtl_accuracy_spaces_the_points() -> None:
    b = _armed(SRTL_ACCURACY=5.0)
    _drive(b, [(0.0, 0.0), (30.0, 0.0)])
    assert [round(n) for n, _e in b.ep.path] == [0, 5, 10, 15, 20, 25, 30]


def test_breadcrumbs_are_taken_at_3_hz_as_rover_takes_them() -> None:
    # ModeSmartRTL::save_position is a 3 Hz task: at 6 m/s, 50 Hz ticks, the points are 2 m
    # apart even with SRTL_ACCURACY 1 (taken every tick they were 1.08 m apart)
    b = _armed(SRTL_ACCURACY=1.0)
    for k in range(1, 151):  # 3 s
        n = 6.0 * 0.02 * k
        b.tick(state={"north_m": n, "east_m": 0.0, "yaw_rad": 0.0, "speed_mps": 6.0, "yaw_rate_radps": 0.0})
    gaps = [b2[0] - a2[0] for a2, b2 in itertools.pairwise(b.ep.path)]
    assert len(gaps) >= 8 and all(1.8 <= g <= 2.2 for g in gaps[1:]), gaps


def test_srtl_points_0_keeps_no_way_back_and_smartrtl_is_refused() -> None:
    b = _armed(SRTL_POINTS=0)
    _drive(b, [(0.0, 0.0), (10.0, 0.0)])
    assert b.ep.path == []
    assert b.set_mode("SMART_RTL") == mav.MAV_RESULT_FAILED
    assert "SmartRTL unavailable: no path kept" in [s for _t, s in b.ep.statustexts]


def test_srtl_points_and_accuracy_are_taken_as_the_autopilot_starts_a_change_takes_a_reboot() -> None:
    # Rover's AP_SmartRTL::init sizes the way once at boot (@RebootRequired): SRTL_POINTS 0 set
    # after the start keeps the way at the next arming; after a reboot none is kept
    b = _armed()
    assert b.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED
    b.ep.params["SRTL_POINTS"].value = 0
    assert b.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    _drive(b, [(0.0, 0.0), (10.0, 0.0)])
    assert b.ep.path_started and len(b.ep.path) >= 5
    assert b.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED
    assert b.command(mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == mav.MAV_RESULT_ACCEPTED
    while b.ep.rebooting or not any(t == "ArduPilot Ready" for _, t in b.ep.statustexts[-3:]):
        b.tick(0.1)
    assert b.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    _drive(b, [(10.0, 0.0), (20.0, 0.0)])
    assert not b.ep.path_started and b.ep.path == []
    b.ep.params["SRTL_POINTS"].value = 300  # and back: again only after a reboot
    assert b.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED
    assert b.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    assert not b.ep.path_started


def test_points_used_up_and_none_freed_gives_smartrtl_up_until_the_next_arming() -> None:
    b = _armed(SRTL_POINTS=10)
    # a zigzag with nothing to simplify and no loop: 10 points fill the way
    zig = [(4.0 * i, 0.0 if i % 2 == 0 else 4.0) for i in range(12)]
    _drive(b, zig, step_m=2.0)  # (11 s: within SmartRTL's 15 s timeout)
    assert len(b.ep.path) == 10
    assert b.ep.path_started
    stay = {"north_m": zig[-1][0], "east_m": zig[-1][1] + 3.0, "yaw_rad": 0.0, "speed_mps": 0.0, "yaw_rate_radps": 0.0}
    for _ in range(int(SRTL_TIMEOUT_S / 0.02) + 60):  # a point due and no room for it, for 15 s
        b.tick(state=stay)
    assert "SmartRTL deactivated: buffer full" in [s for _t, s in b.ep.statustexts]
    assert not b.ep.path_started
    assert b.set_mode("SMART_RTL") == mav.MAV_RESULT_FAILED
    assert b.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED
    assert b.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    assert b.ep.path_started and b.ep.mode != MODES["SMART_RTL"]


def test_the_way_back_is_kept_in_rtl_too() -> None:
    # Rover's ModeSmartRTL::save_position saves in every mode but SmartRTL: RTL part way,
    # then SmartRTL, goes back along the RTL leg too (lfctl left it out)
    b = _armed()
    _drive(b, [(0.0, 0.0), (20.0, 0.0)])
    assert b.set_mode("RTL") == mav.MAV_RESULT_ACCEPTED
    _drive(b, [(20.0, 0.0), (20.0, 10.0)])  # (a way RTL would not take: the points are what count)
    assert b.ep.path[-1][1] > 8.0  # its RTL leg kept (a point each 2 m)
    assert b.set_mode("SMART_RTL") == mav.MAV_RESULT_ACCEPTED
    _drive(b, [(20.0, 10.0), (20.0, 20.0)])  # nothing saved while in SmartRTL
    assert max(e for _n, e in b.ep.path) <= 10.5


def test_the_way_is_kept_while_disarmed_once_started() -> None:
    # AP_SmartRTL::update saves whatever the arming once its way has begun (a pushed rover)
    b = _armed()
    _drive(b, [(0.0, 0.0), (10.0, 0.0)])
    assert b.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED
    _drive(b, [(10.0, 0.0), (10.0, 8.0)])
    assert b.ep.path[-1][1] > 5.0
