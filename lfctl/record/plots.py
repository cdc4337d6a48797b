"""`lfctl audit --plot`: the PNGs to review a run by.

- ``trajectories.png``: every vehicle's path (top view, east right, north up), start (circle)
  and end (square), a numbered mark every 10 s of simulation time; the mission's waypoints
  with their acceptance circles and the time each was reached.
- ``<follower>_errors.png``: range and bearing error and the track state over time, with the
  scenario's events (occluders, lighting keys, sensor dropouts), every mode change after 0 s and the
  ``--strict`` limits (RMS limits, drawn as a band the error's RMS must stay inside).
- ``<follower>_pose.png``: the camera's range and bearing estimate against the truth.
- ``link.png``: message rates each way per vehicle, packets lost per sender (by its
  sequence) and each command's ack latency.
"""

from __future__ import annotations

import dataclasses
import math
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lfctl.config import AuditConfig, Config, parse_config
from lfctl.errors import ConfigError
from lfctl.record.audit import (
    MAX_JSON_NUMBER,
    AuditReport,
    Contents,
    _followers,
    _json_messages,
    ack_latencies,
    heard_by_sender,
    lost_by_sequence,
    mavlink_packets,
)
from lfctl.record.writer import EVENT_MODE, MISSION_TOPIC, PALETTE, SCENE_TOPIC, scenario_events

__all__ = ["TIME_MARK_S", "plot_all"]

#: a time mark on every trajectory this often, s of simulation time
TIME_MARK_S = 10.0
#: the most time marks a track gets, and the most bins a rate over time is counted in: a
#: log's times come from the file, and may span years
MAX_MARKS = 40
MAX_BINS = 2000


def mark_step_s(end_s: float) -> float:
    """Time between marks on a track that ends at ``end_s``: :data:`TIME_MARK_S`, or a whole
    multiple of it that keeps the marks to :data:`MAX_MARKS`.

    Parameters
    ----------
    end_s : float
        The track's last time, s.
    """
    if not (math.isfinite(end_s) and end_s > TIME_MARK_S * MAX_MARKS):
        return TIME_MARK_S
    return TIME_MARK_S * math.ceil(end_s / (TIME_MARK_S * MAX_MARKS))


#: marks nearer than this share of the time axis to the one before share its label
LABEL_GAP_FRAC = 0.02
#: a pose series' line is broken where no pose came for this many usual steps
GAP_STEPS = 3.0


def _scenario(c: Contents) -> Config | None:
    """The attached scenario as run (the sensing the command line chose, from the run's
    metadata), or None when it is missing or does not load."""
    text = c.attachments.get("scenario.toml")
    try:
        cfg = parse_config(text.decode()) if text else None
    except (ConfigError, UnicodeDecodeError):
        return None
    sensing = c.metadata.get("run", {}).get("sensing")
    if cfg is not None and sensing in ("truth", "camera"):
        cfg = dataclasses.replace(cfg, sim=dataclasses.replace(cfg.sim, sensing=sensing))
    return cfg


def _json(c: Contents, topic: str) -> list[tuple[float, dict[str, Any]]]:
    """The topic's messages that pass the audit's checks (the others are findings there)."""
    return _json_messages(c, topic)


def _colour(k: int) -> tuple[float, float, float]:
    return PALETTE[0 if k == 0 else 1 + (k - 1) % (len(PALETTE) - 1)]


