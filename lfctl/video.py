"""Frames from a real camera, a video file or a stream (OpenCV's VideoCapture), for
`lfctl follow` and `lfctl track`."""

from __future__ import annotations

import contextlib
import math
import os
import socket
import stat
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import cv2
import numpy as np

from lfctl.errors import ConfigError

__all__ = [
    "REOPEN_S",
    "RTP_CLOCK_HZ",
    "RTP_PAYLOAD_TYPE",
    "STREAM_TIMEOUT_S",
    "FileInfo",
    "LatestFrames",
    "Reopening",
    "SourceNotReady",
    "VideoSource",
    "open_live",
    "probe_file",
    "rtp_address",
    "sdp",
]

#: how long a stream (a URL) may take to open, and to give its next frame, s: a silent one
#: is an error (opening) or its end (reading), not a process blocked for ever
STREAM_TIMEOUT_S = 10.0
#: a camera or stream that is not there yet, or has stopped, is tried again this often, s
REOPEN_S = 1.0
#: how long a source being closed as a run ends waits for its reading thread's read under
#: way, s (past it the capture is released by a later close, or by the process's end)
STOP_WAIT_S = 0.5
#: a file's frames that do not decode, one after another, passed over before its end is
#: taken as reached (a damaged stretch in the middle; read on after it, where its container
#: declares more frames)
MAX_UNDECODABLE_RUN = 30


class SourceNotReady(ConfigError):
    """A camera or stream that is not there now (no such camera yet, or busy; no stream
    arriving): one that may come (a camera plugged in or started later) is tried again."""


#: FFmpeg's readers that draw a text file (ANSI art, an .nfo, a .bin such as an ArduPilot
#: log) as pictures, and the codecs they give: such a file is not a video
TEXT_FORMATS = frozenset({"tty", "bin", "xbin", "adf", "idf"})
TEXT_CODECS = frozenset({"ansi", "bintext", "xbin", "idf"})
#: the first bytes of an MCAP file (the format's magic, with its major version): FFmpeg's
#: probe takes a run's log for a raw H.264 stream (its frames are in it) and decodes smears
MCAP_MAGIC = b"\x89MCAP0\r\n"


def missing_source(source: str, shipped: Path | None = None) -> str:
    """What to say of a video source that names no file, camera or stream; ``shipped``: the
    folder of clips a command also takes by name (lfctl's footage)."""
    by_name = f"; or a shipped clip by name, from {shipped}" if shipped is not None else ""
    return f"video source {source[:200]!r} does not exist (give a file, a camera index or a stream URL{by_name})"


@dataclass(frozen=True)
class FileInfo:
    """What a video file's container says of its first video stream (FFmpeg's, through PyAV)."""

    format: str  # FFmpeg's name for the container ("mov,mp4,m4a,3gp,3g2,mj2", "matroska,webm")
    codec: str  # the video codec
    frames: int | None  # the frames it stores a count of (MP4, MOV, AVI); None where it stores none
    #: the duration a Matroska or WebM file's head declares, s, where it is the video's: a file
    #: of the one video stream starting at 0 (else None: audio may run longer, and a late
    #: start counts in the duration)
    duration_s: float | None
    grey: bool  # its pixels are grey levels alone (a monochrome camera's format)


