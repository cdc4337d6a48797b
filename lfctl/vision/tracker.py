"""The leader tracker: CAMShift on hue x saturation x LBP, background-weighted, with a
Bhattacharyya-gated model update, three Kalman filters, explicit TRACKING / OCCLUDED / LOST
states and reacquisition from the banner's marker constellation.

Three kinds share the code so the benchmark compares like with like:

- ``"hue"``: the paper's baseline, classic CAMShift on a hue histogram over the whole frame;
- ``"hs-lbp"``: the paper's features (H x S x LBP, ratio histogram), no filters, no gating;
- ``"full"``: everything: search only a region around the Kalman-predicted window, gate and
  blend the model, coast through occlusions, re-detect the markers when lost or doubtful.

Pure: frames in, :class:`TrackState` out; no clock, file or socket.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import cv2
import numpy as np

from lfctl.vision.boxes import Box, clip_box, iou
from lfctl.vision.camshift import camshift_in_roi
from lfctl.vision.frames import FrameError, check_bgr, check_roi
from lfctl.vision.histogram import FeatureSpace, back_project, bhattacharyya, histogram, ratio_lut
from lfctl.vision.kalman import AreaFilter, CentreFilter, OcclusionCoaster
from lfctl.vision.markers import Constellation, find_constellations, refine
from lfctl.vision.track_state import TrackStatus

__all__ = ["TrackState", "Tracker", "TrackerSettings"]


@dataclass(frozen=True)
class TrackerSettings:
    """Tracker parameters (defaults calibrated on the rendered benchmark suite).

    Parameters
    ----------
    kind : "full", "hs-lbp" or "hue"
        Which tracker (see the module docstring).
    marker_hue_deg : float
        Hue of the banner's markers, degrees.
    panel_over_side : float
        Banner panel size / marker square side: the banner box from the markers.
    lbp_threshold : int
        LBP noise threshold, grey levels (see :func:`~lfctl.vision.lbp.lbp_ri36`).
    d_same : float
        Bhattacharyya distance below which the window still holds the target.
    d_update : float
        Below this the candidate is blended into the model (lighting drift).
    alpha : float
        Blend rate of a model update.
    min_mass : float
        Smallest mean back-projection (0..1) inside a window that still counts.
    search_scale : float
        Search region / predicted window (about 2x).
    ring_scale : float
        The background ring the model is weighted against / the target's window.
    lost_after_frames : int
        Frames OCCLUDED before the track is LOST.
    relearn_after_frames : int
        Frames of marker-confirmed target with a large histogram distance (lighting changed)
        after which the model is learnt afresh from the markers' window.
    use_markers : bool
        Use the banner's marker constellation (start, confirmation, reacquisition); False
        tracks any object by its histogram only.
    """

    kind: Literal["full", "hs-lbp", "hue"] = "full"
    marker_hue_deg: float = 0.0
    panel_over_side: float = 0.22 / 0.14
    lbp_threshold: int = 3
    d_same: float = 0.62
    d_update: float = 0.45
    alpha: float = 0.15
    min_mass: float = 0.12
    search_scale: float = 2.0
    ring_scale: float = 2.0
    lost_after_frames: int = 60
    relearn_after_frames: int = 5
    use_markers: bool = True


@dataclass(frozen=True)
class TrackState:
    """One frame's tracking result (pixels)."""

    frame: int  # index of the frame since init (0 for the first)
    status: TrackStatus  # TRACKING, OCCLUDED (coasting) or LOST
    bbox: Box | None  # the target's window; while OCCLUDED the predicted one; None when LOST
    quality: float  # 0..1
    distance: float  # Bhattacharyya distance of the window to the model (1 when unknown)
    markers: np.ndarray | None  # (4, 2) TL, TR, BR, BL when the constellation was seen
    search: Box | None  # where this frame searched
    reason: str = ""  # why the status is what it is (for logs and recordings)

    @property
    def centre(self) -> tuple[float, float] | None:
        """Centre of :attr:`bbox` (x, y), px; None without a window."""
        if self.bbox is None:
            return None
        x, y, w, h = self.bbox
        return x + w / 2.0, y + h / 2.0


