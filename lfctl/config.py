"""Scenario TOML -> frozen dataclasses, validated; every error names the key.

``load_config(path)`` is the only reader of scenario files. Keys ending in ``_deg`` (and
``_degps`` for rates) fill the ``_rad`` (``_radps``) field of the same stem, converted once
here. Unknown keys, wrong types and out-of-range values raise :class:`ConfigError` naming
the dotted key, the value and what was expected.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import tomllib
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from lfctl.checks import NAME_PATTERN, Bound, check_host_port, check_inside, check_name, check_text, read_text_file
from lfctl.data import builtin_models
from lfctl.errors import ConfigError
from lfctl.link.params import formation_params

__all__ = [
    "MAX_CAMERA_PIXELS",
    "MAX_CAMERA_SIDE_PX",
    "MAX_FOV_DEG",
    "MAX_KEY_PARTS",
    "MAX_LIST",
    "MAX_SCENARIO_BYTES",
    "MAX_STEPS",
    "MAX_VEHICLES",
    "MAX_WAYPOINTS",
    "TAG_DICTIONARIES",
    "VEHICLE_ROLES",
    "AuditConfig",
    "BannerConfig",
    "CameraConfig",
    "Config",
    "FormationConfig",
    "GuidanceConfig",
    "LightKey",
    "LinkConfig",
    "LiveConfig",
    "MissionConfig",
    "OccluderConfig",
    "PropConfig",
    "RecordingConfig",
    "SceneConfig",
    "ScriptConfig",
    "SensingConfig",
    "SimConfig",
    "Slot",
    "VehicleConfig",
    "config_from_table",
    "load_config",
    "parse_config",
    "parse_host_port",
    "read_toml",
    "resolve_paths",
]

# ----------------------------------------------------------------------------------------
# Declared ranges: every number in a scenario has one, checked on construction (from TOML,
# from the Python API and from `dataclasses.replace` alike) and listed by `reference()`.

#: the most [[vehicles]] a scenario may hold (each gets a UDP port and a MAVLink system id)
MAX_VEHICLES = 64
#: the most [mission] waypoints: the endpoints hold 2000 mission items, home included
MAX_WAYPOINTS = 1999
#: the most entries in any other list (props, occluders, lighting keys, script segments, dropouts)
MAX_LIST = 1000
#: the most pixels in a camera image (4096 x 2160, DCI 4K): rendering takes about 100 bytes
#: a pixel (0.9 GB at this size, per camera)
MAX_CAMERA_PIXELS = 4096 * 2160
#: the longest side of a camera image, px
MAX_CAMERA_SIDE_PX = 4096
#: the largest scenario file read, bytes
MAX_SCENARIO_BYTES = 1024 * 1024
#: the most simulation steps in one run (duration_s / dt_s)
MAX_STEPS = 100_000_000
#: the ArUco / AprilTag dictionaries a banner may print its tag from (``banner.aruco_dictionary``,
#: cv2.aruco's ``DICT_<name>``): bits along a side inside the black border, and how many ids
TAG_DICTIONARIES: dict[str, tuple[int, int]] = {
    "4X4_50": (4, 50),
    "4X4_100": (4, 100),
    "5X5_50": (5, 50),
    "6X6_50": (6, 50),
    "APRILTAG_16h5": (4, 30),
    "APRILTAG_36h11": (6, 587),
}

#: the widest slot bearing the trail law holds, deg (lfctl.guidance.formation.TRAIL_MAX_BEARING_RAD:
#: config may not import guidance, a test keeps the two equal)
TRAIL_MAX_BEARING_DEG = 30.0
#: the sliding-mode law holds slots below this bearing either side: abeam, the follower's
#: speed no longer changes the range, and past it the range law's sign turns round
SMC_MAX_BEARING_DEG = 90.0
_BEARING_NOTE = f'either side: < {SMC_MAX_BEARING_DEG:g} with guidance.controller = "smc", <= {TRAIL_MAX_BEARING_DEG:g} with "trail"'
#: the widest field of view a camera may have, deg (hfov_deg's bound; a calibration's focal
#: length is a pinhole's, under it)
MAX_FOV_DEG = 170.0
_FOCAL_NOTE = f"0, or >= {{0}}_px / 2 / tan({MAX_FOV_DEG / 2:g} deg) (a field of view under {MAX_FOV_DEG:g} deg)"

#: a follower's slot and guidance start its ``LFC_*`` parameters, which a ground station may
#: set: each key that sets one takes that parameter's range (one source; a value outside it
#: would be refused when the run starts)
_LFC = {name: Bound(p.lo, p.hi) for name, p in formation_params().items()}

#: a position or distance in the local frame, m (100 km each way)
_POS = Bound(-1e5, 1e5)
#: a positive length of a thing in the scene, m
_SIZE = Bound(0, 100, lo_open=True)
#: a rate of a subsystem, Hz
_RATE = Bound(0.001, 1000)  # Hz: once in about 17 min at the least (a period the scheduler can count)
#: a time in the run, s
_TIME = Bound(0, 1e6)


def _f(default: Any = dataclasses.MISSING, bound: Bound | None = None, *, factory: Any = None, **more: Any) -> Any:
    """A dataclass field with its declared range (``bound``; for ``_rad`` fields in degrees)
    and, for lists, ``max_items`` and per-position ``items`` bounds with the allowed ``arity``."""
    meta = {"bound": bound, **more}
    if factory is not None:
        return field(default_factory=factory, metadata=meta)
    return field(default=default, metadata=meta)


def _shown(field_name: str, value: float) -> float:
    """A value in the unit its TOML key has (degrees for ``_rad`` fields)."""
    if field_name.endswith(("_rad", "_radps")) and isinstance(value, float):
        return round(math.degrees(value), 9)  # 200 deg, not 200.00000000000003
    return value


def _check_fields(obj: Any, prefix: str) -> None:
    """Each field against what its metadata declares: range, list length, entries, name rules."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        key = f"{prefix}.{_toml_key(f.name)}"
        md = f.metadata
        bound: Bound | None = md.get("bound")
        if bound is not None and value is not None:
            bound.check(key, _shown(f.name, value))
        if md.get("name") and value is not None and (value or not md.get("optional")):
            check_name(key, value)
        if md.get("text") and value is not None:
            check_text(key, value, md["text"])
        limit = md.get("max_items")
        if limit is not None and len(value) > limit:
            raise ConfigError(f"{key} may hold at most {limit} entries, got {len(value)}")
        each: Bound | None = md.get("each")
        if each is not None:
            for i, x in enumerate(value):
                each.check(f"{key}[{i}]", x)
        items: tuple[Bound, ...] | None = md.get("items")
        if items is not None:
            arity = md.get("arity", (len(items),))
            for i, entry in enumerate(value):
                if len(entry) not in arity:
                    raise ConfigError(f"{key}[{i}] must be {md['shape']}, got {list(entry)!r}")
                for j, x in enumerate(entry):
                    items[j].check(f"{key}[{i}] {md['names'][j]}", x)
        choices = _literals(type(obj)).get(f.name)
        if choices is not None and value not in choices:
            raise ConfigError(f"{key} must be one of {', '.join(repr(c) for c in choices)}, got {toml_value(value)}")


@functools.cache
def _literals(cls: type) -> dict[str, tuple[Any, ...]]:
    """Field -> the values a ``Literal`` field takes."""
    hints = typing.get_type_hints(cls)
    return {n: typing.get_args(t) for n, t in hints.items() if typing.get_origin(t) is Literal}


class _Section:
    """Base of every section: checks the declared ranges, then the section's own rules."""

    _key: typing.ClassVar[str] = ""

    def __post_init__(self) -> None:
        _check_fields(self, self._prefix())
        self._check()

    def _prefix(self) -> str:
        return self._key

    def _check(self) -> None:
        """Rules across fields (none by default)."""


# ----------------------------------------------------------------------------------------
# Sections


