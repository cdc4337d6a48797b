"""The grey-level pattern gate a hidden target may come back on, worked by hand: the pattern's
numbers, its blindness to the camera's gain and offset, and the gate's learnt threshold."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lfctl.vision.appearance import GRID, SCALES, AppearanceGate, pattern


def _halves(left: int, right: int, size: int = 32) -> np.ndarray:
    img = np.full((size, size), left, np.uint8)
    img[:, size // 2 :] = right
    return img


def test_the_pattern_is_the_cells_less_their_mean_over_their_norm() -> None:
    p = pattern(_halves(0, 100), (0, 0, 32, 32))
    assert p is not None and p.shape == (GRID[1], GRID[0])
    # 256 cells at -50 or +50 around the mean 50: norm 50 x 16 = 800, so each cell is -+1/16
    assert p[:, : GRID[0] // 2] == pytest.approx(-1 / 16)
    assert p[:, GRID[0] // 2 :] == pytest.approx(1 / 16)
    assert float(np.linalg.norm(p)) == pytest.approx(1.0)


def test_no_pattern_for_a_flat_window_or_one_mostly_outside_the_picture() -> None:
    flat = np.full((40, 40), 120, np.uint8)
    flat[0, 0] = 121  # rms far under one grey level
    assert pattern(flat, (0, 0, 40, 40)) is None
    img = np.tile((np.arange(40) * 5).astype(np.uint8), (40, 1))  # a ramp: a pattern everywhere
    assert pattern(img, (26, 0, 30, 30)) is None  # 14 of its 30 columns inside: under half
    assert pattern(img, (25, 0, 30, 30)) is not None  # 15 of 30: half


@settings(max_examples=40, deadline=None)
@given(gain=st.floats(0.5, 1.5), offset=st.integers(0, 60), seed=st.integers(0, 2**16))
def test_a_window_scores_the_same_under_any_gain_and_offset(gain: float, offset: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    scene = rng.integers(20, 120, (48, 48)).astype(np.uint8)
    gate = AppearanceGate(scene, (16, 16, 16, 16))
    brighter = np.clip(scene.astype(np.float64) * gain + offset, 0, 255).astype(np.uint8)  # max 240: no clipping
    score = gate.score(brighter, (16, 16, 16, 16))
    assert score is not None
    # the same pattern, but for uint8's rounding of the scaled levels
    assert score == pytest.approx(1.0, abs=0.01)


def _brute_force_impostor(gate: AppearanceGate, grey: np.ndarray, box: tuple[int, int, int, int]) -> float:
    """The best score of a window at each of SCALES times the box's size, at every place
    (1 px steps) within SURROUNDINGS of it, not overlapping it, scored one by one."""
    x, y, w, h = box
    cx, cy = x + w / 2, y + h / 2
    x0, x1 = max(0, round(cx - 2.5 * w)), min(grey.shape[1], round(cx + 2.5 * w))
    y0, y1 = max(0, round(cy - 2.5 * h)), min(grey.shape[0], round(cy + 2.5 * h))
    best = -1.0
    for k in SCALES:
        kw, kh = round(k * w), round(k * h)
        for wy in range(y0, y1 - kh + 1):
            for wx in range(x0, x1 - kw + 1):
                if wx + kw > x and wx < x + w and wy + kh > y and wy < y + h:
                    continue  # overlaps the target
                v = gate.score(grey, (wx, wy, kw, kh))
                if v is not None:
                    best = max(best, v)
    return best


def test_the_background_is_the_best_impostor_not_overlapping_the_target() -> None:
    rng = np.random.default_rng(3)
    scene = rng.integers(95, 105, (150, 150)).astype(np.uint8)  # faint texture: no pattern of note
    scene[60:90, 60:90] = _halves(20, 220, 30)  # the target: dark left, light right
    impostor = np.full((30, 30), 220, np.uint8)
    impostor[:, :10] = 20  # dark on its left third only: like the target, less
    scene[0:30, 120:150] = impostor  # two windows off, within the 5-window surroundings
    gate = AppearanceGate(scene, (60, 60, 30, 30))
    best = _brute_force_impostor(gate, scene, (60, 60, 30, 30))
    assert gate.background == pytest.approx(best, abs=0.03)  # matchTemplate on the area resampled once a size
    assert best >= gate.score(scene, (120, 0, 30, 30)) > 0.5  # the impostor, or a window on its edge
    # windows overlapping it are partly the target itself, not impostors: without the impostor
    # its surroundings are faint texture, though a window half a size lower scores 0.7
    scene[0:30, 120:150] = rng.integers(95, 105, (30, 30))
    alone = AppearanceGate(scene, (60, 60, 30, 30))
    assert alone.score(scene, (60, 75, 30, 30)) > 0.6 > 0.3 > alone.background


def test_the_impostors_of_a_wide_target_by_a_corner_beside_it_on_one_axis() -> None:
    """A target wider than tall near the picture's top-left corner (the area is clipped there),
    an impostor beside it along x only (its rows overlap the target's), and a better one just
    beyond the surroundings (which must not count)."""
    rng = np.random.default_rng(5)
    scene = rng.integers(95, 105, (120, 200)).astype(np.uint8)
    target = np.full((12, 24), 200, np.uint8)
    target[:, :8] = 30
    target[:4, 16:] = 90
    scene[10:22, 8:32] = target  # x 8-31, y 10-21: the surroundings reach x < 80, y < 46
    near = target.copy()
    near[:, 8:16] = 120  # like it, less
    scene[10:22, 40:64] = near  # beside it in x, the same rows
    scene[60:72, 100:124] = target  # an exact copy beyond the surroundings
    gate = AppearanceGate(scene, (8, 10, 24, 12))
    best = _brute_force_impostor(gate, scene, (8, 10, 24, 12))
    assert gate.background == pytest.approx(best, abs=0.05)
    assert 0.5 < gate.background < 0.9  # the near impostor counts, the copy beyond does not


def test_on_a_plain_wall_no_window_is_an_impostor() -> None:
    """Windows under one grey level of rms have no pattern (a wall in steps of one level):
    they never pass, so they are no impostors, though OpenCV's correlation scores them."""
    scene = (100 + np.arange(150)[None, :] // 40 + np.zeros((150, 1))).astype(np.uint8)
    scene[60:90, 60:90] = _halves(20, 220, 30)
    gate = AppearanceGate(scene, (60, 60, 30, 30))
    assert _brute_force_impostor(gate, scene, (60, 60, 30, 30)) == -1.0  # none has a pattern
    assert gate.background == 0.0


def test_no_impostor_room_means_nothing_passes() -> None:
    scene = _halves(20, 220, 30)
    gate = AppearanceGate(scene, (0, 0, 30, 30), learn_frames=1)
    assert gate.background == 1.0
    gate.observe(1.0)
    assert not gate.passes(1.0)


def test_the_gate_sits_half_way_between_the_typical_score_and_the_best_impostor() -> None:
    rng = np.random.default_rng(4)
    scene = cv2.GaussianBlur(rng.integers(0, 255, (150, 150)).astype(np.uint8), (0, 0), 4)
    gate = AppearanceGate(scene, (60, 60, 30, 30), learn_frames=3)
    assert gate.threshold is None and not gate.passes(0.99)  # nothing passes while learning
    for s in (0.9, 0.7, 0.95):
        gate.observe(s)
    assert gate.typical == pytest.approx(0.9)  # the median
    assert gate.threshold == pytest.approx(0.5 * (0.9 + gate.background))
    assert gate.passes(gate.threshold + 1e-6) and not gate.passes(gate.threshold)
    assert not gate.passes(None)
    gate.observe(0.1)  # learnt once
    assert gate.typical == pytest.approx(0.9)


def test_a_hidden_target_is_scored_at_the_best_of_its_sizes() -> None:
    scene = np.full((200, 200), 100, np.uint8)
    scene[79:121, 79:121] = 30  # the target, 42 px: a dark frame 6 px wide...
    scene[85:115, 85:115] = 220  # ...round a light middle
    gate = AppearanceGate(scene, (79, 79, 42, 42))
    predicted = (85, 85, 30, 30)  # on its centre, at 1 / 1.41 of its size: the light middle only
    assert gate.score(scene, predicted) is None  # flat: no pattern
    assert gate.best_score(scene, predicted) == pytest.approx(1.0)  # at 1.41 x 30 = 42 px
    assert pytest.approx([2 ** (-0.5), 2 ** (-0.25), 1.0, 2**0.25, 2**0.5]) == SCALES


def test_a_target_no_more_distinct_than_its_surroundings_never_passes() -> None:
    scene = np.tile(_halves(20, 220, 30), (5, 5))  # its neighbours are copies of it
    gate = AppearanceGate(scene, (60, 60, 30, 30), learn_frames=1)
    assert gate.background == pytest.approx(1.0)
    gate.observe(0.95)
    assert not gate.passes(0.99)  # typical <= background: the pattern tells nothing here


def test_a_flat_target_has_no_pattern_and_never_passes() -> None:
    scene = np.full((90, 90), 100, np.uint8)
    gate = AppearanceGate(scene, (30, 30, 30, 30), learn_frames=1)
    assert gate.template is None and gate.score(scene, (30, 30, 30, 30)) is None
    gate.observe(None)
    assert gate.typical is None and not gate.passes(0.9)


def _rod_picture(angle_deg: float) -> np.ndarray:
    """A 60 x 16 px rod, light at one end, dark at the other, on mid grey, centred at (60, 60) of a
    120 x 120 picture turned by ``angle_deg`` (OpenCV's sense) about that centre."""
    img = np.full((120, 120, 3), 128, np.uint8)
    img[52:68, 30:90] = np.linspace(40, 230, 60, dtype=np.uint8)[None, :, None]
    m = cv2.getRotationMatrix2D((60.0, 60.0), angle_deg, 1.0)
    return cv2.warpAffine(img, m, (120, 120), flags=cv2.INTER_LINEAR, borderValue=(128, 128, 128))


def test_a_window_turned_back_by_the_targets_turn_scores_as_it_did_at_the_start() -> None:
    gate = AppearanceGate(cv2.cvtColor(_rod_picture(0.0), cv2.COLOR_BGR2GRAY), (30, 52, 60, 16))
    turned = _rod_picture(-40.0)  # turned 40 degrees clockwise
    at_start, back, wrong_way = gate.turned_scores(turned, (60.0, 60.0), (60.0, 16.0), (0.0, 40.0, -40.0))
    assert back is not None and back > 0.95  # turned back, the rod is where it was
    assert at_start is not None and wrong_way is not None
    assert back > at_start + 0.2 and back > wrong_way + 0.2
    # unturned, the window scores as score() does on the same box
    same = gate.turned_scores(_rod_picture(0.0), (60.0, 60.0), (60.0, 16.0), (0.0,))[0]
    assert same == pytest.approx(1.0, abs=1e-6)


def test_no_turned_score_for_an_angle_whose_window_leaves_the_picture() -> None:
    noise = np.random.default_rng(3).integers(0, 255, (120, 120, 3)).astype(np.uint8)
    gate = AppearanceGate(cv2.cvtColor(noise, cv2.COLOR_BGR2GRAY), (30, 52, 60, 16))
    # a 60 x 16 window on (60, 10): upright it spans rows 2-18; turned 30 degrees its corners
    # reach 30 sin 30 + 8 cos 30 = 21.9 px above and below its centre, off the top
    upright, turned = gate.turned_scores(noise, (60.0, 10.0), (60.0, 16.0), (0.0, 30.0))
    assert upright is not None and turned is None
    assert None not in gate.turned_scores(noise, (60.0, 60.0), (60.0, 16.0), (0.0, 30.0))