def _scaled(box: Box, scale: float, centre: tuple[float, float] | None = None) -> Box:
    x, y, w, h = box
    cx, cy = centre if centre is not None else (x + w / 2.0, y + h / 2.0)
    nw, nh = max(2.0, w * scale), max(2.0, h * scale)
    return int(round(cx - nw / 2)), int(round(cy - nh / 2)), int(round(nw)), int(round(nh))


def _square(box: Box, scale: float) -> Box:
    """A square region ``scale`` times the box's longer side, on its centre (a histogram window
    can collapse to a thin stripe of the banner; the markers' search must not)."""
    x, y, w, h = box
    side = max(w, h) * scale
    return int(round(x + w / 2.0 - side / 2)), int(round(y + h / 2.0 - side / 2)), int(round(side)), int(round(side))


def _inner(box: Box, frac: float = 0.7) -> Box:
    return _scaled(box, frac)


def _mismatch(box: Box, expect: Box) -> float:
    """How far a box is from where and how big it was expected: centre distance in expected
    sizes plus the log of the size ratio."""
    x, y, w, h = box
    ex, ey, ew, eh = expect
    size, esize = max(1.0, float(np.sqrt(w * h))), max(1.0, float(np.sqrt(ew * eh)))
    shift = float(np.hypot(x + w / 2.0 - ex - ew / 2.0, y + h / 2.0 - ey - eh / 2.0)) / esize
    return shift + abs(float(np.log(size / esize)))