def _save(plt: Any, fig: Any, path: Path, key: Sequence[str] = ()) -> None:
    """Write the figure as ``path``: a symbolic link there is replaced by the picture, not
    followed (it would write over the file it points at). ``key``: the numbered marks'
    names (:func:`_marks`), written under the plots, as many lines as they need."""
    lines = textwrap.wrap("   ".join(key), width=int(fig.get_figwidth() * 15)) if key else []
    if lines:
        fig.text(0.01, 0.005, "\n".join(lines), fontsize=8, va="bottom", ha="left")
    fig.tight_layout(rect=(0.0, (0.02 + 0.13 * len(lines)) / fig.get_figheight() if lines else 0.0, 1.0, 1.0))
    if path.is_symlink():
        path.unlink()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _mode_changes(c: Contents) -> list[tuple[float, str, str]]:
    """(t_s, vehicle, mode) from the log's ``/log`` events."""
    from foxglove_schemas_protobuf.Log_pb2 import Log
    from google.protobuf.message import DecodeError

    out = []
    for t, d in c.messages.get("/log", []):
        try:
            m = Log.FromString(d)
        except DecodeError:
            continue
        if m.message.startswith(EVENT_MODE):
            out.append((c.sim_s(t), m.name, m.message[len(EVENT_MODE) :]))
    return out


def _scene_mission(c: Contents) -> tuple[float, list[tuple[float, float]], float] | None:
    """The first mission the 3D scene shows (``/scene/mission``; a log made before that topic
    had it in ``/scene``): (sim time, its places as (north, east), acceptance radius), from
    its ``mission`` entity; None when the log has none (or it does not decode)."""
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
    from google.protobuf.message import DecodeError

    for t, d in c.messages.get(MISSION_TOPIC) or c.messages.get(SCENE_TOPIC, []):
        try:
            update = SceneUpdate.FromString(d)
        except DecodeError:
            continue
        for ent in update.entities:
            if ent.id != "mission":
                continue
            places = [(s.pose.position.x, s.pose.position.y) for s in ent.spheres]
            if not places:  # no mission yet: a ground station may upload one later
                continue
            loops = [ln for ln in ent.lines if ln.type == ln.LINE_LOOP and ln.points]
            radius = max(loops[0].points[0].x, 0.0) if loops else 0.0
            fine = all(abs(v) <= MAX_JSON_NUMBER for p in places for v in p)  # NaN fails too
            return (c.sim_s(t), places, radius) if fine else None
    return None


def _track(c: Contents, vehicle: str) -> tuple[np.ndarray, np.ndarray]:
    """A vehicle's ``/<vehicle>/pose`` as simulation times and (N, 2) east/north points:
    messages that do not decode, and points not finite or beyond MAX_JSON_NUMBER m, left out."""
    from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
    from google.protobuf.message import DecodeError

    times, pts = [], []
    for ts, d in c.messages.get(f"/{vehicle}/pose", []):
        try:
            p = PoseInFrame.FromString(d).pose.position
        except DecodeError:
            continue
        if abs(p.x) <= MAX_JSON_NUMBER and abs(p.y) <= MAX_JSON_NUMBER:  # NaN fails too
            times.append(c.sim_s(ts))
            pts.append((p.y, p.x))  # east right, north up
    return np.array(times), np.array(pts).reshape(-1, 2)


