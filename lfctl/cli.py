"""The `lfctl` command line. Exit codes: 0 success, 1 the run failed, 2 bad input (usage,
scenario, file). Errors print as one line naming the bad input; `--debug` shows tracebacks."""

from __future__ import annotations

import argparse
import dataclasses
import logging
import math
import os
import runpy
import signal
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from lfctl import __version__
from lfctl.errors import ConfigError, FmuError, LfctlError

if TYPE_CHECKING:
    from lfctl.config import Config
    from lfctl.sim.runner import RunReport

log = logging.getLogger("lfctl")

BENCH_DIR = Path(__file__).resolve().parents[1] / "benchmarks"


def _bench_names() -> list[str]:
    return sorted(p.stem.removeprefix("bench_") for p in BENCH_DIR.glob("bench_*.py"))


# ----------------------------------------------------------------------------------------
# lfctl sim


def _apply_sim_options(cfg: Config, args: argparse.Namespace) -> Config:
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
    return dataclasses.replace(cfg, sim=sim_cfg, guidance=guidance)


def print_report(report: RunReport) -> None:
    """The run summary: run facts, mission progress, one row per follower."""
    from lfctl.sim.runner import SETTLE_S

    cfg, result = report.config, report.result
    print(
        f"scenario     {cfg.name}  (seed {cfg.sim.seed}, {cfg.sim.clock}, sensing {cfg.sim.sensing}, controller {cfg.guidance.controller})"
    )
    print(f"sim time     {result.sim_time_s:.2f} s in {result.ticks} steps of {cfg.sim.dt_s * 1000:g} ms")
    workers = result.extra.get("camera_workers")
    spread = f", cameras in {workers + 1} processes" if workers else ""
    print(f"wall time    {result.wall_time_s:.3f} s  (x{result.real_time_factor:.1f} real time{spread})")
    if report.leader_mode == "auto":
        reached = ", ".join(f"{i + 1}@{t:.1f}s" for i, t in report.waypoints_reached) or "none"
        print(f"leader       AUTO: {len(report.waypoints_reached)}/{report.n_waypoints} waypoints reached ({reached})")
    else:
        print("leader       scripted speed / yaw-rate profile (no [mission] waypoints)")
    if report.metrics and cfg.script.followers == "formation":
        print()
        print(f"errors after {SETTLE_S:g} s settling; bearing is the target's bearing from the follower's heading")
        head = (
            "follower",
            "target",
            "range_m",
            "bearing",
            "rng RMS m",
            "rng max m",
            "brg RMS deg",
            "brg max deg",
            "min sep m",
            "tracking s",
            "occluded s",
            "lost s",
        )
        rows = []
        for m in report.metrics:
            st = m.time_in_state_s
            rows.append((
                m.name, m.target, f"{m.range_cmd_m:.2f}", f"{math.degrees(m.bearing_cmd_rad):.0f}",
                f"{m.range_err_rms_m:.3f}", f"{m.range_err_max_m:.3f}", f"{math.degrees(m.bearing_err_rms_rad):.2f}",
                f"{math.degrees(m.bearing_err_max_rad):.2f}", f"{m.min_separation_m:.2f}",
                f"{st['tracking']:.1f}", f"{st['occluded']:.1f}", f"{st['lost']:.1f}",
            ))  # fmt: skip
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


