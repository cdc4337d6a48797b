"""The follower's camera: pinhole intrinsics, lens distortion and its mount on the vehicle.

One model for the simulated camera (the renderer draws through it) and the real one
(`lfctl follow`, `lfctl track`): both come from a scenario's ``[camera]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lfctl.config import CameraConfig
from lfctl.frames import rot_z

__all__ = ["CameraModel"]


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
        OpenCV distortion coefficients k1, k2, p1, p2.
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
            np.array([cfg.k1, cfg.k2, 0.0, 0.0]),
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
