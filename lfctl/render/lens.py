"""The lens: a rendered frame bent as the camera's lens bends a real picture.

A camera with distortion coefficients (OpenCV's model: radial ``k1``, ``k2``, ``k3`` and
tangential ``p1``, ``p2``) puts a point whose ideal (pinhole) image is ``p`` at
``distort(p)``; the vision pipeline takes that out again (``cv2.solvePnP`` and
:meth:`CameraModel.rays` with the same coefficients). To match it, the renderer draws an
ideal pinhole picture on a *canvas* and :meth:`Lens.bend` resamples it: each output pixel
takes the canvas's colour along that pixel's ray, which :func:`~lfctl.vision.camera_model.undistort`
finds by inverting the lens model. A barrel lens (``k1 < 0``) sees more than a pinhole of the
same focal length, so the canvas is a pinhole camera of the same size zoomed out just enough
(focal length times :attr:`Lens.scale`, at most 1) to hold every output pixel's ray; its
middle is then drawn at that much less resolution than the lens shows it.

The rays are found exactly on a grid of every :data:`GRID_PX`-th pixel and interpolated
between (the map is smooth: a few thousandths of a pixel off), so a large frame's lens is
built in a fraction of a second. What the truth says of the picture (the banner's box and
visible share) is read from masks drawn on the canvas and bent as the frame is.

Coefficients whose radial function stops growing inside the picture (a strong ``k1 < 0``
with a wide lens) describe no lens: they are refused, naming them.
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np

from lfctl.errors import ConfigError
from lfctl.vision.boxes import Box
from lfctl.vision.camera_model import CameraModel

__all__ = ["GRID_PX", "Lens"]

#: the rays are computed exactly at every this many pixels (and the picture's last row and
#: column) and interpolated between
GRID_PX = 8


def _grid(size: int) -> np.ndarray:
    """Every GRID_PX-th pixel of a side, and its last."""
    return np.unique(np.append(np.arange(0, size, GRID_PX), size - 1)).astype(np.float64)


def _spread(at: np.ndarray, size: int) -> np.ndarray:
    """Linear interpolation weights (size, len(at)) from grid points ``at`` to every pixel."""
    w = np.zeros((size, len(at)))
    idx = np.clip(np.searchsorted(at, np.arange(size), side="right") - 1, 0, len(at) - 2)
    frac = (np.arange(size) - at[idx]) / (at[idx + 1] - at[idx])
    w[np.arange(size), idx] = 1 - frac
    w[np.arange(size), idx + 1] = frac
    return w


class Lens:
    """The lens of ``camera`` (which has some distortion): the canvas camera to render the
    ideal picture with, the resampling that bends it, and the truth of what the picture
    shows of a painted polygon.

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
        self.camera = camera
        self.K = camera.K
        camera.check_lens()  # (a lens whose model folds inside the picture: refused)
        us, vs = _grid(w), _grid(h)
        gu, gv = np.meshgrid(us, vs)
        rays = camera.rays(np.column_stack([gu.ravel(), gv.ravel()]))
        if not np.all(np.isfinite(rays)):  # (past the border's check: a lens folding inside)
            raise ConfigError(
                f"the camera's distortion has no ray for some pixels inside its {w}x{h} picture: "
                "take the coefficients from a calibration of this lens"
            )
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
        wy, wx = _spread(vs, h), _spread(us, w)
        map_x = (wy @ (kc[0, 0] * rays[:, 0] + kc[0, 2]).reshape(len(vs), len(us)) @ wx.T).astype(np.float32)
        map_y = (wy @ (kc[1, 1] * rays[:, 1] + kc[1, 2]).reshape(len(vs), len(us)) @ wx.T).astype(np.float32)
        self._maps = cv2.convertMaps(map_x, map_y, cv2.CV_16SC2)
        # the canvas pixels the picture shows (where its rays land), for the visible share
        footprint = np.zeros((h, w), np.uint8)
        footprint[np.clip(np.rint(map_y), 0, h - 1).astype(int), np.clip(np.rint(map_x), 0, w - 1).astype(int)] = 1
        self._footprint = cv2.dilate(footprint, np.ones((3, 3), np.uint8))

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

    def shown(self, target: np.ndarray, nearer: list[np.ndarray]) -> tuple[Box | None, float]:
        """What the picture shows of a polygon painted on the canvas: its box in the picture
        (None when it shows nowhere), and the share of it in view and not hidden by the
        ``nearer`` polygons (its part outside the picture counts as hidden), read from masks
        drawn on the canvas and bent as the frame is.

        Parameters
        ----------
        target : np.ndarray
            (N, 2) the polygon on the canvas, px.
        nearer : list of np.ndarray
            Polygons painted over it, on the canvas.
        """
        h, w = self._footprint.shape
        mask = np.zeros((h, w), np.uint8)
        cv2.fillPoly(mask, [np.round(target).astype(np.int32)], 255)
        seen = cv2.remap(mask, self._maps[0], None, cv2.INTER_NEAREST)
        if not cv2.countNonZero(seen):
            return None, 0.0
        box = tuple(int(v) for v in cv2.boundingRect(seen))
        for poly in nearer:
            cv2.fillPoly(mask, [np.round(poly).astype(np.int32)], 0)
        full = abs(cv2.contourArea(np.asarray(target, np.float32)))
        shown = cv2.countNonZero(cv2.bitwise_and(mask, mask, mask=self._footprint))
        return box, (min(1.0, shown / full) if full > 0 else 0.0)  # type: ignore[return-value]
