"""The banner's marker constellation, worked by hand: the constellation score's factors on a
skewed quad, its gates at their edges, the look from a scenario's [banner], the hue distance
on OpenCV's circle, the sub-pixel centre, the finder's origin, limit and look, and the checks
of check_constellation at their edges (the homography's projective part, the marker shape's
tolerance, the tiny-marker rule, the hue and saturation limits).

The scenes are drawn straight in HSV (OpenCV's 8-bit scale: hue in degrees / 2): a light
panel (0, 10, 220) everywhere and square markers of hue 0."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lfctl.config import BannerConfig
from lfctl.vision.chaincode import Blob
from lfctl.vision.markers import (
    BannerLook,
    Constellation,
    _hue_off_table,
    check_constellation,
    constellation_scores,
    find_constellation,
    find_constellations,
    refine,
    refine_centre,
)

LIGHT = (0, 10, 220)  # the panel: saturation 10, value 220
RED = (0, 217, 217)  # the markers: hue 0, saturation and value 0.85


def blob_at(x: int, y: int, w: int, h: int, area: float | None = None) -> Blob:
    """A blob with just what check_constellation and refine_centre read: its box and area."""
    return Blob(
        (),
        (x, y),
        float(w * h) if area is None else area,
        4.0 * (w + h),
        (x + (w - 1) / 2, y + (h - 1) / 2),
        (x, y, w, h),
    )


def scene(
    centres: list[tuple[int, int]],
    size: tuple[int, int] = (5, 5),
    marker: tuple[int, int, int] = RED,
    shape: tuple[int, int] = (120, 120),
    area: float | None = None,
) -> tuple[np.ndarray, Constellation]:
    """A light HSV image with a w x h marker on each centre (TL, TR, BR, BL), and the
    constellation of those markers (centres exact, box (cx - w // 2, cy - h // 2, w, h))."""
    hsv = np.empty((*shape, 3), np.uint8)
    hsv[:] = LIGHT
    w, h = size
    bs = []
    for cx, cy in centres:
        x, y = cx - w // 2, cy - h // 2
        hsv[y : y + h, x : x + w] = marker
        bs.append(blob_at(x, y, w, h, area))
    pts = np.array([(b.bbox[0] + (w - 1) / 2, b.bbox[1] + (h - 1) / 2) for b in bs], float)
    return hsv, Constellation(pts, tuple(bs), 1.0)


SQUARE = [(40, 40), (80, 40), (80, 80), (40, 80)]  # side 40, TL TR BR BL


# -- the look and the hue distance --------------------------------------------------------------


def test_the_look_of_a_scenarios_banner_by_hand() -> None:
    # By hand: markers 0.04 m and panel 0.24 m on a 0.16 m square: 0.04 / 0.16 = 0.25,
    # 0.24 / 0.16 = 1.5; the saturation as given, 0.7.
    look = BannerLook.from_config(
        BannerConfig(side_m=0.16, marker_size_m=0.04, panel_size_m=0.24, marker_saturation=0.7)
    )
    assert look.marker_saturation == 0.7
    assert look.marker_over_side == pytest.approx(0.25, rel=1e-12)
    assert look.panel_over_side == pytest.approx(1.5, rel=1e-12)


def test_the_hue_distance_goes_the_short_way_round_opencvs_circle_in_whole_degrees() -> None:
    # Wrong, markers of any hue but red (target 0) would be judged against the wrong hues.
    # By hand, target 5 (10 deg): hue 5 -> 0; hue 0 -> |0 - 5| = 5 -> 10 deg; 10 -> 10 deg;
    # 170 -> |170 - 5| = 165, the short way 180 - 165 = 15 -> 30 deg; 95 -> 90 -> 180 deg.
    table = _hue_off_table(5)
    assert table[[5, 0, 10, 170, 95]].tolist() == [0, 10, 10, 30, 180]


# -- constellation_scores -----------------------------------------------------------------------


def test_the_score_of_a_skewed_quad_is_the_product_of_its_factors_by_hand() -> None:
    # Wrong, any of the factors (upright, width match, pair match, perspective) could be
    # dropped, inverted or mis-paired unnoticed: every one of them is below 1 here.
    # TL (0, 0), TR (40, 0), BR (49, 40), BL (0, 40); areas TL 100, TR 100, BR 81, BL 64.
    # left = 40, right = |(9, 40)| = 41, top = 40, bottom = 49; the shortest side 40 >= 2;
    # aspect = 44.5 / 40.5 = 1.099 (0.2..1.4).
    # upright = 1 - (0 + 9) / (40 + 41) = 8/9; width match = 40/49;
    # pair match = (64/100) (81/100) = 0.5184, its root 0.72;
    # perspective: expected (41/40)^2 = 1.050625, got (100 + 81) / (100 + 64) = 181/164
    # = 1.103659: min(ratio, 1/ratio) = 0.951947, its root 0.975678;
    # scale = sqrt(345 / 4) / 40.5 = 0.2293 (0.125..0.4).
    # score = 8/9 * 40/49 * 0.72 * 0.975678 = 0.509742.
    c = np.array([[[0, 0], [40, 0], [49, 40], [0, 40]]], float)
    sizes = np.array([[100.0, 100.0, 81.0, 64.0]])
    perspective = (41.0 / 40.0) ** 2 / (181.0 / 164.0)
    expected = 8.0 / 9.0 * 40.0 / 49.0 * 0.72 * math.sqrt(perspective)
    got = constellation_scores(c, sizes)
    assert got[0] == pytest.approx(expected, rel=1e-12)
    assert got[0] == pytest.approx(0.509742, abs=1e-6)


def test_the_nearer_sides_markers_are_larger_by_the_square_of_the_side_ratio() -> None:
    # By hand: TL (0, 0), TR (30, 10), BR (30, 30), BL (0, 40): left 40, right 20, top =
    # bottom = sqrt(900 + 100) = 31.62; expected area ratio (20/40)^2 = 0.25; areas 100 on the
    # left, 25 on the right: got 50 / 200 = 0.25: perspective 1; every other factor 1;
    # scale sqrt(250 / 4) / 30 = 0.2635: score 1.
    c = np.array([[[0, 0], [30, 10], [30, 30], [0, 40]]], float)
    assert constellation_scores(c, np.array([[100.0, 25.0, 25.0, 100.0]]))[0] == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize(
    ("quad", "area", "score"),
    [
        # the shortest side exactly 2 px (area 0.25: scale sqrt(0.25) / 2 = 0.25): kept
        ([[0, 0], [2, 0], [2, 2], [0, 2]], 0.25, 1.0),
        # sides of 1.5 px (area 0.140625: scale 0.375 / 1.5 = 0.25, aspect 1): too small
        ([[0, 0], [1.5, 0], [1.5, 1.5], [0, 1.5]], 0.140625, 0.0),
        # aspect exactly 1.4: sides 56 across, 40 down (area 100: scale 10 / 40 = 0.25): kept
        ([[0, 0], [56, 0], [56, 40], [0, 40]], 100.0, 1.0),
        # aspect exactly 0.2: 8 across, 40 down: kept
        ([[0, 0], [8, 0], [8, 40], [0, 40]], 100.0, 1.0),
        # aspect 2: 80 across, 40 down: not a banner
        ([[0, 0], [80, 0], [80, 40], [0, 40]], 100.0, 0.0),
        # scale exactly 0.5 x 0.25 = 0.125 (area 25 on a side of 40: 5 / 40): kept
        ([[0, 0], [40, 0], [40, 40], [0, 40]], 25.0, 1.0),
        # scale exactly 1.6 x 0.25 = 0.4 (area 256: 16 / 40): kept
        ([[0, 0], [40, 0], [40, 40], [0, 40]], 256.0, 1.0),
    ],
)
def test_the_constellation_gates_at_their_edges(quad: list[list[float]], area: float, score: float) -> None:
    # Wrong (a gate's edge moved, or one gate overwriting another's verdict), constellations
    # at the limits of the accepted range would come and go.
    # Every kept one is an upright rectangle with equal markers: each factor 1, score 1.
    got = constellation_scores(np.array([quad], float), np.full((1, 4), area))
    assert got[0] == score


# -- refine_centre and refine -------------------------------------------------------------------


@pytest.mark.parametrize(("hue_deg", "opencv_hue"), [(0.0, 0), (100.0, 50)])
def test_the_sub_pixel_centre_weighs_saturation_above_30_and_reads_the_images_first_column_and_row(
    hue_deg: float, opencv_hue: int
) -> None:
    # Wrong, a marker in the image's corner would lose its first column or row, or every
    # centre move by another saturation floor; or (the marker hue turned into OpenCV's scale
    # another way) markers of any hue but red would lose their sub-pixel centre.
    # By hand: a 2 x 1 marker at (0, 0): saturation 130 and 230, of the marker's hue (100 deg
    # is OpenCV's 50): weights 130 - 30 = 100 and 230 - 30 = 200 (0 elsewhere):
    # x = (0 * 100 + 1 * 200) / 300 = 2/3, y = 0. A pixel of the other hue beside it (100 deg
    # off) weighs 0.
    hsv = np.zeros((5, 10, 3), np.uint8)
    hsv[0, 0] = (opencv_hue, 130, 200)
    hsv[0, 1] = (opencv_hue, 230, 200)
    hsv[0, 2] = (50 - opencv_hue, 255, 200)
    x, y = refine_centre(hsv, blob_at(0, 0, 2, 1), hue_deg, 18.0)
    assert x == pytest.approx(2.0 / 3.0, abs=1e-12)
    assert y == 0.0


def test_the_sub_pixel_centre_looks_two_pixels_round_the_blob_and_no_further() -> None:
    # Wrong, a red pixel three pixels off the marker (another marker's rim, clutter) would
    # pull its centre.
    # By hand: the same 2 x 1 marker at (5, 3): (5 + 2/3, 3). Red pixels at (2, 3), (5, 0),
    # (9, 3) and (5, 6) are 3 px left of, above, right of and below its box: outside the
    # region (columns 3..8, rows 1..5).
    hsv = np.zeros((8, 10, 3), np.uint8)
    hsv[3, 5] = (0, 130, 200)
    hsv[3, 6] = (0, 230, 200)
    for row, col in ((3, 2), (0, 5), (3, 9), (6, 5)):
        hsv[row, col] = (0, 255, 200)
    x, y = refine_centre(hsv, blob_at(5, 3, 2, 1), 0.0, 18.0)
    assert x == pytest.approx(5.0 + 2.0 / 3.0, abs=1e-12)
    assert y == pytest.approx(3.0, abs=1e-12)


def test_the_sub_pixel_centre_of_a_faint_or_missing_marker() -> None:
    # By hand: one pixel of saturation 31 at (3, 1): weight 31 - 30 = 1, M00 = 1: the centre
    # is that pixel, (3, 1). No pixel of the hue: M00 = 0: the blob's own centroid.
    hsv = np.zeros((5, 10, 3), np.uint8)
    hsv[1, 3] = (0, 31, 200)
    b = Blob((), (3, 1), 1.0, 4.0, (7.5, 2.5), (3, 1, 1, 1))
    assert refine_centre(hsv, b, 0.0, 18.0) == (3.0, 1.0)
    assert refine_centre(np.zeros((5, 10, 3), np.uint8), b, 0.0, 18.0) == (7.5, 2.5)


def test_refine_keeps_the_blobs_and_score_and_adds_the_origin() -> None:
    # By hand: the square's markers (5 x 5, uniform): the weighted centres are the box
    # centres; + origin (100, 50).
    hsv, c = scene(SQUARE)
    c = Constellation(c.centres, c.blobs, 0.75)
    r = refine(c, hsv, 0.0, origin=(100, 50))
    assert r.blobs is c.blobs
    assert r.score == 0.75
    assert r.centres == pytest.approx(np.array([[140, 90], [180, 90], [180, 130], [140, 130]], float), abs=1e-9)


# -- find_constellations and find_constellation -------------------------------------------------


def drawn(shape: tuple[int, int] = (120, 200), at: list[tuple[int, int]] | None = None, v: int = 217) -> np.ndarray:
    """HSV: dark ground (value 60), a light panel 64 x 64 on each centre, 10 x 10 markers of value
    ``v`` on the corners of a 40 px square about it."""
    hsv = np.zeros((*shape, 3), np.uint8)
    hsv[:] = (0, 0, 60)
    for cx, cy in at or [(60, 60)]:
        hsv[cy - 32 : cy + 32, cx - 32 : cx + 32] = LIGHT
        for sx in (-1, 1):
            for sy in (-1, 1):
                mx, my = cx + sx * 20, cy + sy * 20
                hsv[my - 5 : my + 5, mx - 5 : mx + 5] = (0, 217, v)
    return hsv


def test_a_drawn_banner_scores_one_and_comes_back_in_frame_pixels() -> None:
    # By hand: markers 10 x 10 from (35, 35), (75, 35), (75, 75), (35, 75): centroids
    # (39.5, 39.5), ...: a square of side 40 with equal markers: score exactly 1, kept at
    # min_score 1; with origin (100, 50) every centre moves by it.
    hsv = drawn()
    (c,) = find_constellations(hsv, 0.0, origin=(100, 50), min_score=1.0)
    assert c.score == 1.0
    assert c.centres == pytest.approx(
        np.array([[139.5, 89.5], [179.5, 89.5], [179.5, 129.5], [139.5, 129.5]]), abs=1e-9
    )
    best = find_constellation(hsv, 0.0, origin=(100, 50))
    assert best is not None
    assert best.centres == pytest.approx(c.centres, abs=1e-9)


def test_at_most_limit_constellations_come_back() -> None:
    # By hand: two banners (centres (60, 60) and (140, 60)) in one image, each a
    # constellation: limit 1 gives one.
    hsv = drawn(at=[(60, 60), (140, 60)])
    assert len(find_constellations(hsv, 0.0)) >= 2
    assert len(find_constellations(hsv, 0.0, limit=1)) == 1


def test_the_banners_look_is_used_for_the_checks() -> None:
    # Wrong (the default look taken), a scenario's own banner would be judged as the default.
    # By hand: a look whose panel is 3x the square (instead of 1.57x) puts the panel's ring
    # (0.95 x 3 x 20 = 57 px from the centre) on the dark ground (value 60 < 217 / 2): "panel".
    hsv = drawn()
    look = BannerLook(panel_over_side=3.0)
    assert find_constellations(hsv, 0.0)
    assert find_constellations(hsv, 0.0, look=look) == []
    assert find_constellation(hsv, 0.0, look=look) is None


def test_markers_as_dark_as_value_40_are_found() -> None:
    # The default v_min is 40 (the colour module's own default is 50): markers of value
    # exactly 40 are marker pixels (their panel then needs value >= ceil(40 / 2) = 20).
    assert len(find_constellations(drawn(v=40), 0.0)) == 1


def test_the_looks_marker_size_is_used_for_the_score() -> None:
    # By hand: markers 10 px on a 40 px square: sqrt(100) / 40 = 0.25; a look whose markers
    # are 0.1 of the square accepts 0.05..0.16: no constellation.
    assert find_constellations(drawn(), 0.0, look=BannerLook(marker_over_side=0.1)) == []


def test_no_markers_no_constellation() -> None:
    assert find_constellation(np.zeros((60, 60, 3), np.uint8), 0.0) is None


# -- check_constellation ------------------------------------------------------------------------


def skewed(k: float, s: int = 20, at: tuple[int, int] = (30, 30)) -> list[tuple[int, int]]:
    """TL (a, b), TR (a + s, b), BR (a + k s, b + k s), BL (a, b + s): the unit square's image
    under H with third row (g, g, 1), g = -(k - 1) / (2 k - 1) (solved from the four corners;
    translation and scale leave the third row alone)."""
    a, b = at
    return [(a, b), (a + s, b), (a + int(k * s), b + int(k * s)), (a, b + s)]


def test_a_quad_whose_projective_part_is_just_over_0_6_fails_perspective() -> None:
    # By hand: k = 4: g = -3/7, |(g, g)| / 1 = sqrt(2) 3/7 = 0.606 > 0.6: "perspective".
    # k = 3: g = -2/5, sqrt(2) 2/5 = 0.566: passes (and the light panel: all passes).
    # Marker shape: across = s + s sqrt(k^2 + (k - 1)^2) = down: aspect 1, square markers.
    hsv, c = scene(skewed(4.0), size=(3, 3), shape=(160, 160))
    assert check_constellation(c, hsv, 0.0) == "perspective"
    hsv, c = scene(skewed(3.0), size=(3, 3), shape=(160, 160))
    assert check_constellation(c, hsv, 0.0) == ""


def test_a_marker_exactly_at_the_shapes_tolerance_passes() -> None:
    # By hand: a square of side 80 (aspect 1); markers 27 x 20: |27 - 1 x 20| = 7 and
    # 0.3 x 1 x 20 + 1 = 7: not more than the tolerance: passes.
    big = [(40, 40), (120, 40), (120, 120), (40, 120)]
    hsv, c = scene(big, size=(27, 20), shape=(170, 170))
    assert check_constellation(c, hsv, 0.0) == ""
    hsv, c = scene(big, size=(28, 20), shape=(170, 170))  # |28 - 20| = 8 > 7
    assert check_constellation(c, hsv, 0.0) == "marker shape"


def _speckled(sat_low: int, n_low: int, area: float, size: int = 5) -> tuple[np.ndarray, Constellation]:
    """The square with markers of which the first ``n_low`` pixels (row-major) have
    saturation ``sat_low`` and the rest 217."""
    hsv, c = scene(SQUARE, size=(size, size), area=area)
    for b in c.blobs:
        x, y, w, h = b.bbox
        region = hsv[y : y + h, x : x + w].reshape(-1, 3)
        region[:n_low, 1] = sat_low
        hsv[y : y + h, x : x + w] = region.reshape(h, w, 3)
    return hsv, c


def test_a_marker_of_16_px_or_more_is_judged_by_its_median_saturation() -> None:
    # By hand: 5 x 5 markers, area 16 (TINY_MARKER_PX: not tiny) and 25: 13 pixels at 100,
    # 12 at 217; the median (the 13th of 25) is 100 < 0.7 x 0.85 x 255 = 151.7: "marker
    # colour" (its most saturated pixel, 217, is not what counts).
    for area in (16.0, 25.0):
        hsv, c = _speckled(100, 13, area)
        assert check_constellation(c, hsv, 0.0) == "marker colour"


def test_a_marker_under_16_px_is_judged_by_its_most_saturated_pixel() -> None:
    # By hand: the same markers with area 15 (tiny): max saturation 217 >= 151.7: passes.
    hsv, c = _speckled(100, 13, 15.0)
    assert check_constellation(c, hsv, 0.0) == ""


def test_a_marker_pixel_at_exactly_s_min_counts_as_marker() -> None:
    # Wrong (saturation > s_min), pixels at exactly 90 would leave the median.
    # By hand: 13 of 25 pixels at saturation 90 (= s_min), 12 at 217: all 25 are marker
    # pixels, the median is 90 < 151.7: "marker colour" (without the 90s it would be 217).
    hsv, c = _speckled(90, 13, 25.0)
    assert check_constellation(c, hsv, 0.0) == "marker colour"


def test_a_marker_pixel_at_exactly_the_hue_tolerance_counts_as_marker() -> None:
    # By hand: 13 of 25 pixels at hue 9 (18 deg = the tolerance), 12 at hue 0, all
    # saturation 217: all are marker pixels, the median hue distance 18 > 9: "marker colour".
    hsv, c = scene(SQUARE)
    for b in c.blobs:
        x, y, w, h = b.bbox
        region = hsv[y : y + h, x : x + w].reshape(-1, 3)
        region[:13, 0] = 9
        hsv[y : y + h, x : x + w] = region.reshape(h, w, 3)
    assert check_constellation(c, hsv, 0.0) == "marker colour"


def test_a_marker_hue_exactly_half_the_window_off_passes() -> None:
    # By hand: tolerance 16 deg; markers at hue 4 (8 deg off red): 8 > 16 / 2 is false:
    # passes; at hue 5 (10 deg): "marker colour".
    hsv, c = scene(SQUARE, marker=(4, 217, 217))
    assert check_constellation(c, hsv, 0.0, tolerance_deg=16.0) == ""
    hsv, c = scene(SQUARE, marker=(5, 217, 217))
    assert check_constellation(c, hsv, 0.0, tolerance_deg=16.0) == "marker colour"


def test_markers_of_value_exactly_40_pass_the_checks_defaults() -> None:
    # By hand: the check's default v_min is 40: markers (0, 217, 40) are marker pixels; the
    # panel needs value >= ceil(40 / 2) = 20: passes.
    hsv, c = scene(SQUARE, marker=(0, 217, 40))
    assert check_constellation(c, hsv, 0.0) == ""


def test_a_marker_saturation_of_152_passes_the_printed_limit() -> None:
    # By hand: 0.7 x 0.85 x 255 = 151.725: 152 passes, 151 does not.
    hsv, c = scene(SQUARE, marker=(0, 152, 217))
    assert check_constellation(c, hsv, 0.0) == ""
    hsv, c = scene(SQUARE, marker=(0, 151, 217))
    assert check_constellation(c, hsv, 0.0) == "marker colour"


def test_light_panel_means_at_least_half_the_markers_value() -> None:
    # By hand: markers of value 217: the panel must be at value ceil(217 / 2) = 109 or more
    # and saturation below ceil(217 / 2) = 109: a panel (0, 10, 109) passes, (0, 10, 108)
    # does not; (0, 108, 220) passes, (0, 109, 220) does not.
    for panel, verdict in [((0, 10, 109), ""), ((0, 10, 108), "panel"), ((0, 108, 220), ""), ((0, 109, 220), "panel")]:
        hsv, c = scene(SQUARE)
        hsv[np.all(hsv == LIGHT, axis=2)] = panel
        assert check_constellation(c, hsv, 0.0) == verdict, panel


def test_green_markers_pass_against_a_green_banner_hue() -> None:
    # Wrong (the banner's hue turned into OpenCV's scale another way), only red banners
    # would pass. By hand: 100 deg = OpenCV 50; markers (50, 217, 217): 0 deg off: passes.
    hsv, c = scene(SQUARE, marker=(50, 217, 217))
    assert check_constellation(c, hsv, 100.0) == ""


def _panel_darkened(n_dark: int, width: int = 89) -> tuple[np.ndarray, Constellation]:
    """SQUARE's scene in a picture ``width`` px wide, with ``n_dark`` panel pixels dark (value
    50): the first of rows 46..74 (between the markers' rows), x = 30..88, read left to right."""
    hsv, c = scene(SQUARE, shape=(120, width))
    ys, xs = np.mgrid[46:75, 30:89]
    hsv[ys.ravel()[:n_dark], xs.ravel()[:n_dark]] = (0, 10, 50)
    return hsv, c


def test_the_panel_must_be_light_on_60_percent_of_its_pixels_counted_by_hand() -> None:
    # The panel's quad: the centres (40..80) about (60, 60) scaled by 0.22 / 0.14 * 0.95
    # = 1.492857: 60 -+ 29.857, rounded 30 and 90, filled with its edges; the picture ends
    # at x = 88: 59 x 61 = 3599 px. Each 5 x 5 marker (box at 38 or 78) takes a rectangle
    # from x - 1 - 5 // 3 to x + 5 + 1 (36..44 or 76..84) out: 9 x 9 = 81 px, 324 in all:
    # 3275 panel pixels, of which 60 % is 1965 exactly. 1310 dark: light 1965, a banner;
    # 1311 dark: light 1964, not.
    hsv, c = _panel_darkened(1310)
    assert check_constellation(c, hsv, 0.0) == ""
    hsv, c = _panel_darkened(1311)
    assert check_constellation(c, hsv, 0.0) == "panel"
    # a dark rim round a marker (column 36, rows 36..44: inside its rectangle) is not panel
    hsv, c = _panel_darkened(1310)
    hsv[36:45, 36] = (0, 10, 50)
    assert check_constellation(c, hsv, 0.0) == ""
    # in a wider picture the quad's last column (x = 90) is panel too: 61 x 61 - 324 = 3397
    # pixels, 60 % of them 2038.2: 1358 dark leaves 2039 light, a banner; 1359, not
    for n_dark, verdict in ((1358, ""), (1359, "panel")):
        hsv, c = _panel_darkened(n_dark, width=120)
        assert check_constellation(c, hsv, 0.0) == verdict, n_dark


def test_the_panel_is_light_against_the_markers_upper_median_saturation() -> None:
    # markers of saturation 200, 210, 220 and 230 (the printed 0.85 of 255 is 217; each is
    # above 0.7 of it): the panel counts as light below half the upper median, 220 / 2 = 110.
    # A panel of saturation 109 is light, 110 is not.
    for panel_s, verdict in ((109, ""), (110, "panel")):
        hsv, c = scene(SQUARE)
        hsv[np.all(hsv == LIGHT, axis=2)] = (0, panel_s, 220)
        for (x, y, w, h), sat in zip((b.bbox for b in c.blobs), (200, 230, 210, 220), strict=True):
            hsv[y : y + h, x : x + w, 1] = sat
        assert check_constellation(c, hsv, 0.0) == verdict, panel_s


def test_a_panel_mostly_outside_the_picture_is_too_little_to_tell() -> None:
    # Markers 5 px on a 20 px square in the top-left corner of a 30 x 30 picture, about
    # (14, 14). With a panel 1.5 sides wide the quad is 14 -+ 10 * 1.5 * 0.95 = 14 -+ 14.25:
    # 0..28, all inside: 29 x 29 - 4 x 81 = 517 px of an expected 28^2 (1 - 4 (0.25 / 1.5)^2)
    # = 696.9: more than 0.3 of it, and light: a banner. Four sides wide, 14 -+ 38: 900 - 324
    # = 576 px of the picture against an expected 76^2 (1 - 4 (0.25 / 4)^2) = 5685.75: under
    # 0.3 of it (1705.7), too little of the panel in view to call it one. 2.5 sides wide,
    # 14 -+ 23.75: -10..38, 48^2 (1 - 4 (0.25 / 2.5)^2) = 2211.8 expected, 576 under 0.3 of it.
    corner = [(4, 4), (24, 4), (24, 24), (4, 24)]
    hsv, c = scene(corner, shape=(30, 30))
    assert check_constellation(c, hsv, 0.0, look=BannerLook(0.85, 0.25, 1.5)) == ""
    assert check_constellation(c, hsv, 0.0, look=BannerLook(0.85, 0.25, 4.0)) == "panel"
    assert check_constellation(c, hsv, 0.0, look=BannerLook(0.85, 0.25, 2.5)) == "panel"
