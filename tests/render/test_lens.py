"""The lens: rendered frames bent as OpenCV's distortion model says a real lens bends them, so
that the pose (which takes the lens out with the same coefficients) measures true ranges, and
a calibration made at one resolution serves frames of another of the same aspect."""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest

from lfctl.config import BannerConfig, CameraConfig, SceneConfig
from lfctl.errors import ConfigError
from lfctl.render.lens import Lens
from lfctl.render.renderer import Renderer, VehiclePose
from lfctl.vision.camera_model import CameraModel, at_frame_size
from lfctl.vision.markers import find_constellation
from lfctl.vision.perception import BannerPerception

QUIET = dict(noise_sigma=0.0, shot_noise=0.0, auto_exposure=False, white_balance_drift=0.0, vignetting=0.0)
BARREL = dict(k1=-0.12, k2=0.03, p1=0.002, p2=-0.001, k3=-0.01)  # a typical webcam's calibration
ME = VehiclePose(0.0, 0.0, 0.0, banner=False)


def marker_blobs(img: np.ndarray) -> np.ndarray:
    """Centres of the red marker blobs, sorted TL, TR, BL, BR by rows then columns."""
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    red = (((hsv[..., 0] < 10) | (hsv[..., 0] > 170)) & (hsv[..., 1] > 120) & (hsv[..., 2] > 60)).astype(np.uint8)
    n, _lab, stats, centres = cv2.connectedComponentsWithStats(red)
    found = np.array([centres[i] for i in range(1, n) if stats[i, cv2.CC_STAT_AREA] > 15])
    assert len(found) == 4
    found = found[np.argsort(found[:, 1])]
    return np.concatenate([found[:2][np.argsort(found[:2, 0])], found[2:][np.argsort(found[2:, 0])]])


def test_rays_take_the_lens_out_and_a_pinhole_ray_is_the_pixel_over_the_focal_length() -> None:
    plain = CameraModel.from_config(CameraConfig(fx_px=500.0, cx_px=320.0, cy_px=240.0))
    # by hand: (420 - 320) / 500 = 0.2, (190 - 240) / 500 = -0.1
    assert plain.rays(np.array([[420.0, 190.0]])) == pytest.approx(np.array([[0.2, -0.1]]))
    bent = CameraModel.from_config(CameraConfig(**BARREL))
    ray = np.array([[0.35, -0.28, 1.0]])
    pixel, _ = cv2.projectPoints(ray, np.zeros(3), np.zeros(3), bent.K, bent.dist)
    assert bent.rays(pixel.reshape(1, 2)) == pytest.approx(ray[:, :2], abs=1e-9)


def test_a_barrel_lens_draws_on_a_zoomed_out_canvas_and_a_pincushion_on_the_camera_itself() -> None:
    camera = CameraModel.from_config(CameraConfig(k1=-0.1))
    barrel = Lens(camera)
    # the picture's corners look farther out than a pinhole of its focal length sees: the
    # canvas's focal length is shrunk just enough that every corner's ray lands on the canvas
    assert barrel.scale < 1.0
    corners = np.array([[0.0, 0.0], [639.0, 0.0], [0.0, 479.0], [639.0, 479.0]])
    kc = barrel.K_canvas
    on_canvas = camera.rays(corners) * (kc[0, 0], kc[1, 1]) + (kc[0, 2], kc[1, 2])
    assert np.all((on_canvas >= -1e-6) & (on_canvas <= (639 + 1e-6, 479 + 1e-6)))
    assert min(on_canvas.min(), (639 - on_canvas[:, 0]).min(), (479 - on_canvas[:, 1]).min()) < 1e-6
    assert camera.pixels(camera.rays(corners)) == pytest.approx(corners, abs=1e-9)  # and back through the lens
    pincushion = Lens(CameraModel.from_config(CameraConfig(k1=0.1)))
    assert pincushion.scale == 1.0


