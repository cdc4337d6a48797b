"""The banner's four markers: segmentation by hue, square blobs (chain codes), and the
constellation check: four blobs of consistent size on the corners of a square, then the
look of a real banner (:func:`check_constellation`): a light panel around them, markers of
the expected hue and saturation, each marker the square's shape in the square's
perspective."""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from lfctl.config import BannerConfig
from lfctl.vision.boxes import point_bounds
from lfctl.vision.chaincode import Blob, blobs
from lfctl.vision.color import hue_window_mask

__all__ = [
    "BannerLook",
    "Constellation",
    "check_constellation",
    "find_constellation",
    "find_constellations",
    "order_corners",
    "refine",
]


@dataclass(frozen=True)
class BannerLook:
    """What the banner looks like, for :func:`check_constellation` (defaults: the default
    ``[banner]``; :meth:`from_config` takes a scenario's).

    Parameters
    ----------
    marker_saturation : float
        The markers' saturation (0..1) as printed (HSV).
    marker_over_side : float
        Marker side / the side of the square the marker centres sit on.
    panel_over_side : float
        Panel side / the side of the square the marker centres sit on.
    """

    marker_saturation: float = 0.85
    marker_over_side: float = 0.035 / 0.14
    panel_over_side: float = 0.22 / 0.14

    @staticmethod
    def from_config(cfg: BannerConfig) -> BannerLook:
        """The look a scenario's ``[banner]`` describes.

        Parameters
        ----------
        cfg : BannerConfig
            The ``[banner]`` section.
        """
        return BannerLook(cfg.marker_saturation, cfg.marker_size_m / cfg.side_m, cfg.panel_size_m / cfg.side_m)


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
        x0, y0, x1, y1 = point_bounds(c + (self.centres - c) * panel_over_side)
        return x0, y0, x1 - x0, y1 - y0


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
    rows = np.arange(len(quads))[:, None]  # indexing with it: np.take_along_axis costs 15 us a call
    by_y = np.argsort(quads[:, :, 1], axis=1, kind="stable")
    top, bottom = by_y[:, :2], by_y[:, 2:]
    tx, bx = quads[rows, top, 0], quads[rows, bottom, 0]
    top = np.where((tx[:, 0] <= tx[:, 1])[:, None], top, top[:, ::-1])
    bottom = np.where((bx[:, 0] <= bx[:, 1])[:, None], bottom, bottom[:, ::-1])
    idx = np.stack([top[:, 0], top[:, 1], bottom[:, 1], bottom[:, 0]], axis=1)
    return quads[rows, idx], idx


def constellation_scores(c: np.ndarray, sizes: np.ndarray, marker_over_side: float = 0.25) -> np.ndarray:
    """0..1 for each of M ordered quads (M, 4, 2) of marker centres (TL, TR, BR, BL) with
    their blob areas (M, 4): how well four points fit a square's corners seen in perspective
    on an upright banner that may be turned up to ~70 deg.

    Checks: the vertical sides stay upright; the top and bottom sides match (they lie at the
    same depths); each side's markers match each other; the nearer side's markers are larger
    by the square of the side-height ratio (perspective); markers are the banner's fraction of
    the square: sqrt(marker area) / square height is ``marker_over_side`` head-on and
    ``marker_over_side * sqrt(cos yaw)`` turned (0.6x at 70 deg), and a blurred small marker
    loses a pixel's rim; 0.5-1.6 times it is accepted.
    """
    tl, tr, br, bl = c[:, 0], c[:, 1], c[:, 2], c[:, 3]
    down_left, down_right = bl - tl, br - tr
    left, right = _lengths(down_left), _lengths(down_right)
    top, bottom = _lengths(tr - tl), _lengths(br - bl)
    ok = np.minimum(np.minimum(left, right), np.minimum(top, bottom)) >= 2.0
    left, right = np.maximum(left, 1e-9), np.maximum(right, 1e-9)
    aspect = ((top + bottom) / 2) / ((left + right) / 2)  # ~cos(yaw): 1 head-on
    ok &= (aspect >= 0.2) & (aspect <= 1.4)
    upright = 1.0 - np.minimum(1.0, (np.abs(down_left[:, 0]) + np.abs(down_right[:, 0])) / (left + right))
    width_match = np.minimum(top, bottom) / np.maximum(np.maximum(top, bottom), 1e-9)
    s_tl, s_tr, s_br, s_bl = sizes[:, 0], sizes[:, 1], sizes[:, 2], sizes[:, 3]
    pair_match = np.minimum(s_tl, s_bl) / np.maximum(s_tl, s_bl) * np.minimum(s_tr, s_br) / np.maximum(s_tr, s_br)
    expected = (right / left) ** 2  # right-side / left-side marker area from perspective
    got = (s_tr + s_br) / (s_tl + s_bl)
    perspective = np.minimum(expected / got, got / expected)
    scale = np.sqrt(np.add.reduce(sizes, axis=1) / 4) / ((left + right) / 2)  # the mean size's root
    ok &= (scale >= 0.5 * marker_over_side) & (scale <= 1.6 * marker_over_side)
    score = upright * width_match * np.sqrt(pair_match) * np.sqrt(perspective)
    return np.where(ok, score, 0.0)


