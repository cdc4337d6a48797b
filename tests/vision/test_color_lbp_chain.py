"""Colour (eq. 1-2), LBP codes and Freeman chain codes with hand-worked numbers."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from lfctl.vision.chaincode import blobs, chain_code, chain_perimeter
from lfctl.vision.color import hsv_of_rgb, hue_window_mask, to_hsv
from lfctl.vision.lbp import N_CODES, RI_CODES, RI_LUT, lbp_ri36, lbp_ri36_reference


@pytest.mark.parametrize(
    ("rgb", "hue"),
    [
        ((1, 0, 0), 0),
        ((1, 1, 0), 60),
        ((0, 1, 0), 120),
        ((0, 1, 1), 180),
        ((0, 0, 1), 240),
        ((1, 0, 1), 300),
        ((1, 0.5, 0), 30),
    ],
)
def test_eq1_hue_of_pure_colours(rgb: tuple[float, float, float], hue: float) -> None:
    h, s, v = hsv_of_rgb(*rgb)
    assert h == pytest.approx(hue) and s == pytest.approx(1.0) and v == pytest.approx(1.0)


def test_eq2_saturation_and_grey() -> None:
    assert hsv_of_rgb(0.5, 0.5, 0.5) == (0.0, 0.0, 0.5)  # grey: hue 0 by convention, s = 0
    assert hsv_of_rgb(0.0, 0.0, 0.0)[1] == 0.0  # max = 0
    assert hsv_of_rgb(1.0, 0.5, 0.5)[1] == pytest.approx(0.5)  # 1 - min / max


def test_opencv_hue_is_half_degrees() -> None:
    bgr = np.array([[[0, 255, 0], [255, 0, 0], [0, 255, 255]]], np.uint8)  # green, blue, yellow
    assert to_hsv(bgr)[0, :, 0].tolist() == [60, 120, 30]


def test_hue_window_wraps_around_red() -> None:
    hsv = np.array([[[2, 200, 200], [178, 200, 200], [60, 200, 200], [2, 20, 200]]], np.uint8)
    assert hue_window_mask(hsv, 0.0, 18.0, 90, 50)[0].tolist() == [255, 255, 0, 0]  # unsaturated: out


def test_exactly_36_rotation_invariant_codes() -> None:
    assert N_CODES == 36 and len(set(RI_LUT.tolist())) == 36 and RI_CODES[0] == 0 and RI_CODES[-1] == 255


def test_lbp_of_known_patches() -> None:
    flat = np.full((3, 3), 100, np.uint8)
    assert lbp_ri36(flat, 0)[1, 1] == 35  # all neighbours >= centre: 0xFF, the last code
    assert lbp_ri36(flat, 1)[1, 1] == 0  # with a noise threshold a flat patch is "nothing brighter"
    one = flat.copy()
    one[0, 1] = 200  # one brighter neighbour (north), threshold 1
    assert lbp_ri36(one, 1)[1, 1] == int(np.searchsorted(RI_CODES, 1))  # pattern 00000001
    edge = np.array([[200, 200, 200], [100, 100, 100], [0, 0, 0]], np.uint8)
    code = lbp_ri36(edge, 1)[1, 1]
    assert RI_CODES[code] == 0b00000111  # three consecutive brighter neighbours, rotated to the minimum


def test_lbp_is_rotation_invariant() -> None:
    patch = np.array([[10, 200, 30], [40, 100, 150], [170, 80, 120]], np.uint8)
    codes = {int(lbp_ri36(np.rot90(patch, k).copy(), 2)[1, 1]) for k in range(4)}
    assert len(codes) == 1


@settings(max_examples=40, deadline=None)
@given(arrays(np.uint8, (12, 15), elements=st.integers(0, 200)), st.integers(0, 55), st.integers(0, 5))
def test_lbp_matches_the_numpy_oracle_and_ignores_a_constant(img: np.ndarray, c: int, thr: int) -> None:
    codes = lbp_ri36(img, thr)
    assert np.array_equal(codes, lbp_ri36_reference(img, thr))
    assert np.array_equal(codes, lbp_ri36((img + c).astype(np.uint8), thr))  # no overflow below 255


@settings(max_examples=60, deadline=None)
@given(arrays(np.uint8, (9, 11), elements=st.integers(0, 255)), st.integers(-260, 261))
def test_lbp_matches_the_numpy_oracle_over_the_whole_range(img: np.ndarray, thr: int) -> None:
    # the 8-bit path saturates its differences: a threshold at or past +-255 still counts right
    assert np.array_equal(lbp_ri36(img, thr), lbp_ri36_reference(img, thr))


@settings(max_examples=60, deadline=None)
@given(arrays(np.uint8, (16, 20), elements=st.sampled_from([0, 255])))
def test_blobs_chain_codes_are_each_contours_own(mask: np.ndarray) -> None:
    # blobs() codes every contour in one pass; each must be chain_code of that contour alone
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    want = {(int(c[0, 0, 0]), int(c[0, 0, 1])): chain_code(c) if len(c) > 1 else [] for c in contours}
    found = blobs(mask, min_area_px=0.0)
    assert sorted(b.start for b in found) == sorted(want)  # every contour, once
    for b in found:
        assert list(b.codes) == want[b.start]
        assert b.perimeter_px == pytest.approx(chain_perimeter(list(b.codes)) + 4.0)


def test_chain_codes_of_a_known_square() -> None:
    # border pixels of a 3x3 square, clockwise on screen from its top-left pixel
    contour = np.array([[1, 1], [2, 1], [3, 1], [3, 2], [3, 3], [2, 3], [1, 3], [1, 2]])
    assert chain_code(contour) == [0, 0, 6, 6, 4, 4, 2, 2]
    assert chain_perimeter([0, 1, 2]) == pytest.approx(2 + np.sqrt(2))


def test_chain_code_rejects_a_broken_contour() -> None:
    with pytest.raises(ValueError, match=r"not 8-connected: step \(2, 0\)"):
        chain_code(np.array([[0, 0], [2, 0], [2, 1]]))


def test_blob_measures_of_a_square_and_a_bar() -> None:
    mask = np.zeros((40, 60), np.uint8)
    cv2.rectangle(mask, (5, 5), (14, 14), 255, -1)  # 10 x 10 square
    cv2.rectangle(mask, (30, 10), (57, 12), 255, -1)  # 28 x 3 bar
    found = sorted(blobs(mask), key=lambda b: b.bbox[0])
    square, bar = found
    assert square.area_px == pytest.approx(100, abs=2) and square.centroid == pytest.approx((9.5, 9.5))
    assert square.bbox == (5, 5, 10, 10) and square.is_square()
    assert sorted(set(square.codes)) == [0, 2, 4, 6]  # an axis-aligned square has no diagonal steps
    assert not bar.is_square()