def probe_file(path: str) -> FileInfo | str:
    """What the container at ``path`` says (:class:`FileInfo`), or why FFmpeg could not open
    it (its words), before OpenCV reads the frames.

    Matroska and WebM store no frame count (OpenCV's is the duration times the nominal rate,
    far off for a variable rate or a recorder that dropped frames), but write the duration
    in their head, so a cut one ends well before it; an MPEG-TS states neither (its duration
    is estimated from what is there).

    Parameters
    ----------
    path : str
        A video file.

    Raises
    ------
    ConfigError
        A file with no video stream (audio only), one FFmpeg draws as text, not a video, or
        an MCAP log.
    """
    import av

    try:
        with open(path, "rb") as f:
            head = f.read(len(MCAP_MAGIC))
    except OSError:
        head = b""  # (FFmpeg says why below)
    if head == MCAP_MAGIC:
        raise ConfigError(f"{path} is an MCAP log, not a video: `lfctl replay {path}` shows its camera frames")

    undecodable = False
    try:
        with av.open(path) as container:
            streams = container.streams.video
            name = container.format.name
            info = None
            if streams and streams[0].codec_context is None:  # no decoder for it in FFmpeg
                undecodable = True
            elif streams:
                stream = streams[0]
                duration = None
                alone = len(container.streams) == 1 and not (container.start_time or 0) > 0.5e6
                if "matroska" in name and container.duration and alone:
                    duration = container.duration / 1e6  # (microseconds)
                count = stream.frames if stream.frames > 0 else None
                shown_s = float(stream.duration * stream.time_base) if stream.duration and stream.time_base else 0.0
                if count is not None and shown_s > 0 and stream.average_rate and "mp4" in name:
                    # an MP4 trimmed with an edit list (ffmpeg -ss .. -c copy) keeps samples
                    # it does not show: its count is of the samples, its duration (from its
                    # index, which a cut MP4 has not) of the shown; an AVI's duration may be
                    # estimated from what is there, so its count stands
                    count = min(count, round(shown_s * float(stream.average_rate)))
                pix_fmt = stream.codec_context.pix_fmt or ""
                grey = pix_fmt.startswith(("gray", "ya", "mono"))
                info = FileInfo(name, stream.codec_context.name, count, duration, grey)
    except (av.FFmpegError, OSError, EOFError, ValueError) as exc:
        return str(getattr(exc, "strerror", None) or exc)
    if undecodable:
        raise ConfigError(f"{path}: its video is in a format FFmpeg has no decoder for")
    if info is None:
        raise ConfigError(f"{path} has no video stream (audio only, or no frames)")
    if name in TEXT_FORMATS or info.codec in TEXT_CODECS:
        raise ConfigError(f"{path} is not a video: FFmpeg draws it as text (its {name!r} reader)")
    return info


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

    @property
    def ended(self) -> bool:
        """Whether the source has ended: a failed read, or a stream silent for its read timeout
        (its newest frame may still be waiting to be taken)."""
        return self._ended

    def next(self, timeout_s: float | None = None) -> np.ndarray | None:
        """The newest frame not yet taken (waiting up to ``timeout_s`` for one, by default the
        source's own), or None once the source has ended or stayed silent that long."""
        wait = self._timeout_s if timeout_s is None else timeout_s
        with self._ready:
            if self._frame is None and not self._ended:
                self._ready.wait_for(lambda: self._frame is not None or self._ended, wait)
            frame, self._frame = self._frame, None
            return frame

    def stop(self, wait_s: float | None = None) -> bool:
        """Stop reading; whether the thread has ended (a read under way is waited for up to
        ``wait_s``, by default ``timeout_s``: a source must not be released while the thread
        is inside it)."""
        self._stopping = True
        self._thread.join(self._timeout_s if wait_s is None else wait_s)
        return not self._thread.is_alive()


