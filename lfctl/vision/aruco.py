"""The ArUco banner's detector: one tag of a known id found with ``cv2.aruco``, in the same
shape as the marker tracker's output so the rest of perception is shared.

    frame -> grey -> cv2.aruco.ArucoDetector (sub-pixel corners) in a search region
          -> the tag's four corners (TL, TR, BR, BL) as :attr:`TrackState.markers`
          -> (perception) solvePnP IPPE_SQUARE on the tag's side -> range and bearing

The search region follows the tag with the tracker's constant-velocity centre filter
(:class:`~lfctl.vision.kalman.CentreFilter`); when the tag is not found the state is
OCCLUDED and :class:`~lfctl.vision.kalman.OcclusionCoaster` carries the predicted window on,
widening the region with its uncertainty, until ``lost_after_frames`` misses make it LOST
(then the whole frame is searched). With several banners printing the same id (a
formation), the one nearest the expected or predicted window is the target.

Pure: frames in, :class:`~lfctl.vision.tracker.TrackState` out.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from lfctl.vision.boxes import Box, clip_box
from lfctl.vision.frames import FrameError, check_bgr, check_roi
from lfctl.vision.kalman import CentreFilter, OcclusionCoaster
from lfctl.vision.track_state import TrackStatus
from lfctl.vision.tracker import TrackState

__all__ = ["ArucoSettings", "ArucoTracker", "detect_tags", "tag_bitmap", "tag_dictionary"]


def tag_dictionary(name: str) -> cv2.aruco.Dictionary:
    """cv2.aruco's predefined dictionary ``DICT_<name>`` (e.g. ``"4X4_50"``).

    Parameters
    ----------
    name : str
        The dictionary's name as a scenario gives it (``banner.aruco_dictionary``).

    Raises
    ------
    ValueError
        This OpenCV has no such dictionary.
    """
    code = getattr(cv2.aruco, f"DICT_{name}", None)
    if code is None:
        raise ValueError(f"cv2.aruco has no dictionary DICT_{name}")
    return cv2.aruco.getPredefinedDictionary(code)


def tag_bitmap(name: str, tag_id: int) -> np.ndarray:
    """The tag as cells, one pixel each, black border included: (n, n) uint8, 0 black, 255 white.

    Parameters
    ----------
    name : str
        The dictionary's name (see :func:`tag_dictionary`).
    tag_id : int
        The tag's id in it.
    """
    d = tag_dictionary(name)
    n = d.markerSize + 2
    return cv2.aruco.generateImageMarker(d, tag_id, n, borderBits=1)


def detect_tags(
    detector: cv2.aruco.ArucoDetector, grey: np.ndarray, tag_id: int, origin: tuple[int, int] = (0, 0)
) -> list[np.ndarray]:
    """Every tag with ``tag_id`` in ``grey``: its corners TL, TR, BR, BL, (4, 2) pixels each.

    Parameters
    ----------
    detector : cv2.aruco.ArucoDetector
        The detector (dictionary and parameters).
    grey : np.ndarray
        Grey image (a region of the frame), uint8.
    tag_id : int
        The id to keep.
    origin : (int, int)
        Where ``grey``'s top-left pixel is in the frame: the corners are given in frame pixels.
    """
    corners, ids, _rejected = detector.detectMarkers(grey)
    if ids is None:
        return []
    shift = np.array(origin, np.float64)
    return [
        c.reshape(4, 2).astype(np.float64) + shift for c, i in zip(corners, ids.ravel(), strict=True) if i == tag_id
    ]


def _box_of(corners: np.ndarray, panel_over_tag: float) -> Box:
    """The banner's box (x, y, w, h) from its tag's corners: the tag's box grown to the panel."""
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    c, half = (lo + hi) / 2, (hi - lo) / 2 * panel_over_tag
    return int(round(c[0] - half[0])), int(round(c[1] - half[1])), int(round(2 * half[0])), int(round(2 * half[1]))


def _grow(box: Box, scale: float, centre: tuple[float, float] | None = None) -> Box:
    x, y, w, h = box
    cx, cy = centre if centre is not None else (x + w / 2.0, y + h / 2.0)
    nw, nh = max(8.0, w * scale), max(8.0, h * scale)
    return int(round(cx - nw / 2)), int(round(cy - nh / 2)), int(round(nw)), int(round(nh))


@dataclass(frozen=True)
class ArucoSettings:
    """The ArUco detector's settings.

    Parameters
    ----------
    dictionary : str
        cv2.aruco dictionary name (``"4X4_50"``, ...).
    tag_id : int
        The target's tag id.
    panel_over_tag : float
        Banner panel side / tag side: the banner's box from the tag's.
    search_scale : float
        Search region / predicted banner box while tracking.
    lost_after_frames : int
        Frames without the tag (OCCLUDED, coasting) before the track is LOST.
    """

    dictionary: str = "4X4_50"
    tag_id: int = 0
    panel_over_tag: float = 0.22 / 0.165
    search_scale: float = 2.0
    lost_after_frames: int = 60


