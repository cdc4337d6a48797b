"""The camera model's geometry (lfctl.vision.camera_model) on numbers worked by hand: where
the camera is on a turned vehicle, what it sees of points in the body frame, and how given
intrinsics scale to another frame size."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from lfctl.config import CameraConfig
from lfctl.vision.camera_model import CameraModel, at_frame_size

# 640 x 480, fx 500, fy 400, principal point (320, 240); the camera 0.3 m ahead of the
# vehicle's reference point, 0.2 m up, level
CAM = CameraConfig(fx_px=500.0, fy_px=400.0, cx_px=320.0, cy_px=240.0, mount_forward_m=0.3, mount_height_m=0.2)


def test_the_camera_sits_on_the_turned_vehicle_and_looks_where_it_heads() -> None:
    # heading east (90 deg) from (10, 20) m: the camera is 0.3 m east of the reference point,
    # 0.2 m up (NED down -0.2), and its optical axis (camera z) is east, its x (right) south,
    # its y (down) down
    R_cam_from_ned, centre = CameraModel.from_config(CAM).pose(10.0, 20.0, math.pi / 2)
    assert centre == pytest.approx([10.0, 20.3, -0.2], abs=1e-12)
    assert R_cam_from_ned @ [0.0, 1.0, 0.0] == pytest.approx([0.0, 0.0, 1.0], abs=1e-12)  # east: ahead
    assert R_cam_from_ned @ [-1.0, 0.0, 0.0] == pytest.approx([1.0, 0.0, 0.0], abs=1e-12)  # south: right
    assert R_cam_from_ned @ [0.0, 0.0, 1.0] == pytest.approx([0.0, 1.0, 0.0], abs=1e-12)  # down: down


def test_a_body_point_projects_with_each_axis_own_focal_length() -> None:
    # body (1.3, 0.1, -0.1) FRD is (1.0, 0.1, 0.1) from the camera: 1 m ahead, 0.1 m right,
    # 0.1 m below it. u = 320 + 500 * 0.1 / 1 = 370, v = 240 + 400 * 0.1 / 1 = 280, depth 1.
    uvz = CameraModel.from_config(CAM).project_body(np.array([1.3, 0.1, -0.1]))
    assert uvz == pytest.approx((370.0, 280.0, 1.0), abs=1e-9)


def test_a_point_within_5_cm_of_the_camera_is_not_projected() -> None:
    model = CameraModel.from_config(CAM)
    assert model.project_body(np.array([0.34, 0.0, -0.2])) is None  # 4 cm ahead of the lens
    # 6 cm ahead and 1 cm right: u = 320 + 500 * 0.01 / 0.06 = 403.33
    u, v, z = model.project_body(np.array([0.36, 0.01, -0.2]))
    assert (u, v, z) == pytest.approx((320 + 500 / 6, 240.0, 0.06), abs=1e-9)


def test_given_intrinsics_scale_each_axis_by_its_own_ratio() -> None:
    # 640 x 480 -> 1280 x 961 is the same aspect within a pixel (480 * 2 = 960): x scales by 2,
    # y by 961 / 480 = 2.0020833. fx 500 -> 1000, fy 400 -> 800.8333; the principal point's
    # pixel centres scale as (c + 0.5) s - 0.5: 320 -> 640.5, 240 -> 481.0 - 0.5 + 0.5 * 0.0020833..
    scaled, note = at_frame_size(CAM, 1280, 961)
    assert note is not None and "scaled by 2" in note
    assert scaled.fx_px == pytest.approx(1000.0)
    assert scaled.fy_px == pytest.approx(400 * 961 / 480)
    assert scaled.cx_px == pytest.approx(640.5)
    assert scaled.cy_px == pytest.approx(240.5 * 961 / 480 - 0.5)
    # fy not given: it is fx's, and scales with the height
    only_fx, _ = at_frame_size(CameraConfig(fx_px=500.0), 1280, 961)
    assert only_fx.fy_px == pytest.approx(500 * 961 / 480)


def test_a_camera_pitched_up_sees_a_level_point_below_its_centre() -> None:
    # pitched 30 deg up, its axis is (cos 30, 0, -sin 30) in FRD (up is -z): a point 2 m along it
    # is the principal point. A point 1 m level ahead of the lens is, in the camera's frame,
    # (0, sin 30, cos 30) = (0, 0.5, 0.866): v = 240 + 400 * 0.5 / 0.866025 = 470.94.
    model = CameraModel.from_config(dataclasses.replace(CAM, pitch_rad=math.radians(30)))
    lens = np.array([0.3, 0.0, -0.2])
    axis = np.array([math.cos(math.radians(30)), 0.0, -math.sin(math.radians(30))])
    assert model.project_body(lens + 2 * axis) == pytest.approx((320.0, 240.0, 2.0), abs=1e-9)
    assert model.project_body(lens + np.array([1.0, 0.0, 0.0])) == pytest.approx(
        (320.0, 240 + 200 / math.cos(math.radians(30)), math.cos(math.radians(30))), abs=1e-9
    )


def test_without_a_principal_point_it_is_the_middle_of_the_picture() -> None:
    # pixel centres at whole numbers: the middle of 640 x 480 is (319.5, 239.5)
    K = CameraModel.from_config(CameraConfig(fx_px=500.0)).K
    assert (K[0, 2], K[1, 2]) == (319.5, 239.5)


@pytest.mark.parametrize("size", [(7680, 4320), (5312, 2988), (4097, 100)])
def test_frames_larger_than_the_camera_takes_are_named_by_their_size(size: tuple[int, int]) -> None:
    # an 8K or 5.3K video given to `lfctl track` was refused as "camera.width_px must be within
    # 16..4096", a scenario setting its user never gave
    from lfctl.errors import ConfigError

    with pytest.raises(ConfigError, match=r"^larger than lfctl's camera takes, 4096 px a side .* scale the video down"):
        at_frame_size(CameraConfig(), *size)
    assert at_frame_size(CameraConfig(), 4096, 2160)[0].width_px == 4096  # the largest it takes
