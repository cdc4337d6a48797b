"""CAMShift moments (eq. 3-8), the background-weighted model and the two pose estimators."""

from __future__ import annotations

import itertools
import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lfctl.config import BannerConfig, CameraConfig, SceneConfig
from lfctl.render.renderer import Renderer, VehiclePose
from lfctl.vision.camera_model import CameraModel
from lfctl.vision.camshift import camshift_in_roi, window_moments
from lfctl.vision.histogram import bhattacharyya, ratio_lut
from lfctl.vision.markers import find_constellation, order_corners
from lfctl.vision.pose import paper_pose, pnp_pose, to_vehicle_frame


def test_eq3_to_8_moments_of_a_uniform_rectangle() -> None:
    prob = np.zeros((100, 100), np.uint8)
    prob[40:50, 20:60] = 255  # 40 wide, 10 tall
    m = window_moments(prob, (0, 0, 100, 100))
    assert m.m00 == pytest.approx(400 * 255)
    assert (m.xc, m.yc) == pytest.approx((39.5, 44.5))
    assert m.a == pytest.approx((40**2 - 1) / 12)  # variance of a uniform run of 40 pixels
    assert m.c == pytest.approx((10**2 - 1) / 12)
    assert m.b == pytest.approx(0.0, abs=1e-9)
    assert m.major == pytest.approx(math.sqrt(m.a)) and m.minor == pytest.approx(math.sqrt(m.c))


def test_eq7_corrected_b_term_gives_the_axis_angle() -> None:
    prob = np.zeros((120, 120), np.uint8)
    cv2.ellipse(prob, (60, 60), (40, 8), 30, 0, 360, 255, -1)  # rotated 30 deg
    m = window_moments(prob, (0, 0, 120, 120))
    assert math.degrees(m.angle_rad) == pytest.approx(30, abs=1.0)
    assert m.major / m.minor == pytest.approx(5, rel=0.08)


def test_camshift_in_roi_finds_the_blob_in_full_image_coordinates() -> None:
    prob = np.zeros((200, 300), np.uint8)
    prob[100:130, 200:230] = 255
    roi = prob[80:160, 150:260]
    win, mass = camshift_in_roi(roi, (150, 80), (170, 90, 40, 40))
    cx, cy = win[0] + win[2] / 2, win[1] + win[3] / 2
    assert (cx, cy) == pytest.approx((215, 115), abs=2) and mass > 0.5


def test_background_weighting_suppresses_shared_bins() -> None:
    target = np.zeros((4,), np.float32)
    target[:] = [50, 50, 0, 0]
    background = np.array([0, 500, 100, 400], np.float32)
    lut = ratio_lut(target, background)
    assert lut[0] == pytest.approx(255)  # never in the background: full weight
    assert lut[1] == pytest.approx(255 * 0.2)  # common in the background: o* / o_u = 0.1 / 0.5
    assert lut[2] == 0 and lut[3] == 0


def test_bhattacharyya_ends() -> None:
    a = np.array([1, 2, 3, 0], np.float32)
    assert bhattacharyya(a, a * 7) == pytest.approx(0.0, abs=1e-6)
    assert bhattacharyya(a, np.array([0, 0, 0, 5], np.float32)) == pytest.approx(1.0)


def test_corner_order() -> None:
    pts = np.array([[10, 50], [50, 12], [12, 10], [52, 51]])
    assert order_corners(pts).tolist() == [[12, 10], [50, 12], [52, 51], [10, 50]]


def projected_square(K: np.ndarray, centre_cam: np.ndarray, yaw: float, side: float) -> np.ndarray:
    """Image points TL, TR, BR, BL of a vertical square at ``centre_cam`` turned by ``yaw``."""
    right = np.array([math.cos(yaw), 0.0, -math.sin(yaw)])
    down = np.array([0.0, 1.0, 0.0])
    h = side / 2
    pts = [
        centre_cam - right * h - down * h,
        centre_cam + right * h - down * h,
        centre_cam + right * h + down * h,
        centre_cam - right * h + down * h,
    ]
    uv = (K @ np.array(pts).T).T
    return uv[:, :2] / uv[:, 2:3]


