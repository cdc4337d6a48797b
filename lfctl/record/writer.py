"""The run's log: an MCAP file and, with ``--live``, a Foxglove WebSocket, fed by one call.

Every message is logged once, through foxglove-sdk channels on the run's own context; the
context's sinks are the MCAP file (foxglove-sdk's MCAP writer: zstd or lz4 chunks with
chunk, data-section and summary CRCs) and the live WebSocket server. So the file and the
live view carry the same topics, schemas and messages, and there is no second list of
either. Written first, so a crash cannot lose them: metadata (lfctl version and git
revision, package versions, the run's scenario, seed, clock, dt, its start time) and
attachments (the scenario TOML, each FMU's modelDescription.xml) with their SHA-256.

Times: ``log_time`` and every message's ``timestamp`` are on the epoch clock, the run's
start wall time (metadata ``run.start_time_ns``) plus the simulation time; JSON messages
also carry the simulation time as ``t_s``. An image, its annotations and its tracker
message share one timestamp.

Topics: ``/<vehicle>/pose`` (foxglove.PoseInFrame), ``/<vehicle>/fix`` (foxglove.LocationFix,
the Map panel), ``/tf`` (foxglove.FrameTransforms: map (ENU) -> ned -> each vehicle -> each
follower's ``<follower>/camera``), ``/scene`` (foxglove.SceneUpdate: vehicles with their
banners, the mission's waypoints and acceptance circles, each follower's commanded slot),
``/log`` (foxglove.Log: STATUSTEXT and lfctl's events), ``/<follower>/camera/video``
(foxglove.CompressedVideo, H.264) or ``/<follower>/camera/image/compressed``
(foxglove.CompressedImage, JPEG), ``/<follower>/camera/calibration``
(foxglove.CameraCalibration), ``/<follower>/camera/annotations`` (foxglove.ImageAnnotations),
and JSON-schema channels ``/<follower>/tracker``, ``/<follower>/pose_estimate``,
``/<follower>/controller``, ``/leader/mission`` and ``/mavlink/<vehicle>``.
"""

from __future__ import annotations

import base64
import contextlib
import datetime as dt
import hashlib
import importlib.metadata
import json
import logging
import math
import platform
import shutil
import socket
import subprocess
import threading
import time
import zipfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import foxglove
import numpy as np
from foxglove import channels as fc
from foxglove import messages as fm
from foxglove.mcap import MCAPCompression, MCAPWriteOptions

from lfctl import __version__
from lfctl.config import Config
from lfctl.data import loaded_code
from lfctl.errors import ConfigError, LfctlError
from lfctl.frames import ned_to_geodetic
from lfctl.vision.camera_model import CameraModel
from lfctl.vision.pose import MarkerPose
from lfctl.vision.track_state import RelativeMeasurement
from lfctl.vision.tracker import TrackState

__all__ = ["EVENT_MODE", "FLUSH_INTERVAL_S", "RecordError", "Recorder", "image_topic", "run_path", "scenario_events"]

#: the recorder ends a chunk and hands it to the OS at least this often (wall time, s), so a
#: run killed outright loses at most about this much of its log
FLUSH_INTERVAL_S = 1.0
#: how many ``-2``, ``-3`` ... suffixes a log name tries before giving up
_MAX_SUFFIX = 1000

WORLD_FRAME = "ned"
#: the 3D panel's fixed frame: east, north, up, so the scene is drawn the right way up
MAP_FRAME = "map"
#: (x, y, z, w) of the ned frame in map: 180 deg about (1, 1, 0) / sqrt 2 swaps x, y and flips z
NED_IN_MAP = (math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0)
#: a /log event that says a vehicle's mode changed starts with this (``mode GUIDED``)
EVENT_MODE = "mode "
#: the 3D scene's topics, each whole in every message (Foxglove's 3D panel, after a seek,
#: draws only the newest message of each topic): the followers' slots (every guidance step),
#: the vehicles with their banners, and the mission
SCENE_TOPIC = "/scene"
VEHICLES_TOPIC = "/scene/vehicles"
MISSION_TOPIC = "/scene/mission"
#: the vehicles and the mission are sent again this often, s, for viewers that join late
SCENE_REPEAT_S = 5.0
#: how long closing waits for the Foxglove server to stop, s
SERVER_STOP_S = 3.0
PACKAGES = (
    "fmpy",
    "numpy",
    "opencv-python-headless",
    "filterpy",
    "mcap",
    "foxglove-sdk",
    "av",
    "pymavlink",
)
#: MAV_SEVERITY 0..7 -> Foxglove log level
SEVERITY_LEVEL = (
    fm.LogLevel.Fatal,
    fm.LogLevel.Fatal,
    fm.LogLevel.Error,
    fm.LogLevel.Error,
    fm.LogLevel.Warning,
    fm.LogLevel.Info,
    fm.LogLevel.Info,
    fm.LogLevel.Debug,
)
LEVELS = {
    "debug": fm.LogLevel.Debug,
    "info": fm.LogLevel.Info,
    "warning": fm.LogLevel.Warning,
    "error": fm.LogLevel.Error,
}
COMPRESSION = {"zstd": MCAPCompression.Zstd, "lz4": MCAPCompression.Lz4, "none": None}

