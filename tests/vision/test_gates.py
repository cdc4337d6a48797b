"""The full tracker's learnt gates and the pieces they stand on, worked by hand: the distance
gate's thresholds, the separating back-projection level, the colour marginal, brightness bins
for grey pixels, mean shift at a fixed size, and the size filter's start and precise
measurements."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from lfctl.vision.camshift import meanshift_in_roi
from lfctl.vision.gates import DistanceGate, colour_distance, ring_boxes, separating_level
from lfctl.vision.histogram import FeatureSpace, histogram
from lfctl.vision.kalman import AreaFilter


def test_the_gate_learns_the_typical_distance_then_splits_it_from_the_background() -> None:
    gate = DistanceGate(background=0.8, learn_frames=3)
    # learning: the window must at least look more like the target than its surroundings did
    assert gate.threshold == gate.reentry_threshold == 0.8
    assert gate.accepts(0.79) and not gate.accepts(0.8)
    assert not gate.confident(0.1)  # nothing is taught to the model before the gate is learnt
    for d in (0.3, 0.1, 0.2):
        gate.observe(d)
    assert gate.typical == pytest.approx(0.2)  # the median
    assert gate.threshold == pytest.approx(0.5)  # half way to the background
    assert gate.reentry_threshold == pytest.approx(0.35)  # a quarter of the way
    assert gate.accepts(0.49) and not gate.accepts(0.5)
    assert gate.accepts(0.34, reentry=True) and not gate.accepts(0.36, reentry=True)
    assert gate.confident(0.35) and not gate.confident(0.36)  # nearer the typical than the threshold
    gate.observe(0.45)  # learnt once: later distances do not move it
    assert gate.typical == pytest.approx(0.2)


def test_an_accepted_window_teaches_the_model_less_the_nearer_the_threshold() -> None:
    gate = DistanceGate(background=0.8, learn_frames=3)
    assert gate.teach_weight(0.1) == 0.0  # nothing before the gate is learnt
    for d in (0.3, 0.1, 0.2):
        gate.observe(d)
    # typical 0.2, threshold 0.5, confident up to 0.35: all of it there, none at the threshold
    assert gate.teach_weight(0.2) == gate.teach_weight(0.35) == 1.0
    assert gate.teach_weight(0.4) == pytest.approx(0.1 / 0.15)  # (0.5 - 0.4) / (0.5 - 0.35)
    assert gate.teach_weight(0.47) == pytest.approx(0.2)  # 0.03 / 0.15
    assert gate.teach_weight(0.5) == gate.teach_weight(0.7) == 0.0  # refused: teaches nothing
    # a typical distance at the background one (no accepted window could give it): no division
    flat = DistanceGate(background=0.4, learn_frames=1)
    flat.observe(0.4)
    assert flat.teach_weight(0.39) == 1.0 and flat.teach_weight(0.41) == 0.0


def test_separating_level_is_youdens_cut() -> None:
    inside = np.array([0, 10, 200, 210, 220, 230], np.uint8)  # a third of the target dim
    outside = np.array([0, 0, 5, 10, 20, 200], np.uint8)
    # at 21: 4/6 of the target and 1/6 of the surroundings at or above: J = 0.5, the largest
    assert separating_level(inside, outside) == 21
    assert separating_level(np.array([5, 5], np.uint8), np.array([9, 9], np.uint8)) == 0  # nothing separates
    assert separating_level(np.array([], np.uint8), outside) == 0


def test_colour_distance_ignores_texture() -> None:
    a = np.zeros((4, 2, 3), np.float32)
    b = np.zeros((4, 2, 3), np.float32)
    a[1, 0, 0] = a[2, 1, 2] = 5.0
    b[1, 0, 2] = b[2, 1, 0] = 5.0  # the same colours, every pixel with another LBP code
    assert colour_distance(a, b) == pytest.approx(0.0, abs=1e-6)
    b[3, 1, 1] = 10.0  # a colour the other has not
    assert colour_distance(a, b) > 0.3


def test_ring_boxes_surround_the_window() -> None:
    ring = ring_boxes((10, 20, 4, 6))
    assert len(ring) == 8 and (10, 20, 4, 6) not in ring
    assert {(x, y) for x, y, _, _ in ring} == {(x, y) for x in (6, 10, 14) for y in (14, 20, 26)} - {(10, 20)}


def test_grey_levels_tell_black_from_light_grey_and_leave_colours_alone() -> None:
    img = np.array([[[20, 20, 20], [150, 150, 150], [30, 30, 200], [30, 30, 25]]], np.uint8)  # BGR
    paper = FeatureSpace()
    grey = FeatureSpace(grey_levels=4)
    assert grey.bins[0] == 36 and grey.ranges[1] == pytest.approx(202.5)
    hp, _ = paper.features(img)
    hg, _ = grey.features(img)
    assert hp[0][0, 0] == hp[0][0, 1] == 0  # the paper's features: black and grey share hue bin 0
    bin_of = lambda v: int(v // (180 / 32))  # noqa: E731
    black, light, red, dark_red = (bin_of(v) for v in hg[0][0])
    assert (black, light) == (32, 34)  # value 20 -> band 0, value 150 -> band 2 (of 4)
    assert red == bin_of(hp[0][0, 2]) == 0  # a saturated red keeps its hue bin
    assert dark_red == 32  # value 30: too dark for its hue to mean anything
    # the histogram over the extended axis has the brightness bins
    hist = histogram(grey, hg, None)
    assert hist.shape == (36, 16, 36) and hist[32].sum() == 2 and hist[34].sum() == 1 and hist[:32].sum() == 1


def test_mean_shift_moves_the_window_and_keeps_its_size() -> None:
    prob = np.zeros((60, 80), np.uint8)
    prob[30:40, 50:60] = 255
    win, mass = meanshift_in_roi(prob, (100, 200), (140, 225, 12, 12))  # region at (100, 200)
    assert win[2:] == (12, 12)
    assert (win[0] + 6, win[1] + 6) == pytest.approx((155, 235), abs=1)
    assert mass > 0.6
    assert meanshift_in_roi(prob, (100, 200), (500, 500, 10, 10)) == ((500, 500, 10, 10), 0.0)


def test_size_filter_starts_exact_and_takes_a_precise_measurement_harder_by_hand() -> None:
    f = AreaFilter(math.log(50.0), accel_var=1e-6, meas_var=0.04, rate_var=1e-4, size_var=0.02**2)
    assert f.kf.P[0, 0] == pytest.approx(0.0004) and f.kf.P[1, 1] == pytest.approx(1e-4)
    f.predict()
    p = 0.0004 + 1e-4 + 1e-6 / 4  # P_pp after one predict
    z = math.log(60.0)
    g = AreaFilter(math.log(50.0), accel_var=1e-6, meas_var=0.04, rate_var=1e-4, size_var=0.02**2)
    g.predict()
    f.update(z)  # a CAMShift size: K = p / (p + 0.04)
    g.update(z, meas_var=0.0004)  # the markers' size: K = p / (p + 0.0004)
    assert f.kf.x[0] == pytest.approx(math.log(50.0) + p / (p + 0.04) * (z - math.log(50.0)))
    assert g.kf.x[0] == pytest.approx(math.log(50.0) + p / (p + 0.0004) * (z - math.log(50.0)))
    assert g.kf.R[0, 0] == 0.04  # the filter's own noise is unchanged


def test_the_tracker_learns_a_floor_for_a_target_on_a_shared_colour() -> None:
    # a red square on grey, with a faint red wash around it: the back-projection of the wash is
    # weak but not zero; the full tracker's floor cuts it, so its window is the square
    from lfctl.vision.tracker import Tracker, TrackerSettings

    img = np.full((120, 160, 3), 110, np.uint8)
    cv2.rectangle(img, (70, 50), (89, 69), (40, 40, 210), -1)
    rng = np.random.default_rng(1)
    wash = rng.random((120, 160)) < 0.15
    img[wash & ~np.pad(np.ones((20, 20), bool), ((50, 50), (70, 70)))] = (90, 90, 140)
    tracker = Tracker(TrackerSettings(use_markers=False))
    tracker.init(img, (70, 50, 20, 20))
    assert tracker._floor > 0
    for _ in range(5):
        st = tracker.update(img)
    assert st.bbox is not None and abs(st.bbox[0] - 70) <= 3 and abs(st.bbox[2] - 20) <= 4
