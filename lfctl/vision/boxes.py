"""Axis-aligned image boxes ``(x, y, w, h)`` in pixels: the one IoU every tracker, test,
benchmark and replay scores with."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["Box", "clip_box", "iou", "point_bounds"]

Box = tuple[int, int, int, int]


def iou(a: Sequence[float] | None, b: Sequence[float] | None) -> float:
    """Intersection over union of two boxes (0 when either is None or empty).

    Parameters
    ----------
    a, b : sequence of 4 numbers or None
        Boxes as (x, y, w, h), pixels.
    """
    if a is None or b is None:
        return 0.0
    ax, ay, aw, ah = a
    bx, by, bw, bh = b
    ix = max(0, min(ax + aw, bx + bw) - max(ax, bx))
    iy = max(0, min(ay + ah, by + bh) - max(ay, by))
    inter = ix * iy
    union = aw * ah + bw * bh - inter
    return inter / union if union > 0 else 0.0


def clip_box(box: Box, shape: tuple[int, ...]) -> Box | None:
    """The part of ``box`` inside an image of ``shape`` (H, W, ...), or None if none is.

    Parameters
    ----------
    box : Box
        (x, y, w, h), pixels.
    shape : tuple of int
        The image's shape; only H and W are read.
    """
    x, y, w, h = box
    H, W = shape[:2]
    x0, y0, x1, y1 = max(0, x), max(0, y), min(W, x + w), min(H, y + h)
    if x1 <= x0 or y1 <= y0:
        return None
    return x0, y0, x1 - x0, y1 - y0


#: coordinates well inside int64, where math.floor and numpy's astype(int) agree
_INT_SAFE = 2.0**62


def point_bounds(points: np.ndarray) -> tuple[int, int, int, int]:
    """The pixels a set of image points spans: the floor of their least x and y and the
    ceiling of their greatest, ``(x0, y0, x1, y1)``, as ``np.floor(points.min(axis=0))``
    and ``np.ceil(points.max(axis=0))`` converted with ``astype(int)`` give them.

    Worked in Python floats for the few points of a polygon or a banner (numpy's reductions
    cost more than the arithmetic there, several times a frame); points with a non-finite
    coordinate, or beyond int64's range, take numpy's own path (its NaN-propagating min and
    its conversion of those to int), so every input gets numpy's ints.

    Parameters
    ----------
    points : np.ndarray
        (N, 2) image points (x, y), pixels; N >= 1.
    """
    xs, ys = points.T.tolist()
    if math.isfinite(sum(xs) + sum(ys)):
        lx, ly, hx, hy = min(xs), min(ys), max(xs), max(ys)
        if max(-lx, -ly, hx, hy) < _INT_SAFE:
            return math.floor(lx), math.floor(ly), math.ceil(hx), math.ceil(hy)
    with np.errstate(invalid="ignore"):
        x0, y0 = np.floor(points.min(axis=0)).astype(int).tolist()
        x1, y1 = np.ceil(points.max(axis=0)).astype(int).tolist()
    return x0, y0, x1, y1
