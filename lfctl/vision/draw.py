"""Drawing a tracker's result onto a frame (annotated videos from `lfctl track`)."""

from __future__ import annotations

import cv2
import numpy as np

from lfctl.vision.track_state import TrackStatus
from lfctl.vision.tracker import TrackState

__all__ = ["annotate"]


def annotate(frame: np.ndarray, track: TrackState | None, label: str) -> np.ndarray:
    """A copy of ``frame`` with the tracked window (green when tracking, orange otherwise),
    the markers (magenta) and ``label`` drawn on it.

    Parameters
    ----------
    frame : np.ndarray
        BGR image.
    track : TrackState or None
        The tracker's result for this frame.
    label : str
        Text for the top-left corner.
    """
    vis = frame.copy()
    if track is not None and track.bbox:
        x, y, w, h = track.bbox
        colour = (0, 200, 0) if track.status is TrackStatus.TRACKING else (0, 165, 255)
        cv2.rectangle(vis, (x, y), (x + w, y + h), colour, 2)
    if track is not None and track.markers is not None:
        for u, v in track.markers:
            cv2.circle(vis, (int(u), int(v)), 4, (255, 0, 255), -1)
    cv2.putText(vis, label, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 2)
    return vis
