"""The labelled real footage (``footage/``, see its README): the label files read into
sequences whose frames come straight from the shipped videos, and what each labelled frame
says about the target (in plain view, partly covered, hidden).

Used by the ``real`` section of `lfctl bench vision` and by the tracker tests, so both read
the labels the same way.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from lfctl.data import footage_dir
from lfctl.errors import ConfigError
from lfctl.vision.boxes import Box

__all__ = ["LabelledSequence", "load_sequence", "load_sequences", "start_boxes"]


@dataclass(frozen=True)
class LabelledSequence:
    """One labelled clip of a real video.

    Parameters
    ----------
    name : str
        The label file's stem (``vtest_navyred``).
    video : Path
        The video file.
    first_frame : int
        The clip's first frame in the video, counted in the order OpenCV's
        ``VideoCapture.read()`` returns frames.
    n_frames : int
        Frames in the clip.
    boxes : dict of int to Box or None
        Labelled clip frames (every 5th): the target's box (x, y, w, h), px, or None where
        it is hidden. Empty for a sequence with no target (``no_banner``).
    partial : frozenset of int
        Labelled frames where the target is partly covered (the box is the visible part).
    no_banner : bool
        The clip shows no leader banner: marker detection must find nothing in it.
    target : str
        What is labelled (empty without a target).
    """

    name: str
    video: Path
    first_frame: int
    n_frames: int
    boxes: dict[int, Box | None]
    partial: frozenset[int]
    no_banner: bool
    target: str = ""

    @property
    def init_box(self) -> Box | None:
        """The target's box in clip frame 0 (where a tracker starts), or None without a target."""
        return self.boxes.get(0)

    def in_plain_view(self) -> list[int]:
        """Labelled frames (after frame 0) where the target is wholly visible: what success
        and centre error are scored on, and where OCCLUDED is wrong."""
        return [i for i, b in sorted(self.boxes.items()) if i > 0 and b is not None and i not in self.partial]

    def hidden(self) -> list[int]:
        """Frames where the target is hidden: every frame labelled ``null`` and every frame
        between two consecutive ``null`` labels (the labels' notes say it stays hidden there)."""
        nulls = sorted(i for i, b in self.boxes.items() if b is None)
        out = set(nulls)
        labelled = sorted(self.boxes)
        for a, b in itertools.pairwise(labelled):
            if a in nulls and b in nulls:
                out.update(range(a + 1, b))
        return sorted(out)

    def frames(self) -> Iterator[np.ndarray]:
        """Yield the clip's frames (BGR, uint8) in order.

        Raises
        ------
        ConfigError
            The video cannot be opened or ends before the clip does.
        """
        cap = cv2.VideoCapture(str(self.video))
        if not cap.isOpened():
            raise ConfigError(f"{self.name}: cannot open {self.video} with OpenCV")
        try:
            for k in range(self.first_frame):
                if not cap.grab():
                    raise ConfigError(
                        f"{self.name}: {self.video.name} ends at frame {k}, before frame {self.first_frame}"
                    )
            for k in range(self.n_frames):
                ok, frame = cap.read()
                if not ok or frame is None:
                    raise ConfigError(
                        f"{self.name}: {self.video.name} ends at clip frame {k} of {self.n_frames} "
                        f"(video frame {self.first_frame + k})"
                    )
                yield frame
        finally:
            cap.release()


def _box(name: str, key: str, value: object) -> Box | None:
    if value is None:
        return None
    if not isinstance(value, list) or len(value) != 4 or not all(isinstance(v, int) for v in value):
        raise ConfigError(f"{name}: frames.{key} must be [x, y, w, h] in whole pixels or null, got {value!r}")
    x, y, w, h = value
    if w <= 0 or h <= 0:
        raise ConfigError(f"{name}: frames.{key} has a non-positive width or height: {value!r}")
    return x, y, w, h


