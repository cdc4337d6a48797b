"""`lfctl audit`: integrity, provenance and content of a run's MCAP log.

Integrity: :mod:`lfctl.record.mcap_read` reads every record within fixed limits (memory and
time stay bounded whatever the file holds), checks the chunk, data-section and summary CRCs,
and reports each fault with the byte offset of the record it is in: bad magic, a flipped
bit, a file cut short (after SIGKILL). Everything read before a fault is still audited, and
``recover`` writes it to a new, complete file. Provenance checks the metadata (the run, why
it ended) and the attachments' SHA-256. Content recomputes formation, tracking, pose,
mission and link figures from the recorded topics; every value read from the file is
checked for its type and range first, and a bad one is a finding, never an exception.
docs/audit.md lists the limits and what each finding means.
"""

from __future__ import annotations

import hashlib
import heapq
import itertools
import json
import math
import re
from collections import Counter, defaultdict
from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mcap.writer import CompressionType, Writer

from lfctl.checks import printable, write_whole
from lfctl.errors import ConfigError
from lfctl.metrics import SETTLE_S, formation_metrics, track_episodes
from lfctl.record.mcap_read import (
    Contents,
    Finding,
    MessageStore,
    ReadLimits,
    read_contents,
    regular_file_problem,
)
from lfctl.record.writer import image_topic
from lfctl.vision.track_state import TrackStatus

__all__ = [
    "AuditReport",
    "Contents",
    "Finding",
    "ack_latencies",
    "audit",
    "check_thresholds",
    "format_report",
    "heard_by_sender",
    "lost_by_sequence",
    "mavlink_packets",
    "plot",
    "recover",
]

#: a rate in the run metadata must lie in (0, this], Hz
MAX_RATE_HZ = 1e6
#: numbers in a JSON message must lie within +-this (finite); larger is damage
MAX_JSON_NUMBER = 1e12
#: vehicle names as the scenario allows them (and as file names of plots)
NAME = re.compile(r"[A-Za-z0-9_-]{1,64}")


@dataclass
class AuditReport:
    """What :func:`audit` found in one file."""

    path: str  # the file audited
    findings: list[Finding]  # integrity and provenance problems, in the order found
    contents: Contents  # everything read from it
    #: the recomputed figures (sizes, run metadata, formation, mission, links, topics), as
    #: :func:`format_report` prints them and ``lfctl audit --json`` writes them
    figures: dict[str, Any]

    @property
    def ok(self) -> bool:
        """No finding is an error."""
        return not any(f.level == "error" for f in self.findings)


# -- JSON messages, checked field by field --------------------------------------------------------
def _num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and -MAX_JSON_NUMBER <= v <= MAX_JSON_NUMBER


def _positive(v: Any) -> bool:
    return _num(v) and v > 0


def _int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and -(2**63) <= v < 2**64


def _index(v: Any) -> bool:
    return _int(v) and 0 <= v < 2**31


def _byte(v: Any) -> bool:
    return _int(v) and 0 <= v <= 255


def _text(v: Any) -> bool:
    return isinstance(v, str) and len(v) <= 256 and v.isprintable()


def _status(v: Any) -> bool:
    return isinstance(v, str) and v in _STATUSES


def _direction(v: Any) -> bool:
    return v in ("in", "out") and isinstance(v, str)


def _box(v: Any) -> bool:
    return v is None or (isinstance(v, list) and len(v) == 4 and all(_num(x) for x in v))


def _mav_fields(v: Any) -> bool:
    return isinstance(v, dict) and all(k not in v or _int(v[k]) for k in _MAV_ADDRESSING)


#: the packet fields the link figures read (commands matched to their acks by these)
_MAV_ADDRESSING = ("command", "target_system", "target_component")


_STATUSES = frozenset(s.value for s in TrackStatus)
_Check = Callable[[Any], bool]
#: what each checker wants, for the finding
_WANTS: dict[_Check, str] = {
    _num: f"a finite number within +-{MAX_JSON_NUMBER:g}",
    _positive: "a positive number",
    _int: "an integer",
    _index: "a non-negative integer",
    _byte: "an integer 0..255",
    _text: "printable text",
    _status: f"one of {sorted(_STATUSES)}",
    _direction: "'in' or 'out'",
    _box: "null or [x, y, w, h]",
    _mav_fields: "an object (with integer 'command', 'target_system', 'target_component', if any)",
}
#: field -> (check, required), for each JSON topic lfctl writes
_CONTROLLER = {
    "status": (_status, True),
    "range_cmd_m": (_num, True),
    "bearing_cmd_deg": (_num, False),
    "range_error_m": (_num, True),
    "bearing_error_deg": (_num, True),
    "separation_m": (_num, True),
    "path_error_m": (_num, False),
    "yaw_rate_cmd_degps": (_num, True),
    "target": (_text, False),
    "law": (_text, False),
}
_POSE_ESTIMATE = {
    "range_m": (_num, True),
    "bearing_deg": (_num, True),
    "truth_range_m": (_positive, True),
    "truth_bearing_deg": (_num, True),
}
#: "reached" events carry an index; "stored" ones (a mission replaced or cleared) do not
_MISSION = {"event": (_text, True), "index": (_index, False), "waypoints": (_index, False), "mission": (_index, False)}
_MAVLINK = {
    "direction": (_direction, True),
    "sysid": (_int, True),
    "compid": (_int, True),
    "name": (_text, True),
    "seq": (_byte, False),
    "fields": (_mav_fields, True),
    "to": (_text, False),
}
_TRACKER = {"bbox": (_box, False), "truth_bbox": (_box, False), "truth_visible_fraction": (_num, False)}
#: a follower whose companion ran outside the run (run metadata ``companion_outside``): no
#: track state of the simulator's in its steps
_CONTROLLER_OUTSIDE = {**_CONTROLLER, "status": (_status, False)}


