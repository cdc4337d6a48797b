"""Relative pose of the leader from its four markers (paper section 3.5, eq. 9-11).

Camera frame as in OpenCV: x right, y down, z forward. Two estimators:

- the paper's, with the pinhole correction: from the left and right marker pairs' image
  heights ``h_L``, ``h_R`` (px) the depths ``z = f E / h`` (the printed eq. 10 is a thin-lens
  form), lateral offsets ``x = z u / f`` (u from the principal point), then eq. 9/11:
  ``x_T, z_T`` the means, range ``sqrt(x_T^2 + z_T^2)``, bearing ``atan2(x_T, z_T)`` and the
  banner's yaw from ``(x_R - x_L, z_R - z_L)``;
- ``cv2.solvePnP(..., SOLVEPNP_IPPE_SQUARE)`` on the four centres: the full 6-DoF pose.

Both give the banner centre in the camera frame, the bearing and the leader's heading
relative to the camera, and a quality figure; :func:`to_vehicle_frame` turns that into the
range and bearing between the two vehicles' reference points.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from lfctl.frames import wrap_pi

__all__ = ["MarkerPose", "paper_pose", "pnp_pose", "to_vehicle_frame"]


@dataclass(frozen=True)
class MarkerPose:
    """The banner seen from the camera.

    Parameters
    ----------
    centre_cam_m : np.ndarray
        Banner centre in the camera frame (x right, y down, z forward), m.
    range_m : float
        Horizontal distance from the camera to the banner centre (x-z plane), m.
    bearing_rad : float
        Bearing of the banner centre from the camera's axis, clockwise positive, rad.
    rel_heading_rad : float
        The leader's heading minus the camera's, clockwise positive, rad, in the camera's
        x-z plane (the horizontal one for a level camera; :func:`to_vehicle_frame` takes it
        into the horizontal for a pitched one).
    quality : float
        0..1: from the reprojection error (PnP) or from how far the two marker pairs'
        spacing is from the square's side (the paper's estimator).
    method : str
        The estimator: ``"pnp"`` or ``"paper"``.
    right_cam : np.ndarray or None
        The banner's right axis in the camera frame, a unit vector (PnP's; None from the
        paper's estimator, which measures in the x-z plane only).
    """

    centre_cam_m: np.ndarray
    range_m: float
    bearing_rad: float
    rel_heading_rad: float
    quality: float
    method: str
    right_cam: np.ndarray | None = None


def paper_pose(centres: np.ndarray, K: np.ndarray, side_m: float) -> MarkerPose | None:
    """Eq. 9-11 with the pinhole correction; None when a marker pair is under a pixel tall.

    The depth comes from each pair's height in pixels over the vertical focal length, the
    sideways offset from the horizontal one. It takes the camera as level (the paper's rig):
    pitched, the pairs look shorter and the range comes out short (about 2 % at 10 degrees,
    5 % at 20), which is why :func:`pnp_pose`, exact at any pitch, is tried first.

    Parameters
    ----------
    centres : np.ndarray
        The four marker centres TL, TR, BR, BL, (4, 2), undistorted pixels.
    K : np.ndarray
        3x3 camera intrinsic matrix, pixels.
    side_m : float
        Side of the markers' square (the paper's E), m.
    """
    tl, tr, br, bl = np.asarray(centres, float)
    fx, fy = float(K[0, 0]), float(K[1, 1])
    cx, cy = float(K[0, 2]), float(K[1, 2])
    h_l, h_r = float(np.linalg.norm(bl - tl)), float(np.linalg.norm(br - tr))
    if h_l < 1.0 or h_r < 1.0:
        return None
    z_l, z_r = fy * side_m / h_l, fy * side_m / h_r  # eq. 10, pinhole form: a pair's height is vertical
    u_l, u_r = (tl[0] + bl[0]) / 2 - cx, (tr[0] + br[0]) / 2 - cx
    x_l, x_r = z_l * u_l / fx, z_r * u_r / fx
    x_t, z_t = (x_l + x_r) / 2, (z_l + z_r) / 2  # eq. 9
    v_mid = (tl[1] + tr[1] + br[1] + bl[1]) / 4 - cy
    y_t = z_t * v_mid / fy
    rng = math.hypot(x_t, z_t)  # eq. 11
    bearing = math.atan2(x_t, z_t)
    # the banner's right axis in the camera's x-z plane; turning right (clockwise) swings it to -z
    rel = wrap_pi(math.atan2(-(z_r - z_l), x_r - x_l))
    # quality: the pair gap (x_R - x_L) should be E cos(yaw); disagreement means a poor fit
    width = math.hypot(x_r - x_l, z_r - z_l)
    quality = max(0.0, 1.0 - abs(width - side_m) / side_m)
    return MarkerPose(np.array([x_t, y_t, z_t]), rng, bearing, rel, quality, "paper")


#: no lens distortion, for OpenCV (shared, never written)
_NO_DISTORTION = np.zeros(4)
_NO_DISTORTION.flags.writeable = False


@functools.lru_cache(maxsize=16)  # one banner per run; keyed on a float: bounded
def _square_points(side_m: float) -> np.ndarray:
    """IPPE_SQUARE's fixed object points for a square of ``side_m``, matched to the image
    corners BL, BR, TR, TL: the object frame is x right, y down the banner, z away from the
    camera. This order is exact on synthetic corners (tests/vision); TL, TR, BR, BL was not.
    Made once per side (every frame with markers asked for the same four points)."""
    s = side_m / 2
    obj = np.array([[-s, s, 0.0], [s, s, 0.0], [s, -s, 0.0], [-s, -s, 0.0]])
    obj.flags.writeable = False  # shared by every call
    return obj


def pnp_pose(centres: np.ndarray, K: np.ndarray, dist: np.ndarray | None, side_m: float) -> MarkerPose | None:
    """``cv2.solvePnP(..., SOLVEPNP_IPPE_SQUARE)``; None when it fails or puts the banner
    behind the camera.

    Parameters
    ----------
    centres : np.ndarray
        The four marker centres TL, TR, BR, BL, (4, 2), raw (distorted) pixels.
    K : np.ndarray
        3x3 camera intrinsic matrix, pixels.
    dist : np.ndarray or None
        OpenCV distortion coefficients; None for none.
    side_m : float
        Side of the markers' square (the paper's E), m.
    """
    obj = _square_points(side_m)
    img = np.ascontiguousarray(np.asarray(centres, np.float64)[[3, 2, 1, 0]]).reshape(4, 1, 2)
    d = dist if dist is not None else _NO_DISTORTION
    ok, rvec, tvec = cv2.solvePnP(obj, img, K, d, flags=cv2.SOLVEPNP_IPPE_SQUARE)
    if not ok:
        return None
    t = tvec.reshape(3)
    if not (np.isfinite(t).all() and np.isfinite(rvec).all()) or t[2] <= 0:
        return None  # IPPE says ok with NaN on a few exact, noise-free squares: no pose
    R, _ = cv2.Rodrigues(rvec)
    proj, _ = cv2.projectPoints(obj, rvec, tvec, K, d)
    err = float(np.sqrt(np.mean(np.sum((proj.reshape(4, 2) - img.reshape(4, 2)) ** 2, axis=1))))
    x_axis = R[:, 0]  # the banner's right axis in the camera frame
    rel = wrap_pi(math.atan2(-x_axis[2], x_axis[0]))
    quality = max(0.0, 1.0 - err / 3.0)
    return MarkerPose(t.copy(), math.hypot(t[0], t[2]), math.atan2(t[0], t[2]), rel, quality, "pnp", x_axis.copy())


def to_vehicle_frame(
    pose: MarkerPose, mount_body_m: np.ndarray, R_body_from_cam: np.ndarray, banner_offset_m: float
) -> tuple[float, float, float]:
    """Range (m), bearing (rad) and relative heading between the vehicles' reference points.

    The banner centre is moved from the camera frame into the follower's body frame (FRD),
    then ``banner_offset_m`` forward along the leader's heading to its reference point. The
    heading is the banner's right axis turned into the body frame when the pose has it
    (PnP), so that a pitched camera measures it in the horizontal.

    Parameters
    ----------
    pose : MarkerPose
        The banner in the camera frame.
    mount_body_m : np.ndarray
        The camera centre in the follower's body frame (FRD), m.
    R_body_from_cam : np.ndarray
        3x3 rotation from the camera frame to the body frame.
    banner_offset_m : float
        How far the banner is behind the leader's reference point, m.
    """
    p = mount_body_m + R_body_from_cam @ pose.centre_cam_m
    rel = pose.rel_heading_rad
    if pose.right_cam is not None:  # the banner's right axis in the body frame, levelled: exact at any pitch
        right_body = R_body_from_cam @ pose.right_cam
        if math.hypot(right_body[0], right_body[1]) > 1e-6:
            rel = math.atan2(-right_body[0], right_body[1])
    fwd = p[0] + banner_offset_m * math.cos(rel)
    right = p[1] + banner_offset_m * math.sin(rel)
    return math.hypot(fwd, right), math.atan2(right, fwd), rel