@dataclass(frozen=True)
class SimConfig(_Section):
    """[sim]: the co-simulation clock and the rates of each subsystem."""

    _key = "sim"
    #: physics step: every FMU advances by this much per tick, s
    dt_s: float = _f(0.01, Bound(1e-4, 1.0))
    duration_s: float = _f(60.0, Bound(0, 1e6, lo_open=True), note="at most 1e8 steps of dt_s")  # simulated time, s
    #: seeds every random stream (sensor noise, renderers): same seed, same run
    seed: int = _f(0, Bound(0, 2**63 - 1, integer=True))
    #: "lockstep" runs as fast as the CPU allows, deterministic; "realtime" paces to the wall
    #: clock and opens a UDP port per vehicle
    clock: Literal["lockstep", "realtime"] = "lockstep"
    guidance_rate_hz: float = _f(20.0, _RATE, note="<= 1 / dt_s")  # the leader's autopilot and each follower's stack
    camera_rate_hz: float = _f(30.0, _RATE, note="<= 1 / dt_s")  # rendered frames per follower (camera sensing)
    #: vehicle poses to the log and the trajectory kept for the summary
    telemetry_rate_hz: float = _f(10.0, _RATE, note="<= 1 / dt_s")
    #: each follower's formation status (NAMED_VALUE_FLOAT) to the ground station
    status_rate_hz: float = _f(2.0, _RATE, note="<= 1 / dt_s")
    #: "truth": range and bearing from the world truth with noise ([sensing]); "camera": each
    #: follower's view rendered and perceived
    sensing: Literal["truth", "camera"] = "truth"
    #: processes besides the main one that render and track followers' cameras: -1 one per
    #: spare core (at most one per follower beyond the first), 0 none
    camera_workers: int = _f(-1, Bound(-1, 64, integer=True))
    #: where the FMUs run: "auto" a user FMU (a vehicle's ``fmu``) in a process of its own and
    #: the built-in models in this one; "separate" every FMU in that process; "main" all here
    fmu_process: Literal["auto", "separate", "main"] = "auto"
    #: an FMU in a process of its own may take this long over one step before the run ends, s
    fmu_step_timeout_s: float = _f(10.0, Bound(0.01, 86400))

    def _check(self) -> None:
        if self.duration_s / self.dt_s > MAX_STEPS:
            raise ConfigError(
                f"sim.duration_s / dt_s = {self.duration_s / self.dt_s:.3g} steps; at most {MAX_STEPS:.0e} in one run"
            )
        for name in ("guidance_rate_hz", "camera_rate_hz", "telemetry_rate_hz", "status_rate_hz"):
            rate = getattr(self, name)
            if rate > 1.0 / self.dt_s + 1e-9:
                raise ConfigError(
                    f"sim.{name} = {rate!r} Hz is faster than the physics rate 1/dt = {1.0 / self.dt_s:g} Hz"
                )


#: the roles a vehicle FMU's variables play ([vehicles.map], [vehicles.units] keys)
VEHICLE_ROLES = ("speed_cmd", "yaw_rate_cmd", "north", "east", "yaw", "speed", "yaw_rate", "north_0", "east_0", "yaw_0")


@dataclass(frozen=True)
class VehicleConfig(_Section):
    """One [[vehicles]] entry.

    ``name`` (letters, digits, ``-``, ``_``) is unique; ``role`` is ``"leader"`` (exactly one,
    first) or ``"follower"``. ``model`` names a built-in model (fmu_models/); ``fmu`` a user
    FMU file instead (absolute, or relative to the scenario file's folder and inside it), with
    ``map`` (role -> variable name) and ``units`` (role -> unit) where its names differ.
    """

    name: str = _f(name=True)
    role: Literal["leader", "follower"] = _f()
    #: a built-in model's name (the name of a user FMU's model, with ``fmu``)
    model: str = _f("SkidSteerRover", name=True, builtin=True)
    fmu: str | None = _f(None, text=4096, note="absolute, or relative to the scenario's folder and inside it")
    fmi_version: int = _f(2, Bound(2, 3, integer=True))  # which build of a built-in model to load: 2 or 3
    north_m: float = _f(0.0, _POS)  # initial position north, local NED, m
    east_m: float = _f(0.0, _POS)  # initial position east, m
    yaw_rad: float = _f(0.0, Bound(-360, 360))  # initial heading, rad (TOML yaw_deg)
    #: FMU parameter name -> value (a Boolean parameter's: true or false, or 1 or 0)
    parameters: Mapping[str, float | bool] = _f(factory=dict, max_items=MAX_LIST, note="each a number, true or false")
    map: Mapping[str, str] = _f(factory=dict, note="a user FMU's only (with fmu); keys: the roles (see below)")
    units: Mapping[str, str] = _f(factory=dict, note="a user FMU's only (with fmu); keys: the roles (see below)")
    # follower only: whom to follow and where (the formation controller holds this slot)
    #: the vehicle it follows (None: as [formation] says)
    target: str | None = _f(None, name=True, note="another vehicle's name; no cycle of targets")
    #: commanded range to the target, m (None: as [formation] says)
    range_m: float | None = _f(None, _LFC["LFC_RANGE"])
    #: commanded bearing, clockwise positive (TOML bearing_deg)
    bearing_rad: float | None = _f(None, _LFC["LFC_BEARING"], note=_BEARING_NOTE)
    #: the ArUco tag its banner prints with ``banner.kind = "aruco"`` (None: ``banner.aruco_id``
    #: plus its place in [[vehicles]], the leader's 0); a follower looks for its target's id only
    aruco_id: int | None = _f(
        None, Bound(0, 586, integer=True), note='with banner.kind = "aruco" only; unique; < the dictionary\'s size'
    )
    #: follower only: false leaves it without a simulated companion computer: it waits as a
    #: Rover does (HOLD, disarmed) for one on its UDP port, ``lfctl follow`` (--realtime only)
    companion: bool = _f(True, note="followers only; false needs `lfctl sim --realtime`")

    def _prefix(self) -> str:
        ok = isinstance(self.name, str) and NAME_PATTERN.fullmatch(self.name)
        return f"vehicles[{self.name}]" if ok else "vehicles"

    def _check(self) -> None:
        key = self._prefix()
        if self.fmu is None and self.model not in (known := builtin_models()):
            raise ConfigError(f"{key}.model must be one of {', '.join(known)}, got {self.model!r}")
        if self.role == "leader":
            for k in ("target", "range_m", "bearing_rad"):
                if getattr(self, k) is not None:
                    raise ConfigError(f"{key}.{_toml_key(k)}: a leader follows nobody, got {getattr(self, k)!r}")
            if not self.companion:
                raise ConfigError(f"{key}.companion: a leader has no companion computer to leave out, got false")
        # the start pose's parameters are the vehicle's own keys' (a value here was overwritten by them)
        pose = {
            self.map.get(role, role): k
            for role, k in (("north_0", "north_m"), ("east_0", "east_m"), ("yaw_0", "yaw_deg"))
        }
        for p, v in self.parameters.items():
            check_text(f"{key}.parameters key", p)
            if not isinstance(v, bool):  # (a Boolean FMU parameter's value)
                Bound(-math.inf, math.inf).check(f"{key}.parameters.{p}", v)
            if p in pose:
                raise ConfigError(
                    f"{key}.parameters.{p}: the start pose is the vehicle's {pose[p]} key; set that instead, got {v!r}"
                )
        for table in ("map", "units"):
            for role, text in getattr(self, table).items():
                if role not in VEHICLE_ROLES:
                    raise ConfigError(f"{key}.{table}: unknown role {role!r} (roles: {', '.join(VEHICLE_ROLES)})")
                check_text(f"{key}.{table}.{role}", text)
        if self.fmu is None and (self.map or self.units):
            table = "map" if self.map else "units"
            raise ConfigError(
                f"{key}.{table}: map and units apply only to a user FMU (fmu = ...); "
                f"model {self.model!r} has its own names, got {toml_value(dict(getattr(self, table)))}"
            )


@dataclass(frozen=True)
class ScriptConfig(_Section):
    """[script]: open-loop inputs for runs without guidance.

    ``leader`` is a list of ``[duration_s, speed_mps, yaw_rate_deg_s]`` segments, repeated
    to the end of the run (used when ``[mission]`` has no waypoints); ``followers`` is
    ``"formation"`` (closed-loop formation control), ``"stand"`` (zero commands) or
    ``"copy"`` (the leader's commands, open loop).
    """

    _key = "script"
    leader: tuple[tuple[float, float, float], ...] = _f(
        ((4.0, 0.3, 0.0), (3.0, 0.3, 30.0)),
        max_items=MAX_LIST,
        items=(Bound(0, 1e6, lo_open=True), Bound(-100, 100), Bound(-3600, 3600)),
        names=("duration_s", "speed_mps", "yaw_rate_deg_s"),
        shape="[duration_s, speed_mps, yaw_rate_deg_s]",
        note="at least 1 entry",
    )
    followers: Literal["formation", "stand", "copy"] = "formation"

    def _check(self) -> None:
        if not self.leader:
            raise ConfigError("script.leader must have at least one [duration_s, speed_mps, yaw_rate_deg_s] segment")


