"""`lfctl audit`: integrity, provenance and content of a run's MCAP log.

Integrity reads every record with CRC validation on (chunk and data-section CRCs) through a
stream that counts bytes, so a fault is reported with its byte offset: bad magic, a flipped
byte, a file cut short (after SIGKILL). Everything read before the fault is still audited,
and ``recover`` writes it to a new, complete file. Provenance checks the metadata and the
attachments' SHA-256. Content recomputes formation, tracking, pose, mission and link figures
from the recorded topics.
"""

from __future__ import annotations

import hashlib
import io
import itertools
import json
import math
import struct
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mcap.exceptions import EndOfFile, McapError
from mcap.records import Attachment, Channel, DataEnd, Footer, Header, Message, Metadata, Schema, Statistics
from mcap.stream_reader import CRCValidationError, StreamReader
from mcap.writer import CompressionType, Writer

from lfctl.metrics import SETTLE_S, formation_metrics, track_episodes
from lfctl.record.writer import image_topic

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

MAGIC = b"\x89MCAP0\r\n"
KNOWN_SIGNATURES = {
    b"\x89PNG": "a PNG image",
    b"\xff\xd8\xff": "a JPEG image",
    b"PK\x03\x04": "a zip archive",
    b"%PDF": "a PDF",
    b"\x7fELF": "an ELF binary",
}


class _CountingStream(io.RawIOBase):
    """Wraps a file, counting the bytes read (the offset of a fault)."""

    def __init__(self, f: Any) -> None:
        self.f = f
        self.pos = 0

    def readable(self) -> bool:
        return True

    def readinto(self, b: Any) -> int:
        data = self.f.read(len(b))
        n = len(data)
        b[:n] = data
        self.pos += n
        return n

    def read(self, n: int = -1) -> bytes:
        data = self.f.read(n)
        self.pos += len(data)
        return data


@dataclass
class Finding:
    """One problem: ``error`` fails the audit, ``warning`` is reported."""

    level: str  # "error" or "warning"
    what: str  # what is wrong, for a person
    offset: int | None = None  # byte offset in the file where it was found (None: not at one place)

    def line(self) -> str:
        """The finding as one report line: ``ERROR: what (byte N)``."""
        at = f" (byte {self.offset})" if self.offset is not None else ""
        return f"{self.level.upper()}: {self.what}{at}"


@dataclass
class Contents:
    """Everything read from the file, up to a fault if there was one."""

    header_library: str = ""  # the header's library field (who wrote the file)
    schemas: dict[int, Schema] = field(default_factory=dict)  # by schema id
    channels: dict[int, Channel] = field(default_factory=dict)  # by channel id
    #: topic -> (log_time in ns, payload) of every message, in file order
    messages: dict[str, list[tuple[int, bytes]]] = field(default_factory=lambda: defaultdict(list))
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)  # by metadata record name
    attachments: dict[str, bytes] = field(default_factory=dict)  # by attachment name
    statistics: Statistics | None = None  # the summary's statistics record (None: not reached)
    footer: bool = False  # the footer was read: the file is complete
    data_end: bool = False  # the data section's end record was read
    bytes_read: int = 0  # bytes read intact, up to the first fault
    file_size: int = 0  # the file's size, bytes

    @property
    def start_ns(self) -> int:
        """The run's start on the epoch clock, ns (metadata ``run.start_time_ns``); 0 for a
        log whose times are the simulation time itself."""
        try:
            return int(self.metadata.get("run", {}).get("start_time_ns", "0"))
        except ValueError:
            return 0

    def sim_s(self, log_time_ns: int) -> float:
        """A log time as simulation time, s.

        Parameters
        ----------
        log_time_ns : int
            A message's ``log_time``, ns.
        """
        return (log_time_ns - self.start_ns) / 1e9


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