class VideoSource:
    """An opened video source; use as a context manager.

    A camera or a stream read with ``latest`` is read on a thread of its own and gives its
    newest frame (:class:`LatestFrames`); a file always gives every frame in turn.

    Parameters
    ----------
    source : str, int or os.PathLike
        A camera index (``0`` or ``"0"``), a video file (a path), a stream URL (``rtsp://...``),
        a session description (a ``.sdp`` file: an RTP stream as a player takes it), or
        ``rtp://HOST:PORT``: RTP/UDP H.264 with payload type 96 arriving on that port (as
        ``lfctl sim --video``, QGroundControl's "UDP h.264 Video Stream" and most rover
        cameras send it; its session description is made here).
    latest : bool
        For a camera or a stream: each read gives the newest frame, passing over older ones
        (a controller's view of the world); otherwise every frame in turn, however old.
    timeout_s : float, optional
        How long a stream may take to open, and to give its next frame (default
        :data:`STREAM_TIMEOUT_S`).

    Raises
    ------
    ConfigError
        A file that does not exist, a named pipe or socket (it would block with no end), a
        stream that does not open within ``timeout_s``, or a source OpenCV cannot open or
        read a frame from.
    """

    def __init__(
        self, source: str | int | os.PathLike[str], latest: bool = False, timeout_s: float | None = None
    ) -> None:
        wait = STREAM_TIMEOUT_S if timeout_s is None else timeout_s
        if isinstance(source, bool) or not isinstance(source, str | int | os.PathLike):
            raise ConfigError(f"video source must be a camera index, a file or a stream URL, got {source!r}")
        path = isinstance(source, os.PathLike)  # a path is a file, even one named "7"
        source = os.fspath(source) if path else str(source)
        self.name = source
        target: str | int = int(source) if source.isdigit() and not path else source
        stream = isinstance(target, str) and "://" in target
        made: str | None = None  # the session description made for an rtp:// source
        rtp_url = isinstance(target, str) and target.startswith("rtp://")
        if rtp_url:
            target = made = _rtp_session(str(target))
        # a session description here (a stream); one at a URL is FFmpeg's to fetch
        rtp = isinstance(target, str) and "://" not in target and target.lower().endswith(".sdp")
        stream = stream or rtp
        #: what the file's container says (None for a camera or a stream)
        self.info: FileInfo | None = None
        why_not = ""  # FFmpeg's reason a file would not open
        if isinstance(target, str) and not stream:
            self.info, why_not = self._check_file(source)
        if rtp:
            self._check_sdp(str(target), source)
        if stream:
            ms = max(1, int(wait * 1000))
            # one decoding thread: FFmpeg's frame threads hold back a frame each (a frame more
            # than one thread behind the camera, and each held frame handed over only when a
            # read times out once the stream stops: its end came a read timeout later each)
            params = [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, ms, cv2.CAP_PROP_READ_TIMEOUT_MSEC, ms, cv2.CAP_PROP_N_THREADS, 1]
            try:
                with _ffmpeg_options("protocol_whitelist;file,udp,rtp" if rtp else None):
                    self._cap = cv2.VideoCapture(target, cv2.CAP_FFMPEG, params)
            finally:  # FFmpeg has read the description it was made for (or the open was cut short)
                if made is not None:
                    Path(made).unlink(missing_ok=True)
        else:
            self._cap = cv2.VideoCapture(target)
        if not self._cap.isOpened():
            if isinstance(target, int):
                mine = f" (a file named {source!r} is here: give ./{source} for it)" if Path(source).is_file() else ""
                raise SourceNotReady(f"cannot open camera {target} with OpenCV (no such camera, or it is busy){mine}")
            if rtp_url:
                raise SourceNotReady(
                    f"no RTP stream to {source[:200]} within {wait:g} s: start the camera (or lfctl sim "
                    "--video) sending to this machine's port first, or within that time"
                )
            if stream:
                raise SourceNotReady(
                    f"cannot open video source {source[:200]!r} with OpenCV (no stream within "
                    f"{wait:g} s, or unsupported format)"
                )
            raise ConfigError(
                f"cannot read {source[:200]!r} as a video ({why_not or 'OpenCV cannot open it'}): not a video, or a "
                "file cut short (an MP4 or MOV recording stopped before it finished has no index)"
            )
        #: a camera or a stream (frames come in real time), not a file
        self.live = isinstance(target, int) or stream
        self._latest = LatestFrames(self._cap, wait) if latest and self.live else None
        self.frames_read = 0  # frames handed over
        #: a file's frames that did not decode (damaged in the middle) with frames after them
        #: that did: passed over, the reading going on
        self.passed_over = 0
        self._released = False
        self._abandoned = False  # a close waited for the reading thread in vain
        self._pending: np.ndarray | None = None  # a frame given back (unread), handed over next
        self._first_ms: float | None = None  # the first frame's time in the file, ms
        self._last_ms = -math.inf
        self._timed_frames = 0  # frames read up to the last one with a time of its own
        #: the frames carry no times of their own (a raw H.264 or MJPEG stream): a frame's
        #: time is counted from the declared rate
        self.untimed = self.live

    @staticmethod
    def _check_sdp(path: str, source: str) -> None:
        """A session description must be a readable text file naming a video stream."""
        try:
            text = Path(path).read_text(errors="replace")[:65536]
        except OSError as exc:
            raise ConfigError(f"cannot read the session description {source[:200]!r}: {exc}") from None
        if "m=video" not in text:
            raise ConfigError(f"{source[:200]} is no session description of a video stream (no 'm=video' line)")

    @staticmethod
    def _check_file(source: str) -> tuple[FileInfo | None, str]:
        """Refuse what is not a video file (missing, a directory, empty, a pipe, text); the
        container's information, or FFmpeg's reason it would not open."""
        try:
            st = os.stat(source)
        except (OSError, ValueError):
            if source.startswith("/dev/"):  # a camera's device, not there yet (a USB camera enumerating)
                raise SourceNotReady(f"no camera device {source[:200]} (not plugged in, or not ready)") from None
            raise ConfigError(missing_source(source)) from None
        if stat.S_ISFIFO(st.st_mode) or stat.S_ISSOCK(st.st_mode):
            raise ConfigError(f"{source} is a named pipe or socket, not a video file (a stream is given by its URL)")
        if stat.S_ISDIR(st.st_mode):
            raise ConfigError(f"{source} is a directory, not a video file")
        if not stat.S_ISREG(st.st_mode):
            return None, ""  # a device (a camera's /dev/video0): OpenCV opens it, nothing to probe
        if st.st_size == 0:
            raise ConfigError(f"{source} is empty (0 bytes)")
        info = probe_file(source)
        return (info, "") if isinstance(info, FileInfo) else (None, info)

    def _declares_more(self, failed: int) -> bool:
        """Whether a file's container declares frames beyond those read and ``failed``."""
        declared = self.info.frames if self.info is not None else None
        return declared is not None and self.frames_read + self.passed_over + failed < declared

    @property
    def fps(self) -> float:
        """Frames per second the source declares (30 when it declares none)."""
        return float(self._cap.get(cv2.CAP_PROP_FPS) or 30.0)

    @property
    def declared_frames(self) -> int | None:
        """How many frames a video file's container says it holds (None for a camera or a
        stream, or a container that stores no count: OpenCV's figure for those is an
        estimate from the duration, far off for a variable frame rate)."""
        return self.info.frames if self.info is not None else None

    @property
    def pixel_aspect(self) -> tuple[int, int] | None:
        """The sample (pixel) aspect ratio a file or stream declares when its pixels are not
        square (a DV or DVD picture's 64:45, say), else None."""
        num, den = (int(self._cap.get(p) or 0) for p in (cv2.CAP_PROP_SAR_NUM, cv2.CAP_PROP_SAR_DEN))
        return (num, den) if num > 0 and den > 0 and num != den else None

    @property
    def declared_duration_s(self) -> float | None:
        """The duration a Matroska or WebM file's head declares, s (None otherwise)."""
        return self.info.duration_s if self.info is not None else None

    @property
    def time_s(self) -> float:
        """The time of the frame last read, from the first frame's, s: the frame's own
        timestamp in a file (right for a variable frame rate), else counted at :attr:`fps`."""
        if self._first_ms is None:  # a camera, a stream, or none read yet
            return max(0, self.frames_read - 1) / self.fps
        timed_s = (self._last_ms - self._first_ms) / 1000.0
        return timed_s + (self.frames_read - self._timed_frames) / self.fps  # (counted on once untimed)

    @property
    def skipped(self) -> int:
        """Frames passed over for a newer one (with ``latest`` on a live source; else 0)."""
        return self._latest.skipped if self._latest is not None else 0

    def unread(self, frame: np.ndarray) -> None:
        """Give back the frame last read: the next :meth:`read` returns it again (a file's
        first frame, read to learn the picture's size, is still the first one used).

        Parameters
        ----------
        frame : np.ndarray
            The frame :meth:`read` last returned.
        """
        self._pending = frame
        self.frames_read -= 1

    @property
    def ended(self) -> bool:
        """Whether a live source read with ``latest`` has stopped giving frames (its reading
        thread ended: a failed read, or a stream silent for the source's timeout); False
        for any other source (a file's end is :meth:`read` returning None)."""
        return self._latest is not None and self._latest.ended

    def read(self, timeout_s: float | None = None) -> np.ndarray | None:
        """The next frame (BGR, uint8), or the newest (``latest``), or None at the end of the
        source.

        Parameters
        ----------
        timeout_s : float, optional
            With ``latest``: how long to wait for a new frame before None (default the
            source's timeout); None then means none came in that time, and the source
            has ended only if :attr:`ended` says so.
        """
        if self._pending is not None:
            frame, self._pending = self._pending, None
            self.frames_read += 1
            return frame
        if self._latest is not None:
            frame = self._latest.next(timeout_s)
            self.frames_read += frame is not None
            return frame
        ok, frame = self._cap.read()
        failed = 0  # frames of a file that do not decode, before the end its container declares
        while (not ok or frame is None) and failed < MAX_UNDECODABLE_RUN and self._declares_more(failed):
            failed += 1
            ok, frame = self._cap.read()
        if not ok or frame is None:
            return None
        self.passed_over += failed
        self.frames_read += 1
        if not self.untimed:
            ms = float(self._cap.get(cv2.CAP_PROP_POS_MSEC))
            if self._first_ms is None:
                self._first_ms = ms
            elif not ms > self._last_ms:  # a stream with no times (FFmpeg gives 0 for each)
                self.untimed = True  # counted on from the last time it had, at the rate
                return frame
            self._last_ms, self._timed_frames = ms, self.frames_read
        return frame

    def close(self, wait_s: float | None = None) -> None:
        """Release the source (once its reading thread, if any, has stopped, waited for up to
        ``wait_s``, by default the source's timeout: a capture released under a read would
        crash the process). One whose read is still under way then is left: a later close
        does not wait again and releases it if the read has ended meanwhile, else the
        process's end does. Closing a released source does nothing."""
        if self._released:
            return
        if self._latest is not None and not self._latest.stop(0.0 if self._abandoned else wait_s):
            self._abandoned = True
            return
        self._cap.release()
        self._released = True

    def __enter__(self) -> VideoSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_live(
    source: str | int | os.PathLike[str], wait_s: float | None = None, say: Callable[[str], None] | None = None
) -> tuple[VideoSource, np.ndarray]:
    """Open a video source and read its first frame; a camera or a stream that is not there
    yet (:class:`SourceNotReady`, or one that opens and gives no frame) is tried again every
    :data:`REOPEN_S` for up to ``wait_s`` (None: until it comes), as a rover's camera may
    start after its companion. A live source is read with ``latest`` (its newest frame each
    read); a file is not waited for.

    Parameters
    ----------
    source : str, int or os.PathLike
        As :class:`VideoSource` takes it.
    wait_s : float, optional
        How long to wait for a live source, s (None: no end; 0: one try).
    say : callable, optional
        Told why, at the first failed try and every :data:`STREAM_TIMEOUT_S` after.

    Returns
    -------
    (VideoSource, np.ndarray)
        The open source and its first frame (already read).

    Raises
    ------
    ConfigError
        A source that is no video (a file, at once), or a live one still not there after
        ``wait_s`` (its last reason, and how long it was waited for).
    """
    start = time.monotonic()
    said_at = -math.inf
    while True:
        # a stream's try (its opening, then its first frame) fits in what is left of the wait
        left = math.inf if wait_s is None else wait_s - (time.monotonic() - start)
        timeout = min(STREAM_TIMEOUT_S, max(0.1, left / 2))
        try:
            video = VideoSource(source, latest=True, timeout_s=timeout)
        except SourceNotReady as exc:
            why = str(exc)
        else:
            first = video.read()
            if first is not None:
                return video, first
            video.close()
            if not video.live:
                raise ConfigError(f"video {str(source)[:200]!r} gave no frame (an empty or broken file)")
            why = f"the camera {str(source)[:200]!r} opened but gave no frame within {timeout:g} s"
        waited = time.monotonic() - start
        if wait_s is not None and waited >= wait_s:
            raise ConfigError(f"{why} (waited {waited:.1f} s for it)")
        if say is not None and waited - said_at >= STREAM_TIMEOUT_S:
            said_at = waited
            say(why)
        pause = REOPEN_S if wait_s is None else min(REOPEN_S, wait_s - waited)
        time.sleep(max(0.0, pause))


