"""The model histogram, its ratio look-up table, the back-projection and the Bhattacharyya
distance, worked by hand on a 2 x 2 hue image and 2-bin histograms.

Hue alone (``FeatureSpace(use_saturation=False, use_lbp=False)``): 32 bins over 0..180, each
180 / 32 = 5.625 wide, so hue 6 is bin 1 and hue 0 bin 0 (over 0..256 instead, 8 wide, hue 6
would be bin 0)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from lfctl.vision.histogram import FeatureSpace, back_project, bhattacharyya, histogram, ratio_lut

HUE = FeatureSpace(use_saturation=False, use_lbp=False)
# hue 6 (bin 1), 0 (bin 0), 100 (bin 17), 179 (bin 31)
PLANE = np.array([[6, 0], [100, 179]], np.uint8)


def test_the_histogram_counts_only_the_masked_pixels() -> None:
    # Wrong, the pixels around the target would be counted into its model.
    # By hand: mask on the top row only: bin 1 (hue 6) 1, bin 0 (hue 0) 1, bins 17 and 31 0.
    mask = np.array([[255, 255], [0, 0]], np.uint8)
    h = histogram(HUE, [PLANE], mask).ravel()
    assert h.shape == (32,)
    assert h[[0, 1, 17, 31]].tolist() == [1.0, 1.0, 0.0, 0.0]
    assert h.sum() == 2.0


def test_the_back_projection_is_the_look_up_table_at_each_pixels_hue_bin() -> None:
    # Wrong (another value range, or a scale), the probability image CAMShift follows would
    # come from the wrong bins or be doubled.
    # By hand: LUT bin 1 = 200, bin 0 = 7, others 0: hue 6 -> 200, hue 0 -> 7, 100 -> 0, 179 -> 0.
    lut = np.zeros((32, 1), np.float32)
    lut[1], lut[0] = 200.0, 7.0
    prob = back_project(HUE, [PLANE], lut)
    assert prob.dtype == np.uint8
    assert prob.tolist() == [[200, 7], [0, 0]]


def test_a_back_projection_of_255_stays_255() -> None:
    # By hand: LUT bin 1 = 100 and bin 0 = 255: at scale 1 hue 6 -> 100 (not 200), hue 0 -> 255.
    lut = np.zeros((32, 1), np.float32)
    lut[1], lut[0] = 100.0, 255.0
    assert back_project(HUE, [PLANE], lut).tolist() == [[100, 255], [0, 0]]


def test_the_ratio_table_of_a_two_bin_target_with_no_background() -> None:
    # Wrong, a model started without surroundings (background None) would fail or be weighted.
    # By hand: target [1, 3], sum 4; noise floor max(1, 0.002 * 4) = 1: no bin is below it.
    # w = [0.25, 0.75], peak 0.75: table [0.25 * 255 / 0.75, 255] = [85, 255].
    t = np.array([[1.0], [3.0]], np.float32)
    lut = ratio_lut(t, None)
    assert lut.dtype == np.float32
    assert lut.ravel() == pytest.approx([85.0, 255.0], rel=1e-6)


def test_an_empty_background_weights_nothing_down() -> None:
    # Wrong, a target whose surroundings fall outside the frame (all-zero background counts)
    # would get a table of NaN.
    # By hand: as above, [85, 255].
    t = np.array([[1.0], [3.0]], np.float32)
    lut = ratio_lut(t, np.zeros((2, 1), np.float32))
    assert lut.ravel() == pytest.approx([85.0, 255.0], rel=1e-6)


def test_a_target_of_one_pixel_gets_255_in_its_bin() -> None:
    # Wrong, a one-pixel target (sum 1) would get an all-zero table.
    # By hand: target [0, 1], sum 1, floor max(1, 0.002) = 1: bin 1 (1 count) is not below it:
    # w = [0, 1], table [0, 255].
    t = np.array([[0.0], [1.0]], np.float32)
    assert ratio_lut(t, None).ravel().tolist() == [0.0, 255.0]


def test_bins_below_two_per_mille_of_the_target_are_noise() -> None:
    # Wrong (the floor taken as 0.002 / sum, or not scaled with the target), rare bins of a
    # large target would enter the model.
    # By hand: target [3, 1997], sum 2000, floor max(1, 0.002 * 2000) = 4: bin 0 (3 < 4) is
    # dropped: table [0, 255].
    t = np.array([[3.0], [1997.0]], np.float32)
    assert ratio_lut(t, None).ravel().tolist() == [0.0, 255.0]


def test_a_target_made_only_of_noise_bins_gives_an_all_zero_table() -> None:
    # Wrong, a target of 1000 one-count bins (every bin below the floor) would divide by a peak
    # of 0.
    # By hand: sum 1000, floor max(1, 2) = 2: every bin (1 < 2) dropped, peak 0: all zeros.
    t = np.ones((1000, 1), np.float32)
    lut = ratio_lut(t, None)
    assert lut.shape == (1000, 1)
    assert not lut.any()


def test_an_empty_target_gives_an_all_zero_table_of_its_shape_without_dividing_by_zero() -> None:
    # Wrong, an empty target window would give a table of another shape (back_project fails)
    # or come out of 0 / 0.
    t = np.zeros((32, 1), np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lut = ratio_lut(t, None)
    assert lut.shape == (32, 1)
    assert lut.dtype == np.float32
    assert not lut.any()


def test_bhattacharyya_of_two_bin_histograms_by_hand() -> None:
    # The definition (cv2.compareHist, HISTCMP_BHATTACHARYYA, normalising each):
    # d = sqrt(1 - sum_i sqrt(a_i b_i) / sqrt(sum a * sum b)).
    # a = [1, 0], b = [1, 1]: sum sqrt(ab) = 1, sqrt(1 * 2) = 1.41421: d = sqrt(1 - 0.70711) = 0.541196.
    # a = [1, 3], b = [3, 1]: sum sqrt(ab) = 2 sqrt(3) = 3.46410, sqrt(4 * 4) = 4:
    # d = sqrt(1 - 0.86603) = 0.366025.
    assert bhattacharyya(np.array([1.0, 0.0]), np.array([1.0, 1.0])) == pytest.approx(0.541196, abs=1e-6)
    assert bhattacharyya(np.array([1.0, 3.0]), np.array([3.0, 1.0])) == pytest.approx(
        math.sqrt(1.0 - math.sqrt(3.0) / 2.0), abs=1e-6
    )


def test_bhattacharyya_of_one_pixel_histograms_is_not_taken_for_empty() -> None:
    # Wrong, a histogram summing to 1 (a one-pixel window) would count as empty (distance 1).
    # By hand: a = b = [1, 0]: sum sqrt(ab) = 1, sqrt(1 * 1) = 1: d = 0.
    one = np.array([1.0, 0.0])
    assert bhattacharyya(one, one) == 0.0
    assert bhattacharyya(one, np.array([2.0, 0.0])) == 0.0
    assert bhattacharyya(np.array([2.0, 0.0]), one) == 0.0


def test_bhattacharyya_with_an_empty_histogram_is_one() -> None:
    # The docstring: 1 when either is empty (and never more: it is a distance in 0..1).
    some = np.array([1.0, 3.0])
    empty = np.zeros(2)
    assert bhattacharyya(empty, some) == 1.0
    assert bhattacharyya(some, empty) == 1.0
    assert bhattacharyya(empty, empty) == 1.0
