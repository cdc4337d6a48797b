"""The realistic renderer (scene.realism = "on"): each effect measured on frames, so a test
fails when its effect is missing or wrong; everything deterministic for a seed."""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest

from lfctl.config import BannerConfig, CameraConfig, PropConfig, SceneConfig
from lfctl.render.footage import close_loop, make_periodic
from lfctl.render.renderer import Renderer, VehiclePose
from lfctl.render.sensor import Sensor

QUIET = CameraConfig(noise_sigma=0.0, shot_noise=0.0, auto_exposure=False, white_balance_drift=0.0, vignetting=0.0)
SCENE = SceneConfig(realism="on", textures="procedural")
ME = VehiclePose(0.0, 0.0, 0.0, banner=False)


def frame(camera: CameraConfig = QUIET, scene: SceneConfig = SCENE, leader: VehiclePose | None = None, **kw):
    r = Renderer(camera, kw.pop("banner", BannerConfig()), scene, kw.pop("seed", 0))
    img, truth = r.render(kw.pop("t_s", 0.0), ME, [leader or VehiclePose(1.5, 0.0, 0.0)], 0, "f", **kw)
    return img, truth, r


def project(r: Renderer, p: np.ndarray) -> tuple[int, int]:
    R, c = r.cam.pose(ME.north_m, ME.east_m, ME.yaw_rad)
    uv = r.cam.K @ (R @ (np.asarray(p, float) - c))
    return int(round(uv[0] / uv[2])), int(round(uv[1] / uv[2]))


def window(img: np.ndarray, x: int, y: int, half: int = 2) -> float:
    return float(img[y - half : y + half + 1, x - half : x + half + 1].astype(float).mean())


def test_same_seed_same_frames_and_seeds_vary_the_photographs() -> None:
    cam = CameraConfig()  # every sensor effect on
    scene = SceneConfig(realism="on", textures="footage")
    a = Renderer(cam, BannerConfig(), scene, 3)
    b = Renderer(cam, BannerConfig(), scene, 3)
    c = Renderer(cam, BannerConfig(), scene, 4)
    for k in range(4):
        t = k / 30
        fa = a.render(t, ME, [VehiclePose(1.6, 0.1 * k, 0.1)], 0, "f", 0.2)[0]
        fb = b.render(t, ME, [VehiclePose(1.6, 0.1 * k, 0.1)], 0, "f", 0.2)[0]
        fc = c.render(t, ME, [VehiclePose(1.6, 0.1 * k, 0.1)], 0, "f", 0.2)[0]
        assert np.array_equal(fa, fb)
        assert np.mean(np.abs(fa.astype(int) - fc.astype(int))) > 3  # another ground, another background
    assert not np.array_equal(a.ground_tex, c.ground_tex)


def test_vignetting_darkens_the_corners_by_the_configured_amount() -> None:
    s = Sensor(dataclasses.replace(QUIET, vignetting=0.3), 0)
    out = s.expose(np.full((480, 640, 3), 200, np.uint8), 0.0, np.ones(3), 0.0, 532.0)
    centre, corner = out[236:244, 316:324].mean(), out[:4, :4].mean()
    assert corner / centre == pytest.approx(0.7, abs=0.02)


def test_shot_noise_grows_with_the_signal() -> None:
    s = Sensor(dataclasses.replace(QUIET, noise_sigma=1.0, shot_noise=0.1), 0)
    dark = s.expose(np.full((480, 640, 3), 30, np.uint8), 0.0, np.ones(3), 0.0, 532.0).std()
    bright = s.expose(np.full((480, 640, 3), 220, np.uint8), 0.0, np.ones(3), 0.0, 532.0).std()
    assert bright > 2.0 * dark
    assert bright == pytest.approx(math.sqrt(1.0 + 0.1 * 220), rel=0.25)


