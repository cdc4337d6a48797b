"""The lens: a rendered frame bent as the camera's lens bends a real picture.

A camera with distortion coefficients (OpenCV's model: radial ``k1``, ``k2``, ``k3`` and
tangential ``p1``, ``p2``) puts a point whose ideal (pinhole) image is ``p`` at
``distort(p)``; the vision pipeline takes that out again (``cv2.solvePnP`` and
``cv2.undistortPoints`` with the same coefficients). To match it, the renderer draws an
ideal pinhole picture on a *canvas* and :meth:`Lens.bend` resamples it: each output pixel
takes the canvas's colour along that pixel's ray, which :meth:`CameraModel.rays` finds by
inverting the lens model. A barrel lens (``k1 < 0``) sees more than a pinhole of the same
focal length, so the canvas is a pinhole camera of the same size zoomed out just enough
(focal length times :attr:`Lens.scale`, at most 1) to hold every output pixel's ray.

Coefficients that bend the picture's edge past where the model turns back on itself (a
strong ``k1 < 0`` with a wide lens: the radial function stops growing inside the picture)
describe no lens, and are refused naming them.
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np

from lfctl.errors import ConfigError
from lfctl.vision.camera_model import CameraModel

__all__ = ["Lens"]

#: an output pixel whose ray does not come back to it within this many pixels through the
#: lens model is past the model's reach (the coefficients are refused)
ROUND_TRIP_PX = 0.5
_NAMES = ("k1", "k2", "p1", "p2", "k3")


class Lens:
    """The lens of ``camera`` (which has some distortion): the canvas camera to render the
    ideal picture with, the resampling that bends it, and the mapping of canvas points
    (painted polygons) to the output's pixels.

    Parameters
    ----------
    camera : CameraModel
        The real camera: intrinsics and distortion coefficients (k1, k2, p1, p2, k3).

    Raises
    ------
    ConfigError
        The coefficients fold the picture back on itself (no ray for some pixel).
    """

    def __init__(self, camera: CameraModel) -> None:
        w, h = camera.width, camera.height
        self.K = camera.K
        self.dist = np.asarray(camera.dist, np.float64)
        u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        pixels = np.stack([u.ravel(), v.ravel()], axis=-1)
        rays = camera.rays(pixels)
        back = self._through_lens(rays)
        miss = np.hypot(*(back - pixels).T)
        if not np.all(np.isfinite(miss)) or float(np.nanmax(miss)) > ROUND_TRIP_PX:
            worst = int(np.nanargmax(np.where(np.isfinite(miss), miss, np.inf)))
            coefficients = ", ".join(f"camera.{n} = {c:g}" for n, c in zip(_NAMES, self.dist, strict=True) if c != 0)
            raise ConfigError(
                f"{coefficients}: this lens model folds the picture back on itself (no ray for pixel "
                f"({worst % w}, {worst // w}) of the {w}x{h} picture: its radial function stops growing inside "
                "it); take the coefficients from a calibration of this lens"
            )
        #: the largest ray (normalised radius) the picture holds: canvas points farther out are
        #: outside the picture and are held to it before the lens maps them (past it the
        #: model turns back and would bring them inside)
        self.max_radius = float(np.max(np.hypot(rays[:, 0], rays[:, 1])))
        fx, fy, cx, cy = self.K[0, 0], self.K[1, 1], self.K[0, 2], self.K[1, 2]
        limits = [1.0]
        for lo, hi, f, c, size in (
            (rays[:, 0].min(), rays[:, 0].max(), fx, cx, w),
            (rays[:, 1].min(), rays[:, 1].max(), fy, cy, h),
        ):
            if lo < 0:
                limits.append(c / (f * -lo))
            if hi > 0:
                limits.append((size - 1 - c) / (f * hi))
        #: the canvas's focal length over the camera's (1: the ideal picture holds every ray)
        self.scale = float(min(limits))
        self.K_canvas = self.K.copy()
        self.K_canvas[0, 0] *= self.scale
        self.K_canvas[1, 1] *= self.scale
        kc = self.K_canvas
        map_x = (kc[0, 0] * rays[:, 0] + kc[0, 2]).reshape(h, w).astype(np.float32)
        map_y = (kc[1, 1] * rays[:, 1] + kc[1, 2]).reshape(h, w).astype(np.float32)
        self._maps = cv2.convertMaps(map_x, map_y, cv2.CV_16SC2)

    def canvas_camera(self, camera: CameraModel) -> CameraModel:
        """The pinhole camera the ideal picture is drawn with.

        Parameters
        ----------
        camera : CameraModel
            The real camera: the result is it with the canvas's focal lengths and no distortion.
        """
        return dataclasses.replace(camera, K=self.K_canvas.copy(), dist=np.zeros(5))

    def bend(self, canvas: np.ndarray) -> np.ndarray:
        """The picture the lens makes of the ideal ``canvas``.

        Parameters
        ----------
        canvas : np.ndarray
            The ideal frame drawn with :attr:`K_canvas`, of the camera's size.
        """
        return cv2.remap(canvas, self._maps[0], self._maps[1], cv2.INTER_LINEAR)

    def rays_to_image(self, rays: np.ndarray) -> np.ndarray:
        """Output pixels (N, 2) of rays, those past the picture held to its largest first.

        Parameters
        ----------
        rays : np.ndarray
            (N, 2) normalised pinhole coordinates (x / z, y / z).
        """
        rays = np.asarray(rays, np.float64).reshape(-1, 2)
        r = np.hypot(rays[:, 0], rays[:, 1])
        far = r > self.max_radius
        if np.any(far):
            rays = rays.copy()
            rays[far] *= (self.max_radius / r[far])[:, None]
        return self._through_lens(rays)

    def canvas_to_image(self, points: np.ndarray) -> np.ndarray:
        """Output pixels (N, 2) of canvas pixels.

        Parameters
        ----------
        points : np.ndarray
            (N, 2) canvas pixels (a painted polygon's corners, say).
        """
        kc = self.K_canvas
        p = np.asarray(points, np.float64).reshape(-1, 2)
        rays = np.stack([(p[:, 0] - kc[0, 2]) / kc[0, 0], (p[:, 1] - kc[1, 2]) / kc[1, 1]], axis=-1)
        return self.rays_to_image(rays)

    def polygon_to_image(self, poly: np.ndarray, steps: int = 8) -> np.ndarray:
        """A canvas polygon as the lens shows it, (N * steps, 2): each edge cut into ``steps``
        pieces first, so that its bend shows in the outline.

        Parameters
        ----------
        poly : np.ndarray
            (N, 2) the polygon's corners on the canvas, px.
        steps : int
            Pieces each edge is cut into.
        """
        p = np.asarray(poly, np.float64).reshape(-1, 2)
        nxt = np.roll(p, -1, axis=0)
        t = np.arange(steps, dtype=np.float64)[None, :, None] / steps
        dense = (p[:, None, :] + t * (nxt - p)[:, None, :]).reshape(-1, 2)
        return self.canvas_to_image(dense)

    def _through_lens(self, rays: np.ndarray) -> np.ndarray:
        """Pixels of normalised rays through the camera's K and distortion (OpenCV's model)."""
        pts = np.concatenate([rays, np.ones((len(rays), 1))], axis=1)
        out, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), self.K, self.dist)
        return out.reshape(-1, 2)
