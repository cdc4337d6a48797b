"""Exposure compensation: hand-worked gains and the hysteresis."""

from __future__ import annotations

import numpy as np
import pytest

from lfctl.vision.exposure import Exposure, frame_level, scale_value


def _grey(level: int) -> np.ndarray:
    return np.full((48, 64, 3), level, np.uint8)


def test_the_level_is_the_mean_of_a_sparse_grid() -> None:
    frame = _grey(100)
    frame[1::4] = 0  # rows the grid skips
    assert frame_level(frame) == pytest.approx(100.0)
    frame[::4, ::4, 2] = 40  # red channel of the grid: (100 + 100 + 40) / 3
    assert frame_level(frame) == pytest.approx(80.0)
    assert frame_level(_grey(0)) == 1.0  # never 0


def test_gain_engages_past_1_6x_holds_above_1_25x_and_is_bounded() -> None:
    e = Exposure()
    e.start(_grey(100))
    steps = [(65, 1.0), (50, 2.0), (75, 100 / 75), (90, 1.0), (64, 1.0), (170, 100 / 170), (5, 10.0), (100, 1.0)]
    for level, gain in steps:  # 100/65 = 1.54: not yet; 2x: on; 1.33x: still on; 1.11x: off; ...
        assert e.update(_grey(level)) == pytest.approx(gain), level


def test_scale_value_multiplies_the_value_channel_and_saturates() -> None:
    hsv = np.array([[[10, 200, 100], [170, 30, 200]]], np.uint8)
    out = scale_value(hsv.copy(), 2.0)
    assert out.tolist() == [[[10, 200, 200], [170, 30, 255]]]
    assert scale_value(hsv.copy(), 1.0).tolist() == hsv.tolist()


def test_bad_thresholds_are_refused() -> None:
    with pytest.raises(ValueError, match="need 1 < release <= engage <= limit"):
        Exposure(engage=1.2, release=1.5)


def test_a_limit_under_the_engage_level_is_refused() -> None:
    with pytest.raises(ValueError, match=r"1\.25, 1\.6, 1\.5"):
        Exposure(engage=1.6, release=1.25, limit=1.5)


def test_the_gain_engages_past_1_6x_not_at_it() -> None:
    # 160 / 100 is 1.6 exactly: not past it
    e = Exposure()
    e.start(_grey(160))
    assert e.update(_grey(100)) == 1.0
    assert e.update(_grey(99)) == pytest.approx(160 / 99)


def test_the_gain_is_at_least_a_tenth() -> None:
    # 10 / 250 = 0.04 wanted: held at 1 / limit = 0.1
    e = Exposure()
    e.start(_grey(10))
    assert e.update(_grey(250)) == pytest.approx(0.1)


def test_a_model_learnt_afresh_while_compensating_keeps_the_gain() -> None:
    # started at 100; the light halves: gain 2. The model is learnt again on a frame at 50
    # seen at gain 2, i.e. at 100: the reference stays 100 and the next frame at 50 still
    # gets 2 (rebased on its raw 50, the gain would drop to 1 and the model's pixels halve)
    e = Exposure()
    e.start(_grey(100))
    assert e.update(_grey(50)) == pytest.approx(2.0)
    e.rebase(_grey(50))
    assert e.update(_grey(50)) == pytest.approx(2.0)
    assert e.update(_grey(100)) == pytest.approx(1.0)  # the light back: 1x


def test_scale_value_rounds_to_nearest_and_darkens_too() -> None:
    hsv = np.array([[[0, 0, 3], [0, 0, 200]]], np.uint8)
    assert scale_value(hsv.copy(), 1.25)[0, :, 2].tolist() == [4, 250]  # 3.75 -> 4
    assert scale_value(hsv.copy(), 0.5)[0, :, 2].tolist() == [2, 100]  # 1.5 -> 2 (half to even)
