"""Followers' cameras across processes: render, track, estimate the pose and encode the image
(JPEG or H.264 for the log, H.264 for the live stream) of every follower in lockstep, some in this process and the rest in worker processes.

Rendering and tracking are numpy and OpenCV driven from Python, so threads would share one
interpreter lock; processes do not. Each follower's camera (renderer, tracker, their random
streams) lives in exactly one process for the whole run and sees the same world states in
the same order, so a run gives the same result with any number of workers. Per camera tick
the main process sends the world state (a few hundred bytes) to every worker, runs its own
followers meanwhile, then collects the workers' samples (no raw image: the encoded ones that are due). A camera's
H.264 encoders live in its process, so their streams stay whole whichever process it is.
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import subprocess
import time
import traceback
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, replace
from multiprocessing.connection import Connection
from typing import Any

import cv2
import numpy as np

from lfctl.config import Config
from lfctl.errors import ConfigError, LfctlError
from lfctl.record.video import H264Encoder
from lfctl.sim.camera_sensor import CameraSample, CameraSensor
from lfctl.sim.world import WorldState
from lfctl.vision.camera_model import CameraModel
from lfctl.vision.draw import annotate
from lfctl.vision.track_state import RelativeMeasurement
from lfctl.workers import start_worker, worker_fds

__all__ = ["CameraJob", "CameraPool", "CameraResult", "CameraWorkerError", "default_workers"]


class CameraWorkerError(LfctlError, RuntimeError):
    """A camera worker process failed or died."""


@dataclass(frozen=True)
class CameraJob:
    """One follower's camera tick."""

    follower: str  # whose camera
    me: int  # the follower's index in the world state
    target: int  # its target's index in the world state
    image: bool  # an image is due for the log (encoded as ``[recording] image_format`` says)
    stream: bool = False  # encode the frame for the live RTP stream too (annotated if ``[live] video_annotated``)


@dataclass(frozen=True)
class CameraResult:
    """What a camera tick hands back: the sample, the encoded images that were due, and the
    seconds each stage took (for the cost split)."""

    sample: CameraSample  # the tick's sample (its frame None when it came from a worker)
    image: bytes | None  # the log's JPEG or H.264 access unit; None when no image was due
    render_s: float  # rendering, s
    vision_s: float  # tracking and pose
    encode_s: float  # encoding the log's image
    stream: bytes | None = None  # the live stream's H.264 access unit, when asked for


def default_workers(cfg: Config) -> int:
    """``sim.camera_workers`` resolved: -1 is one worker per usable core beyond this one, at
    most one per follower beyond the first (this process runs cameras too).

    Parameters
    ----------
    cfg : Config
        The scenario (``[sim] camera_workers``, its followers).
    """
    n = cfg.sim.camera_workers
    if n >= 0:
        return min(n, max(0, len(cfg.followers) - 1))
    return max(0, min(usable_cores() - 1, len(cfg.followers) - 1))


