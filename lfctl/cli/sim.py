"""`lfctl sim`: run a scenario closed loop, print the summary, record the log."""

from __future__ import annotations

import argparse
import dataclasses
import logging
import math
import shlex
import signal
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lfctl.cli import stopped_by
from lfctl.cli.options import command, integer, number, whole_path
from lfctl.data import example_names, examples_dir

if TYPE_CHECKING:
    from lfctl.config import Config
    from lfctl.sim.runner import RunReport

log = logging.getLogger("lfctl")


def register(sub: Any) -> None:
    """Add the ``sim`` command to the parser."""
    s = sub.add_parser(
        "sim",
        help="run a scenario and print a summary",
        description="Run a scenario (a TOML file, or a shipped example by name: "
        f"{', '.join(example_names()) or 'none found'}) in the co-simulation and print a summary.",
        epilog=f"The shipped examples (copy one to edit it): {whole_path(examples_dir())}",
    )
    s.add_argument(
        "scenario", help="scenario TOML file, or the name of a shipped example such as convoy, column5 or vee"
    )
    s.add_argument(
        "--duration",
        type=number(0, 1e6, lo_open=True, unit="s"),
        metavar="S",
        help="simulated seconds (default: the scenario's sim.duration_s)",
    )
    s.add_argument(
        "--seed", type=integer(0, 2**63 - 1), metavar="N", help="random seed (default: the scenario's sim.seed)"
    )
    s.add_argument("--realtime", action="store_true", help="pace the run to the wall clock")
    s.add_argument(
        "--sensing", choices=("truth", "camera"), help="where followers' range/bearing come from (default: sim.sensing)"
    )
    s.add_argument(
        "--controller",
        choices=("smc", "p", "trail"),
        help="follower control law: sliding mode, the P baseline, or the target's trail (default: guidance.controller)",
    )
    s.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    s.add_argument("--no-record", action="store_true", help="do not write the MCAP log (default: [recording] enabled)")
    s.add_argument(
        "--live",
        nargs="?",
        const="",
        metavar="HOST:PORT",
        help="serve the run on a Foxglove WebSocket while it runs, with the log's messages "
        "(default: [live] foxglove, 127.0.0.1:8765; port 0: any free port)",
    )
    s.add_argument(
        "--video",
        nargs="?",
        const="",
        metavar="HOST:PORT",
        help="stream each follower's camera as RTP/UDP H.264 to a ground station, follower k to PORT + 2 (k - 1) "
        "(default: [live] video, 127.0.0.1:5600, QGroundControl's; camera sensing); with --realtime a MAVLink "
        "camera component announces it",
    )
    s.add_argument(
        "--image-format", choices=("h264", "jpeg"), help="how the log records camera frames (default: [recording])"
    )
    s.set_defaults(func=run)


def apply_options(cfg: Config, args: argparse.Namespace) -> Config:
    """The scenario with the command line's overrides."""
    sim_cfg = cfg.sim
    if args.seed is not None:
        sim_cfg = dataclasses.replace(sim_cfg, seed=args.seed)
    if args.duration is not None:
        sim_cfg = dataclasses.replace(sim_cfg, duration_s=args.duration)
    if args.realtime:
        sim_cfg = dataclasses.replace(sim_cfg, clock="realtime")
    if args.sensing is not None:
        sim_cfg = dataclasses.replace(sim_cfg, sensing=args.sensing)
    guidance = cfg.guidance
    if args.controller is not None:
        guidance = dataclasses.replace(guidance, controller=args.controller)
    recording = cfg.recording
    if getattr(args, "image_format", None) is not None:
        recording = dataclasses.replace(recording, image_format=args.image_format)
    return dataclasses.replace(cfg, sim=sim_cfg, guidance=guidance, recording=recording)


def live_address(value: str | None, default: str, option: str) -> tuple[str, int] | None:
    """``--live`` / ``--video``'s address: None when the option was not given, the scenario's
    default when it was given without a value; ConfigError for a value that is not HOST:PORT.

    Parameters
    ----------
    value : str or None
        What the command line said (``""`` for the option alone).
    default : str
        The scenario's ``[live]`` address.
    option : str
        The option's name, for the error.
    """
    from lfctl.config import parse_host_port

    if value is None:
        return None
    return parse_host_port(value or default, option)