JSON_SCHEMAS: dict[str, dict[str, Any]] = {
    "lfctl.Tracker": {
        "type": "object",
        "properties": {
            "t_s": {"type": "number", "description": "simulation time, s"},
            "state": {"type": "string", "description": "absent: the frame was tracked outside the simulator"},
            "bbox": {"type": "array", "items": {"type": "number"}, "description": "x, y, w, h, px (absent: no window)"},
            "quality": {"type": "number"},
            "distance": {"type": "number"},
            "markers": {
                "type": "array",
                "items": {"type": "object", "properties": {"x": {"type": "number"}, "y": {"type": "number"}}},
                "description": "the four markers' centres, px (absent: not found)",
            },
            "reason": {"type": "string"},
            "truth_bbox": {"type": "array", "items": {"type": "number"}, "description": "absent: not in view"},
            "truth_visible_fraction": {"type": "number"},
        },
    },
    "lfctl.PoseEstimate": {
        "type": "object",
        "properties": {
            "t_s": {"type": "number", "description": "simulation time, s"},
            "method": {"type": "string"},
            "range_m": {"type": "number"},
            "bearing_deg": {"type": "number"},
            "rel_heading_deg": {"type": "number"},
            "truth_range_m": {"type": "number"},
            "truth_bearing_deg": {"type": "number"},
            "truth_rel_heading_deg": {"type": "number"},
        },
    },
    "lfctl.Controller": {
        "type": "object",
        "properties": {
            "t_s": {"type": "number", "description": "simulation time, s"},
            "status": {
                "type": "string",
                "description": "the follower's track state; absent when its companion ran outside the simulator",
            },
            "speed_cmd_mps": {"type": "number"},
            "yaw_rate_cmd_degps": {"type": "number"},
            "range_cmd_m": {"type": "number"},
            "bearing_cmd_deg": {"type": "number"},
            "range_m": {"type": "number", "description": "truth"},
            "bearing_deg": {"type": "number", "description": "truth"},
            "range_error_m": {"type": "number"},
            "bearing_error_deg": {"type": "number"},
            "separation_m": {"type": "number"},
            "path_error_m": {"type": "number", "description": "off the target's path, less the slot's sideways offset"},
            "target": {"type": "string"},
            "law": {"type": "string", "description": "the law that made the command: smc, p or trail"},
        },
    },
    "lfctl.Mission": {
        "type": "object",
        "properties": {
            "t_s": {"type": "number", "description": "simulation time, s"},
            "event": {"type": "string"},
            "index": {"type": "integer"},
            "active": {"type": "integer"},
            "count": {"type": "integer", "description": "items in the mission, home not counted"},
            "waypoints": {"type": "integer", "description": "of them, the waypoints (NAV items)"},
            "mission": {"type": "integer", "description": "which mission: 1 the first stored, counting each change"},
        },
    },
    "lfctl.MavlinkPacket": {
        "type": "object",
        "properties": {
            "t_s": {"type": "number", "description": "simulation time, s"},
            "direction": {"type": "string", "enum": ["in", "out"]},
            "sysid": {"type": "integer"},
            "compid": {"type": "integer"},
            "msgid": {"type": "integer"},
            "name": {"type": "string"},
            "seq": {"type": "integer", "description": "the packet's sequence number"},
            "fields": {
                "type": "object",
                "properties": {},
                "description": "the message's fields as pymavlink names them (which depends on msgid)",
            },
            "raw": {"type": "string", "contentEncoding": "base64"},
            "to": {
                "type": "string",
                "description": "out, to one network peer alone (host:port); absent: to the in-memory link "
                "and to each network peer that takes it (a stream: those keeping no rates of their own)",
            },
        },
    },
}


class RecordError(LfctlError, OSError):
    """The log could not be written or served; the message names the file or address."""


#: the logger the foxglove SDK's MCAP writer reports its failed writes on
FOXGLOVE_LOGGER = "foxglove.log_sink_set"


class _WriteErrors(logging.Filter):
    """The foxglove SDK's MCAP writer reports each message it could not write (after a
    failed write, a full disk say, every one) as a warning on its logger: the first is let
    through and kept (its words say why), the repeats are dropped. One for the process:
    a warning does not say which file it was, so the recorder whose flush then fails says
    it, with these words."""

    def __init__(self) -> None:
        super().__init__()
        self.first: str | None = None

    def filter(self, record: logging.LogRecord) -> bool:
        text = record.getMessage()
        if "error logging message" not in text:
            return True
        seen, self.first = self.first is not None, self.first or text.split(":", 1)[-1].strip()
        return not seen


log = logging.getLogger(__name__)
_WRITE_ERRORS = _WriteErrors()
logging.getLogger(FOXGLOVE_LOGGER).addFilter(_WRITE_ERRORS)


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def git_revision() -> str:
    """The source tree's git revision (with ``-dirty``) when lfctl runs from a checkout (an
    editable install); ``installed`` for a wheel, ``unknown`` when git cannot tell."""
    root = Path(__file__).resolve().parents[2]
    if not (root / "pyproject.toml").is_file() or not (root / "fmu_models").is_dir():
        return "installed"  # site-packages: any git repository around it is not lfctl's
    try:
        rev = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            timeout=5,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=5,
        ).stdout.strip()
        return rev + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def package_versions() -> dict[str, str]:
    out = {}
    for name in PACKAGES:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def run_path(cfg: Config, now: dt.datetime | None = None) -> Path:
    """``<dir>/<UTC time>-<scenario>-<seed>.mcap``: where a run's log goes.

    Parameters
    ----------
    cfg : Config
        The scenario (``[recording] dir``, name, seed).
    now : datetime, optional
        The time in the name (default now, UTC).
    """
    stamp = (now or dt.datetime.now(dt.UTC)).strftime("%Y%m%dT%H%M%SZ")
    return Path(cfg.recording.dir) / f"{stamp}-{cfg.name}-{cfg.sim.seed}.mcap"


def image_topic(follower: str, image_format: str) -> str:
    """The topic a follower's camera frames go to: ``/<follower>/camera/video`` (H.264) or
    ``/<follower>/camera/image/compressed`` (JPEG).

    Parameters
    ----------
    follower : str
        Whose camera.
    image_format : str
        ``h264`` or ``jpeg`` (``[recording] image_format``).
    """
    return f"/{follower}/camera/video" if image_format == "h264" else f"/{follower}/camera/image/compressed"


def scenario_events(cfg: Config) -> list[tuple[float, str]]:
    """The scenario's scheduled events, in time order: occluders crossing and lighting key
    frames (camera sensing), or the truth sensor's dropouts (truth sensing). ``/log`` carries them as they
    happen; ``lfctl audit --plot`` marks them on the error plots.

    Parameters
    ----------
    cfg : Config
        The scenario.
    """
    if cfg.sim.sensing == "camera":
        out = [(o.t_s, f"occluder crosses {o.follower or 'every follower'}") for o in cfg.scene.occluders]
        out += [(k.t_s, f"lighting key: gain {k.gain:g}") for k in cfg.scene.lighting if k.t_s > 0]
    else:
        out = [(a, f"sensor dropout until {b:g} s") for a, b in cfg.sensing.dropouts]
    return sorted(out)


def _quat_yaw(yaw_rad: float) -> fm.Quaternion:
    """A rotation by ``yaw_rad`` about z (NED down: clockwise from above)."""
    return fm.Quaternion(x=0.0, y=0.0, z=math.sin(yaw_rad / 2), w=math.cos(yaw_rad / 2))