def test_pose_of_a_known_marker_layout() -> None:
    K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
    centre = np.array([0.3, -0.05, 2.0])
    pts = projected_square(K, centre, math.radians(25), 0.14)
    for est in (paper_pose(pts, K, 0.14), pnp_pose(pts, K, None, 0.14)):
        assert est is not None
        assert est.range_m == pytest.approx(math.hypot(0.3, 2.0), rel=0.01), est.method
        assert math.degrees(est.bearing_rad) == pytest.approx(math.degrees(math.atan2(0.3, 2.0)), abs=0.3)
        assert math.degrees(est.rel_heading_rad) == pytest.approx(25, abs=2.0), est.method


def test_the_papers_estimate_takes_depth_from_the_vertical_focal_length() -> None:
    # a square facing the camera 2 m ahead, 0.4 m right, side 0.14 m; fx 500, fy 520 (non-square
    # pixels). By hand: each pair is 520 * 0.14 / 2 = 36.4 px tall, so z = 520 * 0.14 / 36.4 = 2.0;
    # the pairs' columns sit at 320 + 500 * (0.4 -+ 0.07) / 2, so x = 2.0 * 100 / 500 = 0.4
    K = np.array([[500.0, 0, 320], [0, 520.0, 240], [0, 0, 1]])
    est = paper_pose(projected_square(K, np.array([0.4, 0.0, 2.0]), 0.0, 0.14), K, 0.14)
    assert est is not None
    assert est.centre_cam_m == pytest.approx([0.4, 0.0, 2.0], abs=1e-9)
    assert est.range_m == pytest.approx(math.hypot(0.4, 2.0), abs=1e-9)  # the mean focal length: 1.96 m


@pytest.mark.parametrize("pitch_deg", [-20.0, -10.0, 10.0])
def test_the_papers_estimate_is_measured_level_so_a_pitched_camera_reads_true_ranges(pitch_deg: float) -> None:
    # a vertical square 2 m ahead and 0.3 m right of the camera, at its height, turned 20 deg;
    # the camera pitched: its pixels put through the mount's rotation give the level geometry
    from lfctl.vision.camera_model import CameraModel

    cam = CameraModel.from_config(CameraConfig(pitch_rad=math.radians(pitch_deg)))
    R = cam.R_body_from_cam
    yaw = math.radians(20)
    right = np.array([-math.sin(yaw), math.cos(yaw), 0.0])  # body FRD: the square's right axis
    down = np.array([0.0, 0.0, 1.0])
    centre = np.array([2.0, 0.3, 0.0])
    h = 0.07
    corners = [
        centre - right * h - down * h,
        centre + right * h - down * h,
        centre + right * h + down * h,
        centre - right * h + down * h,
    ]
    cam_pts = np.array([R.T @ c for c in corners])
    uv = (cam.K @ cam_pts.T).T
    pixels = uv[:, :2] / uv[:, 2:3]
    level = paper_pose(pixels, cam.K, 0.14, R)
    assert level is not None
    assert level.range_m == pytest.approx(math.hypot(2.0, 0.3), abs=1e-9)
    assert level.bearing_rad == pytest.approx(math.atan2(0.3, 2.0), abs=1e-9)
    assert level.rel_heading_rad == pytest.approx(yaw, abs=1e-9) and level.quality == pytest.approx(1.0)
    assert R @ level.centre_cam_m == pytest.approx(centre, abs=1e-9)
    r, _b, rel = to_vehicle_frame(level, np.zeros(3), R, 0.0)
    assert (r, rel) == pytest.approx((math.hypot(2.0, 0.3), yaw), abs=1e-9)
    # measured in the camera's own frame, as before: the pitch reads the range short
    tilted = paper_pose(pixels, cam.K, 0.14)
    assert tilted is not None and tilted.range_m < 0.99 * level.range_m


