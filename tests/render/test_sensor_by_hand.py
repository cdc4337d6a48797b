"""The camera sensor's effects (lfctl.render.sensor), each on a tiny frame whose output is
worked out by hand in the test (exactly, or for the noise its spread, from a fixed seed): the vignetting's fall-off, the noise's sizes, the
auto-exposure's metering and lag, the white balance and the scene's light as channel gains,
motion blur and the rolling shutter's bands. test_realism.py checks the same effects on whole
rendered frames, within tolerances; these pin the numbers."""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest

from lfctl.config import CameraConfig
from lfctl.render.sensor import Sensor

QUIET = CameraConfig(noise_sigma=0.0, shot_noise=0.0, auto_exposure=False, white_balance_drift=0.0, vignetting=0.0)
NO_LIGHT_CHANGE = np.ones(3)


def quiet(**kw) -> CameraConfig:
    return dataclasses.replace(QUIET, **kw)


def grey(value: int, h: int = 16, w: int = 16) -> np.ndarray:
    return np.full((h, w, 3), value, np.uint8)


def test_vignetting_is_one_less_v_r_squared_with_r_one_in_the_corners() -> None:
    # 17 x 17: the centre pixel (8, 8) is exactly on the axis. r^2 = (dx^2 + dy^2) / (8^2 + 8^2):
    # the centre 0, a corner 1, the middle of a side 64 / 128 = 0.5. With v = 0.5 the
    # multipliers are 1, 0.5 and 0.75 (as eighths of 128: 128, 64 and 96, exact), so 200 becomes
    # 200, 100 and 150.
    s = Sensor(quiet(width_px=17, height_px=17, vignetting=0.5), 0)
    out = s.expose(grey(200, 17, 17), 0.0, NO_LIGHT_CHANGE, 0.0, 10.0)
    assert out[8, 8].tolist() == [200, 200, 200]
    for y, x in ((0, 0), (0, 16), (16, 0), (16, 16)):
        assert out[y, x].tolist() == [100, 100, 100]
    for y, x in ((8, 0), (8, 16), (0, 8), (16, 8)):
        assert out[y, x].tolist() == [150, 150, 150]


def test_no_effect_configured_leaves_the_frame_as_it_was() -> None:
    img = np.random.default_rng(3).integers(0, 256, (16, 16, 3), np.uint8)
    out = Sensor(QUIET, 0).expose(img.copy(), 0.0, NO_LIGHT_CHANGE, 0.0, 10.0)
    assert np.array_equal(out, img)


def test_read_noise_has_the_configured_sigma_whatever_the_signal() -> None:
    # the read part adds round(N(0, sigma)): its spread is sigma and the rounding's 1/12
    # (variance), sqrt(16 + 1/12) = 4.01 for sigma 4, at a dark level as at a bright one
    s = Sensor(quiet(noise_sigma=4.0, width_px=64, height_px=64), 0)
    for level in (60, 190):
        out = s.expose(grey(level, 64, 64), 0.0, NO_LIGHT_CHANGE, 0.0, 10.0).astype(float)
        assert out.mean() == pytest.approx(level, abs=0.15)
        assert out.std() == pytest.approx(math.sqrt(16 + 1 / 12), rel=0.05)


def test_shot_noise_is_fitted_as_b_times_the_signal_over_the_sensor_range() -> None:
    # Shot noise has variance shot * I. It is applied as a multiplier (1 + b n), variance
    # (b I)^2, with b^2 the least-squares fit of shot * I by b^2 I^2 over I = 16, 32, .. 240
    # (I = 16 k, k = 1..15): b^2 = shot * sum(16^3 k^3) / sum(16^4 k^4)
    #    = shot * 14400 / (16 * 178312) = 0.0050473 shot  (sum k^3 = 120^2, sum k^4 = 178312).
    # shot 0.5: b = sqrt(0.0025237) = 0.050236; at I = 200 the spread is 200 b = 10.05 (with
    # the multiplier's 1/128 steps and the final rounding, sqrt(10.05^2 + 0.45^2 + 1/12) = 10.06).
    s = Sensor(quiet(shot_noise=0.5, width_px=64, height_px=64), 0)
    out = s.expose(grey(200, 64, 64), 0.0, NO_LIGHT_CHANGE, 0.0, 10.0).astype(float)
    assert out.mean() == pytest.approx(200, abs=0.3)
    assert out.std() == pytest.approx(10.06, rel=0.05)