def _quat_matrix(R: np.ndarray) -> fm.Quaternion:
    """The unit quaternion of a 3x3 rotation matrix (Shepperd's method: the largest of the
    four candidates keeps it well conditioned)."""
    tr = float(np.trace(R))
    cands = (tr, R[0, 0], R[1, 1], R[2, 2])
    k = int(np.argmax(cands))
    if k == 0:
        s = 2.0 * math.sqrt(1.0 + tr)
        w, x, y, z = s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s
    elif k == 1:
        s = 2.0 * math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        w, x, y, z = (R[2, 1] - R[1, 2]) / s, s / 4, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s
    elif k == 2:
        s = 2.0 * math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])
        w, x, y, z = (R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, s / 4, (R[1, 2] + R[2, 1]) / s
    else:
        s = 2.0 * math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])
        w, x, y, z = (R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, s / 4
    return fm.Quaternion(x=float(x), y=float(y), z=float(z), w=float(w))


def _transform(
    stamp: fm.Timestamp, parent: str, child: str, translation: fm.Vector3, rotation: fm.Quaternion
) -> fm.FrameTransform:
    """``child``'s origin and orientation in ``parent``."""
    return fm.FrameTransform(
        timestamp=stamp, parent_frame_id=parent, child_frame_id=child, translation=translation, rotation=rotation
    )


def _colour(r: float, g: float, b: float, a: float = 1.0) -> fm.Color:
    return fm.Color(r=r, g=g, b=b, a=a)


#: the leader orange, followers in turn blue, green, purple, teal (r, g, b)
PALETTE = ((1.0, 0.55, 0.1), (0.2, 0.45, 0.95), (0.2, 0.7, 0.3), (0.6, 0.35, 0.8), (0.1, 0.65, 0.65))


def _vehicle_colour(index: int, alpha: float = 1.0) -> fm.Color:
    """Vehicle ``index``'s colour (the leader's is 0)."""
    return _colour(*PALETTE[0 if index == 0 else 1 + (index - 1) % (len(PALETTE) - 1)], alpha)


def _pose(north_m: float = 0.0, east_m: float = 0.0, down_m: float = 0.0, yaw_rad: float = 0.0) -> fm.Pose:
    return fm.Pose(position=fm.Vector3(x=north_m, y=east_m, z=down_m), orientation=_quat_yaw(yaw_rad))


class Recorder:
    """Logs one run to an MCAP file, a live Foxglove WebSocket, or both, with one call per
    message. Use as a context manager; closing finishes the file (summary, CRCs) and stops
    the server.

    The metadata and the scenario attachment are written on creation.

    Parameters
    ----------
    path : str or Path or None
        The MCAP file to write (its folder is made if missing; a name taken gets `-2`, `-3` ...:
        :attr:`path` says where it went); None writes no file.
    cfg : Config
        The run's scenario: ``[recording]`` settings, rates and names for the metadata.
    live : (host, port), optional
        Also serve the messages on a Foxglove WebSocket there (port 0: any free port; see
        :attr:`live_port`).
    start_ns : int, optional
        The run's start on the epoch clock, ns: log times are this plus the simulation
        time (default: now).

    Raises
    ------
    RecordError
        The file cannot be created, or the server cannot listen there.
    """

    def __init__(
        self,
        path: str | Path | None,
        cfg: Config,
        *,
        live: tuple[str, int] | None = None,
        start_ns: int | None = None,
    ) -> None:
        self.path = Path(path) if path is not None else None
        self.cfg = cfg
        self.start_ns = time.time_ns() if start_ns is None else start_ns
        self._ctx = foxglove.Context()
        self._mcap: Any = None
        self._server: Any = None
        self._server_ns = -1  # the clock last told to the live view's clients
        self._live: tuple[str, int] | None = None  # where to serve, once serve() is called
        #: told the port once the Foxglove WebSocket takes connections (:meth:`serve`)
        self.on_serve: Callable[[int], None] | None = None
        self._channels: dict[str, Any] = {}
        self._next_image: dict[str, float] = {}  # per follower: when the next image is due, sim s
        self._mounts: dict[str, CameraModel] = {}  # followers whose camera is in /tf
        self._index = {v.name: k for k, v in enumerate(cfg.vehicles)}  # a vehicle's colour, as in the scene
        self._waypoints: list[tuple[float, float]] = []
        self._radius_m = cfg.mission.acceptance_radius_m
        self._scene_at = -math.inf
        self.messages = 0
        self._closed = False
        self._hashes: dict[str, str] = {}
        self._made_dirs: list[Path] = []  # folders made for the log, deepest first (removed with it)
        self._flushed_at = time.monotonic()
        # a failed write (a full disk) makes the MCAP writer refuse every write after it: the
        # next flush says so (within FLUSH_INTERVAL_S), and ends the run (_check_written)
        self._write_error: str | None = None
        _WRITE_ERRORS.first = None  # (the writer's words for a failure before this log's)
        if self.path is not None:
            rec = cfg.recording
            options = MCAPWriteOptions(
                compression=COMPRESSION[rec.compression],
                chunk_size=rec.chunk_size_bytes,
                calculate_chunk_crcs=True,
                calculate_data_section_crc=True,
                calculate_summary_section_crc=True,
                calculate_attachment_crcs=True,
                compression_threads=0,  # compress in the writer's thread: the cores belong to the cameras
            )
            self.path, self._mcap = self._open_new(self.path, options)
        if live is not None:
            host, port = live
            host = host[1:-1] if host.startswith("[") and host.endswith("]") else host  # [::1], as a URL writes it
            try:
                self._live = (host, _free_port(host, port))
            except OSError as exc:
                self._close_file()
                self._remove_file()  # made a moment ago (never over a file), with nothing in it
                raise RecordError(f"cannot serve Foxglove on {host}:{port}: {exc}") from exc
        if self._mcap is not None:
            self._provenance()

    def _open_new(self, path: Path, options: MCAPWriteOptions) -> tuple[Path, Any]:
        """Create the log, never over an existing file: a name taken (two runs in the same
        second) gets ``-2``, ``-3``, ... before the suffix. Returns the path and the writer."""
        self._made_dirs = [q for q in (path.parent, *path.parent.parents) if not q.exists()]
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except (FileExistsError, NotADirectoryError) as exc:  # a file where a folder should be: bad input
            blocker = next((q for q in (path.parent, *path.parent.parents) if q.exists() and not q.is_dir()), None)
            what = (
                str(exc)
                if blocker is None
                else f"{blocker} is {'a file' if blocker.is_file() else 'there'}, not a folder"
            )
            raise ConfigError(f"cannot create the log folder {path.parent} (recording.dir): {what}") from exc
        except OSError as exc:
            raise RecordError(f"cannot create the log folder {path.parent} (recording.dir): {exc}") from exc
        for n in range(1, _MAX_SUFFIX + 1):
            candidate = path if n == 1 else path.with_name(f"{path.stem}-{n}{path.suffix}")
            try:  # created exclusively: a concurrent run cannot take the same name
                writer = foxglove.open_mcap(str(candidate), context=self._ctx, writer_options=options)
            except FileExistsError:
                continue
            except (OSError, RuntimeError) as exc:
                raise RecordError(f"cannot create the run log {candidate}: {exc}") from exc
            return candidate, writer
        raise RecordError(f"cannot create the run log {path}: it and {_MAX_SUFFIX - 1} suffixed names exist")

    def flush(self) -> None:
        """End the chunk in progress and hand everything written so far to the OS."""
        if self._mcap is not None:
            with self._writing():
                self._mcap.flush()
        self._flushed_at = time.monotonic()
        self._check_written()

    @contextlib.contextmanager
    def _writing(self) -> Iterator[None]:
        """A write to the log that may fail: the first failure is kept, with the writer's own
        words for why when it logged them (:meth:`_check_written` says it)."""
        try:
            yield
        except (RuntimeError, OSError) as exc:
            if self._write_error is None:
                why = _WRITE_ERRORS.first
                self._write_error = f"{exc}" + (f" ({why})" if why else "")

    def _written(self) -> None:
        """Count a message; flush when a second of wall time has passed (a killed run loses
        at most about that much)."""
        self.messages += 1
        if time.monotonic() - self._flushed_at >= FLUSH_INTERVAL_S:
            self.flush()

    def _check_written(self) -> None:
        """A write that failed ends the run with an error naming the log and why (the
        writer takes nothing after it): what reached the file before it is recoverable."""
        if self._write_error is None or self.path is None:
            return
        why = self._write_error
        try:
            free = shutil.disk_usage(self.path.parent).free
            why += f"; {free} bytes free on its device"
        except OSError:
            pass
        raise RecordError(
            f"cannot write the run log {self.path}: {why} (`lfctl audit --recover` keeps what was written)"
        )

    @property
    def live_port(self) -> int | None:
        """The Foxglove WebSocket's port (None without ``live``): chosen as the recorder is
        made (a port 0 asked for is a free one then), served from :meth:`serve`."""
        if self._server is not None:
            return int(self._server.port)
        return self._live[1] if self._live is not None else None

    def serve(self) -> None:
        """Start the Foxglove WebSocket (once; nothing without ``live``). Called after a run's
        first step has made its channels: a client that joins while channels are being made
        can be told of one and then refused it ("Unknown channel ID", foxglove-sdk 0.30), and
        its panel stays empty for the run.

        A port another program took since it was checked is said, and the run goes on
        without the live view (its log is unaffected).
        """
        if self._live is None or self._server is not None or self._closed:
            return
        host, port = self._live
        try:
            # it publishes its clock (the log's: a lockstep run's time runs faster than the
            # wall's), which Foxglove then reads messages on; without it Foxglove reads them on
            # the wall clock, and a fast run's bodies drawn at that time fell behind their slots
            self._server = foxglove.start_server(
                name=f"lfctl {self.cfg.name}",
                host=host,
                port=port,
                context=self._ctx,
                capabilities=[foxglove.websocket.Capability.Time],
            )
        except RuntimeError as exc:
            self._live = None
            log.error("cannot serve Foxglove on %s:%d (%s): the run goes on without the live view", host, port, exc)
            return
        if self.on_serve is not None:
            self.on_serve(int(self._server.port))

    def _ns(self, t_s: float) -> int:
        return self.start_ns + int(round(t_s * 1e9))

    def _stamp(self, t_s: float) -> fm.Timestamp:
        ns = self._ns(t_s)
        return fm.Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)

    # -- provenance -----------------------------------------------------------------------
    def _provenance(self) -> None:
        cfg = self.cfg
        self._attach("scenario.toml", "application/toml", cfg.source.encode())
        self._mcap.write_metadata(
            "lfctl",
            {
                "version": __version__,
                "git_revision": git_revision(),
                "code_sha256": loaded_code(),  # which build ran: every wheel is "0.1.0 (installed)"
                "python": platform.python_version(),
                "platform": platform.platform(),
                **{f"package.{k}": v for k, v in package_versions().items()},
            },
        )
        images = cfg.recording.images and cfg.sim.sensing == "camera"
        self._mcap.write_metadata(
            "run",
            {
                "scenario": cfg.name,
                "seed": str(cfg.sim.seed),
                "clock": cfg.sim.clock,
                "dt_s": repr(cfg.sim.dt_s),
                "duration_s": repr(cfg.sim.duration_s),
                "sensing": cfg.sim.sensing,
                "controller": cfg.guidance.controller,
                "vehicles": ",".join(v.name for v in cfg.vehicles),
                "followers": ",".join(v.name for v in cfg.followers),
                # followers whose companion (lfctl follow) ran outside the simulator: it tracked their
                # frames itself, so they have no tracker topics and no track state here
                "companion_outside": ",".join(v.name for v in cfg.followers if not v.companion),
                "telemetry_rate_hz": repr(cfg.sim.telemetry_rate_hz),
                "guidance_rate_hz": repr(cfg.sim.guidance_rate_hz),
                "camera_rate_hz": repr(cfg.sim.camera_rate_hz),
                "images": str(images).lower(),
                "image_format": cfg.recording.image_format,
                "image_rate_hz": repr(min(cfg.recording.image_rate_hz, cfg.sim.camera_rate_hz)),
                "video_bitrate_kbps": str(cfg.recording.video_bitrate_kbps),
                "video_gop": str(cfg.recording.video_gop),
                "waypoints": str(len(cfg.mission.waypoints)),
                "start_time_ns": str(self.start_ns),
            },
        )
        self._mcap.flush()

    def _attach(self, name: str, media_type: str, data: bytes) -> None:
        """An attachment and, right after it, its SHA-256 (both outside chunks, on disk now)."""
        self._mcap.attach(
            log_time=self.start_ns, create_time=self.start_ns, name=name, media_type=media_type, data=data
        )
        self._hashes[name] = sha256(data)
        self._mcap.write_metadata(
            f"sha256:{name}", {"name": name, "sha256": self._hashes[name], "bytes": str(len(data))}
        )
        self._mcap.flush()

    def attach(self, name: str, media_type: str, data: bytes) -> None:
        """Attach a file the run read (before any message; nothing without a file), with
        its SHA-256 for the audit.

        Parameters
        ----------
        name : str
            The attachment's name, e.g. ``mission/survey.plan``.
        media_type : str
            Its media type.
        data : bytes
            Its bytes, as the run read them.
        """
        if self._mcap is None:
            return
        self._attach(name, media_type, data)

    def attach_fmus(self, fmu_paths: list[Path]) -> None:
        """Attach each FMU's modelDescription.xml (before any message; nothing without a file).

        Parameters
        ----------
        fmu_paths : list of Path
            The FMU files the run loaded.
        """
        if self._mcap is None:
            return
        for p in fmu_paths:
            with zipfile.ZipFile(p) as z:
                self._attach(f"{p.name}/modelDescription.xml", "application/xml", z.read("modelDescription.xml"))

    # -- channels --------------------------------------------------------------------------
    def _typed(self, topic: str, kind: Any) -> Any:
        ch = self._channels.get(topic)
        if ch is None:
            ch = self._channels[topic] = kind(topic, context=self._ctx)
        return ch

    def _log(self, topic: str, kind: Any, t_s: float, msg: Any) -> None:
        ns = self._ns(t_s)
        self._tell_time(ns)
        self._typed(topic, kind).log(msg, log_time=ns)
        self._written()

    def _tell_time(self, ns: int) -> None:
        """Tell the live view's clients the log's time, once for each new time, before its
        messages (Foxglove's WebSocket time: the messages' clock)."""
        if self._server is not None and ns > self._server_ns:
            self._server_ns = ns
            self._server.broadcast_time(ns)

    def json(self, topic: str, schema: str, t_s: float, payload: dict[str, Any]) -> None:
        """A JSON message on a JSON-schema channel (made on first use); ``t_s`` is added to it.

        Parameters
        ----------
        topic : str
            The channel's topic.
        schema : str
            One of the ``lfctl.*`` JSON schemas (``lfctl.Tracker``, ``lfctl.Controller``, ...).
        t_s : float
            Simulation time, s.
        payload : dict
            The message; numpy values and bytes (base64) are converted, NaN is refused.
        """
        ch = self._channels.get(topic)
        if ch is None:
            ch = self._channels[topic] = foxglove.Channel(
                topic,
                message_encoding="json",
                schema=foxglove.Schema(
                    name=schema, encoding="jsonschema", data=json.dumps(JSON_SCHEMAS[schema]).encode()
                ),
                context=self._ctx,
            )
        data = _ENCODER.encode({"t_s": round(t_s, 6), **payload})
        ns = self._ns(t_s)
        self._tell_time(ns)
        ch.log(data.encode(), log_time=ns)
        self._written()

    # -- vehicles ----------------------------------------------------------------------------
    def poses(
        self,
        t_s: float,
        names: tuple[str, ...],
        pos_ned_m: np.ndarray,
        yaw_rad: np.ndarray,
        fix: bool | Sequence[tuple[float, float, float] | None] = True,
    ) -> None:
        """``/<vehicle>/pose`` and ``/<vehicle>/fix`` for each vehicle, and one ``/tf``: map ->
        ned -> each vehicle -> each recorded camera.

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        names : tuple of str
            The vehicles, in the order of the arrays.
        pos_ned_m : np.ndarray
            (N, 2) north, east, m.
        yaw_rad : np.ndarray
            (N,) headings, rad.
        fix : bool or sequence
            The LocationFix: True places each vehicle by ``[link]`` home (a local frame whose
            origin is known); False sends none; a sequence gives each vehicle's own global
            position, in the order of ``names``: (latitude deg, longitude deg, altitude m), or
            None for a vehicle that has none (no LocationFix for it).
        """
        stamp = self._stamp(t_s)
        lat0, lon0, alt0 = self.cfg.link.home_lat_deg, self.cfg.link.home_lon_deg, self.cfg.link.home_alt_m
        tfs = [
            _transform(
                stamp,
                MAP_FRAME,
                WORLD_FRAME,
                fm.Vector3(x=0.0, y=0.0, z=0.0),
                fm.Quaternion(x=NED_IN_MAP[0], y=NED_IN_MAP[1], z=NED_IN_MAP[2], w=NED_IN_MAP[3]),
            )
        ]
        for i, name in enumerate(names):
            north, east, yaw = float(pos_ned_m[i, 0]), float(pos_ned_m[i, 1]), float(yaw_rad[i])
            position, orientation = fm.Vector3(x=north, y=east, z=0.0), _quat_yaw(yaw)
            self._log(
                f"/{name}/pose",
                fc.PoseInFrameChannel,
                t_s,
                fm.PoseInFrame(
                    timestamp=stamp, frame_id=WORLD_FRAME, pose=fm.Pose(position=position, orientation=orientation)
                ),
            )
            tfs.append(_transform(stamp, WORLD_FRAME, name, position, orientation))
            geo: tuple[float, float, float] | None
            if isinstance(fix, bool):
                geo = ned_to_geodetic(north, east, 0.0, lat0, lon0, alt0) if fix else None
            else:
                geo = fix[i]
            if geo is None:
                continue
            lat, lon, alt = geo
            self._log(
                f"/{name}/fix",
                fc.LocationFixChannel,
                t_s,
                fm.LocationFix(
                    timestamp=stamp,
                    frame_id=name,
                    latitude=lat,
                    longitude=lon,
                    altitude=alt,
                    heading=yaw % (2 * math.pi),
                    color=_vehicle_colour(self._index.get(name, i)),
                ),
            )
        for follower, cam in self._mounts.items():
            m = cam.mount_body_m
            mount = fm.Vector3(x=float(m[0]), y=float(m[1]), z=float(m[2]))
            tfs.append(_transform(stamp, follower, f"{follower}/camera", mount, _quat_matrix(cam.R_body_from_cam)))
        self._log("/tf", fc.FrameTransformsChannel, t_s, fm.FrameTransforms(transforms=tfs))

    def set_mission(self, t_s: float, waypoints_ned_m: list[tuple[float, float]], radius_m: float) -> None:
        """The leader's mission changed: its waypoints and acceptance circles go to ``/scene``
        now (and with every full scene after).

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        waypoints_ned_m : list of (north, east)
            The waypoints in the local frame, m (home not included).
        radius_m : float
            The acceptance radius, m.
        """
        self._waypoints, self._radius_m = list(waypoints_ned_m), radius_m
        self._scene_at = -math.inf

    def scene(self, t_s: float, slots: dict[str, tuple[float, float, float, float]]) -> None:
        """The 3D scene: each follower's commanded slot now (:data:`SCENE_TOPIC`), and every
        :data:`SCENE_REPEAT_S` (and after a mission change) the vehicles with their banners
        (:data:`VEHICLES_TOPIC`) and the mission (:data:`MISSION_TOPIC`), and each camera's
        calibration again, for viewers that join late. Each topic's message is whole, so the
        newest of each (what Foxglove draws after a seek) shows the whole scene.

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        slots : dict
            Follower -> (slot north, slot east, target north, target east), m: where its
            slot puts it, and its target.
        """
        stamp = self._stamp(t_s)
        entities = []
        for k, (follower, (sn, se, tn, te)) in enumerate(slots.items()):
            ghost = _vehicle_colour(1 + k, 0.45)
            entities.append(
                fm.SceneEntity(
                    timestamp=stamp,
                    frame_id=WORLD_FRAME,
                    id=f"slot/{follower}",
                    spheres=[
                        fm.SpherePrimitive(
                            pose=_pose(sn, se, -0.05), size=fm.Vector3(x=0.12, y=0.12, z=0.12), color=ghost
                        )
                    ],
                    lines=[
                        fm.LinePrimitive(
                            type=fm.LinePrimitiveLineType.LineStrip,
                            pose=_pose(),
                            thickness=2.0,
                            scale_invariant=True,
                            points=[fm.Point3(x=tn, y=te, z=-0.05), fm.Point3(x=sn, y=se, z=-0.05)],
                            color=ghost,
                        )
                    ],
                )
            )
        if t_s - self._scene_at >= SCENE_REPEAT_S:
            self._scene_at = t_s
            vehicles = fm.SceneUpdate(entities=self._vehicle_entities(stamp))
            self._log(VEHICLES_TOPIC, fc.SceneUpdateChannel, t_s, vehicles)
            self._log(MISSION_TOPIC, fc.SceneUpdateChannel, t_s, fm.SceneUpdate(entities=[self._mission_entity(stamp)]))
            for follower, cam in list(self._mounts.items()):
                if t_s > 0:  # the calibration again, for viewers that joined after the start
                    self.calibration(t_s, follower, cam)
        self._log(SCENE_TOPIC, fc.SceneUpdateChannel, t_s, fm.SceneUpdate(entities=entities))

    def _vehicle_entities(self, stamp: fm.Timestamp) -> list[fm.SceneEntity]:
        """Each vehicle as a body with its banner (panel and four markers, or its ArUco tag as
        a black square, its id beside the name) and its name, locked to its own frame (FRD: x
        forward, z down)."""
        b = self.cfg.banner
        tags = self.cfg.tag_ids() if b.kind == "aruco" else None
        out = []
        for i, v in enumerate(self.cfg.vehicles):
            marker = _colour(0.9, 0.1, 0.1)
            h, half = b.centre_height_m, b.side_m / 2
            cubes = [
                fm.CubePrimitive(
                    pose=_pose(0.0, 0.0, -0.07), size=fm.Vector3(x=0.3, y=0.24, z=0.12), color=_vehicle_colour(i)
                ),
                fm.CubePrimitive(
                    pose=_pose(-b.back_m, 0.0, -h),
                    size=fm.Vector3(x=0.01, y=b.panel_size_m, z=b.panel_size_m),
                    color=_colour(0.95, 0.95, 0.92),
                ),
            ]
            if tags is not None:
                cubes.append(
                    fm.CubePrimitive(
                        pose=_pose(-b.back_m - 0.008, 0.0, -h),
                        size=fm.Vector3(x=0.005, y=b.tag_size_m, z=b.tag_size_m),
                        color=_colour(0.05, 0.05, 0.05),
                    )
                )
            else:
                for dy, dz in ((-half, -half), (half, -half), (half, half), (-half, half)):
                    cubes.append(
                        fm.CubePrimitive(
                            pose=_pose(-b.back_m - 0.008, dy, -h + dz),
                            size=fm.Vector3(x=0.005, y=b.marker_size_m, z=b.marker_size_m),
                            color=marker,
                        )
                    )
            out.append(
                fm.SceneEntity(
                    timestamp=stamp,
                    frame_id=v.name,
                    id=f"vehicle/{v.name}",
                    frame_locked=True,
                    cubes=cubes,
                    texts=[
                        fm.TextPrimitive(
                            pose=_pose(0.0, 0.0, -0.45),
                            billboard=True,
                            font_size=14.0,
                            scale_invariant=True,
                            color=_colour(1.0, 1.0, 1.0),
                            text=v.name if tags is None else f"{v.name} (tag {tags[v.name]})",
                        )
                    ],
                )
            )
        return out

    def _mission_entity(self, stamp: fm.Timestamp) -> fm.SceneEntity:
        """The waypoints (numbered spheres), the route through them and each acceptance circle."""
        wps, r = self._waypoints, self._radius_m
        blue = _colour(0.3, 0.8, 1.0)
        circle = [(r * math.cos(a), r * math.sin(a)) for a in np.linspace(0.0, 2 * math.pi, 33)]
        lines = [
            fm.LinePrimitive(
                type=fm.LinePrimitiveLineType.LineLoop,
                pose=_pose(n, e, -0.01),
                thickness=2.0,
                scale_invariant=True,
                points=[fm.Point3(x=dx, y=dy, z=0.0) for dx, dy in circle],
                color=blue,
            )
            for n, e in wps
        ]
        if len(wps) > 1:
            lines.append(
                fm.LinePrimitive(
                    type=fm.LinePrimitiveLineType.LineStrip,
                    pose=_pose(),
                    thickness=1.0,
                    scale_invariant=True,
                    points=[fm.Point3(x=n, y=e, z=-0.01) for n, e in wps],
                    color=_colour(0.3, 0.8, 1.0, 0.5),
                )
            )
        return fm.SceneEntity(
            timestamp=stamp,
            frame_id=WORLD_FRAME,
            id="mission",
            spheres=[
                fm.SpherePrimitive(pose=_pose(n, e, -0.03), size=fm.Vector3(x=0.08, y=0.08, z=0.08), color=blue)
                for n, e in wps
            ],
            lines=lines,
            texts=[
                fm.TextPrimitive(
                    pose=_pose(n, e, -0.2),
                    billboard=True,
                    font_size=12.0,
                    scale_invariant=True,
                    color=blue,
                    text=str(k + 1),
                )
                for k, (n, e) in enumerate(wps)
            ],
        )

    # -- events ------------------------------------------------------------------------------
    def event(self, t_s: float, source: str, text: str, level: str = "info") -> None:
        """One line in ``/log`` (Foxglove's Log panel): lfctl's events, a vehicle's STATUSTEXT.

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        source : str
            Who says it: a vehicle's name, or ``lfctl``.
        text : str
            The line (a mode change starts with :data:`EVENT_MODE`).
        level : str
            ``debug``, ``info``, ``warning`` or ``error``.
        """
        self._log(
            "/log",
            fc.LogChannel,
            t_s,
            fm.Log(timestamp=self._stamp(t_s), level=LEVELS[level], message=text, name=source),
        )

    # -- the camera --------------------------------------------------------------------------
    def calibration(self, t_s: float, follower: str, camera: CameraModel) -> None:
        """A follower's camera calibration (``/<follower>/camera/calibration``); from now on
        its mount is in ``/tf`` too, so the 3D panel can place the camera.

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        follower : str
            Whose camera.
        camera : CameraModel
            Its intrinsics, distortion and mount.
        """
        K, dist = camera.K, camera.dist
        self._mounts[follower] = camera
        cal = fm.CameraCalibration(
            timestamp=self._stamp(t_s),
            frame_id=f"{follower}/camera",
            width=camera.width,
            height=camera.height,
            distortion_model="plumb_bob",
            D=[float(d) for d in dist],  # plumb_bob: k1, k2, p1, p2, k3
            K=[float(v) for v in K.ravel()],
            R=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            P=[float(K[0, 0]), 0.0, float(K[0, 2]), 0.0, 0.0, float(K[1, 1]), float(K[1, 2]), 0.0, 0.0, 0.0, 1.0, 0.0],
        )
        self._log(f"/{follower}/camera/calibration", fc.CameraCalibrationChannel, t_s, cal)

    def image_due(self, t_s: float, follower: str) -> bool:
        """Whether this camera tick's frame is recorded: ``image_rate_hz`` on average, no drift.

        Camera ticks fall on physics steps, so their spacing jitters by a step (30 Hz on a
        100 Hz step is 0.03 or 0.04 s): a tick is taken when it is within half a camera
        period of the schedule, and the schedule advances by whole periods.

        Parameters
        ----------
        t_s : float
            The camera tick's simulation time, s.
        follower : str
            Whose camera (each has its own schedule).
        """
        rec = self.cfg.recording
        if not rec.images:
            return False
        camera_period = 1.0 / self.cfg.sim.camera_rate_hz
        period = max(1.0 / rec.image_rate_hz, camera_period)
        due = self._next_image.get(follower, -math.inf)
        if t_s < due - camera_period / 2:
            return False
        self._next_image[follower] = due + period if t_s - due < period else t_s + period
        return True

    def _image(self, t_s: float, follower: str, image: bytes | None) -> fm.Timestamp:
        """A camera tick's image, if one was encoded; the frame's stamp."""
        stamp = self._stamp(t_s)
        if image is not None:
            frame_id = f"{follower}/camera"
            topic = image_topic(follower, self.cfg.recording.image_format)
            if self.cfg.recording.image_format == "h264":
                self._log(
                    topic,
                    fc.CompressedVideoChannel,
                    t_s,
                    fm.CompressedVideo(timestamp=stamp, frame_id=frame_id, data=image, format="h264"),
                )
            else:
                self._log(
                    topic,
                    fc.CompressedImageChannel,
                    t_s,
                    fm.CompressedImage(timestamp=stamp, frame_id=frame_id, data=image, format="jpeg"),
                )
        return stamp

    def camera(
        self,
        t_s: float,
        follower: str,
        track: TrackState | None,
        pose: MarkerPose | None = None,
        measurement: RelativeMeasurement | None = None,
        truth: Any = None,
        image: bytes | None = None,
        perceived: bool = True,
    ) -> None:
        """One camera tick: the image (H.264 access unit or JPEG, as ``[recording]
        image_format`` says, encoded by the camera when :meth:`image_due` said so) with its
        annotations, the tracker state and the pose against the truth, all stamped with the
        frame's time. A frame that was not ``perceived`` (a rehearsal's follower, whose
        companion tracks its frames outside the simulator) has its image and its truth only.

        Parameters
        ----------
        t_s : float
            The frame's simulation time, s.
        follower : str
            Whose camera.
        track : TrackState or None
            The tracker's result (None before the target was found).
        pose : MarkerPose, optional
            The banner's pose from its markers, when seen.
        measurement : RelativeMeasurement, optional
            What the follower's stack was fed.
        truth : FrameTruth, optional
            What the frame really shows (the renderer's ground truth; none on a real rover).
        image : bytes, optional
            The frame encoded; None records no image this tick.
        perceived : bool
            This process tracked the frame (False: the image and the truth only).
        """
        stamp = self._image(t_s, follower, image)
        payload: dict[str, Any] = {}
        if perceived and image is not None:
            # with its image alone: Foxglove draws the newest annotations over the image shown
            # (or, synchronised, those of its time), so annotations of frames not recorded
            # would put a later frame's window over the picture
            self._log(
                f"/{follower}/camera/annotations",
                fc.ImageAnnotationsChannel,
                t_s,
                _annotations(stamp, track, measurement),
            )
        if perceived:
            # a value that is not there is left out (Foxglove's JSON schemas have no null)
            payload = {
                "state": track.status.value if track else "lost",
                "quality": float(track.quality) if track else 0.0,
                "distance": float(track.distance) if track else 1.0,
                "reason": track.reason if track else "not started",
            }
        if track is not None and track.bbox:
            payload["bbox"] = list(track.bbox)
        if track is not None and track.markers is not None:
            payload["markers"] = [{"x": x, "y": y} for x, y in np.round(track.markers, 2).tolist()]
        if truth is not None:
            if truth.bbox:
                payload["truth_bbox"] = list(truth.bbox)
            payload["truth_visible_fraction"] = round(float(truth.visible_fraction), 4)
        self.json(f"/{follower}/tracker", "lfctl.Tracker", t_s, payload)
        if (
            pose is not None
            and measurement is not None
            and measurement.range_m is not None
            and measurement.bearing_rad is not None
        ):
            est: dict[str, Any] = {
                "method": pose.method,
                "range_m": round(measurement.range_m, 5),
                "bearing_deg": round(math.degrees(measurement.bearing_rad), 4),
                "rel_heading_deg": round(math.degrees(pose.rel_heading_rad), 3),
            }
            if truth is not None:
                est["truth_range_m"] = round(truth.range_m, 5)
                est["truth_bearing_deg"] = round(math.degrees(truth.bearing_rad), 4)
                est["truth_rel_heading_deg"] = round(math.degrees(truth.rel_heading_rad), 3)
            self.json(f"/{follower}/pose_estimate", "lfctl.PoseEstimate", t_s, est)

    # -- guidance, link, mission ----------------------------------------------------------------
    def metadata(self, name: str, values: dict[str, str]) -> None:
        """A metadata record (after the run's start: what the run found, e.g. link statistics).

        Parameters
        ----------
        name : str
            The record's name.
        values : dict of str
            Its key-value pairs.
        """
        if self._mcap is not None and self._write_error is None:  # (after a failed write: none taken)
            with self._writing():
                self._mcap.write_metadata(name, values)
            self._check_written()

    def controller(self, t_s: float, follower: str, payload: dict[str, Any]) -> None:
        """One guidance step of a follower (``/<follower>/controller``).

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        follower : str
            Whose step.
        payload : dict
            The ``lfctl.Controller`` fields: status, commands, slot, truth and errors (no
            status from a follower whose companion runs outside: its commands are what
            reached the vehicle).
        """
        self.json(f"/{follower}/controller", "lfctl.Controller", t_s, payload)

    def mavlink(self, t_s: float, vehicle: str, packet: dict[str, Any]) -> None:
        """One MAVLink packet in or out of a vehicle's endpoint (``/mavlink/<vehicle>``); a
        STATUSTEXT also goes to ``/log``.

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        vehicle : str
            Whose endpoint.
        packet : dict
            As :func:`~lfctl.link.endpoint.packet_record` makes it.
        """
        self.json(f"/mavlink/{vehicle}", "lfctl.MavlinkPacket", t_s, packet)
        if packet["name"] == "STATUSTEXT":
            fields = packet["fields"]
            sev = int(fields.get("severity", 6))
            src = vehicle if packet["direction"] == "out" else f"{vehicle} <- {packet['sysid']}/{packet['compid']}"
            self._log(
                "/log",
                fc.LogChannel,
                t_s,
                fm.Log(
                    timestamp=self._stamp(t_s),
                    level=SEVERITY_LEVEL[max(0, min(7, sev))],
                    message=str(fields.get("text", "")),
                    name=src,
                ),
            )

    def mission_reached(
        self, t_s: float, index: int, active: int, count: int, waypoints: int, mission: int = 1
    ) -> None:
        """The leader reached a waypoint (``/leader/mission``, and a line in ``/log``).

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        index : int
            The waypoint reached, from 0.
        active : int
            The mission item now current.
        count : int
            Items in the mission (home not counted).
        waypoints : int
            Of them, the waypoints (NAV items): what "N/M waypoints reached" counts against.
        mission : int
            Which mission it is (1 the first stored, counting each replacement or clear).
        """
        self.json(
            "/leader/mission",
            "lfctl.Mission",
            t_s,
            {
                "event": "reached",
                "index": index,
                "active": active,
                "count": count,
                "waypoints": waypoints,
                "mission": mission,
            },
        )
        self.event(t_s, self.cfg.vehicles[0].name, f"reached mission item {index + 1}/{count}")

    def mission_stored(self, t_s: float, waypoints: int, mission: int) -> None:
        """The leader's mission was stored: replaced, or cleared (``/leader/mission``).

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        waypoints : int
            Its waypoints (NAV items; 0 when cleared).
        mission : int
            Its number (1 the first stored).
        """
        self.json(
            "/leader/mission", "lfctl.Mission", t_s, {"event": "stored", "waypoints": waypoints, "mission": mission}
        )

    # -- the end ---------------------------------------------------------------------------------
    def _close_file(self) -> None:
        mcap, self._mcap = self._mcap, None
        if mcap is None:
            return
        with self._writing():
            mcap.close()

    def close(self, reason: str = "completed", t_s: float | None = None) -> None:
        """Finish the file (why the run ended: metadata ``end``; summary, indexes, footer) and
        stop the server.

        Parameters
        ----------
        reason : str
            ``completed``, ``interrupted`` or ``error: ...``.
        t_s : float, optional
            The simulation time it ended at, s.
        """
        if self._closed:
            return
        self._closed = True
        try:
            if self._mcap is not None and self._write_error is None:
                end = {"reason": reason} | ({"t_s": repr(t_s)} if t_s is not None else {})
                with self._writing():
                    self._mcap.write_metadata("end", end)
            self._close_file()
        finally:
            self._stop_server()
        self._check_written()  # a log that could not be finished is an error, said once

    def discard(self) -> None:
        """Close and delete the file (a run that never started has nothing to keep)."""
        if not self._closed:
            self._closed = True
            self._close_file()
            self._stop_server()
        self._remove_file()

    def _remove_file(self) -> None:
        """Delete the log of a run that never started, and the folders made for it that
        are still empty (a refused start leaves no empty ``logs/`` behind)."""
        if self.path is None:
            return
        self.path.unlink(missing_ok=True)
        for folder in self._made_dirs:  # (each tried: in a/../b, a/.. is no folder to remove, a is)
            with contextlib.suppress(OSError):  # not empty (another run's log went there meanwhile), or gone
                folder.rmdir()

    def _stop_server(self) -> None:
        """Stop the Foxglove WebSocket, waiting at most :data:`SERVER_STOP_S`: foxglove-sdk's
        stop waits for each client to take its close, which a client that stopped reading (a
        laptop asleep, a half-open Wi-Fi link) never does, and the run never ended, Ctrl-C
        and SIGTERM included. Past the wait the server is left to the process's exit, said."""
        server, self._server = self._server, None
        if server is None:
            return
        done = threading.Thread(target=server.stop, name="foxglove-stop", daemon=True)
        done.start()
        done.join(SERVER_STOP_S)
        if done.is_alive():
            log.warning(
                "the Foxglove server did not stop within %g s (a client that stopped reading holds it): "
                "left to end with the process",
                SERVER_STOP_S,
            )

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close("completed" if exc[0] is None else f"error: {exc[0].__name__}")  # type: ignore[union-attr]