class Reopening:
    """A live source opened again on a thread of its own, every :data:`REOPEN_S` until it
    opens (a camera whose stream stopped: its driver reset, a loose cable, the stream's sender
    restarted); :meth:`take` hands it over once, :meth:`stop` ends the tries.

    Parameters
    ----------
    opener : callable
        Opens the source (``VideoSource(name, latest=True)``); any error it raises
        (:class:`SourceNotReady`, another :class:`ConfigError`, a driver's) means not yet,
        and it is tried again.
    delay_s : float
        Wait before the first try, s (a source that opened and stopped at once is not
        opened again at once).
    """

    def __init__(self, opener: Callable[[], VideoSource], delay_s: float = 0.0) -> None:
        self._opener = opener
        self._delay_s = delay_s  # before the first try
        self.tries = 0
        self.why = ""  # the last failed try's reason
        self._opened: VideoSource | None = None
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._run, name="lfctl-camera-open", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        self._stopping.wait(self._delay_s)
        while not self._stopping.is_set():
            self.tries += 1
            try:
                video = self._opener()
            except Exception as exc:  # (a driver's error too: the tries must go on, not die unseen)
                self.why = str(exc) or type(exc).__name__
            else:
                with self._lock:
                    if self._stopping.is_set():
                        video.close(STOP_WAIT_S)
                    else:
                        self._opened = video
                return
            self._stopping.wait(REOPEN_S)

    def take(self) -> VideoSource | None:
        """The source once it has opened (handed over once: the taker closes it), else None."""
        with self._lock:
            video, self._opened = self._opened, None
            return video

    def stop(self) -> None:
        """End the tries, at once: a source opened and not taken is closed, and one a try
        under way opens (up to :data:`STREAM_TIMEOUT_S` from now) is closed by its thread."""
        self._stopping.set()
        with self._lock:
            video, self._opened = self._opened, None
        if video is not None:
            video.close(STOP_WAIT_S)


