"""The run recorder: one MCAP file per run, Foxglove schemas where one fits.

Written first, so a crash cannot lose them: metadata (lfctl version and git revision,
package versions, the run's scenario, seed, clock, dt) and attachments (the scenario TOML,
each FMU's modelDescription.xml) with their SHA-256 in the metadata. Then messages, in
zstd (or lz4) chunks of about 1 MiB with chunk and data-section CRCs, ``log_time`` = the
simulation time in ns.

Topics: ``/<vehicle>/pose`` (foxglove.PoseInFrame), ``/tf`` (foxglove.FrameTransform),
``/<follower>/camera/image/compressed`` (foxglove.CompressedImage, JPEG),
``/<follower>/camera/calibration`` (foxglove.CameraCalibration),
``/<follower>/camera/annotations`` (foxglove.ImageAnnotations), and JSON-schema channels
``/<follower>/tracker``, ``/<follower>/pose_estimate``, ``/<follower>/controller``,
``/leader/mission`` and ``/mavlink/<link>``.
"""

from __future__ import annotations

import base64
import datetime as dt
import hashlib
import importlib.metadata
import json
import math
import platform
import subprocess
import time
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.ImageAnnotations_pb2 import ImageAnnotations
from foxglove_schemas_protobuf.PointsAnnotation_pb2 import PointsAnnotation
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from mcap.writer import CompressionType, Writer
from mcap_protobuf.schema import build_file_descriptor_set

from lfctl import __version__
from lfctl.config import Config
from lfctl.errors import LfctlError

__all__ = ["FLUSH_INTERVAL_S", "RecordError", "Recorder", "run_path"]

#: the recorder ends a chunk and hands it to the OS at least this often (wall time, s), so a
#: run killed outright loses at most about this much of its log
FLUSH_INTERVAL_S = 1.0
#: how many ``-2``, ``-3`` ... suffixes a log name tries before giving up
_MAX_SUFFIX = 1000

WORLD_FRAME = "ned"
PACKAGES = (
    "fmpy",
    "numpy",
    "opencv-python-headless",
    "filterpy",
    "mcap",
    "mcap-protobuf-support",
    "foxglove-schemas-protobuf",
    "pymavlink",
    "protobuf",
)

JSON_SCHEMAS: dict[str, dict[str, Any]] = {
    "lfctl.Tracker": {
        "type": "object",
        "properties": {
            "state": {"type": "string"},
            "bbox": {"type": ["array", "null"], "items": {"type": "integer"}},
            "quality": {"type": "number"},
            "distance": {"type": "number"},
            "markers": {"type": ["array", "null"]},
            "reason": {"type": "string"},
            "truth_bbox": {"type": ["array", "null"]},
            "truth_visible_fraction": {"type": "number"},
        },
    },
    "lfctl.PoseEstimate": {
        "type": "object",
        "properties": {
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
            "status": {"type": "string"},
            "speed_cmd_mps": {"type": "number"},
            "yaw_rate_cmd_degps": {"type": "number"},
            "range_cmd_m": {"type": "number"},
            "bearing_cmd_deg": {"type": "number"},
            "range_m": {"type": "number", "description": "truth"},
            "bearing_deg": {"type": "number", "description": "truth"},
            "range_error_m": {"type": "number"},
            "bearing_error_deg": {"type": "number"},
            "separation_m": {"type": "number"},
            "target": {"type": "string"},
        },
    },
    "lfctl.Mission": {
        "type": "object",
        "properties": {
            "event": {"type": "string"},
            "index": {"type": "integer"},
            "active": {"type": "integer"},
            "count": {"type": "integer"},
        },
    },
    "lfctl.MavlinkPacket": {
        "type": "object",
        "properties": {
            "direction": {"type": "string", "enum": ["in", "out"]},
            "sysid": {"type": "integer"},
            "compid": {"type": "integer"},
            "msgid": {"type": "integer"},
            "name": {"type": "string"},
            "fields": {"type": "object"},
            "raw": {"type": "string", "contentEncoding": "base64"},
        },
    },
}


class RecordError(LfctlError, OSError):
    """The log could not be written; the message names the file."""


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