def _trajectories(plt: Any, report: AuditReport, path: Path) -> None:
    c = report.contents
    run = c.metadata.get("run", {})
    vehicles = [v for v in run.get("vehicles", "").split(",") if v] or sorted(
        t.split("/")[1] for t in c.messages if t.endswith("/pose") and t.count("/") == 2
    )
    fig, ax = plt.subplots(figsize=(8, 8))
    cfg = _scenario(c)
    changed = report.figures.get("mission_changes_s") or []
    if cfg is not None and cfg.mission.waypoints:
        # reach times belong to the scenario's waypoints only while its mission was the one flown
        until = changed[0] if changed else math.inf
        reached = {m["index"]: m["t_s"] for m in report.figures.get("mission", []) if m["t_s"] < until}
        r = cfg.mission.acceptance_radius_m
        for k, wp in enumerate(cfg.mission.waypoints, start=1):
            n, e = wp[0], wp[1]
            ax.add_patch(plt.Circle((e, n), r, fill=False, ls="--", lw=1, color="tab:cyan"))
            ax.plot(e, n, "x", color="tab:cyan", ms=8, mew=2)
            when = f" @{reached[k]} s" if k in reached else ("" if changed else " (not reached)")
            ax.annotate(f"WP{k}{when}", (e, n), xytext=(6, 6), textcoords="offset points", color="teal", fontsize=9)
        what = f"the scenario's waypoints, replaced or cleared at {changed[0]:g} s" if changed else "waypoints"
        ax.plot([], [], "x", color="tab:cyan", label=f"{what} (acceptance {r:g} m)")
    elif (shown := _scene_mission(c)) is not None:
        # a mission file, or one a ground station uploaded: its places as the run first showed them
        t0, places, r = shown
        for k, (n, e) in enumerate(places, start=1):
            ax.add_patch(plt.Circle((e, n), r, fill=False, ls="--", lw=1, color="tab:cyan"))
            ax.plot(e, n, "x", color="tab:cyan", ms=8, mew=2)
            ax.annotate(f"{k}", (e, n), xytext=(6, 6), textcoords="offset points", color="teal", fontsize=9)
        later = [t for t in changed if t > t0]  # not the upload that put this one there
        what = f"the mission's places at {t0:g} s" + (f", changed at {later[0]:g} s" if later else "")
        ax.plot([], [], "x", color="tab:cyan", label=f"{what} (acceptance {r:g} m)")
    tracks = [(k, v, *_track(c, v)) for k, v in enumerate(vehicles)]
    # marks over the time the tracks span (a foreign file's times may start far from 0)
    first_s = min((float(t[0]) for _k, _v, t, _a in tracks if len(t)), default=0.0)
    last_s = max((float(t[-1]) for _k, _v, t, _a in tracks if len(t)), default=0.0)
    step = mark_step_s(last_s - first_s)
    first_mark = max(step, math.ceil(first_s / step) * step)
    times: list[tuple[float, float, str, Any]] = []  # (east, north, label, colour) of each time dot
    for k, v, t, a in tracks:
        if not len(t):
            continue
        col = _colour(k)
        ax.plot(a[:, 0], a[:, 1], color=col, lw=1.5, label=v)
        ax.plot(a[0, 0], a[0, 1], "o", color=col, ms=9, mfc="white", mew=2)
        ax.plot(a[-1, 0], a[-1, 1], "s", color=col, ms=8)
        for mark in np.arange(first_mark, t[-1] + 1e-9, step):
            i = int(np.searchsorted(t, mark))
            if i < len(t):
                ax.plot(a[i, 0], a[i, 1], ".", color="black", ms=6)
                times.append((float(a[i, 0]), float(a[i, 1]), f"{mark:g}", col))
    ax.plot([], [], "o", color="grey", mfc="white", label="start")
    ax.plot([], [], "s", color="grey", label="end")
    ax.plot([], [], ".", color="black", label=f"every {step:g} s (labelled in s)")
    ax.set_xlabel("east of home (m)")
    ax.set_ylabel("north of home (m)")
    ax.set_aspect("equal")
    _time_labels(ax, times)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(f"{run.get('scenario', '')} seed {run.get('seed', '')}: trajectories (top view)")
    _save(plt, fig, path)


#: the errors plot's key under the plots: at most this many numbered entries, and names in one
KEY_ENTRIES = 12
KEY_NAMES = 3

#: a time label nearer than this to one already written is left out (its dot stays), px
LABEL_CLEARANCE_PX = (16.0, 9.0)


def _time_labels(ax: Any, labels: list[tuple[float, float, str, Any]]) -> None:
    """Each time dot's label beside it, in order (the leader's first), but none within
    :data:`LABEL_CLEARANCE_PX` of one already written: where vehicles pass the same place,
    labels piled up into an unreadable blot."""
    ax.apply_aspect()  # the equal-aspect limits, so pixel distances are the picture's
    written: list[tuple[float, float]] = []
    dx, dy = LABEL_CLEARANCE_PX
    for east, north, text, col in labels:
        x, y = ax.transData.transform((east, north))
        if any(abs(x - wx) < dx and abs(y - wy) < dy for wx, wy in written):
            continue
        written.append((x, y))
        ax.annotate(text, (east, north), xytext=(3, -10), textcoords="offset points", fontsize=7, color=col)