def _lengths(v: np.ndarray) -> np.ndarray:
    """The length of each of M vectors (M, 2), as np.linalg.norm(v, axis=1) computes it, without
    its checks (a third of constellation_scores' time went to four norm calls)."""
    return np.sqrt(np.add.reduce(v * v, axis=1))


def find_constellation(
    hsv: np.ndarray, hue_deg: float, origin: tuple[int, int] = (0, 0), look: BannerLook | None = None
) -> Constellation | None:
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
    look : BannerLook, optional
        What the banner looks like (default :class:`BannerLook`'s).
    """
    found = find_constellations(hsv, hue_deg, origin, limit=1, look=look)
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
    look: BannerLook | None = None,
) -> list[Constellation]:
    """Up to ``limit`` candidate constellations, best first, with blob-centroid centres
    (:func:`refine` the one you keep), each of which looks like a real banner
    (:func:`check_constellation`).

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
    look : BannerLook, optional
        What the banner looks like (default :class:`BannerLook`'s).
    """
    look = look or BannerLook()
    mask = hue_window_mask(hsv, hue_deg, tolerance_deg, s_min, v_min)
    # an opening whose dilation reaches back the way its erosion ate: OpenCV's MORPH_OPEN with
    # an even kernel anchors both at its centre, (1, 1), which moves every blob 1 px down and right
    mask = cv2.dilate(cv2.erode(mask, _OPEN_KERNEL, anchor=(1, 1)), _OPEN_KERNEL, anchor=(0, 0))
    cands = [b for b in blobs(mask, min_area_px=4.0) if b.is_square(0.6, 3.5)]  # foreshortened up to ~70 deg
    if len(cands) < 4:
        return []
    cands.sort(key=lambda b: -b.area_px)
    cands = cands[:10]  # the banners' markers are among the larger square blobs
    combos = _combinations(len(cands))
    ordered, idx = _order_many(np.array([b.centroid for b in cands])[combos])  # (M, 4, 2)
    combos = combos[np.arange(len(combos))[:, None], idx]  # the blobs of each, in order
    sizes = np.array([b.area_px for b in cands])[combos]
    scores = constellation_scores(ordered, sizes, look.marker_over_side)
    out: list[Constellation] = []
    for k in np.argsort(-scores, kind="stable"):
        if scores[k] < min_score or len(out) >= limit:
            break
        chosen = tuple(cands[j] for j in combos[k].tolist())
        candidate = Constellation(ordered[k], chosen, float(scores[k]))
        if not check_constellation(candidate, hsv, hue_deg, look, tolerance_deg, s_min, v_min):
            out.append(Constellation(ordered[k] + np.array(origin, float), chosen, float(scores[k])))
    return out


#: the opening that drops single-pixel specks from the marker mask (shared, never written)
_OPEN_KERNEL = np.ones((2, 2), np.uint8)
_OPEN_KERNEL.flags.writeable = False


@functools.cache
def _combinations(n: int) -> np.ndarray:
    """Every choice of 4 of ``n`` indices, (M, 4), in itertools' order."""
    combos = np.array(list(itertools.combinations(range(n), 4)))
    combos.flags.writeable = False  # shared by every call
    return combos


def _hue_off_deg(hue: np.ndarray, target: int) -> np.ndarray:
    """|hue - target| in whole degrees on the circle (OpenCV hue: degrees / 2, 0..179), int16."""
    d = np.abs(hue.astype(np.int16) - target)
    return np.minimum(d, 180 - d) * 2


@functools.cache
def _hue_off_table(target: int) -> np.ndarray:
    """:func:`_hue_off_deg` of every 8-bit hue, int16 (a table look-up per pixel)."""
    table = _hue_off_deg(np.arange(256), target)
    table.flags.writeable = False  # shared by every call
    return table


#: the unit square's corners TL, TR, BR, BL, for the perspective check (shared, never written)
_UNIT_SQUARE = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
_UNIT_SQUARE.flags.writeable = False

#: a marker blob smaller than this (px; 4 x 4) is mostly its blurred rim, whose pixels blend
#: the marker's colour with the panel's: its saturation is that of its most saturated pixel
#: (the rendered banner 8 m out: 2-3 px markers, medians 130-150 of 255, cores 200-216)
TINY_MARKER_PX = 16.0


def check_constellation(
    c: Constellation,
    hsv: np.ndarray,
    hue_deg: float,
    look: BannerLook | None = None,
    tolerance_deg: float = 18.0,
    s_min: int = 90,
    v_min: int = 40,
) -> str:
    """Whether four blobs that sit like a banner's markers also look like one: "" when they
    do, else the name of the first check that fails.

    Four reddish spots on the corners of a square turn up in real video (a face, brickwork,
    window frames). Each check was measured on lfctl's labelled footage (the 36 false
    constellations the finder reported there before these checks, scores 0.45-0.76) and on
    the rendered tiers (606 true ones: every 10th frame of 7 tiers x 3 seeds) together. The
    marker colour check alone rejects all 36, and so does the panel check; with the tighter
    marker-to-square size of :func:`constellation_scores` (which already drops 26 of them)
    all are rejected and all 606 true ones kept:

    - ``"marker colour"``: each marker's median hue within half the segmentation window of
      ``hue_deg`` and its median saturation at least 0.7 of the printed one (of a marker
      under :data:`TINY_MARKER_PX`, its most saturated pixel's). The reddish surfaces that
      fall in the window (skin, lips, brick, wood) sit at its orange edge (median hue off by
      6-18 deg) and are less saturated (90-132 of 255; the one constellation of tiny blobs
      on the footage that reaches this check: at most 92); the rendered markers are within
      2 deg and at 196-227.
    - ``"marker shape"``: each marker as wide for its height as the square it sits on (a
      square seen turned narrows as the constellation does): within 30 % and a pixel.
      Rendered markers: 0.79-1.19 of it; false ones 0.38-3.7.
    - ``"perspective"``: the homography from a unit square to the four centres has a
      projective part under 0.6: the depth across the markers varies by less than 60 % (a
      0.14 m square turned 70 deg is that close at 0.2 m); rendered banners: at most 0.46;
      false ones up to 6.9 (half of them over 0.6).
    - ``"panel"``: at least 60 % of the panel around and between the markers is light: less
      than half as saturated as the markers and at least half as bright. Rendered banners:
      94-100 % (in the shadow band too); false constellations at most 39 %.

    Parameters
    ----------
    c : Constellation
        A candidate, its centres in ``hsv``'s pixels.
    hsv : np.ndarray
        The HSV image it was found in (OpenCV's 8-bit scale).
    hue_deg : float
        The markers' hue, degrees.
    look : BannerLook, optional
        What the banner looks like (default :class:`BannerLook`'s).
    tolerance_deg : float
        Half-width of the hue window the markers were segmented with, degrees.
    s_min, v_min : int
        Smallest saturation and value (0..255) of a marker pixel, as segmented.
    """
    look = look or BannerLook()
    H, W = hsv.shape[:2]
    pts = np.asarray(c.centres, np.float64)
    (x_tl, y_tl), (x_tr, y_tr), (x_br, y_br), (x_bl, y_bl) = pts.tolist()
    across = math.hypot(x_tr - x_tl, y_tr - y_tl) + math.hypot(x_br - x_bl, y_br - y_bl)
    down = math.hypot(x_bl - x_tl, y_bl - y_tl) + math.hypot(x_br - x_tr, y_br - y_tr)
    aspect = across / max(1e-9, down)
    hue_off_of = _hue_off_table(int(round(hue_deg / 2.0)) % 180)
    sats, vals = [], []
    # every marker's pixels in one array: one conversion, hue look-up and threshold for all
    # of them (on a marker's few pixels numpy's cost per call was most of the time); each
    # marker's rows are then its own, in the same order, so the same medians
    boxes = [b.bbox for b in c.blobs]
    regions = [hsv[max(0, y) : y + h, max(0, x) : x + w].reshape(-1, 3) for x, y, w, h in boxes]
    every = np.concatenate(regions).astype(np.int16) if regions else np.zeros((0, 3), np.int16)
    every[:, 0] = hue_off_of[every[:, 0]]
    marker = (every[:, 0] <= tolerance_deg) & (every[:, 1] >= s_min) & (every[:, 2] >= v_min)
    end = 0
    for b, (_x, _y, w, h), region in zip(c.blobs, boxes, regions, strict=True):
        start, end = end, end + region.shape[0]
        if abs(w - aspect * h) > 0.3 * aspect * h + 1.0:
            return "marker shape"
        on = every[start:end][marker[start:end]]
        if on.shape[0] == 0:
            return "marker colour"
        k = on.shape[0] // 2
        hue_off, sat, val = np.partition(on, k, axis=0)[k].tolist()  # the medians (upper of an even count)
        # a marker mostly rim, blended with the panel, is judged by its core (the panel check
        # below still compares with the medians)
        judged = int(on[:, 1].max()) if b.area_px < TINY_MARKER_PX else sat
        if hue_off > tolerance_deg / 2.0 or judged < 0.7 * look.marker_saturation * 255.0:
            return "marker colour"
        sats.append(sat)
        vals.append(val)
    homography = cv2.getPerspectiveTransform(_UNIT_SQUARE, pts.astype(np.float32))
    if np.hypot(homography[2, 0], homography[2, 1]) / max(abs(homography[2, 2]), 1e-9) > 0.6:
        return "perspective"
    centre = pts.mean(axis=0)
    quad = np.round(centre + (pts - centre) * look.panel_over_side * 0.95).astype(np.int32)
    # the panel's pixels, within its bounding box in the image
    x0, y0 = max(0, int(quad[:, 0].min())), max(0, int(quad[:, 1].min()))
    x1, y1 = min(W, int(quad[:, 0].max()) + 1), min(H, int(quad[:, 1].max()) + 1)
    if x1 <= x0 or y1 <= y0:
        return "panel"
    panel = np.zeros((y1 - y0, x1 - x0), np.uint8)
    cv2.fillConvexPoly(panel, quad - np.array([x0, y0], np.int32), 255)
    for b in c.blobs:  # the markers and their blurred rims are not panel
        x, y, w, h = b.bbox
        x, y = x - x0, y - y0
        cv2.rectangle(panel, (x - 1 - w // 3, y - 1 - h // 3), (x + w + w // 3, y + h + h // 3), 0, -1)
    n_panel = cv2.countNonZero(panel)
    expected = cv2.contourArea(quad.astype(np.float32)) * (
        1.0 - 4.0 * (look.marker_over_side / look.panel_over_side) ** 2
    )
    if n_panel < 0.3 * expected:
        return "panel"  # mostly outside the image: too little of it to tell
    # light: saturation below half the markers' and value at least half theirs (whole levels)
    sat_below, val_from = math.ceil(0.5 * sorted(sats)[2]), math.ceil(0.5 * sorted(vals)[2])
    light = cv2.inRange(hsv[y0:y1, x0:x1], (0, 0, val_from), (255, sat_below - 1, 255))
    if n_panel and cv2.countNonZero(cv2.bitwise_and(light, panel)) / n_panel < 0.6:
        return "panel"
    return ""


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


@functools.lru_cache(maxsize=64)  # keyed on a float tolerance: bounded
def _refine_tables(target: int, tolerance_deg: float, s_floor: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`refine_centre`'s per-pixel weights as two 256-entry tables (a marker is a few
    pixels: a table look-up costs a third of the image operations it replaces): hue (OpenCV's
    0..179, ``target`` its value) -> 255 within ``tolerance_deg`` on the circle, else 0;
    saturation -> how far it is above ``s_floor`` (0 below)."""
    on_hue = np.where(_hue_off_table(target) <= tolerance_deg, 255, 0).astype(np.uint8)
    levels = np.arange(256, dtype=np.uint8)
    over_floor = cv2.subtract(levels, np.full_like(levels, s_floor)).ravel()
    for table in (on_hue, over_floor):
        table.flags.writeable = False  # shared by every call
    return on_hue, over_floor


def refine_centre(
    hsv: np.ndarray, blob: Blob, hue_deg: float, tolerance_deg: float, s_floor: int = 30
) -> tuple[float, float]:
    """Sub-pixel marker centre: the centroid weighted by saturation above ``s_floor`` over the
    pixels of the marker's hue around the blob (edge pixels count by how much marker they hold)."""
    x, y, w, h = blob.bbox
    H, W = hsv.shape[:2]
    x0, y0, x1, y1 = max(0, x - 2), max(0, y - 2), min(W, x + w + 2), min(H, y + h + 2)
    roi = hsv[y0:y1, x0:x1]
    on_hue, over_floor = _refine_tables(int(round(hue_deg / 2.0)) % 180, tolerance_deg, s_floor)
    m = cv2.moments(on_hue[roi[:, :, 0]] & over_floor[roi[:, :, 1]])
    if m["m00"] <= 0:
        return blob.centroid
    return x0 + m["m10"] / m["m00"], y0 + m["m01"] / m["m00"]