def test_auto_exposure_lags_a_step_in_the_light() -> None:
    s = Sensor(dataclasses.replace(QUIET, auto_exposure=True, exposure_lag_s=0.4), 0)
    grey = np.full((48, 64, 3), 100, np.uint8)
    levels = []
    for k in range(150):  # 5 s at 30 Hz; the light halves at 1 s
        light = np.ones(3) * (1.0 if k < 30 else 0.5)
        levels.append(float(s.expose(grey.copy(), k / 30, light, 0.0, 532.0).mean()))
    before = levels[29]
    assert levels[31] < 0.65 * before  # the frame after the drop: still the old gain
    assert levels[36] < 0.9 * before  # 0.2 s later: catching up
    assert levels[-1] == pytest.approx(before, rel=0.05)  # 4 s later (10 lags): back


def test_white_balance_drifts_within_its_amount() -> None:
    s = Sensor(dataclasses.replace(QUIET, white_balance_drift=0.05), 7)
    gains = np.array([s.white_balance(t) for t in np.linspace(0, 120, 400)])
    assert np.all(gains[:, 1] == 1.0)
    assert np.ptp(gains[:, 0]) > 0.03 and np.ptp(gains[:, 2]) > 0.03
    assert np.abs(gains - 1).max() <= 0.05 + 1e-9


def test_jpeg_and_rolling_shutter_change_the_frame() -> None:
    rng = np.random.default_rng(0)
    img = cv2.GaussianBlur(rng.integers(0, 255, (480, 640, 3), np.uint8), (0, 0), 2)
    jpeg = Sensor(dataclasses.replace(QUIET, jpeg_quality=20), 0).expose(img.copy(), 0.0, np.ones(3), 0.0, 532.0)
    assert 0.5 < np.abs(jpeg.astype(int) - img.astype(int)).mean() < 20
    line = np.zeros((480, 640, 3), np.uint8)
    line[:, 320] = 255
    rs = Sensor(dataclasses.replace(QUIET, rolling_shutter_s=0.03), 0).expose(line, 0.0, np.ones(3), 1.0, 532.0)
    top, bottom = int(np.argmax(rs[2, :, 0])), int(np.argmax(rs[-3, :, 0]))
    assert top > 320 > bottom and top - bottom == pytest.approx(1.0 * 0.03 * 532, abs=3)


def test_contact_shadow_is_darker_under_the_rover_than_beside_it() -> None:
    img, _truth, r = frame(scene=dataclasses.replace(SCENE, shadows=False))
    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    behind = project(r, [1.5 - 0.165, 0.0, 0.0])  # on the ground just behind the rear bumper
    beside = project(r, [1.5 - 0.165, 0.45, 0.0])
    assert window(grey, *behind) < 0.8 * window(grey, *beside)


def test_cast_shadow_falls_away_from_the_sun() -> None:
    east_sun = dataclasses.replace(SCENE, sun_azimuth_rad=math.radians(90), sun_elevation_rad=math.radians(30))
    lit, _t, r = frame(scene=dataclasses.replace(east_sun, shadows=False))
    shaded, _t, _r = frame(scene=east_sun)
    west = project(r, [1.5, -0.3, 0.0])  # the sun in the east: the shadow lies west (left)
    east = project(r, [1.5, 0.35, 0.0])
    g_lit, g_sh = cv2.cvtColor(lit, cv2.COLOR_BGR2GRAY), cv2.cvtColor(shaded, cv2.COLOR_BGR2GRAY)
    assert window(g_sh, *west) < 0.7 * window(g_lit, *west)
    assert window(g_sh, *east) == pytest.approx(window(g_lit, *east), abs=2)


def laplacian_var(img: np.ndarray, r0: int, r1: int) -> float:
    g = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY).astype(np.float32)
    return float(cv2.Laplacian(g, cv2.CV_32F)[r0:r1, 20:-20].var())


def test_nearest_ground_rows_are_as_sharp_as_far_ones() -> None:
    behind = VehiclePose(-3.0, 0.0, 0.0)  # out of view: only the floor below the horizon
    new, _t, _r = frame(leader=behind)
    old, _t, _r = frame(leader=behind, scene=dataclasses.replace(SCENE, realism="off"))
    near, far = laplacian_var(new, 440, 478), laplacian_var(new, 300, 340)
    assert near > 0.5 * far
    # the old look: half resolution and a coarse texture blur the nearest rows
    assert laplacian_var(old, 440, 478) < 0.3 * laplacian_var(old, 300, 340)
    assert near > 5 * laplacian_var(old, 440, 478)