def _marks(ax: Any, events: list[tuple[float, str]], modes: list[tuple[float, str, str]], label: bool) -> list[str]:
    """Scenario events (red dotted) and mode changes (grey dashed) as vertical lines; with
    ``label``, a number over each line, just above the axes, and the key's entries
    returned (``"2 lighting key: gain 1 (40.0 s)"``; names written along the lines ran over
    the curves. Marks closer than :data:`LABEL_GAP_FRAC` of the time axis to the one before
    share a number (side by side the numbers overlap)."""
    for t, _text in events:
        ax.axvline(t, color="tab:red", ls=":", lw=1.2)
    for t, _vehicle, _mode in modes:
        ax.axvline(t, color="grey", ls="--", lw=0.8)
    if not label:
        return []
    lo, hi = ax.get_xlim()
    gap = LABEL_GAP_FRAC * (hi - lo)
    groups = sorted(
        [(t, x, "tab:red") for t, x in _grouped(events, gap)]
        + [(t, x, "dimgrey") for t, x in _grouped([(t, f"{v}: {m}") for t, v, m in modes], gap)],
        key=lambda g: g[0],
    )
    keys = []
    for k, (t, text, color) in enumerate(groups, start=1):
        names = text.split(" / ")
        if len(names) > KEY_NAMES:  # a burst of mode changes: the first few, and how many more
            text = " / ".join([*names[:KEY_NAMES], f"{len(names) - KEY_NAMES} more"])
        ax.annotate(
            str(k), xy=(t, 1.0), xycoords=("data", "axes fraction"), xytext=(0, 2), textcoords="offset points",
            ha="center", va="bottom", fontsize=7, color=color, fontweight="bold", annotation_clip=True,
        )  # fmt: skip
        keys.append(f"{k} {text}")
    if len(keys) > KEY_ENTRIES:  # the key stays a few lines under the plots (the log has them all)
        keys = [*keys[:KEY_ENTRIES], f"{KEY_ENTRIES + 1}-{len(keys)}: see the log's /log topic"]
    return keys


def _broken(t: np.ndarray, series: list[np.ndarray]) -> tuple[np.ndarray, list[np.ndarray]]:
    """``t`` and ``series`` with a NaN put in each gap longer than :data:`GAP_STEPS` times the
    usual step (matplotlib breaks a line at a NaN)."""
    if len(t) < 3:
        return t, series
    steps = np.diff(t)
    cut = np.flatnonzero(steps > GAP_STEPS * float(np.median(steps))) + 1
    return np.insert(t, cut, np.nan), [np.insert(s.astype(float), cut, np.nan) for s in series]


def _grouped(marks: list[tuple[float, str]], gap: float) -> list[tuple[float, str]]:
    """Marks in time order, each within ``gap`` of the group's first joined into it (" / "),
    each named with its own time (``"occluder (30.0 s) / lighting key: gain 1 (40.0 s)"``: on
    a long run's axis marks minutes apart share a number, and the first's time was all the
    key gave)."""
    groups: list[list[tuple[float, str]]] = []
    for t, text in sorted(marks):
        if groups and t - groups[-1][0][0] < gap:
            groups[-1].append((t, text))
        else:
            groups.append([(t, text)])
    return [(g[0][0], " / ".join(f"{text} ({t:.1f} s)" for t, text in g)) for g in groups]


