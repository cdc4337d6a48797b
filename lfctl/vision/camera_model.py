"""The follower's camera: pinhole intrinsics, lens distortion and its mount on the vehicle.

One model for the simulated camera (the renderer draws through it) and the real one
(`lfctl follow`, `lfctl track`): both come from a scenario's ``[camera]``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from lfctl.config import MAX_CAMERA_PIXELS, MAX_CAMERA_SIDE_PX, CameraConfig
from lfctl.errors import ConfigError
from lfctl.frames import rot_z

__all__ = ["CameraModel", "at_frame_size", "distort", "rising_radius", "undistort"]

#: the distortion coefficients' keys in [camera], in OpenCV's order
DISTORTION_KEYS = ("k1", "k2", "p1", "p2", "k3")
#: frames whose height differs from the calibrated height scaled by the widths' ratio by more
#: than this are another aspect (a crop of the sensor, or rows padded), px
ASPECT_TOLERANCE_PX = 1.0

#: the lens model's inverse: the radial part by bisection on its first rising branch (OpenCV's
#: fixed-point inverse stops after five steps by default, a tenth of a pixel off at a strong
#: lens's corners, and run longer cycles without converging on some wide lenses), then Newton
#: steps on the whole model (tangential terms too)
INVERSE_BISECTIONS = 60
INVERSE_NEWTON_STEPS = 8
#: a ray whose image through the model misses its pixel by more than this (normalised) is none
INVERSE_TOLERANCE = 1e-9
#: the radial function's first rising branch is looked for out to this radius (normalised:
#: 87 degrees off the axis)
RADIUS_LIMIT = 20.0


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
    if max(width, height) > MAX_CAMERA_SIDE_PX or width * height > MAX_CAMERA_PIXELS:
        # (else the scenario's camera.width_px bound was named: a setting the user never gave)
        raise ConfigError(
            f"larger than lfctl's camera takes, {MAX_CAMERA_SIDE_PX} px a side and {MAX_CAMERA_PIXELS} pixels "
            "(4096 x 2160): scale the video down first, e.g. `ffmpeg -i IN -vf scale=1920:-2 OUT`, or set the "
            "camera to a smaller picture"
        )
    given = [k for k in ("fx_px", "fy_px", "cx_px", "cy_px") if getattr(camera, k) != 0]
    if not given:
        return dataclasses.replace(camera, width_px=width, height_px=height), None
    sx, sy = width / W, height / H
    turned = abs(width * W / H - height) <= 2 * ASPECT_TOLERANCE_PX and (width > height) != (W > H)
    if abs(H * sx - height) > ASPECT_TOLERANCE_PX and turned:
        raise ConfigError(
            f"camera.{given[0]} and the other intrinsics hold at camera.width_px x height_px = {W}x{H}, and the "
            f"frames are {width}x{height}: the picture turned a quarter (a phone's upright recording carries a "
            "rotation, which the video reader applies); lfctl does not turn a calibration: calibrate the camera "
            f"from frames as the video gives them ({width}x{height}) and give that size"
        )
    if abs(H * sx - height) > ASPECT_TOLERANCE_PX:
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
        fy_px=(camera.fy_px or camera.fx_px) * sy,  # (fy given as fx's: it scales with the height)
        cx_px=centre(camera.cx_px, sx),
        cy_px=centre(camera.cy_px, sy),
    )
    return scaled, (
        f"camera intrinsics given for camera.width_px x height_px = {W}x{H} scaled by {sx:.4g} to the frames' "
        f"{width}x{height} (if they were measured at {width}x{height}, give that size)"
    )


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

    @cached_property
    def _border_rays(self) -> tuple[np.ndarray, np.ndarray]:
        """Pixels along the picture's border, and their rays (NaN past the lens model)."""
        w, h = self.width - 1.0, self.height - 1.0
        edge = np.linspace(0.0, 1.0, 65)
        border = np.concatenate(
            [np.column_stack([edge * w, 0 * edge]), np.column_stack([edge * w, 0 * edge + h]),
             np.column_stack([0 * edge, edge * h]), np.column_stack([0 * edge + w, edge * h])]
        )  # fmt: skip
        return border, self.rays(border)

    @cached_property
    def reach(self) -> float:
        """The largest ray the picture holds (a normalised radius, x / z and y / z), on its
        border: the lens model means nothing past it."""
        rays = self._border_rays[1]
        r = np.hypot(rays[:, 0], rays[:, 1])
        r = r[np.isfinite(r)]
        return float(r.max()) if r.size else math.nan  # (none: a lens check_lens refuses)

    def check_lens(self) -> None:
        """Refuse distortion coefficients that fold the picture back on itself (the lens
        model's radial function stops growing inside the picture: no ray for its edge).

        Raises
        ------
        ConfigError
            Naming the coefficients and a pixel with no ray.
        """
        border, rays = self._border_rays
        lost = np.flatnonzero(~np.isfinite(rays[:, 0]))
        if len(lost):
            x, y = border[lost[0]]
            given = ", ".join(f"camera.{n} = {c:g}" for n, c in zip(DISTORTION_KEYS, self.dist, strict=True) if c != 0)
            raise ConfigError(
                f"{given}: this lens model folds the picture back on itself (no ray for pixel ({x:g}, {y:g}) of "
                f"the {self.width}x{self.height} picture: its radial function stops growing inside it); take the "
                "coefficients from a calibration of this lens"
            )

    @cached_property
    def rising_to(self) -> float:
        """How far out (a normalised radius) the lens model's radial function keeps growing
        (:func:`rising_radius`)."""
        return rising_radius(self.dist)

    def pixels(self, rays: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) of rays through the lens (OpenCV's model). A ray past the picture's
        :attr:`reach` is held to it first: past it a barrel lens's model turns back, and would
        bring a point far outside the picture into it.

        Parameters
        ----------
        rays : np.ndarray
            (N, 2) normalised pinhole coordinates (x / z, y / z).
        """
        rays = np.asarray(rays, np.float64).reshape(-1, 2)
        if not np.any(self.dist):
            return rays * (self.K[0, 0], self.K[1, 1]) + (self.K[0, 2], self.K[1, 2])
        r = np.hypot(rays[:, 0], rays[:, 1])
        far = r > self.reach
        if np.any(far):
            rays = rays.copy()
            rays[far] *= (self.reach / r[far])[:, None]
        shown, _jac = distort(rays, self.dist)
        return shown * (self.K[0, 0], self.K[1, 1]) + (self.K[0, 2], self.K[1, 2])

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        """Normalised pinhole coordinates (x / z, y / z), (N, 2), of raw pixels (N, 2): the
        lens taken out, exactly (:func:`undistort`); NaN for a pixel the model has no ray for
        (past the radius where its radial function stops growing: a lens that folds).

        Parameters
        ----------
        pixels : np.ndarray
            (N, 2) pixels as the camera gives them (distorted).
        """
        pts = np.asarray(pixels, np.float64).reshape(-1, 2)
        seen = (pts - (self.K[0, 2], self.K[1, 2])) / (self.K[0, 0], self.K[1, 1])
        return undistort(seen, self.dist, self.rising_to) if np.any(self.dist) else seen


def distort(rays: np.ndarray, dist: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV's lens model on normalised rays (N, 2): where each shows (normalised), and the
    model's Jacobian there (N, 2, 2).

    Parameters
    ----------
    rays : np.ndarray
        (N, 2) pinhole coordinates.
    dist : np.ndarray
        k1, k2, p1, p2, k3 (fewer: the rest 0).
    """
    k1, k2, p1, p2, k3 = (list(np.asarray(dist, np.float64).ravel()) + [0.0] * 5)[:5]
    x, y = rays[:, 0], rays[:, 1]
    r2 = x * x + y * y
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    slope = k1 + r2 * (2 * k2 + 3 * k3 * r2)  # d radial / d r2
    out = np.column_stack(
        [x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x), y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y]
    )
    jac = np.empty((len(rays), 2, 2))
    jac[:, 0, 0] = radial + 2 * x * x * slope + 2 * p1 * y + 6 * p2 * x
    jac[:, 0, 1] = 2 * x * y * slope + 2 * p1 * x + 2 * p2 * y
    jac[:, 1, 0] = jac[:, 0, 1]
    jac[:, 1, 1] = radial + 2 * y * y * slope + 6 * p1 * y + 2 * p2 * x
    return out, jac