def announce_live(port: int, host: str, layout: Path) -> None:
    """Say where Foxglove connects, and which layout to open (see :func:`live_layout`)."""
    if ":" in host and not host.startswith("["):
        host = f"[{host}]"  # an IPv6 address, as a URL writes it (ws://::1:8765 is no URL)
    print(f"foxglove     ws://{host}:{port}  (layout: {layout})", flush=True)


def live_layout(follower: str | None, leader: str, image_format: str, camera: bool = True, scene: bool = True) -> Path:
    """The Foxglove layout that shows this run: the shipped one when its names fit
    (``follower1`` behind ``leader``, H.264), else one made for it in the user cache
    (``~/.cache/lfctl/layouts``).

    Parameters
    ----------
    follower : str or None
        Whose camera and errors the layout shows; None (no follower): the leader's views alone.
    leader : str
        The vehicle its 3D view follows.
    image_format : str
        ``h264`` or ``jpeg``, as ``[recording] image_format``.
    camera : bool
        The run has a camera (camera sensing); without one the layout has no camera panel.
    scene : bool
        The run publishes ``/scene`` (``lfctl follow`` does not).
    """
    from lfctl.data import cache_error, examples_dir, user_cache
    from lfctl.record.layout import layout_json

    if (follower, leader, image_format, camera, scene) == ("follower1", "leader", "h264", True, True):
        return examples_dir() / "foxglove-layout.json"
    kind = (image_format if camera else "no-camera") + ("" if scene else "-no-scene")
    name = f"{leader}-{follower}-{kind}" if follower is not None else f"{leader}-alone"
    path = user_cache("layouts") / f"{name}.json"
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(layout_json(follower, leader, image_format, camera, scene))
    except OSError as exc:
        raise cache_error(path.parent, exc) from None
    return path


def print_report(report: RunReport) -> None:
    """The run summary: run facts, mission progress, one row per follower, final poses."""
    from lfctl.metrics import SETTLE_S

    cfg, result = report.config, report.result
    print(
        f"scenario     {cfg.name}  (seed {cfg.sim.seed}, {cfg.sim.clock}, sensing {cfg.sim.sensing}, controller {cfg.guidance.controller})"
    )
    print(f"sim time     {result.sim_time_s:.2f} s in {result.ticks} steps of {cfg.sim.dt_s * 1000:g} ms")
    workers = result.extra.get("camera_workers")
    spread = f", cameras in {workers + 1} processes" if isinstance(workers, int) and workers else ""
    print(f"wall time    {result.wall_time_s:.3f} s  (x{result.real_time_factor:.1f} real time{spread})")
    modes = ", ".join(f"{name} {secs:.1f} s" for name, secs in report.leader_modes) or "none"
    if report.leader_mode == "auto":
        reached = ", ".join(f"{i + 1}@{round(t, 2)}s" for i, t in report.waypoints_reached) or "none"
        print(f"leader       {modes}; {report.n_reached}/{report.n_waypoints} waypoints reached ({reached})")
    else:
        print(f"leader       {modes}; scripted speed / yaw-rate profile (no [mission] waypoints)")
    for c in report.mission_changes:
        what = f"edited ({c.items} items)" if c.edit else f"replaced ({c.items} items)" if c.items else "cleared"
        print(f"             {c.kind} {what} by system {c.sysid} at {c.t_s:.1f} s")
    if report.metrics and cfg.script.followers == "formation":
        print()
        print(
            f"errors after {SETTLE_S:g} s settling (min sep over the whole run);"
            " bearing is the target's bearing from the follower's heading"
        )
        print("path RMS: the follower's distance from the path its target drove, less the slot's sideways offset")
        head = (
            "follower", "target", "range_m", "bearing", "rng RMS m", "rng max m", "brg RMS deg", "brg max deg",
            "min sep m", "path RMS m", "tracking s", "occluded s", "lost s",
        )  # fmt: skip

        def num(value: float | None, fmt: str, scale: float = 1.0) -> str:
            return "-" if value is None else format(value * scale, fmt)

        deg = math.degrees(1.0)
        rows = []
        outside = {v.name for v in cfg.followers if not v.companion}
        for m in report.metrics:
            st = m.time_in_state_s  # (None for a follower whose companion ran outside: it tracked there)
            rows.append((
                m.name, m.target, f"{m.range_cmd_m:.2f}", f"{math.degrees(m.bearing_cmd_rad):.0f}",
                num(m.range_err_rms_m, ".3f"), num(m.range_err_max_m, ".3f"), num(m.bearing_err_rms_rad, ".2f", deg),
                num(m.bearing_err_max_rad, ".2f", deg), num(m.min_separation_m, ".2f"), num(m.path_err_rms_m, ".3f"),
                num(st["tracking"], ".2f"), num(st["occluded"], ".2f"), num(st["lost"], ".2f"),  # steps of dt: exact
            ))  # fmt: skip
        if outside:
            print(
                f"{', '.join(sorted(outside))}: its companion ran outside the simulator: the errors are the truth "
                "of how it drove; its tracking is in that companion's closing line"
            )
        widths = [max(len(str(r[i])) for r in [head, *rows]) for i in range(len(head))]
        for r in [head, *rows]:
            print(
                "  ".join(
                    str(c).rjust(w) if i > 1 else str(c).ljust(w)
                    for i, (c, w) in enumerate(zip(r, widths, strict=True))
                )
            )
    print()
    print(f"{'vehicle':<12} {'north_m':>9} {'east_m':>9} {'yaw_deg':>8} {'speed_mps':>10}")
    for i, name in enumerate(result.names):
        st = result.final.vehicle(i)
        print(f"{name:<12} {st.north_m:9.3f} {st.east_m:9.3f} {math.degrees(st.yaw_rad):8.2f} {st.speed_mps:10.3f}")