def read_contents(path: Path) -> tuple[Contents, list[Finding]]:
    """Read every record with CRC validation; stop at the first fault and say where."""
    c = Contents()
    findings: list[Finding] = []
    try:
        c.file_size = path.stat().st_size
        f = path.open("rb")
    except OSError as exc:
        return c, [Finding("error", f"cannot read {path}: {exc}")]
    with f:
        head = f.read(8)
        if head != MAGIC:
            kind = next((name for sig, name in KNOWN_SIGNATURES.items() if head.startswith(sig)), None)
            what = f"not an MCAP file: bad magic {head[:8]!r}" + (f" (looks like {kind})" if kind else "")
            if not head:
                what = "not an MCAP file: the file is empty"
            return c, [Finding("error", what, 0)]
        f.seek(0)
        stream = _CountingStream(f)
        last_time: dict[int, int] = {}
        try:
            for rec in StreamReader(stream, validate_crcs=True).records:
                if isinstance(rec, Header):
                    c.header_library = rec.library
                elif isinstance(rec, Schema):
                    c.schemas[rec.id] = rec
                elif isinstance(rec, Channel):
                    if rec.schema_id != 0 and rec.schema_id not in c.schemas:
                        findings.append(
                            Finding(
                                "error",
                                f"channel {rec.topic!r} refers to schema {rec.schema_id} before it is defined",
                                stream.pos,
                            )
                        )
                    c.channels[rec.id] = rec
                elif isinstance(rec, Message):
                    ch = c.channels.get(rec.channel_id)
                    if ch is None:
                        findings.append(
                            Finding(
                                "error",
                                f"message on channel {rec.channel_id} before the channel is defined",
                                stream.pos,
                            )
                        )
                        continue
                    prev = last_time.get(rec.channel_id)
                    if prev is not None and rec.log_time < prev:
                        findings.append(
                            Finding(
                                "error",
                                f"log_time goes back on {ch.topic}: {rec.log_time} ns after {prev} ns",
                                stream.pos,
                            )
                        )
                    last_time[rec.channel_id] = rec.log_time
                    c.messages[ch.topic].append((rec.log_time, rec.data))
                elif isinstance(rec, Metadata):
                    c.metadata[rec.name] = dict(rec.metadata)
                elif isinstance(rec, Attachment):
                    c.attachments[rec.name] = rec.data
                elif isinstance(rec, Statistics):
                    c.statistics = rec
                elif isinstance(rec, DataEnd):
                    c.data_end = True
                elif isinstance(rec, Footer):
                    c.footer = True
        except EndOfFile:
            findings.append(Finding("error", _truncated(c.file_size), stream.pos))
        except CRCValidationError as exc:
            findings.append(Finding("error", f"CRC mismatch: {exc}", stream.pos))
        except (McapError, ValueError, struct.error, EOFError, OSError) as exc:  # the other ways a damaged stream fails
            what = (
                _truncated(c.file_size) if stream.pos >= c.file_size else f"corrupt record: {type(exc).__name__}: {exc}"
            )
            findings.append(Finding("error", what, stream.pos))
        c.bytes_read = stream.pos
    if not c.footer and not any(f.level == "error" for f in findings):
        findings.append(Finding("error", "no footer: the file was not finished", c.bytes_read))
    if c.footer:
        findings.extend(_check_summary_crc(path))
    return c, findings


def _check_summary_crc(path: Path) -> list[Finding]:
    """The footer's CRC over the summary section (the stream reader does not check it)."""
    import zlib

    data = path.read_bytes()
    # footer record: opcode, length, summary_start, summary_offset_start, summary_crc; magic
    footer = len(data) - 8 - (1 + 8 + 8 + 8 + 4)
    summary_start, _offsets, crc = struct.unpack_from("<QQI", data, footer + 9)
    if summary_start == 0 or crc == 0:
        return []
    got = zlib.crc32(data[summary_start : len(data) - 8 - 4]) & 0xFFFFFFFF
    if got != crc:
        return [Finding("error", f"summary CRC mismatch: computed {got:#010x}, footer says {crc:#010x}", summary_start)]
    return []


def _truncated(size: int) -> str:
    return f"truncated: the file ends inside a record ({size} bytes)"


def _json_messages(c: Contents, topic: str) -> list[tuple[float, dict[str, Any]]]:
    return [(c.sim_s(t), json.loads(d)) for t, d in c.messages.get(topic, [])]


