"""The banner's four markers: segmentation by hue, square blobs (chain codes), and the
constellation check (four blobs of consistent size on the corners of a square)."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import cv2
import numpy as np

from lfctl.vision.chaincode import Blob, blobs
from lfctl.vision.color import hue_window_mask

__all__ = ["Constellation", "find_constellation", "find_constellations", "order_corners", "refine"]


@dataclass(frozen=True)
class Constellation:
    """Four marker centres in image order TL, TR, BR, BL, and how square they look (0..1)."""

    centres: np.ndarray  # (4, 2), pixels
    blobs: tuple[Blob, ...]  # the four markers' blobs, in the order of ``centres``
    score: float  # 0..1, see constellation_scores

    def banner_bbox(self, panel_over_side: float) -> tuple[int, int, int, int]:
        """Bounding box of the whole banner panel, from the markers (x, y, w, h), pixels.

        Parameters
        ----------
        panel_over_side : float
            Panel side / marker square side (see
            :attr:`~lfctl.vision.banner.BannerGeometry.panel_over_side`).
        """
        c = self.centres.mean(axis=0)
        corners = c + (self.centres - c) * panel_over_side
        x0, y0 = np.floor(corners.min(axis=0)).astype(int)
        x1, y1 = np.ceil(corners.max(axis=0)).astype(int)
        return int(x0), int(y0), int(x1 - x0), int(y1 - y0)


def order_corners(pts: np.ndarray) -> np.ndarray:
    """Order four points TL, TR, BR, BL (image y down): the upper two left to right, then
    the lower two right to left.

    Parameters
    ----------
    pts : array-like
        Four points (x, y), (4, 2), pixels.
    """
    return _order_many(np.asarray(pts, float)[None])[0][0]


def _order_many(quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Order each of M quads (M, 4, 2) TL, TR, BR, BL; also return the index permutation."""
    by_y = np.argsort(quads[:, :, 1], axis=1, kind="stable")
    top, bottom = by_y[:, :2], by_y[:, 2:]
    tx = np.take_along_axis(quads[:, :, 0], top, axis=1)
    bx = np.take_along_axis(quads[:, :, 0], bottom, axis=1)
    top = np.where((tx[:, 0] <= tx[:, 1])[:, None], top, top[:, ::-1])
    bottom = np.where((bx[:, 0] <= bx[:, 1])[:, None], bottom, bottom[:, ::-1])
    idx = np.stack([top[:, 0], top[:, 1], bottom[:, 1], bottom[:, 0]], axis=1)
    return np.take_along_axis(quads, idx[:, :, None], axis=1), idx


