"""The closed loop: every vehicle as an FMU behind its MAVLink endpoint, the leader's
autopilot, and each follower's stack (:mod:`lfctl.follower.stack`) fed by its sensor, wired
into the co-simulation master as four typed tasks that run, in this order, on the ticks
their rates put them on (docs/architecture.md):

- ``camera`` (``sim.camera_rate_hz``, camera sensing): render and perceive each follower's view;
- ``record`` (``sim.telemetry_rate_hz``, when recording): every vehicle's pose to the log;
- ``guidance`` (``sim.guidance_rate_hz``): every vehicle's autopilot (its mode and targets),
  each follower's stack;
- ``link`` (``link.rate_hz``): endpoints read their links and stream telemetry; each vehicle
  obeys its endpoint (AUTO commands, GUIDED setpoints).
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import logging
import math
import time
from array import array
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from lfctl.config import Config
from lfctl.errors import ConfigError
from lfctl.follower.stack import Follower, formation_settings
from lfctl.frames import wrap_pi
from lfctl.guidance.formation import CONTROLLERS, Odometry
from lfctl.link.endpoint import MODE_NAMES, packet_record
from lfctl.link.mission import PLACES, nav_count, to_legs
from lfctl.link.mission_server import ListChange
from lfctl.metrics import FormationMetrics, PathHistory, formation_metrics
from lfctl.record.rtp import RtpH264Sender
from lfctl.record.writer import EVENT_MODE, Recorder, scenario_events
from lfctl.sim.camera_pool import CameraJob, CameraPool, default_workers
from lfctl.sim.camera_sensor import CameraSample
from lfctl.sim.cosim import RunResult, Simulation
from lfctl.sim.driver import VehicleDriver
from lfctl.sim.links import Links, scenario_mission
from lfctl.sim.truth_sensor import TruthSensor
from lfctl.sim.watchdog import finish_on_abandon
from lfctl.sim.world import WorldState
from lfctl.vision.camera_model import CameraModel
from lfctl.vision.track_state import TrackStatus

__all__ = [
    "FollowerTrace",
    "RunReport",
    "check_video",
    "events_after_the_end",
    "run_scenario",
    "scenario_warnings",
    "slots_out_of_view",
]

log = logging.getLogger(__name__)


def _floats() -> array[float]:
    return array("d")


@dataclass
class FollowerTrace:
    """What one follower did, sampled at the guidance rate (errors against the truth). The
    samples are kept as packed arrays (8 bytes a number: a list's floats took 32, and a long
    run's trace grew by about 0.4 MB a simulated minute)."""

    name: str  # the follower
    target: str  # the vehicle it follows
    range_cmd_m: float  # its slot now (a ground station may move it): range, m
    bearing_cmd_rad: float  # and bearing, clockwise positive
    t_s: array[float] = dataclasses.field(default_factory=_floats)  # sample times
    range_m: array[float] = dataclasses.field(default_factory=_floats)  # truth
    bearing_rad: array[float] = dataclasses.field(default_factory=_floats)  # truth
    range_err_m: array[float] = dataclasses.field(default_factory=_floats)  # truth - the slot then
    bearing_err_rad: array[float] = dataclasses.field(default_factory=_floats)  # truth - the slot, wrapped
    separation_m: array[float] = dataclasses.field(default_factory=_floats)  # to the nearest vehicle
    status: list[TrackStatus | None] = dataclasses.field(default_factory=list)  # the stack's (None: outside's)
    speed_cmd_mps: array[float] = dataclasses.field(default_factory=_floats)  # the commands sent
    yaw_rate_cmd_radps: array[float] = dataclasses.field(default_factory=_floats)  # positive right
    speed_mps: array[float] = dataclasses.field(default_factory=_floats)  # the follower's true speed
    #: off the path its target drove, less the slot's sideways offset (lfctl.metrics.PathHistory)
    path_err_m: array[float] = dataclasses.field(default_factory=_floats)

    def metrics(self, step_s: float) -> FormationMetrics:
        """The formation figures of this trace (see :mod:`lfctl.metrics`).

        Parameters
        ----------
        step_s : float
            The guidance period the trace was sampled at, s.
        """
        return formation_metrics(
            self.name,
            self.target,
            self.range_cmd_m,
            self.bearing_cmd_rad,
            self.t_s,
            self.range_err_m,
            self.bearing_err_rad,
            self.separation_m,
            [s.value if s is not None else None for s in self.status],
            self.yaw_rate_cmd_radps,
            step_s,
            path_err_m=self.path_err_m,
        )


def stream_port(base: int, k: int) -> int:
    """The UDP port follower ``k`` (0: the first) streams its camera to: every second port
    from ``base``, as RTP asks (RFC 3550: RTP on an even port, RTCP on the odd one after it,
    which a receiver such as FFmpeg binds too).

    Parameters
    ----------
    base : int
        The first follower's port (``--video``'s).
    k : int
        The follower's place among the followers, from 0.
    """
    return base + 2 * k


def check_video(cfg: Config, video: tuple[str, int] | None) -> None:
    """Refuse live video (``video``: where it streams to, None: none) without camera sensing,
    to port 0, or past the last port for the last follower (:func:`stream_port`).

    Parameters
    ----------
    cfg : Config
        The scenario.
    video : (host, port) or None
        Where each follower's camera would stream.

    Raises
    ------
    ConfigError
        Video asked for, and the sensing is not the camera's.
    """
    if video is None:
        return
    if cfg.sim.sensing != "camera":
        raise ConfigError("live video needs camera sensing (sim.sensing = 'camera' or --sensing camera)")
    last = stream_port(video[1], max(0, len(cfg.followers) - 1))
    if video[1] == 0 or last > 65534:  # (each with its RTCP port after it)
        raise ConfigError(
            f"--video needs the port a receiver listens on, 1-{65534 - (last - video[1])} with "
            f"{len(cfg.followers)} follower{'s' if len(cfg.followers) != 1 else ''} (RTCP and any other "
            f"follower's stream take the {last - video[1] + 1} port{'s' if last > video[1] else ''} after it), got {video[1]}"
        )


@dataclass
class RunReport:
    """A closed-loop run: the co-simulation result, follower traces and metrics, mission progress."""

    config: Config  # the scenario run
    result: RunResult  # trajectories and timing
    traces: list[FollowerTrace]  # one per follower, in scenario order
    metrics: list[FormationMetrics]  # the traces' figures, same order
    waypoints_reached: list[tuple[int, float]]  # (waypoint index from 0, t_s) as reached
    n_waypoints: int  # waypoints (NAV items) of the mission last reached in (none reached: the one at the end)
    leader_mode: str  # "auto" (a mission) or "script" (the scenario's speed / yaw-rate profile)
    leader_modes: list[tuple[str, float]] = dataclasses.field(default_factory=list)  # (mode, seconds in it)
    n_reached: int = 0  # distinct waypoints reached of the mission last reached in ("N/M waypoints reached")
    mission_changes: list[ListChange] = dataclasses.field(default_factory=list)  # by clients, after the start
    log_path: Path | None = None  # the MCAP log written (None: not recorded)
    log_messages: int = 0  # messages in it


@dataclass
class SimFollower:
    """One follower in the co-simulation: its place in the world state, its stack, the truth
    sensor that feeds it (None with camera sensing: the camera pool does) and its trace."""

    name: str
    index: int
    target: int
    stack: Follower
    sensor: TruthSensor | None
    trace: FollowerTrace
    simulated: bool = True  # its companion is the simulator's (False: lfctl follow's, outside)


class CameraTask:
    """Render and perceive every follower's view; hand the frames to the log and the live
    video stream."""

    def __init__(
        self,
        sim: Simulation,
        pool: CameraPool,
        followers: list[SimFollower],
        recorder: Recorder | None,
        on_frame: Callable[[str, CameraSample], None] | None,
        video: dict[str, RtpH264Sender] | None = None,
    ) -> None:
        self.sim = sim
        self.pool = pool
        self.followers = followers
        self.recorder = recorder
        self.on_frame = on_frame
        self.video = video or {}
        self.record_s = 0.0  # wall time the recorder spends on camera ticks (annotations, messages)

    def __call__(self, t_s: float) -> None:
        world = self.sim.state()
        rec = self.recorder
        jobs = [
            CameraJob(
                f.name,
                f.index,
                f.target,
                image=rec is not None and rec.image_due(t_s, f.name),
                stream=f.name in self.video,
            )
            for f in self.followers
        ]
        for job, res in zip(jobs, self.pool.capture(t_s, world, jobs), strict=True):
            if self.on_frame is not None:
                self.on_frame(job.follower, res.sample)
            if res.stream is not None:
                self.video[job.follower].send(res.stream, t_s)
            if rec is not None:
                t0 = time.perf_counter()
                s = res.sample
                # (no measurement: its companion runs outside and tracks the frames there)
                perceived = s.measurement is not None
                rec.camera(t_s, job.follower, s.track, s.pose, s.measurement, s.truth, res.image, perceived)
                self.record_s += time.perf_counter() - t0


class TelemetryTask:
    """Every vehicle's pose, position and place in the scene to the log; the leader's
    mission when it changes; the scenario's events as they happen."""

    def __init__(self, sim: Simulation, recorder: Recorder, links: Links, followers: list[SimFollower]) -> None:
        self.sim = sim
        self.recorder = recorder
        self.links = links
        self.followers = followers
        self._mission_version: tuple[int, int] = (-1, -1)  # the map's mission: its version and edits
        self._missions_stored = 0
        self._events = scenario_events(sim.config)

    def __call__(self, t_s: float) -> None:
        st = self.sim.state()
        rec = self.recorder
        rec.poses(t_s, st.names, st.pos_ned_m, st.yaw_rad)
        leader = self.links.endpoints[0]
        if (leader.mission_version, leader.mission_edits) != self._mission_version:
            self._mission_version = (leader.mission_version, leader.mission_edits)
            seen: dict[int, tuple[float, float]] = {}
            me = st.vehicle(0)
            for leg in to_legs(leader.mission, self.links.home, 1, (me.north_m, me.east_m), leader.rtl_destination):
                if leg.command in PLACES:  # a wait where it stands is no place on the map
                    seen.setdefault(leg.seq, (leg.north_m, leg.east_m))
            rec.set_mission(t_s, list(seen.values()), leader.param("WP_RADIUS"))
        if leader.missions.mission_number != self._missions_stored:  # replaced or cleared
            self._missions_stored = leader.missions.mission_number
            rec.mission_stored(t_s, nav_count(leader.mission), self._missions_stored)
        while self._events and self._events[0][0] <= t_s:
            rec.event(t_s, "scenario", self._events.pop(0)[1])
        slots = {}
        for f in self.followers:
            me, tgt = st.vehicle(f.index), st.vehicle(f.target)
            settings = f.stack.settings
            heading = me.yaw_rad + settings.bearing_cmd_rad
            slots[f.name] = (
                tgt.north_m - settings.range_cmd_m * math.cos(heading),
                tgt.east_m - settings.range_cmd_m * math.sin(heading),
                tgt.north_m,
                tgt.east_m,
            )
        rec.scene(t_s, slots)


class GuidanceTask:
    """Every vehicle's autopilot, and every follower's stack, on the world state at ``t_s``."""

    def __init__(
        self,
        sim: Simulation,
        links: Links,
        drivers: list[VehicleDriver],
        followers: list[SimFollower],
        pool: CameraPool | None,
        recorder: Recorder | None,
    ) -> None:
        self.sim = sim
        self.links = links
        self.drivers = drivers
        self.followers = followers
        self.pool = pool
        self.recorder = recorder
        self.open_loop = sim.config.script.followers
        self._paths: dict[int, PathHistory] = {}  # each target's path, for its followers' path error

    def __call__(self, t_s: float) -> None:
        world = self.sim.state()
        for driver in self.drivers:
            driver.update(t_s, world)
        for index in {f.target for f in self.followers}:
            v = world.vehicle(index)
            path = self._paths.get(index)
            if path is None:
                self._paths[index] = PathHistory(v.north_m, v.east_m, v.yaw_rad)
            else:
                path.add(v.north_m, v.east_m)
        for f in self.followers:
            self._follower(t_s, world, f)

    def _follower(self, t_s: float, world: WorldState, f: SimFollower) -> None:
        me = world.vehicle(f.index)
        ep = self.links.endpoints[f.index]
        if "LFC_RANGE" in ep.params:  # (a follower whose companion runs outside has none)
            f.stack.tune_from_params(ep.param)  # a ground station may set them
        if not f.simulated:  # its companion (lfctl follow) runs outside: what drove it is what reached it
            cmd, status, law = self.drivers[f.index].link_command(), None, ""
        elif self.open_loop == "formation":
            if self.pool is not None:
                meas = self.pool.measurement(f.name)
            else:
                assert f.sensor is not None
                meas = f.sensor.measure(t_s, world, f.index, f.target)
            out = f.stack.step(t_s, meas, Odometry(t_s, me.north_m, me.east_m, me.yaw_rad, me.speed_mps))
            cmd, status, law = (out.speed_mps, out.yaw_rate_radps), out.status, out.law
        else:  # scripted runs: copy the leader's command, or stand still
            cmd = self.drivers[0].command if self.open_loop == "copy" else (0.0, 0.0)
            f.stack.command(t_s, *cmd)
            status, law = TrackStatus.TRACKING, ""
        self._trace(t_s, world, f, me.speed_mps, cmd, status, law)

    def _trace(
        self,
        t_s: float,
        world: WorldState,
        f: SimFollower,
        speed_mps: float,
        cmd: tuple[float, float],
        status: TrackStatus | None,
        law: str,
    ) -> None:
        tr, slot = f.trace, f.stack.settings
        tr.range_cmd_m, tr.bearing_cmd_rad = slot.range_cmd_m, slot.bearing_cmd_rad
        pos = world.pos_ned_m
        d = pos - pos[f.index]
        dist = np.hypot(d[:, 0], d[:, 1])
        dist[f.index] = np.inf
        me, tgt = world.vehicle(f.index), world.vehicle(f.target)
        rng = math.hypot(tgt.north_m - me.north_m, tgt.east_m - me.east_m)
        brg = wrap_pi(math.atan2(tgt.east_m - me.east_m, tgt.north_m - me.north_m) - me.yaw_rad)
        range_err, bearing_err = rng - slot.range_cmd_m, wrap_pi(brg - slot.bearing_cmd_rad)
        tr.t_s.append(t_s)
        tr.range_m.append(rng)
        tr.bearing_rad.append(brg)
        tr.range_err_m.append(range_err)
        tr.bearing_err_rad.append(bearing_err)
        tr.separation_m.append(float(dist.min()))
        tr.status.append(status)
        tr.speed_cmd_mps.append(cmd[0])
        tr.yaw_rate_cmd_radps.append(cmd[1])
        tr.speed_mps.append(speed_mps)
        offset = slot.range_cmd_m * abs(math.sin(slot.bearing_cmd_rad))
        tr.path_err_m.append(self._paths[f.target].error(me.north_m, me.east_m, offset))
        if self.recorder is not None:
            self.recorder.controller(
                t_s,
                f.name,
                {
                    **({"status": status.value} if status is not None else {}),
                    "speed_cmd_mps": round(cmd[0], 5),
                    "yaw_rate_cmd_degps": round(math.degrees(cmd[1]), 4),
                    "range_cmd_m": slot.range_cmd_m,
                    "bearing_cmd_deg": round(math.degrees(slot.bearing_cmd_rad), 4),
                    "range_m": round(rng, 5),
                    "bearing_deg": round(math.degrees(brg), 4),
                    "range_error_m": round(range_err, 5),
                    "bearing_error_deg": round(math.degrees(bearing_err), 4),
                    "separation_m": round(tr.separation_m[-1], 5),
                    "path_error_m": round(tr.path_err_m[-1], 5),
                    "target": tr.target,
                    **({"law": law} if law else {}),  # the law that made the command (LFC_LAW may change it)
                },
            )


class LinkTask:
    """Endpoints read their links and stream telemetry; each vehicle obeys its endpoint; a
    vehicle's mode or arming changing is an event in the log."""

    def __init__(
        self, sim: Simulation, links: Links, drivers: list[VehicleDriver], recorder: Recorder | None = None
    ) -> None:
        self.sim = sim
        self.links = links
        self.drivers = drivers
        self.recorder = recorder
        self._states: dict[str, tuple[int, bool]] = {}

    def __call__(self, t_s: float) -> None:
        self.links.tick(t_s, self.sim.state(), self.sim.commanded_speeds_mps())
        for driver in self.drivers:
            self.sim.set_command(driver.index, *driver.link_command())
        if self.recorder is not None:
            for ep in self.links.endpoints:
                now = (ep.mode, ep.armed)
                was = self._states.get(ep.name)
                if was != now:
                    self._states[ep.name] = now
                    if was is None or was[0] != now[0]:
                        self.recorder.event(t_s, ep.name, EVENT_MODE + MODE_NAMES.get(ep.mode, str(ep.mode)))
                    if was is None or was[1] != now[1]:
                        self.recorder.event(t_s, ep.name, "armed" if ep.armed else "disarmed")


def vehicles_on_each_other(cfg: Config) -> list[str]:
    """Each pair of vehicles that starts closer than a rover's length (the renderer's body,
    :data:`~lfctl.render.renderer.BODY_LENGTH_M`): on top of each other, a slip in a scenario
    (the run goes on: its minimum separation says what came of it); :func:`run_scenario`
    says so as it starts.

    Parameters
    ----------
    cfg : Config
        The scenario.
    """
    from lfctl.render.renderer import BODY_LENGTH_M

    out = []
    vs = cfg.vehicles
    for i, a in enumerate(vs):
        for b in vs[i + 1 :]:
            gap = math.hypot(a.north_m - b.north_m, a.east_m - b.east_m)
            if gap < BODY_LENGTH_M:
                out.append(
                    f"vehicles {a.name} and {b.name} start {gap:.2f} m apart, closer than a rover's "
                    f"{BODY_LENGTH_M:g} m length: on top of each other (north_m, east_m)"
                )
    return out


def events_after_the_end(cfg: Config) -> list[str]:
    """Each timed event of the scenario that the run ends before (an occluder's crossing, a
    truth-sensor dropout, from ``sim.duration_s`` on): a slip, or a scenario run shorter than
    it was written for (``--duration``); :func:`run_scenario` says so as it starts.

    Parameters
    ----------
    cfg : Config
        The scenario, with the run's duration.
    """
    end = cfg.sim.duration_s
    out = [
        f"scene.occluders[{i}].t_s = {occ.t_s:g} s is at or after the run's end ({end:g} s): it never crosses"
        for i, occ in enumerate(cfg.scene.occluders)
        if occ.t_s >= end
    ]
    out += [
        f"sensing.dropouts[{i}] starts at {start:g} s, at or after the run's end ({end:g} s): it never happens"
        for i, (start, _stop) in enumerate(cfg.sensing.dropouts)
        if start >= end
    ]
    return out


def scenario_warnings(cfg: Config) -> list[str]:
    """What :func:`run_scenario` warns of as it starts, from the scenario alone: slots out of
    the sensor's view, vehicles on top of each other, events after the run's end (a sweep
    says them once for all its runs).

    Parameters
    ----------
    cfg : Config
        The scenario, with the run's duration.
    """
    return [*slots_out_of_view(cfg), *vehicles_on_each_other(cfg), *events_after_the_end(cfg)]


def slots_out_of_view(cfg: Config) -> list[str]:
    """Each follower whose slot puts its target where its sensor cannot see it, said. With
    camera sensing: the target's banner not wholly in the picture when the follower holds its
    slot (the camera's intrinsics and mount, the banner's place and size, as
    :func:`~lfctl.vision.perception.slot_box` projects it); with truth sensing: a bearing past
    half ``sensing.fov_deg`` or a range past ``sensing.max_range_m``. Such a follower, once
    in its slot, loses its target (a scenario may mean it: one that tests the search);
    :func:`run_scenario` says so as it starts.

    Parameters
    ----------
    cfg : Config
        The scenario.
    """
    from lfctl.vision.banner import BannerGeometry
    from lfctl.vision.perception import banner_in_picture

    out = []
    camera = CameraModel.from_config(cfg.camera) if cfg.sim.sensing == "camera" else None
    for name, slot in cfg.slots().items():
        where = f"{name}'s slot ({slot.range_m:g} m, {math.degrees(slot.bearing_rad):g} deg from {slot.target})"
        if camera is not None:
            banner = BannerGeometry.from_config(cfg.banner_of(slot.target))
            if not banner_in_picture(camera, banner, slot.range_m, slot.bearing_rad):
                out.append(
                    f"{where} leaves {slot.target}'s banner out of the {camera.width}x{camera.height} picture "
                    f"(camera.hfov_deg {math.degrees(cfg.camera.hfov_rad):g}): once in its slot it will not see its target"
                )
            continue
        half = cfg.sensing.fov_rad / 2
        if abs(slot.bearing_rad) > half:
            out.append(
                f"{where} is outside the truth sensor's field of view (+-{math.degrees(half):g} deg): once in "
                "its slot it will not see its target"
            )
        if slot.range_m > cfg.sensing.max_range_m:
            out.append(
                f"{where} is past the truth sensor's sensing.max_range_m ({cfg.sensing.max_range_m:g} m): once "
                "in its slot it will not see its target"
            )
    return out


def run_scenario(
    cfg: Config,
    *,
    controller: str | None = None,
    realtime: bool | None = None,
    duration_s: float | None = None,
    progress: Callable[[float, float], None] | None = None,
    cache_dir: Path | None = None,
    on_frame: Callable[[str, CameraSample], None] | None = None,
    record_to: Path | None = None,
    on_links: Callable[[Links], None] | None = None,
    stop: Callable[[], bool] | None = None,
    live: tuple[str, int] | None = None,
    video: tuple[str, int] | None = None,
    on_live: Callable[[int], None] | None = None,
    on_log: Callable[[Path], None] | None = None,
    warn: bool = True,
) -> RunReport:
    """Run a scenario closed loop and return the report.

    Every vehicle is a MAVLink endpoint: the leader flies the mission its endpoint holds (in
    lockstep uploaded at t = 0 through the mission protocol), each follower obeys the
    SET_POSITION_TARGET_LOCAL_NED its companion sends.

    Parameters
    ----------
    cfg : Config
        The scenario.
    controller : "smc", "p" or "trail", optional
        Follower control law (default ``guidance.controller``).
    realtime : bool, optional
        Pace to the wall clock, each endpoint on its UDP port (default ``sim.clock``).
    duration_s : float, optional
        Simulated seconds (default ``sim.duration_s``).
    progress : callable, optional
        Called as ``progress(t_s, wall_s)`` about once per simulated second.
    cache_dir : Path, optional
        Where built-in FMUs are built.
    on_frame : callable, optional
        Sees each follower's camera samples, frames included (cameras then stay in this process).
    record_to : Path, optional
        Record the run to this MCAP file. It is opened once the vehicles and links are up;
        a run that fails before its first step leaves no file, one that fails later a
        finished file whose ``end`` metadata says why.
    on_links : callable, optional
        Sees the endpoints once they are up (``--realtime`` prints their ports from it).
    stop : callable, optional
        Asked after every physics step; True ends the run with KeyboardInterrupt at that
        point (see :meth:`Simulation.run`).
    live : (host, port), optional
        Serve the run on a Foxglove WebSocket there while it runs (port 0: a free one), with
        the same messages as the log.
    video : (host, port), optional
        Stream each follower's camera as RTP/UDP H.264 there, follower k to ``port + 2 (k - 1)``
        (camera sensing only); with ``realtime`` each follower's system also gets a MAVLink
        camera component that announces its stream.
    on_live : callable, optional
        Told the Foxglove WebSocket's port once it listens.
    on_log : callable, optional
        Told the MCAP log's path once it is open (a name taken gets ``-2``, ...): where an
        interrupted run's finished log is.
    warn : bool
        Log :func:`scenario_warnings` as the run starts (a sweep says them once for all its
        runs, and runs each with ``warn=False``).

    Raises
    ------
    ConfigError
        A bad controller, or ``video`` without camera sensing.
    RecordError
        The log cannot be created, or the WebSocket cannot listen there.
    """
    if not isinstance(cfg, Config):  # a scenario's name or path: it must be loaded first
        raise ConfigError(
            f"run_scenario takes a Config (load_config(resolve_scenario(...))), got {type(cfg).__name__} {cfg!r}"
        )
    if duration_s is not None:  # checked as the scenario's sim.duration_s is
        cfg = dataclasses.replace(cfg, sim=dataclasses.replace(cfg.sim, duration_s=duration_s))
    law = controller or cfg.guidance.controller
    if law not in CONTROLLERS:
        raise ConfigError(f"controller must be one of {', '.join(map(repr, CONTROLLERS))}, got {law!r}")
    check_video(cfg, video)
    alone = [v.name for v in cfg.followers if not v.companion]
    if alone and not (cfg.sim.clock == "realtime" if realtime is None else realtime):
        raise ConfigError(
            f"vehicles[{alone[0]}].companion = false needs --realtime: the companion that commands it "
            "(lfctl follow) talks to it over UDP in real time"
        )
    for problem in scenario_warnings(cfg) if warn else ():
        log.warning("%s", problem)
    mission = scenario_mission(cfg)  # a bad mission file stops the run before it starts
    with Simulation(cfg, realtime=realtime, cache_dir=cache_dir) as sim:
        with _recording(record_to, cfg, sim, live) as recorder:
            tap = None
            if recorder is not None:
                recorder.attach_fmus(sim.fmu_paths)  # provenance first: before any message
                if on_log is not None and recorder.path is not None:
                    on_log(recorder.path)
                if mission is not None:
                    recorder.attach(f"mission/{mission.path.name}", "text/plain", mission.data)
                recorder.on_serve = on_live  # said once it takes connections, after the first step

                def tap(vehicle: str, direction: str, msg: Any, raw: bytes, to: Any = None) -> None:
                    recorder.mavlink(sim.t_s, vehicle, packet_record(direction, msg, raw, to))

            video_ports = (
                {v.name: stream_port(video[1], k) for k, v in enumerate(cfg.followers)} if video is not None else None
            )
            start_ns = recorder.start_ns if recorder is not None else None
            links = Links(cfg, sim.realtime, tap, video_ports, start_ns, mission)
            for ep in links.endpoints[1:]:  # the run's law (--controller, else the scenario's) is each follower's
                if "LFC_LAW" in ep.params:  # (one whose companion runs outside has none: it holds its own)
                    ep.params["LFC_LAW"].value = CONTROLLERS.index(law)
            senders: dict[str, RtpH264Sender] = {}
            try:
                if video is not None and video_ports is not None:
                    for name, port in video_ports.items():
                        senders[name] = RtpH264Sender(video[0], port)
                        if name in links.camera_of:  # its camera component starts and stops it
                            links.camera_of[name].on_streaming = partial(_pause_unless, senders[name])
                if on_links is not None:
                    on_links(links)
                report = _closed_loop(
                    cfg, sim, links, law, duration_s, progress, on_frame, recorder, stop, senders or None
                )
            finally:
                for sender in senders.values():
                    sender.close()
                if recorder is not None and sim.tick > 0:
                    for ep in links.endpoints:  # what each link read and refused, for the audit
                        recorder.metadata(
                            f"link.{ep.name}", {k: str(v) for k, v in dataclasses.asdict(ep.stats).items()}
                        )
                links.close()
        if recorder is not None and recorder.path is not None:
            report.log_path, report.log_messages = recorder.path, recorder.messages
    return report


@contextlib.contextmanager
def _recording(
    path: Path | None, cfg: Config, sim: Simulation, live: tuple[str, int] | None
) -> Iterator[Recorder | None]:
    """The run's log (a file, a live server, or both), finished with the reason the run
    ended; the file is removed when the run ended before its first step (nothing to audit)."""
    if path is None and live is None:
        yield None
        return
    rec = Recorder(path, cfg, live=live)
    # an FMU stuck in a call when the run is told to stop: the watchdog finishes the log
    with finish_on_abandon(lambda message: rec.close(f"error: {message}", sim.t_s)):
        try:
            yield rec
        except BaseException as exc:
            if sim.tick == 0:
                rec.discard()
            else:
                reason = "interrupted" if isinstance(exc, KeyboardInterrupt) else f"error: {type(exc).__name__}: {exc}"
                rec.close(reason, sim.t_s)
            raise
    rec.close("completed", sim.t_s)


def _closed_loop(
    cfg: Config,
    sim: Simulation,
    links: Links,
    law: str,
    duration_s: float | None,
    progress: Callable[[float, float], None] | None,
    on_frame: Callable[[str, CameraSample], None] | None,
    recorder: Recorder | None,
    stop: Callable[[], bool] | None,
    video: dict[str, RtpH264Sender] | None = None,
) -> RunReport:
    idx = sim.index
    step_s = 1.0 / cfg.sim.guidance_rate_hz
    on_reached = recorder.mission_reached if recorder is not None else None
    drivers = [
        VehicleDriver(cfg, ep, i, links.home, step_s, scripted=i == 0, on_reached=on_reached if i == 0 else None)
        for i, ep in enumerate(links.endpoints)
    ]
    rng = np.random.default_rng(cfg.sim.seed)
    slots = cfg.slots()
    camera = cfg.sim.sensing == "camera"
    followers: list[SimFollower] = []
    seeds: list[tuple[str, int]] = []
    for v, companion in zip(cfg.followers, links.companions, strict=True):
        slot = slots[v.name]
        seed = int(rng.integers(2**31))  # the follower's sensor: truth noise, or its camera's renderer
        seeds.append((v.name, seed))
        stack = Follower(
            v.name,
            # LFC_* tune it before each step
            formation_settings(
                cfg, slot.range_m, slot.bearing_rad, law, cfg.camera if cfg.sim.sensing == "camera" else None
            ),
            companion,
            step_rate_hz=cfg.sim.guidance_rate_hz,
            status_rate_hz=cfg.sim.status_rate_hz,
        )
        sensor = None if camera else TruthSensor(cfg.sensing, np.random.default_rng(seed))
        trace = FollowerTrace(v.name, slot.target, slot.range_m, slot.bearing_rad)
        followers.append(SimFollower(v.name, idx[v.name], idx[slot.target], stack, sensor, trace, v.companion))
    # frames stay in this process only when someone looks at them
    pool = CameraPool(cfg, seeds, 0 if on_frame is not None else default_workers(cfg)) if camera else None
    try:
        camera_task = None
        if pool is not None:
            camera_task = CameraTask(sim, pool, followers, recorder, on_frame, video)
            sim.add_task("camera", cfg.sim.camera_rate_hz, camera_task)
        if recorder is not None:
            recorder.event(
                0.0, "lfctl", f"run {cfg.name} seed {cfg.sim.seed}: {cfg.sim.clock}, sensing {cfg.sim.sensing}"
            )
            if pool is not None:
                cam = CameraModel.from_config(cfg.camera)
                for f in followers:
                    recorder.calibration(0.0, f.name, cam)
            sim.add_task("record", cfg.sim.telemetry_rate_hz, TelemetryTask(sim, recorder, links, followers))
        sim.add_task("guidance", cfg.sim.guidance_rate_hz, GuidanceTask(sim, links, drivers, followers, pool, recorder))
        sim.add_task("link", min(cfg.link.rate_hz, 1.0 / cfg.sim.dt_s), LinkTask(sim, links, drivers, recorder))
        if recorder is not None:  # the live server starts once the first tick has made the channels
            sim.add_task("live", cfg.sim.telemetry_rate_hz, lambda _t_s: recorder.serve())
        result = sim.run(duration_s, progress=progress, stop=stop)
    finally:
        if pool is not None:
            pool.close()
    result.extra["record_camera_s"] = camera_task.record_s if camera_task is not None else 0.0
    if pool is not None:
        # CPU seconds summed over processes: with camera workers they add up to more than the wall time
        result.extra["render_s"] = sum(pool.render_s.values())
        result.extra["vision_s"] = sum(pool.vision_s.values())
        result.extra["encode_s"] = sum(pool.encode_s.values())
        result.extra["camera_workers"] = pool.workers
    traces = [f.trace for f in followers]
    leader_ep = links.endpoints[0]
    modes: dict[str, float] = {}
    marks = [*leader_ep.modes, (result.sim_time_s, -1)]
    for (t0, mode), (t1, _next) in itertools.pairwise(marks):
        name = MODE_NAMES.get(mode, str(mode))
        modes[name] = modes.get(name, 0.0) + max(0.0, t1 - t0)
    return RunReport(
        config=cfg,
        result=result,
        traces=traces,
        metrics=[tr.metrics(step_s) for tr in traces],
        waypoints_reached=drivers[0].reached,
        n_waypoints=drivers[0].reached_of if drivers[0].reached_of is not None else nav_count(leader_ep.mission),
        n_reached=drivers[0].distinct_reached,
        leader_mode="script" if not cfg.mission.waypoints and not leader_ep.missions.changes else "auto",
        leader_modes=[(name, secs) for name, secs in modes.items() if secs > 0],
        mission_changes=[c for c in leader_ep.missions.changes if c.t_s > 0 or c.sysid not in (0, 255)],
    )


def _pause_unless(sender: RtpH264Sender, streaming: bool) -> None:
    """A camera component's start or stop: its stream's sender sends or pauses."""
    sender.paused = not streaming
