"""Scenario TOML -> frozen dataclasses, validated; every error names the key (STYLE.md 4).

``load_config(path)`` is the only reader of scenario files. Keys ending in ``_deg`` (and
``_degps`` for rates) fill the ``_rad`` (``_radps``) field of the same stem, converted once
here. Unknown keys, wrong types and out-of-range values raise :class:`ConfigError` naming
the dotted key, the value and what was expected.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from lfctl.errors import ConfigError

# ----------------------------------------------------------------------------------------
# Sections


def _positive(key: str, value: float) -> None:
    if not (value > 0 and math.isfinite(value)):
        raise ConfigError(f"{key} must be > 0, got {value!r}")


def _non_negative(key: str, value: float) -> None:
    if not (value >= 0 and math.isfinite(value)):
        raise ConfigError(f"{key} must be >= 0, got {value!r}")


@dataclass(frozen=True)
class SimConfig:
    """[sim]: the co-simulation clock and the rates of each subsystem."""

    dt_s: float = 0.01
    duration_s: float = 60.0
    seed: int = 0
    clock: Literal["lockstep", "realtime"] = "lockstep"
    guidance_rate_hz: float = 20.0
    camera_rate_hz: float = 30.0
    telemetry_rate_hz: float = 10.0
    sensing: Literal["truth", "camera"] = "truth"

    def __post_init__(self) -> None:
        _positive("sim.dt_s", self.dt_s)
        if self.dt_s > 1.0:
            raise ConfigError(f"sim.dt_s must be <= 1 s, got {self.dt_s!r}")
        _positive("sim.duration_s", self.duration_s)
        if self.seed < 0:
            raise ConfigError(f"sim.seed must be >= 0, got {self.seed!r}")
        for name in ("guidance_rate_hz", "camera_rate_hz", "telemetry_rate_hz"):
            rate = getattr(self, name)
            _positive(f"sim.{name}", rate)
            if rate > 1.0 / self.dt_s + 1e-9:
                raise ConfigError(
                    f"sim.{name} = {rate!r} Hz is faster than the physics rate 1/dt = {1.0 / self.dt_s:g} Hz"
                )


@dataclass(frozen=True)
class VehicleConfig:
    """One [[vehicles]] entry.

    ``model`` names a built-in model (fmu_models/); ``fmu`` a user FMU file instead, with
    ``map`` (role -> variable name) and ``units`` (role -> unit) where its names differ.
    """

    name: str
    role: Literal["leader", "follower"]
    model: str = "SkidSteerRover"
    fmu: str | None = None
    fmi_version: int = 2
    north_m: float = 0.0
    east_m: float = 0.0
    yaw_rad: float = 0.0
    parameters: Mapping[str, float] = field(default_factory=dict)
    map: Mapping[str, str] = field(default_factory=dict)
    units: Mapping[str, str] = field(default_factory=dict)
    # follower only: whom to follow and where (the Guidance issue drives these)
    target: str | None = None
    range_m: float = 1.5
    bearing_rad: float = 0.0

    def __post_init__(self) -> None:
        key = f"vehicles[{self.name}]"
        if not self.name or not self.name.replace("_", "").replace("-", "").isalnum():
            raise ConfigError(f"vehicles.name must be letters, digits, '-' or '_', got {self.name!r}")
        if self.fmi_version not in (2, 3):
            raise ConfigError(f"{key}.fmi_version must be 2 or 3, got {self.fmi_version!r}")
        for k in ("north_m", "east_m", "yaw_rad"):
            if not math.isfinite(getattr(self, k)):
                raise ConfigError(f"{key}.{k} must be finite, got {getattr(self, k)!r}")
        _positive(f"{key}.range_m", self.range_m)
        if not -math.pi <= self.bearing_rad <= math.pi:
            raise ConfigError(f"{key}.bearing_deg must be within [-180, 180], got {math.degrees(self.bearing_rad):.6g}")
        if self.role == "leader" and self.target is not None:
            raise ConfigError(f"{key}.target: a leader follows nobody, got {self.target!r}")
        for p, v in self.parameters.items():
            if not math.isfinite(v):
                raise ConfigError(f"{key}.parameters.{p} must be finite, got {v!r}")


@dataclass(frozen=True)
class ScriptConfig:
    """[script]: open-loop inputs for runs without guidance.

    ``leader`` is a list of ``[duration_s, speed_mps, yaw_rate_deg_s]`` segments, repeated
    to the end of the run; ``followers`` is ``"stand"`` (zero commands) or ``"copy"`` (the
    leader's commands).
    """

    leader: tuple[tuple[float, float, float], ...] = ((4.0, 0.3, 0.0), (3.0, 0.3, 30.0))
    followers: Literal["stand", "copy"] = "copy"

    def __post_init__(self) -> None:
        if not self.leader:
            raise ConfigError("script.leader must have at least one [duration_s, speed_mps, yaw_rate_deg_s] segment")
        for i, seg in enumerate(self.leader):
            if len(seg) != 3:
                raise ConfigError(
                    f"script.leader[{i}] must be [duration_s, speed_mps, yaw_rate_deg_s], got {list(seg)!r}"
                )
            _positive(f"script.leader[{i}][0] (duration_s)", seg[0])


@dataclass(frozen=True)
class Config:
    """A whole scenario."""

    name: str
    sim: SimConfig
    vehicles: tuple[VehicleConfig, ...]
    script: ScriptConfig = field(default_factory=ScriptConfig)
    source: str = ""  # the TOML text, kept for the run record

    def __post_init__(self) -> None:
        if not self.vehicles:
            raise ConfigError("vehicles: need at least one [[vehicles]] entry, got none")
        names = [v.name for v in self.vehicles]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ConfigError(f"vehicles.name must be unique, got {sorted(dup)!r} more than once")
        leaders = [v.name for v in self.vehicles if v.role == "leader"]
        if len(leaders) != 1:
            raise ConfigError(f'vehicles: need exactly one role = "leader", got {len(leaders)} ({leaders!r})')
        if self.vehicles[0].role != "leader":
            raise ConfigError(f"vehicles: the leader must come first, got {self.vehicles[0].name!r} first")
        for v in self.vehicles:
            if v.target is not None and v.target not in names:
                raise ConfigError(f"vehicles[{v.name}].target names an unknown vehicle {v.target!r} (known: {names})")
            if v.target == v.name:
                raise ConfigError(f"vehicles[{v.name}].target cannot be the vehicle itself")
        # followers' targets must lead back to the leader without a cycle
        target = {v.name: (v.target or leaders[0]) for v in self.vehicles if v.role == "follower"}
        for start in target:
            seen, node = [start], target[start]
            while node in target:
                if node in seen:
                    raise ConfigError(f"vehicles: follower targets form a cycle: {' -> '.join([*seen, node])}")
                seen.append(node)
                node = target[node]

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


def _convert(value: Any, tp: Any, key: str) -> Any:
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        return _convert(value, inner[0], key)
    if origin is Literal:
        if value not in args:
            raise ConfigError(f"{key} must be one of {', '.join(repr(a) for a in args)}, got {value!r}")
        return value
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise ConfigError(f"{key} must be a table, got {value!r}")
        return _build(tp, value, key)
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{key} must be a number, got {value!r}")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{key} must be an integer, got {value!r}")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(f"{key} must be a string, got {value!r}")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{key} must be true or false, got {value!r}")
        return value
    if origin is tuple:
        if not isinstance(value, list):
            raise ConfigError(f"{key} must be an array, got {value!r}")
        item = args[0]
        return tuple(_convert(v, item, f"{key}[{i}]") for i, v in enumerate(value))
    if origin in (Mapping, dict, typing.Mapping):
        if not isinstance(value, dict):
            raise ConfigError(f"{key} must be a table, got {value!r}")
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


def parse_config(text: str, name: str = "scenario") -> Config:
    """Parse scenario TOML text; see :func:`load_config`."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{name}: not valid TOML: {exc}") from exc
    data.setdefault("name", name)
    data.setdefault("sim", {})
    vehicles = data.get("vehicles", [])
    if not isinstance(vehicles, list):
        raise ConfigError(f"vehicles must be an array of tables ([[vehicles]]), got {vehicles!r}")
    tables = []
    for i, v in enumerate(vehicles):
        if not isinstance(v, dict):
            raise ConfigError(f"vehicles[{i}] must be a table, got {v!r}")
        tables.append(v)
    data["vehicles"] = tables
    # Vehicle errors name the vehicle: build them one by one with their name in the key.
    built = []
    for i, v in enumerate(tables):
        label = f"vehicles[{v.get('name', i)}]"
        built.append(_build(VehicleConfig, v, label))
    rest = {k: v for k, v in data.items() if k != "vehicles"}
    cfg = _build(_ConfigTable, rest, "")
    return Config(name=cfg.name, sim=cfg.sim, vehicles=tuple(built), script=cfg.script, source=text)


@dataclass(frozen=True)
class _ConfigTable:
    """Top-level keys other than [[vehicles]] (which parse_config builds one by one)."""

    name: str
    sim: SimConfig = field(default_factory=SimConfig)
    script: ScriptConfig = field(default_factory=ScriptConfig)


def load_config(path: str | Path) -> Config:
    """Read and validate a scenario file.

    Parameters
    ----------
    path : str or Path
        A TOML scenario (see examples/).

    Raises
    ------
    ConfigError
        Unreadable file, bad TOML, unknown key, wrong type or out-of-range value.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read scenario {p}: {exc}") from exc
    try:
        return parse_config(text, name=p.stem)
    except ConfigError as exc:
        raise ConfigError(f"{p}: {exc}") from None