def _errors(plt: Any, c: Contents, follower: str, path: Path) -> bool:
    msgs = _json(c, f"/{follower}/controller")
    msgs = [(t, m) for t, m in msgs if "range_error_m" in m]
    if not msgs:
        return False
    cfg = _scenario(c)
    limits = cfg.audit if cfg is not None else AuditConfig()
    t = np.array([x[0] for x in msgs])
    events = [e for e in (scenario_events(cfg) if cfg is not None else []) if e[0] <= t[-1]]
    modes = [m for m in _mode_changes(c) if 0 < m[0] <= t[-1]]
    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(11, 8), sharex=True, gridspec_kw={"height_ratios": [3, 3, 1.2]})
    rng = np.array([m["range_error_m"] for _, m in msgs])
    brg = np.array([m["bearing_error_deg"] for _, m in msgs])
    range_cmd = float(msgs[-1][1].get("range_cmd_m", 1.0))
    r_lim = limits.max_range_err_rms_frac * range_cmd
    a1.plot(t, rng, color="tab:blue", lw=1)
    a1.axhspan(-r_lim, r_lim, color="tab:green", alpha=0.08)
    for s in (-1, 1):
        a1.axhline(s * r_lim, color="tab:green", ls="--", lw=1)
    a1.set_ylabel("range error (m)")
    a1.plot([], [], color="tab:green", ls="--", label=f"--strict: RMS within {r_lim:.3g} m")
    a2.plot(t, brg, color="tab:purple", lw=1)
    b_lim = limits.max_bearing_err_rms_deg
    a2.axhspan(-b_lim, b_lim, color="tab:green", alpha=0.08)
    for s in (-1, 1):
        a2.axhline(s * b_lim, color="tab:green", ls="--", lw=1)
    a2.set_ylabel("bearing error (deg)")
    a2.plot([], [], color="tab:green", ls="--", label=f"--strict: RMS within {b_lim:g} deg")
    code = {"tracking": 2, "occluded": 1, "lost": 0}
    if all("status" in m for _, m in msgs):
        a3.step(t, [code.get(m["status"], 0) for _, m in msgs], where="post", color="black", lw=1)
    else:  # its companion ran outside the simulator (a rehearsal's follower): the state was its own
        a3.text(
            0.5, 0.5, "track state not recorded: its companion ran outside the simulator",
            transform=a3.transAxes, ha="center", va="center", color="grey",
        )  # fmt: skip
    a3.set_yticks([0, 1, 2], ["lost", "occluded", "tracking"])
    a3.set_ylim(-0.3, 2.3)
    a3.set_xlabel("simulation time (s)")
    keys: list[str] = []
    for ax, label in ((a1, True), (a2, False), (a3, False)):
        keys += _marks(ax, events, modes, label)
        ax.grid(alpha=0.3)
    if events:
        a1.plot([], [], color="tab:red", ls=":", label="scenario event")
    if modes:
        a1.plot([], [], color="grey", ls="--", label="mode change")
    a1.legend(loc="lower right", fontsize=8)
    a2.legend(loc="lower right", fontsize=8)
    a1.set_title(f"{follower}: formation errors (truth) and track state", pad=14)  # room for the numbers
    _save(plt, fig, path, key=keys)
    return True


def _pose(plt: Any, c: Contents, follower: str, path: Path) -> bool:
    msgs = [(t, m) for t, m in _json(c, f"/{follower}/pose_estimate") if "truth_range_m" in m]
    if not msgs:
        return False
    t = np.array([x[0] for x in msgs])
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
    # the truth is logged with each pose found: across the frames without one (the banner
    # hidden) the line is broken, not drawn straight through what was not measured
    t_line, (truth_range, truth_bearing) = _broken(
        t, [np.array([m["truth_range_m"] for _, m in msgs]), np.array([m["truth_bearing_deg"] for _, m in msgs])]
    )
    a1.plot(t_line, truth_range, color="black", lw=1.5, label="truth (where a pose was found)")
    a1.plot(t, [m["range_m"] for _, m in msgs], ".", color="tab:orange", ms=2.5, label="estimate (markers)")
    a1.set_ylabel("range (m)")
    a2.plot(t_line, truth_bearing, color="black", lw=1.5, label="truth (where a pose was found)")
    a2.plot(t, [m["bearing_deg"] for _, m in msgs], ".", color="tab:orange", ms=2.5, label="estimate (markers)")
    a2.set_ylabel("bearing (deg)")
    a2.set_xlabel("simulation time (s)")
    for ax in (a1, a2):
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    a1.set_title(f"{follower}: camera pose estimate against the truth ({len(msgs)} frames with the markers seen)")
    _save(plt, fig, path)
    return True


