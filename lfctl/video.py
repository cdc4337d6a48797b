"""Frames from a real camera, a video file or a stream (OpenCV's VideoCapture), for
`lfctl follow` and `lfctl track`."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from lfctl.errors import ConfigError

__all__ = ["VideoSource"]


class VideoSource:
    """An opened video source; use as a context manager.

    Parameters
    ----------
    source : str
        A camera index (``0``), a video file or a stream URL (``rtsp://...``).

    Raises
    ------
    ConfigError
        A file that does not exist, or a source OpenCV cannot open or read a frame from.
    """

    def __init__(self, source: str) -> None:
        self.name = source
        target: str | int = int(source) if source.isdigit() else source
        if isinstance(target, str) and "://" not in target and not Path(target).exists():
            raise ConfigError(f"video source {source!r} does not exist (give a file, a camera index or a stream URL)")
        self._cap = cv2.VideoCapture(target)
        if not self._cap.isOpened():
            raise ConfigError(f"cannot open video source {source!r} with OpenCV (unsupported format or no such camera)")

    @property
    def fps(self) -> float:
        """Frames per second the source declares (30 when it declares none)."""
        return float(self._cap.get(cv2.CAP_PROP_FPS) or 30.0)

    @property
    def declared_frames(self) -> int | None:
        """How many frames a video file's container says it holds (None for a camera or a
        stream, or a file that does not say)."""
        n = self._cap.get(cv2.CAP_PROP_FRAME_COUNT)
        return int(n) if n and n > 0 and Path(self.name).is_file() else None

    def read(self) -> np.ndarray | None:
        """The next frame (BGR, uint8), or None at the end of the source."""
        ok, frame = self._cap.read()
        if not ok or frame is None:
            return None
        return frame

    def close(self) -> None:
        """Release the source."""
        self._cap.release()

    def __enter__(self) -> VideoSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