def test_the_lens_model_is_opencvs_and_its_inverse_is_exact_even_where_opencvs_cycles() -> None:
    from lfctl.vision.camera_model import distort

    rng = np.random.default_rng(3)
    rays = rng.uniform(-0.8, 0.8, (200, 2))
    dist = np.array([-0.12, 0.03, 0.002, -0.001, -0.01])
    pts, _ = cv2.projectPoints(np.column_stack([rays, np.ones(200)]), np.zeros(3), np.zeros(3), np.eye(3), dist)
    assert distort(rays, dist)[0] == pytest.approx(pts.reshape(-1, 2), abs=1e-12)
    # a wide lens (112 deg) whose radial function rises to the corners: OpenCV's fixed-point
    # inverse cycles at its edge (178 px off at pixel (1, 10)); here every pixel's ray is exact
    wide = CameraModel.from_config(CameraConfig(hfov_rad=math.radians(112.3), k1=-0.192, k2=0.271, k3=-0.064))
    u, v = np.meshgrid(np.arange(0.0, 640.0, 3.0), np.arange(0.0, 480.0, 3.0))
    pixels = np.column_stack([u.ravel(), v.ravel()])
    assert wide.pixels(wide.rays(pixels)) == pytest.approx(pixels, abs=1e-7)
    Lens(wide)  # and it is a lens: not refused
    opencv = cv2.undistortPoints(np.array([[[1.0, 10.0]]]), wide.K, wide.dist)
    assert np.abs(opencv.reshape(2) - wide.rays(np.array([[1.0, 10.0]]))[0]).max() > 0.1


def test_what_a_lens_picture_shows_of_a_polygon_is_read_from_the_bent_masks() -> None:
    lens = Lens(CameraModel.from_config(CameraConfig(**BARREL)))
    outside = np.array([[-900.0, -200.0], [-300.0, -200.0], [-300.0, 700.0], [-900.0, 700.0]])  # left of the picture
    assert lens.shown(outside, []) == (None, 0.0)  # (straight chords between held points showed 47,809 px)
    square = np.array([[200.0, 150.0], [300.0, 150.0], [300.0, 250.0], [200.0, 250.0]])
    box, share = lens.shown(square, [])
    assert share == pytest.approx(1.0, abs=0.03) and box is not None
    corners = lens.camera.pixels((square - lens.K_canvas[:2, 2]) / np.diag(lens.K_canvas)[:2])
    assert box[0] == pytest.approx(corners[:, 0].min(), abs=2) and box[1] == pytest.approx(corners[:, 1].min(), abs=2)
    left_half = np.array([[150.0, 100.0], [250.0, 100.0], [250.0, 300.0], [150.0, 300.0]])
    assert lens.shown(square, [left_half])[1] == pytest.approx(0.5, abs=0.03)
    half_out = square - (250.0, 0.0)  # half of it left of the canvas: hidden, and the picture
    assert 0.35 < lens.shown(half_out, [])[1] < 0.5  # shows less than the canvas there


def test_a_slot_is_judged_through_the_lens() -> None:
    from lfctl.vision.banner import BannerGeometry
    from lfctl.vision.perception import banner_in_picture, slot_box

    wide = CameraModel.from_config(CameraConfig(hfov_rad=math.radians(100), k1=-0.28, k2=0.07))
    banner = BannerGeometry.from_config(BannerConfig())
    bearing = math.radians(40)
    # a pinhole of this focal length puts the banner at x 616 of 640, its edge past the
    # picture; the barrel lens draws it in at about x 546
    box = slot_box(wide, banner, 1.5, bearing)
    assert box is not None and 520 < box[0] + box[2] / 2 < 570
    assert banner_in_picture(wide, banner, 1.5, bearing)


@pytest.mark.parametrize("realism", ["off", "on"])
@pytest.mark.parametrize("lens", [BARREL, dict(k1=0.1)], ids=["barrel", "pincushion"])
def test_the_markers_are_drawn_where_the_lens_puts_them_and_the_truth_says_so(realism: str, lens: dict) -> None:
    cam = CameraConfig(**QUIET, **lens)
    scene = SceneConfig(realism=realism, textures="procedural")
    leader = VehiclePose(2.155, 0.7, 0.0)  # the banner to the right, where the lens bends most
    img, truth = Renderer(cam, BannerConfig(), scene, 0).render(0.0, ME, [leader], 0)
    ideal_img, ideal = Renderer(
        dataclasses.replace(cam, k1=0.0, k2=0.0, p1=0.0, p2=0.0, k3=0.0), BannerConfig(), scene, 0
    ).render(0.0, ME, [leader], 0)
    model = CameraModel.from_config(cam)
    # where OpenCV's model puts the ideal (pinhole) markers: their rays through the lens
    kc = model.K
    ideal_rays = (ideal.markers_px - (kc[0, 2], kc[1, 2])) / (kc[0, 0], kc[1, 1])
    pts = np.concatenate([ideal_rays, np.ones((4, 1))], axis=1)
    expected, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), model.K, model.dist)
    expected = expected.reshape(4, 2)
    assert truth.markers_px == pytest.approx(expected, abs=1e-6)
    order = [0, 1, 3, 2]  # TL, TR, BR, BL -> the blobs' TL, TR, BL, BR
    seen = marker_blobs(img)
    assert np.abs(seen - expected[order]).max() < 0.8  # drawn where the lens puts them
    moved = np.abs(expected - ideal.markers_px).max()
    assert moved > 2.0  # the lens moves them by pixels: the test tells the two directions apart
    assert np.abs(marker_blobs(ideal_img) - ideal.markers_px[order]).max() < 0.8
    x, y, w, h = truth.bbox
    assert np.all((seen >= (x, y)) & (seen <= (x + w, y + h)))