def _link(plt: Any, c: Contents, path: Path) -> bool:
    links = mavlink_packets(c)
    if not links:
        return False
    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    end = max((msgs[-1][0] for msgs in links.values() if msgs), default=1.0)
    width = max(1.0, math.ceil(end / MAX_BINS)) if math.isfinite(end) else 1.0  # s per bin
    bins = np.arange(0.0, max(end, 1.0) + width, width)
    any_ack = False
    most_latency_ms = 0.0
    order = [v for v in c.metadata.get("run", {}).get("vehicles", "").split(",") if v]
    for topic, msgs in links.items():
        vehicle = topic.split("/")[2]
        k = order.index(vehicle) if vehicle in order else len(order)  # the vehicle's colour, as in trajectories
        for direction, ls in (("out", "-"), ("in", "--")):
            times = [t for t, m in msgs if m["direction"] == direction]
            if times:
                counts, edges = np.histogram(times, bins=bins)
                a1.step(
                    edges[:-1], counts / width, where="post", color=_colour(k), ls=ls, label=f"{vehicle} {direction}"
                )
        _commands, acks = ack_latencies(msgs)
        if acks:
            any_ack = True
            most_latency_ms = max(most_latency_ms, *(lat * 1000 for _, lat in acks))
            a3.plot(
                [t for t, _ in acks],
                [lat * 1000 for _, lat in acks],
                "o",
                ms=4,
                color=_colour(k),
                label=f"{vehicle}: {len(acks)} acks",
            )
    a1.set_ylabel("packets per second")
    a1.legend(loc="upper right", fontsize=8, ncol=2)
    a1.set_title("MAVLink: packets each way per vehicle, loss per sender (its sequence numbers), command acks")
    most_lost = 0
    for k, (sender, got) in enumerate(heard_by_sender(links).items()):
        lost = lost_by_sequence(got)
        most_lost = max(most_lost, lost[-1])
        a2.step(
            [t for t, _ in got],
            lost,
            where="post",
            color=f"C{k}",
            lw=max(1.0, 3.0 - k),  # senders with the same count stay visible under each other
            label=f"sender {sender}: {len(got)} heard, {lost[-1]} lost",
        )
    a2.set_ylim(-0.5, max(3.0, most_lost * 1.15))
    a2.set_ylabel("packets lost (cumulative)")
    a2.legend(loc="upper left", fontsize=8)
    if any_ack:
        a3.legend(loc="upper right", fontsize=8)
    else:
        a3.text(0.5, 0.5, "no command was acknowledged", transform=a3.transAxes, ha="center", color="grey")
    a3.set_ylim(-1.0, max(5.0, most_latency_ms * 1.2))
    a3.set_ylabel("ack latency (ms, log clock)")
    a3.set_xlabel("simulation time (s)")
    for ax in (a1, a2, a3):
        ax.grid(alpha=0.3)
    _save(plt, fig, path)
    return True


def plot_all(report: AuditReport, out_dir: Path) -> list[Path]:
    """Write every plot the log has data for; returns the files written.

    Parameters
    ----------
    report : AuditReport
        What :func:`~lfctl.record.audit.audit` found.
    out_dir : Path
        Where the PNGs go (made if missing).
    """
    from lfctl.data import pyplot

    plt = pyplot()

    c = report.contents
    if not c.channels and not c.metadata:  # nothing readable (not MCAP, empty): no empty plots
        return []
    out_dir.mkdir(parents=True, exist_ok=True)
    made = [out_dir / "trajectories.png"]
    _trajectories(plt, report, made[0])
    for f in _followers(c):  # names of letters, digits, '-', '_': every file stays in out_dir
        for suffix, fn in (("errors", _errors), ("pose", _pose)):
            p = out_dir / f"{f}_{suffix}.png"
            if fn(plt, c, f, p):
                made.append(p)
    if _link(plt, c, out_dir / "link.png"):
        made.append(out_dir / "link.png")
    return made