def rtp_address(url: str) -> tuple[str, int]:
    """The address an ``rtp://HOST:PORT`` source arrives on (an IPv6 host without its
    brackets). ConfigError for a URL that is not ``rtp://HOST:PORT`` with a port below 65535.

    Parameters
    ----------
    url : str
        The source, ``rtp://127.0.0.1:5600``.
    """
    from lfctl.checks import check_host_port

    rest = url[len("rtp://") :] if url.startswith("rtp://") else ""
    if not rest or "/" in rest or "?" in rest:
        raise ConfigError(f"an RTP source is rtp://HOST:PORT (the port it arrives on), got {url[:200]!r}")
    host, port = check_host_port("rtp://", rest, allow_any_port=True)
    if not 0 < port < 65535:
        raise ConfigError(
            f"an RTP source needs the port it arrives on, below 65535 (RTCP takes the next), got {url[:200]!r}"
        )
    return (host[1:-1] if host.startswith("[") and host.endswith("]") else host), port  # ([::1])


def _rtp_session(url: str) -> str:
    """``rtp://HOST:PORT`` as a session description file (H.264, payload type 96), made in
    the temporary folder; its path. ConfigError for a URL that is not ``rtp://HOST:PORT``."""
    import tempfile

    host, port = rtp_address(url)
    six = ":" in host
    if not six:  # a name (localhost) as the address FFmpeg binds: its description takes no names
        try:
            host = socket.gethostbyname(host)
        except OSError as exc:
            raise ConfigError(f"{url[:200]}: cannot resolve {host!r} ({exc})") from None
    family, anywhere = (socket.AF_INET6, "::") if six else (socket.AF_INET, "0.0.0.0")
    # the stream's port on HOST, and RTCP's after it, which FFmpeg binds on every address
    for addr in ((host, port), (anywhere, port + 1)):
        with socket.socket(family, socket.SOCK_DGRAM) as s:
            try:
                s.bind(addr)
            except OSError as exc:
                raise ConfigError(
                    f"{url[:200]}: cannot receive on {addr[0]}:{addr[1]} ({exc.strerror}): another reader holds it "
                    "(lfctl follow or track, a ground station), or it is not this machine's address"
                ) from None
    fd, path = tempfile.mkstemp(prefix="lfctl-rtp-", suffix=".sdp")
    with os.fdopen(fd, "w") as f:
        f.write(sdp(host, port))
    return path