def test_the_pose_through_a_lens_measures_the_true_range() -> None:
    # without the lens drawn as OpenCV's model bends (the frames were bent the other way), the
    # ranges here came out 5 cm short in the mean, 7.7 cm RMS, and bearings 0.9 deg off
    cam = CameraConfig(**QUIET, **BARREL)
    renderer = Renderer(cam, BannerConfig(), SceneConfig(), 0)
    perception = BannerPerception.from_config(cam, BannerConfig(), (1.5, 0.0))
    rng = np.random.default_rng(1)
    range_err, bearing_err = [], []
    for _ in range(20):
        d, b, yaw = rng.uniform(1.0, 4.0), rng.uniform(-0.45, 0.45), rng.uniform(-0.5, 0.5)
        img, truth = renderer.render(0.0, ME, [VehiclePose(d * math.cos(b), d * math.sin(b), yaw)], 0)
        found = find_constellation(cv2.cvtColor(img, cv2.COLOR_BGR2HSV), 0.0)
        assert found is not None
        pose = perception.marker_pose(np.asarray(found.centres, float))
        assert pose is not None
        r, brg, _ = perception.vehicle_relative(pose)
        range_err.append(r - truth.range_m)
        bearing_err.append(math.degrees(brg - truth.bearing_rad))
    assert math.sqrt(np.mean(np.square(range_err))) < 0.01
    assert math.sqrt(np.mean(np.square(bearing_err))) < 0.2


def test_coefficients_that_fold_the_picture_are_refused_naming_them() -> None:
    with pytest.raises(ConfigError, match=r"camera\.k1 = -0\.3: this lens model folds the picture"):
        Renderer(CameraConfig(k1=-0.3), BannerConfig(), SceneConfig(), 0)


def test_a_calibration_scales_to_frames_of_its_aspect_and_refuses_another() -> None:
    cal = CameraConfig(width_px=1536, height_px=1152, fx_px=1000.0, cx_px=770.0, cy_px=575.0, k1=-0.1)
    same, note = at_frame_size(cal, 1536, 1152)
    assert same is cal and note is None
    half, note = at_frame_size(cal, 768, 576)
    # by hand: fx 1000 x 0.5; pixel centres at whole numbers, so cx = (770 + 0.5) x 0.5 - 0.5
    assert (half.width_px, half.height_px, half.fx_px, half.fy_px) == (768, 576, 500.0, 500.0)
    assert (half.cx_px, half.cy_px) == (384.75, 287.25)
    assert half.k1 == -0.1 and note is not None and "1536x1152" in note and "768x576" in note
    by_fov, note = at_frame_size(CameraConfig(), 1280, 720)  # no calibration: the field of view holds
    assert (by_fov.width_px, by_fov.height_px, by_fov.fx_px, note) == (1280, 720, 0.0, None)
    with pytest.raises(ConfigError, match=r"camera\.fx_px .* 1536x1152, not the frames' 1280x720"):
        at_frame_size(cal, 1280, 720)
    with pytest.raises(ConfigError, match="another aspect"):  # rows padded (1080 -> 1088): no scaling
        at_frame_size(dataclasses.replace(cal, width_px=1920, height_px=1080, cx_px=960.0, cy_px=540.0), 1920, 1088)


def test_a_real_camera_whose_lens_folds_is_refused_before_it_tracks(capsys: pytest.CaptureFixture[str]) -> None:
    # lfctl follow and lfctl track build no renderer: the perception refuses it, naming the key
    with pytest.raises(ConfigError, match=r"camera\.k1 = -0\.3: this lens model folds"):
        BannerPerception.from_config(CameraConfig(k1=-0.3), BannerConfig())
    from lfctl.vision.pose import paper_pose

    K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
    assert paper_pose(np.array([[1.0, 1.0], [np.nan, 1.0], [9.0, 9.0], [1.0, 9.0]]), K, 0.14) is None