def cmd_sim(args: argparse.Namespace) -> int:
    from lfctl.config import load_config
    from lfctl.sim.runner import run_scenario

    cfg = _apply_sim_options(load_config(args.scenario), args)
    log.info(
        "scenario %s: %d vehicles, %.1f s, dt %.3g s, %s clock",
        cfg.name,
        len(cfg.vehicles),
        cfg.sim.duration_s,
        cfg.sim.dt_s,
        cfg.sim.clock,
    )
    show = not args.quiet and sys.stderr.isatty()

    def announce(links: object) -> None:
        ports = links.ports  # type: ignore[attr-defined]
        if ports:
            for name, port in ports.items():
                print(
                    f"mavlink      {name}: udpin {cfg.link.udp_host}:{port}"
                    + (f", udpout {cfg.link.gcs_udpout}" if cfg.link.gcs_udpout else ""),
                    flush=True,
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
        if requested.is_set():
            raise KeyboardInterrupt
        requested.set()

    handlers = {sig: signal.signal(sig, ask_stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        if cfg.recording.enabled and not args.no_record:
            from lfctl.record.writer import Recorder, run_path

            path = run_path(cfg)
            with Recorder(path, cfg) as rec:
                report = run_scenario(cfg, progress=progress, recorder=rec, on_links=announce, stop=requested.is_set)
            log.info("recorded %d messages to %s", rec.messages, path)
        else:
            path = None
            report = run_scenario(cfg, progress=progress, on_links=announce, stop=requested.is_set)
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)
    if show:
        print(file=sys.stderr)
    print_report(report)
    if path is not None:
        print(f"\nlog          {path}  ({path.stat().st_size / 1e6:.1f} MB; check it with `lfctl audit {path}`)")
    return 0


# ----------------------------------------------------------------------------------------
# lfctl audit / replay


def cmd_audit(args: argparse.Namespace) -> int:
    import json

    from lfctl.record.audit import audit, check_thresholds, format_report, plot, recover

    if not args.file.exists():
        raise ConfigError(f"{args.file} does not exist")
    report = audit(args.file)
    if args.strict:
        report.findings.extend(check_thresholds(report))
    if args.json:
        print(
            json.dumps(
                {
                    "file": report.path,
                    "ok": report.ok,
                    "findings": [f.__dict__ for f in report.findings],
                    "figures": report.figures,
                },
                indent=1,
            )
        )
    else:
        print(format_report(report))
    if args.plot:
        for p in plot(report, args.plot):
            print(f"plot: {p}", file=sys.stderr)
    if args.recover:
        n = recover(report, args.recover)
        print(f"recovered {n} messages into {args.recover}", file=sys.stderr)
    return 0 if report.ok else 1


def cmd_replay(args: argparse.Namespace) -> int:
    import json

    import cv2
    import numpy as np

    from lfctl.record.audit import audit
    from lfctl.vision.tracker import Tracker, TrackerSettings

    report = audit(args.file)
    c = report.contents
    followers = [f for f in report.figures.get("run", {}).get("followers", "").split(",") if f]
    name = args.follower or (followers[0] if followers else "")
    images = c.messages.get(f"/{name}/camera/image/compressed", [])
    if not images:
        raise ConfigError(
            f"{args.file} has no recorded camera images for follower {name!r} (was it run with sensing = 'camera' and recording.images = true?)"
        )
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage

    recorded = {t: json.loads(d) for t, d in c.messages.get(f"/{name}/tracker", [])}
    kind = {"hue-only": "hue", "hue": "hue", "hs-lbp": "hs-lbp", "full": "full"}[args.tracker]
    tracker = Tracker(TrackerSettings(kind=kind))

    def iou(a: list[int] | None, b: list[int] | None) -> float:
        if not a or not b:
            return 0.0
        ix = max(0, min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]))
        iy = max(0, min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]))
        u = a[2] * a[3] + b[2] * b[3] - ix * iy
        return ix * iy / u if u > 0 else 0.0

    ok_new = ok_old = n = 0
    started = False
    for t, data in images:
        frame = cv2.imdecode(np.frombuffer(CompressedImage.FromString(data).data, np.uint8), cv2.IMREAD_COLOR)
        rec = recorded.get(t, {})
        truth = rec.get("truth_bbox")
        if not started:
            if not truth:
                continue
            st = tracker.init(frame, tuple(truth))
            started = True
            continue
        st = tracker.update(frame)
        if truth and rec.get("truth_visible_fraction", 0) >= 0.5:
            n += 1
            ok_new += iou(list(st.bbox) if st.bbox else None, truth) >= 0.5
            ok_old += iou(rec.get("bbox"), truth) >= 0.5
    if n == 0:
        raise ConfigError(f"{args.file}: no frame with a recorded truth box to score against")
    print(f"replayed {len(images)} frames of {name} from {args.file}")
    print(
        f"  recorded tracker (full):  success {ok_old / n:.3f}  (IoU >= 0.5 on {n} frames with the banner at least half visible)"
    )
    print(f"  replayed tracker ({args.tracker}): success {ok_new / n:.3f}")
    return 0


# ----------------------------------------------------------------------------------------
# lfctl track


def _parse_roi(text: str) -> tuple[int, int, int, int]:
    try:
        parts = [int(p) for p in text.split(",")]
    except ValueError:
        raise ConfigError(f"--roi must be x,y,w,h in whole pixels, got {text!r}") from None
    if len(parts) != 4:
        raise ConfigError(f"--roi must be x,y,w,h (four numbers), got {text!r}")
    return parts[0], parts[1], parts[2], parts[3]