def _create_new(path: Path) -> tuple[Path, Any]:
    """Create ``path`` for writing, never over an existing file: a name taken (two runs in
    the same second) gets ``-2``, ``-3``, ... before the suffix. Returns the path and the file."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RecordError(f"cannot create the log folder {path.parent}: {exc}") from exc
    for n in range(1, _MAX_SUFFIX + 1):
        candidate = path if n == 1 else path.with_name(f"{path.stem}-{n}{path.suffix}")
        try:
            return candidate, candidate.open("xb")  # exclusive: a concurrent run cannot take it too
        except FileExistsError:
            continue
        except OSError as exc:
            raise RecordError(f"cannot create the run log {candidate}: {exc}") from exc
    raise RecordError(f"cannot create the run log {path}: it and {_MAX_SUFFIX - 1} suffixed names exist")


def run_path(cfg: Config, now: dt.datetime | None = None) -> Path:
    """``<dir>/<UTC time>-<scenario>-<seed>.mcap``: where a run's log goes (the recorder adds
    ``-2``, ``-3`` ... when that file exists).

    Parameters
    ----------
    cfg : Config
        The scenario (``[recording] dir``, name, seed).
    now : datetime, optional
        The time in the name (default now, UTC).
    """
    stamp = (now or dt.datetime.now(dt.UTC)).strftime("%Y%m%dT%H%M%SZ")
    return Path(cfg.recording.dir) / f"{stamp}-{cfg.name}-{cfg.sim.seed}.mcap"


def _quat_yaw(yaw_rad: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by ``yaw_rad`` about z (NED down: clockwise from above)."""
    return 0.0, 0.0, math.sin(yaw_rad / 2), math.cos(yaw_rad / 2)


def _ts(msg_time: Any, t_ns: int) -> None:
    msg_time.seconds = t_ns // 1_000_000_000
    msg_time.nanos = t_ns % 1_000_000_000


