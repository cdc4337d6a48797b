"""Replay: run a tracker on a log's recorded camera frames and score it, beside the tracker
that ran live, against the renderer's truth (`lfctl replay`)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from lfctl.errors import ConfigError
from lfctl.record.audit import audit
from lfctl.record.video import decode_h264
from lfctl.record.writer import image_topic
from lfctl.vision.boxes import iou
from lfctl.vision.tracker import Tracker, TrackerSettings

__all__ = ["ReplayResult", "recorded_frames", "replay"]

#: a frame is scored when at least this much of the banner shows
MIN_VISIBLE = 0.5


@dataclass(frozen=True)
class ReplayResult:
    """Success rates (IoU >= 0.5 against the truth) of the recorded and the replayed tracker."""

    follower: str  # whose camera
    frames: int  # recorded images
    scored: int  # frames scored: those after the first with a truth box, banner at least MIN_VISIBLE shown
    recorded_success: float  # fraction of scored frames the live tracker got right, 0..1
    replayed_success: float  # the same for the replayed tracker
    recorded_markers: float = 0.0  # fraction of scored frames whose four markers the live tracker found
    replayed_markers: float = 0.0  # the same for the replayed tracker (markers readable after encoding)


def replay(path: Path, kind: str = "full", follower: str | None = None) -> ReplayResult:
    """Re-run a tracker on the recorded frames of one follower and score both.

    Parameters
    ----------
    path : Path
        An MCAP log recorded with camera sensing and images.
    kind : "full", "hs-lbp" or "hue"
        The tracker to replay.
    follower : str, optional
        Whose camera (default the first follower).

    Raises
    ------
    ConfigError
        The log holds no images for the follower, or no frame with a truth box.
    """
    report = audit(path)
    c = report.contents
    followers = [f for f in report.figures.get("run", {}).get("followers", "").split(",") if f]
    name = follower or (followers[0] if followers else "")
    images = recorded_frames(c.messages, name)
    if not images:
        raise ConfigError(
            f"{path} has no recorded camera images for follower {name!r} "
            "(was it run with sensing = 'camera' and recording.images = true?)"
        )
    recorded = {t: json.loads(d) for t, d in c.messages.get(f"/{name}/tracker", [])}
    tracker = Tracker(TrackerSettings(kind=kind))  # type: ignore[arg-type]
    ok_new = ok_old = n = markers_new = markers_old = 0
    started = False
    for t, frame in images:
        rec = recorded.get(t, {})
        truth = rec.get("truth_bbox")
        if not started:
            if truth:
                tracker.init(frame, tuple(truth))
                started = True
            continue
        st = tracker.update(frame)
        if truth and rec.get("truth_visible_fraction", 0) >= MIN_VISIBLE:
            n += 1
            ok_new += iou(st.bbox, truth) >= 0.5
            ok_old += iou(rec.get("bbox"), truth) >= 0.5
            markers_new += st.markers is not None
            markers_old += rec.get("markers") is not None
    if n == 0:
        raise ConfigError(f"{path}: no frame with a recorded truth box to score against")
    return ReplayResult(name, len(images), n, ok_old / n, ok_new / n, markers_old / n, markers_new / n)


def recorded_frames(messages: dict[str, list[tuple[int, bytes]]], follower: str) -> list[tuple[int, np.ndarray]]:
    """A follower's recorded camera frames, decoded: (log_time ns, BGR image) in order, from
    its H.264 video or its JPEG images (whichever the log holds).

    Parameters
    ----------
    messages : dict
        Topic -> (log_time ns, payload) of every message (as :class:`~lfctl.record.audit.Contents` holds them).
    follower : str
        Whose camera.
    """
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
    from foxglove_schemas_protobuf.CompressedVideo_pb2 import CompressedVideo

    video = messages.get(image_topic(follower, "h264"), [])
    if video:
        times = [t for t, _ in video]
        units = (CompressedVideo.FromString(d).data for _, d in video)
        return [(times[k], frame) for k, frame in decode_h264(units)]
    return [
        (t, cv2.imdecode(np.frombuffer(CompressedImage.FromString(d).data, np.uint8), cv2.IMREAD_COLOR))
        for t, d in messages.get(image_topic(follower, "jpeg"), [])
    ]