class Tracker:
    """Track one target in a stream of BGR frames; see the module docstring.

    Start with :meth:`init` or :meth:`init_from_markers`, then call :meth:`update` on every
    following frame.

    Parameters
    ----------
    settings : TrackerSettings, optional
        The tracker's kind and parameters (default :class:`TrackerSettings`'s).
    """

    def __init__(self, settings: TrackerSettings | None = None) -> None:
        self.s = settings or TrackerSettings()
        kind = self.s.kind
        self.space = FeatureSpace(
            use_saturation=kind != "hue", use_lbp=kind != "hue", lbp_threshold=self.s.lbp_threshold
        )
        self.frame_index = -1
        self.window: Box | None = None
        self.status = TrackStatus.LOST
        self._lut: np.ndarray | None = None
        self._ref_hist: np.ndarray | None = None
        self._centre: CentreFilter | None = None
        self._area: AreaFilter | None = None
        self._coaster: OcclusionCoaster | None = None
        self._occluded_frames = 0
        self._hidden_height_px: float | None = None  # window height when the target was last seen
        self._relearn_count = 0
        self._markers_seen = False
        self._markers_missing = 0

    # -- initialisation ----------------------------------------------------------------
    def init(self, frame: np.ndarray, roi: Box) -> TrackState:
        """Start on a window the user chose: learn the model there (the state is TRACKING).

        Parameters
        ----------
        frame : np.ndarray
            BGR image, uint8, H x W x 3.
        roi : Box
            The target's window (x, y, w, h), pixels; clipped to the frame.

        Raises
        ------
        FrameError
            A bad frame, or a window that does not overlap it.
        """
        frame = check_bgr(frame)
        roi = check_roi(roi, frame.shape)
        self.frame_index = 0
        self._learn(frame, roi)
        hsv = cv2.cvtColor(frame, cv2.COLOR_BGR2HSV)
        c = (
            self._markers_near(hsv, _scaled(roi, 1.5), roi, strict=True)
            if self.s.use_markers and self.s.kind == "full"
            else None
        )
        self._markers_seen = c is not None
        self._start_filters(roi)
        self.status = TrackStatus.TRACKING
        return TrackState(0, self.status, roi, 1.0, 0.0, c.centres if c else None, None, "init")

    def init_from_markers(self, frame: np.ndarray, expect: Box | None = None) -> TrackState | None:
        """Start on the banner found by its marker constellation anywhere in the frame: the
        one nearest ``expect`` (where the target should appear) when several banners show,
        else the squarest; None (still not started) when no constellation is found.

        Parameters
        ----------
        frame : np.ndarray
            BGR image, uint8, H x W x 3.
        expect : Box, optional
            Where the target's banner should appear (x, y, w, h), pixels.
        """
        frame = check_bgr(frame)
        hsv = cv2.cvtColor(frame, cv2.COLOR_BGR2HSV)
        c = self._markers_near(hsv, (0, 0, frame.shape[1], frame.shape[0]), expect)
        if c is None:
            return None
        box = clip_box(c.banner_bbox(self.s.panel_over_side), frame.shape)
        if box is None:
            return None
        st = self.init(frame, box)
        return replace(st, markers=c.centres, reason="init from markers")

    def _learn(self, frame: np.ndarray, roi: Box) -> None:
        """Model = target histogram weighted by a ring around it."""
        ring = clip_box(_scaled(roi, self.s.ring_scale), frame.shape) or roi
        rx, ry, rw, rh = ring
        region = frame[ry : ry + rh, rx : rx + rw]
        planes, hsv = self.space.features(region)
        tmask = np.zeros((rh, rw), np.uint8)
        x, y, w, h = roi
        tmask[y - ry : y - ry + h, x - rx : x - rx + w] = 255
        if self.s.kind == "hue":
            # classic CAMShift: hue histogram of saturated, bright-enough pixels, no background term
            vis = cv2.inRange(hsv, (0, 60, 32), (180, 255, 255))
            t = histogram(self.space, planes, cv2.bitwise_and(tmask, vis))
            self._lut = cv2.normalize(t, None, 0, 255, cv2.NORM_MINMAX)
            self._ref_hist = t
            return
        t = histogram(self.space, planes, tmask)
        b = histogram(self.space, planes, cv2.bitwise_not(tmask))
        self._lut = ratio_lut(t, b)
        ix, iy, iw, ih = _inner(roi)
        imask = np.zeros((rh, rw), np.uint8)
        imask[max(0, iy - ry) : iy - ry + ih, max(0, ix - rx) : ix - rx + iw] = 255
        self._ref_hist = histogram(self.space, planes, imask)

    def _start_filters(self, box: Box) -> None:
        x, y, w, h = box
        self.window = box
        self._centre = CentreFilter(x + w / 2.0, y + h / 2.0)
        self._area = AreaFilter(float(np.sqrt(w * h)))
        self._coaster = None
        self._occluded_frames = 0

    # -- per frame -----------------------------------------------------------------------
    def update(self, frame: np.ndarray) -> TrackState:
        """Track into the next frame.

        Parameters
        ----------
        frame : np.ndarray
            BGR image, uint8, H x W x 3, the same size as the previous ones.

        Raises
        ------
        FrameError
            A bad frame, or the tracker was never started.
        """
        frame = check_bgr(frame)
        if self._lut is None or self.window is None:
            raise FrameError("tracker not initialised: call init(frame, roi) or init_from_markers(frame) first")
        self.frame_index += 1
        if self.s.kind == "full":
            return self._update_full(frame)
        return self._update_plain(frame)

    def _update_plain(self, frame: np.ndarray) -> TrackState:
        """The baselines: CamShift over the whole frame from the last window. The markers
        inside the window are reported for the pose (the paper's pipeline: track, then
        measure the markers the window holds) but play no part in tracking."""
        assert self._lut is not None and self.window is not None
        planes, hsv = self.space.features(frame)
        prob = back_project(self.space, planes, self._lut)
        if self.s.kind == "hue":  # classic CAMShift: hue means nothing for grey or dark pixels
            prob = cv2.bitwise_and(prob, cv2.inRange(hsv, (0, 60, 32), (180, 255, 255)))
        win, mass = camshift_in_roi(prob, (0, 0), self.window)
        if win[2] <= 0 or win[3] <= 0:
            self.status = TrackStatus.LOST
            return TrackState(self.frame_index, self.status, None, 0.0, 1.0, None, None, "window vanished")
        self.window = win
        self.status = TrackStatus.TRACKING
        markers = None
        region = clip_box(_scaled(win, 1.5), frame.shape) if self.s.use_markers else None
        if region is not None:
            rx, ry, rw, rh = region
            c = self._markers_near(hsv[ry : ry + rh, rx : rx + rw], region, win, origin=(rx, ry), strict=True)
            markers = c.centres if c is not None else None
        return TrackState(
            self.frame_index, self.status, win, mass, 1.0, markers, (0, 0, frame.shape[1], frame.shape[0])
        )

    def _update_full(self, frame: np.ndarray) -> TrackState:
        assert self._centre is not None and self._area is not None and self.window is not None and self._lut is not None
        s = self.s
        pred_c = self._centre.predict()
        pred_size = self._area.predict()
        if self.status is not TrackStatus.TRACKING and self._coaster is not None:
            pred_c = self._coaster.predict()
        _, _, w0, h0 = self.window
        aspect = h0 / max(1, w0)
        pw = max(4.0, pred_size / np.sqrt(max(aspect, 1e-3)))
        ph = max(4.0, pw * aspect)
        pred_win = (int(round(pred_c[0] - pw / 2)), int(round(pred_c[1] - ph / 2)), int(round(pw)), int(round(ph)))
        scale = s.search_scale
        if self.status is not TrackStatus.TRACKING and self._coaster is not None:
            scale += 2.0 * self._coaster.sigma_px / max(pw, ph)  # widen while hidden
        if self.status is TrackStatus.LOST:
            scale = max(scale, 4.0)
        search = clip_box(_scaled(pred_win, scale, pred_c), frame.shape)
        if search is None:
            return self._miss(frame, pred_win, None, 1.0, "prediction left the frame")
        sx, sy, sw, sh = search
        region = frame[sy : sy + sh, sx : sx + sw]
        planes, hsv = self.space.features(region)
        prob = back_project(self.space, planes, self._lut)
        win, mass = camshift_in_roi(prob, (sx, sy), pred_win)
        constellation = self._markers_near(hsv, search, pred_win, origin=(sx, sy)) if s.use_markers else None
        if constellation is None and self._markers_seen:
            self._markers_missing += 1
            if self._markers_missing % 3 == 0:
                # the histogram window may have shrunk onto part of the banner: look wider
                wide = clip_box(_square(win if win[2] > 0 else pred_win, 4.0), frame.shape)
                if wide is not None:
                    wx, wy, ww, wh = wide
                    whsv = cv2.cvtColor(frame[wy : wy + wh, wx : wx + ww], cv2.COLOR_BGR2HSV)
                    constellation = self._markers_near(whsv, wide, pred_win, origin=(wx, wy))
        if constellation is not None:
            self._markers_seen = True
            self._markers_missing = 0
            mbox = clip_box(constellation.banner_bbox(s.panel_over_side), frame.shape)
            if mbox is not None:
                win, mass = mbox, max(mass, 0.5)
        if win[2] <= 0 or win[3] <= 0:
            return self._miss(frame, pred_win, search, 1.0, "window vanished")
        # candidate histogram from the inner part of the window
        ix, iy, iw, ih = _inner(win)
        cmask = np.zeros((sh, sw), np.uint8)
        cmask[max(0, iy - sy) : max(0, iy - sy + ih), max(0, ix - sx) : max(0, ix - sx + iw)] = 255
        cand = histogram(self.space, planes, cmask)
        d = bhattacharyya(cand, self._ref_hist) if self._ref_hist is not None else 1.0
        size = float(np.sqrt(win[2] * win[3]))
        area_ok = self._area.consistent(size)
        if self._coaster is not None and self._hidden_height_px is not None:
            # back from an occlusion the size filter has coasted as long as the centre, and its
            # gate is wide open: a sliver of the banner (CAMShift on the part already in view)
            # must not pass for the target. Hold the window to the height it had when hidden:
            # an upright banner turning away narrows, but keeps its height at a given range.
            area_ok = area_ok and 0.6 <= win[3] / self._hidden_height_px <= 1.6
        good = constellation is not None or (d < s.d_same and mass >= s.min_mass and area_ok)
        if not good:
            why = "area jump" if not area_ok else ("histogram distance" if d >= s.d_same else "weak back-projection")
            return self._miss(frame, pred_win, search, d, why)
        # tracking: update the filters and (carefully) the model
        self.window = win
        self._centre.update(win[0] + win[2] / 2.0, win[1] + win[3] / 2.0)
        self._area.update(size)
        self._coaster = None
        self._occluded_frames = 0
        if d < s.d_update:
            self._blend(cand)
            self._relearn_count = 0
        elif constellation is not None:
            self._relearn_count += 1
            if self._relearn_count >= s.relearn_after_frames:  # lighting changed: learn afresh
                self._learn(frame, win)
                self._relearn_count = 0
        self.status = TrackStatus.TRACKING
        quality = float(np.clip(1.0 - d, 0.0, 1.0)) if constellation is None else max(0.8, 1.0 - d)
        return TrackState(
            self.frame_index, self.status, win, quality, d, constellation.centres if constellation else None, search
        )

    def _blend(self, cand: np.ndarray) -> None:
        assert self._ref_hist is not None
        a = self.s.alpha
        ref = self._ref_hist / max(float(self._ref_hist.sum()), 1e-9)
        new = cand / max(float(cand.sum()), 1e-9)
        self._ref_hist = ((1 - a) * ref + a * new) * float(self._ref_hist.sum())

    def _miss(self, frame: np.ndarray, pred_win: Box, search: Box | None, d: float, why: str) -> TrackState:
        """No acceptable window: coast (OCCLUDED), then LOST; try the markers to come back."""
        assert self._centre is not None
        if self._coaster is None:
            x, P = self._centre.state
            self._coaster = OcclusionCoaster(x, P)
            self._hidden_height_px = float(self.window[3]) if self.window is not None else None
        self._occluded_frames += 1
        self.status = TrackStatus.LOST if self._occluded_frames > self.s.lost_after_frames else TrackStatus.OCCLUDED
        # reacquire: look for the constellation in the (widened) search region, or everywhere when lost
        if self.s.use_markers and self._markers_seen:
            hsv_region = search if self.status is TrackStatus.OCCLUDED else None
            if hsv_region is None and self._occluded_frames % 3 == 0:
                hsv_region = (0, 0, frame.shape[1], frame.shape[0])
            if hsv_region is not None:
                rx, ry, rw, rh = hsv_region
                hsv = cv2.cvtColor(frame[ry : ry + rh, rx : rx + rw], cv2.COLOR_BGR2HSV)
                c = self._markers_near(hsv, hsv_region, pred_win, origin=(rx, ry))
                if c is not None:
                    box = clip_box(c.banner_bbox(self.s.panel_over_side), frame.shape)
                    if box is not None:
                        self._start_filters(box)
                        self.status = TrackStatus.TRACKING
                        return TrackState(
                            self.frame_index, self.status, box, 0.8, d, c.centres, search, "reacquired from markers"
                        )
        box = clip_box(pred_win, frame.shape)
        return TrackState(
            self.frame_index,
            self.status,
            box if self.status is TrackStatus.OCCLUDED else None,
            0.0,
            d,
            None,
            search,
            why,
        )

    def _markers_near(
        self,
        hsv: np.ndarray,
        region: Box,
        expect: Box | None,
        origin: tuple[int, int] = (0, 0),
        strict: bool = False,
    ) -> Constellation | None:
        """The target's constellation in ``hsv`` (an image of ``region``).

        Of several banners in view (a formation: every vehicle carries one), the one whose
        box is nearest ``expect`` in place and size; with ``strict`` it must also overlap it.
        """
        found = find_constellations(hsv, self.s.marker_hue_deg, origin=origin)
        if not found:
            return None
        c = found[0]
        if expect is not None:
            pos = self.s.panel_over_side
            c = min(found, key=lambda k: _mismatch(k.banner_bbox(pos), expect))
            if strict and iou(c.banner_bbox(pos), expect) < 0.2:
                return None
        return refine(c, hsv, self.s.marker_hue_deg, origin)