def _spec(topic: str, outside: Collection[str] = ()) -> tuple[str, dict[str, tuple[_Check, bool]]] | None:
    """The JSON schema name and field checks of a topic (None: not a JSON topic the audit reads);
    ``outside``: the followers whose companion ran outside the run."""
    if topic.startswith("/mavlink/"):
        return "lfctl.MavlinkPacket", _MAVLINK
    if topic == "/leader/mission":
        return "lfctl.Mission", _MISSION
    for suffix, name, spec in (
        ("/controller", "lfctl.Controller", _CONTROLLER),
        ("/pose_estimate", "lfctl.PoseEstimate", _POSE_ESTIMATE),
        ("/tracker", "lfctl.Tracker", _TRACKER),
    ):
        if topic.endswith(suffix) and topic.count("/") == 2:
            if spec is _CONTROLLER and topic.split("/")[1] in outside:
                return name, _CONTROLLER_OUTSIDE
            return name, spec
    return None


def _outside(c: Contents) -> list[str]:
    """The followers the run metadata names in ``companion_outside`` (valid names only)."""
    return _names(c.metadata.get("run", {}), "companion_outside", [])


def _check_json(data: bytes, spec: dict[str, tuple[_Check, bool]]) -> dict[str, Any] | str:
    """The message as a dict when it is a JSON object whose fields pass ``spec``; else why not."""
    try:
        m = json.loads(data)
    except RecursionError:
        return "JSON nested too deeply"
    except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError, too many digits
        return f"not JSON ({type(exc).__name__}: {str(exc)[:80]})"
    if not isinstance(m, dict):
        return f"a JSON {type(m).__name__}, not an object"
    for name, (check, required) in spec.items():
        if name not in m:
            if required:
                return f"no field {name!r}"
        elif not check(m[name]):
            return f"field {name!r} is {_short(m[name])}, not {_WANTS[check]}"
    return m


def _short(v: Any) -> str:
    text = repr(v)
    return text if len(text) <= 40 else text[:37] + "..."


def _decoded(c: Contents, topic: str) -> tuple[list[tuple[float, dict[str, Any]]], list[tuple[int, float, str]]]:
    """The messages of a JSON topic that pass its checks, as (t in s, dict), and the others
    as (index, t in s, why); computed once per topic."""
    if topic not in c.decoded:
        good: list[tuple[float, dict[str, Any]]] = []
        bad: list[tuple[int, float, str]] = []
        spec = _spec(topic, _outside(c))
        slim = topic.startswith("/mavlink/")
        for i, (t, d) in enumerate(c.messages.get(topic, [])):
            m = _check_json(d, spec[1]) if spec else _check_json(d, {})
            if slim and isinstance(m, dict) and "to" in m and m["direction"] != "out":
                m = "'to' (the peer a packet went to alone) on a packet that came in"
            if isinstance(m, str):
                bad.append((i, c.sim_s(t), m))
            else:
                good.append((c.sim_s(t), _slim_packet(m) if slim else m))
        c.decoded[topic] = (good, bad)
    return c.decoded[topic]


#: the fields of a MAVLink packet the audit reads (commands, acks, mission acks); the rest of
#: each packet's fields are not kept: a long run logs millions of packets
PACKET_FIELDS = ("command", "target_system", "target_component", "type", "mission_type", "result")


def _slim_packet(m: dict[str, Any]) -> dict[str, Any]:
    """A decoded ``/mavlink/*`` packet with only what the audit reads: its header, the peer
    it went to alone (if it did) and :data:`PACKET_FIELDS` (about a third of the memory of
    the whole packet)."""
    fields = m["fields"]
    kept = {k: fields[k] for k in PACKET_FIELDS if k in fields}
    out = {"direction": m["direction"], "sysid": m["sysid"], "compid": m["compid"], "name": m["name"], "fields": kept}
    for key in ("seq", "to"):
        if key in m:
            out[key] = m[key]
    return out


def _json_messages(c: Contents, topic: str) -> list[tuple[float, dict[str, Any]]]:
    """(t in s, message) of each message on ``topic`` that is valid (see ``_spec``)."""
    return _decoded(c, topic)[0]


def _bad_json_findings(c: Contents) -> list[Finding]:
    out = []
    outside = _outside(c)
    for topic in sorted(c.messages):
        spec = _spec(topic, outside)
        if spec is None:
            continue
        bad = _decoded(c, topic)[1]
        if bad:
            i, t, why = bad[0]
            msgs = c.messages[topic]
            at = msgs.offset(i) if hasattr(msgs, "offset") else None
            out.append(
                Finding(
                    "error",
                    f"{len(bad)} of {len(msgs)} messages on {topic} are not valid {spec[0]} "
                    f"(first: message {i} at t = {t:.3f} s: {why}); figures leave them out",
                    at,
                    "content",
                )
            )
    return out