@dataclass(frozen=True)
class MissionConfig(_Section):
    """[mission]: the leader's route in local NED, flown in AUTO.

    ``waypoints`` holds ``[north_m, east_m]`` or ``[north_m, east_m, hold_s]`` (wait there);
    ``file`` names a ground station's mission file instead (a QGroundControl ``.plan``, with
    its fence and rally points, or a QGC WPL ``.waypoints``). Without either the leader
    follows ``[script]``.
    """

    _key = "mission"
    waypoints: tuple[tuple[float, ...], ...] = _f(
        (),
        max_items=MAX_WAYPOINTS,
        items=(
            _POS,
            _POS,
            Bound(0, 32768, hi_open=True),
        ),  # a hold: a NAV_WAYPOINT's, whole seconds in Rover's signed 16 bits
        arity=(2, 3),
        names=("north_m", "east_m", "hold_s"),
        shape="[north_m, east_m] or [north_m, east_m, hold_s]",
        note="hold_s is whole seconds (a fraction is dropped, as Rover's mission item holds); not with file",
    )
    #: a waypoint driven through is reached within this distance, m (the leader's WP_RADIUS,
    #: Rover's range; 0: only by passing it); a point it stops on is driven onto
    acceptance_radius_m: float = _f(0.3, Bound(0, 100))
    cruise_speed_mps: float = _f(0.3, Bound(0, 100, lo_open=True))  # the leader's speed on straight legs, m/s
    #: LOS lookahead on the path, m; 0: pure pursuit of the waypoint (eq. 12)
    lookahead_m: float = _f(0.8, Bound(0, 1000))
    #: a QGroundControl .plan or QGC WPL .waypoints file flown instead of ``waypoints``
    file: str | None = _f(
        None, text=4096, note="absolute, or relative to the scenario's folder and inside it; not with waypoints"
    )

    def _check(self) -> None:
        if self.file is not None and self.waypoints:
            raise ConfigError("mission.file and mission.waypoints are two missions: give one of them")


_GAIN = Bound(0, 1000, lo_open=True)
_YAW_RATE = Bound(0, 3600, lo_open=True)  # deg/s
_ANGLE = Bound(0, 180, lo_open=True)  # deg


@dataclass(frozen=True)
class GuidanceConfig(_Section):
    """[guidance]: controller choice, gains and limits (leader heading, follower formation)."""

    _key = "guidance"
    #: followers' law: sliding mode, the P baseline, or the target's trail (its path, not a
    #: line to it: no corner cut)
    controller: Literal["smc", "p", "trail"] = "smc"
    trail_lookahead_m: float = _f(0.3, _LFC["LFC_LOOKAHEAD"])  # the trail law's lookahead distance, m
    #: followers' speed limit; also caps the leader's cruise speed
    max_speed_mps: float = _f(0.5, Bound(0, 100, lo_open=True))
    #: followers may back up this fast to restore the range
    reverse_speed_mps: float = _f(0.15, Bound(0, 100))
    #: every vehicle's yaw-rate limit (TOML max_yaw_rate_degps)
    max_yaw_rate_radps: float = _f(math.radians(90.0), _YAW_RATE)
    # followers' sliding-mode range law (RangeGains)
    range_eta_mps: float = _f(0.25, Bound(0, 100, lo_open=True))  # reaching rate outside the boundary layer, m/s
    range_phi_m: float = _f(0.25, Bound(0, 100, lo_open=True))  # boundary-layer half-width, m
    min_cos_bearing: float = _f(0.2, Bound(0, 1, lo_open=True))  # floor on |cos(bearing)| (the broadside singularity)
    # followers' sliding-mode bearing law (BearingGains); TOML *_degps, *_deg
    bearing_eta_radps: float = _f(math.radians(70.0), _YAW_RATE)  # yaw rate outside the boundary layer
    bearing_lambda_s: float = _f(0.1, Bound(0, 100))  # weight of the error rate in the sliding variable, s
    bearing_phi_rad: float = _f(math.radians(15.0), _ANGLE)  # boundary-layer half-width
    # the leader's sliding-mode heading law in AUTO (BearingGains); TOML *_degps, *_deg
    heading_eta_radps: float = _f(math.radians(60.0), _YAW_RATE)  # yaw rate outside the boundary layer
    heading_lambda_s: float = _f(0.1, Bound(0, 100))  # weight of the error rate in the sliding variable, s
    heading_phi_rad: float = _f(math.radians(20.0), _ANGLE)  # boundary-layer half-width
    #: fraction of its speed the leader sheds for a 180 deg turn
    turn_slowdown: float = _f(0.6, Bound(0, 1))
    p_gain: float = _f(0.8, _GAIN)  # the P baseline's position gain (FOLL_POS_P), 1/s
    coast_s: float = _f(2.0, _LFC["LFC_COAST"])  # followers coast on their filter this long without a measurement, s
    slowdown_s: float = _f(1.0, Bound(0, 3600, lo_open=True))  # then slow to a stop over this long before LOST, s
    #: once LOST, turn in place one full turn at this rate to look for the target (TOML
    #: search_yaw_rate_degps; 0: hold still; at most max_yaw_rate; only a follower of the leader nobody follows)
    search_yaw_rate_radps: float = _f(0.0, _LFC["LFC_SEARCH"])  # deg/s


@dataclass(frozen=True)
class SensingConfig(_Section):
    """[sensing]: the truth sensor (``--sensing truth``): noise, delay, field of view, dropouts.

    ``dropouts`` are ``[start_s, end_s]`` windows with no measurement: an occluder crossing.
    """

    _key = "sensing"
    range_noise_m: float = _f(0.01, Bound(0, 100))  # 1-sigma Gaussian noise on the range, m
    #: 1-sigma noise on the bearing (TOML bearing_noise_deg)
    bearing_noise_rad: float = _f(math.radians(0.3), Bound(0, 180))
    delay_s: float = _f(0.05, Bound(0, 1))  # age of a measurement when the follower gets it, s
    #: full field of view; outside it the target is hidden (TOML fov_deg)
    fov_rad: float = _f(math.radians(360.0), Bound(0, 360, lo_open=True))
    max_range_m: float = _f(10.0, Bound(0, 1e4, lo_open=True))  # the target is hidden beyond this range, m
    dropouts: tuple[tuple[float, float], ...] = _f(
        (),
        max_items=MAX_LIST,
        items=(_TIME, _TIME),
        names=("start_s", "end_s"),
        note="start_s < end_s",
        shape="[start_s, end_s]",
    )

    def _check(self) -> None:
        for i, w in enumerate(self.dropouts):
            if not w[0] < w[1]:
                raise ConfigError(f"sensing.dropouts[{i}] must be [start_s, end_s] with start < end, got {list(w)!r}")


@dataclass(frozen=True)
class FormationConfig(_Section):
    """[formation]: a shipped shape that fills each follower's target, range and bearing.

    ``shape``: ``"column"`` (one behind the other), ``"echelon"`` (a diagonal line back to the
    right), ``"vee"`` (alternating right and left arms). ``targets``: ``"chain"`` (follow the
    vehicle ahead in the shape) or ``"leader"`` (all follow the leader). A follower's own
    ``target``/``range_m``/``bearing_deg`` override the shape.
    """

    _key = "formation"
    shape: Literal["none", "column", "echelon", "vee"] = "none"
    targets: Literal["chain", "leader"] = "chain"
    #: range to the target, m; with targets = "leader", times the place in line or arm
    spacing_m: float = _f(1.5, _LFC["LFC_RANGE"], note='times the place in line with targets = "leader": at most 1000')
    #: echelon, vee: how far off straight behind a follower sits (TOML angle_deg)
    angle_rad: float = _f(math.radians(30.0), Bound(0, 90, hi_open=True), note=_BEARING_NOTE)