@contextlib.contextmanager
def _ffmpeg_options(options: str | None) -> Iterator[None]:
    """OpenCV's FFmpeg capture options (``OPENCV_FFMPEG_CAPTURE_OPTIONS``, read as a capture
    opens) with ``options`` added while the block runs: an RTP session description opens
    only with the udp and rtp protocols allowed."""
    key = "OPENCV_FFMPEG_CAPTURE_OPTIONS"
    before = os.environ.get(key)
    if options is not None:
        os.environ[key] = options if not before else f"{before}|{options}"
    try:
        yield
    finally:
        if options is not None:
            if before is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = before


#: the dynamic payload type QGroundControl and GStreamer pipelines expect for H.264 over RTP
RTP_PAYLOAD_TYPE = 96
#: RTP's clock for video, Hz
RTP_CLOCK_HZ = 90_000


def sdp(host: str, port: int, name: str = "lfctl camera") -> str:
    """A session description of a stream :class:`lfctl.record.rtp.RtpH264Sender` sends to ``host:port``, for
    players that need one (``ffplay -protocol_whitelist file,udp,rtp -i stream.sdp``).

    Parameters
    ----------
    host : str
        The address the stream is sent to (the receiving side).
    port : int
        Its UDP port.
    name : str
        The session's name.
    """
    kind = "IP6" if ":" in host else "IP4"
    return (
        "v=0\r\n"
        f"o=- 0 0 IN {kind} {host}\r\n"
        f"s={name}\r\n"
        f"c=IN {kind} {host}\r\n"
        "t=0 0\r\n"
        f"m=video {port} RTP/AVP {RTP_PAYLOAD_TYPE}\r\n"
        f"a=rtpmap:{RTP_PAYLOAD_TYPE} H264/{RTP_CLOCK_HZ}\r\n"
        f"a=fmtp:{RTP_PAYLOAD_TYPE} packetization-mode=1\r\n"
    )
