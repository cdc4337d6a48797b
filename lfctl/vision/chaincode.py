"""Contours as Freeman chain codes (paper section 3.2, fig. 2) and blob shape measures.

OpenCV's ``findContours(..., CHAIN_APPROX_NONE)`` gives every border pixel (8-connected
border following); the chain code is the direction between successive pixels. Codes follow
the paper's figure 2 table: 0 = next column (right), 2 = previous row (up), 4 = left,
6 = next row (down), odd codes the diagonals between them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Blob", "blobs", "chain_code", "chain_perimeter"]

#: (dx, dy) in image coordinates (x right, y down) -> Freeman code, as in fig. 2
FREEMAN = {(1, 0): 0, (1, -1): 1, (0, -1): 2, (-1, -1): 3, (-1, 0): 4, (-1, 1): 5, (0, 1): 6, (1, 1): 7}


_LUT = np.full(9, -1, np.int8)  # index (dx + 1) * 3 + (dy + 1) -> code
for (_dx, _dy), _code in FREEMAN.items():
    _LUT[(_dx + 1) * 3 + (_dy + 1)] = _code


def chain_code(contour: np.ndarray, check: bool = True) -> list[int]:
    """Freeman codes of a closed 8-connected contour, one per step (the last one back to the
    first point); empty for fewer than two points.

    Parameters
    ----------
    contour : np.ndarray
        Points (x, y) in order, (N, 1, 2) as findContours gives them or (N, 2), px.
    check : bool
        Raise ValueError when two successive points are not 8-neighbours; False skips the
        check for contours from findContours with CHAIN_APPROX_NONE, which are 8-connected
        by construction.
    """
    pts = np.asarray(contour).reshape(-1, 2)
    if len(pts) < 2:
        return []
    d = np.empty_like(pts)
    d[:-1] = pts[1:] - pts[:-1]
    d[-1] = pts[0] - pts[-1]
    if check and (np.abs(d).max() > 1 or np.any((d == 0).all(axis=1))):
        bad = d[(np.abs(d).max(axis=1) > 1) | (d == 0).all(axis=1)][0]
        raise ValueError(f"contour is not 8-connected: step {(int(bad[0]), int(bad[1]))}")
    return _LUT[(d[:, 0] + 1) * 3 + (d[:, 1] + 1)].tolist()


def chain_perimeter(codes: list[int]) -> float:
    """Freeman perimeter: 1 per even (axis) step, sqrt(2) per odd (diagonal) step, px.

    Parameters
    ----------
    codes : list of int
        Freeman codes 0..7 (see :func:`chain_code`).
    """
    return _freeman_length(len(codes), sum(c & 1 for c in codes))


def _freeman_length(steps: int, diagonal: int) -> float:
    """The Freeman length of ``steps`` steps of which ``diagonal`` are diagonal, px."""
    return (steps - diagonal) + diagonal * math.sqrt(2.0)


@dataclass(frozen=True)
class Blob:
    """A segmented blob: its outer border and shape measures (pixels).

    Parameters
    ----------
    codes : tuple of int
        Freeman chain code of the outer border (see :func:`chain_code`).
    start : (int, int)
        The border pixel the chain code starts from, (x, y).
    area_px : float
        Pixels the blob covers, estimated from its border, px^2.
    perimeter_px : float
        Freeman perimeter of the outer edge of the border pixels, px.
    centroid : (float, float)
        Centre of the area its border encloses (x, y), px (the box centre when that area is 0).
    bbox : (int, int, int, int)
        Bounding box x, y, w, h, px.
    """

    codes: tuple[int, ...]
    start: tuple[int, int]
    area_px: float
    perimeter_px: float
    centroid: tuple[float, float]
    bbox: tuple[int, int, int, int]  # x, y, w, h

    @property
    def squareness(self) -> float:
        """``4 sqrt(area) / perimeter``: 1 for an axis-aligned square, lower for thin or ragged shapes."""
        return 4.0 * math.sqrt(self.area_px) / self.perimeter_px if self.perimeter_px > 0 else 0.0

    def is_square(self, min_squareness: float = 0.75, max_aspect: float = 2.0) -> bool:
        """A square marker seen in perspective: compact, not much longer than wide.

        Parameters
        ----------
        min_squareness : float
            Smallest :attr:`squareness` accepted (1 for an axis-aligned square).
        max_aspect : float
            Largest ratio of the bounding box's longer side to its shorter side.
        """
        _, _, w, h = self.bbox
        aspect = max(w, h) / max(1, min(w, h))
        return self.squareness >= min_squareness and aspect <= max_aspect


def blobs(mask: np.ndarray, min_area_px: float = 4.0) -> list[Blob]:
    """Outer blobs of a binary mask with their chain codes and shape measures (holes are
    ignored).

    Parameters
    ----------
    mask : np.ndarray
        Binary image, uint8, non-zero inside.
    min_area_px : float
        Blobs covering fewer pixels are dropped, px^2.
    """
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    out: list[Blob] = []
    for c, (codes, diagonal) in zip(contours, _chain_codes(contours), strict=True):
        m = cv2.moments(c)
        # the border's own area underestimates small blobs; count the pixels it encloses
        area = max(m["m00"], 0.0)
        x, y, w, h = cv2.boundingRect(c)
        pixel_area = float(w * h) if len(c) <= 4 else area + len(c) / 2.0 + 1.0
        if pixel_area < min_area_px:
            continue
        perim = _freeman_length(len(codes), diagonal) + 4.0  # border pixel centres -> outer edge of the pixels
        cx, cy = (m["m10"] / m["m00"], m["m01"] / m["m00"]) if m["m00"] > 0 else (x + (w - 1) / 2, y + (h - 1) / 2)
        out.append(
            Blob(
                tuple(codes),
                (int(c[0, 0, 0]), int(c[0, 0, 1])),
                pixel_area,
                perim,
                (float(cx), float(cy)),
                (x, y, w, h),
            )
        )
    return out


def _chain_codes(contours: Sequence[np.ndarray]) -> list[tuple[list[int], int]]:
    """:func:`chain_code` (unchecked) of each of findContours' contours and how many of its
    steps are diagonal, in one pass over all their points: a mask holds tens to hundreds of
    short contours, and numpy's cost per call was most of the time."""
    if not contours:
        return []
    lengths = np.array([len(c) for c in contours])
    ends = np.cumsum(lengths)
    starts = ends - lengths
    pts = np.concatenate(contours).reshape(-1, 2)
    following = np.arange(1, len(pts) + 1)
    following[ends - 1] = starts  # each contour's last point steps back to its first
    step = pts[following] - pts
    codes = _LUT[(step[:, 0] + 1) * 3 + (step[:, 1] + 1)]
    diagonal = np.add.reduceat((codes & 1).astype(np.intp), starts).tolist()
    flat = codes.tolist()
    return [
        (flat[a:b], d) if b - a > 1 else ([], 0)  # a single point has no steps
        for a, b, d in zip(starts.tolist(), ends.tolist(), diagonal, strict=True)
    ]