def test_banner_markers_are_printed_not_flat() -> None:
    img, truth, _r = frame(leader=VehiclePose(1.0, 0.0, 0.0))
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    x, y = np.round(truth.markers_px[0]).astype(int)
    patch = hsv[y - 3 : y + 4, x - 3 : x + 4]
    assert patch[..., 1].max() < 250  # not fully saturated
    assert img[y - 3 : y + 4, x - 3 : x + 4, 2].std() > 1.0  # ink varies
    # soft edges: across a marker's side the saturation ramps instead of jumping
    row = hsv[y, x : x + 40, 1].astype(int)
    steps = np.abs(np.diff(row))
    assert steps.max() < 0.8 * (row.max() - row.min())


def test_banner_glare_follows_the_sun_and_the_view() -> None:
    gloss = BannerConfig(gloss=1.0)
    behind_low = dataclasses.replace(SCENE, sun_azimuth_rad=math.pi, sun_elevation_rad=math.radians(6))
    side = dataclasses.replace(SCENE, sun_azimuth_rad=math.radians(90), sun_elevation_rad=math.radians(6))
    r = Renderer(QUIET, gloss, behind_low, 0)
    centre, right, down = r.geometry.frame_ned(1.5, 0.0, 0.0)
    half = r.banner.panel_size_m / 2
    tl = centre - (right + down) * half
    corners = np.array([tl, tl + 2 * right * half, tl + 2 * (right + down) * half, tl + 2 * down * half])
    normal = np.array([-1.0, 0.0, 0.0])
    _R, c = r.cam.pose(0.0, 0.0, 0.0)
    facing = r._banner_glare(corners, normal, c, 1.0)
    assert facing is not None and facing.max() > 40
    r_side = Renderer(QUIET, gloss, side, 0)
    sideways = r_side._banner_glare(corners, normal, c, 1.0)
    assert sideways is None or sideways.max() < 0.2 * facing.max()
    matte = Renderer(QUIET, BannerConfig(gloss=0.0), behind_low, 0)
    assert matte._banner_glare(corners, normal, c, 1.0) is None
    bright, truth, _ = frame(scene=behind_low, banner=gloss)
    dull, _, _ = frame(scene=behind_low, banner=BannerConfig(gloss=0.0))
    x, y, w, h = truth.bbox
    assert bright[y : y + h, x : x + w].mean() > dull[y : y + h, x : x + w].mean() + 5


def test_rover_has_wheels_on_the_ground() -> None:
    img, _truth, r = frame(leader=VehiclePose(1.0, 0.0, 0.0))
    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    # the rear tyres' contact points, seen from behind: dark rubber where the ground would be
    for y_m in (0.102, -0.102):
        x, y = project(r, [1.0 - 0.095 - 0.04, y_m, -0.01])
        assert window(grey, x, y, 1) < 60


def test_shadow_gain_is_a_cloud_on_the_ground_not_on_the_sky() -> None:
    period = 20.0
    sunny, _t, _r = frame(t_s=period / 2, scene=dataclasses.replace(SCENE, shadow_period_s=period))
    cloudy, _t, _r = frame(t_s=period / 2, scene=dataclasses.replace(SCENE, shadow_gain=0.5, shadow_period_s=period))
    assert np.array_equal(sunny[:150], cloudy[:150])  # the sky and the background keep their light
    ground_ratio = cloudy[400:].astype(float).mean() / sunny[400:].astype(float).mean()
    assert ground_ratio < 0.8


def test_photographs_tile_without_seams() -> None:
    rng = np.random.default_rng(0)
    img = cv2.resize(rng.integers(0, 255, (8, 8, 3), np.uint8), (64, 64), interpolation=cv2.INTER_CUBIC)
    p = make_periodic(img).astype(float)
    seam = np.abs(p[:, 0] - p[:, -1]).mean()
    inside = np.abs(np.diff(p, axis=1)).mean()
    assert seam < 2 * inside