def usable_cores() -> int:
    """Cores this process may run on (respects taskset and cgroup CPU sets)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


class _Cameras:
    """The cameras one process runs, with their encoders.

    With a core to spare (``threaded``), one encoder thread encodes a frame for the log while
    its tracker runs (imencode and x264 release the interpreter lock). Without one the
    thread only costs: handing the lock back and forth on one core made a leader + 1 run
    ~20 % slower than encoding in line, so then the frame is encoded in line. The single
    thread keeps each H.264 encoder's frames in order.
    """

    def __init__(self, cfg: Config, specs: list[tuple[str, int]], threaded: bool) -> None:
        self.cfg = cfg
        # a follower whose companion runs outside (lfctl follow) tracks its frames there: here
        # they are only rendered, streamed as the camera sees them and recorded
        self._bare_streams = {v.name for v in cfg.followers if not v.companion}
        self.sensors = {
            name: CameraSensor(cfg, name, seed, perceive=name not in self._bare_streams) for name, seed in specs
        }
        # x264 through PyAV takes and gives back the interpreter lock several times a frame:
        # beside a busy tracker thread each hand-over waits for a switch interval, which made
        # a thread 4x slower than encoding in line; JPEG (one call, lock released) gains
        threaded = threaded and cfg.recording.image_format == "jpeg"
        self._encoder = ThreadPoolExecutor(max_workers=1, thread_name_prefix="lfctl-encode") if threaded else None
        self._video: dict[str, H264Encoder] = {}  # the log's H.264, per follower
        self._stream: dict[str, H264Encoder] = {}  # the live stream's H.264, per follower

    def _encode_image(self, follower: str, frame: np.ndarray) -> tuple[bytes | None, float]:
        """The frame for the log, as ``[recording] image_format`` says, and the seconds it took."""
        rec = self.cfg.recording
        t0 = time.perf_counter()
        if rec.image_format == "jpeg":
            ok, buf = cv2.imencode(".jpg", frame, [cv2.IMWRITE_JPEG_QUALITY, rec.jpeg_quality])
            return (buf.tobytes() if ok else None), time.perf_counter() - t0
        enc = self._video.get(follower)
        if enc is None:
            fps = min(rec.image_rate_hz, self.cfg.sim.camera_rate_hz)
            h, w = frame.shape[:2]
            if w % 2 or h % 2:
                raise ConfigError(
                    f"camera.width_px x height_px is {w}x{h}: H.264 recording (recording.image_format) needs both "
                    'even; make them even, or set recording.image_format = "jpeg"'
                )
            enc = self._video[follower] = H264Encoder(w, h, fps, rec.video_bitrate_kbps, rec.video_gop)
        return enc.encode(frame).data, time.perf_counter() - t0

    def _encode_stream(self, follower: str, frame: np.ndarray, sample: CameraSample) -> bytes:
        """The frame for the live stream (annotated when ``[live] video_annotated``, unless
        the follower has no simulated companion: then the stream is the camera an outside one
        tracks, and drawn boxes would be tracked with it)."""
        live = self.cfg.live
        enc = self._stream.get(follower)
        if enc is None:
            fps = self.cfg.sim.camera_rate_hz
            h, w = frame.shape[:2]
            if w % 2 or h % 2:
                raise ConfigError(f"camera.width_px x height_px is {w}x{h}: the H.264 stream (--video) needs both even")
            enc = self._stream[follower] = H264Encoder(w, h, fps, live.video_bitrate_kbps, max(1, round(fps)))
        m = sample.measurement
        if live.video_annotated and m is not None:
            label = f"{follower} t {sample.t_s:.1f} s " + (
                f"{m.status.value} r {m.range_m:.2f} m b {math.degrees(m.bearing_rad):+.1f} deg"
                if m.range_m is not None and m.bearing_rad is not None
                else m.status.value
            )
            frame = annotate(frame, sample.track, label)
        return enc.encode(frame).data

    def run(self, t_s: float, world: WorldState, jobs: list[CameraJob], keep_frames: bool) -> list[CameraResult]:
        pending: list[tuple[CameraJob, CameraSample, Future[tuple[bytes | None, float]] | None, float, float]] = []
        for job in jobs:
            sensor = self.sensors[job.follower]
            started: list[Future[tuple[bytes | None, float]]] = []

            def encode(
                _t: float,
                frame: np.ndarray,
                job: CameraJob = job,
                started: list[Future[tuple[bytes | None, float]]] = started,
            ) -> None:
                if not job.image:
                    return
                if self._encoder is not None:
                    started.append(self._encoder.submit(self._encode_image, job.follower, frame))
                else:
                    done: Future[tuple[bytes | None, float]] = Future()
                    done.set_result(self._encode_image(job.follower, frame))
                    started.append(done)

            r0, v0 = sensor.render_s, sensor.vision_s
            sample = sensor.capture(t_s, world, job.me, job.target, encode)
            pending.append((job, sample, started[0] if started else None, sensor.render_s - r0, sensor.vision_s - v0))
        out = []
        for job, sample, fut, render_s, vision_s in pending:
            image, encode_s = fut.result() if fut is not None else (None, 0.0)
            stream = (
                self._encode_stream(job.follower, sample.frame, sample)
                if job.stream and sample.frame is not None
                else None
            )
            kept = sample if keep_frames else replace(sample, frame=None)
            out.append(CameraResult(kept, image, render_s, vision_s, encode_s, stream))
        return out

    def close(self) -> None:
        if self._encoder is not None:
            self._encoder.shutdown(wait=True, cancel_futures=True)


def _worker_main(conn: Connection) -> None:
    """A worker process: build its cameras, then serve ticks until told to stop."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the main process decides when a run ends
    cv2.setNumThreads(1)  # one core per process: OpenCV's own threads would fight the others
    try:
        cfg, specs, threaded = conn.recv()
        cams = _Cameras(cfg, specs, threaded)
        conn.send(("ready", None))
        while True:
            msg = conn.recv()
            if msg is None:
                break
            t_s, world, jobs = msg
            conn.send(("ok", cams.run(t_s, world, jobs, keep_frames=False)))
        cams.close()
    except (EOFError, BrokenPipeError):
        return  # the main process went away
    except Exception:  # everything goes back to the main process, which raises it
        conn.send(("error", traceback.format_exc()))


