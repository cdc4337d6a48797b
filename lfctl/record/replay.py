"""Replay: run a tracker on a log's recorded camera frames and score it, beside the tracker
that ran live, against the renderer's truth (`lfctl replay`)."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from lfctl.errors import ConfigError
from lfctl.record.audit import _json_messages, audit
from lfctl.record.video import decode_h264
from lfctl.record.writer import image_topic
from lfctl.vision.boxes import iou
from lfctl.vision.frames import FrameError
from lfctl.vision.tracker import Tracker, TrackerSettings, tracker_kind

__all__ = ["ReplayResult", "recorded_frames", "replay"]

#: a frame is scored when at least this much of the banner shows
MIN_VISIBLE = 0.5
#: an H.264 NAL unit that carries no picture (stands in for a unit that does not parse)
_ACCESS_UNIT_DELIMITER = b"\x00\x00\x00\x01\x09\xf0"
#: recorded frames larger than this many pixels are not decoded (a damaged or crafted size)
MAX_FRAME_PIXELS = 4096 * 4096


@dataclass(frozen=True)
class ReplayResult:
    """Success rates (IoU >= 0.5 against the truth) of the recorded and the replayed tracker."""

    follower: str  # whose camera
    frames: int  # recorded images
    scored: int  # frames scored: those after the first with a truth box, banner at least MIN_VISIBLE shown
    #: fraction of scored frames the live tracker got right, 0..1; None when no tracker ran in
    #: the recording (a rehearsal's follower: its companion tracked the frames outside)
    recorded_success: float | None
    replayed_success: float  # the same for the replayed tracker
    unreadable: int = 0  # recorded images skipped: they do not decode, or differ in size from the first
    recorded_markers: float | None = 0.0  # fraction of scored frames whose four markers the live tracker found
    replayed_markers: float = 0.0  # the same for the replayed tracker (markers readable after encoding)
    truncated: bool = False  # the log was not finished (cut, or its run killed): what was read before the cut
    #: damage the reading found in the file (a chunk skipped, a record passed over, bytes after
    #: its end: the audit's integrity errors): the frames are those that could be read
    damaged: int = 0


def replay(path: Path, kind: str = "full", follower: str | None = None) -> ReplayResult:
    """Re-run a tracker on the recorded frames of one follower and score both.

    Parameters
    ----------
    path : Path
        An MCAP log recorded with camera sensing and images.
    kind : "full", "hs-lbp" or "hue" ("hue-only" too; ConfigError for another)
        The tracker to replay.
    follower : str, optional
        Whose camera (default the first follower).

    Raises
    ------
    ConfigError
        The path is not a regular file, the log holds no images for the follower (or none
        that decodes), or no frame with a truth box.
    """
    kind = tracker_kind(kind)  # ConfigError for a name that is none
    report = audit(path)
    unusable = next((f for f in report.findings if f.kind == "file"), None)
    if unusable is not None:
        raise ConfigError(unusable.what)
    c = report.contents
    if not c.channels and not c.metadata:  # nothing readable: say why, as the audit does
        why = next((f.what for f in report.findings if f.level == "error"), "no readable records")
        raise ConfigError(f"{path}: {why}")
    followers = [f for f in report.figures.get("run", {}).get("followers", "").split(",") if f]
    if follower is not None and followers and follower not in followers:
        raise ConfigError(f"{path} has no follower {follower!r} (its followers: {', '.join(followers)})")
    name = follower or (followers[0] if followers else "")
    if not name:  # a file lfctl did not write, or one whose run metadata names no follower
        raise ConfigError(f"{path} names no follower in its run metadata: give --follower NAME")
    count = len(c.messages.get(image_topic(name, "h264"), []) or c.messages.get(image_topic(name, "jpeg"), []))
    run = report.figures.get("run", {})
    images_expected = run.get("sensing") == "camera" and run.get("images") == "true"
    if not count and not c.footer and images_expected:
        raise ConfigError(f"{path} is truncated (not finished) before any camera image of {name!r} was written")
    if not count:
        damage = next((f.what for f in report.findings if f.level == "error"), None)
        if damage is not None and images_expected:  # they were recorded: the damage took them
            raise ConfigError(
                f"{path} is damaged ({damage}): none of {name!r}'s camera images can be read "
                f"(`lfctl audit {path}` says where)"
            )
        raise ConfigError(
            f"{path} has no recorded camera images for follower {name!r} "
            "(was it run with sensing = 'camera' and recording.images = true?)"
        )
    recorded = dict(_json_messages(c, f"/{name}/tracker"))  # valid messages only, by t in s
    tracker = Tracker(TrackerSettings(kind=kind))
    ok_new = ok_old = n = markers_new = markers_old = 0
    decoded = unreadable = 0
    started = False
    shape: tuple[int, ...] | None = None
    for t, frame in recorded_frames(c.messages, name):  # one at a time: a long log's frames do not fit in memory
        decoded += 1
        if shape is not None and frame.shape != shape:
            unreadable += 1
            continue
        shape = frame.shape
        rec = recorded.get(c.sim_s(t), {})
        truth = rec.get("truth_bbox")
        if not started:
            if truth:
                try:
                    tracker.init(frame, tuple(truth))
                except FrameError:  # a truth box outside the frame: wait for the next
                    continue
                started = True
            continue
        st = tracker.update(frame)
        if truth and rec.get("truth_visible_fraction", 0) >= MIN_VISIBLE:
            n += 1
            ok_new += iou(st.bbox, truth) >= 0.5
            ok_old += iou(rec.get("bbox"), truth) >= 0.5
            markers_new += st.markers is not None
            markers_old += rec.get("markers") is not None
    unreadable += count - decoded
    if not decoded:
        raise ConfigError(f"{path}: none of the {count} recorded images of {name!r} decodes")
    if n == 0:
        raise ConfigError(f"{path}: no frame with a recorded truth box to score against")
    truncated = not c.footer
    damaged = sum(f.level == "error" and f.kind in ("corrupt", "crc") for f in report.findings)
    live = any("state" in m for m in recorded.values())  # (none: the frames were tracked outside the run)
    return ReplayResult(
        name,
        count,
        n,
        ok_old / n if live else None,
        ok_new / n,
        unreadable,
        markers_old / n if live else None,
        markers_new / n,
        truncated,
        damaged,
    )


def recorded_frames(
    messages: dict[str, Sequence[tuple[int, bytes]]], follower: str
) -> Iterator[tuple[int, np.ndarray]]:
    """A follower's recorded camera frames that decode: (log_time ns, BGR image) in order,
    decoded one at a time as they are taken (a 30 fps 640 x 480 camera's frames take 1.7 GB a
    recorded minute), from its H.264 video or its JPEG images (whichever the log holds).
    Frames that do not decode, or claim more than :data:`MAX_FRAME_PIXELS`, are left out.

    Parameters
    ----------
    messages : dict
        Topic -> (log_time ns, payload) of every message (as :class:`~lfctl.record.audit.Contents` holds them).
    follower : str
        Whose camera.
    """
    from foxglove_schemas_protobuf.CompressedVideo_pb2 import CompressedVideo
    from google.protobuf.message import DecodeError

    video = messages.get(image_topic(follower, "h264"), [])
    if video:
        times = [t for t, _ in video]

        def units() -> Iterator[bytes]:
            for _, d in video:
                try:
                    yield CompressedVideo.FromString(d).data
                except DecodeError:
                    yield _ACCESS_UNIT_DELIMITER  # decodes to nothing, and keeps frame k at unit k

        yield from ((times[k], frame) for k, frame in decode_h264(units(), MAX_FRAME_PIXELS) if k < len(times))
        return
    for t, d in messages.get(image_topic(follower, "jpeg"), []):
        frame = _decode(d)
        if frame is not None:
            yield t, frame


def _decode(data: bytes) -> np.ndarray | None:
    """A recorded foxglove.CompressedImage as a BGR frame; None when it is not one, is empty,
    is not a JPEG or PNG OpenCV decodes, or is larger than MAX_FRAME_PIXELS."""
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
    from google.protobuf.message import DecodeError

    try:
        jpeg = CompressedImage.FromString(data).data
    except DecodeError:
        return None
    size = _image_size(jpeg)
    if size is None or not 0 < size[0] * size[1] <= MAX_FRAME_PIXELS:
        return None
    try:
        frame = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    except cv2.error:
        return None
    return frame if frame is not None and frame.ndim == 3 and frame.size else None


def _image_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from a JPEG's frame header or a PNG's IHDR; None when there is none."""
    if data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) >= 24:
        return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    if data[:2] != b"\xff\xd8":
        return None
    i = 2
    while i + 4 <= len(data):
        if data[i] != 0xFF:
            return None
        marker, length = data[i + 1], int.from_bytes(data[i + 2 : i + 4], "big")
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):  # start of frame
            if i + 9 > len(data):
                return None
            return int.from_bytes(data[i + 7 : i + 9], "big"), int.from_bytes(data[i + 5 : i + 7], "big")
        if length < 2:
            return None
        i += 2 + length
    return None