def load_sequence(path: Path, folder: Path | None = None) -> LabelledSequence:
    """Read one label file.

    Parameters
    ----------
    path : Path
        A ``footage/labels/*.json`` file.
    folder : Path, optional
        Where the videos are (default: the label folder's parent).

    Raises
    ------
    ConfigError
        Unreadable JSON, a missing or ill-typed field, a box outside the clip, or a video
        that is not there; the message names the file and the field.
    """
    name = path.stem
    try:
        d = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ConfigError(f"{path}: not a readable label file ({exc})") from None
    for key, kind in (("video", str), ("first_frame", int), ("n_frames", int)):
        if not isinstance(d.get(key), kind):
            raise ConfigError(f"{name}: {key!r} missing or not a {kind.__name__}")
    n = d["n_frames"]
    if d["first_frame"] < 0 or n <= 0:
        raise ConfigError(f"{name}: first_frame must be >= 0 and n_frames > 0")
    no_banner = bool(d.get("no_banner", False))
    raw = d.get("frames", {})
    if not isinstance(raw, dict):
        raise ConfigError(f"{name}: 'frames' must map frame numbers to boxes")
    boxes: dict[int, Box | None] = {}
    for key, value in raw.items():
        if not key.isdigit() or int(key) >= n:
            raise ConfigError(f"{name}: frames key {key!r} is not a clip frame 0..{n - 1}")
        boxes[int(key)] = _box(name, key, value)
    if not no_banner and boxes.get(0) is None:
        raise ConfigError(f"{name}: a labelled sequence needs a box in frame 0 (where the tracker starts)")
    partial = d.get("partial", [])
    if not isinstance(partial, list) or not all(isinstance(p, int) and p in boxes for p in partial):
        raise ConfigError(f"{name}: 'partial' must list labelled frame numbers")
    video = (folder or path.parent.parent) / d["video"]
    if not video.is_file():
        raise ConfigError(f"{name}: video {video} is not there (see footage/README.md)")
    return LabelledSequence(
        name, video, d["first_frame"], n, boxes, frozenset(partial), no_banner, str(d.get("target", ""))
    )


def load_sequences(folder: Path | None = None) -> list[LabelledSequence]:
    """Every labelled sequence in ``folder/labels`` (default :func:`lfctl.data.footage_dir`),
    sorted by name.

    Parameters
    ----------
    folder : Path, optional
        A footage folder: videos at its top, label files in ``labels/``.

    Raises
    ------
    ConfigError
        No label files there, or one that does not read (see :func:`load_sequence`).
    """
    folder = folder or footage_dir()
    paths = sorted((folder / "labels").glob("*.json"))
    if not paths:
        raise ConfigError(f"no label files in {folder / 'labels'} (see footage/README.md)")
    return [load_sequence(p, folder) for p in paths]


def start_boxes(box: Box, n: int = 11, moved_px: int = 2, seed: int = 0) -> list[Box]:
    """``box`` and ``n - 1`` others whose x, y, width and height are each moved by a whole
    number of pixels from ``-moved_px`` to ``moved_px`` (uniform, seeded; sizes kept >= 2).

    The labels' edges are certain to about 2 px (``footage/README.md``), so a tracker's score
    from the one label box is one draw among starts a labeller could as well have drawn; the
    spread over these is how much of it is the start's luck.

    Parameters
    ----------
    box : Box
        The label's start box (x, y, w, h), px.
    n : int
        How many boxes, the label's first (>= 1).
    moved_px : int
        The largest move of each of x, y, w and h, px (>= 0).
    seed : int
        Seeds the moves: the same boxes for the same arguments.

    Raises
    ------
    ValueError
        ``n`` below 1 or ``moved_px`` negative.
    """
    if n < 1 or moved_px < 0:
        raise ValueError(f"start_boxes needs n >= 1 and moved_px >= 0, got n={n!r}, moved_px={moved_px!r}")
    rng = np.random.default_rng(seed)
    x, y, w, h = box
    out: list[Box] = [box]
    for _ in range(n - 1):
        dx, dy, dw, dh = (int(v) for v in rng.integers(-moved_px, moved_px + 1, 4))
        out.append((x + dx, y + dy, max(2, w + dw), max(2, h + dh)))
    return out