@dataclass(frozen=True)
class CameraConfig(_Section):
    """[camera]: the pinhole camera on each follower (and the real camera for `lfctl follow`).

    Intrinsics come from ``hfov_deg`` unless ``fx_px`` (and optionally ``fy_px``, ``cx_px``,
    ``cy_px``) are given. ``tracker`` picks the tracker the frames feed (the ablation's
    baselines ``"hue"`` and ``"hs-lbp"``, or lfctl's ``"full"``). The mount is ``mount_forward_m`` ahead of the vehicle's reference
    point at ``mount_height_m`` above the ground, pitched ``pitch_deg`` (positive: nose up).
    An image holds at most :data:`MAX_CAMERA_PIXELS`.
    """

    _key = "camera"
    #: image width, px
    width_px: int = _f(640, Bound(16, MAX_CAMERA_SIDE_PX, integer=True), note="width x height <= 8847360")
    #: image height, px
    height_px: int = _f(480, Bound(16, MAX_CAMERA_SIDE_PX, integer=True), note="width x height <= 8847360")
    #: horizontal field of view, sets fx (TOML hfov_deg)
    hfov_rad: float = _f(math.radians(62.0), Bound(0, MAX_FOV_DEG, lo_open=True, hi_open=True))
    fx_px: float = _f(0.0, Bound(0, 1e5), note=_FOCAL_NOTE.format("width"))  # focal length, px; 0: from hfov
    fy_px: float = _f(0.0, Bound(0, 1e5), note=_FOCAL_NOTE.format("height"))  # focal length, px; 0: fx
    cx_px: float = _f(0.0, Bound(0, 1e5), note="< width_px")  # principal point, px; 0: the image centre
    cy_px: float = _f(0.0, Bound(0, 1e5), note="< height_px")  # principal point, px; 0: the image centre
    # lens distortion, OpenCV's model (a calibration's k1, k2, p1, p2, k3 as cv2.calibrateCamera
    # gives them); the renderer bends its frames by them and the pose takes them out
    k1: float = _f(0.0, Bound(-10, 10))  # radial distortion
    k2: float = _f(0.0, Bound(-10, 10))  # radial distortion, second coefficient
    p1: float = _f(0.0, Bound(-1, 1))  # tangential distortion
    p2: float = _f(0.0, Bound(-1, 1))  # tangential distortion, second coefficient
    k3: float = _f(0.0, Bound(-100, 100))  # radial distortion, third coefficient
    mount_forward_m: float = _f(0.12, Bound(-10, 10))  # camera ahead of the vehicle's reference point, m
    mount_height_m: float = _f(0.2, Bound(0, 100))  # camera above the ground, m
    pitch_rad: float = _f(0.0, Bound(-60, 60))  # positive: nose up (TOML pitch_deg)
    noise_sigma: float = _f(2.0, Bound(0, 255))  # sensor read noise (signal-independent), digital numbers
    motion_blur: bool = False  # blur rendered frames along the image rows while the follower turns
    # The sensor effects below apply with scene.realism = "on"; "off" (the default) draws the
    # flat look, with only noise_sigma and motion_blur. docs/rendering.md gives each one's cost.
    #: shot noise: the noise variance added per digital number of signal (0: read noise only)
    shot_noise: float = _f(0.06, Bound(0, 10))
    auto_exposure: bool = True  # the gain follows the scene's brightness, with a lag
    #: the auto-exposure's time constant: how slowly the gain follows a change of light, s
    exposure_lag_s: float = _f(0.4, Bound(0, 60))
    exposure_target: float = _f(0.45, Bound(0, 1, lo_open=True, hi_open=True))  # mean level it aims at, of full scale
    #: white balance drift: relative swing of the red and blue gains against green (0: none)
    white_balance_drift: float = _f(0.03, Bound(0, 0.5))
    vignetting: float = _f(0.3, Bound(0, 1, hi_open=True))  # light lost in the image corners, fraction
    #: JPEG compression of every frame at this quality, as a compressed stream delivers it (0: none)
    jpeg_quality: int = _f(0, Bound(0, 100, integer=True))
    #: rolling shutter: the time the sensor takes to read from the top row to the bottom one, s (0: global shutter)
    rolling_shutter_s: float = _f(0.0, Bound(0, 0.2))
    #: the tracker the camera feeds: "full" (lfctl's), "hs-lbp" (the paper's features, no
    #: filters) or "hue" (the paper's hue-only CAMShift baseline); see lfctl.vision.tracker
    tracker: Literal["full", "hs-lbp", "hue"] = "full"

    def _check(self) -> None:
        if self.width_px * self.height_px > MAX_CAMERA_PIXELS:
            raise ConfigError(
                f"camera.width_px x height_px must be at most {MAX_CAMERA_PIXELS} pixels, "
                f"got {self.width_px}x{self.height_px} = {self.width_px * self.height_px}"
            )
        # a calibration's principal point lies on the picture, and its focal lengths are a
        # pinhole's (a field of view under 170 deg, as hfov_deg's): others are typing slips
        for key, size, side in (("cx_px", self.width_px, "width_px"), ("cy_px", self.height_px, "height_px")):
            value = getattr(self, key)
            if value >= size:  # (on the far edge, the camera would see nothing on that side)
                raise ConfigError(
                    f"camera.{key} must lie on the picture (below camera.{side} = {size}; 0: its centre), got {value:g}"
                )
        for key, size, side in (("fx_px", self.width_px, "width_px"), ("fy_px", self.height_px, "height_px")):
            value = getattr(self, key)
            least = size / 2 / math.tan(math.radians(MAX_FOV_DEG / 2))
            if 0 < value < least:
                raise ConfigError(
                    f"camera.{key} = {value:g} px would be a field of view over {MAX_FOV_DEG:g} deg across camera.{side} = "
                    f"{size} px (a pinhole's focal length is at least {least:.3g} px there)"
                )


@dataclass(frozen=True)
class BannerConfig(_Section):
    """[banner]: the leader's banner, a textured panel on the vehicle's back carrying either
    four markers of one hue on a square of side ``side_m`` (the paper's E; ``kind =
    "markers"``) or one ArUco tag of side ``tag_size_m`` at its centre (``kind = "aruco"``).
    The panel's size, height and place on the vehicle are the same for both."""

    _key = "banner"
    side_m: float = _f(0.14, Bound(0, 10, lo_open=True))  # side of the square the marker centres sit on, m
    marker_size_m: float = _f(0.035, Bound(0, 10, lo_open=True))  # side of one square marker, m
    #: side of the square panel, m
    panel_size_m: float = _f(0.22, Bound(0, 10, lo_open=True), note=">= side_m + marker_size_m")
    centre_height_m: float = _f(0.2, Bound(0, 100, lo_open=True))  # height of the banner's centre above the ground, m
    #: the banner's plane is this far behind the vehicle's reference point (its centre of
    #: rotation), m: a follower measures the banner and adds this to reach the vehicle
    back_m: float = _f(0.155, Bound(0, 100))
    marker_hue_deg: float = _f(0.0, Bound(0, 360, hi_open=True))  # red; HSV hue in degrees
    marker_saturation: float = _f(0.85, Bound(0, 1))  # the markers' HSV saturation in the rendered scene
    #: near white: the markers carry the hue
    panel_bgr: tuple[int, ...] = _f((215, 218, 222), each=Bound(0, 255, integer=True), note="3 entries")
    #: what the panel carries: "markers" (the paper's four) or "aruco" (one tag; each vehicle's
    #: banner prints its own id, see ``vehicles.aruco_id``)
    kind: Literal["markers", "aruco"] = "markers"
    #: the tag's dictionary (cv2.aruco's DICT_<name>)
    aruco_dictionary: Literal["4X4_50", "4X4_100", "5X5_50", "6X6_50", "APRILTAG_16h5", "APRILTAG_36h11"] = "4X4_50"
    #: the leader's tag id; each vehicle after it prints the next id unless it sets its own
    aruco_id: int = _f(0, Bound(0, 586, integer=True), note="< the dictionary's size")
    #: side of the tag's black square, m (a one-cell white margin must fit around it)
    tag_size_m: float = _f(0.165, Bound(0, 10, lo_open=True), note="+ 2 cells <= panel_size_m")
    #: the panel's thickness, m: its edges show when it is seen at an angle (scene.realism "on")
    thickness_m: float = _f(0.005, Bound(0, 1))
    #: how glossy the print is: the strength of the sun's glare on it, 0 matte (scene.realism "on")
    gloss: float = _f(0.3, Bound(0, 1))

    def _check(self) -> None:
        if len(self.panel_bgr) != 3:
            raise ConfigError(f"banner.panel_bgr must be [b, g, r] within 0..255, got {list(self.panel_bgr)!r}")
        if self.side_m + self.marker_size_m > self.panel_size_m:
            raise ConfigError(
                f"banner.side_m + marker_size_m ({self.side_m + self.marker_size_m:g}) must fit on panel_size_m ({self.panel_size_m:g})"
            )
        bits, ids = TAG_DICTIONARIES[self.aruco_dictionary]
        if self.aruco_id >= ids:
            raise ConfigError(f"banner.aruco_id must be below {ids} for {self.aruco_dictionary}, got {self.aruco_id}")
        # the tag is bits + 2 cells wide (its black border included); the detector needs a
        # light margin of at least one cell around it
        with_margin = self.tag_size_m * (bits + 4) / (bits + 2)
        if self.kind == "aruco" and with_margin > self.panel_size_m + 1e-9:
            raise ConfigError(
                f"banner.tag_size_m with a one-cell margin each side ({with_margin:g}) must fit on "
                f"panel_size_m ({self.panel_size_m:g}): tag_size_m at most "
                f"{self.panel_size_m * (bits + 2) / (bits + 4):g} for {self.aruco_dictionary}"
            )


@dataclass(frozen=True)
class PropConfig(_Section):
    """One [[scene.props]]: a vertical panel in the world, still or moving.

    ``kind``: ``"wall"`` / ``"box"`` (textured clutter), ``"distractor"`` (flat, the markers'
    hue at saturation 0.6), ``"textured_distractor"`` (the markers' hue and saturation,
    hatched), ``"panel_clutter"`` (flat, the banner panel's colour).
    """

    _key = "scene.props"
    kind: Literal["wall", "box", "distractor", "textured_distractor", "panel_clutter"] = _f()
    north_m: float = _f(bound=_POS)  # the panel's centre at t = 0, local NED, m
    east_m: float = _f(bound=_POS)  # the panel's centre at t = 0, m
    yaw_rad: float = _f(0.0, Bound(-360, 360))  # the panel's normal, from north
    width_m: float = _f(0.5, _SIZE)  # the panel's size, m
    height_m: float = _f(0.5, _SIZE)  # the panel's size, m
    base_m: float = _f(0.0, Bound(0, 100))  # height of the lower edge above ground
    vel_north_mps: float = _f(0.0, Bound(-100, 100))  # constant velocity of the panel, north, m/s
    vel_east_mps: float = _f(0.0, Bound(-100, 100))  # constant velocity of the panel, east, m/s


