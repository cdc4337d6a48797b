"""Colour (paper section 3.1, eq. 1-2): HSV conversion and marker segmentation."""

from __future__ import annotations

import cv2
import numpy as np

from lfctl.vision.frames import check_bgr

__all__ = ["hsv_of_rgb", "hue_window_mask", "to_hsv"]


def hsv_of_rgb(r: float, g: float, b: float) -> tuple[float, float, float]:
    """Eq. 1-2 for one colour: hue in degrees [0, 360), saturation and value in [0, 1].

    ``h = 0`` when ``max = min`` (grey: hue has no meaning).

    Parameters
    ----------
    r, g, b : float
        The colour's red, green and blue, each in [0, 1].
    """
    mx, mn = max(r, g, b), min(r, g, b)
    if mx == mn:
        h = 0.0
    elif mx == r:
        h = (60.0 * (g - b) / (mx - mn) + 360.0) % 360.0
    elif mx == g:
        h = 60.0 * (b - r) / (mx - mn) + 120.0
    else:
        h = 60.0 * (r - g) / (mx - mn) + 240.0
    s = 0.0 if mx == 0 else 1.0 - mn / mx
    return h, s, mx


def to_hsv(frame_bgr: np.ndarray) -> np.ndarray:
    """BGR -> HSV with OpenCV's 8-bit scale: hue 0..179 (degrees / 2), S and V 0..255.

    Parameters
    ----------
    frame_bgr : np.ndarray
        BGR image, uint8, H x W x 3 (else :class:`~lfctl.vision.frames.FrameError`).
    """
    return cv2.cvtColor(check_bgr(frame_bgr), cv2.COLOR_BGR2HSV)


def hue_window_mask(
    hsv: np.ndarray, hue_deg: float, tolerance_deg: float = 18.0, s_min: int = 90, v_min: int = 50
) -> np.ndarray:
    """Pixels whose hue is within ``tolerance_deg`` of ``hue_deg`` and that are saturated and
    bright enough to have a meaningful hue: 255 inside, 0 outside.

    The paper's "within 10 %" of the hue circle is +-18 deg. Red wraps around 0, so the window
    may be two ranges.

    Parameters
    ----------
    hsv : np.ndarray
        HSV image on OpenCV's 8-bit scale (see :func:`to_hsv`).
    hue_deg : float
        The wanted hue, degrees (0..360).
    tolerance_deg : float
        Half-width of the hue window, degrees.
    s_min, v_min : int
        Smallest saturation and value (0..255) a pixel needs for its hue to count.
    """
    h = hue_deg / 2.0
    tol = tolerance_deg / 2.0
    lo, hi = h - tol, h + tol
    floors = (s_min, v_min)
    if lo < 0:
        a = cv2.inRange(hsv, (0, *floors), (hi, 255, 255))
        b = cv2.inRange(hsv, (180 + lo, *floors), (180, 255, 255))
        return cv2.bitwise_or(a, b)
    if hi > 180:
        a = cv2.inRange(hsv, (lo, *floors), (180, 255, 255))
        b = cv2.inRange(hsv, (0, *floors), (hi - 180, 255, 255))
        return cv2.bitwise_or(a, b)
    return cv2.inRange(hsv, (lo, *floors), (hi, 255, 255))
