"""Input checks shared by the vision functions: a bad frame or ROI is a clear error."""

from __future__ import annotations

import math

import numpy as np

from lfctl.errors import LfctlError

__all__ = ["FrameError", "check_bgr", "check_roi", "colourless"]

#: a pixel whose channels differ by more than this many grey levels has a colour
GREY_SPREAD = 8
#: a frame with fewer such pixels than this share has none (a mono or infrared camera's,
#: with compression's faint tints)
COLOURED_SHARE = 0.001


class FrameError(LfctlError, ValueError):
    """A frame or region of interest is not usable; the message says what was wrong."""


def check_bgr(frame: object) -> np.ndarray:
    """The frame as a non-empty uint8 H x W x 3 array, or :class:`FrameError`.

    Parameters
    ----------
    frame : object
        What a video source or caller handed over (None when the source gave no image).
    """
    if frame is None:
        raise FrameError("frame is None (the source returned no image)")
    if not isinstance(frame, np.ndarray):
        raise FrameError(f"frame must be a numpy array, got {type(frame).__name__}")
    if frame.size == 0:
        raise FrameError(f"frame is empty (shape {frame.shape})")
    if frame.dtype != np.uint8:
        raise FrameError(f"frame must be uint8, got {frame.dtype}")
    if frame.ndim != 3 or frame.shape[2] != 3:
        raise FrameError(f"frame must be H x W x 3 (BGR), got shape {frame.shape}")
    return frame


def check_roi(roi: tuple[int, int, int, int], shape: tuple[int, ...]) -> tuple[int, int, int, int]:
    """An (x, y, w, h) window with positive size that overlaps the frame, clipped to it, or
    :class:`FrameError`.

    Parameters
    ----------
    roi : tuple of 4 numbers
        (x, y, w, h), pixels; rounded to integers.
    shape : tuple of int
        The frame's shape; only H and W are read.
    """
    try:
        if isinstance(roi, str | bytes):  # iterable, but no window
            raise TypeError
        values = [float(v) for v in roi]
    except (TypeError, ValueError):
        raise FrameError(f"ROI must be four numbers x, y, w, h; got {roi!r}") from None
    if len(values) != 4:
        raise FrameError(f"ROI must be x, y, w, h; got {roi!r}")
    if not all(math.isfinite(v) for v in values):
        raise FrameError(f"ROI must be four finite numbers x, y, w, h; got {roi!r}")
    x, y, w, h = (int(round(v)) for v in values)
    H, W = shape[:2]
    if w <= 0 or h <= 0:
        raise FrameError(f"ROI {x},{y},{w},{h} must have a positive width and height")
    x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + w, W), min(y + h, H)
    if x1 <= x0 or y1 <= y0:
        raise FrameError(f"ROI {x},{y},{w},{h} lies outside the {W}x{H} frame")
    return x0, y0, x1 - x0, y1 - y0


def colourless(frame: np.ndarray) -> bool:
    """Whether a BGR frame shows a scene with no colour: every pixel grey (a monochrome or
    infrared camera, a grey video), give or take compression's faint tints, in a picture
    that is not one flat level (a black frame as a camera starts says nothing). The
    trackers follow hue and saturation, which such a frame has none of.

    Parameters
    ----------
    frame : np.ndarray
        H x W x 3 uint8 BGR.
    """
    sample = frame[::4, ::4].astype(np.int16)  # every 16th pixel is plenty to find colour
    spread = sample.max(axis=2) - sample.min(axis=2)
    grey = int(np.count_nonzero(spread > GREY_SPREAD)) < COLOURED_SHARE * spread.size
    return grey and float(sample.std()) > FLAT_STD


#: a frame whose grey levels spread less than this (standard deviation) is flat: black, or
#: one level, which tells nothing of whether the camera sees colour
FLAT_STD = 2.0