def cmd_track(args: argparse.Namespace) -> int:
    import json

    import cv2
    import numpy as np

    from lfctl.config import CameraConfig, load_config
    from lfctl.sim.camera import BANNER_BACK_M, CameraModel
    from lfctl.vision.frames import FrameError
    from lfctl.vision.pose import paper_pose, pnp_pose, to_vehicle_frame
    from lfctl.vision.tracker import Tracker, TrackerSettings

    source: str | int = int(args.source) if args.source.isdigit() else args.source
    if isinstance(source, str) and "://" not in source and not Path(source).exists():
        raise ConfigError(f"video source {source!r} does not exist (give a file, a camera index or a stream URL)")
    cap = cv2.VideoCapture(source)
    if not cap.isOpened():
        raise ConfigError(
            f"cannot open video source {args.source!r} with OpenCV (unsupported format or no such camera)"
        )
    scen = load_config(args.scenario) if args.scenario else None
    banner = scen.banner if scen else None
    hue = args.marker_hue_deg if args.marker_hue_deg is not None else (banner.marker_hue_deg if banner else 0.0)
    side = banner.side_m if banner else 0.14
    panel = banner.panel_size_m if banner else 0.22
    settings = TrackerSettings(
        kind=args.tracker, marker_hue_deg=hue, panel_over_side=panel / side, use_markers=not args.no_markers
    )
    tracker = Tracker(settings)
    fps = cap.get(cv2.CAP_PROP_FPS) or 30.0
    writer = None
    cam: CameraModel | None = None
    n = 0
    try:
        while args.max_frames is None or n < args.max_frames:
            ok, frame = cap.read()
            if not ok or frame is None:
                break
            if cam is None:
                h, w = frame.shape[:2]
                cam_cfg = scen.camera if scen else CameraConfig(width_px=w, height_px=h)
                if (cam_cfg.width_px, cam_cfg.height_px) != (w, h):
                    cam_cfg = dataclasses.replace(cam_cfg, width_px=w, height_px=h)
                cam = CameraModel.from_config(cam_cfg)
                if args.out:
                    writer = cv2.VideoWriter(str(args.out), cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h))
                    if not writer.isOpened():
                        raise ConfigError(f"cannot write {args.out} (check the directory and the .mp4/.avi extension)")
                if args.roi:
                    st = tracker.init(frame, _parse_roi(args.roi))
                else:
                    found = tracker.init_from_markers(frame)
                    if found is None:
                        raise ConfigError(
                            "no banner (four-marker constellation) in the first frame: give --roi x,y,w,h"
                        )
                    st = found
            else:
                st = tracker.update(frame)
            rec: dict[str, object] = {
                "frame": n,
                "t_s": round(n / fps, 4),
                "state": st.status.value,
                "bbox": list(st.bbox) if st.bbox else None,
                "quality": round(st.quality, 3),
            }
            if st.markers is not None:
                rec["markers"] = np.round(st.markers, 2).tolist()
                pose = pnp_pose(st.markers, cam.K, cam.dist, side) or paper_pose(st.markers, cam.K, side)
                if pose is not None:
                    rng, brg, rel = to_vehicle_frame(pose, cam.mount_body_m, cam.R_body_from_cam, -BANNER_BACK_M)
                    rec["pose"] = {
                        "range_m": round(rng, 4),
                        "bearing_deg": round(math.degrees(brg), 3),
                        "rel_heading_deg": round(math.degrees(rel), 2),
                        "method": pose.method,
                    }
            print(json.dumps(rec), flush=True)
            if writer is not None:
                vis = frame.copy()
                if st.bbox:
                    x, y, w_, h_ = st.bbox
                    colour = (0, 200, 0) if st.status.value == "tracking" else (0, 165, 255)
                    cv2.rectangle(vis, (x, y), (x + w_, y + h_), colour, 2)
                if st.markers is not None:
                    for u, v in st.markers:
                        cv2.circle(vis, (int(u), int(v)), 4, (255, 0, 255), -1)
                cv2.putText(vis, f"{n} {st.status.value}", (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 2)
                writer.write(vis)
            n += 1
    except FrameError as exc:
        raise ConfigError(f"frame {n} of {args.source}: {exc}") from exc
    finally:
        cap.release()
        if writer is not None:
            writer.release()
    if n == 0:
        raise ConfigError(f"video source {args.source!r} gave no frames")
    return 0


# ----------------------------------------------------------------------------------------
# lfctl gcs


def cmd_gcs(args: argparse.Namespace) -> int:
    from lfctl.link.endpoint import signing_key_from_passphrase
    from lfctl.link.gcs import GroundStation
    from lfctl.link.mission import load_mission, save_mission

    key = signing_key_from_passphrase(args.signing_passphrase)
    gcs = GroundStation(args.connect, target_system=args.target, timeout_s=args.timeout, signing_key=key)
    try:
        hb = gcs.wait_heartbeat()
        action = args.action
        if action == "upload":
            items = load_mission(args.file)
            gcs.upload(items)
            print(f"uploaded {len(items) - 1} items (+ home) to system {args.target}")
        elif action == "download":
            items = gcs.download()
            if args.file:
                save_mission(items, args.file)
                print(f"downloaded {len(items)} items to {args.file}")
            else:
                for it in items:
                    print(
                        f"{it.seq:3d} cmd {it.command:3d} frame {it.frame} p1 {it.param1:g} p2 {it.param2:g} lat {it.lat_deg:.7f} lon {it.lon_deg:.7f} alt {it.z:g}"
                    )
        elif action == "clear":
            gcs.clear()
            print("mission cleared")
        elif action in ("mode", "arm", "disarm"):
            result = gcs.set_mode(args.mode) if action == "mode" else gcs.arm(action == "arm")
            name = mav_result_name(result)
            print(f"{action} {args.mode if action == 'mode' else ''}: {name}".replace("  ", " "))
            if name != "MAV_RESULT_ACCEPTED":
                return 1
        elif action == "param":
            if args.param_action == "list":
                for k, v in gcs.param_list().items():
                    print(f"{k:<16} {v:g}")
            elif args.param_action == "get":
                print(f"{args.name} = {gcs.param_get(args.name):g}")
            else:
                got = gcs.param_set(args.name, args.value)
                print(f"{args.name} = {got:g}")
                if abs(got - args.value) > 1e-6:
                    print(
                        f"lfctl: error: {args.name} kept {got:g} (refused {args.value:g}; see the vehicle's STATUSTEXT)",
                        file=sys.stderr,
                    )
                    return 1
        elif action == "watch":
            _watch(gcs, args.count, hb)
        return 0
    finally:
        gcs.close()


def mav_result_name(result: int) -> str:
    from pymavlink.dialects.v20 import ardupilotmega as mav

    e = mav.enums["MAV_RESULT"].get(result)
    return e.name if e else str(result)


def _watch(gcs: object, count: int | None, first: object) -> None:
    """A live table of every vehicle heard: mode, armed, position, speed, formation status."""
    import time

    from lfctl.link.gcs import mode_name

    rows: dict[int, dict[str, object]] = {}
    shown = 0
    next_draw = time.monotonic()
    while count is None or shown < count:
        gcs.heartbeat()  # type: ignore[attr-defined]
        m = gcs._next(0.1)  # type: ignore[attr-defined]
        if m is not None:
            row = rows.setdefault(
                m.get_srcSystem(),
                {
                    "mode": "?",
                    "armed": "?",
                    "lat": 0.0,
                    "lon": 0.0,
                    "speed": 0.0,
                    "rng_err": "",
                    "brg_err": "",
                    "trk_q": "",
                    "text": "",
                },
            )
            kind = m.get_type()
            if kind == "HEARTBEAT" and m.get_srcComponent() == 1:
                row["mode"] = mode_name(m.custom_mode)
                row["armed"] = "armed" if m.base_mode & 128 else "disarmed"
            elif kind == "GLOBAL_POSITION_INT":
                row["lat"], row["lon"] = m.lat / 1e7, m.lon / 1e7
                row["speed"] = math.hypot(m.vx, m.vy) / 100
            elif kind == "NAMED_VALUE_FLOAT":
                name = m.name.decode(errors="replace") if isinstance(m.name, bytes) else m.name
                row[name.rstrip("\x00")] = f"{m.value:.2f}"
            elif kind == "STATUSTEXT":
                row["text"] = (m.text.decode(errors="replace") if isinstance(m.text, bytes) else m.text).rstrip("\x00")
        if time.monotonic() >= next_draw:
            next_draw = time.monotonic() + 1.0
            shown += 1
            print(
                f"{'sys':>3} {'mode':<7} {'armed':<8} {'lat':>12} {'lon':>12} {'m/s':>5} {'rng_err':>7} {'brg_err':>7} {'trk_q':>5}  last message"
            )
            for sysid, r in sorted(rows.items()):
                print(
                    f"{sysid:>3} {r['mode']!s:<7} {r['armed']!s:<8} {r['lat']:>12.7f} {r['lon']:>12.7f} {r['speed']:>5.2f} {r['rng_err']!s:>7} {r['brg_err']!s:>7} {r['trk_q']!s:>5}  {r['text']}"
                )
            print(flush=True)


# ----------------------------------------------------------------------------------------
# lfctl follow


def cmd_follow(args: argparse.Namespace) -> int:
    import cv2

    from lfctl.config import CameraConfig, load_config
    from lfctl.guidance.formation import FormationController
    from lfctl.link.companion import RoverLink, follow_loop
    from lfctl.link.endpoint import signing_key_from_passphrase
    from lfctl.sim.camera import BANNER_BACK_M, CameraModel
    from lfctl.sim.runner import formation_settings
    from lfctl.vision.pose import paper_pose, pnp_pose, to_vehicle_frame
    from lfctl.vision.track_state import RelativeMeasurement, TrackStatus
    from lfctl.vision.tracker import Tracker, TrackerSettings

    cfg = load_config(args.scenario) if args.scenario else None
    if cfg is None:
        from lfctl.config import parse_config

        cfg = parse_config(
            '[[vehicles]]\nname = "leader"\nrole = "leader"\n[[vehicles]]\nname = "rover"\nrole = "follower"\n',
            "follow",
        )
    source: str | int = int(args.camera) if args.camera.isdigit() else args.camera
    cap = cv2.VideoCapture(source)
    if not cap.isOpened():
        raise ConfigError(f"cannot open camera {args.camera!r} (a camera index, video file or stream URL)")
    ok, frame = cap.read()
    if not ok or frame is None:
        raise ConfigError(f"camera {args.camera!r} gave no frame")
    h, w = frame.shape[:2]
    cam_cfg = dataclasses.replace(cfg.camera if args.scenario else CameraConfig(), width_px=w, height_px=h)
    cam = CameraModel.from_config(cam_cfg)
    banner = cfg.banner
    tracker = Tracker(
        TrackerSettings(
            kind="full", marker_hue_deg=banner.marker_hue_deg, panel_over_side=banner.panel_size_m / banner.side_m
        )
    )
    started = [False]
    frames = [0]

    def measure(t_s: float) -> RelativeMeasurement | None:
        ok, img = cap.read()
        if not ok or img is None or (args.max_frames is not None and frames[0] >= args.max_frames):
            return None
        frames[0] += 1
        st = tracker.update(img) if started[0] else tracker.init_from_markers(img)
        if st is None:
            return RelativeMeasurement(t_s, TrackStatus.LOST)
        started[0] = True
        if st.markers is not None and st.status is TrackStatus.TRACKING:
            pose = pnp_pose(st.markers, cam.K, cam.dist, banner.side_m) or paper_pose(st.markers, cam.K, banner.side_m)
            if pose is not None:
                rng, brg, _ = to_vehicle_frame(pose, cam.mount_body_m, cam.R_body_from_cam, -BANNER_BACK_M)
                return RelativeMeasurement(t_s, TrackStatus.TRACKING, rng, brg, pose.quality)
        return RelativeMeasurement(t_s, st.status if st.status is not TrackStatus.TRACKING else TrackStatus.OCCLUDED)

    slot_range = args.range if args.range is not None else 1.5
    controller = FormationController(
        formation_settings(cfg, slot_range, math.radians(args.bearing), cfg.guidance.controller)
    )
    rover = RoverLink(
        args.mavlink,
        target_system=args.target,
        timeout_s=args.timeout,
        signing_key=signing_key_from_passphrase(args.signing_passphrase),
    )
    try:
        rover.start()
        rover.set_guided()
        if args.arm:
            rover.arm()
        steps = follow_loop(rover, measure, controller, 1.0 / args.rate, args.steps)
    finally:
        rover.close()
        cap.release()
    print(f"sent {steps} setpoints; {frames[0]} frames")
    return 0


# ----------------------------------------------------------------------------------------
# lfctl fmu


def cmd_fmu_build(args: argparse.Namespace) -> int:
    from lfctl.sim.fmu_build import available_models, build_model

    names = args.models or available_models()
    for name in names:
        built = build_model(name, args.cache_dir, force=args.force)
        print(f"{built.identifier:<20} FMI 2.0  {built.fmi2}")
        print(f"{'':<20} FMI 3.0  {built.fmi3}")
    return 0


def cmd_fmu_info(args: argparse.Namespace) -> int:
    from lfctl.sim.fmu import FmuLibrary
    from lfctl.sim.fmu_build import available_models, build_model

    target = args.fmu
    path = Path(target)
    if not path.is_file():
        if target in available_models():
            path = build_model(target, args.cache_dir).path(args.fmi_version)
        else:
            raise ConfigError(
                f"{target!r} is neither an FMU file nor a built-in model ({', '.join(available_models())})"
            )
    md = FmuLibrary.describe(path)
    cs = md.coSimulation
    print(f"{path}")
    print(f"model        {md.modelName}  (FMI {md.fmiVersion}, {'Co-Simulation' if cs else 'no Co-Simulation'})")
    if md.description:
        print(f"description  {md.description}")
    print(f"generated by {md.generationTool or '?'}")
    print()
    rows = []
    for v in md.modelVariables:
        unit = getattr(v, "unit", None) or (
            v.declaredType.unit
            if getattr(v, "declaredType", None) is not None and getattr(v.declaredType, "unit", None)
            else ""
        )
        start = "" if v.start is None else str(v.start)
        rows.append(
            (
                v.name,
                str(v.valueReference),
                v.causality or "",
                v.variability or "",
                v.type,
                unit or "",
                start,
                v.description or "",
            )
        )
    header = ("name", "vr", "causality", "variability", "type", "unit", "start", "description")
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header) - 1)]
    for r in [header, *rows]:
        print("  ".join(c.ljust(w) for c, w in zip(r[:-1], widths, strict=True)) + "  " + r[-1])
    return 0


