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
        Horizontal distance from the camera to the banner centre, m: in the camera's x-z
        plane (PnP), or level (the paper's estimator).
    bearing_rad : float
        Bearing of the banner centre from the camera's axis, clockwise positive, rad (level,
        from the body's forward axis, for the paper's estimator).
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
        The banner's right axis in the camera frame, a unit vector (the paper's estimator
        gives it level: the pairs' horizontal offset).
    """

    centre_cam_m: np.ndarray
    range_m: float
    bearing_rad: float
    rel_heading_rad: float
    quality: float
    method: str
    right_cam: np.ndarray | None = None


#: the camera frame (x right, y down, z forward) in the body frame (FRD) of a level camera
_LEVEL = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
_LEVEL.flags.writeable = False


def paper_pose(
    centres: np.ndarray, K: np.ndarray, side_m: float, R_body_from_cam: np.ndarray | None = None
) -> MarkerPose | None:
    """Eq. 9-11 with the pinhole correction, measured level; None when a marker pair is under a
    pixel tall or not one above the other.

    The paper's rig is a level camera, where a vertical marker pair ``E`` tall at horizontal
    distance ``d`` spans ``f E / d`` pixels (eq. 10, pinhole form). Here each marker's ray is
    turned into the vehicle's level frame first (``R_body_from_cam``: the mount's pitch), where
    the same holds whatever the pitch: the pair's two rays climb ``tan_t`` and ``tan_b`` per
    metre of horizontal distance, so ``d = E / (tan_b - tan_t)``, and each pair stands at ``d``
    along its rays' horizontal direction (eq. 9 averages the two pairs, eq. 11 takes the
    range). For a level camera this is the paper's estimate exactly; measured in the camera's
    own frame, a camera pitched 10 or 20 degrees read ranges about 2 or 5 % short.
    :func:`pnp_pose` is tried first; this is its fallback.

    Parameters
    ----------
    centres : np.ndarray
        The four marker centres TL, TR, BR, BL, (4, 2), undistorted pixels.
    K : np.ndarray
        3x3 camera intrinsic matrix, pixels.
    side_m : float
        Side of the markers' square (the paper's E), m.
    R_body_from_cam : np.ndarray, optional
        3x3 rotation from the camera frame to the vehicle's body frame (FRD); None: a level
        camera looking forward.
    """
    tl, tr, br, bl = np.asarray(centres, float)
    if not np.all(np.isfinite(centres)) or np.linalg.norm(bl - tl) < 1.0 or np.linalg.norm(br - tr) < 1.0:
        return None
    R = _LEVEL if R_body_from_cam is None else np.asarray(R_body_from_cam, float)
    fx, fy = float(K[0, 0]), float(K[1, 1])
    cx, cy = float(K[0, 2]), float(K[1, 2])
    pts = np.array([tl, tr, br, bl])
    rays = np.column_stack([(pts[:, 0] - cx) / fx, (pts[:, 1] - cy) / fy, np.ones(4)]) @ R.T  # FRD
    flat = np.hypot(rays[:, 0], rays[:, 1])  # each ray's horizontal run per unit
    if np.any(flat < 1e-9):
        return None
    climb = rays[:, 2] / flat  # metres down per metre of horizontal distance
    heading = rays[:, :2] / flat[:, None]  # unit horizontal directions
    pairs = []
    for top, bottom in ((0, 3), (1, 2)):  # left pair TL-BL, right pair TR-BR
        drop = climb[bottom] - climb[top]
        if drop <= 0:  # the "bottom" marker not below the top one: no pair to measure
            return None
        d = side_m / drop  # eq. 10, level: the pair's horizontal distance
        where = d * (heading[top] + heading[bottom]) / 2
        pairs.append(np.array([where[0], where[1], d * (climb[top] + climb[bottom]) / 2]))
    left, right = pairs
    centre_body = (left + right) / 2  # eq. 9
    rng = math.hypot(centre_body[0], centre_body[1])  # eq. 11
    bearing = math.atan2(centre_body[1], centre_body[0])
    across = right[:2] - left[:2]  # the banner's right axis, level
    rel = wrap_pi(math.atan2(-across[0], across[1]))
    # quality: the pairs' gap should be E (the square's side); disagreement means a poor fit
    width = float(np.linalg.norm(across))
    quality = max(0.0, 1.0 - abs(width - side_m) / side_m)
    right_cam = R.T @ np.array([across[0], across[1], 0.0]) / width if width > 0 else None
    return MarkerPose(R.T @ centre_body, rng, bearing, rel, quality, "paper", right_cam)


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
