"""Formation figures by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lfctl.metrics import (
    PathHistory,
    distance_to_path,
    formation_metrics,
    sign_changes,
    track_episodes,
    variation_per_s,
)


def test_variation_per_s_sums_the_command_s_moves_over_the_run() -> None:
    # |1-0| + |0-1| + |1-0| = 3 over 4 samples of 0.5 s = 2 s
    assert variation_per_s([0.0, 1.0, 0.0, 1.0], 0.5) == pytest.approx(1.5)
    assert variation_per_s([0.3] * 10, 0.05) == 0.0
    assert variation_per_s([0.3], 0.05) == 0.0


def test_sign_changes_ignore_swings_inside_the_deadband() -> None:
    assert sign_changes(np.array([0.1, -0.1, 0.01, -0.01, 0.1]), 0.05) == 2


def test_distance_to_a_path_by_hand() -> None:
    # an L: (0,0) -> (4,0) -> (4,3)
    path = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]])
    assert distance_to_path(path, 2.0, 1.0) == pytest.approx(1.0)  # beside the first leg
    assert distance_to_path(path, 5.0, 4.0) == pytest.approx(math.hypot(1.0, 1.0))  # past the end: to (4,3)
    assert distance_to_path(path, 3.0, 1.0) == pytest.approx(1.0)  # inside the corner: 1 m from both legs
    assert distance_to_path(path[:1], 3.0, 4.0) == pytest.approx(5.0)  # one point
    assert distance_to_path(np.array([[1.0, 1.0], [1.0, 1.0]]), 1.0, 2.0) == pytest.approx(1.0)  # a repeated point


@given(
    st.floats(-50, 50), st.floats(-50, 50), st.floats(-50, 50), st.floats(-50, 50), st.floats(0, 1), st.floats(-5, 5)
)
def test_a_point_off_a_segment_is_its_offset_away(
    n0: float, e0: float, n1: float, e1: float, u: float, off: float
) -> None:
    seg = np.array([[n0, e0], [n1, e1]])
    length = math.hypot(n1 - n0, e1 - e0)
    if length < 1e-3:
        return
    # a point on the segment, moved sideways by off: |off| away (never further)
    side = np.array([-(e1 - e0), n1 - n0]) / length
    p = seg[0] + u * (seg[1] - seg[0]) + off * side
    assert distance_to_path(seg, *p) == pytest.approx(abs(off), abs=1e-6)


def test_path_history_leads_in_keeps_a_spaced_path_and_subtracts_the_offset() -> None:
    # starts at (0,0) heading east: the lead-in runs 10 m west
    h = PathHistory(0.0, 0.0, math.pi / 2, spacing_m=0.5, keep=100)
    assert h.error(0.0, -3.0) == pytest.approx(0.0)  # behind it on the road it came on
    for k in range(1, 11):
        h.add(0.0, 0.1 * k)  # 1 m east in 0.1 m steps: a point each 0.5 m
    assert h.points[-2:].tolist() == [[0.0, 0.5], [0.0, 1.0]]
    h.add(1.0, 1.0)  # turns north
    assert h.error(0.5, 1.3) == pytest.approx(0.3)
    assert h.error(0.5, 1.3, offset_m=0.3) == pytest.approx(0.0)


def test_path_history_keeps_the_newest_points_when_full() -> None:
    h = PathHistory(0.0, 0.0, 0.0, spacing_m=1.0, keep=3, lead_in_m=1.0)
    for k in range(1, 8):
        h.add(float(k), 0.0)
    assert h.points.tolist() == [[5.0, 0.0], [6.0, 0.0], [7.0, 0.0]]
    assert h.error(0.0, 0.0) == pytest.approx(5.0)  # the older path is no longer kept


def test_the_path_error_counts_after_settling_and_is_none_without_samples() -> None:
    t = [0.0, 5.0, 6.0]
    args = ("f", "l", 1.5, 0.0, t, [0.0] * 3, [0.0] * 3, [2.0] * 3, ["tracking"] * 3, [0.0] * 3, 1.0)
    m = formation_metrics(*args, path_err_m=[9.0, 0.3, -0.4])
    assert m.path_err_rms_m == pytest.approx(math.sqrt((0.09 + 0.16) / 2)) and m.path_err_max_m == pytest.approx(0.4)
    assert formation_metrics(*args).path_err_rms_m is None  # an old log: no figure


def test_time_in_each_state_by_hand_and_none_where_the_state_was_not_known() -> None:
    t = [0.0, 0.5, 1.0, 1.5, 2.0]
    args = ("f", "l", 1.5, 0.0, t, [0.0] * 5, [0.0] * 5, [2.0] * 5)
    known = formation_metrics(*args, ["tracking", "occluded", "occluded", "lost", "tracking"], [0.0] * 5, 0.5)
    assert known.time_in_state_s == {"tracking": 1.0, "occluded": 1.0, "lost": 0.5}
    episodes = track_episodes(t, ["tracking", "occluded", "occluded", "lost", "tracking"], 0.5, after_s=0.25)
    assert [(e.start_s, e.duration_s, e.recovered, e.worst) for e in episodes] == [(0.5, 1.5, True, "lost")]
    # a stretch that begins by after_s is the start-up, all of it (its tail was counted as one)
    assert track_episodes(t, ["occluded", "occluded", "lost", "tracking", "occluded"], 0.5)[0].start_s == 2.0
    # a follower whose companion ran outside the simulator: its track state was that companion's
    outside = formation_metrics(*args, [None] * 5, [0.1, -0.1, 0.1, -0.1, 0.1], 0.5)
    assert outside.time_in_state_s == {"tracking": None, "occluded": None, "lost": None}
    assert outside.chattering_per_s == pytest.approx(4 / 2.5)  # its commands still count
    assert track_episodes(t, [None] * 5, 0.5) == []
