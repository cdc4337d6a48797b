"""The follower's camera: pinhole intrinsics, lens distortion and its mount on the vehicle.

One model for the simulated camera (the renderer draws through it) and the real one
(`lfctl follow`, `lfctl track`): both come from a scenario's ``[camera]``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import cv2
import numpy as np

from lfctl.config import CameraConfig
from lfctl.errors import ConfigError
from lfctl.frames import rot_z

__all__ = ["CameraModel", "at_frame_size"]

#: frames whose width and height scale the calibrated size by factors this far apart
#: (relative) are another aspect, a crop of the sensor
ASPECT_TOLERANCE = 0.01

#: the lens model's inverse, iterated until it converges: OpenCV's default stops after five
#: steps, which leaves about a tenth of a pixel at a strong lens's corners (k1 = -0.3)
UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-10)


def at_frame_size(camera: CameraConfig, width: int, height: int) -> tuple[CameraConfig, str | None]:
    """``camera`` for frames of ``width`` x ``height`` px (a real camera's, or a video's), and a
    note when its intrinsics were scaled to them.

    Without given intrinsics only the size changes (the focal length comes from
    ``hfov_deg``). Given ones (``fx_px`` .. ``cy_px``, a calibration) hold at the scenario's
    ``width_px`` x ``height_px``: a camera mode of the same aspect is the same picture at
    another resolution, so they scale with it (the distortion coefficients, in normalised
    coordinates, stay); another aspect is a crop of the sensor, which no scaling describes.

    Parameters
    ----------
    camera : CameraConfig
        The scenario's ``[camera]``.
    width, height : int
        The frames' size, px.

    Raises
    ------
    ConfigError
        Given intrinsics and frames of another aspect, or a size the camera cannot take.
    """
    W, H = camera.width_px, camera.height_px
    if (width, height) == (W, H):
        return camera, None
    given = [k for k in ("fx_px", "fy_px", "cx_px", "cy_px") if getattr(camera, k) != 0]
    if not given:
        return dataclasses.replace(camera, width_px=width, height_px=height), None
    sx, sy = width / W, height / H
    if abs(sx / sy - 1) > ASPECT_TOLERANCE:
        raise ConfigError(
            f"camera.{given[0]} and the other intrinsics hold at camera.width_px x height_px = {W}x{H}, not "
            f"the frames' {width}x{height}: another aspect (a crop of the sensor, which scaling does not "
            f"describe); set the camera to {W}x{H}, or calibrate it at {width}x{height} and give that size"
        )

    def centre(c: float, s: float) -> float:  # pixel centres at whole numbers: (c + 0.5) scales
        return 0.0 if c == 0 else (c + 0.5) * s - 0.5

    scaled = dataclasses.replace(
        camera,
        width_px=width,
        height_px=height,
        fx_px=camera.fx_px * sx,
        fy_px=camera.fy_px * sy,
        cx_px=centre(camera.cx_px, sx),
        cy_px=centre(camera.cy_px, sy),
    )
    return scaled, f"camera intrinsics given for {W}x{H} scaled by {sx:.4g} to the frames' {width}x{height}"


@dataclass(frozen=True)
class CameraModel:
    """Intrinsics (pixels) and mount of a follower's camera.

    Parameters
    ----------
    width, height : int
        Image size, pixels.
    K : np.ndarray
        3x3 intrinsic matrix, pixels.
    dist : np.ndarray
        OpenCV distortion coefficients k1, k2, p1, p2, k3.
    mount_body_m : np.ndarray
        Camera centre in the vehicle body frame (FRD), m.
    R_body_from_cam : np.ndarray
        3x3 rotation from the camera frame (x right, y down, z forward) to the body frame.
    """

    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray
    mount_body_m: np.ndarray
    R_body_from_cam: np.ndarray

    @staticmethod
    def from_config(cfg: CameraConfig) -> CameraModel:
        """The model a scenario's ``[camera]`` describes (``fx`` from ``hfov`` unless given).

        Parameters
        ----------
        cfg : CameraConfig
            The ``[camera]`` section.
        """
        fx = cfg.fx_px or (cfg.width_px / 2) / math.tan(cfg.hfov_rad / 2)
        fy = cfg.fy_px or fx
        cx = cfg.cx_px or (cfg.width_px - 1) / 2
        cy = cfg.cy_px or (cfg.height_px - 1) / 2
        K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        c, s = math.cos(cfg.pitch_rad), math.sin(cfg.pitch_rad)
        # columns: camera x (right), y (down), z (forward, pitched up by pitch_rad) in FRD
        R = np.array([[0.0, s, c], [1.0, 0.0, 0.0], [0.0, c, -s]])
        return CameraModel(
            cfg.width_px,
            cfg.height_px,
            K,
            np.array([cfg.k1, cfg.k2, cfg.p1, cfg.p2, cfg.k3]),
            np.array([cfg.mount_forward_m, 0.0, -cfg.mount_height_m]),
            R,
        )

    def pose(self, north_m: float, east_m: float, yaw_rad: float) -> tuple[np.ndarray, np.ndarray]:
        """(R_cam_from_ned, camera centre in NED) for a vehicle at this pose.

        Parameters
        ----------
        north_m, east_m : float
            The vehicle's reference point in NED, m.
        yaw_rad : float
            The vehicle's heading, rad.
        """
        Rz = rot_z(yaw_rad)
        R_ned_from_cam = Rz @ self.R_body_from_cam
        centre = np.array([north_m, east_m, 0.0]) + Rz @ self.mount_body_m
        return R_ned_from_cam.T, centre

    def project_body(self, point_body_m: np.ndarray) -> tuple[float, float, float] | None:
        """Pixel (u, v) and depth (m) of a point given in the body frame, or None behind the
        camera (within 5 cm of it). Ideal pinhole: no distortion.

        Parameters
        ----------
        point_body_m : np.ndarray
            (3,) point in the vehicle body frame (FRD), m.
        """
        p = self.R_body_from_cam.T @ (point_body_m - self.mount_body_m)
        if p[2] <= 0.05:
            return None
        K = self.K
        return float(K[0, 0] * p[0] / p[2] + K[0, 2]), float(K[1, 1] * p[1] / p[2] + K[1, 2]), float(p[2])

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        """Normalised pinhole coordinates (x / z, y / z), (N, 2), of raw pixels (N, 2): the
        lens taken out (to convergence, :data:`UNDISTORT_CRITERIA`).

        Parameters
        ----------
        pixels : np.ndarray
            (N, 2) pixels as the camera gives them (distorted).
        """
        pts = np.asarray(pixels, np.float64).reshape(-1, 1, 2)
        return cv2.undistortPoints(pts, self.K, self.dist, criteria=UNDISTORT_CRITERIA).reshape(-1, 2)
