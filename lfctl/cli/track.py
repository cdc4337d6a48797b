"""`lfctl track`: the follower's perception on any video, camera or stream; a JSON line per frame."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from typing import TYPE_CHECKING, Any

from lfctl.cli.options import TRACKER_KINDS, integer, number, video_out

if TYPE_CHECKING:
    from lfctl.config import BannerConfig, Config


def register(sub: Any) -> None:
    """Add the ``track`` command to the parser."""
    t = sub.add_parser(
        "track",
        help="run the tracker on a video file, camera index or stream; JSON line per frame",
        description="Track the leader's banner (or any object from --roi) in a video; prints one JSON line per frame and can write an annotated video.",
    )
    t.add_argument(
        "source",
        help="video file, camera index (0), stream URL (rtsp://..., rtp://HOST:PORT for RTP/UDP H.264, a .sdp file); or a shipped clip by name (bikes.mp4)",
    )
    t.add_argument("--roi", help="initial window x,y,w,h in pixels (default: find the banner's four markers)")
    t.add_argument("--out", type=video_out, help="write an annotated video here (.mp4, .avi, .mkv or .mov)")
    t.add_argument("--tracker", choices=tuple(TRACKER_KINDS), default="full", help="tracker kind (default: full)")
    t.add_argument("--no-markers", action="store_true", help="histogram path only (objects without the banner)")
    t.add_argument(
        "--marker-hue-deg",
        type=number(0, 360, hi_open=True, unit="deg"),
        help="marker hue, degrees (default: the scenario's, else red 0)",
    )
    t.add_argument(
        "--scenario", help="take camera intrinsics and banner geometry from this scenario (a file, or a shipped name)"
    )
    t.add_argument("--max-frames", type=integer(1, 10**9), help="stop after this many frames")
    t.add_argument(
        "--fps",
        type=number(0.01, 10000, unit="fps"),  # (a frame each 100 s at the least: below is a slip)
        help="the frames' rate, for t_s (default: each frame's own time in a file; a raw .h264 or MJPEG "
        "stream has none, and is counted at the rate FFmpeg assumes)",
    )
    t.set_defaults(func=run)


def parse_roi(text: str) -> tuple[int, int, int, int]:
    """``x,y,w,h`` as four whole numbers."""
    from lfctl.errors import ConfigError

    try:
        parts = [int(p) for p in text.split(",")]
    except ValueError:
        raise ConfigError(f"--roi must be x,y,w,h in whole pixels, got {text!r}") from None
    if len(parts) != 4:
        raise ConfigError(f"--roi must be x,y,w,h (four numbers), got {text!r}")
    return parts[0], parts[1], parts[2], parts[3]


def _say_odd_roi(roi: tuple[int, int, int, int], width: int, height: int) -> None:
    """Say on stderr when --roi looks like a slip (the window is clipped to the frame): most
    of it off the frame (another resolution's coordinates?), or most of the frame inside."""
    x, y, w, h = roi
    inside = max(0, min(x + w, width) - max(x, 0)) * max(0, min(y + h, height) - max(y, 0))
    if 0 < inside < 0.5 * w * h:
        print(
            f"lfctl track: --roi {x},{y},{w},{h} lies mostly outside the {width}x{height} frame (coordinates of "
            "another size or orientation?); its part inside is tracked",
            file=sys.stderr,
        )
    elif inside > 0.5 * width * height:
        print(
            f"lfctl track: --roi {x},{y},{w},{h} holds more than half the {width}x{height} frame: the tracker "
            "follows what it holds, mostly background",
            file=sys.stderr,
        )


def _watched_banner(scen: Config) -> BannerConfig:
    """The banner the scenario's first follower looks for (with ArUco tags, its target's id);
    the leader's in a scenario without followers."""
    slots = scen.slots()
    return scen.banner_of(next(iter(slots.values())).target) if slots else scen.banner


def run(args: argparse.Namespace) -> int:
    """Perceive every frame; print a JSON line each; write the annotated video."""
    import cv2
    import numpy as np

    from lfctl.config import BannerConfig, CameraConfig, load_config
    from lfctl.data import footage_dir, resolve_footage, resolve_scenario
    from lfctl.errors import ConfigError
    from lfctl.video import VideoSource, missing_source
    from lfctl.vision.camera_model import at_frame_size
    from lfctl.vision.draw import annotate
    from lfctl.vision.frames import FrameError, colourless
    from lfctl.vision.perception import BannerPerception

    roi = parse_roi(args.roi) if args.roi is not None else None
    args.source = resolve_footage(args.source)
    _check_paths(args.source, args.out)
    if "://" not in args.source and not args.source.isdigit() and not os.path.lexists(args.source):
        if "%" in args.source:
            raise ConfigError(
                f"{args.source[:200]!r}: lfctl track reads videos, not numbered image files: make a video of them "
                "first (ffmpeg -framerate 30 -i frame_%04d.png clip.mp4)"
            )
        raise ConfigError(missing_source(args.source, footage_dir()))
    scen = load_config(resolve_scenario(args.scenario)) if args.scenario else None
    n = 0
    writer = None
    with VideoSource(args.source) as video:
        declared, declared_s = video.declared_frames, video.declared_duration_s
        rate = args.fps or video.fps
        perception = None
        untimed_said = False
        try:
            while args.max_frames is None or n < args.max_frames:
                frame = video.read()
                if frame is None:
                    break
                if perception is None:
                    h, w = frame.shape[:2]
                    banner = _watched_banner(scen) if scen else BannerConfig()
                    if banner.kind != "aruco" and video.info is not None and video.info.grey:
                        raise ConfigError(
                            f"{args.source} has no colour (its pixels are grey levels: a monochrome or infrared "
                            "camera): lfctl's trackers follow a target by its hue and saturation; give a colour video"
                        )
                    if banner.kind != "aruco" and colourless(frame):  # (a dim or grey first frame may pass)
                        print(
                            f"lfctl track: {args.source}'s first frame has no colour (every pixel grey: a monochrome "
                            "camera?); the trackers follow hue and saturation and will not hold a target in it",
                            file=sys.stderr,
                        )
                    try:
                        camera, scaled = at_frame_size(scen.camera if scen else CameraConfig(), w, h)
                    except ConfigError as exc:  # (its message names the scenario's key)
                        raise ConfigError(
                            f"{args.source}: its frames are {w}x{h} px, which the tracker cannot take ({exc})"
                        ) from None
                    if scaled:
                        print(f"lfctl track: {scaled}", file=sys.stderr)
                    perception = BannerPerception.from_config(
                        camera,
                        banner,
                        kind=TRACKER_KINDS[args.tracker],
                        use_markers=not args.no_markers,
                        marker_hue_deg=args.marker_hue_deg,
                    )
                    if roi is not None:
                        _say_odd_roi(roi, w, h)
                    sar = video.pixel_aspect
                    if sar is not None:
                        print(
                            f"lfctl track: {args.source}'s pixels are not square (aspect {sar[0]}:{sar[1]}): --roi and "
                            f"the boxes are in its {w}x{h} stored pixels, not the {round(w * sar[0] / sar[1])}x{h} "
                            "picture a player shows",
                            file=sys.stderr,
                        )
                    # the writer's codecs take even sizes (OpenCV would resize the frames,
                    # moving every box off its pixels): an odd edge is padded
                    pad_w, pad_h = w % 2, h % 2
                    if args.out and (pad_w or pad_h):
                        print(
                            f"lfctl track: --out {args.out} is {w + pad_w}x{h + pad_h}, the {w}x{h} frames with a "
                            "black edge (its codec takes even sizes)",
                            file=sys.stderr,
                        )
                # (at --fps, the frames passed over took their time too)
                t_s = (n + video.passed_over) / args.fps if args.fps else video.time_s
                if video.untimed and not args.fps and not video.live and not untimed_said:
                    untimed_said = True
                    print(
                        f"lfctl track: {args.source}'s frames carry no times (a raw stream): t_s counts them at "
                        f"{video.fps:g} fps, the rate FFmpeg assumes; give --fps for the camera's",
                        file=sys.stderr,
                    )
                seen = perception.step(t_s, frame, roi)
                st = seen.track
                if st is None and n == 0:
                    if not video.live:
                        raise ConfigError(
                            "no banner (its four markers, or its ArUco tag) in the first frame: give --roi x,y,w,h"
                        )
                    # a camera's first frame may not show it yet (or come half decoded, a stream
                    # joined between keyframes): each frame is searched until it does
                    print(
                        f"lfctl track: no banner (its four markers, or its ArUco tag) in {args.source}'s first "
                        "frame: looking for it in each frame (or give --roi x,y,w,h)",
                        file=sys.stderr,
                    )
                rec: dict[str, object] = {
                    "frame": n,
                    "t_s": round(t_s, 4),
                    "state": st.status.value if st is not None else "lost",
                    "bbox": list(st.bbox) if st is not None and st.bbox else None,
                    "quality": round(st.quality, 3) if st is not None else 0.0,
                }
                if st is not None and st.markers is not None:
                    rec["markers"] = np.round(st.markers, 2).tolist()
                if seen.pose is not None:
                    rng, brg, rel = perception.vehicle_relative(seen.pose)
                    rec["pose"] = {
                        "range_m": round(rng, 4),
                        "bearing_deg": round(math.degrees(brg), 3),
                        "rel_heading_deg": round(math.degrees(rel), 2),
                        "method": seen.pose.method,
                    }
                print(json.dumps(rec), flush=True)
                if args.out and writer is None:  # opened (so emptied) once the first frame is tracked
                    writer = cv2.VideoWriter(
                        str(args.out), cv2.VideoWriter_fourcc(*"mp4v"), rate, (w + pad_w, h + pad_h)
                    )
                    if not writer.isOpened():
                        raise ConfigError(f"cannot write {args.out} (check the directory and the .mp4/.avi extension)")
                if writer is not None:
                    drawn = annotate(frame, st, f"{n} {rec['state']}")
                    if pad_w or pad_h:
                        drawn = cv2.copyMakeBorder(drawn, 0, pad_h, 0, pad_w, cv2.BORDER_CONSTANT, value=0)
                    writer.write(drawn)
                n += 1
        except FrameError as exc:
            raise ConfigError(f"frame {n} of {args.source}: {exc}") from exc
        finally:
            if writer is not None:
                writer.release()
        last_s, timed = video.time_s, not video.untimed
        passed_over = video.passed_over
    if n == 0:
        raise ConfigError(f"video source {args.source!r} gave no frames")
    if writer is not None:
        _check_written(args.out, n)
    whole = args.max_frames is None or n < args.max_frames
    if passed_over:
        print(
            f"lfctl track: {args.source}: {passed_over} frame{'s' if passed_over > 1 else ''} that did not decode "
            "passed over (damaged in the middle; the frames after were tracked, `frame` counts those tracked and "
            "`t_s` is each one's own time)",
            file=sys.stderr,
        )
    if whole and declared is not None and n + passed_over < declared - 1:
        # (a container's count may be one off): a file that ends well short of it is cut or damaged
        said = f"{args.source} ended after {n} of the {declared} frames it declares"
        if n < SHORT_END * declared:
            raise ConfigError(f"{said}: the file is cut or damaged (the {n} frames read were tracked)")
        print(f"lfctl track: {said}", file=sys.stderr)
    elif whole and declared_s is not None and timed:
        # a Matroska or WebM file stores no count but its duration: its last frame, and that
        # frame's time on the screen, fall well short of it in a cut one
        shown = last_s + 1.0 / rate
        if shown < SHORT_END * declared_s:
            raise ConfigError(
                f"{args.source} ended at {shown:.2f} s of the {declared_s:.2f} s it declares: the file is cut or "
                f"damaged (the {n} frames read were tracked)"
            )
    return 0


#: a video file that ends before this share of the frames its container declares is an error
SHORT_END = 0.9


def _check_paths(source: str, out: str | None) -> None:
    """Refuse an --out that is the source itself or any file that exists (an earlier annotated
    video, a recording: track writes over nothing, as `audit --recover` does not); a named pipe
    or socket as the source is refused by the video source."""
    import os
    from pathlib import Path

    from lfctl.errors import ConfigError

    if out is None:
        return
    if Path(source).exists() and Path(out).exists() and os.path.samefile(source, out):  # (links too)
        raise ConfigError(f"--out {out} is the video being tracked: give another file")
    if os.path.lexists(out):  # (a link to nothing too: the writer would create its target)
        raise ConfigError(f"--out {out}: it exists (track writes over nothing: name a new file)")


def _check_written(out: str, frames: int) -> None:
    """The annotated video holds the frames written (OpenCV's writer does not report a failed
    write, a full disk say)."""
    import cv2

    from lfctl.errors import ConfigError

    cap = cv2.VideoCapture(str(out))
    try:
        held = int(cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0) if cap.isOpened() else 0
    finally:
        cap.release()
    if held < frames - 1:
        raise ConfigError(
            f"--out {out}: {frames} annotated frames were written but the file holds {held} "
            "(is the disk full?); the JSON lines above have every frame"
        )
