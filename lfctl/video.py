"""Frames from a real camera, a video file or a stream (OpenCV's VideoCapture), for
`lfctl follow` and `lfctl track`."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import cv2
import numpy as np

from lfctl.errors import ConfigError

__all__ = ["STREAM_TIMEOUT_S", "VideoSource"]

#: how long a stream (a URL) may take to open, and to give its next frame, s: a silent one
#: is an error (opening) or its end (reading), not a process blocked for ever
STREAM_TIMEOUT_S = 10.0


class VideoSource:
    """An opened video source; use as a context manager.

    Parameters
    ----------
    source : str, int or os.PathLike
        A camera index (``0`` or ``"0"``), a video file (a path) or a stream URL (``rtsp://...``).

    Raises
    ------
    ConfigError
        A file that does not exist, a named pipe or socket (it would block with no end), a
        stream that does not open within :data:`STREAM_TIMEOUT_S`, or a source OpenCV cannot
        open or read a frame from.
    """

    def __init__(self, source: str | int | os.PathLike[str]) -> None:
        if isinstance(source, bool) or not isinstance(source, str | int | os.PathLike):
            raise ConfigError(f"video source must be a camera index, a file or a stream URL, got {source!r}")
        path = isinstance(source, os.PathLike)  # a path is a file, even one named "7"
        source = os.fspath(source) if path else str(source)
        self.name = source
        target: str | int = int(source) if source.isdigit() and not path else source
        stream = isinstance(target, str) and "://" in target
        if isinstance(target, str) and not stream:
            try:
                mode = os.stat(target).st_mode
            except (OSError, ValueError):
                raise ConfigError(
                    f"video source {source[:200]!r} does not exist (give a file, a camera index or a stream URL)"
                ) from None
            if stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode):
                raise ConfigError(
                    f"{source} is a named pipe or socket, not a video file (a stream is given by its URL)"
                )
        if stream:
            ms = int(STREAM_TIMEOUT_S * 1000)
            params = [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, ms, cv2.CAP_PROP_READ_TIMEOUT_MSEC, ms]
            self._cap = cv2.VideoCapture(target, cv2.CAP_FFMPEG, params)
        else:
            self._cap = cv2.VideoCapture(target)
        if not self._cap.isOpened():
            why = f"no stream within {STREAM_TIMEOUT_S:g} s, or " if stream else ""
            raise ConfigError(
                f"cannot open video source {source[:200]!r} with OpenCV ({why}unsupported format or no such camera)"
            )

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