def test_realism_off_keeps_the_old_look() -> None:
    old, truth_old, _ = frame(CameraConfig(), dataclasses.replace(SCENE, realism="off"))
    new, truth_new, _ = frame(CameraConfig(), SCENE)
    assert truth_old.bbox is not None and truth_new.bbox is not None
    assert abs(truth_old.bbox[0] - truth_new.bbox[0]) <= 2  # the same banner, where it was
    assert np.abs(old.astype(int) - new.astype(int)).mean() > 5  # drawn differently


def test_a_long_shadow_stays_on_the_floor_not_on_the_sky() -> None:
    # a tall pole near the floor's far end, a low sun: its shadow runs on past where the
    # floor is drawn; past there the frame shows sky (or the background photograph)
    pole = PropConfig(kind="box", north_m=25.0, east_m=3.0, yaw_rad=math.pi, width_m=0.5, height_m=6.0)
    low_sun = dataclasses.replace(
        SCENE, props=(pole,), sun_azimuth_rad=math.radians(120), sun_elevation_rad=math.radians(5)
    )
    shaded, _t, r = frame(scene=low_sun, leader=VehiclePose(-3.0, 0.0, 0.0))
    lit, _t, _r = frame(scene=dataclasses.replace(low_sun, shadows=False), leader=VehiclePose(-3.0, 0.0, 0.0))
    floor_top = r._ground_bands[0][0]
    assert not np.array_equal(shaded[floor_top:], lit[floor_top:])  # the shadow is there, on the floor
    assert np.array_equal(shaded[:floor_top], lit[:floor_top])  # and nowhere above it


def test_the_background_loop_blends_only_its_join() -> None:
    rng = np.random.default_rng(1)
    strip = cv2.resize(rng.integers(0, 255, (4, 40, 3), np.uint8), (400, 40), interpolation=cv2.INTER_CUBIC)
    loop = close_loop(strip, 48)
    assert loop.shape == (40, 352, 3)
    assert np.array_equal(loop[:, 48:], strip[:, 48:352])  # the photograph itself, no ghost
    wrapped = np.concatenate([loop, loop], axis=1).astype(float)
    seam = np.abs(wrapped[:, 352] - wrapped[:, 351]).mean()
    inside = np.abs(np.diff(loop.astype(float), axis=1)).mean()
    assert seam < 2 * inside


def test_the_background_fades_into_the_sky_at_its_top() -> None:
    r = Renderer(QUIET, BannerConfig(), dataclasses.replace(SCENE, textures="footage"), 0)
    if r._background is None:
        pytest.skip("the footage is not installed")
    img, _t, _r = frame(scene=dataclasses.replace(SCENE, textures="footage"), leader=VehiclePose(-3.0, 0.0, 0.0))
    top = r._background_foot() - r._background.shape[0]
    assert top > 2
    cut = np.abs(img[top].astype(float) - img[top - 1].astype(float)).mean()  # across the cut edge
    assert cut < 3.0
    middle = img[top + r._background.shape[0] // 2].astype(float)
    assert np.abs(middle - img[top - 1].astype(float)).mean() > 10  # the photograph shows lower down


@pytest.mark.slow  # builds seventeen renderers
def test_the_cost_table_measures_every_effect_against_its_reference(capsys: pytest.CaptureFixture[str]) -> None:
    from lfctl.bench import render_cost

    result = render_cost.effect_costs(frames=2, block=1)
    ms, costs = result["median_ms"], result["cost_ms"]
    assert set(costs) == set(render_cost.EFFECTS)
    for name, (default, _change) in render_cost.EFFECTS.items():
        expected = ms["on"] - ms[name] if default else ms[name] - ms["on"]
        assert costs[name] == pytest.approx(expected, abs=2e-3)
    assert all(v > 0 for v in ms.values())
    render_cost.print_costs(result)
    out = capsys.readouterr().out
    assert 'realism "off" (baseline)' in out and "JPEG (quality 80)" in out
