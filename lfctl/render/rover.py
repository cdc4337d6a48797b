"""The rover as the realistic renderer draws it: a chassis and a deck plate (boxes), four
wheels that touch the ground, the banner as a slab with thickness, and their shadows on the
ground (the sun's cast shadow and the dark contact patch under the body).

Geometry is in the body frame (FRD: x forward, y right, z down, the reference point on the
ground); every face is a convex polygon drawn flat-shaded, anti-aliased, with Lambert light
from the sun (:func:`sun_light`). Vectorised: one projection per vehicle.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

__all__ = [
    "CHASSIS",
    "DECK",
    "MESH",
    "WHEELS",
    "WHEEL_RADIUS_M",
    "Mesh",
    "banner_edges",
    "shadow_polygons",
    "sun_direction",
    "sun_light",
    "visible_faces",
]

#: chassis box: x from, x to, y half-width, z bottom (height above ground), z top, m
CHASSIS = (-0.15, 0.15, 0.085, 0.045, 0.14)
DECK = (-0.11, 0.12, 0.065, 0.14, 0.16)  # the deck plate on top
WHEEL_RADIUS_M = 0.048
WHEEL_WIDTH_M = 0.032
#: wheel centres, body frame (x, y), m: outside the chassis, touching the ground
WHEELS = ((0.095, 0.102), (0.095, -0.102), (-0.095, 0.102), (-0.095, -0.102))
_WHEEL_SEGMENTS = 16
_ANG = np.linspace(0, 2 * math.pi, _WHEEL_SEGMENTS, endpoint=False)
_RIM = np.stack([np.cos(_ANG), np.zeros_like(_ANG), np.sin(_ANG)], axis=1) * WHEEL_RADIUS_M  # a circle in x-z

CHASSIS_BGR = (62, 60, 58)
DECK_BGR = (128, 126, 122)
TYRE_BGR = (34, 33, 32)
HUB_BGR = (150, 148, 145)
EDGE_BGR = (205, 208, 210)  # the banner board's cut edges


def sun_direction(azimuth_rad: float, elevation_rad: float) -> np.ndarray:
    """Unit vector towards the sun in NED (its down component negative).

    Parameters
    ----------
    azimuth_rad : float
        From north, clockwise (east positive).
    elevation_rad : float
        Above the horizon.
    """
    ce = math.cos(elevation_rad)
    return np.array([ce * math.cos(azimuth_rad), ce * math.sin(azimuth_rad), -math.sin(elevation_rad)])


def sun_light(normal: np.ndarray | None, sun: np.ndarray, ambient: float, direct: float = 1.0) -> float:
    """The light a surface gets relative to the sunlit ground (1): ambient plus the sun's
    share by Lambert's cosine law, scaled so a horizontal surface in the sun gets 1.

    Parameters
    ----------
    normal : np.ndarray or None
        Outward unit normal, NED; None: a rounded surface, lit half as a face to the sun.
    sun : np.ndarray
        Unit vector to the sun (:func:`sun_direction`).
    ambient : float
        Share of the light that is not the sun's.
    direct : float
        How much of the sun reaches it (0 in a shadow).
    """
    up = max(-float(sun[2]), 1e-3)
    cos = 0.5 * up if normal is None else max(0.0, float(np.dot(normal, sun)))
    return min(1.8, ambient + (1.0 - ambient) * direct * cos / up)


def _box(x0: float, x1: float, hw: float, zb: float, zt: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """A box's five visible-from-somewhere faces (no bottom), body frame: (corners, normal)."""
    zt, zb = -zt, -zb  # heights to FRD z
    return [
        (np.array([(x0, -hw, zt), (x0, hw, zt), (x0, hw, zb), (x0, -hw, zb)]), np.array([-1.0, 0, 0])),
        (np.array([(x1, hw, zt), (x1, -hw, zt), (x1, -hw, zb), (x1, hw, zb)]), np.array([1.0, 0, 0])),
        (np.array([(x1, -hw, zt), (x0, -hw, zt), (x0, -hw, zb), (x1, -hw, zb)]), np.array([0, -1.0, 0])),
        (np.array([(x0, hw, zt), (x1, hw, zt), (x1, hw, zb), (x0, hw, zb)]), np.array([0, 1.0, 0])),
        (np.array([(x0, -hw, zt), (x1, -hw, zt), (x1, hw, zt), (x0, hw, zt)]), np.array([0, 0, -1.0])),
    ]


class Mesh:
    """The rover's faces in the body frame, packed for one projection per frame.

    Attributes: ``points`` (P, 3) every corner; ``faces`` a list of (start, end) rows of
    ``points``; ``normals`` (F, 3) outward (zero for a tyre, drawn as the hull of its rims,
    lit as a rounded surface); ``centres`` (F, 3); ``bgr`` (F, 3) albedo; ``wheel_side``
    (F,) +1 / -1 for a wheel's faces on the right / left, 0 for the body; ``order`` (F,).
    """

    def __init__(self) -> None:
        pts: list[np.ndarray] = []
        faces: list[tuple[int, int]] = []
        normals, bgr, side, order = [], [], [], []

        def add(p: np.ndarray, n: np.ndarray | None, colour: tuple[int, int, int], s: float, o: float) -> None:
            faces.append((sum(len(q) for q in pts), sum(len(q) for q in pts) + len(p)))
            pts.append(np.asarray(p, float))
            normals.append(np.zeros(3) if n is None else np.asarray(n, float))
            bgr.append(colour)
            side.append(s)
            order.append(o)

        for x, y in WHEELS:
            outer = 1.0 if y > 0 else -1.0
            centre = np.array([x, y, -WHEEL_RADIUS_M])
            half = np.array([0.0, WHEEL_WIDTH_M / 2, 0.0]) * outer
            add(np.vstack([centre + _RIM - half, centre + _RIM + half]), None, TYRE_BGR, outer, 0.0)
            add(centre + _RIM + half, np.array([0.0, outer, 0.0]), TYRE_BGR, outer, 1.0)
            add(centre + half * 1.05 + _RIM * 0.45, np.array([0.0, outer, 0.0]), HUB_BGR, outer, 2.0)
        for p, n in _box(*CHASSIS):
            add(p, n, CHASSIS_BGR, 0.0, 5.0)
        for p, n in _box(*DECK):
            add(p, n, DECK_BGR, 0.0, 6.0)
        self.points = np.vstack(pts)
        self.faces = faces
        self.normals = np.array(normals)
        self.centres = np.array([self.points[a:b].mean(axis=0) for a, b in faces])
        self.bgr = np.array(bgr, float)
        self.wheel_side = np.array(side)
        self.order = np.array(order)