class CameraPool:
    """Every follower's camera, spread over this process and ``workers`` worker processes.

    ``specs`` are (follower, seed) pairs; follower k goes to process k mod (workers + 1),
    with 0 this one. Use as a context manager, or call :meth:`close`.

    Parameters
    ----------
    cfg : Config
        The scenario every camera renders (camera, banner, scene, slots).
    specs : list of (str, int)
        Each follower's name and its renderer's seed.
    workers : int
        Worker processes to start (at most one per follower beyond the first; 0: every
        camera in this process).

    Raises
    ------
    CameraWorkerError
        A worker failed to start or to build its cameras.
    """

    def __init__(self, cfg: Config, specs: list[tuple[str, int]], workers: int = 0) -> None:
        self.cfg = cfg
        self.workers = max(0, min(workers, len(specs) - 1))
        n = self.workers + 1
        self.where = {name: k % n for k, (name, _seed) in enumerate(specs)}  # follower -> process
        groups = [[s for s in specs if self.where[s[0]] == g] for g in range(n)]
        self.render_s = dict.fromkeys(self.where, 0.0)
        self.vision_s = dict.fromkeys(self.where, 0.0)
        self.encode_s = dict.fromkeys(self.where, 0.0)
        self.latest: dict[str, CameraSample] = {}
        self.cam = CameraModel.from_config(cfg.camera)
        self._procs: list[tuple[subprocess.Popen[bytes], Connection]] = []
        threaded = usable_cores() > self.workers + 1  # a core left for JPEG threads
        self._cv_threads = cv2.getNumThreads()
        if self.workers:
            cv2.setNumThreads(1)  # a core per process: OpenCV's own threads would only fight them
        try:
            for group in groups[1:]:
                proc, conn = start_worker("lfctl.sim.camera_pool")
                self._procs.append((proc, conn))
                self._send(len(self._procs), proc, conn, (cfg, group, threaded))
            self._local = _Cameras(cfg, groups[0], threaded)
            for k, (proc, conn) in enumerate(self._procs):
                self._reply(k + 1, proc, conn)  # wait until its renderers are built
        except BaseException:
            self.close()
            raise

    def _names(self, k: int) -> str:
        return ", ".join(n for n, w in self.where.items() if w == k)

    def _died(self, k: int, proc: subprocess.Popen[bytes]) -> CameraWorkerError:
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(1.0)
        return CameraWorkerError(
            f"camera worker for {self._names(k)} died (exit code {proc.returncode}); "
            "set [sim] camera_workers = 0 to run every camera in the main process"
        )

    def _send(self, k: int, proc: subprocess.Popen[bytes], conn: Connection, msg: Any) -> None:
        try:
            conn.send(msg)
        except OSError:  # broken pipe, reset
            raise self._died(k, proc) from None

    def _reply(self, k: int, proc: subprocess.Popen[bytes], conn: Connection) -> Any:
        try:
            kind, payload = conn.recv()
        except (EOFError, OSError):
            raise self._died(k, proc) from None
        if kind == "error":
            raise CameraWorkerError(f"camera worker for {self._names(k)} failed:\n{payload}")
        return payload

    def capture(self, t_s: float, world: WorldState, jobs: list[CameraJob]) -> list[CameraResult]:
        """Run every job of this tick; results in the order of ``jobs``.

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        world : WorldState
            The truth every camera renders.
        jobs : list of CameraJob
            One per follower whose camera ticks now.

        Raises
        ------
        CameraWorkerError
            A worker failed or died.
        """
        remote: list[list[CameraJob]] = [[] for _ in self._procs]
        local = []
        for job in jobs:
            w = self.where[job.follower]
            (local if w == 0 else remote[w - 1]).append(job)
        for k, ((proc, conn), group) in enumerate(zip(self._procs, remote, strict=True)):
            if group:
                self._send(k + 1, proc, conn, (t_s, world, group))
        by_name = {j.follower: r for j, r in zip(local, self._local.run(t_s, world, local, True), strict=True)}
        for k, ((proc, conn), group) in enumerate(zip(self._procs, remote, strict=True)):
            if group:
                for job, res in zip(group, self._reply(k + 1, proc, conn), strict=True):
                    by_name[job.follower] = res
        out = [by_name[j.follower] for j in jobs]
        for job, res in zip(jobs, out, strict=True):
            self.render_s[job.follower] += res.render_s
            self.vision_s[job.follower] += res.vision_s
            self.encode_s[job.follower] += res.encode_s
            self.latest[job.follower] = res.sample
        return out

    def measurement(self, follower: str) -> RelativeMeasurement | None:
        """The follower's newest measurement (None before its first frame, and from a camera
        that only renders).

        Parameters
        ----------
        follower : str
            The follower's name.
        """
        s = self.latest.get(follower)
        return s.measurement if s is not None else None

    def close(self) -> None:
        """Stop the workers (politely, then firmly)."""
        if getattr(self, "_local", None) is not None:
            self._local.close()
        for _proc, conn in self._procs:
            with contextlib.suppress(BrokenPipeError, OSError):
                conn.send(None)
        deadline = time.monotonic() + 5.0
        for proc, conn in self._procs:
            try:
                proc.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
            conn.close()
        self._procs = []
        cv2.setNumThreads(self._cv_threads)

    def __enter__(self) -> CameraPool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


if __name__ == "__main__":
    # run the worker from the module under its real name, so what it pickles names
    # lfctl.sim.camera_pool classes, not __main__ ones
    from lfctl.sim import camera_pool

    camera_pool._worker_main(Connection(worker_fds()[0]))
