"""The metrics' paths and counts by hand: PathHistory's lead-in and spacing off the axes and
its buffer as it shifts, the boundaries of track_episodes, the sizes sign_changes and
variation_per_s count from, and the distance to a one-point path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lfctl.metrics import PathHistory, TrackEpisode, distance_to_path, sign_changes, track_episodes, variation_per_s


def test_the_lead_in_runs_back_along_a_heading_off_the_axes_from_a_start_away_from_home() -> None:
    # Wrong, a follower starting behind a leader that heads anywhere but north would score a
    # large path error (the road it came on drawn ahead of the leader, or too long).
    # By hand: start (1, 2), heading 30 deg, lead-in 10 m: the first point is
    # (1 - 10 cos 30, 2 - 10 sin 30) = (-7.660254, -3.0), then the start itself.
    h = PathHistory(1.0, 2.0, math.radians(30.0))
    assert h.points == pytest.approx(np.array([[1.0 - 10.0 * math.cos(math.radians(30.0)), -3.0], [1.0, 2.0]]))
    assert h.points[0] == pytest.approx([-7.660254, -3.0], abs=1e-6)
    # heading north: straight back south, 10 m
    assert PathHistory(0.0, 0.0, 0.0).points == pytest.approx(np.array([[-10.0, 0.0], [0.0, 0.0]]))


def test_a_point_is_kept_once_it_is_the_spacing_from_the_last_along_north() -> None:
    # Wrong, the path would be sampled too finely or too coarsely along north (every test
    # before drove east), or measured from the wrong place.
    # By hand: start (1, 0), spacing 0.5: (1.3, 0) is 0.3 m on (0.09 < 0.25): not kept;
    # (1.6, 0) is 0.6 m on (0.36 >= 0.25): kept.
    h = PathHistory(1.0, 0.0, 0.0, spacing_m=0.5)
    h.add(1.3, 0.0)
    assert len(h.points) == 2
    h.add(1.6, 0.0)
    assert h.points[-1].tolist() == [1.6, 0.0] and len(h.points) == 3


def test_a_full_path_history_shifts_its_newest_points_to_the_front() -> None:
    # Wrong, the kept path right after the buffer fills would hold blanks (NaN) instead of the
    # last points driven, and the follower's path error would be lost.
    # By hand: keep 3, a buffer of 6 rows: the lead-in (-1, 0), the start (0, 0), then 1..4 m
    # north fill it; 5 m shifts the newest 3 (2, 3, 4) to the front and adds (5, 0): the kept
    # points are (3, 0), (4, 0), (5, 0).
    h = PathHistory(0.0, 0.0, 0.0, spacing_m=1.0, keep=3, lead_in_m=1.0)
    for k in range(1, 6):
        h.add(float(k), 0.0)
    assert h.points.tolist() == [[3.0, 0.0], [4.0, 0.0], [5.0, 0.0]]
    assert h.error(3.5, 1.0) == pytest.approx(1.0, abs=1e-12)


def test_a_stretch_without_tracking_is_reported_from_its_first_sample_with_its_worst_state() -> None:
    # Wrong, occlusions would be reported as "lost", unrecovered ones as recovered, or the
    # start of a stretch missed.
    # By hand: 1 s samples; occluded at 1 s and 2 s, tracking again at 3 s: one stretch from
    # 1.0 s lasting 2 * 1.0 = 2.0 s, recovered, at worst occluded.
    t = [0.0, 1.0, 2.0, 3.0]
    assert track_episodes(t, ["tracking", "occluded", "occluded", "tracking"], 1.0) == [
        TrackEpisode(1.0, 2.0, True, "occluded")
    ]
    # the run ends occluded: not recovered
    assert track_episodes(t, ["tracking", "occluded", "occluded", "occluded"], 1.0) == [
        TrackEpisode(1.0, 3.0, False, "occluded")
    ]
    # a stretch from the very first sample, after after_s: it begins there (1.0 s), 2 s long
    assert track_episodes([1.0, 2.0, 3.0], ["occluded", "occluded", "tracking"], 1.0) == [
        TrackEpisode(1.0, 2.0, True, "occluded")
    ]


def test_a_stretch_beginning_exactly_at_after_s_is_the_start_up_and_the_default_is_half_a_second() -> None:
    # Wrong, the start-up's search would be counted as a lost track, or a loss at 1 s ignored.
    # By hand: after_s 0.5 (the default); a stretch from 0.5 s is not after it (0.5 > 0.5 is
    # false): none. One from 1.0 s is: 1.0 > 0.5.
    t = [0.0, 0.5, 1.0, 1.5]
    assert track_episodes(t, ["tracking", "occluded", "tracking", "tracking"], 0.5) == []
    assert track_episodes(t, ["tracking", "tracking", "lost", "tracking"], 0.5) == [
        TrackEpisode(1.0, 0.5, True, "lost")
    ]


def test_swings_are_counted_only_outside_the_deadband_and_between_two_samples_outside_it() -> None:
    # Wrong, a command sitting on the deadband would count as chattering, or one swing
    # between two samples would not count.
    # By hand: (0.05, -0.05) with deadband 0.05: |v| > 0.05 for neither: 0. (0.1, -0.1): both
    # outside, one change: 1. (0.1,) alone: nothing to change from: 0.
    assert sign_changes(np.array([0.05, -0.05]), 0.05) == 0
    assert sign_changes(np.array([0.1, -0.1]), 0.05) == 1
    assert sign_changes(np.array([0.1]), 0.05) == 0


def test_the_variation_of_two_samples_and_of_none() -> None:
    # Wrong, a two-sample command would read still, or an empty one NaN.
    # By hand: (0, 1) every 0.5 s: |1 - 0| / (2 * 0.5) = 1.0 per s. None: 0.0.
    assert variation_per_s([0.0, 1.0], 0.5) == pytest.approx(1.0, abs=1e-12)
    assert variation_per_s([], 0.5) == 0.0


def test_the_distance_to_a_one_point_path_is_the_distance_to_that_point() -> None:
    # Wrong, a path of one point away from the origin would be measured from its mirror image.
    # By hand: from (1, 1) to (4, 5): hypot(3, 4) = 5.
    assert distance_to_path(np.array([[1.0, 1.0]]), 4.0, 5.0) == pytest.approx(5.0, abs=1e-12)