class ArucoTracker:
    """Find and follow one ArUco tag; the marker tracker's interface (:meth:`init`,
    :meth:`init_from_markers`, :meth:`update`), so :class:`~lfctl.vision.perception.BannerPerception`
    runs either.

    Parameters
    ----------
    settings : ArucoSettings
        Dictionary, id and search parameters.
    """

    def __init__(self, settings: ArucoSettings) -> None:
        self.s = settings
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        self.detector = cv2.aruco.ArucoDetector(tag_dictionary(settings.dictionary), params)
        self.frame_index = -1
        self.status = TrackStatus.LOST
        self.window: Box | None = None
        self._centre: CentreFilter | None = None
        self._coaster: OcclusionCoaster | None = None
        self._missed = 0

    # -- finding the tag -------------------------------------------------------------------
    def _find(self, frame: np.ndarray, region: Box, expect: Box | None) -> np.ndarray | None:
        """The target tag's corners in ``region`` of ``frame``: the one nearest ``expect``."""
        x, y, w, h = region
        grey = cv2.cvtColor(frame[y : y + h, x : x + w], cv2.COLOR_BGR2GRAY)
        found = detect_tags(self.detector, grey, self.s.tag_id, (x, y))
        if not found:
            return None
        if expect is None or len(found) == 1:
            return max(found, key=lambda c: float(cv2.contourArea(c.astype(np.float32))))
        ex, ey, ew, eh = expect
        centre, size = np.array([ex + ew / 2.0, ey + eh / 2.0]), max(1.0, float(np.sqrt(ew * eh)))

        def mismatch(c: np.ndarray) -> float:
            bx, by, bw, bh = _box_of(c, self.s.panel_over_tag)
            shift = float(np.hypot(bx + bw / 2.0 - centre[0], by + bh / 2.0 - centre[1])) / size
            return shift + abs(float(np.log(max(1.0, float(np.sqrt(bw * bh))) / size)))

        return min(found, key=mismatch)

    def _start(self, box: Box) -> None:
        x, y, w, h = box
        self.window = box
        self._centre = CentreFilter(x + w / 2.0, y + h / 2.0)
        self._coaster = None
        self._missed = 0

    # -- the tracker's interface -------------------------------------------------------------
    def init(self, frame: np.ndarray, roi: Box) -> TrackState:
        """Start on a window the user chose: the tag inside it (TRACKING) or, when none shows
        there, coast from the window (OCCLUDED) and look around it on the next frames.

        Parameters
        ----------
        frame : np.ndarray
            BGR image, uint8, H x W x 3.
        roi : Box
            The banner's window (x, y, w, h), pixels; clipped to the frame.

        Raises
        ------
        FrameError
            A bad frame, or a window that does not overlap it.
        """
        frame = check_bgr(frame)
        roi = check_roi(roi, frame.shape)
        self.frame_index = 0
        region = clip_box(_grow(roi, 1.5), frame.shape) or roi
        corners = self._find(frame, region, roi)
        if corners is None:
            self._start(roi)
            self._coaster = OcclusionCoaster(*self._centre.state)  # type: ignore[union-attr]
            self._missed = 1
            self.status = TrackStatus.OCCLUDED
            return TrackState(0, self.status, roi, 0.0, 1.0, None, region, "no tag in the window")
        return self._tracking(frame, corners, region, "init")

    def init_from_markers(self, frame: np.ndarray, expect: Box | None = None) -> TrackState | None:
        """Start on the tag found anywhere in the frame (the one nearest ``expect`` when
        several show); None (still not started) when there is none.

        Parameters
        ----------
        frame : np.ndarray
            BGR image, uint8, H x W x 3.
        expect : Box, optional
            Where the target's banner should appear (x, y, w, h), pixels.
        """
        frame = check_bgr(frame)
        whole = (0, 0, frame.shape[1], frame.shape[0])
        corners = self._find(frame, whole, expect)
        if corners is None:
            return None
        self.frame_index = 0
        return self._tracking(frame, corners, whole, "init from tag")

    def update(self, frame: np.ndarray) -> TrackState:
        """Look for the tag where the centre filter predicts it (everywhere once LOST).

        Parameters
        ----------
        frame : np.ndarray
            BGR image, uint8, H x W x 3.

        Raises
        ------
        FrameError
            A bad frame, or the tracker was never started.
        """
        frame = check_bgr(frame)
        if self._centre is None or self.window is None:
            raise FrameError("tracker not initialised: call init(frame, roi) or init_from_markers(frame) first")
        self.frame_index += 1
        pred = self._centre.predict()
        scale = self.s.search_scale
        if self._coaster is not None:
            pred = self._coaster.predict()
            scale += 2.0 * self._coaster.sigma_px / max(self.window[2], self.window[3], 1)  # widen while hidden
        pred_win = _grow(self.window, 1.0, pred)
        whole = (0, 0, frame.shape[1], frame.shape[0])
        region = whole if self.status is TrackStatus.LOST else clip_box(_grow(pred_win, scale), frame.shape)
        corners = self._find(frame, region, pred_win) if region is not None else None
        if corners is not None:
            return self._tracking(frame, corners, region, "")  # type: ignore[arg-type]
        # not seen: coast the centre (the marker tracker's occlusion filter), OCCLUDED, then LOST
        if self._coaster is None:
            self._coaster = OcclusionCoaster(*self._centre.state)
        self._missed += 1
        self.status = TrackStatus.LOST if self._missed > self.s.lost_after_frames else TrackStatus.OCCLUDED
        box = clip_box(pred_win, frame.shape) if self.status is TrackStatus.OCCLUDED else None
        why = "no tag" if region is not None else "prediction left the frame"
        return TrackState(self.frame_index, self.status, box, 0.0, 1.0, None, region, why)

    def _tracking(self, frame: np.ndarray, corners: np.ndarray, region: Box, why: str) -> TrackState:
        box = clip_box(_box_of(corners, self.s.panel_over_tag), frame.shape)
        assert box is not None  # the tag's corners are inside the frame
        x, y, w, h = box
        if self._centre is None or self.status is TrackStatus.LOST or self.frame_index == 0:
            self._start(box)
        else:
            self._centre.update(x + w / 2.0, y + h / 2.0)
            self.window = box
            self._coaster = None
            self._missed = 0
        self.status = TrackStatus.TRACKING
        return TrackState(self.frame_index, self.status, box, 1.0, 0.0, corners, region, why)