@dataclass(frozen=True)
class OccluderConfig(_Section):
    """One [[scene.occluders]]: a panel that crosses between a follower and its target.

    At ``t_s`` it appears ``lateral_m`` to the side of the line of sight, ``fraction`` of the
    way from the follower to the target, and moves across it at ``speed_mps``. Its path is
    fixed in the world when it appears: it reaches that line after ``lateral_m /
    speed_mps`` (3 s with the defaults), by when a pair driving at 0.3 m/s has moved on and
    the panel may pass behind the follower; a nearer, shorter crossing (``fraction`` 0.6,
    ``lateral_m`` 0.8) hides the target from a moving follower.
    """

    _key = "scene.occluders"
    t_s: float = _f(bound=_TIME)
    #: whose view it crosses ("": every follower's)
    follower: str = _f("", name=True, optional=True, note="a vehicle's name")
    width_m: float = _f(0.6, _SIZE)  # the panel's size, m
    height_m: float = _f(0.6, _SIZE)  # the panel's size, m
    speed_mps: float = _f(0.4, Bound(0, 100, lo_open=True))
    fraction: float = _f(0.5, Bound(0, 1, lo_open=True, hi_open=True))
    lateral_m: float = _f(1.2, Bound(0, 1000, lo_open=True))


@dataclass(frozen=True)
class LightKey(_Section):
    """One [[scene.lighting]] key frame; gain and tint are interpolated between keys."""

    _key = "scene.lighting"
    t_s: float = _f(bound=_TIME, note="keys in time order")  # when this key holds, s
    gain: float = _f(1.0, Bound(0, 100, lo_open=True))  # brightness factor
    #: per-channel factors (B, G, R)
    tint_bgr: tuple[float, ...] = _f((1.0, 1.0, 1.0), each=Bound(0, 100, lo_open=True), note="3 entries")

    def _check(self) -> None:
        if len(self.tint_bgr) != 3:
            raise ConfigError(f"scene.lighting.tint_bgr must be three positive factors, got {list(self.tint_bgr)!r}")


@dataclass(frozen=True)
class SceneConfig(_Section):
    """[scene]: what the simulated camera sees besides the vehicles."""

    _key = "scene"
    ground: Literal["concrete", "checker", "carpet"] = "concrete"  # the floor's texture
    props: tuple[PropConfig, ...] = _f((), max_items=MAX_LIST)  # [[scene.props]]: still or moving panels
    #: [[scene.occluders]]: panels crossing a line of sight
    occluders: tuple[OccluderConfig, ...] = _f((), max_items=MAX_LIST)
    #: [[scene.lighting]] key frames (none: constant light)
    lighting: tuple[LightKey, ...] = _f((), max_items=MAX_LIST)
    flicker_amplitude: float = _f(0.0, Bound(0, 1, hi_open=True))  # relative brightness swing of a flicker
    flicker_hz: float = _f(0.0, Bound(0, 1000))  # its frequency, Hz (0: none)
    #: < 1: a shadow sweeps across (realism "on": a cloud's shadow crossing the ground and the
    #: vehicles on it, which keep this fraction of their light; "off": a band across the image)
    shadow_gain: float = _f(1.0, Bound(0, 1, lo_open=True))
    #: period of that shadow's sweep, s
    shadow_period_s: float = _f(20.0, Bound(0, 1e6, lo_open=True))
    #: "on": a shaded rover with wheels and shadows, a printed banner, sun and cast shadows, full
    #: resolution, photographed textures and the camera's sensor effects (about 3 ms more per
    #: 640 x 480 frame: a camera run slows from about 5x to about 3x real time, docs/rendering.md);
    #: "off", the default: the flat look, fast (the vision benchmark's tiers render "on")
    realism: Literal["on", "off"] = "off"
    #: "footage": ground, walls and background photographed (frames of footage/, chosen per
    #: seed; the vision benchmark's tiers use them); "procedural": drawn from noise, the
    #: default (the look the realistic tests and figures were measured with; the convoy
    #: follows alike on both, docs/rendering.md); realism "on" only
    textures: Literal["footage", "procedural"] = "procedural"
    #: where the sun is, from north, clockwise (TOML sun_azimuth_deg)
    sun_azimuth_rad: float = _f(math.radians(140.0), Bound(-360, 360))
    #: the sun's height above the horizon (TOML sun_elevation_deg)
    sun_elevation_rad: float = _f(math.radians(35.0), Bound(5, 90))
    #: the share of the light that is not direct sun: what a shadow keeps (1: overcast, no shadows)
    ambient: float = _f(0.45, Bound(0, 1))
    shadows: bool = True  # vehicles and props cast shadows on the ground from the sun

    def _check(self) -> None:
        times = [k.t_s for k in self.lighting]
        if times != sorted(times):
            raise ConfigError(f"scene.lighting key frames must be in time order, got t_s {times!r}")


@dataclass(frozen=True)
class AuditConfig(_Section):
    """[audit]: limits `lfctl audit --strict` enforces on this scenario's logs."""

    _key = "audit"
    #: largest range error RMS, as a fraction of the commanded range
    max_range_err_rms_frac: float = _f(0.10, Bound(0, 100, lo_open=True))
    max_bearing_err_rms_deg: float = _f(5.0, _ANGLE)  # largest bearing error RMS, degrees
    min_separation_m: float = _f(0.3, Bound(0, 1000))  # closest any follower may come to another vehicle, m


@dataclass(frozen=True)
class LinkConfig(_Section):
    """[link]: MAVLink. Vehicle n (leader 0) listens on ``udp_base_port + n`` with
    ``--realtime`` and sends telemetry to ``gcs_udpout`` too; home is the geodetic origin of
    the local NED frame (GLOBAL_POSITION_INT, missions)."""

    _key = "link"
    #: address the vehicles' UDP ports bind to
    udp_host: str = _f("127.0.0.1", text=253, note="a host name or an address")
    #: the leader's port; vehicle n listens on this + n
    udp_base_port: int = _f(14561, Bound(1, 65535, integer=True), note="+ vehicles - 1 <= 65535")
    #: where every vehicle also sends its telemetry: HOST:PORT, or "" for none
    gcs_udpout: str = _f("127.0.0.1:14550", text=260, note="HOST:PORT (port 1..65535) or empty")
    home_lat_deg: float = _f(12.9602, Bound(-90, 90))  # CSIR-NAL, Bengaluru
    home_lon_deg: float = _f(77.6690, Bound(-180, 180))  # home longitude, degrees
    home_alt_m: float = _f(900.0, Bound(-1000, 1e5))  # home altitude, m
    #: how often the endpoints read their links and stream telemetry, Hz
    rate_hz: float = _f(50.0, _RATE)
    #: non-empty: MAVLink 2 signing on the UDP links (key = SHA-256)
    signing_passphrase: str = _f("", text=1024)

    def _check(self) -> None:
        if not re.fullmatch(r"[A-Za-z0-9.:_-]{1,253}", self.udp_host):
            raise ConfigError(f"link.udp_host must be a host name or an address, got {self.udp_host!r}")
        if self.gcs_udpout:
            check_host_port("link.gcs_udpout", self.gcs_udpout)


@dataclass(frozen=True)
class RecordingConfig(_Section):
    """[recording]: the run's MCAP log (``<dir>/<UTC time>-<scenario>-<seed>.mcap``; ``dir``
    relative to the working folder)."""

    _key = "recording"
    enabled: bool = True  # record the run (`lfctl sim --no-record` turns it off too)
    dir: str = _f("logs", text=4096)
    images: bool = True  # record the camera frames (camera sensing only)
    image_format: Literal["h264", "jpeg"] = "h264"  # H.264 video (foxglove.CompressedVideo) or JPEG images
    image_rate_hz: float = _f(30.0, _RATE)  # at most the camera rate
    jpeg_quality: int = _f(85, Bound(1, 100, integer=True))  # JPEG quality of recorded frames
    video_bitrate_kbps: int = _f(800, Bound(50, 50_000, integer=True))  # H.264 target bitrate, kbit/s
    video_gop: int = _f(30, Bound(1, 600, integer=True))  # H.264 frames from one keyframe to the next
    compression: Literal["zstd", "lz4", "none"] = "zstd"  # of the MCAP chunks
    chunk_size_bytes: int = _f(1024 * 1024, Bound(1024, 256 * 1024 * 1024, integer=True))  # MCAP chunk size