def test_a_pnp_answer_of_not_a_number_is_no_pose_and_the_papers_estimate_is_taken(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # OpenCV's IPPE_SQUARE says "ok" with a NaN translation on a few exact, noise-free squares
    # (about 1 in 20 of random poses of the default banner, none with 0.05 px of noise)
    from lfctl.vision.banner import BannerGeometry
    from lfctl.vision.perception import BannerPerception

    K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
    pts = projected_square(K, np.array([0.3, -0.05, 2.0]), math.radians(25), 0.14)
    nan = np.full((3, 1), np.nan)
    monkeypatch.setattr(cv2, "solvePnP", lambda *a, **k: (True, np.zeros((3, 1)), nan))
    assert pnp_pose(pts, K, None, 0.14) is None
    cam = CameraConfig()
    perception = BannerPerception.from_config(cam, BannerConfig(), (1.5, 0.0))
    side = BannerGeometry.from_config(BannerConfig()).square_m
    found = perception.marker_pose(projected_square(perception.camera.K, np.array([0.3, -0.05, 2.0]), 0.4, side))
    assert found is not None and found.method == "paper" and math.isfinite(found.range_m)


@pytest.fixture(scope="module")
def renderer() -> Renderer:
    return Renderer(CameraConfig(), BannerConfig(), SceneConfig(), 7)


@settings(max_examples=25, deadline=None)
@given(st.floats(0.8, 3.0), st.floats(-0.3, 0.3), st.floats(-0.8, 0.8))
def test_pose_of_a_rendered_banner_within_tolerance(renderer: Renderer, rng: float, brg: float, yaw: float) -> None:
    img, truth = renderer.render(
        0.0, VehiclePose(0, 0, 0, False), [VehiclePose(rng * math.cos(brg), rng * math.sin(brg), yaw)], 0
    )
    if truth.visible_fraction < 0.99:  # partly out of the image: no constellation to ask for
        return
    # the marker finder takes banners turned up to ~70 deg from the line of sight (a marker
    # seen more obliquely than that is a sliver); hypothesis found a 73 deg view at 0.8 m
    banner_n, banner_e = rng * math.cos(brg) - 0.155 * math.cos(yaw), rng * math.sin(brg) - 0.155 * math.sin(yaw)
    line_of_sight = math.atan2(banner_e, banner_n - 0.12)  # from the camera, 0.12 m ahead of the reference point
    if abs(math.remainder(line_of_sight - yaw, 2 * math.pi)) > math.radians(65):
        return
    c = find_constellation(cv2.cvtColor(img, cv2.COLOR_BGR2HSV), 0.0)
    assert c is not None
    cam = CameraModel.from_config(CameraConfig())
    est = pnp_pose(c.centres, cam.K, None, 0.14)
    assert est is not None
    r, b, rel = to_vehicle_frame(est, cam.mount_body_m, cam.R_body_from_cam, BannerConfig().back_m)
    assert r == pytest.approx(truth.range_m, rel=0.02)
    assert math.degrees(abs(b - truth.bearing_rad)) < 1.0
    # IPPE's two mirror solutions are close for a small banner: the heading is the weak part
    assert math.degrees(abs(rel - truth.rel_heading_rad)) < 20.0


@pytest.mark.parametrize("ground", ["concrete", "checker", "carpet"])
def test_tiled_floor_draws_the_same_picture_as_wrapping_one_tile(ground: str) -> None:
    # the 3 x 3 tiling is only a speed-up: the periodic floor must look as a wrapped single tile
    tiled = Renderer(CameraConfig(), BannerConfig(), SceneConfig(ground=ground), 7)
    single = Renderer(CameraConfig(), BannerConfig(), SceneConfig(ground=ground), 7)
    # one tile per level (BGRA, as the renderer holds its tiles), and the floor's bands rebuilt
    # on them: the bands take their tiles when the renderer is built
    single._ground_tiles = [cv2.cvtColor(t, cv2.COLOR_BGR2BGRA) for t in single._ground_levels]
    single._init_ground_bands()
    assert single._band_paint[0][0].shape[:2] == single._ground_levels[single._ground_bands[0][2]].shape[:2]
    lead = VehiclePose(0.0, 0.0, 0.0)
    for i in range(20):
        me = VehiclePose(-1.5 + 37.3 * i, -11.1 * i, 0.7 * i, banner=False)
        a, _ = tiled.render(i / 30, me, [lead], 0)
        b, _ = single.render(i / 30, me, [lead], 0)
        diff = np.abs(a.astype(int) - b.astype(int))
        assert diff.max() <= 1 and np.mean(diff > 0) < 1e-3


@pytest.mark.parametrize("ground", ["concrete", "checker", "carpet"])
def test_floor_mip_levels_tile_without_a_seam(ground: str) -> None:
    # each level is filtered as if the floor went on forever: two tiles of level L side by
    # side are what filtering a wide patch of level L - 1 gives, seam included
    levels = Renderer(CameraConfig(), BannerConfig(), SceneConfig(ground=ground), 7)._ground_levels
    assert len(levels) == 4
    for fine, coarse in itertools.pairwise(levels):
        h, w = fine.shape[:2]
        wide = cv2.pyrDown(np.tile(fine, (4, 4, 1)))[h // 2 : h // 2 + h, w // 2 : w // 2 + w]
        assert np.array_equal(wide, np.tile(coarse, (2, 2, 1)))
        assert abs(float(fine.mean()) - float(coarse.mean())) < 1.0


def test_floor_is_coarser_towards_the_horizon() -> None:
    r = Renderer(CameraConfig(), BannerConfig(), SceneConfig(), 7)
    bands = r._ground_bands
    levels = [level for _, _, level in bands]
    assert levels == sorted(levels, reverse=True) and levels[0] == 3 and levels[-1] == 0
    # contiguous, down to the bottom row of the half-resolution layer
    assert all(a[1] == b[0] for a, b in itertools.pairwise(bands)) and bands[-1][1] == r._half_size[1]


def test_a_tracker_kind_is_one_of_three_and_hue_only_is_hue() -> None:
    # a wrong name ran hs-lbp silently, the CLI's own "hue-only" among them
    from lfctl.vision.perception import BannerPerception
    from lfctl.vision.tracker import TrackerSettings

    assert TrackerSettings(kind="hue-only").kind == "hue"
    for bad in ("csrt", "Full", ""):
        with pytest.raises(
            ValueError, match=f"tracker kind must be one of full, hs-lbp, hue \\(or hue-only\\), got '{bad}'"
        ):
            TrackerSettings(kind=bad)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="got 'csrt'"):
        BannerPerception.from_config(CameraConfig(), BannerConfig(kind="aruco"), kind="csrt")
    with pytest.raises(ValueError, match="ring_scale must be a positive number, got nan"):
        TrackerSettings(ring_scale=math.nan)


def test_a_frame_of_another_size_is_refused_by_the_tracker_and_the_perception() -> None:
    # the trackers reported TRACKING with a window outside a smaller frame; a perception built for
    # 640x480 gave a 36 deg bearing for a target at 27 deg in 768x576 frames
    from lfctl.vision.frames import FrameError
    from lfctl.vision.perception import BannerPerception
    from lfctl.vision.tracker import Tracker, TrackerSettings

    frame = np.zeros((240, 320, 3), np.uint8)
    frame[100:140, 100:140] = (0, 0, 255)
    for kind in ("hue", "hs-lbp", "full"):
        tracker = Tracker(TrackerSettings(kind=kind))
        tracker.init(frame, (100, 100, 40, 40))
        with pytest.raises(FrameError, match="frame is 640x480, the tracker started on 320x240"):
            tracker.update(np.zeros((480, 640, 3), np.uint8))
        assert tracker.update(frame).status is not None  # the right size goes on
    for roi in (None, (math.nan, 1, 2, 3)):
        with pytest.raises(FrameError, match="ROI must be four"):
            Tracker().init(frame, roi)  # type: ignore[arg-type]
    perception = BannerPerception.from_config(CameraConfig(), BannerConfig())
    with pytest.raises(FrameError, match="frame is 768x576, the camera model 640x480"):
        perception.step(0.0, np.zeros((576, 768, 3), np.uint8), (10, 10, 20, 20))


@pytest.mark.parametrize("pitch_deg", [0.0, 10.0, 20.0])
def test_the_leaders_heading_and_place_from_a_pitched_camera_are_measured_in_the_horizontal(pitch_deg: float) -> None:
    # the leader 2 m away at 8 deg, turned 25 deg; PnP's heading in the camera's x-z plane is
    # 24.67 deg at 10 deg pitch and 23.66 at 20 (atan(cos p tan 25)): levelled, 25 exactly
    import dataclasses

    from lfctl.vision.banner import BannerGeometry

    banner = BannerGeometry.from_config(BannerConfig())
    cam = CameraModel.from_config(dataclasses.replace(CameraConfig(), pitch_rad=math.radians(pitch_deg)))
    b, yaw = math.radians(8.0), math.radians(25.0)
    uv = np.array([cam.project_body(p)[:2] for p in banner.markers_ned(2.0 * math.cos(b), 2.0 * math.sin(b), yaw)])
    pose = pnp_pose(uv, cam.K, None, banner.square_m)
    assert pose is not None
    in_plane = math.degrees(math.atan(math.cos(math.radians(pitch_deg)) * math.tan(yaw)))
    assert math.degrees(pose.rel_heading_rad) == pytest.approx(in_plane, abs=0.01)
    rng, brg, rel = to_vehicle_frame(pose, cam.mount_body_m, cam.R_body_from_cam, banner.back_m)
    assert (rng, math.degrees(brg), math.degrees(rel)) == pytest.approx((2.0, 8.0, 25.0), abs=1e-3)