# ----------------------------------------------------------------------------------------
# lfctl bench


def cmd_bench(args: argparse.Namespace) -> int:
    import json
    import subprocess

    names = _bench_names()
    chosen = [args.name] if args.name else names
    for name in chosen:
        if name not in names:
            raise ConfigError(f"unknown benchmark {name!r} (known: {', '.join(names)})")
    if args.name:  # one benchmark: run it here, its output is the result
        print(f"== lfctl bench {args.name}", flush=True)
        argv = sys.argv
        try:
            sys.argv = [f"bench_{args.name}.py", *(["--quick"] if args.quick else [])]
            runpy.run_path(str(BENCH_DIR / f"bench_{args.name}.py"), run_name="__main__")
        finally:
            sys.argv = argv
        return 0
    # all of them, each in its own process, collected into bench-results.md / .json
    md = ["# lfctl bench results", ""]
    results: dict[str, object] = {}
    failed = []
    for name in chosen:
        print(f"== lfctl bench {name}", flush=True)
        cmd = [sys.executable, str(BENCH_DIR / f"bench_{name}.py"), *(["--quick"] if args.quick else [])]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        print(proc.stdout, end="", flush=True)
        lines = proc.stdout.strip().splitlines()
        if proc.returncode != 0 or not lines or not lines[-1].startswith("{"):
            failed.append(name)
            print(proc.stderr[-2000:], file=sys.stderr)
            md += [f"## {name}", "", f"FAILED (exit {proc.returncode})", ""]
            continue
        results[name] = json.loads(lines[-1])
        md += [f"## {name}", "", *lines[:-1], ""]
    Path("bench-results.md").write_text("\n".join(md) + "\n")
    Path("bench-results.json").write_text(json.dumps(results, indent=1) + "\n")
    print("wrote bench-results.md and bench-results.json")
    if failed:
        raise LfctlError(f"benchmarks failed: {', '.join(failed)}")
    return 0