def audit(path: str | Path) -> AuditReport:
    """Audit a log file; never raises for a bad file (the findings say what is wrong).

    Parameters
    ----------
    path : str or Path
        An MCAP log written by :class:`~lfctl.record.writer.Recorder` (or a damaged one).
    """
    p = Path(path)
    c, findings = read_contents(p)
    figures: dict[str, Any] = {
        "file_bytes": c.file_size,
        "bytes_read": c.bytes_read,
        "messages": sum(len(v) for v in c.messages.values()),
    }
    if not c.channels and findings:
        return AuditReport(str(p), findings, c, figures)
    # -- integrity: counts against the statistics, expected topics, gaps --------------------
    counted = {ch_id: len(c.messages.get(ch.topic, [])) for ch_id, ch in c.channels.items()}
    if c.statistics is not None:
        if c.statistics.message_count != sum(counted.values()):
            findings.append(
                Finding(
                    "error",
                    f"statistics say {c.statistics.message_count} messages, the file holds {sum(counted.values())}",
                )
            )
        for ch_id, n in c.statistics.channel_message_counts.items():
            if counted.get(ch_id, 0) != n:
                findings.append(
                    Finding(
                        "error",
                        f"statistics say {n} messages on {c.channels[ch_id].topic}, the file holds {counted.get(ch_id, 0)}",
                    )
                )
    run = c.metadata.get("run", {})
    if not run:
        findings.append(Finding("error", "metadata 'run' missing (scenario, seed, clock)"))
    if "lfctl" not in c.metadata:
        findings.append(Finding("error", "metadata 'lfctl' missing (version, git revision, packages)"))
    expected = _expected_topics(run)
    for topic, period in expected.items():
        msgs = c.messages.get(topic)
        if not msgs:
            findings.append(Finding("error" if c.footer else "warning", f"expected topic {topic} is missing"))
            continue
        times = np.array([c.sim_s(t) for t, _ in msgs])
        gaps = np.diff(times)
        big = gaps > 3 * period + 1e-6
        if big.any():
            i = int(np.argmax(gaps))
            findings.append(
                Finding(
                    "warning",
                    f"{topic}: {int(big.sum())} gaps longer than 3x its {period * 1000:.0f} ms period (longest {gaps[i]:.3f} s at t={times[i]:.2f} s)",
                )
            )
    # -- provenance -------------------------------------------------------------------------
    hashes = {m["name"]: m["sha256"] for k, m in c.metadata.items() if k.startswith("sha256:")}
    for name, data in c.attachments.items():
        want = hashes.get(name)
        got = hashlib.sha256(data).hexdigest()
        if want is None:
            findings.append(Finding("warning", f"attachment {name} has no recorded SHA-256"))
        elif want != got:
            findings.append(
                Finding("error", f"attachment {name}: SHA-256 {got[:12]}... does not match the recorded {want[:12]}...")
            )
    figures["attachments"] = sorted(c.attachments)
    figures["provenance"] = {
        k: v for k, v in c.metadata.get("lfctl", {}).items() if k in ("version", "git_revision", "python")
    }
    figures["run"] = run
    end = c.metadata.get("end")
    figures["end"] = end
    if end is not None and end.get("reason") != "completed":
        findings.append(Finding("warning", f"the run ended early{_at(end)}: {end.get('reason')}"))
    # -- content ----------------------------------------------------------------------------
    figures["followers"] = _formation_figures(c, run)
    figures["mission"] = [
        {"index": m["index"] + 1, "t_s": round(t, 2)}
        for t, m in _json_messages(c, "/leader/mission")
        if m.get("event") == "reached"
    ]
    figures["waypoints"] = int(run.get("waypoints", "0") or 0)
    link = _link_figures(c)
    figures["links"], figures["link_senders"] = link["links"], link["senders"]
    figures["topics"] = {
        ch.topic: counted[ch_id] for ch_id, ch in sorted(c.channels.items(), key=lambda kv: kv[1].topic)
    }
    return AuditReport(str(p), findings, c, figures)


def _expected_topics(run: dict[str, str]) -> dict[str, float]:
    """Topic -> expected period (s) from the run metadata."""
    if not run:
        return {}
    out: dict[str, float] = {}
    tel = 1.0 / float(run.get("telemetry_rate_hz", "10"))
    guid = 1.0 / float(run.get("guidance_rate_hz", "20"))
    cam = 1.0 / float(run.get("camera_rate_hz", "30"))
    for v in filter(None, run.get("vehicles", "").split(",")):
        out[f"/{v}/pose"] = tel
    out["/tf"] = tel
    for f in filter(None, run.get("followers", "").split(",")):
        out[f"/{f}/controller"] = guid
        if run.get("sensing") == "camera":
            out[f"/{f}/tracker"] = cam
            out[f"/{f}/camera/annotations"] = cam
            if run.get("images") == "true":
                out[image_topic(f, run.get("image_format", "jpeg"))] = 1.0 / float(run.get("image_rate_hz", "30"))
    return out


def _at(end: dict[str, str]) -> str:
    """`` at t = 12.34 s`` from an ``end`` metadata record ("" when it has no usable time)."""
    try:
        return f" at t = {float(end['t_s']):.2f} s"
    except (KeyError, ValueError):
        return ""


def _rounded(value: float | None, digits: int, scale: float = 1.0) -> float | None:
    return None if value is None else round(value * scale, digits)


