"""CAMShift moments (paper eq. 3-8, eq. 7 corrected) and the run on a region of interest."""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["WindowMoments", "camshift_in_roi", "meanshift_in_roi", "window_moments"]

TERM = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 10, 1.0)


@dataclass(frozen=True)
class WindowMoments:
    """Moments of a probability image inside a window and the equivalent ellipse."""

    m00: float  # eq. 3: sum of the probability image inside the window
    xc: float  # eq. 5: centroid column, px (full-image coordinates)
    yc: float  # eq. 5: centroid row, px
    a: float  # eq. 7: M20/M00 - xc^2, px^2
    b: float  # eq. 7: 2 (M11/M00 - xc yc), px^2
    c: float  # eq. 7: M02/M00 - yc^2, px^2
    major: float  # eq. 8 "w": standard deviation along the major axis, px
    minor: float  # eq. 8 "h": along the minor axis, px
    angle_rad: float  # of the major axis from the image x axis


def window_moments(prob: np.ndarray, window: tuple[int, int, int, int]) -> WindowMoments:
    """Eq. 3-8 on ``prob`` inside ``window`` (x, y, w, h), coordinates in the full image.

    Eq. 3 ``M00 = sum I``; eq. 4 first moments; eq. 5 ``(xc, yc) = (M10/M00, M01/M00)``;
    eq. 6 second moments; eq. 7 corrected: ``a = M20/M00 - xc^2``, ``b = 2 (M11/M00 - xc yc)``,
    ``c = M02/M00 - yc^2``; eq. 8 the axes ``sqrt(((a + c) -+ sqrt(b^2 + (a - c)^2)) / 2)``.
    An empty window (``M00 = 0``) gives its centre and zero moments.

    Parameters
    ----------
    prob : np.ndarray
        Probability image (a back-projection), H x W.
    window : Box
        (x, y, w, h), pixels, inside ``prob``.
    """
    x, y, w, h = window
    roi = prob[y : y + h, x : x + w].astype(np.float64)
    ys, xs = np.mgrid[y : y + h, x : x + w]
    m00 = float(roi.sum())
    if m00 <= 0:
        return WindowMoments(0.0, x + w / 2, y + h / 2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    xc = float((xs * roi).sum() / m00)
    yc = float((ys * roi).sum() / m00)
    a = float((xs * xs * roi).sum() / m00 - xc * xc)
    b = float(2.0 * ((xs * ys * roi).sum() / m00 - xc * yc))
    c = float((ys * ys * roi).sum() / m00 - yc * yc)
    root = math.sqrt(b * b + (a - c) ** 2)
    major = math.sqrt(max(0.0, ((a + c) + root) / 2.0))
    minor = math.sqrt(max(0.0, ((a + c) - root) / 2.0))
    angle = 0.5 * math.atan2(b, a - c)
    return WindowMoments(m00, xc, yc, a, b, c, major, minor, angle)


def _part_inside(
    shape: tuple[int, ...], roi_origin: tuple[int, int], window: tuple[int, int, int, int]
) -> tuple[int, int, int, int] | None:
    """The part of ``window`` (full-image pixels) inside a region of ``shape`` at
    ``roi_origin``, in the region's pixels and at least 1 px a side; None when none of it is."""
    ox, oy = roi_origin
    x, y, w, h = window
    rh, rw = shape[:2]
    lx, ly = max(0, x - ox), max(0, y - oy)
    if lx >= rw or ly >= rh or x + w <= ox or y + h <= oy:
        return None
    return lx, ly, max(1, min(w - (lx - (x - ox)), rw - lx)), max(1, min(h - (ly - (y - oy)), rh - ly))


def camshift_in_roi(
    prob_roi: np.ndarray, roi_origin: tuple[int, int], window: tuple[int, int, int, int]
) -> tuple[tuple[int, int, int, int], float]:
    """cv2.CamShift on a back-projection of a region of interest.

    ``window`` and the result are in full-image coordinates; returns the new window and the
    mean probability (0..1) inside it: ``window`` and 0 when none of it is in the region, a
    zero-size window at ``window``'s corner and 0 when CamShift loses it (no probability in
    the window it measures: OpenCV then hands back mean shift's window grown by 10 px a side,
    empty, not an empty size). A window partly outside the region starts on its part inside.

    Parameters
    ----------
    prob_roi : np.ndarray
        8-bit back-projection (0..255) of the region of interest only.
    roi_origin : (int, int)
        The region's top-left corner (x, y) in the full image, px.
    window : Box
        Where to start: (x, y, w, h) in full-image pixels.
    """
    inside = _part_inside(prob_roi.shape, roi_origin, window)
    if inside is None:
        return window, 0.0
    ox, oy = roi_origin
    x, y = window[:2]
    _, (nx, ny, nw, nh) = cv2.CamShift(prob_roi, inside, TERM)
    mass = float(prob_roi[ny : ny + nh, nx : nx + nw].mean()) / 255.0 if nw > 0 and nh > 0 else 0.0
    if mass <= 0.0:
        return (x, y, 0, 0), 0.0
    return (nx + ox, ny + oy, nw, nh), mass


def meanshift_in_roi(
    prob_roi: np.ndarray, roi_origin: tuple[int, int], window: tuple[int, int, int, int]
) -> tuple[tuple[int, int, int, int], float]:
    """cv2.meanShift on a back-projection of a region of interest: the window moves to the
    probability's centroid and keeps its size (CAMShift without eq. 8's resizing).

    ``window`` and the result are in full-image coordinates; returns the moved window (clipped
    to the region) and the mean probability (0..1) inside it, or ``window`` and 0 when none of
    it is in the region. A window partly outside the region starts on its part inside.

    Parameters
    ----------
    prob_roi : np.ndarray
        8-bit back-projection (0..255) of the region of interest only.
    roi_origin : (int, int)
        The region's top-left corner (x, y) in the full image, px.
    window : Box
        Where to start: (x, y, w, h) in full-image pixels.
    """
    inside = _part_inside(prob_roi.shape, roi_origin, window)
    if inside is None:
        return window, 0.0
    ox, oy = roi_origin
    _, (nx, ny, nw, nh) = cv2.meanShift(prob_roi, inside, TERM)
    mass = float(prob_roi[ny : ny + nh, nx : nx + nw].mean()) / 255.0
    return (nx + ox, ny + oy, nw, nh), mass