@dataclass(frozen=True)
class LiveConfig(_Section):
    """[live]: what `--live` and `--video` serve while a run goes on."""

    _key = "live"
    #: host:port of the Foxglove WebSocket (`--live` without a value); port 0: a free one
    foxglove: str = _f("127.0.0.1:8765", text=260, note="HOST:PORT, port 0..65535 (0: a free one)")
    #: host:port the RTP/UDP H.264 stream goes to (`--video` without a value)
    video: str = _f("127.0.0.1:5600", text=260, note="HOST:PORT, port 1..65535")
    video_annotated: bool = True  # draw the tracked window, markers and state on the streamed view
    video_bitrate_kbps: int = _f(1500, Bound(50, 50_000, integer=True))  # the stream's H.264 target bitrate, kbit/s

    def _check(self) -> None:
        parse_host_port(self.foxglove, "live.foxglove")
        check_host_port("live.video", self.video)


def parse_host_port(text: str, what: str) -> tuple[str, int]:
    """``HOST:PORT`` of a server lfctl starts, as (host, port): port 0 asks for a free port.
    :class:`ConfigError` naming ``what`` and the value otherwise.

    Parameters
    ----------
    text : str
        ``127.0.0.1:8765``.
    what : str
        The option or key it came from, for the error.
    """
    return check_host_port(what, text, allow_any_port=True)


@dataclass(frozen=True)
class Slot:
    """Where a follower keeps itself."""

    target: str  # the vehicle it follows
    range_m: float  # commanded range to it, m
    bearing_rad: float  # commanded bearing to it, clockwise positive, rad


@dataclass(frozen=True)
class Config:
    """A whole scenario, as :func:`load_config` reads it.

    Parameters
    ----------
    name : str
        The scenario's name (the file's stem unless the file sets ``name``).
    sim : SimConfig
        ``[sim]``.
    vehicles : tuple of VehicleConfig
        ``[[vehicles]]``: the leader first, then the followers; names unique, follower targets
        leading back to the leader without a cycle.
    script, mission, guidance, sensing, formation, camera, banner, scene, recording, link, live, audit
        The other sections (``[script]``, ``[mission]``, ...), defaults where absent.
    source : str
        The TOML text, kept for the run record.
    """

    name: str
    sim: SimConfig
    vehicles: tuple[VehicleConfig, ...]
    script: ScriptConfig = field(default_factory=ScriptConfig)
    mission: MissionConfig = field(default_factory=MissionConfig)
    guidance: GuidanceConfig = field(default_factory=GuidanceConfig)
    sensing: SensingConfig = field(default_factory=SensingConfig)
    formation: FormationConfig = field(default_factory=FormationConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    banner: BannerConfig = field(default_factory=BannerConfig)
    scene: SceneConfig = field(default_factory=SceneConfig)
    recording: RecordingConfig = field(default_factory=RecordingConfig)
    link: LinkConfig = field(default_factory=LinkConfig)
    live: LiveConfig = field(default_factory=LiveConfig)
    audit: AuditConfig = field(default_factory=AuditConfig)
    source: str = ""  # the TOML text, kept for the run record

    def __post_init__(self) -> None:
        check_name("name", self.name)
        if not self.vehicles:
            raise ConfigError("vehicles: need at least one [[vehicles]] entry, got none")
        if len(self.vehicles) > MAX_VEHICLES:
            raise ConfigError(f"vehicles: at most {MAX_VEHICLES} [[vehicles]], got {len(self.vehicles)}")
        last_port = self.link.udp_base_port + len(self.vehicles) - 1
        if last_port > 65535:
            raise ConfigError(
                f"link.udp_base_port = {self.link.udp_base_port}: vehicle {len(self.vehicles) - 1} would listen on "
                f"port {last_port}, past 65535"
            )
        names = [v.name for v in self.vehicles]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ConfigError(f"vehicles.name must be unique, got {sorted(dup)!r} more than once")
        leaders = [v.name for v in self.vehicles if v.role == "leader"]
        if len(leaders) != 1:
            raise ConfigError(
                f'vehicles: need exactly one role = "leader", got {len(leaders)}'
                + (f" ({', '.join(leaders)})" if leaders else "")
            )
        if self.vehicles[0].role != "leader":
            raise ConfigError(f"vehicles: the leader must come first, got {self.vehicles[0].name!r} first")
        for v in self.vehicles:
            if v.target is not None and v.target not in names:
                raise ConfigError(
                    f"vehicles[{v.name}].target names an unknown vehicle {v.target!r} (known: {', '.join(names)})"
                )
            if v.target == v.name:
                raise ConfigError(f"vehicles[{v.name}].target cannot be the vehicle itself")
        for i, occ in enumerate(self.scene.occluders):
            if occ.follower and occ.follower not in names:
                raise ConfigError(
                    f"scene.occluders[{i}].follower names an unknown vehicle {occ.follower!r} (known: {', '.join(names)})"
                )
        if self.banner.kind == "aruco":
            self._check_tag_ids()
        else:  # a key that would be taken and ignored is refused, as map and units without an FMU are
            tagged = [v.name for v in self.vehicles if v.aruco_id is not None]
            if tagged:
                raise ConfigError(
                    f"vehicles[{tagged[0]}].aruco_id: a tag id applies only to an ArUco banner"
                    f' (banner.kind = "aruco"), got banner.kind = {self.banner.kind!r}'
                )
        if self.scene.textures == "footage" and self.scene.realism == "off":
            raise ConfigError(
                'scene.textures = "footage": photographed textures apply only with scene.realism = "on"'
                " (the flat look paints its own)"
            )
        if self.guidance.controller == "smc":
            for name, slot in self.slots().items():
                if abs(slot.bearing_rad) >= math.radians(SMC_MAX_BEARING_DEG) - 1e-12:
                    raise ConfigError(
                        f"vehicles[{name}]: a slot at bearing {math.degrees(slot.bearing_rad):g} deg is at or past the "
                        f'side, which guidance.controller = "smc" cannot hold (its speed sets the range along the '
                        f'line of sight: below {SMC_MAX_BEARING_DEG:g} deg): use "p"'
                    )
        if self.guidance.controller == "trail":
            for name, slot in self.slots().items():
                if abs(slot.bearing_rad) > math.radians(TRAIL_MAX_BEARING_DEG) + 1e-12:
                    raise ConfigError(
                        f"vehicles[{name}]: a slot at bearing {math.degrees(slot.bearing_rad):g} deg is wider than "
                        f'guidance.controller = "trail" holds (at most {TRAIL_MAX_BEARING_DEG:g} deg): use "smc"'
                    )
        rng = _LFC["LFC_RANGE"]
        for v in self.followers:  # a shape's range is spacing_m times the place in line: check the product
            slot = self.slots()[v.name]
            if v.range_m is None and not rng.contains(slot.range_m):
                raise ConfigError(
                    f"formation.spacing_m = {self.formation.spacing_m:g} puts vehicles[{v.name}] {slot.range_m:g} m "
                    f'from its target (with formation.targets = "leader", the spacing times its place in line): '
                    f"a slot's range must be {rng.text()} m (a smaller spacing_m, or the follower's own range_m)"
                )
        # followers' targets must lead back to the leader without a cycle
        target = {name: slot.target for name, slot in self.slots().items()}
        for start in target:
            seen, node = [start], target[start]
            while node in target:
                if node in seen:
                    raise ConfigError(f"vehicles: follower targets form a cycle: {' -> '.join([*seen, node])}")
                seen.append(node)
                node = target[node]

    def _check_tag_ids(self) -> None:
        """Each vehicle's tag id inside the dictionary, and no two vehicles with the same id."""
        b = self.banner
        _bits, size = TAG_DICTIONARIES[b.aruco_dictionary]
        given = {v.name: v.aruco_id for v in self.vehicles}

        def which(name: str, tag: int) -> str:
            if given[name] is not None:
                return f"vehicles[{name}].aruco_id {tag}"
            return f"vehicles[{name}]'s tag {tag} (banner.aruco_id {b.aruco_id} + its place in [[vehicles]])"

        owner: dict[int, str] = {}
        for name, tag in self.tag_ids().items():
            if tag >= size:
                raise ConfigError(f"{which(name, tag)} must be below {size} for {b.aruco_dictionary}")
            if tag in owner:
                raise ConfigError(
                    f"{which(name, tag)} is {which(owner[tag], tag)} too: each banner needs its own tag id "
                    "(give the vehicles their own vehicles.aruco_id)"
                )
            owner[tag] = name

    def tag_ids(self) -> dict[str, int]:
        """The ArUco tag id each vehicle's banner prints (with ``banner.kind = "aruco"``): its
        own ``aruco_id``, else ``banner.aruco_id`` plus its place in [[vehicles]]."""
        base = self.banner.aruco_id
        return {v.name: v.aruco_id if v.aruco_id is not None else base + i for i, v in enumerate(self.vehicles)}

    def banner_of(self, name: str) -> BannerConfig:
        """The banner vehicle ``name`` carries: ``[banner]`` with its own tag id.

        Parameters
        ----------
        name : str
            A vehicle's name.
        """
        return dataclasses.replace(self.banner, aruco_id=self.tag_ids()[name])

    def slots(self) -> dict[str, Slot]:
        """Each follower's target, range and bearing: its own keys, else the formation shape."""
        f = self.formation
        out: dict[str, Slot] = {}
        followers = [v for v in self.vehicles if v.role == "follower"]
        leader = self.vehicles[0].name
        for k, v in enumerate(followers, start=1):
            shaped = f.shape != "none"
            if f.shape == "vee":  # right arm first, then left, alternating
                side, rank = (1 if k % 2 else -1), (k + 1) // 2
                ahead = leader if rank == 1 else followers[k - 3].name
            else:
                side, rank = 1, k
                ahead = self.vehicles[k - 1].name
            # a follower back-right of its target sees it ahead-left: a negative bearing
            bearing = -side * f.angle_rad if f.shape in ("echelon", "vee") else 0.0
            chain = shaped and f.targets == "chain"
            target = ahead if chain else leader
            distance = f.spacing_m * (rank if shaped and not chain else 1)
            out[v.name] = Slot(
                target=v.target if v.target is not None else target,
                range_m=v.range_m if v.range_m is not None else distance,
                bearing_rad=v.bearing_rad if v.bearing_rad is not None else bearing,
            )
        return out

    @property
    def leader(self) -> VehicleConfig:
        """The one leader (validated to be first)."""
        return self.vehicles[0]

    @property
    def followers(self) -> tuple[VehicleConfig, ...]:
        """Every follower, in file order."""
        return self.vehicles[1:]


# ----------------------------------------------------------------------------------------
# Generic conversion: TOML tables -> the dataclasses above


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", None) or str(tp).replace("typing.", "")


def toml_value(value: object, limit: int = 80) -> str:
    """A value as a scenario file writes it (``true``, ``[1, 2]``, ``{a = 1}``), for an error
    message: what the user wrote, not Python's spelling of it; cut to ``limit`` characters."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, list):
        text = "[" + ", ".join(toml_value(v, limit) for v in value) + "]"
    elif isinstance(value, dict):
        text = "{" + ", ".join(f"{k} = {toml_value(v, limit)}" for k, v in value.items()) + "}"
    elif isinstance(value, str):
        text = repr(value)  # a TOML literal string when it holds no quote
    else:
        text = str(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _convert(value: Any, tp: Any, key: str) -> Any:
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        if bool in inner:  # a number, or true/false taken as given
            if isinstance(value, bool):
                return value
            if not isinstance(value, (int, float)):
                raise ConfigError(f"{key} must be a number, true or false, got {toml_value(value)}")
        return _convert(value, inner[0], key)
    if origin is Literal:
        if value not in args:
            raise ConfigError(f"{key} must be one of {', '.join(repr(a) for a in args)}, got {toml_value(value)}")
        return value
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise ConfigError(f"{key} must be a table, got {toml_value(value)}")
        return _build(tp, value, key)
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{key} must be a number, got {toml_value(value)}")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{key} must be an integer, got {toml_value(value)}")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(f"{key} must be a string, got {toml_value(value)}")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{key} must be true or false, got {toml_value(value)}")
        return value
    if origin is tuple:
        if not isinstance(value, list):
            raise ConfigError(f"{key} must be an array, got {toml_value(value)}")
        item = args[0]
        out = []
        for i, v in enumerate(value):
            try:
                out.append(_convert(v, item, f"{key}[{i}]"))
            except ConfigError as exc:  # a table's own checks name its section: add the index
                section = getattr(item, "_key", None)
                text = str(exc)
                if section and text.startswith(f"{section}."):
                    raise ConfigError(f"{key}[{i}].{text[len(section) + 1 :]}") from None
                raise
        return tuple(out)
    if origin in (Mapping, dict, typing.Mapping):
        if not isinstance(value, dict):
            raise ConfigError(f"{key} must be a table, got {toml_value(value)}")
        return {k: _convert(v, args[1], f"{key}.{k}") for k, v in value.items()}
    raise TypeError(f"config field type {_type_name(tp)} not handled")  # a bug in this module


def _build(cls: Any, table: dict[str, Any], prefix: str) -> Any:
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.name != "source"}
    kwargs: dict[str, Any] = {}
    for raw_key, value in table.items():
        name, convert = raw_key, None
        if raw_key.endswith("_deg") and f"{raw_key[:-4]}_rad" in fields:
            name, convert = f"{raw_key[:-4]}_rad", math.radians
        elif raw_key.endswith("_degps") and f"{raw_key[:-6]}_radps" in fields:
            name, convert = f"{raw_key[:-6]}_radps", math.radians
        key = f"{prefix}.{raw_key}" if prefix else raw_key
        if name not in fields or raw_key.endswith(("_rad", "_radps")):
            allowed = sorted(_toml_key(f) for f in fields)
            raise ConfigError(f"unknown key {key!r} (allowed here: {', '.join(allowed)})")
        if name in kwargs:
            raise ConfigError(f"{key} given twice (as degrees and radians)")
        converted = _convert(value, hints[name], key)
        kwargs[name] = convert(converted) if convert else converted
    missing = [
        n
        for n, f in fields.items()
        if n not in kwargs and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise ConfigError(
            f"{prefix or 'scenario'}: missing required key(s) {', '.join(repr(_toml_key(m)) for m in missing)}"
        )
    return cls(**kwargs)


def _toml_key(field_name: str) -> str:
    if field_name.endswith("_radps"):
        return field_name[:-6] + "_degps"
    if field_name.endswith("_rad"):
        return field_name[:-4] + "_deg"
    return field_name


#: the most dotted parts a TOML key may have here (a scenario's deepest has 3, a sweep's 2):
#: Python's TOML reader takes time growing with the square of a key's parts, so one key of
#: half a million parts in a 1 MiB file would hold it for hours
MAX_KEY_PARTS = 16


#: a TOML key part (bare, or quoted on one line) and a run of more than MAX_KEY_PARTS of
#: them joined by dots: wherever it stands (a key, a table header, an inline table; a comment
#: or a string too, where no scenario has one). Possessive, and starting only where a bare
#: part does, so that a long run of letters is scanned once, not once from each of its letters
_KEY_PART = r"""(?:[A-Za-z0-9_-]++|"(?:[^"\\\n]|\\.)*+"|'[^'\n]*+')"""
_LONG_KEY = re.compile(rf"(?<![A-Za-z0-9_-]){_KEY_PART}(?:[ \t]*+\.[ \t]*+{_KEY_PART}){{{MAX_KEY_PARTS},}}")