def constellation_scores(c: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """0..1 for each of M ordered quads (M, 4, 2) of marker centres (TL, TR, BR, BL) with
    their blob areas (M, 4): how well four points fit a square's corners seen in perspective
    on an upright banner that may be turned up to ~70 deg.

    Checks: the vertical sides stay upright; the top and bottom sides match (they lie at the
    same depths); each side's markers match each other; the nearer side's markers are larger
    by the square of the side-height ratio (perspective); markers are a plausible fraction of
    the square.
    """
    tl, tr, br, bl = c[:, 0], c[:, 1], c[:, 2], c[:, 3]
    left, right = np.linalg.norm(bl - tl, axis=1), np.linalg.norm(br - tr, axis=1)
    top, bottom = np.linalg.norm(tr - tl, axis=1), np.linalg.norm(br - bl, axis=1)
    ok = np.minimum.reduce([left, right, top, bottom]) >= 2.0
    left, right = np.maximum(left, 1e-9), np.maximum(right, 1e-9)
    aspect = ((top + bottom) / 2) / ((left + right) / 2)  # ~cos(yaw): 1 head-on
    ok &= (aspect >= 0.2) & (aspect <= 1.4)
    upright = 1.0 - np.minimum(1.0, (np.abs((bl - tl)[:, 0]) + np.abs((br - tr)[:, 0])) / (left + right))
    width_match = np.minimum(top, bottom) / np.maximum(np.maximum(top, bottom), 1e-9)
    s_tl, s_tr, s_br, s_bl = sizes[:, 0], sizes[:, 1], sizes[:, 2], sizes[:, 3]
    pair_match = np.minimum(s_tl, s_bl) / np.maximum(s_tl, s_bl) * np.minimum(s_tr, s_br) / np.maximum(s_tr, s_br)
    expected = (right / left) ** 2  # right-side / left-side marker area from perspective
    got = (s_tr + s_br) / (s_tl + s_bl)
    perspective = np.minimum(expected / got, got / expected)
    scale = np.sqrt(sizes.mean(axis=1)) / ((left + right) / 2)
    ok &= (scale >= 0.08) & (scale <= 0.6)
    score = upright * width_match * np.sqrt(pair_match) * np.sqrt(perspective)
    return np.where(ok, score, 0.0)


def find_constellation(hsv: np.ndarray, hue_deg: float, origin: tuple[int, int] = (0, 0)) -> Constellation | None:
    """The best-scoring four-marker constellation in an HSV image (or region at ``origin``),
    refined, or None (:func:`find_constellations` has the thresholds and the other candidates).

    Parameters
    ----------
    hsv : np.ndarray
        HSV image (OpenCV's 8-bit scale) of the frame or of a region of it.
    hue_deg : float
        The markers' hue, degrees.
    origin : (int, int)
        The region's top-left corner (x, y) in the frame, px: the centres come back in
        frame pixels.
    """
    found = find_constellations(hsv, hue_deg, origin, limit=1)
    return refine(found[0], hsv, hue_deg, origin) if found else None


def find_constellations(
    hsv: np.ndarray,
    hue_deg: float,
    origin: tuple[int, int] = (0, 0),
    min_score: float = 0.45,
    tolerance_deg: float = 18.0,
    s_min: int = 90,
    v_min: int = 40,
    limit: int = 6,
) -> list[Constellation]:
    """Up to ``limit`` candidate constellations, best first, with blob-centroid centres
    (:func:`refine` the one you keep).

    In a formation every vehicle carries the same banner, so a follower whose target drives
    ahead of another vehicle sees two, and the two can mix: a target's left markers with the
    farther banner's markers peeking out beside it look like one banner turned 70 deg, and
    may score higher than the target seen head-on. Which is the target is for the caller to
    decide from where it expects it; candidates may share markers.

    Parameters
    ----------
    hsv : np.ndarray
        HSV image (OpenCV's 8-bit scale) of the frame or of a region of it.
    hue_deg : float
        The markers' hue, degrees.
    origin : (int, int)
        The region's top-left corner (x, y) in the frame, px: the centres come back in
        frame pixels.
    min_score : float
        Candidates scoring less (0..1) are dropped.
    tolerance_deg : float
        Half-width of the markers' hue window, degrees.
    s_min, v_min : int
        Smallest saturation and value (0..255) of a marker pixel.
    limit : int
        Most candidates returned.
    """
    mask = hue_window_mask(hsv, hue_deg, tolerance_deg, s_min, v_min)
    mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((2, 2), np.uint8))
    cands = [b for b in blobs(mask, min_area_px=4.0) if b.is_square(0.6, 3.5)]  # foreshortened up to ~70 deg
    if len(cands) < 4:
        return []
    cands.sort(key=lambda b: -b.area_px)
    cands = cands[:10]  # the banners' markers are among the larger square blobs
    combos = np.array(list(itertools.combinations(range(len(cands)), 4)))
    pts = np.array([b.centroid for b in cands])[combos]  # (M, 4, 2)
    areas = np.array([b.area_px for b in cands])[combos]
    ordered, idx = _order_many(pts)
    sizes = np.take_along_axis(areas, idx, axis=1)
    scores = constellation_scores(ordered, sizes)
    out: list[Constellation] = []
    for k in np.argsort(-scores, kind="stable")[:limit]:
        if scores[k] < min_score:
            break
        chosen = tuple(cands[int(combos[k][j])] for j in idx[k])
        out.append(Constellation(ordered[k] + np.array(origin, float), chosen, float(scores[k])))
    return out


def refine(
    c: Constellation, hsv: np.ndarray, hue_deg: float, origin: tuple[int, int] = (0, 0), tolerance_deg: float = 18.0
) -> Constellation:
    """The constellation with sub-pixel marker centres (see :func:`refine_centre`).

    Parameters
    ----------
    c : Constellation
        A candidate from :func:`find_constellations` on the same image.
    hsv : np.ndarray
        The HSV image it was found in.
    hue_deg : float
        The markers' hue, degrees.
    origin : (int, int)
        The image's top-left corner (x, y) in the frame, px.
    tolerance_deg : float
        Half-width of the markers' hue window, degrees.
    """
    refined = np.array([refine_centre(hsv, b, hue_deg, tolerance_deg) for b in c.blobs])
    return Constellation(refined + np.array(origin, float), c.blobs, c.score)


def refine_centre(
    hsv: np.ndarray, blob: Blob, hue_deg: float, tolerance_deg: float, s_floor: int = 30
) -> tuple[float, float]:
    """Sub-pixel marker centre: the centroid weighted by saturation above ``s_floor`` over the
    pixels of the marker's hue around the blob (edge pixels count by how much marker they hold)."""
    x, y, w, h = blob.bbox
    H, W = hsv.shape[:2]
    x0, y0, x1, y1 = max(0, x - 2), max(0, y - 2), min(W, x + w + 2), min(H, y + h + 2)
    roi = hsv[y0:y1, x0:x1]
    dh = cv2.absdiff(roi[:, :, 0], np.full(roi.shape[:2], int(round(hue_deg / 2.0)) % 180, np.uint8))
    dh = cv2.min(dh, cv2.subtract(np.full_like(dh, 180), dh))  # hue is circular (0..179)
    on_hue = cv2.compare(dh, tolerance_deg / 2.0, cv2.CMP_LE)
    weight = cv2.bitwise_and(cv2.subtract(roi[:, :, 1], np.full_like(dh, s_floor)), on_hue)
    m = cv2.moments(weight)
    if m["m00"] <= 0:
        return blob.centroid
    return x0 + m["m10"] / m["m00"], y0 + m["m01"] / m["m00"]
