"""The appearance gate's edges, from its definitions: a turned window is the window of the
picture turned back about its centre; a window touching the image's edge is scored, one
reaching past it is not; no template, or no pattern anywhere, is no score; a target whose
pattern does not stand out from its surroundings (typical <= background) never passes."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from lfctl.vision.appearance import AppearanceGate, pattern


def textured(h: int, w: int, seed: int = 1) -> np.ndarray:
    """A grey image with a pattern at every scale a few pixels up (no flat window)."""
    rng = np.random.default_rng(seed)
    return cv2.GaussianBlur(rng.integers(0, 256, (h, w)).astype(np.uint8), (3, 3), 0)


def bgr(grey: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)  # its BGR2GRAY is the grey image again


def test_no_template_means_no_score_for_any_angle() -> None:
    # Wrong, a target started on a flat patch (no pattern) would crash the re-entry check.
    flat = np.full((40, 40), 128, np.uint8)
    gate = AppearanceGate(flat, (10, 10, 12, 12))
    assert gate.template is None
    assert gate.turned_scores(bgr(flat), (20.0, 20.0), (12.0, 12.0), (0.0, 30.0)) == [None, None]


def test_best_score_is_none_when_no_size_has_a_pattern() -> None:
    # Wrong, a flat frame (a lens cap, a white wall) would crash best_score (max of nothing).
    grey = textured(60, 60)
    gate = AppearanceGate(grey, (20, 20, 12, 12))
    assert gate.best_score(np.full((60, 60), 90, np.uint8), (20, 20, 12, 12)) is None


def test_a_target_no_more_like_itself_than_its_surroundings_never_passes() -> None:
    # The docstring: never for a target whose pattern does not stand out (typical <= background).
    # By hand: background 0.5 and typical 0.5 (one frame learnt): threshold 0.5; a score of
    # 0.9 is above it, but the target does not stand out: refused.
    gate = AppearanceGate(textured(60, 60), (20, 20, 12, 12), learn_frames=1)
    gate.background = 0.5
    gate.observe(0.5)
    assert gate.threshold == 0.5
    assert not gate.passes(0.9)


@pytest.mark.parametrize("angle", [30.0, -50.0, 90.0])
def test_a_turned_window_is_scored_as_the_picture_turned_back_about_its_centre(angle: float) -> None:
    # The definition (turned_scores): "the picture turned by the angle about the centre puts
    # the target back as it was at the start". Turning the whole picture by `angle` about
    # (40, 40) with cv2.getRotationMatrix2D and cutting the upright 20 x 12 window on that
    # centre, (30, 34, 20, 12), gives the pixels turned_scores must score (to OpenCV's
    # 1/32 px interpolation grid).
    grey = textured(80, 80)
    gate = AppearanceGate(grey, (30, 34, 20, 12))
    turned_back = cv2.warpAffine(
        grey, cv2.getRotationMatrix2D((40.0, 40.0), angle, 1.0), (80, 80), flags=cv2.INTER_LINEAR
    )
    expected = gate.score(turned_back, (30, 34, 20, 12))
    assert expected is not None
    (got,) = gate.turned_scores(bgr(grey), (40.0, 40.0), (20.0, 12.0), (angle,))
    assert got == pytest.approx(expected, abs=0.02)


@pytest.mark.parametrize(
    ("centre", "box"),
    [
        ((4.0, 3.0), (0, 0, 8, 6)),  # touching the left and top edges
        ((36.0, 57.0), (32, 54, 8, 6)),  # touching the right and bottom edges (of a tall frame)
    ],
)
def test_an_upright_window_touching_the_edge_is_scored_as_the_window_itself(
    centre: tuple[float, float], box: tuple[int, int, int, int]
) -> None:
    # Wrong, a window on the image's edge would be refused, or scored on a border copied from
    # the column or row beside the edge.
    # By hand: angle 0: the corners reach (0, 0)..(8, 6) (first) and (32, 54)..(40, 60) =
    # (W, H) (second): inside; the window's pixels are the image's: its score is score(box).
    grey = textured(60, 40)
    gate = AppearanceGate(grey, (16, 27, 8, 6))
    expected = gate.score(grey, box)
    assert expected is not None
    (got,) = gate.turned_scores(bgr(grey), centre, (8.0, 6.0), (0.0,))
    assert got == pytest.approx(expected, abs=1e-5)


def test_a_window_past_the_right_edge_has_no_score_and_the_next_angle_still_gets_one() -> None:
    # Wrong, a window reaching off the image would be scored on a border made up by
    # replication, or the angles after it dropped.
    # By hand: frame 40 x 60 (H x W), centre (56, 20), 10 x 4: at 0 deg its corners reach x =
    # 51..61 > 60: None; at 90 deg it stands 4 wide, 10 high: x 54..58, y 15..25: scored.
    grey = textured(40, 60)
    gate = AppearanceGate(grey, (20, 15, 10, 4))
    scores = gate.turned_scores(bgr(grey), (56.0, 20.0), (10.0, 4.0), (0.0, 90.0))
    assert len(scores) == 2
    assert scores[0] is None
    assert scores[1] is not None


def test_a_window_past_the_bottom_edge_of_a_wide_frame_has_no_score() -> None:
    # By hand: frame 40 x 60 (H x W), centre (30, 38), 6 x 6 at 0 deg: y 35..41 > 40 (though
    # < 60, the width): None.
    grey = textured(40, 60)
    gate = AppearanceGate(grey, (20, 15, 6, 6))
    assert gate.turned_scores(bgr(grey), (30.0, 38.0), (6.0, 6.0), (0.0,)) == [None]


@pytest.mark.parametrize("centre", [(44.0, 20.0), (70.0, 20.0), (20.0, 44.0), (20.0, 70.0)])
def test_a_window_centred_off_the_image_has_no_score(centre: tuple[float, float]) -> None:
    # Wrong, a crop of no pixels would be handed to cvtColor (an OpenCV error).
    # By hand: 4 x 4: r = ceil(hypot(4, 4) / 2) + 1 = ceil(2.83) + 1 = 4; a 40 x 40 frame:
    # centre x 44 = W + r: x0 = 40, x1 = min(40, 48) = 40: no pixels (and so for y).
    grey = textured(40, 40)
    gate = AppearanceGate(grey, (10, 10, 4, 4))
    assert gate.turned_scores(bgr(grey), centre, (4.0, 4.0), (0.0, 45.0)) == [None, None]


def test_a_two_pixel_window_is_scored_at_two_pixels() -> None:
    # Wrong (a window floored at 3 px), the smallest targets would be scored on a window
    # wider than their own.
    # By hand: the template is the 2 x 2 window at (20, 20) itself: the window of 2 x 2 on its
    # centre (21, 21), upright, is those same pixels: correlation 1. best_score tries
    # max(2, round(2 k)) for k = 2^(-1/2)..2^(1/2): 2, 2, 2, 2, 3 px; the 2 x 2 one is the
    # template's window: its best is 1.
    grey = textured(60, 60)
    gate = AppearanceGate(grey, (20, 20, 2, 2))
    assert gate.turned_scores(bgr(grey), (21.0, 21.0), (2.0, 2.0), (0.0,)) == [pytest.approx(1.0, abs=1e-6)]
    assert gate.best_score(grey, (20, 20, 2, 2)) == pytest.approx(1.0, abs=1e-6)


def test_the_best_impostor_is_looked_for_all_round_the_target() -> None:
    # Wrong (the surroundings centred off the target), a look-alike on one side would be
    # missed and the gate let impostors back.
    # By hand: a flat frame (100 x 160, grey 100) with the target's 16 x 16 pattern at
    # (64, 42) and a copy of it at (32, 42). Surroundings: 5x the box on its centre (72, 50):
    # (32, 10, 80, 80). At scale 1 the area is resampled 16 / 16 = 1:1, so the copy's window
    # (32, 42) is the template itself: score 1; every other window clear of the box is
    # (partly) flat or a shifted part of a copy: the best is 1.
    grey = np.full((100, 160), 100, np.uint8)
    patch = textured(16, 16, seed=3)
    grey[42:58, 64:80] = patch
    grey[42:58, 32:48] = patch
    gate = AppearanceGate(grey, (64, 42, 16, 16))
    assert gate.background == pytest.approx(1.0, abs=1e-4)


def _flat_with(patch: np.ndarray, places: list[tuple[int, int]], shape: tuple[int, int] = (120, 160)) -> np.ndarray:
    grey = np.full(shape, 100, np.uint8)
    for x, y in places:
        grey[y : y + 16, x : x + 16] = patch
    return grey


def test_a_target_alone_on_a_plain_ground_has_no_impostor() -> None:
    # The docstring: 0 when every window clear of the target is flat. Wrong (the target's
    # own place in the search area misplaced), the target would be its own best impostor (1).
    # By hand: the 16 x 16 pattern at (64, 42) on grey 100; every window clear of it is flat.
    grey = _flat_with(textured(16, 16, seed=3), [(64, 42)])
    assert AppearanceGate(grey, (64, 42, 16, 16)).background == 0.0


def test_a_look_alike_below_the_target_is_an_impostor() -> None:
    # By hand: target at (64, 42), a copy at (64, 74) (two heights below, same columns):
    # surroundings (32, 10, 80, 80) hold it, at a whole number of cells (64 rows) from the
    # area's top at scale 1: score 1.
    patch = textured(16, 16, seed=3)
    grey = _flat_with(patch, [(64, 42), (64, 74)])
    assert AppearanceGate(grey, (64, 42, 16, 16)).background == pytest.approx(1.0, abs=1e-4)


@pytest.mark.parametrize("copy", [(112, 42), (64, 90)])
def test_a_look_alike_just_outside_the_surroundings_is_no_impostor(copy: tuple[int, int]) -> None:
    # By hand: surroundings 5x the 16 x 16 box on its centre (72, 50): x 32..111, y 10..89.
    # A copy at x = 112 (right) or y = 90 (below) lies just outside them: 0 (all else flat).
    patch = textured(16, 16, seed=3)
    grey = _flat_with(patch, [(64, 42), copy])
    assert AppearanceGate(grey, (64, 42, 16, 16)).background == 0.0


def test_a_box_needs_half_its_area_inside_the_image_for_a_pattern() -> None:
    # By hand: a 40-wide image; box (36, 10, 8, 2): 4 x 2 = 8 px inside = half of 16: a
    # pattern; box (37, 10, 8, 2): 3 x 2 = 6 < 8: none.
    grey = textured(40, 40)
    assert pattern(grey, (36, 10, 8, 2)) is not None
    assert pattern(grey, (37, 10, 8, 2)) is None


def test_a_pattern_of_rms_exactly_one_grey_level_is_a_pattern() -> None:
    # By hand: a 16 x 16 checkerboard of 100 and 102 (the grid itself: no resampling): mean
    # 101, cells +-1, norm sqrt(256) = 16 = sqrt(cells): not under it: a pattern, cells / 16.
    grey = np.where((np.indices((16, 16)).sum(axis=0) % 2) == 0, 100, 102).astype(np.uint8)
    p = pattern(grey, (0, 0, 16, 16))
    assert p is not None
    assert np.abs(p).tolist() == np.full((16, 16), 1.0 / 16.0).tolist()


def test_a_pattern_averages_each_cell_of_the_box() -> None:
    # By hand: a 48 x 48 box: 3 x 3 pixels a cell (INTER_AREA: their mean). Cells alternate
    # "one pixel of 255 in the middle, 0 round it" (mean 255 / 9 = 28.33) and "all 28"
    # (mean 28): cells 28.33 and 28, rms 0.17 < 1: flat, no pattern (a resampling that
    # took each cell's middle pixel would see 255 against 28).
    grey = np.full((48, 48), 28, np.uint8)
    for i in range(16):
        for j in range(16):
            if (i + j) % 2 == 0:
                grey[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] = 0
                grey[3 * i + 1, 3 * j + 1] = 255
    assert pattern(grey, (0, 0, 48, 48)) is None


def test_the_pattern_gate_learns_from_five_frames_by_default() -> None:
    gate = AppearanceGate(textured(60, 60), (20, 20, 12, 12))
    for s in (0.9, 0.8, 0.7, 0.6):
        gate.observe(s)
    assert gate.typical is None
    gate.observe(0.5)
    assert gate.typical == pytest.approx(0.7)  # median(0.9, 0.8, 0.7, 0.6, 0.5)


def test_a_target_without_a_pattern_has_background_one() -> None:
    # The docstring of _best_impostor: 1 (nothing passes) when there is nothing to compare.
    gate = AppearanceGate(np.full((40, 40), 128, np.uint8), (10, 10, 12, 12))
    assert gate.background == 1.0