def _formation_figures(c: Contents, run: dict[str, str]) -> list[dict[str, Any]]:
    out = []
    step_s = 1.0 / float(run.get("guidance_rate_hz", "20") or 20)
    deg = math.degrees(1.0)
    for f in filter(None, run.get("followers", "").split(",")):
        msgs = _json_messages(c, f"/{f}/controller")
        if not msgs:
            continue
        t = [m[0] for m in msgs]
        status = [m[1]["status"] for m in msgs]
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
            "time_in_state_s": {k: round(v, 2) for k, v in m.time_in_state_s.items()},
            "control_effort_rad": round(m.control_effort_rad, 4),
            "chattering_per_s": round(m.chattering_per_s, 4),
            "occlusion_episodes": [
                {
                    "start_s": round(e.start_s, 2),
                    "duration_s": round(e.duration_s, 2),
                    "recovered": e.recovered,
                    "worst": e.worst,
                }
                for e in track_episodes(t, status, step_s)
            ],
        }
        poses = _json_messages(c, f"/{f}/pose_estimate")
        if poses:
            pr = np.array(
                [
                    (m["range_m"] - m["truth_range_m"]) / m["truth_range_m"]
                    for _, m in poses
                    if m["truth_range_m"] <= 3.0
                ]
            )
            pb = np.array([m["bearing_deg"] - m["truth_bearing_deg"] for _, m in poses if m["truth_range_m"] <= 3.0])
            if pr.size:
                fig["pose_range_err_rms_pct"] = round(float(np.sqrt(np.mean(pr**2)) * 100), 3)
                fig["pose_bearing_err_rms_deg"] = round(float(np.sqrt(np.mean(pb**2))), 3)
        out.append(fig)
    return out


#: a sender silent this long, then heard again, started a new session (a new process,
#: a reconnect): its sequence restarts, which is not loss
SESSION_GAP_S = 2.5
#: a sender's sequence jumping this far (mod 256) restarted: a new process, not 128+ packets lost
RESTART_JUMP = 128
COMMANDS = ("COMMAND_LONG", "COMMAND_INT")


def mavlink_packets(c: Contents) -> dict[str, list[tuple[float, dict[str, Any]]]]:
    """Every ``/mavlink/<vehicle>`` topic's packets, decoded: (simulation time, packet).

    Parameters
    ----------
    c : Contents
        What was read from the log.
    """
    return {t: _json_messages(c, t) for t in sorted(c.messages) if t.startswith("/mavlink/")}


def ack_latencies(packets: list[tuple[float, dict[str, Any]]]) -> tuple[int, list[tuple[float, float]]]:
    """Commands on one link and their acks: (commands, [(ack time, latency s)]).

    An ack is matched to the oldest unanswered command of the same number from the system and
    component it is addressed to, going the other way (commands in and acks out at a vehicle;
    out and in at a companion); an ack without that address, on the command number alone.

    Parameters
    ----------
    packets : list of (t_s, packet)
        One link's packets in log order.
    """
    pending: dict[tuple[str, int, int, int], list[float]] = defaultdict(list)
    out = []
    commands = 0
    for t, m in packets:
        fields = m.get("fields", {})
        if m["name"] in COMMANDS:
            commands += 1
            pending[(m["direction"], m["sysid"], m["compid"], fields.get("command", -1))].append(t)
        elif m["name"] == "COMMAND_ACK":
            other = "out" if m["direction"] == "in" else "in"
            key = (other, fields.get("target_system", 0), fields.get("target_component", 0), fields.get("command"))
            if not pending.get(key):
                key = next((k for k, v in pending.items() if v and k[0] == other and k[3] == key[3]), key)
            if pending.get(key):
                out.append((t, t - pending[key].pop(0)))
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


def _link_figures(c: Contents) -> dict[str, Any]:
    """Per link: packets each way, message rates, commands and their acks (latency on the
    log's clock); per sender: loss by its own sequence numbers over every link."""
    links: dict[str, Any] = {}
    packets = mavlink_packets(c)
    for topic, msgs in packets.items():
        dirs = {"in": 0, "out": 0}
        rates: dict[str, int] = defaultdict(int)
        for _t, m in msgs:
            dirs[m["direction"]] = dirs.get(m["direction"], 0) + 1
            rates[f"{m['direction']} {m['name']}"] += 1
        duration = msgs[-1][0] - msgs[0][0] if len(msgs) > 1 else 0.0
        commands, acks = ack_latencies(msgs)
        latencies = [lat for _, lat in acks]
        links[topic] = {
            "packets_in": dirs.get("in", 0),
            "packets_out": dirs.get("out", 0),
            "duration_s": round(duration, 3),
            "rates_hz": {k: round(n / duration, 3) for k, n in sorted(rates.items())} if duration > 0 else {},
            "commands": commands,
            "commands_acked": len(latencies),
            "command_ack_latency_ms_max": round(max(latencies) * 1000, 2) if latencies else None,
            "command_ack_latency_ms_median": round(float(np.median(latencies)) * 1000, 2) if latencies else None,
        }
    senders = {}
    for sender, got in heard_by_sender(packets).items():
        lost = lost_by_sequence(got)[-1]
        senders[sender] = {"packets": len(got), "lost": lost, "loss_pct": round(100 * lost / (lost + len(got)), 2)}
    return {"links": links, "senders": senders}