def rising_radius(dist: np.ndarray) -> float:
    """How far out (a normalised radius, at most :data:`RADIUS_LIMIT`) the radial function
    ``r (1 + k1 r^2 + k2 r^4 + k3 r^6)`` of OpenCV's lens model keeps growing: past it the
    model folds back and means nothing.

    Parameters
    ----------
    dist : np.ndarray
        k1, k2, p1, p2, k3.
    """
    k1, k2, _p1, _p2, k3 = (list(np.asarray(dist, np.float64).ravel()) + [0.0] * 5)[:5]
    grid = np.linspace(0.0, RADIUS_LIMIT, 20001)
    g2 = grid * grid
    rising = 1 + g2 * (3 * k1 + g2 * (5 * k2 + 7 * k3 * g2))  # d(r radial(r^2)) / dr
    falls = np.flatnonzero(rising <= 0)
    return float(grid[falls[0]] if len(falls) else grid[-1])


def undistort(seen: np.ndarray, dist: np.ndarray, top: float | None = None) -> np.ndarray:
    """The rays (N, 2) that OpenCV's lens model shows at normalised points ``seen`` (N, 2);
    NaN where it shows none.

    The radial part first, by bisection on the radial function's first rising branch (from
    the axis out to where it stops growing: past that the model folds and means nothing),
    then Newton steps on the whole model from there. Exact where the lens is a lens; OpenCV's
    fixed-point inverse cycles without converging at the edge of some wide lenses.

    Parameters
    ----------
    seen : np.ndarray
        (N, 2) normalised distorted coordinates.
    dist : np.ndarray
        k1, k2, p1, p2, k3.
    top : float, optional
        :func:`rising_radius` of ``dist`` (computed when not given).
    """
    k1, k2, _p1, _p2, k3 = (list(np.asarray(dist, np.float64).ravel()) + [0.0] * 5)[:5]
    seen = np.asarray(seen, np.float64).reshape(-1, 2)
    top = rising_radius(dist) if top is None else top
    rd = np.hypot(seen[:, 0], seen[:, 1])
    lo, hi = np.zeros_like(rd), np.full_like(rd, top)
    for _ in range(INVERSE_BISECTIONS):
        mid = (lo + hi) / 2
        m2 = mid * mid
        low = mid * (1 + m2 * (k1 + m2 * (k2 + m2 * k3))) < rd
        lo, hi = np.where(low, mid, lo), np.where(low, hi, mid)
    r = (lo + hi) / 2
    scale = np.divide(r, rd, out=np.ones_like(rd), where=rd > 0)
    rays = seen * scale[:, None]
    for _ in range(INVERSE_NEWTON_STEPS):  # the tangential terms (and the bisection's last bits)
        shown, jac = distort(rays, dist)
        rays = rays - np.linalg.solve(jac, (shown - seen)[:, :, None])[:, :, 0]
    shown, _ = distort(rays, dist)
    miss = np.hypot(*(shown - seen).T)
    rays[~(miss <= INVERSE_TOLERANCE) | (np.hypot(rays[:, 0], rays[:, 1]) > top)] = np.nan
    return rays