MESH = Mesh()


def visible_faces(cam_body: np.ndarray) -> tuple[list[int], list[int]]:
    """Which of :data:`MESH`'s faces a camera at ``cam_body`` (body frame) sees, in painting
    order: those before the banner (the far side's wheels, the body) and those after it (the
    near side's wheels, nearer than the body).

    Parameters
    ----------
    cam_body : np.ndarray
        The camera's position in the rover's body frame (FRD), m.
    """
    m = MESH
    facing = np.einsum("ij,ij->i", m.normals, cam_body[None, :] - m.centres) > 0
    facing |= ~m.normals.any(axis=1)  # tyres: always drawn (as their silhouette)
    near_side = abs(float(cam_body[1])) > CHASSIS[2]
    late = near_side & (m.wheel_side * np.sign(cam_body[1]) > 0)
    idx = np.flatnonzero(facing)
    before = [int(i) for i in idx[~late[idx]]]
    after = [int(i) for i in idx[late[idx]]]
    before.sort(key=lambda i: m.order[i])
    after.sort(key=lambda i: m.order[i])
    return before, after


def banner_edges(
    corners: np.ndarray, yaw_rad: float, thickness_m: float, camera_m: np.ndarray
) -> list[tuple[np.ndarray, np.ndarray]]:
    """The banner board's cut edges (top, right, left) that face the camera: (corners, normal), NED.

    Parameters
    ----------
    corners : np.ndarray
        The printed face (4, 3), TL, TR, BR, BL as seen from behind.
    yaw_rad : float
        The rover's heading.
    thickness_m : float
        The board's thickness (0: none drawn).
    camera_m : np.ndarray
        The camera, NED.
    """
    if thickness_m <= 0:
        return []
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    fwd = np.array([c, s, 0.0]) * thickness_m
    right = np.array([-s, c, 0.0])
    tl, tr, br, bl = corners
    out = []
    for a, b, n in ((tl, tr, np.array([0.0, 0.0, -1.0])), (tr, br, right), (bl, tl, -right)):
        pts = np.array([a, b, b + fwd, a + fwd])
        if float(np.dot(n, camera_m - pts.mean(axis=0))) > 0:
            out.append((pts, n))
    return out


def shadow_polygons(
    north_m: float, east_m: float, yaw_rad: float, sun: np.ndarray, banner_corners: np.ndarray | None
) -> tuple[list[np.ndarray], np.ndarray]:
    """The rover's shadows on the ground (z = 0), NED: the sun's cast shadow (the body with
    its wheels as one hull, and the banner's board) and the contact patch under the body.

    Parameters
    ----------
    north_m, east_m, yaw_rad : float
        The rover's pose.
    sun : np.ndarray
        Unit vector to the sun.
    banner_corners : np.ndarray or None
        The banner's corners, NED, or None.
    """
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    t = np.array([north_m, east_m, 0.0])
    x0, x1, hw, _zb, zt = CHASSIS
    top = np.array([(x0, -hw, -zt), (x1, -hw, -zt), (x1, hw, -zt), (x0, hw, -zt)])
    wheels = np.array([(x, y + 0.016 * np.sign(y), -2 * WHEEL_RADIUS_M * 0.8) for x, y in WHEELS])
    body = np.vstack([top, wheels]) @ R.T + t

    # the ray from the sun through p meets the ground at p - sun p_z / sun_z
    def cast(p: np.ndarray) -> np.ndarray:
        return p - sun[None, :] * (p[:, 2:3] / float(sun[2]))

    foot = body.copy()
    foot[:, 2] = 0.0
    polys = [_hull_xy(np.vstack([cast(body), foot]))]
    if banner_corners is not None:
        polys.append(cast(np.asarray(banner_corners, float)))
    # the contact patch: the footprint of body and wheels, a little larger
    fx0, fx1, fhw = x0 - 0.02, x1 + 0.02, max(y for _x, y in WHEELS) + WHEEL_WIDTH_M / 2 + 0.015
    patch = np.array([(fx0, -fhw, 0.0), (fx1, -fhw, 0.0), (fx1, fhw, 0.0), (fx0, fhw, 0.0)]) @ R.T + t
    return polys, patch


def _hull_xy(pts: np.ndarray) -> np.ndarray:
    """The convex hull of points on the ground (their x, y), as (M, 3) with z = 0."""
    hull = cv2.convexHull(np.ascontiguousarray(np.asarray(pts, np.float32)[:, :2]))[:, 0, :].astype(float)
    return np.c_[hull, np.zeros(len(hull))]