def read_toml(text: str) -> dict[str, Any]:
    """TOML text as :mod:`tomllib` reads it, every failure a ConfigError: bad TOML, arrays
    nested too deeply, or a key of more than :data:`MAX_KEY_PARTS` dotted parts (refused
    before it is parsed: see there).

    Parameters
    ----------
    text : str
        The TOML.
    """
    long = _LONG_KEY.search(text)
    if long is not None:
        line = text.count("\n", 0, long.start()) + 1
        parts = len(re.findall(rf"{_KEY_PART}", long.group()))
        raise ConfigError(f"line {line}: a key of {parts} dotted parts (at most {MAX_KEY_PARTS} are read)")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML: {exc}") from exc
    except RecursionError:
        raise ConfigError("arrays or tables nested too deeply to read") from None


def parse_config(text: str, name: str = "scenario") -> Config:
    """Parse and validate scenario TOML text; see :func:`load_config`.

    Parameters
    ----------
    text : str
        The TOML.
    name : str
        The scenario's name when the text sets none.

    Raises
    ------
    ConfigError
        Bad TOML (or a key of too many dotted parts, or over :data:`MAX_SCENARIO_BYTES`), unknown
        key, wrong type or out-of-range value.
    """
    text = text.removeprefix("\ufeff")  # a byte-order mark some editors write: not TOML, no meaning
    if len(text) > MAX_SCENARIO_BYTES:  # (a log's attachment, say: load_config checks a file's bytes)
        raise ConfigError(f"a scenario of {len(text)} characters: at most {MAX_SCENARIO_BYTES} are read")
    data = read_toml(text)  # (load_config names the file, as for a bad key)
    return config_from_table(data, name, text)


