"""The simulated sensor: a pinhole camera on a follower, rendering the world truth.

Everything is a plane: a textured ground (one homography, tiled with BORDER_WRAP), vertical
textured panels (walls, props, distractors, occluders, the leader's banner) and the
vehicles' box bodies. Planes are clipped at the near plane, warped only inside their
bounding box and painted far to near. Lighting (gain and tint key frames, flicker, a
sweeping shadow band), sensor noise (a seeded bank of noise frames) and optional motion
blur follow. Deterministic for a seed; no per-pixel Python.

Per frame it also returns the ground truth the benchmarks score against: the target's
banner bounding box and marker centres, its visible fraction, and the true range, bearing
and relative heading.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import cv2
import numpy as np

from lfctl.config import BannerConfig, CameraConfig, LightKey, SceneConfig
from lfctl.frames import rot_z, wrap_pi
from lfctl.render import footage
from lfctl.render.lens import Lens
from lfctl.render.rover import EDGE_BGR, MESH, banner_edges, shadow_polygons, sun_direction, sun_light, visible_faces
from lfctl.render.sensor import Sensor
from lfctl.render.tag_texture import tag_banner_texture
from lfctl.render.textures import (
    banner_texture,
    ground_texture,
    noise_texture,
    panel_sizes,
    periodic_pyramid,
    prop_texture,
    real_banner_texture,
    real_ground_texture,
    real_wall_texture,
)
from lfctl.vision.banner import BannerGeometry
from lfctl.vision.boxes import point_bounds
from lfctl.vision.camera_model import CameraModel

__all__ = ["FrameTruth", "Renderer", "VehiclePose"]

NEAR_M = 0.05
FAR_GROUND_M = 40.0  # the realistic floor ends this far away: the background's foot hides the rest
GROUND_TILES = 3  # the floor texture tiled GROUND_TILES x GROUND_TILES for the fast warp path
GROUND_LEVELS = 4  # floor mip levels: full, 1/2, 1/4, 1/8 of the texture's resolution
BODY_LENGTH_M, BODY_WIDTH_M, BODY_BOTTOM_M, BODY_TOP_M = 0.30, 0.22, 0.03, 0.14


# ---------------------------------------------------------------------------------------
# Geometry helpers


def _clip_near(points_cam: np.ndarray) -> np.ndarray:
    """Clip a convex polygon (N, 3) in camera coordinates to z >= NEAR_M."""
    out = []
    n = len(points_cam)
    for i in range(n):
        a, b = points_cam[i], points_cam[(i + 1) % n]
        a_in, b_in = a[2] >= NEAR_M, b[2] >= NEAR_M
        if a_in:
            out.append(a)
        if a_in != b_in:
            t = (NEAR_M - a[2]) / (b[2] - a[2])
            out.append(a + t * (b - a))
    return np.array(out) if out else np.empty((0, 3))


def _pixel_box(poly: np.ndarray, shape: tuple[int, ...]) -> tuple[int, int, int, int] | None:
    """The pixels (x0, y0, x1, y1; x1, y1 exclusive) an image polygon covers inside an image
    of ``shape``, or None when it covers none."""
    H_img, W_img = shape[:2]
    x0, y0, x1, y1 = point_bounds(poly)
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, W_img), min(y1, H_img)
    if x1 <= x0 or y1 <= y0:
        return None
    return x0, y0, x1, y1


def _mean(a: np.ndarray, axis: int) -> np.ndarray:
    """``a.mean(axis)`` as numpy computes it for floats (np.add.reduce, then a division by
    the count), without its ~5 us of Python around the two calls."""
    return np.add.reduce(a, axis=axis) / a.shape[axis]


def _distance(a: np.ndarray, b: np.ndarray) -> float:
    """|a - b| of two 3-vectors exactly as np.linalg.norm computes it (the square root of
    the difference's dot product with itself), without its ~3 us of checks."""
    d = a - b
    return math.sqrt(d.dot(d))


def _unit_cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b, normalised (np.cross costs ~20 us a call)."""
    x = float(a[1] * b[2] - a[2] * b[1])
    y = float(a[2] * b[0] - a[0] * b[2])
    z = float(a[0] * b[1] - a[1] * b[0])
    n = math.sqrt(x * x + y * y + z * z) or 1.0
    return np.array([x / n, y / n, z / n])


def _panels(scene: SceneConfig, seed: int) -> tuple[list[tuple[int, int]], list[np.ndarray]]:
    """The props' texture sizes (width, height) px, and the occluders' textures, all within
    one budget (:func:`panel_sizes`)."""
    sizes = panel_sizes(
        [(p.width_m, p.height_m) for p in scene.props] + [(o.width_m, o.height_m) for o in scene.occluders]
    )
    occ_rng = np.random.default_rng(seed + 1)
    occluders = [noise_texture(occ_rng, h, w, (90, 80, 60), 20.0, 2) for w, h in sizes[len(scene.props) :]]
    return sizes[: len(scene.props)], occluders


@dataclass(frozen=True)
class Plane:
    """A textured rectangle: origin (top-left), axes along texture x and y (world m per px)."""

    origin: np.ndarray
    ax: np.ndarray  # world vector per texture pixel along x
    ay: np.ndarray  # along y
    texture: np.ndarray | None  # None: flat colour
    colour: tuple[int, int, int] = (0, 0, 0)

    @cached_property
    def corners(self) -> np.ndarray:
        """World corners (4, 3): origin, along x, opposite, along y."""
        h, w = (self.texture.shape[:2]) if self.texture is not None else (1, 1)
        o, ax, ay = self.origin, self.ax * w, self.ay * h
        out = np.empty((4, 3))  # np.array([o, o + ax, o + ax + ay, o + ay]) without its list walk
        out[0], out[1], out[2], out[3] = o, o + ax, o + ax + ay, o + ay
        return out

    @cached_property
    def centre(self) -> np.ndarray:
        return _mean(self.corners, 0)

    @cached_property
    def texel_m(self) -> float:
        """The longer side of a texel, m (kept with the plane: a static prop's is reused)."""
        return max(float(np.linalg.norm(self.ax)), float(np.linalg.norm(self.ay)))


class _Face(NamedTuple):
    """A flat-shaded box face: its world corners (4, 3) as :attr:`Plane.corners` lays them
    out, and its colour."""

    corners: np.ndarray
    colour: tuple[int, int, int]


# ---------------------------------------------------------------------------------------
# Frame truth and vehicles


def _box_faces() -> tuple[np.ndarray, np.ndarray, tuple[tuple[int, int, int], ...], tuple[str, ...]]:
    """The body box's faces in the body frame (FRD): corners laid out as seen from outside
    (first to second: the viewer's right; first to fourth: down), outward normals, colours."""
    L, W = BODY_LENGTH_M / 2, BODY_WIDTH_M / 2
    zt, zb = -BODY_TOP_M, -BODY_BOTTOM_M
    faces = {
        "back": ([(-L, -W, zt), (-L, W, zt), (-L, W, zb), (-L, -W, zb)], (-1, 0, 0), (55, 55, 60)),
        "front": ([(L, W, zt), (L, -W, zt), (L, -W, zb), (L, W, zb)], (1, 0, 0), (60, 60, 65)),
        "left": ([(L, -W, zt), (-L, -W, zt), (-L, -W, zb), (L, -W, zb)], (0, -1, 0), (45, 45, 50)),
        "right": ([(-L, W, zt), (L, W, zt), (L, W, zb), (-L, W, zb)], (0, 1, 0), (45, 45, 50)),
        "top": ([(-L, -W, zt), (L, -W, zt), (L, W, zt), (-L, W, zt)], (0, 0, -1), (80, 80, 85)),
    }
    corners = np.array([f[0] for f in faces.values()], dtype=float)
    normals = np.array([f[1] for f in faces.values()], dtype=float)
    return corners, normals, tuple(f[2] for f in faces.values()), tuple(faces)


_BOX_FACES, _BOX_NORMALS, _BOX_COLOURS, _BOX_NAMES = _box_faces()


@dataclass(frozen=True)
class VehiclePose:
    """A vehicle to draw."""

    north_m: float  # reference point, local NED
    east_m: float  # reference point, local NED
    yaw_rad: float  # heading
    banner: bool = True  # draw the banner on its back
    #: the ArUco tag its banner prints (``banner.kind = "aruco"``); None: ``banner.aruco_id``
    tag_id: int | None = None


@dataclass(frozen=True)
class FrameTruth:
    """What the frame shows of the target, from the world truth."""

    t_s: float  # the frame's time, s
    bbox: tuple[int, int, int, int] | None  # banner x, y, w, h in pixels (clipped), None if off-image
    markers_px: np.ndarray  # (4, 2) projected marker centres TL, TR, BR, BL as seen
    visible_fraction: float  # of the banner's in-image area not hidden by nearer things
    in_view: bool  # banner in front of the camera and at least partly inside the image
    range_m: float  # follower reference point to target reference point
    bearing_rad: float  # of the target's reference point from the follower's heading, clockwise positive
    rel_heading_rad: float  # target yaw - follower yaw
    banner_cam_m: np.ndarray  # banner centre in the camera frame


class Renderer:
    """Renders one follower's camera view. Build once per follower; call :meth:`render`.

    Parameters
    ----------
    camera : CameraConfig
        The follower's camera: intrinsics, distortion, mount, noise, motion blur.
    banner : BannerConfig
        The banner drawn on the vehicles that carry one (see :class:`VehiclePose`).
    scene : SceneConfig
        Ground, props, occluders and lighting.
    seed : int
        Seeds every texture and the sensor noise: same seed, same frames.
    """

    def __init__(self, camera: CameraConfig, banner: BannerConfig, scene: SceneConfig, seed: int) -> None:
        self.cfg = camera
        true_cam = CameraModel.from_config(camera)
        #: the camera's lens when it bends (distortion coefficients), else None
        self.lens = Lens(true_cam) if np.any(true_cam.dist != 0) else None
        #: the pinhole camera the scene is drawn with: the camera's own, or the lens's canvas
        self.cam = true_cam if self.lens is None else self.lens.canvas_camera(true_cam)
        self._fx = float(true_cam.K[0, 0])  # the picture's focal length (blur lengths), px
        self.banner = banner
        self.geometry = BannerGeometry.from_config(banner)
        self.scene = scene
        self.realism = scene.realism == "on"
        self._occ_state: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._pyramids: dict[int, list[np.ndarray]] = {}
        self._static_props: dict[tuple[int, float], Plane] = {}  # see _props
        self._last_banner_frame: tuple[VehiclePose, tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None
        self._tag_seed = seed + 4  # every tag's panel is printed on the same paper
        self._tag_tex: dict[int, np.ndarray] = {}  # by tag id (_tag_texture)
        if self.realism:
            self._init_real(seed)
        else:
            self._init_flat(seed)

    def _init_flat(self, seed: int) -> None:
        """The old look (scene.realism = "off"): exactly the frames lfctl drew before."""
        camera, banner, scene = self.cfg, self.banner, self.scene
        rng = np.random.default_rng(seed)
        self.banner_tex, _marks = banner_texture(banner, rng)
        if banner.kind == "aruco":  # the same panel with a tag instead (the rest of the scene unchanged)
            self.banner_tex = self._tag_texture(banner.aruco_id)
        self.ground_tex, self.ground_px_per_m = ground_texture(scene.ground, rng)
        self._ground_levels = periodic_pyramid(self.ground_tex, GROUND_LEVELS)
        # each level repeated 3 x 3: warpPerspective's fast path only samples inside the
        # source image, and wrapping costs ~5x per pixel; centred on the visible floor, most
        # samples land inside and the picture is the same (the texture is periodic). As BGRA:
        # the warp computes each channel as it does for BGR, at ~0.6 of the time (_paint_ground)
        self._ground_tiles = [
            np.tile(cv2.cvtColor(t, cv2.COLOR_BGR2BGRA), (GROUND_TILES, GROUND_TILES, 1)) for t in self._ground_levels
        ]
        props_px, self.occluder_tex = _panels(scene, seed)
        self.prop_tex = [prop_texture(p, banner, rng, size) for p, size in zip(scene.props, props_px, strict=True)]
        w, h = camera.width_px, camera.height_px
        noise_rng = np.random.default_rng(seed + 2)
        # noise frames as (positive, negative) uint8 halves: two saturating uint8 ops per frame
        # instead of a mixed-type add (which costs ~1 ms at 640x480)
        self._noise: list[tuple[np.ndarray, np.ndarray]] = []
        for _ in range(6 if camera.noise_sigma > 0 else 0):
            # normal(0, sigma) is 0 + sigma * standard_normal() element by element: the same
            # draws scaled in place, ~20 % faster than numpy's per-element call
            n = noise_rng.standard_normal((h, w, 3))
            n = np.round(np.multiply(n, camera.noise_sigma, out=n), out=n)
            plus = np.clip(n, 0, 255).astype(np.uint8)
            # the negative half from n negated in place: no second 7 MB array (~4 ms a frame)
            minus = np.clip(np.negative(n, out=n), 0, 255, out=n).astype(np.uint8)
            self._noise.append((plus, minus))
        self._frame_rng = np.random.default_rng(seed + 3)
        # the background (sky, floor and the props behind every vehicle) is drawn at half
        # resolution and scaled up: _half_K maps the scene into that layer exactly as
        # cv2.resize maps the layer back (pixel centres at (x + 0.5) * scale - 0.5)
        self._half_size = ((w + 1) // 2, (h + 1) // 2)
        sx, sy = self._half_size[0] / w, self._half_size[1] / h
        self._half_K = np.array([[sx, 0.0, 0.5 * sx - 0.5], [0.0, sy, 0.5 * sy - 0.5], [0.0, 0.0, 1.0]]) @ self.cam.K
        self._sky_half = cv2.resize(self._sky_image(), self._half_size, interpolation=cv2.INTER_AREA)
        # the bare sky layer scaled up, for the rows of a frame whose layer rows are bare
        # sky (see _upscale); only where the layer is exactly half the frame's size
        self._sky_full = (
            cv2.resize(self._sky_half, (w, h), interpolation=cv2.INTER_LINEAR)
            if (2 * self._half_size[0], 2 * self._half_size[1]) == (w, h)
            else None
        )
        self._ground_bands = self._ground_band_levels()
        self._init_ground_bands()

    def _init_ground_bands(self) -> None:
        """What :meth:`_paint_ground` needs per band that never changes, built once: the
        matrices :func:`_band_homography` multiplies the floor's homography by (stacked, so
        one matmul does every band, item by item as the 3 x 3 products did), the band's
        middle pixel, the level's tile and its period, the band's rows of a BGRA scratch layer
        the warp writes and the layer's rows they are copied to. The layer itself is reused
        frame after frame (it never leaves the renderer): the floor's warps write every pixel
        of their rows, so only the other rows are copied from the sky."""
        w, h = self._half_size
        bands = self._ground_bands
        self._layer = self._sky_half.copy()
        scratch = np.zeros((h, w, 4), np.uint8)
        self._band_shift = np.array([[[1.0, 0.0, 0.0], [0.0, 1.0, -r0], [0.0, 0.0, 1.0]] for r0, _r1, _l in bands])
        self._band_to_level = np.array(
            [
                [[2**lv, 0.0, (2**lv - 1) / 2.0], [0.0, 2**lv, (2**lv - 1) / 2.0], [0.0, 0.0, 1.0]]
                for _r0, _r1, lv in bands
            ]
        )
        self._band_eye = np.array([np.eye(3)] * len(bands)).reshape(len(bands), 3, 3)
        self._band_mid = np.array([[[w / 2.0], [(r1 - r0) / 2.0], [1.0]] for r0, r1, _l in bands])
        self._band_paint = [
            (
                self._ground_tiles[lv],
                self._ground_levels[lv].shape[1],
                self._ground_levels[lv].shape[0],
                scratch[r0:r1],
                self._layer[r0:r1],
            )
            for r0, r1, lv in bands
        ]
        covered = np.zeros(h, bool)
        for r0, r1, _l in bands:
            covered[r0:r1] = True
        edges = np.flatnonzero(np.diff(np.concatenate([[False], ~covered, [False]]).astype(np.int8)))
        self._sky_rows = [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]

    # -- static parts -------------------------------------------------------------------
    def _sky_image(self) -> np.ndarray:
        h, w = self.cfg.height_px, self.cfg.width_px
        ramp = np.linspace(0.0, 1.0, h, dtype=np.float32)[:, None]
        top, bottom = np.array([235, 225, 215], np.float32), np.array([190, 190, 185], np.float32)
        img = top + (bottom - top) * ramp[..., None]
        return np.broadcast_to(img, (h, w, 3)).astype(np.uint8).copy()

    def _ground_band_levels(self) -> list[tuple[int, int, int]]:
        """Bands of half-resolution rows that see the floor, each with the mip level to draw it at.

        The camera moves in the plane at a fixed height and pitch, so the floor's distance in
        each image row, and the size of a pixel's footprint on it, never change: the level
        whose texel is about one footprint (geometric mean of its two sides) is chosen per
        row once. Far rows take coarse levels, which is what a pixel integrating light
        over a long footprint sees, and keeps the warp's reads in cache.
        """
        Kinv = np.linalg.inv(self._half_K)
        R = self.cam.R_body_from_cam
        height = -float(self.cam.mount_body_m[2])
        w, h = self._half_size
        cx = self._half_K[0, 2]
        rows: list[tuple[int, int]] = []
        for r in range(h):
            rays = R @ Kinv @ np.array([[0.0, w - 1.0, cx, cx + 1.0, cx], [r, r, r, r, r + 1.0], [1.0] * 5])
            if not np.all(rays[2] > 1e-6):
                continue
            hits = rays[:2] * (height / rays[2])  # body-frame floor points, m
            across = float(np.linalg.norm(hits[:, 3] - hits[:, 2]))
            along = float(np.linalg.norm(hits[:, 4] - hits[:, 2]))
            texels = math.sqrt(across * along) * self.ground_px_per_m
            level = min(len(self._ground_levels) - 1, max(0, math.floor(math.log2(max(texels, 1.0)))))
            rows.append((r, level))
        bands: list[tuple[int, int, int]] = []
        for r, level in rows:
            if bands and bands[-1][2] == level and bands[-1][1] == r:
                bands[-1] = (bands[-1][0], r + 1, level)
            else:
                bands.append((r, r + 1, level))
        return bands

    # -- painting ----------------------------------------------------------------------
    def _project(self, R: np.ndarray, c: np.ndarray, pts: np.ndarray) -> np.ndarray:
        cam = (R @ (pts - c).T).T
        return cam

    def _ground_homography(self, K: np.ndarray, R: np.ndarray, c: np.ndarray) -> np.ndarray:
        """Level-0 ground texture pixel -> image pixel through camera matrix ``K``."""
        s = self.ground_px_per_m
        # texture pixel (a, b) of level 0 is the world point (a / s, b / s, 0)
        Rt = np.empty((3, 4))  # [R | -R c], C-ordered as np.hstack made it
        Rt[:, :3] = R
        Rt[:, 3] = -R @ c
        return (K @ Rt) @ np.array([[1.0 / s, 0.0, 0.0], [0.0, 1.0 / s, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]])

    def _paint_ground(self, R: np.ndarray, c: np.ndarray) -> None:
        """Draw the floor into the half-resolution background layer (``self._layer``, which
        the bands' views built once look into), band by band. Every band's homography, the
        texel under its middle pixel and the shift to the middle tile are computed for all
        bands at once, with the same 3 x 3 products and solves as one band at a time (the
        warps see bit-identical matrices). Each band is warped from the BGRA tiles into the
        BGRA scratch and its colour copied into the layer: the same pixels as a BGR warp
        (0.29 -> 0.17 ms a frame for the four bands, with the copies, on the convoy's poses)."""
        if not self._band_paint:
            return
        Hg = self._ground_homography(self._half_K, R, c)
        Ms = self._band_shift @ Hg @ self._band_to_level  # _band_homography of every band
        # move by whole texture periods so the floor seen mid-band is in the middle tile
        q = np.linalg.solve(Ms, self._band_mid)[:, :, 0].tolist()
        shifts = self._band_eye.copy()
        for k, ((qx, qy, qw), (_tile, pw, ph, _bgra, _dst)) in enumerate(zip(q, self._band_paint, strict=True)):
            shifts[k, 0, 2] = (math.floor(qx / qw / pw) - GROUND_TILES // 2) * pw
            shifts[k, 1, 2] = (math.floor(qy / qw / ph) - GROUND_TILES // 2) * ph
        Ms = Ms @ shifts
        w = self._layer.shape[1]
        for M, (tile, _pw, _ph, bgra, dst) in zip(Ms, self._band_paint, strict=True):
            cv2.warpPerspective(
                tile, M, (w, dst.shape[0]), dst=bgra, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP
            )
            cv2.cvtColor(bgra, cv2.COLOR_BGRA2BGR, dst=dst)

    def _texture_to_roi(
        self, plane: Plane, R: np.ndarray, c: np.ndarray, K: np.ndarray, x0: int, y0: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """The plane's texture at the mip level its distance asks for, and the homography
        from it to the image region whose top-left is (x0, y0): K [R ax, R ay, R (o - c)],
        shifted to the region."""
        tex, ax, ay, origin = self._mip_level(plane, R, c, float(K[0, 0]))
        cols = np.empty((3, 3))  # as np.column_stack lays them out (C order), at a tenth of its cost
        cols[:, 0], cols[:, 1], cols[:, 2] = R @ ax, R @ ay, R @ (origin - c)
        Hp = K @ cols
        return tex, np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]]) @ Hp

    def _paint_plane(
        self, img: np.ndarray, R: np.ndarray, c: np.ndarray, plane: Plane | _Face, K: np.ndarray
    ) -> np.ndarray | None:
        """Warp a plane (or fill a face) into ``img`` (intrinsics ``K``); returns its image
        polygon (or None if not visible)."""
        cam_pts = self._project(R, c, plane.corners)
        if (cam_pts[:, 2] >= NEAR_M).all():
            # what _clip_near gives for it (its rows, C-ordered), without its loop
            clipped = np.ascontiguousarray(cam_pts)
        else:
            clipped = _clip_near(cam_pts)
            if len(clipped) < 3:
                return None
        uv = (K @ clipped.T).T
        poly = uv[:, :2] / uv[:, 2:3]
        box = _pixel_box(poly, img.shape)
        if box is None:
            return None
        x0, y0, x1, y1 = box
        if isinstance(plane, _Face) or plane.texture is None:
            cv2.fillPoly(img, [np.round(poly * 16).astype(np.int32)], plane.colour, cv2.LINE_AA, shift=4)
            return poly
        sub = img[y0:y1, x0:x1]
        mask = np.zeros(sub.shape[:2], np.uint8)
        cv2.fillPoly(mask, [np.round((poly - [x0, y0]) * 16).astype(np.int32)], 255, cv2.LINE_8, shift=4)
        tex, Hp = self._texture_to_roi(plane, R, c, K, x0, y0)
        warped = cv2.warpPerspective(
            tex, Hp, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
        )
        cv2.copyTo(warped, mask, sub)  # in place into the view (numpy masked copy is ~80x slower)
        return poly

    def _mip_level(
        self, plane: Plane, R: np.ndarray, c: np.ndarray, fx: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The pyramid level of the plane's texture whose texels are about a pixel on screen.

        warpPerspective samples points; drawing a texture much finer than the pixels aliases
        edges and biases small features (a marker's centroid moved by half a pixel). A
        camera integrates light over each pixel; a texture pre-filtered to the screen scale
        (a mip level, cv2.pyrDown) is the cheap equivalent.
        """
        assert plane.texture is not None
        centre = plane.centre
        depth = float((R @ (centre - c))[2])
        if depth <= NEAR_M:
            return plane.texture, plane.ax, plane.ay, plane.origin
        texel_px = fx * plane.texel_m / depth
        level = 0
        while texel_px * (2 ** (level + 1)) <= 1.0 and level < 4:
            level += 1
        if level == 0:
            return plane.texture, plane.ax, plane.ay, plane.origin
        pyr = self._pyramids.get(id(plane.texture))
        if pyr is None:
            pyr = [plane.texture]
            self._pyramids[id(plane.texture)] = pyr
        while len(pyr) <= level:
            pyr.append(cv2.pyrDown(pyr[-1]))
        k = 2**level
        # texel i of level L covers texels k i .. k i + k - 1 of level 0: centre k i + (k - 1) / 2
        origin = plane.origin + (plane.ax + plane.ay) * (k - 1) / 2.0
        return pyr[level], plane.ax * k, plane.ay * k, origin

    def _tag_texture(self, tag_id: int) -> np.ndarray:
        """The panel printed with tag ``tag_id`` (made once per id; the same paper for every
        id). BGRA for the realistic look (opaque), BGR for the flat one."""
        tex = self._tag_tex.get(tag_id)
        if tex is None:
            cfg = dataclasses.replace(self.banner, aruco_id=tag_id)
            tex, _corners = tag_banner_texture(cfg, np.random.default_rng(self._tag_seed))
            if self.realism:
                tex = cv2.cvtColor(tex, cv2.COLOR_BGR2BGRA)
            self._tag_tex[tag_id] = tex
        return tex

    def _banner_texture(self, v: VehiclePose) -> np.ndarray:
        """What vehicle ``v``'s banner shows: its own tag with ``banner.kind = "aruco"``."""
        if self.banner.kind != "aruco" or v.tag_id is None:
            return self.banner_tex
        return self._tag_texture(v.tag_id)

    def _banner_frame(self, v: VehiclePose) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The banner's centre, right and down of vehicle ``v`` (geometry.frame_ned), kept for
        the last vehicle asked: the target's is wanted twice a frame, for its plane and its
        truth (the same pose object, which is frozen)."""
        last = self._last_banner_frame
        if last is not None and last[0] is v:
            return last[1]
        frame = self.geometry.frame_ned(v.north_m, v.east_m, v.yaw_rad)
        self._last_banner_frame = (v, frame)
        return frame

    def _vehicle_faces(self, v: VehiclePose, c: np.ndarray) -> list[tuple[float, Plane | _Face, str]]:
        """The vehicle's box faces (flat shaded) and banner that face the camera at ``c``, with distances."""
        Rz = rot_z(v.yaw_rad)
        pts = np.array([v.north_m, v.east_m, 0.0]) + _BOX_FACES @ Rz.T  # (5, 4, 3) world corners
        centres = _mean(pts, 1)
        outward = _BOX_NORMALS @ Rz.T
        # back-face culling: a face is seen only from the side its outward normal points to
        facing = (np.einsum("ij,ij->i", outward, c - centres) > 0).tolist()
        d = centres - c
        dist = np.sqrt(np.add.reduce(d * d, axis=1)).tolist()  # np.linalg.norm(d, axis=1)'s own sums
        # every face's corners as Plane(p0, p1 - p0, p3 - p0).corners computes them (the same
        # sums, element by element, all faces at once)
        o = pts[:, 0]
        ax, ay = pts[:, 1] - o, pts[:, 3] - o
        corners = np.empty((len(pts), 4, 3))
        corners[:, 0] = o
        corners[:, 1] = o + ax
        corners[:, 2] = o + ax + ay
        corners[:, 3] = o + ay
        out: list[tuple[float, Plane | _Face, str]] = [
            (dist[k], _Face(corners[k], _BOX_COLOURS[k]), _BOX_NAMES[k]) for k in range(len(facing)) if facing[k]
        ]
        if v.banner:
            centre, right, down = self._banner_frame(v)
            if float(np.dot(Rz[:, 0], centre - c)) > 0:  # seen from behind the vehicle
                tex = self._banner_texture(v)
                size = tex.shape[0]
                half = self.banner.panel_size_m / 2
                origin = centre - right * half - down * half
                px = self.banner.panel_size_m / size
                # 1 cm nearer than the back face it is mounted on, so it is painted after it
                plane = Plane(origin, right * px, down * px, tex)
                out.append((_distance(plane.centre, c) - 0.01, plane, "banner"))
        return out

    def _occluders(self, t_s: float, follower: VehiclePose, target: VehiclePose, follower_name: str) -> list[Plane]:
        planes = []
        for i, occ in enumerate(self.scene.occluders):
            if occ.follower and occ.follower != follower_name:
                continue
            if t_s < occ.t_s:
                continue
            if i not in self._occ_state:
                # spawn beside the line of sight, then move straight across it
                f = np.array([follower.north_m, follower.east_m])
                g = np.array([target.north_m, target.east_m])
                d = g - f
                n = np.linalg.norm(d)
                u = d / n if n > 0 else np.array([1.0, 0.0])
                left = np.array([u[1], -u[0]])  # NED: left of the line of sight
                start = f + occ.fraction * d + left * occ.lateral_m
                self._occ_state[i] = (start, -left * occ.speed_mps)
            start, vel = self._occ_state[i]
            pos = start + vel * (t_s - occ.t_s)
            if np.linalg.norm(pos - start) > 2 * occ.lateral_m + occ.width_m:
                continue  # gone by
            # the panel faces along the line of motion's normal (the follower's side)
            across = vel / max(np.linalg.norm(vel), 1e-9)
            tex = self.occluder_tex[i]
            h, w = tex.shape[:2]
            origin = np.array([pos[0], pos[1], -occ.height_m]) - np.array([across[0], across[1], 0.0]) * occ.width_m / 2
            ax = np.array([across[0], across[1], 0.0]) * occ.width_m / w
            ay = np.array([0.0, 0.0, occ.height_m / h])
            planes.append(Plane(origin, ax, ay, tex))
        return planes

    def _props(self, t_s: float) -> list[Plane]:
        """The props' panels at ``t_s``. A prop that does not move gives the same plane every
        frame (its position plus a zero: the sign of that zero, which follows t's, is the
        only thing t can change), so it is built once per sign and kept with its cached
        corners, centre and texel size."""
        planes = []
        sign = math.copysign(1.0, t_s) if math.isfinite(t_s) else None
        for i, (p, tex) in enumerate(zip(self.scene.props, self.prop_tex, strict=True)):
            key = (i, sign) if sign is not None and p.vel_north_mps == 0.0 and p.vel_east_mps == 0.0 else None
            if key is not None:
                kept = self._static_props.get(key)
                if kept is not None:
                    planes.append(kept)
                    continue
            n, e = p.north_m + p.vel_north_mps * t_s, p.east_m + p.vel_east_mps * t_s
            # panel plane: normal along yaw; texture x runs to the right of a viewer facing it
            normal = np.array([math.cos(p.yaw_rad), math.sin(p.yaw_rad), 0.0])
            right = np.array([-normal[1], normal[0], 0.0])  # viewer faces -normal; their right
            h, w = tex.shape[:2]
            origin = np.array([n, e, -(p.base_m + p.height_m)]) - right * p.width_m / 2
            plane = Plane(origin, right * p.width_m / w, np.array([0.0, 0.0, p.height_m / h]), tex)
            if key is not None:
                self._static_props[key] = plane
            planes.append(plane)
        return planes

    # -- lighting -----------------------------------------------------------------------
    def light(self, t_s: float) -> tuple[float, np.ndarray]:
        """Global gain and BGR tint at ``t_s`` (key frames interpolated, then flicker).

        Parameters
        ----------
        t_s : float
            Scene time, s.
        """
        keys: tuple[LightKey, ...] = self.scene.lighting
        gain, tint = 1.0, np.ones(3)
        if keys:
            if t_s <= keys[0].t_s:
                gain, tint = keys[0].gain, np.array(keys[0].tint_bgr)
            elif t_s >= keys[-1].t_s:
                gain, tint = keys[-1].gain, np.array(keys[-1].tint_bgr)
            else:
                for a, b in itertools.pairwise(keys):
                    if a.t_s <= t_s <= b.t_s:
                        f = (t_s - a.t_s) / (b.t_s - a.t_s) if b.t_s > a.t_s else 1.0
                        gain = a.gain + f * (b.gain - a.gain)
                        tint = np.array(a.tint_bgr) + f * (np.array(b.tint_bgr) - np.array(a.tint_bgr))
                        break
        if self.scene.flicker_amplitude > 0 and self.scene.flicker_hz > 0:
            gain *= 1.0 + self.scene.flicker_amplitude * math.sin(2 * math.pi * self.scene.flicker_hz * t_s)
        return gain, tint

    # -- the frame -----------------------------------------------------------------------
    def render(
        self,
        t_s: float,
        follower: VehiclePose,
        others: Sequence[VehiclePose],
        target_index: int,
        follower_name: str = "",
        yaw_rate_radps: float = 0.0,
    ) -> tuple[np.ndarray, FrameTruth]:
        """Render the follower's view at ``t_s``: the BGR frame and its ground truth.

        Parameters
        ----------
        t_s : float
            Scene time, s (moving props, occluders, lighting).
        follower : VehiclePose
            The camera's vehicle.
        others : sequence of VehiclePose
            Every other vehicle in the scene.
        target_index : int
            Which of ``others`` is the tracked target (the truth describes it).
        follower_name : str
            The follower's name: occluders meant for another follower are not drawn.
        yaw_rate_radps : float
            The follower's yaw rate, rad/s: motion blur, when the camera has it.
        """
        if self.realism:
            return self._render_real(t_s, follower, others, target_index, follower_name, yaw_rate_radps)
        R, c = self.cam.pose(follower.north_m, follower.east_m, follower.yaw_rad)
        layer = self._layer
        for r0, r1 in self._sky_rows:
            layer[r0:r1] = self._sky_half[r0:r1]
        self._paint_ground(R, c)
        target = others[target_index]
        items: list[tuple[float, Plane | _Face, str]] = []
        for p in self._props(t_s):
            items.append((_distance(p.centre, c), p, "prop"))
        for i, v in enumerate(others):
            for dist, plane, name in self._vehicle_faces(v, c):
                items.append((dist, plane, "target" if (name == "banner" and i == target_index) else name))
        for p in self._occluders(t_s, follower, target, follower_name):
            items.append((_distance(p.centre, c), p, "occluder"))
        items.sort(key=lambda x: -x[0])
        # props farther than every vehicle and occluder are background: into the layer
        n_back = next((i for i, item in enumerate(items) if item[2] != "prop"), len(items))
        dirty = self._ground_bands[0][0] if self._ground_bands else layer.shape[0]  # layer rows above: bare sky
        for _depth, plane, _kind in items[:n_back]:
            poly = self._paint_plane(layer, R, c, plane, self._half_K)
            if poly is not None:
                dirty = min(dirty, point_bounds(poly)[1] - 2)  # two rows more: an anti-aliased edge's reach
        img = self._upscale(dirty)
        target_poly = None
        nearer_polys: list[np.ndarray] = []
        for _depth, plane, kind in items[n_back:]:
            poly = self._paint_plane(img, R, c, plane, self.cam.K)
            if kind == "target":
                target_poly = poly
            elif poly is not None and target_poly is not None:
                nearer_polys.append(poly)  # painted after the target: nearer, may hide it
        truth = self._truth(t_s, R, c, follower, target, target_poly, nearer_polys)
        if self.lens is not None:  # the scene was drawn ideal: bent now as the lens bends it
            img = self.lens.bend(img)
        if self.cfg.motion_blur and abs(yaw_rate_radps) > 1e-3:
            length = int(min(31, abs(yaw_rate_radps) / 60.0 * self._fx))
            if length >= 2:
                img = cv2.blur(img, (length, 1))
        img = self._apply_light(img, t_s)
        if self._noise:
            plus, minus = self._noise[int(self._frame_rng.integers(len(self._noise)))]
            cv2.add(img, plus, dst=img)
            cv2.subtract(img, minus, dst=img)
        return img, truth

    def _upscale(self, dirty: int) -> np.ndarray:
        """The background layer at the frame's size, exactly as
        ``cv2.resize(self._layer, (width, height), interpolation=cv2.INTER_LINEAR)`` gives it,
        when the layer's rows above ``dirty`` are bare sky.

        Frame row y blends layer rows y // 2 - 1 + y % 2 and the next one (a 2 x upscale), so
        the rows up to 2 dirty - 2 see bare sky only: they are copied from the sky scaled up
        once, and only the layer from row dirty - 1 down is scaled (its first frame row,
        clamped at the cut, is one of the copied ones). Each frame row is computed from the
        same two layer rows with the same weights, whole rows at a time as in the full
        resize, so the pixels are the same. The sky above the floor is half the convoy's
        frame: 0.43 -> ~0.28 ms where no prop rises above the horizon (two frames in three).

        Parameters
        ----------
        dirty : int
            The first layer row that is not bare sky (the floor's first band, or a prop painted
            into the layer); below 2 (or without a bare sky to copy): the whole layer is scaled.
        """
        layer, sky = self._layer, self._sky_full
        size = (self.cfg.width_px, self.cfg.height_px)
        if sky is None or dirty < 2:
            return cv2.resize(layer, size, interpolation=cv2.INTER_LINEAR)
        d = min(dirty, layer.shape[0])
        img = np.empty_like(sky)
        cv2.resize(
            layer[d - 1 :], (size[0], size[1] - 2 * (d - 1)), dst=img[2 * (d - 1) :], interpolation=cv2.INTER_LINEAR
        )
        img[: 2 * d - 1] = sky[: 2 * d - 1]
        return img

    def _apply_light(self, img: np.ndarray, t_s: float) -> np.ndarray:
        """The global gain and tint, then the sweeping shadow band (darkened in place)."""
        sc = self.scene
        if sc.lighting or (sc.flicker_amplitude > 0 and sc.flicker_hz > 0):  # else gain 1, tint 1
            gain, tint = self.light(t_s)
            if gain != 1.0 or np.any(tint != 1.0):
                img = cv2.transform(img, np.diag(gain * tint).astype(np.float32))
        if sc.shadow_gain < 1.0:
            w = img.shape[1]
            band = w // 4
            x0 = int(((t_s % sc.shadow_period_s) / sc.shadow_period_s) * (w + band)) - band
            a, b = max(0, x0), min(w, x0 + band)
            if b > a:
                cols = img[:, a:b]
                cv2.convertScaleAbs(cols, dst=cols, alpha=sc.shadow_gain)
        return img

    def _truth(
        self,
        t_s: float,
        R: np.ndarray,
        c: np.ndarray,
        follower: VehiclePose,
        target: VehiclePose,
        target_poly: np.ndarray | None,
        nearer: list[np.ndarray],
    ) -> FrameTruth:
        K = self.cam.K
        centre, _right, _down = self._banner_frame(target)
        marks_w = self.geometry.markers_ned(target.north_m, target.east_m, target.yaw_rad)
        cam = (R @ (marks_w - c).T).T
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = (K @ cam.T).T
            marks = uv[:, :2] / uv[:, 2:3]
        if self.lens is not None:  # where the lens puts them
            ahead = cam[:, 2] > 0
            marks[ahead] = self.lens.camera.pixels(cam[ahead, :2] / cam[ahead, 2:3])
            marks[~ahead] = np.nan
        ban_cam = R @ (centre - c)
        rng = math.hypot(target.north_m - follower.north_m, target.east_m - follower.east_m)
        brg = wrap_pi(math.atan2(target.east_m - follower.east_m, target.north_m - follower.north_m) - follower.yaw_rad)
        rel = wrap_pi(target.yaw_rad - follower.yaw_rad)
        bbox, vis, in_view = None, 0.0, False
        if target_poly is not None and self.lens is not None:  # (the polygons are on the canvas)
            bbox, vis = self.lens.shown(target_poly, nearer)
            in_view = bbox is not None
        elif target_poly is not None:
            W, H = self.cfg.width_px, self.cfg.height_px
            x0, y0, x1, y1 = point_bounds(target_poly)
            cx0, cy0, cx1, cy1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
            if cx1 > cx0 and cy1 > cy0:
                in_view = True
                bbox = (int(cx0), int(cy0), int(cx1 - cx0), int(cy1 - cy0))
                mask = np.zeros((cy1 - cy0, cx1 - cx0), np.uint8)
                cv2.fillPoly(mask, [np.round(target_poly - [cx0, cy0]).astype(np.int32)], 255)
                total = cv2.countNonZero(mask)
                for poly in nearer:
                    cv2.fillPoly(mask, [np.round(poly - [cx0, cy0]).astype(np.int32)], 0)
                vis = cv2.countNonZero(mask) / total if total else 0.0
                # the fraction of the whole banner, counting parts outside the image as hidden
                full = cv2.contourArea(target_poly.astype(np.float32))
                vis *= min(1.0, total / full) if full > 0 else 0.0
        return FrameTruth(t_s, bbox, marks, float(vis), in_view, rng, brg, rel, ban_cam)

    # -- the realistic look (scene.realism = "on") ----------------------------------------
    def _init_real(self, seed: int) -> None:
        """Textures (photographed where the footage is there), the sun, the ground's mip
        bands at full resolution, the background, and the sensor."""
        camera, banner, scene = self.cfg, self.banner, self.scene
        w = camera.width_px
        rng = np.random.default_rng([seed, 14])
        plates = footage.plates() if scene.textures == "footage" else None
        self.sun = sun_direction(scene.sun_azimuth_rad, scene.sun_elevation_rad)
        self._lit_cache: dict[tuple[int, int], np.ndarray] = {}
        self._lit_keep: list[np.ndarray] = []
        self.banner_tex, _marks = real_banner_texture(banner, rng)
        if banner.kind == "aruco":  # the tag printed on the same board (opaque: alpha 255)
            self.banner_tex = self._tag_texture(banner.aruco_id)
        photos = None
        if plates is not None and scene.ground in ("concrete", "grass"):
            photos = plates.asphalt if scene.ground == "concrete" else plates.grass
        self.ground_tex, self.ground_px_per_m = real_ground_texture(scene.ground, photos, rng)
        self._ground_levels = periodic_pyramid(self.ground_tex, 5)
        # level 0 is only drawn on the nearest rows, which see less than a period: 2 x 2 tiles
        # hold them wherever they fall; coarser levels see more of the floor: 3 x 3
        # (as BGRA: OpenCV warps four channels faster than three)
        reps = (2, 3, 4, 6, 8)
        self._ground_tiles = [
            np.tile(cv2.cvtColor(t, cv2.COLOR_BGR2BGRA), (reps[k], reps[k], 1))
            for k, t in enumerate(self._ground_levels)
        ]
        self._ground_reps = reps
        self._ground_scratch = np.zeros((camera.height_px, camera.width_px, 4), np.uint8)
        props_px, self.occluder_tex = _panels(scene, seed)
        facades = plates.facade if plates else None
        self.prop_tex = [
            real_wall_texture(p, facades, banner, rng, size) for p, size in zip(scene.props, props_px, strict=True)
        ]
        self._sky = self._sky_image()
        # the distant background: a 360-degree strip, one pixel per pixel of the image at the
        # focal length, its foot on the horizon; doubled so any slice of it is contiguous
        fx = float(self.cam.K[0, 0])
        self._ground_bands = self._ground_band_levels_full()
        self._background = None
        if plates is not None:
            pano = plates.background
            width = max(w, int(round(2 * math.pi * fx)))
            height = max(1, int(round(pano.shape[0] * width / pano.shape[1])))
            pano = cv2.resize(pano, (width, height), interpolation=cv2.INTER_AREA)
            pano = np.roll(pano, int(rng.integers(width)), axis=1)
            self._background = self._fade_into_sky(np.concatenate([pano, pano[:, :w]], axis=1))
        self.sensor = Sensor(camera, seed)

    def _background_foot(self) -> int:
        """The image row the background stands on: the floor's first row (or the horizon)."""
        return self._ground_bands[0][0] if self._ground_bands else int(round(self._horizon_row()))

    def _fade_into_sky(self, bg: np.ndarray) -> np.ndarray:
        """The background's top quarter faded into the sky behind it (a photograph's cut
        edge is a hard line across the sky otherwise); the rows it lands on never change, so
        this is done once."""
        rows = max(1, bg.shape[0] // 4)
        top = self._background_foot() - bg.shape[0]
        sky_rows = np.clip(np.arange(top, top + rows), 0, self.cfg.height_px - 1)
        sky = self._sky[sky_rows, :1].astype(np.float32)  # (rows, 1, 3): the sky is the same along a row
        x = (np.arange(rows, dtype=np.float32) + 0.5) / rows
        weight = (x * x * (3 - 2 * x))[:, None, None]  # smoothstep: 0 at the cut, 1 a quarter down
        out = bg.copy()
        out[:rows] = np.round(sky + (bg[:rows].astype(np.float32) - sky) * weight).astype(np.uint8)
        return out

    def _horizon_row(self) -> float:
        """The image row of the horizon straight ahead (the camera moves in the plane at a
        fixed pitch, so it never changes; it can lie outside the image)."""
        ahead = self.cam.R_body_from_cam.T @ np.array([1.0, 0.0, 0.0])  # body forward, camera frame
        if ahead[2] <= 1e-9:
            return -1.0
        return float(self.cam.K[1, 1] * ahead[1] / ahead[2] + self.cam.K[1, 2])

    def _ground_band_levels_full(self) -> list[tuple[int, int, int]]:
        """As :meth:`_ground_band_levels`, at full resolution: the rows that see the floor in
        bands, each with the mip level whose texels are about a pixel's footprint; the
        nearest rows get level 0 (the texture is fine enough for them not to look soft)."""
        Kinv = np.linalg.inv(self.cam.K)
        R = self.cam.R_body_from_cam
        height = -float(self.cam.mount_body_m[2])
        w, h = self.cfg.width_px, self.cfg.height_px
        cx = float(self.cam.K[0, 2])
        bands: list[tuple[int, int, int]] = []
        for r in range(h):
            rays = R @ Kinv @ np.array([[0.0, w - 1.0, cx, cx + 1.0, cx], [r, r, r, r, r + 1.0], [1.0] * 5])
            if not np.all(rays[2] > 1e-6):
                continue
            hits = rays[:2] * (height / rays[2])
            if float(np.linalg.norm(hits[:, 2])) > FAR_GROUND_M:
                continue  # the last rows before the horizon: the background shows there
            across = float(np.linalg.norm(hits[:, 3] - hits[:, 2]))
            along = float(np.linalg.norm(hits[:, 4] - hits[:, 2]))
            texels = math.sqrt(across * along) * self.ground_px_per_m
            level = min(len(self._ground_levels) - 1, max(0, math.floor(math.log2(max(texels, 1.0)))))
            if bands and bands[-1][2] == level and bands[-1][1] == r:
                bands[-1] = (bands[-1][0], r + 1, level)
            else:
                bands.append((r, r + 1, level))
        return bands

    def _paint_ground_full(self, img: np.ndarray, R: np.ndarray, c: np.ndarray) -> None:
        """The floor at full resolution, band by band (see :meth:`_paint_ground`)."""
        Hg = self._ground_homography(self.cam.K, R, c)
        w = img.shape[1]
        for r0, r1, level in self._ground_bands:
            M = _band_homography(Hg, r0, level)
            Minv = np.linalg.inv(M)
            ph, pw = self._ground_levels[level].shape[:2]
            if level == 0:
                # the band's four corners in texels: put their lowest corner in the first tile
                corners = Minv @ np.array([[0.0, w, 0.0, w], [0.0, 0.0, r1 - r0, r1 - r0], [1.0] * 4])
                q = corners[:2] / corners[2]
                kx, ky = math.floor(q[0].min() / pw), math.floor(q[1].min() / ph)
            else:
                q = Minv @ np.array([w / 2.0, (r1 - r0) / 2.0, 1.0])
                kx = math.floor(q[0] / q[2] / pw) - self._ground_reps[level] // 2
                ky = math.floor(q[1] / q[2] / ph) - self._ground_reps[level] // 2
            M = M @ np.array([[1.0, 0.0, kx * pw], [0.0, 1.0, ky * ph], [0.0, 0.0, 1.0]])
            cv2.warpPerspective(
                self._ground_tiles[level],
                M,
                (w, r1 - r0),
                dst=self._ground_scratch[r0:r1],
                flags=cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_WRAP,
            )
        if self._ground_bands:
            r0, r1 = self._ground_bands[0][0], self._ground_bands[-1][1]
            cv2.cvtColor(self._ground_scratch[r0:r1], cv2.COLOR_BGRA2BGR, dst=img[r0:r1])

    def _background_image(self, R: np.ndarray, c: np.ndarray, yaw_rad: float) -> np.ndarray:
        """Sky, and the photographed background standing on the horizon, at full resolution."""
        img = self._sky.copy()
        if self._background is None:
            return img
        h, w = img.shape[:2]
        # its foot on the horizon, or on the farthest row the floor is drawn on
        horizon = self._background_foot()
        bg = self._background
        width = bg.shape[1] - w
        x0 = int(round(yaw_rad * float(self.cam.K[0, 0]) - float(self.cam.K[0, 2]))) % width
        top = horizon - bg.shape[0]
        r0, r1 = max(0, top), min(h, horizon)
        if r1 > r0:
            img[r0:r1] = bg[r0 - top : r1 - top, x0 : x0 + w]
        return img

    def _image_poly(self, R: np.ndarray, c: np.ndarray, pts: np.ndarray) -> np.ndarray | None:
        """World points of a convex polygon -> its image polygon (clipped at the near plane)."""
        cam = (pts - c) @ R.T
        if np.all(cam[:, 2] >= NEAR_M):
            clipped = cam
        else:
            clipped = _clip_near(cam)
            if len(clipped) < 3:
                return None
        uv = clipped @ self.cam.K.T
        return uv[:, :2] / uv[:, 2:3]

    def _cloud(self, t_s: float, follower: VehiclePose) -> tuple[float, float] | None:
        """The cloud shadow's band (east from, east to) at ``t_s``, or None (shadow_gain 1)."""
        sc = self.scene
        if sc.shadow_gain >= 1.0:
            return None
        span, width = 8.0, 1.5
        e = follower.east_m - span / 2 + span * ((t_s % sc.shadow_period_s) / sc.shadow_period_s)
        return e - width / 2, e + width / 2

    def _paint_shadows(
        self,
        img: np.ndarray,
        R: np.ndarray,
        c: np.ndarray,
        t_s: float,
        vehicles: list[tuple[VehiclePose, np.ndarray | None]],
        props: list[Plane],
        cloud: tuple[float, float] | None,
        follower: VehiclePose,
    ) -> None:
        """Darken the floor where the sun does not reach it: cast shadows of vehicles and
        props, the contact patches under the vehicles, and the cloud's band. One mask over
        the region they cover, softened, multiplied in."""
        sc = self.scene
        H, W = img.shape[:2]
        casts: list[np.ndarray] = []
        patches: list[np.ndarray] = []
        band: np.ndarray | None = None
        if sc.shadows:
            for v, corners in vehicles:
                polys, patch = shadow_polygons(v.north_m, v.east_m, v.yaw_rad, self.sun, corners)
                for poly in polys:
                    ip = self._image_poly(R, c, poly)
                    if ip is not None:
                        casts.append(ip)
                ip = self._image_poly(R, c, patch) if v is not follower else None
                if ip is not None:
                    patches.append(ip)
            for plane in props:
                pts = plane.corners
                ground = pts - self.sun[None, :] * (pts[:, 2:3] / float(self.sun[2]))
                ip = self._image_poly(R, c, ground)
                if ip is not None:
                    casts.append(ip)
        elif vehicles:
            for v, _corners in vehicles:
                _polys, patch = shadow_polygons(v.north_m, v.east_m, v.yaw_rad, self.sun, None)
                ip = self._image_poly(R, c, patch) if v is not follower else None
                if ip is not None:
                    patches.append(ip)
        if cloud is not None:
            n0, n1 = follower.north_m - 40.0, follower.north_m + 40.0
            e0, e1 = cloud
            band = self._image_poly(R, c, np.array([[n0, e0, 0.0], [n0, e1, 0.0], [n1, e1, 0.0], [n1, e0, 0.0]]))
        every = casts + ([band] if band is not None else [])
        if every:
            self._shade(img, every, band, casts)
        for poly in patches:
            # the contact patch: little sky reaches under a body: dark, with a soft rim a
            # tenth of its width wide, in its own small window
            sigma = max(1.0, 0.1 * float(np.ptp(poly[:, 0])))
            pad = int(3 * sigma) + 1
            px0, py0 = np.floor(poly.min(axis=0)).astype(int) - pad
            px1, py1 = np.ceil(poly.max(axis=0)).astype(int) + pad
            px0, py0, px1, py1 = max(px0, 0), max(py0, self._floor_top()), min(px1, W), min(py1, H)
            if px1 <= px0 or py1 <= py0:
                continue
            contact = np.full((py1 - py0, px1 - px0), 255, np.uint8)
            dark = int(round(255 * (1.0 - 0.65 * (1.0 - 0.5 * sc.ambient))))
            cv2.fillPoly(contact, [np.round((poly - [px0, py0]) * 16).astype(np.int32)], dark, cv2.LINE_AA, 4)
            k = int(1.7 * sigma) | 1  # two box blurs: nearly a Gaussian, at a fixed cost per pixel
            contact = cv2.blur(cv2.blur(contact, (k, k)), (k, k))
            psub = img[py0:py1, px0:px1]
            cv2.multiply(psub, cv2.cvtColor(contact, cv2.COLOR_GRAY2BGR), dst=psub, scale=1.0 / 255.0)

    def _floor_top(self) -> int:
        """The first image row the floor is drawn on: shadows fall on the floor, so none
        reaches above it (the rows above show the sky and the distant background)."""
        return self._ground_bands[0][0] if self._ground_bands else self.cfg.height_px

    def _shade(
        self, img: np.ndarray, every: list[np.ndarray], band: np.ndarray | None, casts: list[np.ndarray]
    ) -> None:
        """Multiply the cast shadows and the cloud's band into the floor, softened by a few pixels."""
        sc = self.scene
        H, W = img.shape[:2]
        pts = np.vstack(every)
        x0, y0 = np.floor(pts.min(axis=0)).astype(int) - 2
        x1, y1 = np.ceil(pts.max(axis=0)).astype(int) + 2
        x0, y0, x1, y1 = max(x0, 0), max(y0, self._floor_top()), min(x1, W), min(y1, H)
        if x1 <= x0 or y1 <= y0:
            return
        mask = np.full((y1 - y0, x1 - x0), 255, np.uint8)
        off = np.array([x0, y0], float)
        if band is not None:
            cv2.fillPoly(mask, [np.round((band - off) * 16).astype(np.int32)], int(round(255 * sc.shadow_gain)), cv2.LINE_AA, 4)  # fmt: skip
        shade = int(round(255 * sc.ambient))
        for poly in casts:
            cv2.fillPoly(mask, [np.round((poly - off) * 16).astype(np.int32)], shade, cv2.LINE_AA, 4)
        mask = cv2.blur(mask, (3, 3))  # a penumbra of a few pixels
        sub = img[y0:y1, x0:x1]
        cv2.multiply(sub, cv2.cvtColor(mask, cv2.COLOR_GRAY2BGR), dst=sub, scale=1.0 / 255.0)

    def _paint_textured(
        self,
        img: np.ndarray,
        R: np.ndarray,
        c: np.ndarray,
        plane: Plane,
        light: float,
        glare: np.ndarray | None = None,
    ) -> np.ndarray | None:
        """Warp a textured plane into ``img`` at full resolution, lit by ``light``. A BGRA
        texture is blended by its warped alpha (anti-aliased edges) and gets ``glare`` (a
        small float image of added light over the plane, resized to the texture); returns
        the image polygon, or None when not visible."""
        poly = self._image_poly(R, c, plane.corners)
        if poly is None:
            return None
        box = _pixel_box(poly, img.shape)
        if box is None:
            return None
        x0, y0, x1, y1 = box
        sub = img[y0:y1, x0:x1]
        K = self.cam.K
        tex, Hp = self._texture_to_roi(plane, R, c, K, x0, y0)
        size = (x1 - x0, y1 - y0)
        lit = self._lit(tex, light, glare)
        if tex.shape[2] == 4:
            warped = cv2.warpPerspective(lit, Hp, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
            alpha = warped[..., 3].astype(np.float32) * (1.0 / 255.0)
            sub[:] = cv2.blendLinear(warped[..., :3], sub, alpha, 1.0 - alpha)
            return poly
        mask = np.zeros(sub.shape[:2], np.uint8)
        cv2.fillPoly(mask, [np.round((poly - [x0, y0]) * 16).astype(np.int32)], 255, cv2.LINE_8, shift=4)
        warped = cv2.warpPerspective(lit, Hp, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        cv2.copyTo(warped, mask, sub)
        return poly

    def _lit(self, tex: np.ndarray, light: float, glare: np.ndarray | None) -> np.ndarray:
        """A texture (a mip level) times ``light``, plus ``glare`` (resized over it). Without
        glare the result is kept per light level (in steps of 1/128): props and banners
        are lit alike frame after frame."""
        q = round(light * 128)
        if glare is None:
            if q == 128:
                return tex
            hit = self._lit_cache.get((id(tex), q))
            if hit is not None:
                return hit
        colour = tex[..., :3].astype(np.float32) * (q / 128.0)
        if glare is not None:
            colour += cv2.resize(glare, (tex.shape[1], tex.shape[0]), interpolation=cv2.INTER_LINEAR)[..., None]
        out = np.clip(colour, 0, 255).astype(np.uint8)
        if tex.shape[2] == 4:
            out = np.dstack([out, tex[..., 3]])
        if glare is None:
            if len(self._lit_cache) > 256:
                self._lit_cache.clear()
                self._lit_keep.clear()
            self._lit_cache[(id(tex), q)] = out
            self._lit_keep.append(tex)  # keeps the id a valid key
        return out

    def _banner_glare(self, corners: np.ndarray, normal: np.ndarray, c: np.ndarray, direct: float) -> np.ndarray | None:
        """The sun's glare on the banner: Phong lobes of the mirror direction against the
        view direction, on a 5 x 5 grid over the panel (digital numbers to add), or None."""
        gloss = self.banner.gloss
        cos_in = float(np.dot(normal, self.sun))
        if gloss <= 0 or direct <= 0 or cos_in <= 0:
            return None
        mirror = 2 * cos_in * normal - self.sun  # where the sun's light leaves the surface
        u = np.linspace(0.0, 1.0, 5)
        tl, tr, _br, bl = corners
        grid = (
            tl[None, None, :]
            + u[None, :, None] * (tr - tl)[None, None, :]
            + u[:, None, None] * (bl - tl)[None, None, :]
        )
        view = c[None, None, :] - grid
        view /= np.linalg.norm(view, axis=2, keepdims=True)
        cos = np.clip(np.einsum("ijk,k->ij", view, mirror), 0.0, 1.0)
        spec = gloss * direct * (1.0 - self.scene.ambient) * 255.0 * (0.5 * cos**8 + 2.5 * cos**300)
        if float(spec.max()) < 1.0:
            return None
        return spec.astype(np.float32)

    def _render_real(
        self,
        t_s: float,
        follower: VehiclePose,
        others: Sequence[VehiclePose],
        target_index: int,
        follower_name: str,
        yaw_rate_radps: float,
    ) -> tuple[np.ndarray, FrameTruth]:
        """The realistic frame: see the class docstring."""
        R, c = self.cam.pose(follower.north_m, follower.east_m, follower.yaw_rad)
        img = self._background_image(R, c, follower.yaw_rad)
        self._paint_ground_full(img, R, c)
        target = others[target_index]
        cloud = self._cloud(t_s, follower)
        props = self._props(t_s)
        banners: list[np.ndarray | None] = []
        for v in others:
            if v.banner:
                centre, right, down = self.geometry.frame_ned(v.north_m, v.east_m, v.yaw_rad)
                half = self.banner.panel_size_m / 2
                tl = centre - right * half - down * half
                banners.append(
                    np.array([tl, tl + 2 * right * half, tl + 2 * (right + down) * half, tl + 2 * down * half])
                )
            else:
                banners.append(None)
        shadowed = [(v, b) for v, b in zip(others, banners, strict=True)] + [(follower, None)]
        self._paint_shadows(img, R, c, t_s, shadowed, props, cloud, follower)
        # painter's order: props, occluders and whole vehicles, far to near
        items: list[tuple[float, str, object]] = []
        for p in props:
            items.append((float(np.linalg.norm(p.centre - c)), "prop", p))
        for p in self._occluders(t_s, follower, target, follower_name):
            items.append((float(np.linalg.norm(p.centre - c)), "occluder", p))
        for i, v in enumerate(others):
            items.append((math.hypot(v.north_m - c[0], v.east_m - c[1]), "vehicle", i))
        items.sort(key=lambda x: -x[0])
        target_poly = None
        nearer: list[np.ndarray] = []
        for _d, kind, obj in items:
            if kind != "vehicle":
                assert isinstance(obj, Plane)
                normal = _unit_cross(obj.ax, obj.ay)  # towards a viewer who sees the texture unmirrored
                poly = self._paint_textured(img, R, c, obj, self._light_at(obj.centre, normal, cloud))
                if poly is not None and target_poly is not None:
                    nearer.append(poly)
                continue
            assert isinstance(obj, int)
            v, corners = others[obj], banners[obj]
            polys, banner_poly = self._paint_vehicle(img, R, c, v, corners, cloud)
            if obj == target_index:
                target_poly = banner_poly
                nearer.extend(polys[1])  # the vehicle's own faces drawn over its banner
            elif target_poly is not None:
                nearer.extend(polys[0] + polys[1])
        truth = self._truth(t_s, R, c, follower, target, target_poly, nearer)
        if self.lens is not None:  # the scene was drawn ideal: bent now as the lens bends it
            img = self.lens.bend(img)
        gain, tint = self.light(t_s)
        img = self.sensor.expose(img, t_s, gain * np.asarray(tint, float), yaw_rate_radps, self._fx)
        return img, truth

    def _light_at(self, point: np.ndarray, normal: np.ndarray | None, cloud: tuple[float, float] | None) -> float:
        """The light on a surface at ``point``: the sun's unless the cloud's band covers it.
        Props are lit as vertical panels facing the camera half-way to the sun."""
        direct = 1.0
        if cloud is not None and cloud[0] <= float(point[1]) <= cloud[1]:
            direct = self.scene.shadow_gain
        if normal is None:
            return sun_light(None, self.sun, self.scene.ambient, direct)
        return sun_light(normal, self.sun, self.scene.ambient, direct)

    def _paint_vehicle(
        self,
        img: np.ndarray,
        R: np.ndarray,
        c: np.ndarray,
        v: VehiclePose,
        corners: np.ndarray | None,
        cloud: tuple[float, float] | None,
    ) -> tuple[tuple[list[np.ndarray], list[np.ndarray]], np.ndarray | None]:
        """One rover: faces behind the banner, the banner's edges and print (seen from behind
        the vehicle), then the faces in front of it; all the rover's corners projected at
        once. Returns the painted polygons (before, after) and the banner's polygon."""
        direct = 1.0
        if cloud is not None and cloud[0] <= v.east_m <= cloud[1]:
            direct = self.scene.shadow_gain
        cy, sy = math.cos(v.yaw_rad), math.sin(v.yaw_rad)
        Rb = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
        t = np.array([v.north_m, v.east_m, 0.0])
        cam_b = Rb.T @ (c - t)
        before, after = visible_faces(cam_b)
        cam = (MESH.points @ Rb.T + t - c) @ R.T
        ok = cam[:, 2] >= NEAR_M
        uv = cam @ self.cam.K.T
        with np.errstate(divide="ignore", invalid="ignore"):
            px = uv[:, :2] / uv[:, 2:3]
        normals_w = MESH.normals @ Rb.T
        up = max(-float(self.sun[2]), 1e-3)
        amb = self.scene.ambient
        cos = np.where(MESH.normals.any(axis=1), np.maximum(normals_w @ self.sun, 0.0), 0.5 * up)
        light = np.minimum(1.8, amb + (1.0 - amb) * direct * cos / up)
        colours = np.minimum(255.0, np.round(MESH.bgr * light[:, None]))
        drawn: tuple[list[np.ndarray], list[np.ndarray]] = ([], [])
        seen_from_behind = corners is not None and float(np.dot(Rb[:, 0], corners.mean(axis=0) - c)) > 0
        banner_poly = None
        for k, faces in enumerate((before, after)):
            if k == 1 and seen_from_behind and corners is not None:
                for pts, n in banner_edges(corners, v.yaw_rad, self.banner.thickness_m, c):
                    poly = self._image_poly(R, c, pts)
                    if poly is not None:
                        lit = sun_light(n, self.sun, amb, direct)
                        colour = tuple(int(min(255, round(b * lit))) for b in EDGE_BGR)
                        cv2.fillPoly(img, [np.round(poly * 16).astype(np.int32)], colour, cv2.LINE_AA, shift=4)
                        drawn[0].append(poly)
                banner_poly = self._paint_banner(img, R, c, corners, direct, self._banner_texture(v))
            for i in faces:
                a, b = MESH.faces[i]
                if ok[a:b].all():
                    poly = px[a:b]
                    if not MESH.normals[i].any():  # a tyre: the hull of its rims
                        poly = cv2.convexHull(np.ascontiguousarray(poly, np.float32))[:, 0, :].astype(float)
                elif MESH.normals[i].any():
                    poly = self._image_poly(R, c, MESH.points[a:b] @ Rb.T + t)
                    if poly is None:
                        continue
                else:
                    continue
                col = colours[i]
                cv2.fillPoly(
                    img, [np.round(poly * 16).astype(np.int32)], (col[0], col[1], col[2]), cv2.LINE_AA, shift=4
                )
                drawn[k].append(poly)
        return drawn, banner_poly

    def _paint_banner(
        self, img: np.ndarray, R: np.ndarray, c: np.ndarray, corners: np.ndarray, direct: float, tex: np.ndarray
    ) -> np.ndarray | None:
        tl, tr, _br, bl = corners
        size = tex.shape[0]
        normal = _unit_cross(bl - tl, tr - tl)  # towards the viewer behind the vehicle
        plane = Plane(tl, (tr - tl) / size, (bl - tl) / size, tex)
        light = sun_light(normal, self.sun, self.scene.ambient, direct)
        glare = self._banner_glare(corners, normal, c, direct)
        return self._paint_textured(img, R, c, plane, light, glare)


def _band_homography(Hg: np.ndarray, r0: int, level: int) -> np.ndarray:
    """Texel of mip ``level`` -> pixel of the band that starts at image row ``r0``."""
    k = 2**level
    # texel i of this level covers level-0 texels k i .. k i + k - 1: centre k i + (k - 1) / 2
    to_level = np.array([[k, 0.0, (k - 1) / 2.0], [0.0, k, (k - 1) / 2.0], [0.0, 0.0, 1.0]])
    return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, -r0], [0.0, 0.0, 1.0]]) @ Hg @ to_level