def run(args: argparse.Namespace) -> int:
    """Run the scenario; print the summary and where the log went."""
    from lfctl.config import load_config
    from lfctl.data import resolve_scenario
    from lfctl.record.writer import run_path
    from lfctl.sim.runner import check_video, run_scenario, stream_port
    from lfctl.sim.watchdog import BlockedCallWatchdog

    path = resolve_scenario(args.scenario)
    scenario_file = path  # (``path`` becomes the log's below)
    if path != Path(args.scenario):  # a name, not a file here: say which file runs
        print(f"lfctl sim: {args.scenario} is the shipped example {path}", file=sys.stderr)
    cfg = apply_options(load_config(path), args)
    log.info(
        "scenario %s: %d vehicles, %.1f s, dt %.3g s, %s clock",
        cfg.name,
        len(cfg.vehicles),
        cfg.sim.duration_s,
        cfg.sim.dt_s,
        cfg.sim.clock,
    )
    show = not args.quiet and sys.stderr.isatty()

    def announce(links: Any) -> None:
        for name, port in links.ports.items():
            print(
                f"mavlink      {name}: udpin {cfg.link.udp_host}:{port}"
                + (f", udpout {cfg.link.gcs_udpout}" if cfg.link.gcs_udpout else ""),
                flush=True,
            )
        here = "127.0.0.1" if cfg.link.udp_host in ("0.0.0.0", "") else cfg.link.udp_host  # (all addresses)
        slots = cfg.slots()
        for k, v in enumerate(cfg.followers):
            port = links.ports.get(v.name)
            if v.companion or port is None:
                continue
            # its companion is the user's: say how to start lfctl follow on it, camera and all
            camera = (
                f"rtp://{video[0]}:{stream_port(video[1], k)}"
                if video is not None
                else "SOURCE (or --video for its camera)"
            )
            slot = slots[v.name]
            signs = bool(cfg.link.signing_passphrase)
            signing = " --signing-passphrase PASSPHRASE" if signs else ""
            signing_note = " (PASSPHRASE: the scenario's link.signing_passphrase)" if signs else ""
            print(
                f"{v.name:<12} has no companion: waits in HOLD, disarmed, for one: `lfctl follow --mavlink "
                f"udpout:{here}:{port} --target {cfg.vehicles.index(v) + 1} --scenario {shlex.quote(str(scenario_file))} "
                f"--follower {v.name} --camera {camera} --range {slot.range_m:g} "
                f"--bearing {math.degrees(slot.bearing_rad):g} --arm{signing}`{signing_note}",
                flush=True,
            )
        leader_port = links.ports.get(cfg.leader.name)
        if cfg.sim.clock == "realtime" and leader_port is not None and cfg.mission.waypoints:
            # a ground station starts the mission, as on a Rover: say how, or the scene never moves
            host = "127.0.0.1" if cfg.link.udp_host in ("0.0.0.0", "") else cfg.link.udp_host  # (all addresses)
            gcs = f"lfctl gcs --connect udpout:{host}:{leader_port}"
            print(
                f"leader       waits in HOLD, disarmed, its mission stored: `{gcs} mode AUTO`, then `arm`", flush=True
            )

    def progress(t_s: float, wall_s: float) -> None:
        if show:
            rtf = t_s / wall_s if wall_s > 0 else math.inf
            bar = "#" * int(30 * t_s / cfg.sim.duration_s)
            print(
                f"\r[{bar:<30}] {t_s:6.1f}/{cfg.sim.duration_s:.1f} s  x{rtf:7.1f} real time", end="", file=sys.stderr
            )

    # Ctrl-C / SIGTERM ask the run to stop after the current step, so the interrupt never
    # lands inside a write and the log is finished; a second one stops at once
    requested = threading.Event()

    def ask_stop(signum: int, frame: object) -> None:
        stopped_by(signum)
        if requested.is_set():
            raise KeyboardInterrupt
        requested.set()

    live = live_address(args.live, cfg.live.foxglove, "--live")
    video = live_address(args.video, cfg.live.video, "--video")
    first = cfg.followers[0].name if cfg.followers else None
    camera = cfg.sim.sensing == "camera" and cfg.recording.images  # (no images: no camera panel)
    layout = live_layout(first, cfg.leader.name, cfg.recording.image_format, camera) if live is not None else Path()
    check_video(cfg, video)  # refused before it is announced
    if video is not None:
        for k, v in enumerate(cfg.followers):
            print(f"video        {v.name}: RTP/UDP H.264 to {video[0]}:{stream_port(video[1], k)}", flush=True)
    if (live is not None or video is not None) and cfg.sim.clock != "realtime":
        print(
            "note: lockstep runs as fast as it can, and the live view and video go as fast with it;"
            " --realtime paces them for a viewer or a player",
            file=sys.stderr,
            flush=True,
        )
    path: Path | None = run_path(cfg) if cfg.recording.enabled and not args.no_record else None
    handlers = {sig: signal.signal(sig, ask_stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    logged: list[Path] = []
    try:  # an FMU stuck in a step ignores the handlers: the watchdog ends the run instead
        with BlockedCallWatchdog():
            report = run_scenario(
                cfg,
                progress=progress,
                record_to=path,
                on_links=announce,
                stop=requested.is_set,
                live=live,
                video=video,
                on_live=lambda port: announce_live(port, live[0], layout) if live is not None else None,
                on_log=logged.append,
            )
    except KeyboardInterrupt:
        if logged and logged[0].exists():  # finished, "interrupted" in its end metadata
            print(
                f"\nlog          {logged[0]}  (interrupted; check it with `{command('lfctl', 'audit', logged[0])}`)",
                flush=True,
            )
        raise
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)
    if show:
        print(file=sys.stderr)
    print_report(report)
    if report.log_path is not None:
        log.info("recorded %d messages to %s", report.log_messages, report.log_path)
        size_mb = report.log_path.stat().st_size / 1e6
        print(
            f"\nlog          {report.log_path}  ({size_mb:.1f} MB; check it with `{command('lfctl', 'audit', report.log_path)}`)"
        )
    return 0