def test_the_noise_is_added_after_the_gains_so_a_brighter_scene_does_not_grow_the_read_noise() -> None:
    # light 2 on 60: the signal is 120; the read noise's spread stays sqrt(9 + 1/12) = 3.01
    s = Sensor(quiet(noise_sigma=3.0, width_px=64, height_px=64), 0)
    out = s.expose(grey(60, 64, 64), 0.0, np.full(3, 2.0), 0.0, 10.0).astype(float)
    assert out.mean() == pytest.approx(120, abs=0.15)
    assert out.std() == pytest.approx(math.sqrt(9 + 1 / 12), rel=0.05)


def test_the_scenes_light_scales_each_channel_in_bgr_order() -> None:
    out = Sensor(QUIET, 0).expose(grey(100), 0.0, np.array([0.5, 1.0, 2.4]), 0.0, 10.0)
    assert out[0, 0].tolist() == [50, 100, 240]


def test_the_white_balance_gains_are_applied_to_blue_and_red_and_green_stays() -> None:
    s = Sensor(quiet(white_balance_drift=0.2), 5)
    t = 3.7
    b, g, r = s.white_balance(t)
    assert g == 1.0 and abs(b - 1) > 0.01 and abs(r - 1) > 0.01  # seed 5 drifts both at 3.7 s
    out = s.expose(grey(100), t, NO_LIGHT_CHANGE, 0.0, 10.0)
    assert out[0, 0].tolist() == [round(100 * b), 100, round(100 * r)]


def test_the_white_balance_drift_is_the_mean_of_two_sines_times_its_amount() -> None:
    # each of blue and red is 1 + d (sin(2 pi t / p1 + f1) + sin(2 pi t / p2 + f2)) / 2, so it
    # never leaves 1 +- d, and at t where both sines are at their peaks it reaches 1 + d
    s = Sensor(quiet(white_balance_drift=0.1), 0)
    gains = np.array([s.white_balance(t) for t in np.linspace(0.0, 600.0, 6001)])
    assert np.abs(gains[:, [0, 2]] - 1).max() <= 0.1 + 1e-12
    assert np.abs(gains[:, [0, 2]] - 1).max() > 0.09  # both peaks come close together in 10 min
    assert np.array_equal(Sensor(QUIET, 0).white_balance(12.0), np.ones(3))


def test_auto_exposure_starts_metered_and_then_follows_a_step_in_log_space_one_frame_late() -> None:
    # target 0.4 of full scale: 102. Frame 0 (grey 100, light 1): the meter reads 100 and the
    # camera starts metered: gain 102 / 100 = 1.02, the frame 102.
    # Frame 1 (t = 1/30, light 2): the meter reads 200 and wants 0.51, but this frame gets the
    # gain the earlier frames set: 100 * 2 * 1.02 = 204. The gain then moves towards 0.51 by
    # alpha = 1 - exp(-(1/30) / 0.5) = 0.064493 of the way in log space:
    # 1.02 * (0.51 / 1.02)^0.064493 = 1.02 * 0.956282 = 0.975408.
    # Frame 2 (t = 2/30): 100 * 2 * 0.975408 = 195.08 -> 195.
    s = Sensor(quiet(auto_exposure=True, exposure_target=0.4, exposure_lag_s=0.5), 0)
    light = [1.0, 2.0, 2.0]
    out = [int(s.expose(grey(100), k / 30, np.full(3, light[k]), 0.0, 10.0)[0, 0, 1]) for k in range(3)]
    assert out == [102, 204, 195]
    # and after frame 2: 0.975408 * (0.51 / 0.975408)^0.064493 = 0.975408 * 0.959041 = 0.935457
    assert s.gain == pytest.approx(0.935457, abs=2e-6)


def test_auto_exposure_with_no_lag_takes_the_wanted_gain_on_the_next_frame() -> None:
    # lag 0: alpha 1, the gain is the wanted one at once, still one frame late
    s = Sensor(quiet(auto_exposure=True, exposure_target=0.4, exposure_lag_s=0.0), 0)
    light = [1.0, 2.0, 2.0]
    out = [int(s.expose(grey(100), k / 30, np.full(3, light[k]), 0.0, 10.0)[0, 0, 1]) for k in range(3)]
    assert out == [102, 204, 102]


def test_auto_exposure_gain_is_held_between_a_quarter_and_four() -> None:
    # grey 10 wants 102 / 10 = 10.2: held at 4 (40); grey 250 with target 0.02 wants
    # 5.1 / 250 = 0.0204: held at 0.25 (62.5 -> 62, OpenCV rounds half to even)
    dark = Sensor(quiet(auto_exposure=True, exposure_target=0.4), 0)
    assert dark.expose(grey(10), 0.0, NO_LIGHT_CHANGE, 0.0, 10.0)[0, 0].tolist() == [40, 40, 40]
    bright = Sensor(quiet(auto_exposure=True, exposure_target=0.02), 0)
    assert bright.expose(grey(250), 0.0, NO_LIGHT_CHANGE, 0.0, 10.0)[0, 0].tolist() == [62, 62, 62]


