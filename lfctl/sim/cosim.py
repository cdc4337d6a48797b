"""The co-simulation master: lockstep FMU stepping, one scheduler for every subsystem rate.

One physics tick (docs/architecture.md): the tasks due at ``t`` run first (sensing, guidance, link,
recording) and read the world state at ``t``; they leave commands; then every vehicle FMU
steps from ``t`` to ``t + dt`` with those commands. Lockstep runs as fast as the CPU allows
and is bit-for-bit deterministic for a scenario and seed; realtime paces ticks to the wall
clock. The master owns every FMU handle and frees them on exit.
"""

from __future__ import annotations

import math
import time
import warnings
from array import array
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lfctl.config import Config, VehicleConfig
from lfctl.errors import ConfigError, FmuError
from lfctl.fmu.build import build_model
from lfctl.fmu.host import FmuHost, HostedInstance
from lfctl.fmu.load import (
    INPUT_ROLES,
    OUTPUT_BOUNDS,
    OUTPUT_ROLES,
    POSE_ROLES,
    FmuInstance,
    FmuLibrary,
    RoleMap,
)
from lfctl.frames import wrap_pi
from lfctl.sim.world import WorldState

__all__ = ["RunResult", "Simulation", "TaskFn"]

# The output check squares outputs; a huge one overflows to inf, which is what it looks for.
warnings.filterwarnings("ignore", "overflow encountered", RuntimeWarning, r"lfctl\.sim\.cosim")


#: a scheduled task: called with the simulation time, s
TaskFn = Callable[[float], None]


@dataclass
class _Task:
    name: str
    rate_hz: float
    fn: TaskFn
    ticks_per_run: float
    start_tick: int
    runs: int = 0
    next_tick: int = 0


@dataclass
class RunResult:
    """What a run leaves behind for summaries and tests."""

    sim_time_s: float  # simulated time the run covered, s
    wall_time_s: float  # wall-clock time it took, s
    ticks: int  # physics steps taken
    names: tuple[str, ...]  # the vehicles, in the order of the arrays
    final: WorldState  # the truth at the end
    t_s: np.ndarray  # (K,) sample times of the trajectory
    pos_ned_m: np.ndarray  # (K, N, 2)
    yaw_rad: np.ndarray  # (K, N)
    speed_mps: np.ndarray  # (K, N)
    extra: dict[str, object] = field(default_factory=dict)  # timings and counts callers add (cost split)

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else math.inf