class Recorder:
    """Writes one run. Use as a context manager; closing finishes the file (summary, CRCs).

    The metadata and the scenario attachment are written on creation.

    Parameters
    ----------
    path : str or Path
        The MCAP file to write (its folder is made if missing).
    cfg : Config
        The run's scenario: ``[recording]`` settings, rates and names for the metadata.

    Raises
    ------
    RecordError
        The file cannot be created.
    """

    def __init__(self, path: str | Path, cfg: Config) -> None:
        self.cfg = cfg
        self.path, self._f = _create_new(Path(path))
        comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}[
            cfg.recording.compression
        ]
        self._w = Writer(
            self._f,
            chunk_size=cfg.recording.chunk_size_bytes,
            compression=comp,
            enable_crcs=True,
            enable_data_crcs=True,
        )
        self._w.start(profile="", library=f"lfctl {__version__}")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._seq: dict[int, int] = {}
        self._next_image: dict[str, float] = {}  # per follower: when the next image is due, sim s
        self.messages = 0
        self.bytes_payload = 0
        self._closed = False
        self._hashes: dict[str, str] = {}
        self._attach("scenario.toml", "application/toml", cfg.source.encode())
        self._w.add_metadata(
            "lfctl",
            {
                "version": __version__,
                "git_revision": git_revision(),
                "python": platform.python_version(),
                "platform": platform.platform(),
                **{f"package.{k}": v for k, v in package_versions().items()},
            },
        )
        self._flushed_at = time.monotonic()
        self._w.add_metadata(
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
                "telemetry_rate_hz": repr(cfg.sim.telemetry_rate_hz),
                "guidance_rate_hz": repr(cfg.sim.guidance_rate_hz),
                "camera_rate_hz": repr(cfg.sim.camera_rate_hz),
                "images": str(cfg.recording.images and cfg.sim.sensing == "camera").lower(),
                "image_rate_hz": repr(min(cfg.recording.image_rate_hz, cfg.sim.camera_rate_hz)),
                "waypoints": str(len(cfg.mission.waypoints)),
            },
        )
        self._f.flush()

    # -- provenance -----------------------------------------------------------------------
    def _attach(self, name: str, media_type: str, data: bytes) -> None:
        """An attachment and, right after it, its SHA-256 (both outside chunks, on disk now)."""
        self._w.add_attachment(create_time=0, log_time=0, name=name, media_type=media_type, data=data)
        self._hashes[name] = sha256(data)
        self._w.add_metadata(f"sha256:{name}", {"name": name, "sha256": self._hashes[name], "bytes": str(len(data))})
        self._f.flush()

    def attach_fmus(self, fmu_paths: list[Path]) -> None:
        """Attach each FMU's modelDescription.xml (before any message).

        Parameters
        ----------
        fmu_paths : list of Path
            The FMU files the run loaded.
        """
        for p in fmu_paths:
            with zipfile.ZipFile(p) as z:
                self._attach(f"{p.name}/modelDescription.xml", "application/xml", z.read("modelDescription.xml"))

    # -- channels --------------------------------------------------------------------------
    def _proto_channel(self, topic: str, message_type: Any) -> int:
        if topic in self._channels:
            return self._channels[topic]
        name = message_type.DESCRIPTOR.full_name
        if name not in self._schemas:
            self._schemas[name] = self._w.register_schema(
                name, "protobuf", build_file_descriptor_set(message_type).SerializeToString()
            )
        cid = self._w.register_channel(topic, "protobuf", self._schemas[name])
        self._channels[topic] = cid
        return cid

    def _json_channel(self, topic: str, schema_name: str) -> int:
        if topic in self._channels:
            return self._channels[topic]
        if schema_name not in self._schemas:
            self._schemas[schema_name] = self._w.register_schema(
                schema_name, "jsonschema", json.dumps(JSON_SCHEMAS[schema_name]).encode()
            )
        cid = self._w.register_channel(topic, "json", self._schemas[schema_name])
        self._channels[topic] = cid
        return cid

    def _write(self, cid: int, t_s: float, data: bytes) -> None:
        t_ns = int(round(t_s * 1e9))
        seq = self._seq.get(cid, 0)
        self._seq[cid] = seq + 1
        self._w.add_message(channel_id=cid, log_time=t_ns, data=data, publish_time=t_ns, sequence=seq)
        self.messages += 1
        self.bytes_payload += len(data)
        now = time.monotonic()
        if now - self._flushed_at >= FLUSH_INTERVAL_S:  # a killed run loses at most this much
            self.flush()

    def flush(self) -> None:
        """End the chunk in progress and hand everything written so far to the OS."""
        self._w.flush()
        self._flushed_at = time.monotonic()

    def json(self, topic: str, schema: str, t_s: float, payload: dict[str, Any]) -> None:
        """A JSON message on a JSON-schema channel (made on first use).

        Parameters
        ----------
        topic : str
            The channel's topic.
        schema : str
            One of the ``lfctl.*`` JSON schemas (``lfctl.Tracker``, ``lfctl.Controller``, ...).
        t_s : float
            Simulation time, s (the message's log time).
        payload : dict
            The message; numpy values and bytes (base64) are converted, NaN is refused.
        """
        self._write(
            self._json_channel(topic, schema),
            t_s,
            json.dumps(payload, separators=(",", ":"), allow_nan=False, default=_jsonable).encode(),
        )

    # -- topics ----------------------------------------------------------------------------
    def poses(self, t_s: float, names: tuple[str, ...], pos_ned_m: np.ndarray, yaw_rad: np.ndarray) -> None:
        """``/<vehicle>/pose`` for each vehicle and one ``/tf`` per vehicle (ned -> vehicle).

        Parameters
        ----------
        t_s : float
            Simulation time, s (the message's log time).
        names : tuple of str
            The vehicles, in the order of the arrays.
        pos_ned_m : np.ndarray
            (N, 2) north, east, m.
        yaw_rad : np.ndarray
            (N,) headings, rad.
        """
        t_ns = int(round(t_s * 1e9))
        for i, name in enumerate(names):
            qx, qy, qz, qw = _quat_yaw(float(yaw_rad[i]))
            pose = PoseInFrame(frame_id=WORLD_FRAME)
            _ts(pose.timestamp, t_ns)
            pose.pose.position.x, pose.pose.position.y = float(pos_ned_m[i, 0]), float(pos_ned_m[i, 1])
            pose.pose.orientation.x, pose.pose.orientation.y, pose.pose.orientation.z, pose.pose.orientation.w = (
                qx,
                qy,
                qz,
                qw,
            )
            self._write(self._proto_channel(f"/{name}/pose", PoseInFrame), t_s, pose.SerializeToString())
            tf = FrameTransform(parent_frame_id=WORLD_FRAME, child_frame_id=name)
            _ts(tf.timestamp, t_ns)
            tf.translation.x, tf.translation.y = float(pos_ned_m[i, 0]), float(pos_ned_m[i, 1])
            tf.rotation.x, tf.rotation.y, tf.rotation.z, tf.rotation.w = qx, qy, qz, qw
            self._write(self._proto_channel("/tf", FrameTransform), t_s, tf.SerializeToString())

    def calibration(self, t_s: float, follower: str, K: np.ndarray, dist: np.ndarray, width: int, height: int) -> None:
        """A follower's camera calibration (``/<follower>/camera/calibration``).

        Parameters
        ----------
        t_s : float
            Simulation time, s (the message's log time).
        follower : str
            Whose camera.
        K : np.ndarray
            3x3 intrinsic matrix, pixels.
        dist : np.ndarray
            OpenCV distortion coefficients k1, k2, p1, p2.
        width, height : int
            Image size, pixels.
        """
        cal = CameraCalibration(frame_id=f"{follower}/camera", width=width, height=height, distortion_model="plumb_bob")
        _ts(cal.timestamp, int(round(t_s * 1e9)))
        cal.D.extend([float(dist[0]), float(dist[1]), float(dist[2]), float(dist[3]), 0.0])
        cal.K.extend([float(v) for v in K.ravel()])
        cal.R.extend([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0])
        cal.P.extend(
            [float(K[0, 0]), 0.0, float(K[0, 2]), 0.0, 0.0, float(K[1, 1]), float(K[1, 2]), 0.0, 0.0, 0.0, 1.0, 0.0]
        )
        self._write(
            self._proto_channel(f"/{follower}/camera/calibration", CameraCalibration), t_s, cal.SerializeToString()
        )

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

    def camera(self, t_s: float, follower: str, sample: Any, jpeg: bytes | None = None) -> None:
        """One camera tick: the image (``jpeg``, encoded by the camera when :meth:`image_due`
        said so), annotations, tracker state, pose vs truth.

        Parameters
        ----------
        t_s : float
            Simulation time, s (the message's log time).
        follower : str
            Whose camera.
        sample : CameraSample
            The tick's track, pose, measurement and truth (see
            :class:`~lfctl.sim.camera_sensor.CameraSample`).
        jpeg : bytes, optional
            The frame as JPEG; None records no image this tick.
        """
        t_ns = int(round(t_s * 1e9))
        if jpeg is not None:
            img = CompressedImage(frame_id=f"{follower}/camera", format="jpeg", data=jpeg)
            _ts(img.timestamp, t_ns)
            self._write(
                self._proto_channel(f"/{follower}/camera/image/compressed", CompressedImage),
                t_s,
                img.SerializeToString(),
            )
        track, truth = sample.track, sample.truth
        ann = ImageAnnotations()
        if track is not None and track.bbox is not None:
            x, y, w, h = track.bbox
            box = PointsAnnotation(type=PointsAnnotation.Type.LINE_LOOP, thickness=2)
            _ts(box.timestamp, t_ns)
            for px, py in ((x, y), (x + w, y), (x + w, y + h), (x, y + h)):
                p = box.points.add()
                p.x, p.y = float(px), float(py)
            colour = (0.1, 0.8, 0.1) if track.status.value == "tracking" else (1.0, 0.65, 0.0)
            box.outline_color.r, box.outline_color.g, box.outline_color.b, box.outline_color.a = (*colour, 1.0)
            ann.points.append(box)
        if track is not None and track.markers is not None:
            pts = PointsAnnotation(type=PointsAnnotation.Type.POINTS, thickness=6)
            _ts(pts.timestamp, t_ns)
            for u, v in track.markers:
                p = pts.points.add()
                p.x, p.y = float(u), float(v)
            pts.outline_color.r, pts.outline_color.b, pts.outline_color.a = 1.0, 1.0, 1.0
            ann.points.append(pts)
        self._write(
            self._proto_channel(f"/{follower}/camera/annotations", ImageAnnotations), t_s, ann.SerializeToString()
        )
        self.json(
            f"/{follower}/tracker",
            "lfctl.Tracker",
            t_s,
            {
                "state": track.status.value if track else "lost",
                "bbox": list(track.bbox) if track and track.bbox else None,
                "quality": float(track.quality) if track else 0.0,
                "distance": float(track.distance) if track else 1.0,
                "markers": np.round(track.markers, 2).tolist()
                if track is not None and track.markers is not None
                else None,
                "reason": track.reason if track else "not started",
                "truth_bbox": list(truth.bbox) if truth.bbox else None,
                "truth_visible_fraction": round(float(truth.visible_fraction), 4),
            },
        )
        meas = sample.measurement
        if sample.pose is not None and meas.range_m is not None and meas.bearing_rad is not None:
            self.json(
                f"/{follower}/pose_estimate",
                "lfctl.PoseEstimate",
                t_s,
                {
                    "method": sample.pose.method,
                    "range_m": round(meas.range_m, 5),
                    "bearing_deg": round(math.degrees(meas.bearing_rad), 4),
                    "rel_heading_deg": round(math.degrees(sample.pose.rel_heading_rad), 3),
                    "truth_range_m": round(truth.range_m, 5),
                    "truth_bearing_deg": round(math.degrees(truth.bearing_rad), 4),
                    "truth_rel_heading_deg": round(math.degrees(truth.rel_heading_rad), 3),
                },
            )

    def metadata(self, name: str, values: dict[str, str]) -> None:
        """A metadata record (after the run's start: what the run found, e.g. link statistics).

        Parameters
        ----------
        name : str
            The record's name.
        values : dict of str
            Its key-value pairs.
        """
        self._w.add_metadata(name, values)

    def controller(self, t_s: float, follower: str, payload: dict[str, Any]) -> None:
        """One guidance step of a follower (``/<follower>/controller``).

        Parameters
        ----------
        t_s : float
            Simulation time, s (the message's log time).
        follower : str
            Whose step.
        payload : dict
            The ``lfctl.Controller`` fields: status, commands, slot, truth and errors.
        """
        self.json(f"/{follower}/controller", "lfctl.Controller", t_s, payload)

    def mavlink(self, t_s: float, vehicle: str, packet: dict[str, Any]) -> None:
        """One MAVLink packet in or out of a vehicle's endpoint (``/mavlink/<vehicle>``).

        Parameters
        ----------
        t_s : float
            Simulation time, s (the message's log time).
        vehicle : str
            Whose endpoint.
        packet : dict
            As :func:`~lfctl.link.endpoint.packet_record` makes it.
        """
        self.json(f"/mavlink/{vehicle}", "lfctl.MavlinkPacket", t_s, packet)

    def mission_reached(self, t_s: float, index: int, active: int, count: int) -> None:
        """The leader reached a waypoint (``/leader/mission``).

        Parameters
        ----------
        t_s : float
            Simulation time, s (the message's log time).
        index : int
            The waypoint reached, from 0.
        active : int
            The mission item now current.
        count : int
            Waypoints in the mission (home not counted).
        """
        self.json(
            "/leader/mission",
            "lfctl.Mission",
            t_s,
            {"event": "reached", "index": index, "active": active, "count": count},
        )

    def close(self, reason: str = "completed", t_s: float | None = None) -> None:
        """Finish the file: why the run ended (metadata ``end``), summary, indexes, footer.

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
            end = {"reason": reason} | ({"t_s": repr(t_s)} if t_s is not None else {})
            self._w.add_metadata("end", end)
            self._w.finish()
        finally:
            self._f.close()

    def discard(self) -> None:
        """Close and delete the file (a run that never started has nothing to keep)."""
        if not self._closed:
            self._closed = True
            self._f.close()
        self.path.unlink(missing_ok=True)

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close("completed" if exc[0] is None else f"error: {exc[0].__name__}")  # type: ignore[union-attr]


def _jsonable(value: Any) -> Any:
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, bytes):
        return base64.b64encode(value).decode()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
