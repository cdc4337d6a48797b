"""The distance gate and the separating back-projection level at their edges, worked by hand:
a target of one pixel, the level just above zero, a gate whose typical distance is above its
background one, the default number of frames learnt from and the colour distance's
Bhattacharyya number on a 2-bin histogram."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from lfctl.vision.gates import DistanceGate, colour_distance, separating_level


def test_a_target_of_one_pixel_still_gets_its_separating_level() -> None:
    # Wrong, a target whose mask is a single pixel would get no floor (0) however clearly it
    # stands out.
    # By hand: inside = [200], outside = [0, 0]. Share at or above k: target 1 for k <= 200,
    # surroundings 1 for k = 0 and 0 above. J(k) = 1 for k = 1..200, J(0) = 0 (no threshold):
    # the first largest J is at k = 1.
    inside = np.array([200], np.uint8)
    outside = np.zeros(2, np.uint8)
    assert separating_level(inside, outside) == 1


def test_surroundings_of_one_pixel_still_give_a_separating_level() -> None:
    # Wrong, a ring of one pixel (a target at the frame's corner) would give no floor.
    # By hand: inside = [9, 9], outside = [3]. Share at or above k: target 1 for k <= 9,
    # surroundings 1 for k <= 3, 0 above. J = 0 for k <= 3, 1 for k = 4..9: the level is 4.
    inside = np.array([9, 9], np.uint8)
    outside = np.array([3], np.uint8)
    assert separating_level(inside, outside) == 4


def test_the_separating_level_can_be_one() -> None:
    # Wrong, level 1 (keep every pixel with any probability) could never be chosen.
    # By hand: inside = [1, 1], outside = [0, 0]. J(1) = 1 - 0 = 1, J(k >= 2) = 0 - 0 = 0,
    # J(0) = 0 (no threshold): the level is 1.
    assert separating_level(np.ones(2, np.uint8), np.zeros(2, np.uint8)) == 1


@pytest.mark.parametrize("empty", ["inside", "outside"])
def test_an_empty_side_gives_level_zero_without_dividing_by_zero(empty: str) -> None:
    # Wrong, an empty mask (a target window squeezed to nothing) would be divided by its size
    # of 0 and the answer come out of NaN arithmetic (numpy warns "invalid value").
    some = np.array([10, 20], np.uint8)
    none = np.zeros(0, np.uint8)
    inside, outside = (none, some) if empty == "inside" else (some, none)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert separating_level(inside, outside) == 0


def test_the_gate_learns_from_five_frames_by_default() -> None:
    # Wrong, a gate built without learn_frames would learn from another number of windows.
    # By hand: distances 0.1, 0.2, 0.3, 0.4 leave it learning (threshold = background 0.8);
    # the fifth, 0.05, completes it: median(0.05, 0.1, 0.2, 0.3, 0.4) = 0.2, threshold
    # (0.2 + 0.8) / 2 = 0.5.
    gate = DistanceGate(0.8)
    for d in (0.1, 0.2, 0.3, 0.4):
        gate.observe(d)
    assert gate.typical is None
    assert gate.threshold == 0.8
    gate.observe(0.05)
    assert gate.typical == pytest.approx(0.2)
    assert gate.threshold == pytest.approx(0.5)


def test_a_window_at_the_threshold_teaches_nothing_even_when_the_typical_is_above_the_background() -> None:
    # Wrong, a target that looks more like its surroundings than its own model (typical above
    # background: a print on a same-colour shirt) would be taught in full by a window the gate
    # has just refused.
    # By hand: background 0.25, typical 0.5 (one frame learnt): threshold = (0.5 + 0.25) / 2 =
    # 0.375; the confident level (0.5 + 0.375) / 2 = 0.4375 lies above it (span < 0).
    # d = 0.375: at the threshold, refused, weight 0; d = 0.25: accepted, below the confident
    # level, weight 1.
    gate = DistanceGate(0.25, learn_frames=1)
    gate.observe(0.5)
    assert gate.threshold == 0.375
    assert not gate.accepts(0.375)
    assert gate.teach_weight(0.375) == 0.0
    assert gate.teach_weight(0.25) == 1.0


def test_a_gate_whose_typical_equals_its_background_teaches_nothing_at_the_threshold() -> None:
    # By hand: background = typical = 0.5: threshold 0.5, confident level 0.5, span 0.
    # d = 0.5 is at the threshold: weight 0; d = 0.4: weight 1.
    gate = DistanceGate(0.5, learn_frames=1)
    gate.observe(0.5)
    assert gate.teach_weight(0.5) == 0.0
    assert gate.teach_weight(0.4) == 1.0


def test_colour_distance_of_two_bin_histograms_is_opencvs_bhattacharyya() -> None:
    # The definition (cv2.compareHist, HISTCMP_BHATTACHARYYA):
    # d = sqrt(1 - sum_i sqrt(a_i b_i) / sqrt(sum a * sum b)).
    # a = [[1], [0]] (2 x 1: hue x saturation), b = [[1], [1]]:
    # sum sqrt(a b) = 1, sqrt(1 * 2) = 1.41421: d = sqrt(1 - 0.70711) = sqrt(0.29289) = 0.541196.
    a = np.array([[1.0], [0.0]], np.float32)
    b = np.array([[1.0], [1.0]], np.float32)
    assert colour_distance(a, b) == pytest.approx(math.sqrt(1.0 - 1.0 / math.sqrt(2.0)), abs=1e-6)
    assert colour_distance(a, b) == pytest.approx(0.541196, abs=1e-6)