def config_from_table(table: Mapping[str, Any], name: str = "scenario", source: str = "") -> Config:
    """Build and validate a scenario from its TOML tables as :mod:`tomllib` reads them (a
    sweep edits a scenario's tables, then builds each variant with this).

    Parameters
    ----------
    table : mapping
        The scenario's top-level table; not modified.
    name : str
        The scenario's name when the table sets none.
    source : str
        The TOML text the table stands for, kept as :attr:`Config.source`.

    Raises
    ------
    ConfigError
        Unknown key, wrong type or out-of-range value.
    """
    data = dict(table)
    if isinstance(data.get("scenario"), str):  # (a sweep's base scenario: a scenario has no such key)
        raise ConfigError(
            f"unknown key 'scenario': this is a sweep over the scenario {data['scenario']!r}, not a scenario; "
            "run it with `lfctl sweep`"
        )
    data.setdefault("name", re.sub(r"[^A-Za-z0-9_-]", "_", name)[:64] or "scenario")
    data.setdefault("sim", {})
    vehicles = data.get("vehicles", [])
    if not isinstance(vehicles, list):
        raise ConfigError(f"vehicles must be an array of tables ([[vehicles]]), got {toml_value(vehicles)}")
    tables = []
    for i, v in enumerate(vehicles):
        if not isinstance(v, dict):
            raise ConfigError(f"vehicles[{i}] must be a table, got {toml_value(v)}")
        tables.append(v)
    data["vehicles"] = tables
    # Vehicle errors name the vehicle: build them one by one with their name in the key.
    built = []
    for i, v in enumerate(tables):
        label = f"vehicles[{v.get('name', i)}]"
        built.append(_build(VehicleConfig, v, label))
    rest = {k: v for k, v in data.items() if k != "vehicles"}
    top = _build(_ConfigTable, rest, "")
    sections = {f.name: getattr(top, f.name) for f in dataclasses.fields(_ConfigTable)}
    return Config(**sections, vehicles=tuple(built), source=source)


@dataclass(frozen=True)
class _ConfigTable:
    """Top-level keys other than [[vehicles]] (which parse_config builds one by one)."""

    name: str
    sim: SimConfig = field(default_factory=SimConfig)
    script: ScriptConfig = field(default_factory=ScriptConfig)
    mission: MissionConfig = field(default_factory=MissionConfig)
    guidance: GuidanceConfig = field(default_factory=GuidanceConfig)
    sensing: SensingConfig = field(default_factory=SensingConfig)
    formation: FormationConfig = field(default_factory=FormationConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    banner: BannerConfig = field(default_factory=BannerConfig)
    scene: SceneConfig = field(default_factory=SceneConfig)
    recording: RecordingConfig = field(default_factory=RecordingConfig)
    link: LinkConfig = field(default_factory=LinkConfig)
    live: LiveConfig = field(default_factory=LiveConfig)
    audit: AuditConfig = field(default_factory=AuditConfig)


def load_config(path: str | Path) -> Config:
    """Read and validate a scenario file.

    Parameters
    ----------
    path : str or Path
        A TOML scenario (see examples/).

    Raises
    ------
    ConfigError
        Unreadable file (or not a regular file, or over :data:`MAX_SCENARIO_BYTES`), bad TOML,
        unknown key, wrong type or out-of-range value; a relative ``fmu`` path leading out of the
        scenario's folder.
    """
    p = Path(path)
    text = read_text_file(p, "scenario", MAX_SCENARIO_BYTES)
    try:
        return resolve_paths(parse_config(text, name=p.stem), p.parent)
    except ConfigError as exc:
        raise ConfigError(f"{p}: {exc}") from None


def _user_path(key: str, value: str) -> Path:
    """``value`` with a leading ``~`` expanded (ConfigError naming ``key`` when it cannot be)."""
    if not value.strip():
        raise ConfigError(f"{key} is empty: name a file")
    try:
        return Path(value).expanduser()
    except RuntimeError as exc:  # ~user with no such user, or no home
        raise ConfigError(f"{key}: cannot expand {value!r}: {exc}") from None


def resolve_paths(cfg: Config, base_dir: Path) -> Config:
    """The scenario with its file paths (``vehicles.fmu``, ``mission.file``) made absolute:
    ``~`` expanded, a relative one looked for in ``base_dir`` (the scenario's folder) and
    kept inside it, as :func:`load_config` reads them.

    Parameters
    ----------
    cfg : Config
        The scenario as parsed.
    base_dir : Path
        The folder relative paths start from.

    Raises
    ------
    ConfigError
        A relative path leading out of ``base_dir``, an empty one, or a ``~`` that does not expand.
    """

    def where(key: str, value: str) -> str:
        path = _user_path(key, value)
        return str(path if path.is_absolute() else check_inside(key, base_dir, path))

    vehicles = tuple(
        dataclasses.replace(v, fmu=where(f"vehicles[{v.name}].fmu", v.fmu)) if v.fmu is not None else v
        for v in cfg.vehicles
    )
    mission = cfg.mission
    if mission.file is not None:
        mission = dataclasses.replace(mission, file=where("mission.file", mission.file))
    return dataclasses.replace(cfg, vehicles=vehicles, mission=mission)


def reference() -> str:
    """Every scenario key with its type, default and accepted range, as a Markdown table
    (``docs/scenario-reference.md`` is this text; a test keeps the two equal)."""
    rows = ["| key | type | default | accepted |", "| --- | --- | --- | --- |"]
    rows.append(
        "| `name` | string | the file's stem (other characters `_`, the first 64) | 1-64 letters, digits, `-`, `_` |"
    )
    sections: list[tuple[str, type]] = [
        ("sim", SimConfig), ("vehicles", VehicleConfig), ("script", ScriptConfig), ("mission", MissionConfig),
        ("guidance", GuidanceConfig), ("sensing", SensingConfig), ("formation", FormationConfig),
        ("camera", CameraConfig), ("banner", BannerConfig), ("scene", SceneConfig), ("scene.props", PropConfig),
        ("scene.occluders", OccluderConfig), ("scene.lighting", LightKey), ("recording", RecordingConfig),
        ("link", LinkConfig), ("live", LiveConfig), ("audit", AuditConfig),
    ]  # fmt: skip
    for prefix, cls in sections:
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            rows.append(
                f"| `{prefix}.{_toml_key(f.name)}` | {_ref_type(hints[f.name])} | {_ref_default(f)} | {_ref_accepted(f, hints[f.name])} |"
            )
    rows += [
        "",
        f"At most {MAX_VEHICLES} `[[vehicles]]`; the leader first. The roles of `[vehicles.map]` and "
        f"`[vehicles.units]`: {', '.join(f'`{r}`' for r in VEHICLE_ROLES)}. A scenario file is at most "
        f"{MAX_SCENARIO_BYTES} bytes.",
    ]
    return "\n".join(rows) + "\n"


def _ref_type(tp: Any) -> str:
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        return _ref_type(next(a for a in args if a is not type(None)))
    if origin is Literal:
        return "string"
    if origin is tuple:
        inner = args[0]
        return "array of tables" if dataclasses.is_dataclass(inner) else "array"
    if origin in (Mapping, dict, typing.Mapping):
        return "table"
    return {float: "number", int: "integer", str: "string", bool: "boolean"}.get(tp, _type_name(tp))


def _ref_default(f: dataclasses.Field[Any]) -> str:
    if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
        return "(required)"
    value = f.default if f.default is not dataclasses.MISSING else f.default_factory()  # type: ignore[misc]
    if value is None:
        return "(none)"
    if isinstance(value, float):
        return f"{_shown(f.name, value):g}"
    if isinstance(value, tuple):
        return "`" + str([list(v) if isinstance(v, tuple) else v for v in value]).replace("'", '"') + "`"
    if isinstance(value, dict):
        return "{}"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f'`"{value}"`'
    return str(value)


def _ref_accepted(f: dataclasses.Field[Any], tp: Any) -> str:
    md = f.metadata
    parts = []
    if typing.get_origin(tp) is Literal:
        parts.append(", ".join(f'`"{a}"`' for a in typing.get_args(tp)))
    if md.get("bound") is not None:
        parts.append(md["bound"].text())
    if md.get("name"):
        parts.append("1-64 letters, digits, `-`, `_`" + (' or `""`' if md.get("optional") else ""))
    if md.get("text"):
        parts.append(f"printable text, at most {md['text']} characters")
    if md.get("items") is not None:
        names = md["names"]
        each = "; ".join(f"{n} {b.text()}" for n, b in zip(names, md["items"], strict=True))
        parts.append(f"entries {md['shape']}: {each}")
    if md.get("each") is not None:
        parts.append(f"each {md['each'].text()}")
    if md.get("max_items") is not None:
        parts.append(f"at most {md['max_items']} entries")
    if md.get("builtin"):
        parts.append("without fmu: a built-in model, " + " or ".join(f"`{m}`" for m in builtin_models()))
    if md.get("note"):
        parts.append(md["note"])
    return "; ".join(parts) or "-"