# ----------------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="lfctl", description="Vision-guided leader-follower ground robots: co-simulation, tools, benchmarks."
    )
    p.add_argument("--version", action="version", version=f"lfctl {__version__}")
    p.add_argument("--debug", action="store_true", help="show tracebacks and debug logging")
    p.add_argument("-v", "--verbose", action="store_true", help="log progress messages (INFO)")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    s = sub.add_parser(
        "sim",
        help="run a scenario and print a summary",
        description="Run a scenario file (TOML) in the co-simulation and print a summary.",
    )
    s.add_argument("scenario", type=Path, help="scenario TOML file, e.g. examples/convoy.toml")
    s.add_argument(
        "--duration", type=float, metavar="S", help="simulated seconds (default: the scenario's sim.duration_s)"
    )
    s.add_argument("--seed", type=int, metavar="N", help="random seed (default: the scenario's sim.seed)")
    s.add_argument("--realtime", action="store_true", help="pace the run to the wall clock")
    s.add_argument(
        "--sensing", choices=("truth", "camera"), help="where followers' range/bearing come from (default: sim.sensing)"
    )
    s.add_argument(
        "--controller",
        choices=("smc", "p"),
        help="follower control law: sliding mode or the P baseline (default: guidance.controller)",
    )
    s.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    s.add_argument("--no-record", action="store_true", help="do not write the MCAP log (default: [recording] enabled)")
    s.set_defaults(func=cmd_sim)

    g = sub.add_parser(
        "gcs",
        help="a MAVLink ground station: missions, modes, arming, parameters, a live table",
        description="Talk to a vehicle (lfctl sim --realtime, or a real ArduPilot rover) as system 255, component 190.",
    )
    g.add_argument(
        "--connect",
        default="udpout:127.0.0.1:14561",
        help="pymavlink connection (default: the leader of lfctl sim --realtime)",
    )
    g.add_argument("--target", type=int, default=1, help="target system id (leader 1, follower n: 1+n)")
    g.add_argument("--timeout", type=float, default=5.0, help="seconds to wait for each answer")
    g.add_argument("--signing-passphrase", help="MAVLink 2 signing: the vehicle's [link] signing_passphrase")
    gsub = g.add_subparsers(dest="action", required=True, metavar="ACTION")
    gu = gsub.add_parser("upload", help="upload a mission (QGC WPL 110 .waypoints/.txt or .plan)")
    gu.add_argument("file", type=Path)
    gd = gsub.add_parser("download", help="download the mission (print it, or save to FILE)")
    gd.add_argument("file", type=Path, nargs="?")
    gsub.add_parser("clear", help="clear the mission")
    gm = gsub.add_parser("mode", help="set the mode: MANUAL, HOLD, AUTO, GUIDED")
    gm.add_argument("mode", type=str.upper, choices=("MANUAL", "HOLD", "AUTO", "GUIDED"))
    gsub.add_parser("arm", help="arm")
    gsub.add_parser("disarm", help="disarm")
    gp = gsub.add_parser("param", help="parameters: list, get NAME, set NAME VALUE")
    gps = gp.add_subparsers(dest="param_action", required=True, metavar="OP")
    gps.add_parser("list")
    gpg = gps.add_parser("get")
    gpg.add_argument("name")
    gpsv = gps.add_parser("set")
    gpsv.add_argument("name")
    gpsv.add_argument("value", type=float)
    gw = gsub.add_parser("watch", help="live table of every vehicle heard (Ctrl-C to stop)")
    gw.add_argument("--count", type=int, help="stop after this many refreshes")
    g.set_defaults(func=cmd_gcs)

    fo = sub.add_parser(
        "follow",
        help="the follower stack on a real rover: camera -> tracker -> formation control -> GUIDED setpoints",
        description="Run the follower's vision and guidance against a real ArduPilot rover (or lfctl sim --realtime) as its companion computer (component 191).",
    )
    fo.add_argument(
        "--mavlink", required=True, help="connection to the rover, e.g. udpout:ROVER_IP:14550 or /dev/ttyUSB0,921600"
    )
    fo.add_argument("--camera", default="0", help="camera index, video file or stream URL (default 0)")
    fo.add_argument("--target", type=int, default=1, help="the rover's system id (default 1)")
    fo.add_argument("--scenario", type=Path, help="camera intrinsics, banner and guidance gains from this scenario")
    fo.add_argument("--range", type=float, help="commanded range to the leader, m (default 1.5)")
    fo.add_argument("--bearing", type=float, default=0.0, help="commanded bearing to the leader, deg (default 0)")
    fo.add_argument("--rate", type=float, default=20.0, help="setpoint rate, Hz (10-20; default 20)")
    fo.add_argument("--arm", action="store_true", help="also arm the rover (default: you arm it)")
    fo.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for the rover's heartbeat")
    fo.add_argument("--signing-passphrase", help="MAVLink 2 signing: the passphrase the rover's key was set up with")
    fo.add_argument("--max-frames", type=int, help="stop after this many camera frames")
    fo.add_argument("--steps", type=int, help="stop after this many setpoints")
    fo.set_defaults(func=cmd_follow)

    a = sub.add_parser(
        "audit",
        help="check a run's MCAP log: integrity, provenance, formation/link/mission figures",
        description="Audit an MCAP run log. Exit 0 when intact (and, with --strict, within the scenario's limits), 1 otherwise.",
    )
    a.add_argument("file", type=Path, help="an .mcap log (logs/<run>.mcap)")
    a.add_argument("--json", action="store_true", help="machine-readable report")
    a.add_argument("--plot", type=Path, metavar="DIR", help="write PNG plots here")
    a.add_argument("--strict", action="store_true", help="also fail when the scenario's [audit] limits are exceeded")
    a.add_argument("--recover", type=Path, metavar="OUT", help="write every intact record into a new, finished file")
    a.set_defaults(func=cmd_audit)

    rp = sub.add_parser(
        "replay",
        help="re-run a tracker on a log's recorded camera frames and compare",
        description="Decode the recorded camera frames and run a tracker on them; compare with the recorded track and the truth.",
    )
    rp.add_argument("file", type=Path, help="an .mcap log recorded with sensing = 'camera'")
    rp.add_argument(
        "--tracker",
        choices=("full", "hs-lbp", "hue-only", "hue"),
        default="full",
        help="tracker to replay (default: full)",
    )
    rp.add_argument("--follower", help="which follower's camera (default: the first)")
    rp.set_defaults(func=cmd_replay)

    t = sub.add_parser(
        "track",
        help="run the tracker on a video file, camera index or stream; JSON line per frame",
        description="Track the leader's banner (or any object from --roi) in a video; prints one JSON line per frame and can write an annotated video.",
    )
    t.add_argument("source", help="video file, camera index (0) or stream URL")
    t.add_argument("--roi", help="initial window x,y,w,h in pixels (default: find the banner's four markers)")
    t.add_argument("--out", type=Path, help="write an annotated video here (.mp4 or .avi)")
    t.add_argument("--tracker", choices=("full", "hs-lbp", "hue"), default="full", help="tracker kind (default: full)")
    t.add_argument("--no-markers", action="store_true", help="histogram path only (objects without the banner)")
    t.add_argument("--marker-hue-deg", type=float, help="marker hue, degrees (default: the scenario's, else red 0)")
    t.add_argument("--scenario", type=Path, help="take camera intrinsics and banner geometry from this scenario")
    t.add_argument("--max-frames", type=int, help="stop after this many frames")
    t.set_defaults(func=cmd_track)

    f = sub.add_parser(
        "fmu",
        help="build the vehicle FMUs or inspect any FMU",
        description="Build the built-in vehicle FMUs, or list an FMU's variables.",
    )
    fsub = f.add_subparsers(dest="fmu_command", required=True, metavar="ACTION")
    fb = fsub.add_parser("build", help="compile the built-in models to FMI 2.0 and 3.0 FMUs (cached)")
    fb.add_argument("models", nargs="*", help="models to build (default: all)")
    fb.add_argument("--force", action="store_true", help="rebuild even when cached")
    fb.add_argument("--cache-dir", type=Path, help="cache root (default: the user cache dir)")
    fb.set_defaults(func=cmd_fmu_build)
    fi = fsub.add_parser("info", help="list an FMU's variables with units (a file, or a built-in model name)")
    fi.add_argument("fmu", help="an .fmu file or a built-in model name such as SkidSteerRover")
    fi.add_argument(
        "--fmi-version", type=int, choices=(2, 3), default=2, help="for a built-in model: which FMI version"
    )
    fi.add_argument("--cache-dir", type=Path, help="cache root (default: the user cache dir)")
    fi.set_defaults(func=cmd_fmu_info)

    b = sub.add_parser(
        "bench",
        help="run benchmarks (all, or one by name)",
        description=f"Run the benchmarks in benchmarks/ ({', '.join(_bench_names())}); each prints a table and a JSON line.",
    )
    b.add_argument("name", nargs="?", help="one benchmark (default: all)")
    b.add_argument("--quick", action="store_true", help="shorter runs (for a smoke check)")
    b.set_defaults(func=cmd_bench)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.DEBUG if args.debug else (logging.INFO if args.verbose else logging.WARNING)

    # SIGTERM ends a run like Ctrl-C: the recorder's `with` block finishes the log file
    def _terminate(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, _terminate)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(args.func(args))
    except KeyboardInterrupt:
        print("lfctl: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # `lfctl ... | head`: the reader left; not an error of ours
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except (ConfigError, FileNotFoundError) as exc:
        if args.debug:
            raise
        print(f"lfctl: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a port in use, a directory not writable
        if args.debug:
            raise
        print(f"lfctl: error: {exc}", file=sys.stderr)
        return 1
    except (FmuError, LfctlError) as exc:
        if args.debug:
            raise
        print(f"lfctl: error: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