def _protobuf_class(schema: Any) -> Any:
    """The message class a protobuf channel's schema describes, built from the schema's own
    FileDescriptorSet in the file (so a file is read as it was written, whatever schema
    package is installed); None when the schema data does not describe its message."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
    from google.protobuf.message import DecodeError

    try:
        files = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
        pool = descriptor_pool.DescriptorPool()
        for f in files.file:
            pool.Add(f)
        return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name))
    except (DecodeError, KeyError, TypeError, ValueError, RuntimeError):
        return None


def _bad_protobuf_findings(c: Contents) -> list[Finding]:
    """Messages on a protobuf channel that do not decode as the schema the file gives it,
    carry fields the schema does not have (garbage often parses as unknown fields), or lack
    the timestamp a schema with one always has in a log (an empty payload parses as an empty
    message). A schema whose data does not describe its message is not checked."""
    from google.protobuf.message import DecodeError
    from google.protobuf.unknown_fields import UnknownFieldSet

    out = []
    for ch_id, ch in sorted(c.channels.items(), key=lambda kv: kv[1].topic):
        schema = c.schemas.get(ch.schema_id)
        if ch.message_encoding != "protobuf" or schema is None:
            continue
        cls = _protobuf_class(schema)
        msgs = c.by_channel.get(ch_id)
        if cls is None or not msgs:
            continue
        bad: list[tuple[int, float, str]] = []
        stamped = "timestamp" in cls.DESCRIPTOR.fields_by_name
        for i, (t, data) in enumerate(msgs):
            try:
                m = cls.FromString(data)
                why = "fields its schema does not have" if len(UnknownFieldSet(m)) else None
                if why is None and stamped and not m.HasField("timestamp"):
                    why = "no timestamp"  # (an empty payload parses as an empty message)
            except (DecodeError, RuntimeError, ValueError) as exc:
                why = f"does not decode ({exc})"
            if why is not None:
                bad.append((i, c.sim_s(t), why))
        if bad:
            i, t, why = bad[0]
            out.append(
                Finding(
                    "error",
                    f"{len(bad)} of {len(msgs)} messages on {ch.topic} are not valid {schema.name} "
                    f"(first: message {i} at t = {t:.3f} s: {why}); figures leave them out",
                    msgs.offset(i) if hasattr(msgs, "offset") else None,
                    "content",
                )
            )
    return out


# -- the run metadata --------------------------------------------------------------------------------
@dataclass
class _Run:
    """The run metadata, checked: bad values are replaced by the defaults and listed."""

    telemetry_s: float = 0.1  # periods, s
    guidance_s: float = 0.05
    camera_s: float = 1 / 30
    image_s: float = 1 / 30
    vehicles: list[str] = field(default_factory=list)
    followers: list[str] = field(default_factory=list)
    outside: list[str] = field(default_factory=list)  # of them, those whose companion ran outside the run
    camera: bool = False
    images: bool = False
    image_format: str = "jpeg"  # "h264" or "jpeg": which image topic the followers have
    waypoints: int = 0
    problems: list[str] = field(default_factory=list)


def _names(run: dict[str, str], key: str, problems: list[str]) -> list[str]:
    out = []
    for name in filter(None, run.get(key, "").split(",")):
        if NAME.fullmatch(name):
            out.append(name)
        else:
            problems.append(f"{key} names {name!r} (a vehicle name is letters, digits, '-' or '_')")
    return out


def _period(run: dict[str, str], key: str, default_hz: float, problems: list[str]) -> float:
    raw = run.get(key)
    if raw is None:
        return 1.0 / default_hz
    try:
        hz = float(raw)
    except ValueError:
        hz = math.nan
    if not 0 < hz <= MAX_RATE_HZ:  # NaN fails too
        problems.append(f"{key} = {raw!r} (a rate in (0, {MAX_RATE_HZ:g}] Hz)")
        return 1.0 / default_hz
    return 1.0 / hz


#: the run metadata's numbers (MCAP metadata holds text), as :func:`run_values` types them
RUN_INTEGERS = ("seed", "video_bitrate_kbps", "video_gop", "waypoints")
RUN_FLOATS = ("dt_s", "duration_s", "telemetry_rate_hz", "guidance_rate_hz", "camera_rate_hz", "image_rate_hz")
_INTEGER = re.compile(r"-?[0-9]{1,18}")
_DECIMAL = re.compile(r"-?[0-9]{1,18}(\.[0-9]*)?([eE][-+]?[0-9]{1,3})?")


def run_values(run: dict[str, str]) -> dict[str, object]:
    """The run metadata with its numbers as numbers and ``images`` as a boolean, for a
    machine-readable report (a value that does not read as its type stays the text it is:
    the audit's findings name it).

    Parameters
    ----------
    run : dict of str to str
        The log's ``run`` metadata.
    """
    out: dict[str, object] = dict(run)
    for key, kind, form in [(k, int, _INTEGER) for k in RUN_INTEGERS] + [(k, float, _DECIMAL) for k in RUN_FLOATS]:
        text = run.get(key)
        if isinstance(text, str) and form.fullmatch(text):  # as the recorder writes them: no "7_0", no "+7"
            out[key] = kind(text)
    if run.get("images") in ("true", "false"):
        out["images"] = run["images"] == "true"
    return out


def _parse_run(run: dict[str, str]) -> _Run:
    r = _Run()
    p = r.problems
    r.telemetry_s = _period(run, "telemetry_rate_hz", 10.0, p)
    r.guidance_s = _period(run, "guidance_rate_hz", 20.0, p)
    r.camera_s = _period(run, "camera_rate_hz", 30.0, p)
    r.image_s = _period(run, "image_rate_hz", 30.0, p)
    r.vehicles = _names(run, "vehicles", p)
    r.followers = _names(run, "followers", p)
    r.outside = _names(run, "companion_outside", p)
    r.camera = run.get("sensing") == "camera"
    r.images = run.get("images") == "true"
    fmt = run.get("image_format", "jpeg")
    if fmt in ("h264", "jpeg"):
        r.image_format = fmt
    else:
        p.append(f"image_format = {fmt!r} ('h264' or 'jpeg')")
    raw = run.get("waypoints", "0") or "0"
    if raw.isdigit() and len(raw) <= 6:
        r.waypoints = int(raw)
    else:
        p.append(f"waypoints = {raw!r} (a count)")
    return r


def audit(path: str | Path, limits: ReadLimits | None = None) -> AuditReport:
    """Audit a log file; never raises for a bad file (the findings say what is wrong).

    Parameters
    ----------
    path : str or Path
        An MCAP log written by :class:`~lfctl.record.writer.Recorder` (or a damaged one). A
        path that is not a regular file (a FIFO, a directory, a device) is a finding; it is
        not opened for reading.
    limits : ReadLimits, optional
        What the reading refuses (default :mod:`lfctl.record.mcap_read`'s constants).
    """
    p = Path(path)
    c, findings = read_contents(p, limits)
    counted = {ch_id: c.counts.get(ch_id, 0) for ch_id in c.channels}
    figures: dict[str, Any] = {
        "file_bytes": c.file_size,
        "bytes_read": c.bytes_read,
        "messages": sum(c.counts.values()),
    }
    if not c.footer and not any(f.level == "error" for f in findings):  # never "OK" without a footer
        findings.append(Finding("error", "no footer: the file was not finished", c.bytes_read, "truncated"))
    if not c.channels and not c.metadata and findings:
        return AuditReport(str(p), findings, c, figures)
    recovered = "recovery" in c.metadata
    # -- integrity: counts against the statistics, expected topics, gaps --------------------
    if c.statistics is not None:
        total = sum(c.counts.values())
        if c.statistics.message_count != total:
            findings.append(
                Finding(
                    "error",
                    f"statistics say {c.statistics.message_count} messages, the file holds {total} readable ones",
                    kind="corrupt",
                )
            )
        for ch_id, n in sorted(c.statistics.channel_message_counts.items()):
            ch = c.channels.get(ch_id)
            if ch is None:
                findings.append(
                    Finding(
                        "error",
                        f"statistics count {n} messages on channel {ch_id}, which is not defined",
                        kind="corrupt",
                    )
                )
            elif counted.get(ch_id, 0) != n:
                findings.append(
                    Finding(
                        "error",
                        f"statistics say {n} messages on {ch.topic}, the file holds {counted.get(ch_id, 0)} readable ones",
                        kind="corrupt",
                    )
                )
    run = c.metadata.get("run", {})
    if not run:
        findings.append(Finding("error", "metadata 'run' missing (scenario, seed, clock)", kind="provenance"))
    if "lfctl" not in c.metadata:
        findings.append(
            Finding("error", "metadata 'lfctl' missing (version, git revision, packages)", kind="provenance")
        )
    info = _parse_run(run)
    if info.problems:
        findings.append(
            Finding(
                "error",
                "metadata 'run' has bad values: " + "; ".join(info.problems) + " (figures use the defaults)",
                kind="provenance",
            )
        )
    lacking = []
    for topic, period in _expected_topics(info).items():
        msgs = c.messages.get(topic)
        if not msgs:
            if recovered:  # a recovered log holds what was read before the fault
                lacking.append(topic)
            else:
                level = "error" if c.footer else "warning"
                findings.append(Finding(level, f"expected topic {topic} is missing", kind="content"))
            continue
        times = _sim_times(c, msgs)
        gaps = np.diff(times)
        big = gaps > 3 * period + 1e-6
        if big.any():
            i = int(np.argmax(gaps))
            findings.append(
                Finding(
                    "warning",
                    f"{topic}: {int(big.sum())} gaps longer than 3x its {period * 1000:.0f} ms period (longest {gaps[i]:.3f} s at t={times[i]:.2f} s)",
                    kind="content",
                )
            )
    if lacking:
        findings.append(
            Finding("warning", f"the recovered log has no messages on {', '.join(lacking)}", kind="recovery")
        )
    findings += _outside_the_run(c)
    findings.extend(_bad_json_findings(c))
    findings.extend(_bad_protobuf_findings(c))
    # -- provenance -------------------------------------------------------------------------
    hashes = {m.get("name", ""): m.get("sha256", "") for k, m in c.metadata.items() if k.startswith("sha256:")}
    for name, data in c.attachments.items():
        want = hashes.get(name)
        got = hashlib.sha256(data).hexdigest()
        if want is None:
            findings.append(Finding("warning", f"attachment {name!r} has no recorded SHA-256", kind="provenance"))
        elif want != got:
            findings.append(
                Finding(
                    "error",
                    f"attachment {name!r}: SHA-256 {got[:12]}... does not match the recorded {want[:12]}...",
                    kind="provenance",
                )
            )
    for name in sorted(set(hashes) - set(c.attachments)):
        if c.footer:
            findings.append(
                Finding("error", f"attachment {name!r} is missing (its SHA-256 is recorded)", kind="provenance")
            )
    figures["attachments"] = sorted(c.attachments)
    figures["provenance"] = {
        k: v
        for k, v in c.metadata.get("lfctl", {}).items()
        if k in ("version", "git_revision", "code_sha256", "python")
    }
    figures["run"] = run
    end = c.metadata.get("end")
    figures["end"] = end
    findings.extend(_end_findings(c, end, recovered))
    # -- content ----------------------------------------------------------------------------
    figures["followers"] = _formation_figures(c, info)
    figures.update(_mission_figures(_json_messages(c, "/leader/mission"), info.waypoints))
    link = _link_figures(c, info.vehicles[0] if info.vehicles else "leader")
    figures["links"], figures["link_senders"] = link["links"], link["senders"]
    figures["mission_changes_s"] = link["mission_changes_s"]
    figures["topics"] = {
        ch.topic: counted[ch_id] for ch_id, ch in sorted(c.channels.items(), key=lambda kv: kv[1].topic)
    }
    return AuditReport(str(p), findings, c, figures)


def _end_findings(c: Contents, end: dict[str, str] | None, recovered: bool) -> list[Finding]:
    """Why the run ended (metadata ``end``): an error ends it abnormally, an interruption early."""
    if recovered:
        r = c.metadata["recovery"]
        return [
            Finding(
                "warning",
                f"recovered by lfctl audit from {r.get('source', '?')} ({r.get('bytes_read', '?')} of "
                f"{r.get('file_bytes', '?')} bytes read); the original's findings: {r.get('findings', '')}",
                kind="recovery",
            )
        ]
    if end is None:
        if c.footer:  # finished by something other than the Recorder (without a footer: an error already)
            return [Finding("warning", "no 'end' metadata: the log does not say why the run ended", kind="run")]
        return []
    reason = end.get("reason", "")
    if reason == "completed":
        return []
    if reason.startswith("error"):
        return [Finding("error", f"the run ended abnormally{_at(end)}: {reason}", kind="run")]
    return [Finding("warning", f"the run ended early{_at(end)}: {reason or '(no reason given)'}", kind="run")]


def _sim_times(c: Contents, msgs: Any) -> np.ndarray:
    """A topic's messages' log times as simulation time, s (as :meth:`Contents.sim_s`)."""
    times = np.frombuffer(msgs.log_times, np.uint64) if isinstance(msgs, MessageStore) else None
    times = (times if times is not None else np.array([t for t, _ in msgs], np.uint64)).astype(float)
    return (times - float(c.start_ns)) / 1e9


#: how far a message's log time may lie before the run's start or after its end, s (a
#: message logged as the run ends, the clock's own rounding)
OUTSIDE_SLACK_S = 5.0


def _outside_the_run(c: Contents) -> list[Finding]:
    """Messages whose log times lie outside the run: before its start (``run.start_time_ns``)
    or after its end (metadata ``end``'s ``t_s``), by more than :data:`OUTSIDE_SLACK_S`. A
    foreign file's wall-clock times against a start of 0, or one stray time, are named per
    topic, not taken as the run's length."""
    try:
        end_s = float(c.metadata.get("end", {}).get("t_s", "nan"))
    except (TypeError, ValueError):
        end_s = math.nan
    top = end_s + OUTSIDE_SLACK_S if math.isfinite(end_s) else math.inf
    out = []
    for topic, msgs in sorted(c.messages.items()):
        times = _sim_times(c, msgs)
        bad = (times < -OUTSIDE_SLACK_S) | (times > top)
        if bad.any():
            span = "its start" if not math.isfinite(top) else f"0 .. {end_s:.2f} s"
            out.append(
                Finding(
                    "error",
                    f"{topic}: {int(bad.sum())} of {len(times)} messages logged outside the run "
                    f"(t = {times[bad].min():.6g} .. {times[bad].max():.6g} s against {span}, "
                    f"run.start_time_ns {c.start_ns})",
                    kind="content",
                )
            )
    return out


def _expected_topics(run: _Run) -> dict[str, float]:
    """Topic -> expected period (s) from the checked run metadata."""
    out: dict[str, float] = {}
    if not run.vehicles and not run.followers:
        return out
    for v in run.vehicles:
        out[f"/{v}/pose"] = run.telemetry_s
    out["/tf"] = run.telemetry_s
    for f in run.followers:
        out[f"/{f}/controller"] = run.guidance_s
        if run.camera:
            out[f"/{f}/tracker"] = run.camera_s  # (only the truth, for one whose companion ran outside)
            if run.images:
                out[image_topic(f, run.image_format)] = run.image_s
                if f not in run.outside:  # (that one tracked its frames there)
                    out[f"/{f}/camera/annotations"] = run.image_s  # (with each image)
    return out


def _code(provenance: dict[str, str]) -> str:
    """``; code 9b865979ab12`` (the start of the code's SHA-256, which tells two builds of one
    version apart) from the ``lfctl`` metadata ("" for a log without it, or with a bad one)."""
    digest = provenance.get("code_sha256", "")
    return f"; code {digest[:12]}" if re.fullmatch(r"[0-9a-f]{64}", digest) else ""


def _at(end: dict[str, str]) -> str:
    """`` at t = 12.34 s`` from an ``end`` metadata record ("" when it has no usable time)."""
    try:
        t = float(end.get("t_s", ""))
    except ValueError:
        return ""
    if not math.isfinite(t):
        return ""
    return f" at t = {t:.2f} s" if abs(t) < 1e9 else f" at t = {t:.6g} s (not a run's time)"


def _rounded(value: float | None, digits: int, scale: float = 1.0) -> float | None:
    return None if value is None else round(value * scale, digits)


def _followers(c: Contents) -> list[str]:
    """The followers the run metadata names (valid names only)."""
    return _parse_run(c.metadata.get("run", {})).followers


def _formation_figures(c: Contents, run: _Run) -> list[dict[str, Any]]:
    out = []
    step_s = run.guidance_s
    deg = math.degrees(1.0)
    for f in run.followers:
        msgs = _json_messages(c, f"/{f}/controller")
        if not msgs:
            continue
        t = [m[0] for m in msgs]
        status = [m[1].get("status") for m in msgs]
        first = msgs[0][1]
        m = formation_metrics(
            f,
            first.get("target", ""),
            first["range_cmd_m"],
            math.radians(first.get("bearing_cmd_deg", 0.0)),
            t,
            [x[1]["range_error_m"] for x in msgs],
            [math.radians(x[1]["bearing_error_deg"]) for x in msgs],
            [x[1]["separation_m"] for x in msgs],
            status,
            [math.radians(x[1]["yaw_rate_cmd_degps"]) for x in msgs],
            step_s,
            # a log from before the path error was recorded has none
            path_err_m=[x[1]["path_error_m"] for x in msgs] if all("path_error_m" in x[1] for x in msgs) else None,
        )
        fig: dict[str, Any] = {
            "follower": f,
            "target": m.target,
            "range_cmd_m": m.range_cmd_m,
            "range_err_rms_m": _rounded(m.range_err_rms_m, 4),
            "range_err_max_m": _rounded(m.range_err_max_m, 4),
            "bearing_err_rms_deg": _rounded(m.bearing_err_rms_rad, 3, deg),
            "bearing_err_max_deg": _rounded(m.bearing_err_max_rad, 3, deg),
            "min_separation_m": _rounded(m.min_separation_m, 3),
            "time_in_state_s": {k: _rounded(v, 2) for k, v in m.time_in_state_s.items()},
            "control_effort_rad": round(m.control_effort_rad, 4),
            "chattering_per_s": round(m.chattering_per_s, 4),
            "path_err_rms_m": _rounded(m.path_err_rms_m, 4),
            "path_err_max_m": _rounded(m.path_err_max_m, 4),
            "occlusion_episodes": None  # (its track state was the outside companion's)
            if None in status
            else [
                {
                    "start_s": round(e.start_s, 2),
                    "duration_s": round(e.duration_s, 2),
                    "recovered": e.recovered,
                    "worst": e.worst,
                }
                for e in track_episodes(t, status, step_s)
            ],
        }
        every = [m for _, m in _json_messages(c, f"/{f}/pose_estimate")]
        poses = [m for m in every if m["truth_range_m"] <= POSE_RANGE_M]
        fig["pose_samples"] = [len(poses), len(every)]  # within POSE_RANGE_M, all
        if poses:
            pr = np.array([(m["range_m"] - m["truth_range_m"]) / m["truth_range_m"] for m in poses])
            pb = np.array([m["bearing_deg"] - m["truth_bearing_deg"] for m in poses])
            fig["pose_range_err_rms_pct"] = round(float(np.sqrt(np.mean(pr**2)) * 100), 3)
            fig["pose_bearing_err_rms_deg"] = round(float(np.sqrt(np.mean(pb**2))), 3)
        out.append(fig)
    return out


#: the pose errors count the poses of a target at most this far (the truth's range), m: the
#: banner's markers are a few pixels each beyond it, and the figures are those of the range
#: the pose is made for; the report says how many poses that leaves out
POSE_RANGE_M = 3.0

#: a sender silent this long, then heard again, started a new session (a new process,
#: a reconnect): its sequence restarts, which is not loss
SESSION_GAP_S = 2.5
#: a sender's sequence jumping this far (mod 256) restarted: a new process, not 128+ packets lost
RESTART_JUMP = 128
COMMANDS = ("COMMAND_LONG", "COMMAND_INT")
#: the most unanswered commands an ack is looked for among (the oldest are given up)
MAX_UNANSWERED = 1024


def mavlink_packets(c: Contents) -> dict[str, list[tuple[float, dict[str, Any]]]]:
    """Every ``/mavlink/<vehicle>`` topic's packets, decoded: (simulation time, packet), each
    packet with its header and only the fields the audit reads (:data:`PACKET_FIELDS`).

    Parameters
    ----------
    c : Contents
        What was read from the log.
    """
    return {t: _json_messages(c, t) for t in sorted(c.messages) if t.startswith("/mavlink/")}


def ack_latencies(packets: list[tuple[float, dict[str, Any]]]) -> tuple[int, list[tuple[float, float]]]:
    """Commands to one vehicle and their acks: (commands, [(ack time, latency s)]).

    The vehicle is the system its own packets (``out``) come from; a command counts when it is
    addressed to it (or to every system): one for another vehicle that reached its port is
    not its to answer. An ack is matched to the newest unanswered command of the same number
    that it answers (MAVLink's command protocol has one command of a kind in flight from a
    sender: older ones are tries that got no answer, sent again): sent by the system and
    component the ack is addressed to (an ack without that address: by anyone), and addressed
    to the ack's sender (or to every component). The autopilot's acks are logged ``out``; a
    component's reached through the port (a camera, ``lfctl follow``'s companion) ``in``, as
    the command it answers; one ack sent to several peers (recorded once for each) is paired
    once.

    Parameters
    ----------
    packets : list of (t_s, packet)
        One link's packets in log order.
    """
    own = Counter(m["sysid"] for _, m in packets if m["direction"] == "out").most_common(1)
    sysid = own[0][0] if own else None
    # unanswered commands: (t_s, sender system, sender component, target system, target component, number)
    pending: list[tuple[float, int, int, int, int, Any]] = []
    out = []
    commands = 0
    last_ack: tuple[Any, ...] = ()
    for t, m in packets:
        fields = m.get("fields", {})
        if m["name"] in COMMANDS:
            target = fields.get("target_system", 0)
            if sysid is None or target in (0, sysid):
                commands += 1
                pending.append(
                    (t, m["sysid"], m["compid"], target, fields.get("target_component", 0), fields.get("command"))
                )
                del pending[:-MAX_UNANSWERED]
        elif m["name"] == "COMMAND_ACK":
            to_sys, to_comp = fields.get("target_system", 0), fields.get("target_component", 0)
            # one ack sent to each peer its addressee was heard on is recorded once a peer:
            # the copies answer one command
            key = (t, m["sysid"], m["compid"], to_sys, to_comp, fields.get("command"), fields.get("result"))
            if key == last_ack:
                continue
            last_ack = key
            for i in range(len(pending) - 1, -1, -1):
                t0, src_sys, src_comp, tgt_sys, tgt_comp, command = pending[i]
                if (
                    command == fields.get("command")
                    and to_sys in (0, src_sys)
                    and to_comp in (0, src_comp)
                    and tgt_sys in (0, m["sysid"])
                    and tgt_comp in (0, m["compid"])
                ):
                    out.append((t, t - t0))
                    del pending[i]
                    break
    return commands, out


def heard_by_sender(links: dict[str, list[tuple[float, dict[str, Any]]]]) -> dict[str, list[tuple[float, int]]]:
    """Every packet the run's endpoints heard, by sender (``sysid/compid``): (t_s, seq) in
    time order, over all links (a ground station's one counter serves every vehicle).

    Parameters
    ----------
    links : dict
        As :func:`mavlink_packets` gives them.
    """
    heard: dict[str, list[tuple[float, int]]] = defaultdict(list)
    for packets in links.values():
        for t, m in packets:
            if m["direction"] == "in" and "seq" in m:
                heard[f"{m['sysid']}/{m['compid']}"].append((t, m["seq"]))
    # by time only: packets of one tick keep the order they were heard in (a sort on the
    # sequence number too would put 0 before 255 where the counter wraps)
    return {k: sorted(v, key=lambda x: x[0]) for k, v in sorted(heard.items())}


def lost_by_sequence(got: list[tuple[float, int]]) -> list[int]:
    """Packets lost before each packet of one sender, cumulative: the gaps in its sequence
    numbers. A repeated number is a duplicate. A sender that started afresh (a new process,
    a reconnect: its counter restarts) is not loss: after :data:`SESSION_GAP_S` of silence,
    or a jump of half the counter or more (:data:`RESTART_JUMP`; that many packets lost in
    a row without a pause does not happen on a live link).

    Parameters
    ----------
    got : list of (t_s, seq)
        One sender's packets in time order.
    """
    lost = [0] * min(1, len(got))
    for (ta, a), (tb, b) in itertools.pairwise(got):
        gap = (b - a - 1) % 256
        lost.append(lost[-1] + (gap if b != a and gap < RESTART_JUMP and tb - ta < SESSION_GAP_S else 0))
    return lost


def _mission_figures(events: list[tuple[float, dict[str, Any]]], scenario_waypoints: int) -> dict[str, Any]:
    """The leader's mission progress, counted as `lfctl sim` counts it: every arrival in
    order (``mission``), and the distinct waypoints reached of the mission last reached in
    against its size (``waypoints_reached`` / ``waypoints``). With nothing reached, the size
    is the mission stored last (a log from before missions were numbered: the scenario's)."""
    reached = [(t, m) for t, m in events if m.get("event") == "reached" and "index" in m]
    stored = [m for _t, m in events if m.get("event") == "stored"]
    out: dict[str, Any] = {"mission": [{"index": m["index"] + 1, "t_s": round(t, 2)} for t, m in reached]}
    if reached:
        last = reached[-1][1]
        same = [m for _t, m in reached if m.get("mission") == last.get("mission")]  # all, in old logs
        out["waypoints_reached"] = len({m["index"] for m in same})
        out["waypoints"] = last.get("waypoints", scenario_waypoints)
    else:
        out["waypoints_reached"] = 0
        out["waypoints"] = stored[-1].get("waypoints", scenario_waypoints) if stored else scenario_waypoints
    return out


def _link_figures(c: Contents, leader: str) -> dict[str, Any]:
    """Per link: packets each way, message rates, commands and their acks (latency on the
    log's clock); per sender: loss by its own sequence numbers over every link; when a client
    replaced or cleared the leader's mission after the start (its accepted MISSION_ACKs)."""
    links: dict[str, Any] = {}
    packets = mavlink_packets(c)
    changes = [
        round(t, 2)
        for t, m in packets.get(f"/mavlink/{leader}", [])
        if t > 0 and m["direction"] == "out" and m["name"] == "MISSION_ACK"
        and m["fields"].get("type") == 0 and m["fields"].get("mission_type", 0) in (0, 255)  # MISSION, or ALL
    ]  # fmt: skip
    for topic, msgs in packets.items():
        dirs = {"in": 0, "out": 0}
        rates: dict[str, int] = defaultdict(int)
        spans: dict[str, list[float]] = {}  # each peer's: when a packet first and last went to it alone
        for t, m in msgs:
            dirs[m["direction"]] = dirs.get(m["direction"], 0) + 1
            # a packet sent to one peer alone is counted as that peer's (a peer that set its
            # own rates gets its own stream; the sum of all is no one's rate), its rate over
            # the time packets went to that peer alone (from when it set its own rates)
            key = f"{m['direction']} {m['name']}"
            if "to" in m:
                key += f" to {m['to']}"
                spans.setdefault(m["to"], [t, t])[1] = t
            rates[key] += 1
        duration = msgs[-1][0] - msgs[0][0] if len(msgs) > 1 else 0.0
        commands, acks = ack_latencies(msgs)
        latencies = [lat for _, lat in acks]
        links[topic] = {
            "packets_in": dirs.get("in", 0),
            "packets_out": dirs.get("out", 0),
            "duration_s": round(duration, 3),
            "rates_hz": {
                k: round(_rate(n, spans.get(k.partition(" to ")[2]), duration), 3) for k, n in sorted(rates.items())
            }
            if duration > 0
            else {},
            "commands": commands,
            "commands_acked": len(latencies),
            "command_ack_latency_ms_max": round(max(latencies) * 1000, 2) if latencies else None,
            "command_ack_latency_ms_median": round(float(np.median(latencies)) * 1000, 2) if latencies else None,
        }
    senders = {}
    for sender, got in heard_by_sender(packets).items():
        lost = lost_by_sequence(got)[-1]
        senders[sender] = {"packets": len(got), "lost": lost, "loss_pct": round(100 * lost / (lost + len(got)), 2)}
    return {"links": links, "senders": senders, "mission_changes_s": changes}


def _rate(n: int, span: list[float] | None, duration: float) -> float:
    """``n`` packets a second over the run's ``duration``, or over ``span`` (first, last) when
    they went to one peer alone: the time packets went to that peer alone."""
    if span is not None and span[1] > span[0]:
        return n / (span[1] - span[0])
    return n / duration


def check_thresholds(report: AuditReport) -> list[Finding]:
    """--strict: the scenario's [audit] limits (from the attached scenario.toml), as
    findings (an error for each limit a follower broke).

    Parameters
    ----------
    report : AuditReport
        What :func:`audit` found.
    """
    from lfctl.config import AuditConfig, parse_config

    text = report.contents.attachments.get("scenario.toml")
    try:
        a = parse_config(text.decode()).audit if text else AuditConfig()
    except (ConfigError, UnicodeDecodeError) as exc:
        return [Finding("error", f"the attached scenario.toml does not load: {exc}", kind="provenance")]
    except RecursionError:  # tomllib on arrays nested thousands deep
        return [Finding("error", "the attached scenario.toml does not load: nested too deeply", kind="provenance")]
    limits = {
        "max_range_err_rms_frac": a.max_range_err_rms_frac,
        "max_bearing_err_rms_deg": a.max_bearing_err_rms_deg,
        "min_separation_m": a.min_separation_m,
    }
    out = []
    for f in report.figures.get("followers", []):
        if (
            f["range_err_rms_m"] is not None
            and f["range_err_rms_m"] > limits["max_range_err_rms_frac"] * f["range_cmd_m"]
        ):
            out.append(
                Finding(
                    "error",
                    f"{f['follower']}: range error RMS {f['range_err_rms_m']} m exceeds {limits['max_range_err_rms_frac']:.0%} of {f['range_cmd_m']} m",
                )
            )
        if f["bearing_err_rms_deg"] is not None and f["bearing_err_rms_deg"] > limits["max_bearing_err_rms_deg"]:
            out.append(
                Finding(
                    "error",
                    f"{f['follower']}: bearing error RMS {f['bearing_err_rms_deg']} deg exceeds {limits['max_bearing_err_rms_deg']} deg",
                )
            )
        if f["min_separation_m"] is not None and f["min_separation_m"] < limits["min_separation_m"]:
            out.append(
                Finding(
                    "error",
                    f"{f['follower']}: separation fell to {f['min_separation_m']} m (< {limits['min_separation_m']} m)",
                )
            )
    return out


def recover(report: AuditReport, out_path: Path) -> int:
    """Write every record that was read intact into a new, finished file; returns messages.

    Each message is written once, on its own channel (channels that share a topic stay
    apart), with its log time, publish time and sequence number. The file is written beside
    ``out_path`` and renamed into place when finished.

    Parameters
    ----------
    report : AuditReport
        The audit of the damaged file (its contents are what is written).
    out_path : Path
        The new file.

    Raises
    ------
    ConfigError
        ``out_path`` cannot take the copy (see :func:`recover_target_problem`).
    OSError
        The file cannot be written.
    """
    out_path = Path(out_path)
    problem = recover_target_problem(out_path, Path(report.path))
    if problem:
        raise ConfigError(f"cannot recover into {out_path}: {problem}")
    with write_whole(out_path) as tmp, open(tmp, "wb") as f:
        n = _write_recovered(report, f)
    return n


def recover_target_problem(out_path: Path, audited: Path) -> str | None:
    """Why ``out_path`` cannot take a recovered copy of ``audited`` (None: it can): it
    exists (the log itself, another log, a scenario: a recovery writes over nothing), or its
    folder does not exist.

    Parameters
    ----------
    out_path : Path
        Where the copy would go.
    audited : Path
        The log being audited.
    """
    if out_path.exists() or out_path.is_symlink():
        problem = regular_file_problem(out_path)
        if problem:
            return problem
        if audited.exists() and out_path.samefile(audited):
            return "that is the log being audited"
        return "it exists (a recovery writes over nothing: name a new file)"
    if not out_path.parent.is_dir():
        return f"the folder {out_path.parent} does not exist"
    return None


def _write_recovered(report: AuditReport, f: Any) -> int:
    c = report.contents
    w = Writer(f, compression=CompressionType.ZSTD, enable_crcs=True, enable_data_crcs=True)
    w.start(profile="", library=(c.header_library or "unknown") + " (recovered by lfctl audit)")
    for name, data in c.attachments.items():
        log_time, create_time = c.attachment_times.get(name, (0, 0))
        w.add_attachment(create_time, log_time, name, c.attachment_types.get(name, "application/octet-stream"), data)
    for name, md in c.metadata.items():
        if name != "recovery":
            w.add_metadata(name, md)
    w.add_metadata(
        "recovery",
        {
            "source": report.path,
            "bytes_read": str(c.bytes_read),
            "file_bytes": str(c.file_size),
            "findings": " | ".join(x.line() for x in report.findings),
        },
    )
    schema_ids = {sid: w.register_schema(s.name, s.encoding, s.data) for sid, s in c.schemas.items()}
    channels = {
        cid: w.register_channel(ch.topic, ch.message_encoding, schema_ids.get(ch.schema_id, 0), dict(ch.metadata))
        for cid, ch in c.channels.items()
    }

    def rows(cid: int, store: MessageStore) -> Iterator[tuple[int, int, int]]:
        for i in range(len(store)):
            yield store.log_times[i], cid, i

    n = 0
    stores = {cid: s for cid, s in c.by_channel.items() if cid in channels}
    for _t, cid, i in heapq.merge(*(rows(cid, s) for cid, s in stores.items())):  # by log time
        s = stores[cid]
        w.add_message(channels[cid], s.log_times[i], s.payload(i), s.publish_times[i], s.sequences[i])
        n += 1
    w.finish()
    return n


def _cell(value: object) -> str:
    return "-" if value is None else str(value)


def format_report(report: AuditReport) -> str:
    """The readable report: file and run, findings, formation, mission and link figures.

    Parameters
    ----------
    report : AuditReport
        What :func:`audit` found.
    """
    fig = report.figures
    lines = [
        f"{report.path}",
        f"  size {fig['file_bytes']} bytes, read {fig['bytes_read']}, {fig['messages']} messages on {len(fig.get('topics', {}))} topics",
    ]
    if fig.get("run"):
        r = fig["run"]
        lines.append(
            f"  run: scenario {r.get('scenario')} seed {r.get('seed')} clock {r.get('clock')} dt {r.get('dt_s')} s sensing {r.get('sensing')} controller {r.get('controller')}"
        )
    if fig.get("provenance"):
        p = fig["provenance"]
        lines.append(
            f"  lfctl {p.get('version')} ({p.get('git_revision')}{_code(p)}), python {p.get('python')}; attachments: {', '.join(fig.get('attachments', []))}"
        )
    if fig.get("end"):
        e = fig["end"]
        lines.append(f"  ended: {e.get('reason')}{_at(e)}")
    lines.append("integrity: " + ("OK" if report.ok else "FAILED"))
    lines += [f"  {f.line()}" for f in report.findings] or ["  no findings"]
    if fig.get("followers"):
        lines.append(f"formation (errors after {SETTLE_S:g} s settling; min sep over the whole run):")
        lines.append(
            f"  {'follower':<10} {'target':<8} {'rng RMS m':>9} {'rng max m':>9} {'brg RMS deg':>11} {'brg max deg':>11} {'min sep m':>9} {'path RMS m':>10} {'tracking s':>10} {'occluded s':>10} {'lost s':>6} {'pose rng %':>10} {'pose brg deg':>12}"
        )
        for f in fig["followers"]:
            st = f["time_in_state_s"]
            cells = [
                _cell(f[k])
                for k in (
                    "range_err_rms_m",
                    "range_err_max_m",
                    "bearing_err_rms_deg",
                    "bearing_err_max_deg",
                    "min_separation_m",
                    "path_err_rms_m",
                )
            ]
            lines.append(
                f"  {f['follower']:<10} {f['target']:<8} {cells[0]:>9} {cells[1]:>9} {cells[2]:>11} {cells[3]:>11} "
                f"{cells[4]:>9} {cells[5]:>10} {_cell(st['tracking']):>10} {_cell(st['occluded']):>10} {_cell(st['lost']):>6} {_cell(f.get('pose_range_err_rms_pct')):>10} {_cell(f.get('pose_bearing_err_rms_deg')):>12}"
            )
            within, every = f.get("pose_samples", (0, 0))
            if every > within:
                lines.append(
                    f"    pose errors from the {within} of {every} poses with the target within {POSE_RANGE_M:g} m"
                    " (the truth's range); the others are not counted"
                )
            for e in f["occlusion_episodes"] or []:
                lines.append(  # the episode's time counts in occluded s and lost s by state
                    f"    not tracking from {e['start_s']} s for {e['duration_s']} s (at worst {e['worst']}), "
                    + ("recovered" if e["recovered"] else "not recovered")
                )
    if fig.get("waypoints") or fig.get("mission"):
        reached = ", ".join(f"{m['index']}@{m['t_s']}s" for m in fig["mission"]) or "none"
        changed = fig.get("mission_changes_s") or []
        since = (
            f"; the mission was replaced or cleared by a client at {', '.join(f'{t:g}' for t in changed)} s"
            if changed
            else ""
        )
        lines.append(f"mission: {fig['waypoints_reached']}/{fig['waypoints']} waypoints reached ({reached}){since}")
    for topic, link in fig.get("links", {}).items():
        lines.append(
            f"link {topic}: {link['packets_in']} in, {link['packets_out']} out; {link['commands']} commands, "
            f"{link['commands_acked']} acked (ack latency median {_cell(link['command_ack_latency_ms_median'])} ms, "
            f"max {_cell(link['command_ack_latency_ms_max'])} ms on the log's clock)"
        )
    for sender, s in fig.get("link_senders", {}).items():
        lines.append(
            f"  sender {sender}: {s['packets']} packets heard, {s['lost']} lost by its sequence ({s['loss_pct']} %)"
        )
    return printable("\n".join(lines), keep="\n")


def plot(report: AuditReport, out_dir: Path) -> list[Path]:
    """PNG plots to review the run by (see :mod:`lfctl.record.plots`); returns the files
    written.

    Parameters
    ----------
    report : AuditReport
        What :func:`audit` found.
    out_dir : Path
        Where the PNGs go (made if missing).
    """
    from lfctl.record.plots import plot_all

    return plot_all(report, out_dir)
