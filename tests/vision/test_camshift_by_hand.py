"""CAMShift's moments and the runs of cv2.meanShift / cv2.CamShift on a region of interest,
worked by hand on images of a few pixels from the definitions (eq. 3-8; OpenCV's
modules/video/src/camshift.cpp for the two runs).

OpenCV's meanShift moves the window by ``dx = cvRound(m10/m00 - w/2)`` (and so for y) until
the move is nought; cvRound rounds half to even, so on a uniform patch (centroid at
(w - 1) / 2, dx = cvRound(-0.5) = 0) the window stays where it is. CamShift runs meanShift,
grows the window by TOLERANCE = 10 px on every side (clipped to the image), takes the
moments there and, when their m00 is not 0, sizes the window from them:
``width = min(max(round(|length cos|), round(|width sin|)) + 2, 2 (W - xc))`` and so on."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from lfctl.vision.camshift import WindowMoments, camshift_in_roi, meanshift_in_roi, window_moments

ORIGIN = (100, 50)  # the region's top-left corner in the full image


def uniform(value: int, rows: int = 10, cols: int = 20) -> np.ndarray:
    return np.full((rows, cols), value, np.uint8)


# -- window_moments (eq. 3-8) -------------------------------------------------------------------


def test_an_empty_window_has_its_centre_and_zero_moments() -> None:
    # Wrong, a window over no probability would come out as NaN (0 / 0) or off its centre.
    # By hand: window (2, 1, 4, 3) on zeros: centre (2 + 4/2, 1 + 3/2) = (4, 2.5), all else 0.
    prob = np.zeros((6, 8), np.uint8)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = window_moments(prob, (2, 1, 4, 3))
    assert m == WindowMoments(0.0, 4.0, 2.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def test_a_window_holding_a_single_probability_of_one_is_not_empty() -> None:
    # Wrong (m00 <= 1 taken for empty), a faint one-pixel window would report its centre.
    # By hand: prob[2, 3] = 1 in a 4 x 4 window at (0, 0): M00 = 1, (xc, yc) = (3, 2),
    # a = 9 - 9 = 0, b = 2 (6 - 6) = 0, c = 4 - 4 = 0: both axes 0, angle 0.5 atan2(0, 0) = 0.
    prob = np.zeros((4, 4), np.uint8)
    prob[2, 3] = 1
    assert window_moments(prob, (0, 0, 4, 4)) == WindowMoments(1.0, 3.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def test_a_one_pixel_high_line_has_a_major_axis_below_one_and_no_minor_axis() -> None:
    # Wrong (the axes floored at 1 px instead of 0), a thin target's spread would be overstated.
    # By hand: row 0 = [1, 1, 1] in window (0, 0, 3, 1): M00 = 3, xc = 1, yc = 0;
    # a = (0 + 1 + 4) / 3 - 1 = 2/3, b = 0, c = 0; root = sqrt(0 + (2/3)^2) = 2/3;
    # major = sqrt((2/3 + 2/3) / 2) = sqrt(2/3) = 0.816497, minor = sqrt(0 / 2) = 0, angle 0.
    prob = np.ones((1, 3), np.uint8)
    m = window_moments(prob, (0, 0, 3, 1))
    assert m.m00 == 3.0
    assert (m.xc, m.yc) == (1.0, 0.0)
    assert m.a == pytest.approx(2.0 / 3.0, rel=1e-12)
    assert m.major == pytest.approx(math.sqrt(2.0 / 3.0), rel=1e-12)
    assert m.major == pytest.approx(0.816497, abs=1e-6)
    assert m.minor == 0.0
    assert m.angle_rad == 0.0


def test_eq7_b_of_a_two_pixel_diagonal_by_hand() -> None:
    # Wrong (b without its factor 2, as a garbled eq. 7 reads), a leaning target's axes and
    # angle would be off: a diagonal would read sqrt(0.375) long, 0.25 wide, at 22.5 degrees.
    # By hand: ones at (x, y) = (0, 0) and (1, 1) in window (0, 0, 2, 2): M00 = 2, xc = yc = 0.5;
    # a = (0 + 1) / 2 - 0.25 = 0.25, c = 0.25, b = 2 ((0 + 1) / 2 - 0.25) = 0.5;
    # root = sqrt(0.5^2 + 0^2) = 0.5; major = sqrt((0.5 + 0.5) / 2) = 0.707107, minor = 0;
    # angle = atan2(0.5, 0) / 2 = pi / 4 (image y down: the line runs down and right).
    prob = np.array([[1, 0], [0, 1]], np.uint8)
    m = window_moments(prob, (0, 0, 2, 2))
    assert (m.m00, m.xc, m.yc) == (2.0, 0.5, 0.5)
    assert (m.a, m.b, m.c) == pytest.approx((0.25, 0.5, 0.25), abs=1e-12)
    assert m.major == pytest.approx(0.707107, abs=1e-6)
    assert m.minor == pytest.approx(0.0, abs=1e-12)
    assert m.angle_rad == pytest.approx(math.pi / 4, abs=1e-12)


# -- meanshift_in_roi ---------------------------------------------------------------------------


def test_mean_shift_on_a_uniform_patch_at_the_regions_corner_keeps_the_window() -> None:
    # Wrong, a window starting on the region's left or top edge would start a pixel in and
    # come back a pixel narrower or lower.
    # By hand: uniform 255, window (100, 50, 4, 2) = local (0, 0, 4, 2): dx = cvRound(1.5 - 2)
    # = 0, dy = cvRound(0.5 - 1) = 0: it stays; mass 255 / 255 = 1.
    assert meanshift_in_roi(uniform(255), ORIGIN, (100, 50, 4, 2)) == ((100, 50, 4, 2), 1.0)


def test_mean_shift_keeps_a_one_pixel_window_one_pixel() -> None:
    # By hand: uniform 255, window (105, 52, 1, 1): dx = cvRound(0 - 0.5) = 0, dy too: it stays.
    assert meanshift_in_roi(uniform(255), ORIGIN, (105, 52, 1, 1)) == ((105, 52, 1, 1), 1.0)


def test_mean_shift_starts_on_the_part_of_a_window_left_of_the_region_that_is_inside_it() -> None:
    # Wrong, a window hanging off the region's left edge would start (and stay) wider than
    # its part inside the region.
    # By hand: window (97, 52, 5, 3) over a region from x = 100: columns 100 and 101 are
    # inside: local (0, 2, 2, 3); uniform: it stays: (100, 52, 2, 3).
    assert meanshift_in_roi(uniform(255), ORIGIN, (97, 52, 5, 3)) == ((100, 52, 2, 3), 1.0)


def test_mean_shift_starts_on_the_part_of_a_window_above_the_region_that_is_inside_it() -> None:
    # By hand: window (103, 48, 2, 4) over a region from y = 50: rows 50 and 51 are inside:
    # local (3, 0, 2, 2): (103, 50, 2, 2).
    assert meanshift_in_roi(uniform(255), ORIGIN, (103, 48, 2, 4)) == ((103, 50, 2, 2), 1.0)


def test_mean_shifts_mass_is_the_mean_probability_over_255() -> None:
    # By hand: uniform 51: the window stays, its mean is 51: mass 51 / 255 = 0.2.
    (_, mass) = meanshift_in_roi(uniform(51), ORIGIN, (104, 53, 3, 2))
    assert mass == pytest.approx(0.2, rel=1e-12)


@pytest.mark.parametrize(
    "window",
    [
        (120, 52, 4, 2),  # starts at local x = 20 = the region's width
        (125, 52, 4, 2),  # right of it
        (105, 60, 4, 2),  # starts at local y = 10 = the region's height
        (105, 65, 4, 2),  # below it
        (96, 52, 4, 2),  # ends at x = 100, where the region starts: left of it
        (105, 46, 4, 4),  # ends at y = 50: above it
    ],
)
def test_a_window_wholly_outside_the_region_is_handed_back_with_no_mass(window: tuple[int, int, int, int]) -> None:
    # Wrong, mean shift would run from a window outside the region and pull it somewhere in it.
    assert meanshift_in_roi(uniform(255), ORIGIN, window) == (window, 0.0)
    assert camshift_in_roi(uniform(255), ORIGIN, window) == (window, 0.0)


# -- camshift_in_roi ----------------------------------------------------------------------------


def test_camshift_on_a_one_pixel_wide_column_keeps_it_one_pixel_wide() -> None:
    # Wrong (a window of 1 px taken for lost), a target one pixel wide would vanish.
    # By hand: a region 5 rows x 1 column of 255 at (100, 50), window (100, 50, 1, 5).
    # meanShift: centroid (0, 2): dx = cvRound(0 - 0.5) = 0, dy = cvRound(2 - 2.5) = 0.
    # Grown by 10 px and clipped: (0, 0, 1, 5). M00 = 5 * 255, (xc, yc) = (0, 2), mu20 = 0,
    # mu11 = 0, mu02 = 255 (4 + 1 + 0 + 1 + 4) = 2550: a = 0, b = 0, c = 2; square = 2,
    # theta = atan2(0, 0 - 2 + 2) = 0; length = 4 sqrt(0) = 0, width = 4 sqrt(2550 / 1275)
    # = 5.657: swapped, length 5.657, width 0, cos 0, sin 1.
    # width = min(max(0, 0) + 2, 2 (1 - 0)) = 2, height = min(max(6, 0) + 2, 2 (5 - 2)) = 6;
    # x = max(0, 0 - 1) = 0, y = max(0, 2 - 3) = 0; clipped: width min(1, 2) = 1, height
    # min(5, 6) = 5: (0, 0, 1, 5) -> (100, 50, 1, 5), mass 255 / 255 = 1.
    assert camshift_in_roi(uniform(255, rows=5, cols=1), ORIGIN, (100, 50, 1, 5)) == ((100, 50, 1, 5), 1.0)


def test_camshift_on_a_one_pixel_high_row_keeps_it_one_pixel_high() -> None:
    # By hand: the transpose of the column: region 1 row x 5 columns of 255; mu20 = 2550,
    # mu02 = 0: theta = atan2(0, 2 + 2) = 0, length 5.657, width 0 (no swap):
    # width = min(6 + 2, 2 (5 - 2)) = 6, height = min(0 + 2, 2 (1 - 0)) = 2; x = 0, y = 0;
    # clipped (5, 1): (100, 50, 5, 1), mass 1.
    assert camshift_in_roi(uniform(255, rows=1, cols=5), ORIGIN, (100, 50, 5, 1)) == ((100, 50, 5, 1), 1.0)


def test_camshifts_mass_is_the_mean_probability_over_255() -> None:
    # By hand: as the column above with 51 for 255 (the window depends on the shape, not the
    # level): (100, 50, 1, 5), mass 51 / 255 = 0.2.
    win, mass = camshift_in_roi(uniform(51, rows=5, cols=1), ORIGIN, (100, 50, 1, 5))
    assert win == (100, 50, 1, 5)
    assert mass == pytest.approx(0.2, rel=1e-12)


def test_camshift_on_no_probability_loses_the_window() -> None:
    # cv2.CamShift never returns a zero-size window: with m00 = 0 (camshift.cpp, `if (fabs(m00)
    # < DBL_EPSILON) return RotatedRect();`) it hands back the meanShift window already grown
    # by TOLERANCE = 10 px a side. Window (130, 70, 10, 10) on an all-zero 60 x 80 region at
    # (100, 50) -> local (30, 20, 10, 10), meanShift stays (m00 = 0), grown to (20, 10, 30, 30),
    # empty. That is a lost window: a zero-size window at the start and mass 0 (the hue and
    # hs-lbp trackers' LOST, "window vanished"; before, they went on TRACKING a window 20 px
    # larger every frame).
    win, mass = camshift_in_roi(np.zeros((60, 80), np.uint8), ORIGIN, (130, 70, 10, 10))
    assert mass == 0.0
    assert win == (130, 70, 0, 0)


RAMP = (4 * np.arange(60)).astype(np.uint8)[None, :]  # one row, probability 4 i at column i


def test_mean_shift_stops_after_ten_iterations() -> None:
    # Wrong (another iteration limit), mean shift would follow a slope further per frame.
    # By hand: window 21 wide at x over p(i) = 4 i: its centroid, from x, is
    # sum j (j + x) / sum (j + x) (j = 0..20) = (2870 + 210 x) / (21 (10 + x)); the step
    # cvRound(centroid - 10.5): x = 0: 13.67 -> 3; 3: 12.82 -> 2; 5: 12.44 -> 2; 7: 12.16 -> 2;
    # 9: 11.93 -> 1; then 1 a step until x = 27 (centroid 10.99, step 0). After the 10
    # iterations TERM allows: 3 + 2 + 2 + 2 + 6 x 1 = 15. Mass: mean of 4 i over 15..35 = 100:
    # 100 / 255.
    win, mass = meanshift_in_roi(RAMP, ORIGIN, (100, 50, 21, 1))
    assert win == (115, 50, 21, 1)
    assert mass == pytest.approx(100.0 / 255.0, rel=1e-12)


def test_camshift_sizes_the_window_from_where_ten_mean_shift_iterations_leave_it() -> None:
    # By hand: mean shift ends at x = 15 (above); grown by 10: columns 5..45 (one row).
    # Weights i (4 i, the 4 cancels): E[i] = sum i^2 / sum i = 31365 / 1025 = 30.6 -> xc 31;
    # E[i^2] = sum i^3 / sum i = 1071125 / 1025 = 1045, variance 1045 - 30.6^2 = 108.64;
    # length 4 sqrt(108.64) = 41.69, width 0, theta 0: width min(42 + 2, 2 (60 - 31)) = 44,
    # height min(0 + 2, 2 (1 - 0)) = 2; x = 31 - 22 = 9, y = max(0, 0 - 1) = 0; clipped to
    # (9, 0, 44, 1). Mass: mean of 4 i over 9..52 = 122: 122 / 255.
    win, mass = camshift_in_roi(RAMP, ORIGIN, (100, 50, 21, 1))
    assert win == (109, 50, 44, 1)
    assert mass == pytest.approx(122.0 / 255.0, rel=1e-12)


def test_camshift_starts_on_the_part_of_a_window_left_of_the_region_that_is_inside_it() -> None:
    # A window hanging off the region's left (or top) edge starts CAMShift on its part inside,
    # as meanshift_in_roi does (w - (lx - (x - ox))), not on w columns from the edge.
    # By hand: window (90, 50, 21, 1) over the ramp's region at x = 100: the part inside is
    # local columns 0..10, (0, 0, 11, 1). Mean shift from there: centroid (from x) =
    # (sum j (j + x)) / (sum (j + x)), j = 0..10: x = 0: 385 / 55 = 7 -> step cvRound(7 - 5.5)
    # = 2; x = 2: 495 / 77 = 6.43 -> 1; 3: 550 / 88 = 6.25 -> 1; 4: 605 / 99 = 6.11 -> 1;
    # 5: 660 / 110 = 6.0 -> cvRound(0.5) = 0: x = 5. Grown by 10: columns 0..30 (one row):
    # E[i] = sum i^2 / sum i = 9455 / 465 = 20.33 -> xc 20; E[i^2] = sum i^3 / sum i = 465,
    # variance 465 - 20.33^2 = 51.6, length 4 sqrt(51.6) = 28.7: width min(29 + 2, 2 (60 - 20))
    # = 31, x = 20 - 15 = 5: (5, 0, 31, 1) -> (105, 50, 31, 1); mass = mean 4 i over 5..35 =
    # 80: 80 / 255. (Started on (0, 0, 21, 1) instead, it gives (109, 50, 44, 1).)
    win, mass = camshift_in_roi(RAMP, ORIGIN, (90, 50, 21, 1))
    assert win == (105, 50, 31, 1)
    assert mass == pytest.approx(80.0 / 255.0, rel=1e-12)


# -- the baseline trackers, which take CAMShift's window as the track ------------------------------


@pytest.mark.parametrize("kind", ["hue", "hs-lbp"])
def test_a_baseline_tracker_goes_lost_when_its_colours_leave_the_picture(kind: str) -> None:
    # a saturated red square on grey, then the grey alone: no pixel back-projects, CAMShift
    # finds nothing in the window it grows, and the track is LOST ("window vanished"), where it
    # was TRACKING a window 20 px larger every frame; the red square back where the window
    # last was is taken up again
    from lfctl.vision.track_state import TrackStatus
    from lfctl.vision.tracker import Tracker, TrackerSettings

    grey = np.full((120, 160, 3), 128, np.uint8)
    red = grey.copy()
    red[40:80, 60:100] = (0, 0, 220)
    tracker = Tracker(TrackerSettings(kind=kind, use_markers=False))
    tracker.init(red, (60, 40, 40, 40))
    assert tracker.update(red).status is TrackStatus.TRACKING
    for _ in range(3):
        st = tracker.update(grey)
        assert st.status is TrackStatus.LOST and st.bbox is None and st.reason == "window vanished"
    # back: CAMShift's window on a uniform 40 px square is 4 sqrt(40^2 / 12) + 2 = 48 px,
    # centred on it: (56, 36, 48, 48)
    st = tracker.update(red)
    assert st.status is TrackStatus.TRACKING and st.bbox == (56, 36, 48, 48)
