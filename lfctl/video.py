"""Frames from a real camera, a video file or a stream (OpenCV's VideoCapture), for
`lfctl follow` and `lfctl track`."""

from __future__ import annotations

import os
import stat
import threading
from pathlib import Path
from typing import Protocol

import cv2
import numpy as np

from lfctl.errors import ConfigError

__all__ = ["STREAM_TIMEOUT_S", "LatestFrames", "VideoSource"]

#: how long a stream (a URL) may take to open, and to give its next frame, s: a silent one
#: is an error (opening) or its end (reading), not a process blocked for ever
STREAM_TIMEOUT_S = 10.0


class _Capture(Protocol):
    def read(self) -> tuple[bool, np.ndarray | None]: ...


class LatestFrames:
    """A live source read on a thread of its own, its newest frame kept.

    A camera or a stream makes frames at its own rate whether they are read or not: the
    driver (V4L2's buffers, FFmpeg's for a stream) queues what is not, so a reader slower
    than the camera gets ever older frames, each a buffer's worth behind the world. Here a
    thread reads every frame as it comes and :meth:`next` hands over the newest one not yet
    taken (waiting for it when there is none); the frames overwritten before they were taken
    are counted in :attr:`skipped`.

    Parameters
    ----------
    capture : object with ``read() -> (ok, frame)``
        The opened source (a ``cv2.VideoCapture``).
    timeout_s : float
        How long :meth:`next` waits for a frame before it takes the source as ended, s.
    """

    def __init__(self, capture: _Capture, timeout_s: float) -> None:
        self._capture = capture
        self._timeout_s = timeout_s
        self._ready = threading.Condition()
        self._frame: np.ndarray | None = None
        self._ended = False
        self._stopping = False
        self.skipped = 0  # frames overwritten by a newer one before they were taken
        self._thread = threading.Thread(target=self._read, name="lfctl-camera", daemon=True)
        self._thread.start()

    def _read(self) -> None:
        try:
            while not self._stopping:
                try:
                    ok, frame = self._capture.read()
                except Exception:  # a driver's error is the source's end, as a failed read is
                    ok, frame = False, None
                if not ok or frame is None:
                    return
                with self._ready:
                    self.skipped += self._frame is not None
                    self._frame = frame
                    self._ready.notify_all()
        finally:  # ended, failed or stopped: a reader waiting is told at once
            with self._ready:
                self._ended = True
                self._ready.notify_all()

    def next(self) -> np.ndarray | None:
        """The newest frame not yet taken (waiting up to ``timeout_s`` for one), or None once
        the source has ended or stayed silent that long."""
        with self._ready:
            if self._frame is None and not self._ended:
                self._ready.wait_for(lambda: self._frame is not None or self._ended, self._timeout_s)
            frame, self._frame = self._frame, None
            return frame

    def stop(self) -> bool:
        """Stop reading; whether the thread has ended (a read under way is waited for up to
        ``timeout_s``: a source must not be released while the thread is inside it)."""
        self._stopping = True
        self._thread.join(self._timeout_s)
        return not self._thread.is_alive()


class VideoSource:
    """An opened video source; use as a context manager.

    A camera or a stream read with ``latest`` is read on a thread of its own and gives its
    newest frame (:class:`LatestFrames`); a file always gives every frame in turn.

    Parameters
    ----------
    source : str, int or os.PathLike
        A camera index (``0`` or ``"0"``), a video file (a path) or a stream URL (``rtsp://...``).
    latest : bool
        For a camera or a stream: each read gives the newest frame, passing over older ones
        (a controller's view of the world); otherwise every frame in turn, however old.

    Raises
    ------
    ConfigError
        A file that does not exist, a named pipe or socket (it would block with no end), a
        stream that does not open within :data:`STREAM_TIMEOUT_S`, or a source OpenCV cannot
        open or read a frame from.
    """

    def __init__(self, source: str | int | os.PathLike[str], latest: bool = False) -> None:
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
        #: a camera or a stream (frames come in real time), not a file
        self.live = isinstance(target, int) or stream
        self._latest = LatestFrames(self._cap, STREAM_TIMEOUT_S) if latest and self.live else None

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

    @property
    def skipped(self) -> int:
        """Frames passed over for a newer one (with ``latest`` on a live source; else 0)."""
        return self._latest.skipped if self._latest is not None else 0

    def read(self) -> np.ndarray | None:
        """The next frame (BGR, uint8), or the newest (``latest``), or None at the end of the
        source."""
        if self._latest is not None:
            return self._latest.next()
        ok, frame = self._cap.read()
        if not ok or frame is None:
            return None
        return frame

    def close(self) -> None:
        """Release the source (once its reading thread, if any, has stopped: a capture
        released under a read would crash the process; one stuck in its driver is left to
        the process's end)."""
        if self._latest is not None and not self._latest.stop():
            return
        self._cap.release()

    def __enter__(self) -> VideoSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