def _annotations(
    stamp: fm.Timestamp, track: TrackState | None, measurement: RelativeMeasurement | None
) -> fm.ImageAnnotations:
    """The tracked window (green tracking, orange coasting), the markers (magenta) and a line
    of state, each stamped with the frame's time.

    Foxglove's image coordinates have their origin at the top-left corner of the top-left
    pixel: pixel (i, j) covers [i, i+1] x [j, j+1]. The window is a box of whole pixels whose
    x..x+w spans its pixels' edges in those coordinates, as it is. The markers (blob
    centroids, or an ArUco tag's corners) are sub-pixel points in OpenCV's convention, pixel
    (i, j) centred at (i, j): they get half a pixel. The line of state is only placed.
    """
    points, texts = [], []
    label = "not started"
    if track is not None:
        label = f"{track.status.value}  q {track.quality:.2f}"
        if track.bbox is not None:
            x, y, w, h = track.bbox
            tracking = track.status.value == "tracking"
            points.append(
                fm.PointsAnnotation(
                    timestamp=stamp,
                    type=fm.PointsAnnotationType.LineLoop,
                    points=[
                        fm.Point2(x=float(px), y=float(py))
                        for px, py in ((x, y), (x + w, y), (x + w, y + h), (x, y + h))
                    ],
                    outline_color=_colour(0.1, 0.8, 0.1) if tracking else _colour(1.0, 0.65, 0.0),
                    thickness=2.0,
                )
            )
        if track.markers is not None:
            points.append(
                fm.PointsAnnotation(
                    timestamp=stamp,
                    type=fm.PointsAnnotationType.Points,
                    points=[fm.Point2(x=float(u) + 0.5, y=float(v) + 0.5) for u, v in track.markers],
                    outline_color=_colour(1.0, 0.0, 1.0),
                    thickness=6.0,
                )
            )
    if measurement is not None and measurement.range_m is not None and measurement.bearing_rad is not None:
        label += f"  range {measurement.range_m:.2f} m  bearing {math.degrees(measurement.bearing_rad):+.1f} deg"
    texts.append(
        fm.TextAnnotation(
            timestamp=stamp,
            position=fm.Point2(x=8.0, y=24.0),
            text=label,
            font_size=16.0,
            text_color=_colour(1.0, 1.0, 1.0),
            background_color=_colour(0.0, 0.0, 0.0, 0.5),
        )
    )
    return fm.ImageAnnotations(timestamp=stamp, points=points, texts=texts)


def _jsonable(value: Any) -> Any:
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, bytes):
        return base64.b64encode(value).decode()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


#: the JSON messages' encoder, made once: ``json.dumps`` with any option builds a new
#: JSONEncoder per call (a few microseconds each, for thousands of MAVLink packets a minute);
#: the same options, so the same text
_ENCODER = json.JSONEncoder(separators=(",", ":"), allow_nan=False, default=_jsonable)


def _free_port(host: str, port: int) -> int:
    """``port`` if a server may listen there on ``host`` now, else OSError; for 0, a free one
    (the WebSocket starts later, at :meth:`Recorder.serve`)."""
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server binds: past TIME_WAIT
        s.bind((host, port))
        s.listen(1)
        return int(s.getsockname()[1])
