"""Axis-aligned image boxes ``(x, y, w, h)`` in pixels: the one IoU every tracker, test,
benchmark and replay scores with."""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["Box", "clip_box", "iou"]

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