class Simulation:
    """Load the scenario's vehicle FMUs and step them in lockstep.

    Use as a context manager::

        with Simulation(config) as sim:
            sim.add_task("guidance", 20.0, controller)
            result = sim.run()

    Parameters
    ----------
    config : Config
        The scenario.
    realtime : bool, optional
        Pace to the wall clock; default from ``config.sim.clock``.
    cache_dir : Path, optional
        Where built-in FMUs are built (default: ``~/.cache/lfctl/fmu``, see :func:`lfctl.fmu.build.build_model`).
    sample_rate_hz : float, optional
        Rate at which the trajectory is kept for the result; default the telemetry rate.
    """

    def __init__(
        self,
        config: Config,
        *,
        realtime: bool | None = None,
        cache_dir: Path | None = None,
        sample_rate_hz: float | None = None,
    ) -> None:
        self.config = config
        self.dt_s = config.sim.dt_s
        self.realtime = config.sim.clock == "realtime" if realtime is None else realtime
        self.names = tuple(v.name for v in config.vehicles)
        self.index = {n: i for i, n in enumerate(self.names)}
        n = len(self.names)
        # FMU-unit rows the instances read and write directly (no copies per step); shared
        # with the FMU process when some vehicle's FMU runs in one (open())
        self._use_rows(np.zeros((n, len(INPUT_ROLES))), np.zeros((n, len(OUTPUT_ROLES))))
        # the output check (step()): raw outputs times 1 / (their bound in FMU units)
        self._out_weight = np.ones_like(self._out_flat)
        self._out_scratch = np.zeros_like(self._out_flat)
        self._in_scale = np.ones((n, len(INPUT_ROLES)))
        self._out_scale = np.ones((n, len(OUTPUT_ROLES)))
        self._origin = np.zeros((n, 3))  # north, east, yaw of the FMU origin (unmapped pose)
        self._libraries: dict[Path, FmuLibrary] = {}
        self._mapped_by: dict[Path, tuple[str, RoleMap]] = {}  # who loaded each file, with which mapping
        self._instances: list[FmuInstance | HostedInstance] = []  # every vehicle's, in order
        self._local: list[FmuInstance] = []  # those stepped in this process
        self._host: FmuHost | None = None  # the process stepping the others
        self._tasks: list[_Task] = []
        self._sample_rate_hz = sample_rate_hz or config.sim.telemetry_rate_hz
        self._cache_dir = cache_dir
        self.tick = 0
        self.t_s = 0.0
        self._state: WorldState | None = None  # state() of tick _state_tick (see state())
        self._state_tick = -1
        self._opened = False
        #: wall seconds spent in each task and in FMU stepping ("physics"): the cost split
        self.task_time_s: dict[str, float] = {}

    def _use_rows(self, cmd: np.ndarray, out: np.ndarray) -> None:
        self._cmd_raw, self._out_raw = cmd, out
        self._out_flat = out.reshape(-1)  # a view: the outputs as one vector

    def separate(self, v: VehicleConfig) -> bool:
        """Whether vehicle ``v``'s FMU runs in a process of its own (``sim.fmu_process``:
        "auto" for a user FMU, "separate" for every one, "main" for none).

        Parameters
        ----------
        v : VehicleConfig
            One of the scenario's vehicles.
        """
        mode = self.config.sim.fmu_process
        return mode == "separate" or (mode == "auto" and v.fmu is not None)

    # -- lifetime ------------------------------------------------------------------------
    def open(self) -> Simulation:
        """Build (if needed) and load every FMU, instantiate and initialise each vehicle
        (those :meth:`separate` says in one process of their own, :mod:`lfctl.fmu.host`)."""
        try:
            if any(self.separate(v) for v in self.config.vehicles):
                self._host = FmuHost(len(self.names), self.config.sim.fmu_step_timeout_s)
                self._use_rows(self._host.cmd, self._host.out)
            for i, v in enumerate(self.config.vehicles):
                lib = self._library(v)
                self._in_scale[i] = [1.0 / lib.scale[r] for r in INPUT_ROLES]
                self._out_scale[i] = [lib.scale[r] for r in OUTPUT_ROLES]
                self._out_weight.reshape(self._out_raw.shape)[i] = [
                    lib.scale[r] / OUTPUT_BOUNDS[r] for r in OUTPUT_ROLES
                ]
                if not lib.pose_mapped:
                    self._origin[i] = (v.north_m, v.east_m, v.yaw_rad)
                pose = (v.north_m, v.east_m, v.yaw_rad)
                if self._host is not None and self.separate(v):
                    self._instances.append(self._host.add(i, lib, v.name, v.parameters, pose))
                else:
                    local = lib.instantiate(v.name, v.parameters, pose, self._cmd_raw[i], self._out_raw[i])
                    self._instances.append(local)
                    self._local.append(local)
        except BaseException:
            self.close()
            raise
        self._opened = True
        self._state = None  # the outputs are the instances' now
        return self

    def _library(self, v: VehicleConfig) -> FmuLibrary:
        if v.fmu is not None:
            path = Path(v.fmu).expanduser().resolve()
            names = {r: r for r in (*INPUT_ROLES, *OUTPUT_ROLES, *POSE_ROLES)} | dict(v.map)
            role_map = RoleMap(names=names, units=dict(v.units), explicit=frozenset(v.map))
        else:
            path = build_model(v.model, self._cache_dir).path(v.fmi_version)
            role_map = RoleMap()
        key = path
        if key not in self._libraries:
            self._libraries[key] = FmuLibrary(path, role_map)
            self._mapped_by[key] = (v.name, role_map)
        first, mapped = self._mapped_by[key]
        if mapped != role_map:  # one loaded file has one mapping: the second's would be ignored
            raise ConfigError(
                f"vehicles[{first}] and vehicles[{v.name}] use {path} with different map/units; "
                "give both the same (or each its own copy of the file)"
            )
        return self._libraries[key]

    @property
    def fmu_paths(self) -> list[Path]:
        """The FMU files this run loaded."""
        return list(self._libraries)

    def close(self) -> None:
        """Free every FMU instance, end the FMU process, remove every extracted folder."""
        try:
            if self._host is not None:
                self._host.close()
        finally:
            self._host = None
            for lib in self._libraries.values():
                lib.close()
        self._libraries.clear()
        self._mapped_by.clear()
        self._instances.clear()
        self._local.clear()
        self._opened = False

    def __enter__(self) -> Simulation:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- scheduling ----------------------------------------------------------------------
    def add_task(self, name: str, rate_hz: float, fn: TaskFn) -> None:
        """Call ``fn(t_s)`` at ``rate_hz`` (ticks rounded to the physics step), before physics.

        Tasks due on the same tick run in the order they were added.

        Parameters
        ----------
        name : str
            The task's name (in errors and in :attr:`task_time_s`).
        rate_hz : float
            How often, Hz; at most the physics rate (ConfigError otherwise).
        fn : TaskFn
            The task, called with the simulation time.
        """
        if not rate_hz > 0:
            raise ConfigError(f"task {name!r}: rate_hz must be > 0, got {rate_hz!r}")
        ticks = 1.0 / (rate_hz * self.dt_s)
        if ticks < 1.0 - 1e-9:
            raise ConfigError(f"task {name!r}: {rate_hz:g} Hz is faster than the physics rate {1 / self.dt_s:g} Hz")
        self._tasks.append(_Task(name, rate_hz, fn, ticks, start_tick=self.tick, next_tick=self.tick))

    # -- commands and state --------------------------------------------------------------
    def set_command(self, vehicle: int | str, speed_mps: float, yaw_rate_radps: float) -> None:
        """Command a vehicle; held until the next command.

        Parameters
        ----------
        vehicle : int or str
            Its index in :attr:`names` or its name.
        speed_mps : float
            Forward speed, m/s (finite, else ValueError).
        yaw_rate_radps : float
            Yaw rate, rad/s, positive right (finite).
        """
        i = self.index[vehicle] if isinstance(vehicle, str) else vehicle
        if not (math.isfinite(speed_mps) and math.isfinite(yaw_rate_radps)):
            raise ValueError(
                f"{self.names[i]}: commands must be finite, got speed {speed_mps!r}, yaw rate {yaw_rate_radps!r}"
            )
        self._cmd_raw[i, 0] = speed_mps * self._in_scale[i, 0]
        self._cmd_raw[i, 1] = yaw_rate_radps * self._in_scale[i, 1]

    def commanded_speeds_mps(self) -> list[float]:
        """Each vehicle's forward-speed command now, m/s (as :meth:`set_command` last set it),
        in :attr:`names` order."""
        return (self._cmd_raw[:, 0] / self._in_scale[:, 0]).tolist()

    def state(self) -> WorldState:
        """The world truth now (SI, NED).

        Made once per tick and shared: the outputs change only in :meth:`step` (and in
        :meth:`open`), while the tasks due on one tick each ask for it (camera, telemetry,
        guidance and link can all fall on the same tick). Its arrays are read-only, so no
        reader can change what another sees.
        """
        cached = self._state
        if cached is not None and self._state_tick == self.tick:
            return cached
        si = self._out_raw * self._out_scale
        n0, e0, y0 = self._origin[:, 0], self._origin[:, 1], self._origin[:, 2]
        c, s = np.cos(y0), np.sin(y0)
        north = n0 + c * si[:, 0] - s * si[:, 1]
        east = e0 + s * si[:, 0] + c * si[:, 1]
        yaw = np.array([wrap_pi(float(a)) for a in si[:, 2] + y0])
        world = WorldState(self.t_s, self.names, np.stack([north, east], axis=1), yaw, si[:, 3].copy(), si[:, 4].copy())
        for a in (world.pos_ned_m, world.yaw_rad, world.speed_mps, world.yaw_rate_radps):
            a.flags.writeable = False
        self._state, self._state_tick = world, self.tick
        return world

    # -- running -------------------------------------------------------------------------
    def step(self) -> None:
        """One tick: due tasks at t, then every FMU from t to t + dt, then the outputs checked.

        The check (docs/architecture.md, "Containing FMUs") is two vector operations over
        every vehicle's raw outputs, each divided by its bound
        (:data:`~lfctl.fmu.load.OUTPUT_BOUNDS`), and the sum of their squares: NaN and inf make
        it NaN or inf, and any output beyond its bound makes it exceed 1; only then is each
        instance checked (:meth:`~lfctl.fmu.load.FmuInstance.check_outputs`), which raises
        FmuError naming the FMU, the variable, the value and the time.
        """
        tick = self.tick
        clock = time.perf_counter
        for task in self._tasks:
            if tick >= task.next_tick:
                t0 = clock()
                task.fn(self.t_s)
                self.task_time_s[task.name] = self.task_time_s.get(task.name, 0.0) + clock() - t0
                task.runs += 1
                # due ticks come from the run count, so rounding never accumulates drift
                task.next_tick = task.start_tick + round(task.runs * task.ticks_per_run)
        dt = self.dt_s
        t0 = clock()
        host = self._host
        if host is not None:  # its process steps while this one steps the rest
            host.start_step(dt)
        for inst in self._local:
            inst.step(dt)
        if host is not None:
            host.finish_step()
        w = np.multiply(self._out_flat, self._out_weight, out=self._out_scratch)
        if not w.dot(w) <= 1.0:  # False for NaN too
            for inst in self._instances:
                inst.check_outputs()
        self.task_time_s["physics"] = self.task_time_s.get("physics", 0.0) + clock() - t0
        self.tick = tick + 1
        self.t_s = self.tick * dt
        self._state = None

    def run(
        self,
        duration_s: float | None = None,
        *,
        progress: Callable[[float, float], None] | None = None,
        stop: Callable[[], bool] | None = None,
    ) -> RunResult:
        """Run for ``duration_s`` (default the scenario's) and return the trajectory and timing.

        Parameters
        ----------
        duration_s : float, optional
            Simulated seconds, rounded to whole physics steps.
        progress : callable, optional
            Called as ``progress(t_s, wall_s)`` about once per simulated second, and after the
            last step.
        stop : callable, optional
            Asked after every step; when it says True the run ends with KeyboardInterrupt,
            between steps (a signal handler that only sets a flag, so an interrupt never
            lands inside a recorder's write).
        """
        if not self._opened:
            raise FmuError("Simulation.run() before open(): use `with Simulation(cfg) as sim:`", call="run")
        duration = self.config.sim.duration_s if duration_s is None else duration_s
        n_ticks = round(duration / self.dt_s)
        sample_every = max(1, round(1.0 / (self._sample_rate_hz * self.dt_s)))
        # packed samples (a list of each tick's arrays took about 0.3 MB a simulated minute)
        ts, pos, yaw, spd = array("d"), array("d"), array("d"), array("d")
        progress_every = max(1, round(1.0 / self.dt_s))
        wall0 = time.perf_counter()
        start_tick = self.tick
        for k in range(n_ticks):
            if k % sample_every == 0:
                st = self.state()
                ts.append(st.t_s)
                pos.extend(st.pos_ned_m.ravel())
                yaw.extend(st.yaw_rad)
                spd.extend(st.speed_mps)
            self.step()
            if stop is not None and stop():
                raise KeyboardInterrupt(f"stopped at t = {self.t_s:.2f} s")
            if self.realtime:
                lag = (self.tick - start_tick) * self.dt_s - (time.perf_counter() - wall0)
                if lag > 0:
                    time.sleep(lag)
            if progress is not None and (k % progress_every == 0 or k == n_ticks - 1):  # and at the end
                progress(self.t_s, time.perf_counter() - wall0)
        wall = time.perf_counter() - wall0
        final = self.state()
        ts.append(final.t_s)
        pos.extend(final.pos_ned_m.ravel())
        yaw.extend(final.yaw_rad)
        spd.extend(final.speed_mps)
        n = len(self.names)
        return RunResult(
            sim_time_s=n_ticks * self.dt_s,
            wall_time_s=wall,
            ticks=n_ticks,
            names=self.names,
            final=final,
            t_s=np.array(ts),
            pos_ned_m=np.array(pos).reshape(len(ts), n, 2),
            yaw_rad=np.array(yaw).reshape(len(ts), n),
            speed_mps=np.array(spd).reshape(len(ts), n),
            extra={"task_time_s": dict(self.task_time_s)},
        )
