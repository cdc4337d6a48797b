"""What the renderer says a frame shows of the target (FrameTruth), worked by hand with the
pinhole model: the benchmarks score every tracker against these boxes and shares, so an
error here would move every rendered figure without failing a tracker test.

The camera: 640 x 480, fx = fy = 500 px, principal point at the middle (319.5, 239.5), 0.12 m
ahead of the follower's reference point and 0.2 m up, level. The banner (the defaults): a
0.22 m panel whose centre is 0.2 m up (the camera's height) and 0.155 m behind the leader's
reference point; its four markers sit on a 0.14 m square."""

from __future__ import annotations

import math

import pytest

from lfctl.config import BannerConfig, CameraConfig, SceneConfig
from lfctl.render.renderer import Renderer, VehiclePose

ME = VehiclePose(0.0, 0.0, 0.0, banner=False)


def truth(follower: VehiclePose, *vehicles: VehiclePose):
    r = Renderer(CameraConfig(fx_px=500.0, noise_sigma=0.0), BannerConfig(), SceneConfig(), 0)
    return r.render(0.0, follower, list(vehicles), 0, "f")[1]


def test_a_banner_straight_ahead_by_hand() -> None:
    # leader 1.5 m ahead: the banner at 1.5 - 0.155 = 1.345 m, 1.225 m from the camera.
    # Panel: 500 * 0.22 / 1.225 = 89.80 px, centred on (319.5, 239.5): x 274.60..364.40,
    # y 194.60..284.40; the box floors the least and ceils the greatest: (274, 194, 91, 91).
    # Markers: 500 * 0.07 / 1.225 = 28.571 px either side of the middle.
    t = truth(ME, VehiclePose(1.5, 0.0, 0.0))
    assert t.bbox == (274, 194, 91, 91)
    d = 500 * 0.07 / 1.225
    corners = [(319.5 - d, 239.5 - d), (319.5 + d, 239.5 - d), (319.5 + d, 239.5 + d), (319.5 - d, 239.5 + d)]
    assert t.markers_px.ravel().tolist() == pytest.approx([v for corner in corners for v in corner], abs=1e-9)
    assert t.banner_cam_m.tolist() == pytest.approx([0.0, 0.0, 1.225], abs=1e-12)
    assert (t.visible_fraction, t.in_view) == (1.0, True)
    assert (t.range_m, t.bearing_rad, t.rel_heading_rad) == (1.5, 0.0, 0.0)


def test_a_banner_half_out_of_the_picture_is_half_visible_and_its_box_is_clipped() -> None:
    # leader 0.785225 m to the right: the banner's centre at u = 319.5 + 500 * 0.785225 / 1.225
    # = 640, the picture's right edge. The panel spans 595.10..684.90: the box is clipped to
    # x 595..640 (45 px wide), and the share in view is (640 - 595.10) / 89.80 = 0.5, within a
    # pixel column (the polygon is filled on whole pixels: 1 / 89.8 = 0.011)
    t = truth(ME, VehiclePose(1.5, 320.5 * 1.225 / 500, 0.0))
    assert t.bbox == (595, 194, 45, 91)
    assert t.in_view and t.visible_fraction == pytest.approx(0.5, abs=0.011)


def test_a_banner_behind_the_camera_or_just_past_the_edge_is_not_in_view() -> None:
    t = truth(ME, VehiclePose(-2.0, 0.0, 0.0))
    assert (t.bbox, t.visible_fraction, t.in_view) == (None, 0.0, False)
    # the panel's left edge at u = 640.3, just right of the last column (639): the leader
    # 0.11 + 320.8 * 1.225 / 500 = 0.89596 m to the right
    t = truth(ME, VehiclePose(1.5, 0.11 + 320.8 * 1.225 / 500, 0.0))
    assert (t.bbox, t.visible_fraction, t.in_view) == (None, 0.0, False)


def test_a_vehicle_between_hides_the_banner_and_leaves_its_box() -> None:
    # a second rover 0.8 m ahead stands between: the banner is in the picture (the same box)
    # but none of it shows
    t = truth(ME, VehiclePose(1.5, 0.0, 0.0), VehiclePose(0.8, 0.0, 0.0))
    assert t.bbox == (274, 194, 91, 91) and t.in_view
    assert t.visible_fraction == 0.0


def test_range_bearing_and_relative_heading_are_between_the_reference_points() -> None:
    # follower heading 0.1 rad, leader at (2, 1) m heading 0.3 rad: range sqrt(5) = 2.236068,
    # bearing atan2(1, 2) - 0.1 = 0.463648 - 0.1 = 0.363648 rad, relative heading 0.2 rad
    t = truth(VehiclePose(0.0, 0.0, 0.1, banner=False), VehiclePose(2.0, 1.0, 0.3))
    assert t.range_m == pytest.approx(math.sqrt(5), abs=1e-12)
    assert t.bearing_rad == pytest.approx(0.363648, abs=1e-6)
    assert t.rel_heading_rad == pytest.approx(0.2, abs=1e-12)