def check_thresholds(report: AuditReport) -> list[Finding]:
    """--strict: the scenario's [audit] limits (from the attached scenario.toml), as
    findings (an error for each limit a follower broke).

    Parameters
    ----------
    report : AuditReport
        What :func:`audit` found.
    """
    from lfctl.config import AuditConfig, parse_config
    from lfctl.errors import ConfigError

    text = report.contents.attachments.get("scenario.toml")
    try:
        a = parse_config(text.decode()).audit if text else AuditConfig()
    except (ConfigError, UnicodeDecodeError) as exc:
        return [Finding("error", f"the attached scenario.toml does not load: {exc}")]
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
        if f["min_separation_m"] < limits["min_separation_m"]:
            out.append(
                Finding(
                    "error",
                    f"{f['follower']}: separation fell to {f['min_separation_m']} m (< {limits['min_separation_m']} m)",
                )
            )
    return out


def recover(report: AuditReport, out_path: Path) -> int:
    """Write every record that was read intact into a new, finished file; returns messages.

    Parameters
    ----------
    report : AuditReport
        The audit of the damaged file (its contents are what is written).
    out_path : Path
        The new file.
    """
    c = report.contents
    with out_path.open("wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD, enable_crcs=True, enable_data_crcs=True)
        w.start(profile="", library=(c.header_library or "unknown") + " (recovered by lfctl audit)")
        for name, data in c.attachments.items():
            w.add_attachment(0, 0, name, "application/octet-stream", data)
        for name, md in c.metadata.items():
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
        n = 0
        for cid, ch in c.channels.items():
            new = w.register_channel(ch.topic, ch.message_encoding, schema_ids.get(ch.schema_id, 0), dict(ch.metadata))
            for seq, (t, data) in enumerate(c.messages.get(ch.topic, [])):
                w.add_message(new, t, data, t, seq)
                n += 1
            del cid
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
            f"  lfctl {p.get('version')} ({p.get('git_revision')}), python {p.get('python')}; attachments: {', '.join(fig.get('attachments', []))}"
        )
    if fig.get("end"):
        e = fig["end"]
        lines.append(f"  ended: {e.get('reason')}{_at(e)}")
    lines.append("integrity: " + ("OK" if report.ok else "FAILED"))
    lines += [f"  {f.line()}" for f in report.findings] or ["  no findings"]
    if fig.get("followers"):
        lines.append(f"formation (after {SETTLE_S:g} s settling):")
        lines.append(
            f"  {'follower':<10} {'target':<8} {'rng RMS m':>9} {'rng max m':>9} {'brg RMS deg':>11} {'brg max deg':>11} {'min sep m':>9} {'tracking s':>10} {'occluded s':>10} {'lost s':>6} {'pose rng %':>10} {'pose brg deg':>12}"
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
                )
            ]
            lines.append(
                f"  {f['follower']:<10} {f['target']:<8} {cells[0]:>9} {cells[1]:>9} {cells[2]:>11} {cells[3]:>11} "
                f"{cells[4]:>9} {st['tracking']:>10} {st['occluded']:>10} {st['lost']:>6} {_cell(f.get('pose_range_err_rms_pct')):>10} {_cell(f.get('pose_bearing_err_rms_deg')):>12}"
            )
            for e in f["occlusion_episodes"]:
                lines.append(
                    f"    {e['worst']} at {e['start_s']} s for {e['duration_s']} s, "
                    + ("recovered" if e["recovered"] else "not recovered")
                )
    if fig.get("waypoints"):
        reached = ", ".join(f"{m['index']}@{m['t_s']}s" for m in fig["mission"]) or "none"
        lines.append(f"mission: {len(fig['mission'])}/{fig['waypoints']} waypoints reached ({reached})")
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
    return "\n".join(lines)


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