def test_auto_exposure_meters_the_light_it_is_given_not_only_the_picture() -> None:
    # the meter reads the picture (100) times the light's mean (0.5): 50, wanting 102 / 50 = 2.04;
    # the first frame gets it: 100 * 0.5 * 2.04 = 102
    s = Sensor(quiet(auto_exposure=True, exposure_target=0.4), 0)
    assert s.expose(grey(100), 0.0, np.full(3, 0.5), 0.0, 10.0)[0, 0].tolist() == [102, 102, 102]


def test_a_black_frame_leaves_the_gain_alone() -> None:
    # nothing to meter (level at most 1): the gain stays at its nominal 1
    s = Sensor(quiet(auto_exposure=True, exposure_target=0.4), 0)
    out = s.expose(grey(1), 0.0, NO_LIGHT_CHANGE, 0.0, 10.0)
    assert out[0, 0].tolist() == [1, 1, 1] and s.gain == 1.0


def blurred_column(yaw_rate: float, fx: float) -> np.ndarray:
    img = np.zeros((4, 100, 3), np.uint8)
    img[:, 40] = 248
    s = Sensor(quiet(width_px=100, height_px=16, motion_blur=True), 0)
    return s.expose(img, 0.0, NO_LIGHT_CHANGE, yaw_rate, fx)[1, :, 0]


def test_motion_blur_smears_a_row_over_the_pixels_turned_through_in_a_sixtieth_of_a_second() -> None:
    # 1 rad/s at fx 496 px: 496 / 60 = 8.27 -> a box of 8 px along the rows. OpenCV's box with
    # an even width is anchored at its middle (4): output x averages inputs x - 4 .. x + 3, so
    # the column at 40 lands on 37..44, 248 / 8 = 31 each
    row = blurred_column(1.0, 496.0)
    assert np.flatnonzero(row).tolist() == list(range(37, 45))
    assert set(row[37:45].tolist()) == {31}
    # turning the other way smears the same
    assert np.array_equal(blurred_column(-1.0, 496.0), row)


def test_motion_blur_is_at_most_31_px_and_none_under_2() -> None:
    # 10 rad/s at 496 px: 82 px, held at 31 (anchor 15: inputs x - 15 .. x + 15): 25..55, 248 / 31 = 8
    row = blurred_column(10.0, 496.0)
    assert np.flatnonzero(row).tolist() == list(range(25, 56)) and set(row[25:56].tolist()) == {8}
    # 0.2 rad/s: 1.65 px, int 1: no blur
    row = blurred_column(0.2, 496.0)
    assert np.flatnonzero(row).tolist() == [40] and row[40] == 248


def test_rolling_shutter_shifts_each_band_of_eight_rows_by_its_share_of_the_turn() -> None:
    # yaw 1 rad/s, 20 ms readout, fx 400 px: the scene moves 8 px from the top row to the
    # bottom. 16 rows, two bands: rows 0-7 are read at (4 / 16 - 1/2) = -1/4 of that, so they
    # see the scene 2 px to the right; rows 8-15 at +1/4, 2 px to the left. The edge column
    # fills what the shift uncovers.
    img = np.zeros((16, 32, 3), np.uint8)
    img[:, 10] = 255
    img[:, 0] = 7
    img[:, 31] = 9
    s = Sensor(quiet(width_px=32, height_px=16, rolling_shutter_s=0.02), 0)
    out = s.expose(img, 0.0, NO_LIGHT_CHANGE, 1.0, 400.0)[..., 0]
    for y in range(8):
        assert np.flatnonzero(out[y] == 255).tolist() == [12]
        assert out[y, :3].tolist() == [7, 7, 7]
    for y in range(8, 16):
        assert np.flatnonzero(out[y] == 255).tolist() == [8]
        assert out[y, -3:].tolist() == [9, 9, 9]


def test_jpeg_gives_the_frame_a_jpeg_of_that_quality_decodes_to() -> None:
    img = cv2.GaussianBlur(np.random.default_rng(1).integers(0, 256, (32, 32, 3), np.uint8), (0, 0), 1.5)
    out = Sensor(quiet(width_px=32, height_px=32, jpeg_quality=30), 0).expose(
        img.copy(), 0.0, NO_LIGHT_CHANGE, 0.0, 10.0
    )
    ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 30])
    assert ok and np.array_equal(out, cv2.imdecode(buf, cv2.IMREAD_COLOR))
    assert not np.array_equal(out, img)
