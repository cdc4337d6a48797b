"""The flat renderer's faster paths against the plain computations they replace: each must
give bit-identical numbers (the frames' pixels follow from them), on random poses."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from lfctl.config import BannerConfig, CameraConfig, PropConfig, SceneConfig
from lfctl.frames import rot_z
from lfctl.render.renderer import (
    _BOX_FACES,
    _BOX_NAMES,
    GROUND_TILES,
    Plane,
    Renderer,
    VehiclePose,
    _band_homography,
)


def reference_ground(r: Renderer, R: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The floor as it was drawn band by band: a homography, a solve and a shift each, warped
    from the level's BGR tiles."""
    layer = r._sky_half.copy()
    Hg = r._ground_homography(r._half_K, R, c)
    w = layer.shape[1]
    for r0, r1, level in r._ground_bands:
        M = _band_homography(Hg, r0, level)
        q = np.linalg.solve(M, np.array([w / 2.0, (r1 - r0) / 2.0, 1.0]))
        ph, pw = r._ground_levels[level].shape[:2]
        kx = math.floor(q[0] / q[2] / pw) - GROUND_TILES // 2
        ky = math.floor(q[1] / q[2] / ph) - GROUND_TILES // 2
        M = M @ np.array([[1.0, 0.0, kx * pw], [0.0, 1.0, ky * ph], [0.0, 0.0, 1.0]])
        bgr = np.tile(r._ground_levels[level], (GROUND_TILES, GROUND_TILES, 1))
        cv2.warpPerspective(bgr, M, (w, r1 - r0), dst=layer[r0:r1], flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
    return layer


@pytest.mark.parametrize(
    "camera",
    [CameraConfig(), CameraConfig(width_px=322, height_px=242, pitch_rad=0.1), CameraConfig(pitch_rad=-0.3)],
)
def test_the_floors_stacked_bands_are_the_band_by_band_floor(camera: CameraConfig) -> None:
    r = Renderer(camera, BannerConfig(), SceneConfig(), 3)
    rng = np.random.default_rng(1)
    for k in range(150):
        R, c = r.cam.pose(*rng.uniform(-50, 50, 2), rng.uniform(-4, 4))
        r._layer[:] = 7 * (k % 2)  # whatever the last frame left
        for r0, r1 in r._sky_rows:
            r._layer[r0:r1] = r._sky_half[r0:r1]
        r._paint_ground(R, c)
        assert np.array_equal(r._layer, reference_ground(r, R, c))


def test_box_faces_have_the_corners_their_planes_had() -> None:
    r = Renderer(CameraConfig(), BannerConfig(), SceneConfig(), 3)
    rng = np.random.default_rng(2)
    for _ in range(200):
        v = VehiclePose(*rng.uniform(-20, 20, 2), rng.uniform(-4, 4))
        c = np.array([*rng.uniform(-20, 20, 2), -0.2])
        pts = np.array([v.north_m, v.east_m, 0.0]) + _BOX_FACES @ rot_z(v.yaw_rad).T
        faces = [(face, name) for _d, face, name in r._vehicle_faces(v, c) if name != "banner"]
        assert faces
        for face, name in faces:
            p = pts[_BOX_NAMES.index(name)]
            assert np.array_equal(face.corners, Plane(p[0], p[1] - p[0], p[3] - p[0], None).corners)


def test_a_static_props_plane_is_kept_and_a_moving_ones_is_not() -> None:
    props = (
        PropConfig("box", 4.0, 1.0, math.pi, width_m=0.5, height_m=0.4),
        PropConfig("box", 5.0, -1.0, math.pi, width_m=0.5, height_m=0.4, vel_east_mps=0.2),
    )
    r = Renderer(CameraConfig(), BannerConfig(), SceneConfig(props=props), 3)
    first, later = r._props(0.0), r._props(2.5)
    assert later[0] is first[0]  # built once
    assert not np.array_equal(later[1].origin, first[1].origin)  # moved
    fresh = Renderer(CameraConfig(), BannerConfig(), SceneConfig(props=props), 3)._props(2.5)
    for kept, new in zip(later, fresh, strict=True):
        assert np.array_equal(kept.corners, new.corners) and np.array_equal(kept.centre, new.centre)
