"""The closed loop: leader autopilot, each follower's sensor and formation controller, wired
into the co-simulation master; and the per-follower metrics the summary and tests use."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lfctl.config import Config
from lfctl.errors import ConfigError
from lfctl.frames import wrap_pi
from lfctl.guidance.formation import FormationController, FormationSettings, Odometry
from lfctl.guidance.leader import AutopilotSettings, LeaderAutopilot
from lfctl.guidance.smc import BearingGains, RangeGains
from lfctl.link.endpoint import MODES, packet_record
from lfctl.link.mission import Leg, to_legs
from lfctl.record.writer import Recorder
from lfctl.sim.camera_pool import CameraJob, CameraPool, default_workers
from lfctl.sim.camera_sensor import CameraSample
from lfctl.sim.cosim import RunResult, Simulation
from lfctl.sim.links import Links
from lfctl.sim.scripted import scripted_command
from lfctl.sim.sensing import TruthSensor
from lfctl.sim.world import WorldState
from lfctl.vision.track_state import TrackStatus

SETTLE_S = 5.0
#: a yaw-rate command swinging across +-this counts as one chattering sign change
CHATTER_DEADBAND_RADPS = 0.02


def sign_changes(values: np.ndarray, deadband: float) -> int:
    """Swings from above ``+deadband`` to below ``-deadband`` or back (noise inside is ignored)."""
    outside = np.sign(values[np.abs(values) > deadband])
    return int(np.count_nonzero(outside[1:] != outside[:-1])) if outside.size > 1 else 0


@dataclass
class FollowerTrace:
    """What one follower did, sampled at the guidance rate."""

    name: str
    target: str
    range_cmd_m: float
    bearing_cmd_rad: float
    t_s: list[float] = dataclasses.field(default_factory=list)
    range_m: list[float] = dataclasses.field(default_factory=list)  # truth
    bearing_rad: list[float] = dataclasses.field(default_factory=list)  # truth
    separation_m: list[float] = dataclasses.field(default_factory=list)  # to the nearest vehicle
    status: list[TrackStatus] = dataclasses.field(default_factory=list)
    speed_cmd_mps: list[float] = dataclasses.field(default_factory=list)
    yaw_rate_cmd_radps: list[float] = dataclasses.field(default_factory=list)
    speed_mps: list[float] = dataclasses.field(default_factory=list)


@dataclass(frozen=True)
class FollowerMetrics:
    """Formation quality of one follower (errors after ``SETTLE_S``)."""

    name: str
    target: str
    range_cmd_m: float
    bearing_cmd_rad: float
    range_err_rms_m: float
    range_err_max_m: float
    bearing_err_rms_rad: float
    bearing_err_max_rad: float
    min_separation_m: float
    time_in_state_s: dict[str, float]
    control_effort_rad: float  # integral of |yaw-rate command|
    chattering_per_s: float  # sign changes of the yaw-rate command per second


def follower_metrics(tr: FollowerTrace, dt_s: float, settle_s: float = SETTLE_S) -> FollowerMetrics:
    """Metrics of one trace (pure)."""
    t = np.asarray(tr.t_s)
    keep = t >= settle_s
    r_err = np.asarray(tr.range_m)[keep] - tr.range_cmd_m
    b_err = np.array([wrap_pi(b - tr.bearing_cmd_rad) for b in np.asarray(tr.bearing_rad)[keep]])
    yaw_cmd = np.asarray(tr.yaw_rate_cmd_radps)
    flips = sign_changes(yaw_cmd, CHATTER_DEADBAND_RADPS)
    duration = len(t) * dt_s
    states = {s.value: 0.0 for s in TrackStatus}
    for s in tr.status:
        states[s.value] += dt_s

    def rms(a: np.ndarray) -> float:
        return float(np.sqrt(np.mean(a**2))) if a.size else math.nan

    def amax(a: np.ndarray) -> float:
        return float(np.max(np.abs(a))) if a.size else math.nan

    return FollowerMetrics(
        tr.name,
        tr.target,
        tr.range_cmd_m,
        tr.bearing_cmd_rad,
        rms(r_err),
        amax(r_err),
        rms(b_err),
        amax(b_err),
        float(np.min(tr.separation_m)) if tr.separation_m else math.nan,
        states,
        float(np.sum(np.abs(yaw_cmd)) * dt_s),
        flips / duration if duration > 0 else 0.0,
    )


@dataclass
class RunReport:
    """A closed-loop run: the co-simulation result, follower traces and metrics, mission progress."""

    config: Config
    result: RunResult
    traces: list[FollowerTrace]
    metrics: list[FollowerMetrics]
    waypoints_reached: list[tuple[int, float]]
    n_waypoints: int
    leader_mode: str  # "auto" (mission) or "script"


def formation_settings(cfg: Config, range_cmd_m: float, bearing_cmd_rad: float, controller: str) -> FormationSettings:
    """The formation controller settings a scenario asks for."""
    g = cfg.guidance
    return FormationSettings(
        range_cmd_m=range_cmd_m,
        bearing_cmd_rad=bearing_cmd_rad,
        controller=controller,  # type: ignore[arg-type]
        range=RangeGains(
            eta_mps=g.range_eta_mps,
            phi_m=g.range_phi_m,
            min_speed_mps=-g.reverse_speed_mps,
            max_speed_mps=g.max_speed_mps,
            min_cos_bearing=g.min_cos_bearing,
        ),
        bearing=BearingGains(
            eta_radps=g.bearing_eta_radps,
            lam_s=g.bearing_lambda_s,
            phi_rad=g.bearing_phi_rad,
            max_yaw_rate_radps=g.max_yaw_rate_radps,
        ),
        p_gain_per_s=g.p_gain,
        coast_s=g.coast_s,
        slowdown_s=g.slowdown_s,
        meas_sigma_m=max(0.02, cfg.sensing.range_noise_m * 2),
    )


def autopilot_settings(cfg: Config) -> AutopilotSettings:
    """The leader AUTO settings a scenario asks for."""
    g, m = cfg.guidance, cfg.mission
    return AutopilotSettings(
        cruise_speed_mps=min(m.cruise_speed_mps, g.max_speed_mps),
        acceptance_radius_m=m.acceptance_radius_m,
        lookahead_m=m.lookahead_m if m.lookahead_m > 0 else None,
        turn_slowdown=g.turn_slowdown,
        heading=BearingGains(
            eta_radps=g.heading_eta_radps,
            lam_s=g.heading_lambda_s,
            phi_rad=g.heading_phi_rad,
            max_yaw_rate_radps=g.max_yaw_rate_radps,
        ),
    )


def run_scenario(
    cfg: Config,
    *,
    controller: str | None = None,
    realtime: bool | None = None,
    duration_s: float | None = None,
    progress: Callable[[float, float], None] | None = None,
    cache_dir: Path | None = None,
    on_frame: Callable[[str, CameraSample], None] | None = None,
    recorder: Recorder | None = None,
    on_links: Callable[[Links], None] | None = None,
    stop: Callable[[], bool] | None = None,
) -> RunReport:
    """Run a scenario closed loop and return the report.

    Every vehicle is a MAVLink endpoint: the leader flies the mission its endpoint holds (in
    lockstep uploaded at t = 0 through the mission protocol), each follower obeys the
    SET_POSITION_TARGET_LOCAL_NED its companion sends. ``on_links`` sees the endpoints once
    they are up (``--realtime`` prints their ports from it).

    Parameters
    ----------
    controller : "smc" or "p", optional
        Follower control law (default ``guidance.controller``).
    stop : callable, optional
        Asked after every physics step; True ends the run with KeyboardInterrupt at that
        point (see :meth:`Simulation.run`).
    """
    law = controller or cfg.guidance.controller
    if law not in ("smc", "p"):
        raise ConfigError(f"controller must be 'smc' or 'p', got {law!r}")
    slots = cfg.slots()
    dt_guid = 1.0 / cfg.sim.guidance_rate_hz
    rng = np.random.default_rng(cfg.sim.seed)
    with Simulation(cfg, realtime=realtime, cache_dir=cache_dir) as sim:
        tap = None
        if recorder is not None:
            recorder.attach_fmus(sim.fmu_paths)  # provenance first: before any message

            def tap(vehicle: str, direction: str, msg: Any, raw: bytes) -> None:
                recorder.json(f"/mavlink/{vehicle}", "lfctl.MavlinkPacket", sim.t_s, packet_record(direction, msg, raw))

        links = Links(cfg, sim.realtime, tap)
        try:
            if on_links is not None:
                on_links(links)
            report = _closed_loop(
                cfg, sim, links, law, slots, dt_guid, rng, duration_s, progress, on_frame, recorder, stop
            )
        finally:
            links.close()
    return report


@dataclass
class _LeaderState:
    """The leader's autopilot, rebuilt whenever its endpoint's mission or current item changes."""

    autopilot: LeaderAutopilot | None = None
    version: int = -1
    legs: list[Leg] = dataclasses.field(default_factory=list)
    reached: list[tuple[int, float]] = dataclasses.field(default_factory=list)


def _closed_loop(
    cfg, sim, links, law, slots, dt_guid, rng, duration_s, progress, on_frame, recorder, stop
) -> RunReport:
    idx = sim.index
    camera = cfg.sim.sensing == "camera"
    leader_ep = links.endpoints[0]
    ls = _LeaderState()
    commands: dict[int, tuple[float, float]] = {i: (0.0, 0.0) for i in range(len(sim.names))}
    followers = []
    camera_seeds: list[tuple[str, int]] = []
    for v in cfg.followers:
        slot = slots[v.name]
        sensor_seed = int(rng.integers(2**31))
        camera_seeds.append((v.name, sensor_seed))
        sensor = None if camera else TruthSensor(cfg.sensing, np.random.default_rng(sensor_seed))
        followers.append(
            (
                idx[v.name],
                idx[slot.target],
                sensor,
                FormationController(formation_settings(cfg, slot.range_m, slot.bearing_rad, law)),
                FollowerTrace(v.name, slot.target, slot.range_m, slot.bearing_rad),
            )
        )
    last_status: dict[str, TrackStatus] = {}
    record_camera_s = [0.0]  # wall time the recorder spends on camera ticks (JPEG, annotations)

    def leader_command(t_s: float, world: WorldState) -> tuple[float, float]:
        ep = leader_ep
        if not ep.armed:
            return 0.0, 0.0
        if ep.mode == MODES["GUIDED"]:
            return ep.guided_command() or (0.0, 0.0)
        if ep.mode != MODES["AUTO"]:
            return 0.0, 0.0
        if not ep.mission:
            return scripted_command(cfg.script, t_s) if not cfg.mission.waypoints else (0.0, 0.0)
        ld = world.vehicle(0)
        if ep.mission_version != ls.version:
            ls.version = ep.mission_version
            ls.legs = to_legs(ep.mission, links.home, max(1, ep.current_seq))
            settings = dataclasses.replace(
                autopilot_settings(cfg),
                cruise_speed_mps=ep.param("WP_SPEED"),
                acceptance_radius_m=ep.param("WP_RADIUS"),
            )
            ls.autopilot = LeaderAutopilot(
                [(g.north_m, g.east_m, g.hold_s) for g in ls.legs],
                settings,
                (ld.north_m, ld.east_m),
                [g.speed_mps for g in ls.legs],
            )
        assert ls.autopilot is not None
        out = ls.autopilot.step(t_s, ld.north_m, ld.east_m, ld.yaw_rad, dt_guid)
        for k in out.los.reached:
            seq = ls.legs[k].seq
            ep.reached(seq)
            ls.reached.append((seq - 1, t_s))
            if recorder is not None:
                recorder.json(
                    "/leader/mission",
                    "lfctl.Mission",
                    t_s,
                    {"event": "reached", "index": seq - 1, "active": ep.current_seq, "count": len(ep.mission) - 1},
                )
        return out.speed_mps, out.yaw_rate_radps

    def guidance(t_s: float) -> None:
        world = sim.state()
        commands[0] = leader_command(t_s, world)
        pos = world.pos_ned_m
        for k, (me, target, sensor, ctl, tr) in enumerate(followers):
            st = world.vehicle(me)
            ep = links.endpoints[me]
            rng_cmd, brg_cmd = ep.param("LFC_RANGE"), math.radians(ep.param("LFC_BEARING"))
            if abs(rng_cmd - ctl.settings.range_cmd_m) > 1e-9 or abs(brg_cmd - ctl.settings.bearing_cmd_rad) > 1e-9:
                ctl.settings = dataclasses.replace(
                    ctl.settings, range_cmd_m=rng_cmd, bearing_cmd_rad=brg_cmd
                )  # set from a GCS
                tr.range_cmd_m, tr.bearing_cmd_rad = rng_cmd, brg_cmd
            if cfg.script.followers == "formation":
                meas = pool.measurement(tr.name) if pool is not None else sensor.measure(t_s, world, me, target)
                out_f = ctl.step(meas, Odometry(t_s, st.north_m, st.east_m, st.yaw_rad, st.speed_mps))
                cmd, status = (out_f.speed_mps, out_f.yaw_rate_radps), out_f.status
            else:
                cmd = commands[0] if cfg.script.followers == "copy" else (0.0, 0.0)
                status = TrackStatus.TRACKING
            comp = links.companions[k]
            comp.setpoint(t_s, *cmd)
            prev = last_status.get(tr.name)
            if prev is not None and status is not prev and (status is TrackStatus.LOST or prev is TrackStatus.LOST):
                comp.statustext(f"{tr.name}: leader {'lost, stopping' if status is TrackStatus.LOST else 'reacquired'}")
            last_status[tr.name] = status
            d = pos - pos[me]
            dist = np.hypot(d[:, 0], d[:, 1])
            dist[me] = np.inf
            tgt = world.vehicle(target)
            tr.t_s.append(t_s)
            tr.range_m.append(math.hypot(tgt.north_m - st.north_m, tgt.east_m - st.east_m))
            tr.bearing_rad.append(wrap_pi(math.atan2(tgt.east_m - st.east_m, tgt.north_m - st.north_m) - st.yaw_rad))
            tr.separation_m.append(float(dist.min()))
            tr.status.append(status)
            tr.speed_cmd_mps.append(cmd[0])
            tr.yaw_rate_cmd_radps.append(cmd[1])
            tr.speed_mps.append(st.speed_mps)
            if int(round(t_s / dt_guid)) % 10 == 0:  # 2 Hz formation status to the GCS
                comp.report(
                    t_s,
                    tr.range_m[-1] - tr.range_cmd_m,
                    math.degrees(wrap_pi(tr.bearing_rad[-1] - tr.bearing_cmd_rad)),
                    1.0 if status is TrackStatus.TRACKING else 0.0,
                )
            if recorder is not None:
                recorder.json(
                    f"/{tr.name}/controller",
                    "lfctl.Controller",
                    t_s,
                    {
                        "status": status.value,
                        "speed_cmd_mps": round(cmd[0], 5),
                        "yaw_rate_cmd_degps": round(math.degrees(cmd[1]), 4),
                        "range_cmd_m": tr.range_cmd_m,
                        "bearing_cmd_deg": round(math.degrees(tr.bearing_cmd_rad), 4),
                        "range_m": round(tr.range_m[-1], 5),
                        "bearing_deg": round(math.degrees(tr.bearing_rad[-1]), 4),
                        "range_error_m": round(tr.range_m[-1] - tr.range_cmd_m, 5),
                        "bearing_error_deg": round(math.degrees(wrap_pi(tr.bearing_rad[-1] - tr.bearing_cmd_rad)), 4),
                        "separation_m": round(tr.separation_m[-1], 5),
                        "target": tr.target,
                    },
                )

    def link(t_s: float) -> None:
        """Endpoints read their links and stream telemetry; vehicles obey their endpoints."""
        world = sim.state()
        links.tick(t_s, world)
        sim.set_command(0, *commands[0])
        for me, _target, _sensor, _ctl, _tr in followers:
            ep = links.endpoints[me]
            cmd = ep.guided_command() if (ep.armed and ep.mode == MODES["GUIDED"]) else None
            sim.set_command(me, *(cmd or (0.0, 0.0)))

    # frames stay in this process only when someone looks at them
    pool = CameraPool(cfg, camera_seeds, 0 if on_frame is not None else default_workers(cfg)) if camera else None
    if pool is not None:
        quality = cfg.recording.jpeg_quality

        def cameras(t_s: float) -> None:
            world = sim.state()
            jobs = [
                CameraJob(tr.name, me, target, quality if recorder and recorder.image_due(t_s, tr.name) else None)
                for me, target, _sensor, _ctl, tr in followers
            ]
            for job, res in zip(jobs, pool.capture(t_s, world, jobs), strict=True):
                if on_frame is not None:
                    on_frame(job.follower, res.sample)
                if recorder is not None:
                    t0 = time.perf_counter()
                    recorder.camera(t_s, job.follower, res.sample, res.jpeg)
                    record_camera_s[0] += time.perf_counter() - t0

        sim.add_task("camera", cfg.sim.camera_rate_hz, cameras)
    if recorder is not None:
        for _me, _target, _sensor, _ctl, tr in followers:
            if pool is not None:
                cam = pool.cam
                recorder.calibration(0.0, tr.name, cam.K, cam.dist, cam.width, cam.height)

        def telemetry(t_s: float) -> None:
            st = sim.state()
            recorder.poses(t_s, st.names, st.pos_ned_m, st.yaw_rad)

        sim.add_task("record", cfg.sim.telemetry_rate_hz, telemetry)
    sim.add_task("guidance", cfg.sim.guidance_rate_hz, guidance)
    sim.add_task("link", min(cfg.link.rate_hz, 1.0 / cfg.sim.dt_s), link)
    try:
        result = sim.run(duration_s, progress=progress, stop=stop)
    finally:
        if pool is not None:
            pool.close()
    result.extra["record_camera_s"] = record_camera_s[0]
    if pool is not None:
        # CPU seconds summed over processes: with camera workers they add up to more than the wall time
        result.extra["render_s"] = sum(pool.render_s.values())
        result.extra["vision_s"] = sum(pool.vision_s.values())
        result.extra["encode_s"] = sum(pool.encode_s.values())
        result.extra["camera_workers"] = pool.workers
    traces = [f[4] for f in followers]
    return RunReport(
        config=cfg,
        result=result,
        traces=traces,
        metrics=[follower_metrics(tr, dt_guid) for tr in traces],
        waypoints_reached=ls.reached,
        n_waypoints=max(0, len(leader_ep.mission) - 1),
        leader_mode="auto" if leader_ep.mission else "script",
    )
