"""Load vehicle FMUs with fmpy and step them fast; the only module that imports fmpy's
runtime (:mod:`lfctl.fmu.build` imports it for paths and headers).

A vehicle FMU is any FMI 2.0 or 3.0 Co-Simulation FMU with, by some name, the roles lfctl
needs: forward-speed and yaw-rate command inputs, and north, east, yaw, speed and yaw-rate
outputs. :class:`RoleMap` names them; declared units are converted to SI. Each FMU file is
extracted once and its library loaded once (:class:`FmuLibrary`); every instance of it shares
that library. Stepping calls the FMI functions through ctypes with arrays preallocated over
rows of numpy arrays the co-simulation master owns, so no list is built per step.

An FMU is foreign code and data (docs/architecture.md, "Containing FMUs"): its archive is
checked and unpacked within limits (:mod:`lfctl.fmu.archive`); its outputs are checked
(:meth:`FmuInstance.check_outputs`: finite and within :data:`OUTPUT_BOUNDS`); and every FMI
call it is inside is visible to another thread (:func:`calls_in_progress`), so a watchdog can
end a run whose FMU never returns (:mod:`lfctl.sim.watchdog`).
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import math
import os
import re
import threading
import zipfile
from collections import deque
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from fmpy import platform as fmpy_platform
from fmpy import platform_tuple as fmpy_platform_tuple
from fmpy import read_model_description, sharedLibraryExtension, supported_platforms
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.fmi3 import FMU3Slave, fmi3Boolean, fmi3Float64

from lfctl.errors import ConfigError, FmuError, command, file_name_encoding_error
from lfctl.fmu.archive import ExtractionDir, extract_archive, read_member, remove_stale_extractions

__all__ = [
    "INPUT_ROLES",
    "KEPT_MESSAGES",
    "OUTPUT_BOUNDS",
    "OUTPUT_ROLES",
    "POSE_ROLES",
    "FmuInstance",
    "FmuLibrary",
    "FmuVariable",
    "InCall",
    "RoleMap",
    "calls_in_progress",
    "check_output_row",
    "discard_extractions",
    "hold_returns",
    "returned_from_call",
    "unwatch_calls",
    "watch_calls",
]

log = logging.getLogger(__name__)

#: what lfctl sets every step: forward-speed and yaw-rate commands
INPUT_ROLES = ("speed_cmd", "yaw_rate_cmd")
#: what lfctl reads every step: the vehicle's pose, speed and yaw rate
OUTPUT_ROLES = ("north", "east", "yaw", "speed", "yaw_rate")
#: optional initial-pose parameters
POSE_ROLES = ("north_0", "east_0", "yaw_0")
ROLE_SI_UNIT = {
    "speed_cmd": "m/s",
    "yaw_rate_cmd": "rad/s",
    "north": "m",
    "east": "m",
    "yaw": "rad",
    "speed": "m/s",
    "yaw_rate": "rad/s",
    "north_0": "m",
    "east_0": "m",
    "yaw_0": "rad",
}
#: unit -> (SI unit, factor to SI)
UNIT_TO_SI = {
    "m": ("m", 1.0),
    "cm": ("m", 0.01),
    "mm": ("m", 0.001),
    "km": ("m", 1000.0),
    "m/s": ("m/s", 1.0),
    "km/h": ("m/s", 1.0 / 3.6),
    "rad": ("rad", 1.0),
    "deg": ("rad", math.pi / 180.0),
    "rad/s": ("rad/s", 1.0),
    "deg/s": ("rad/s", math.pi / 180.0),
}
#: each SI unit of a role as exponents of the FMI base units (m, s; rad apart, see _si_of)
_SI_EXPONENTS = {"m": (1, 0), "m/s": (1, -1), "rad": (0, 0), "rad/s": (0, -1)}
FMI_STATUS = ("OK", "Warning", "Discard", "Error", "Fatal", "Pending")
#: largest magnitude each output may have, SI: past it, or not finite (NaN, inf), the FMU has
#: failed and stepping stops with an FmuError. Far beyond any ground vehicle, and within what
#: every consumer of the world state can carry: 1000 km from home stays a valid degE7 latitude
#: and longitude in MAVLink telemetry, 300 m/s fits GLOBAL_POSITION_INT's int16 cm/s.
OUTPUT_BOUNDS = {"north": 1e6, "east": 1e6, "yaw": 1e6, "speed": 300.0, "yaw_rate": 1e3}
#: messages an instance keeps of what its FMU logged (the newest; an FMU logging in a loop
#: must not fill the memory)
KEPT_MESSAGES = 100

# Live libraries and instances by id (plain dicts: another thread takes a snapshot of their
# values atomically under the GIL), and the gate a thread returning from an FMI call passes
# while a watchdog holds it (hold_returns).
_LIBRARIES: dict[int, FmuLibrary] = {}
_INSTANCES: dict[int, InCall] = {}
_gate_lock = threading.Lock()
_gate_closed = False
_swept = False


def _pass_gate() -> None:
    with _gate_lock:
        pass


@contextlib.contextmanager
def hold_returns() -> Iterator[None]:
    """While inside, a thread returning from an FMI call waits before it goes on.

    A watchdog that finds an FMU stuck in a call (:func:`calls_in_progress`) holds this
    while it decides and finishes the run, so the stepping thread cannot come back and touch
    what the watchdog is closing; an FMI call returns to lfctl in a few instructions, so
    holding it costs the stepping thread nothing while it computes.
    """
    global _gate_closed
    with _gate_lock:
        _gate_closed = True  # after taking the lock: a returning thread that sees it waits
        try:
            yield
        finally:
            _gate_closed = False


class InCall(Protocol):
    """What :func:`calls_in_progress` reads of an FMU instance: an :class:`FmuInstance`, or
    one stepped in another process (:class:`lfctl.fmu.host.HostedInstance`)."""

    @property
    def name(self) -> str:
        """The instance's name (the vehicle's)."""
        ...

    @property
    def busy(self) -> str | None:
        """The FMI call it is inside now, None between calls."""
        ...

    @property
    def t_s(self) -> float:
        """The simulation time of its step, s."""
        ...

    @property
    def calls(self) -> int:
        """Slow-path calls made: with :attr:`t_s`, it tells one call from the next."""
        ...


def watch_calls(instance: InCall) -> None:
    """Have :func:`calls_in_progress` look at ``instance`` too, until :func:`unwatch_calls`.

    Parameters
    ----------
    instance : InCall
        An FMU instance stepped by this process's main thread in some other way.
    """
    _INSTANCES[id(instance)] = instance


def unwatch_calls(instance: InCall) -> None:
    """Stop looking at ``instance`` (see :func:`watch_calls`); safe to call twice.

    Parameters
    ----------
    instance : InCall
        As given to :func:`watch_calls`.
    """
    _INSTANCES.pop(id(instance), None)


def returned_from_call() -> None:
    """A watched call (:func:`watch_calls`) returned: wait here while a watchdog holds the
    return gate (:func:`hold_returns`), as an FMI call made in this process does."""
    if _gate_closed:
        _pass_gate()


def calls_in_progress() -> list[tuple[InCall, str, tuple[object, ...]]]:
    """Every FMI call some thread is inside now: (instance, FMI function, key).

    The key is the same for as long as the same call goes on, so a watchdog polling this
    sees how long a call has lasted. Safe to call from any thread.
    """
    out = []
    for inst in tuple(_INSTANCES.values()):
        call, t_s, serial = inst.busy, inst.t_s, inst.calls
        if call is not None:
            out.append((inst, call, (id(inst), call, t_s, serial)))
    return out


def discard_extractions() -> None:
    """Remove every loaded FMU's extracted folder without calling the FMUs (a process that
    is about to ``os._exit`` while an FMU is stuck; its code stays mapped until then)."""
    for lib in tuple(_LIBRARIES.values()):
        if lib._dir is not None:
            lib._dir.remove()


@dataclass(frozen=True)
class RoleMap:
    """Which FMU variable plays each role lfctl needs, and unit overrides.

    Parameters
    ----------
    names : Mapping[str, str]
        role -> FMU variable name, for every role in INPUT_ROLES and OUTPUT_ROLES; the
        POSE_ROLES (initial-pose parameters) are optional: without them lfctl moves the
        FMU's own origin to the vehicle's initial pose.
    units : Mapping[str, str]
        role -> unit, for FMUs that declare none or declare it wrongly.
    explicit : frozenset of str
        The roles mapped by hand (``[vehicles.map]``): an initial-pose role among them is no
        longer optional, a mistyped name is an error rather than a role skipped.
    """

    names: Mapping[str, str] = field(default_factory=lambda: {r: r for r in (*INPUT_ROLES, *OUTPUT_ROLES, *POSE_ROLES)})
    units: Mapping[str, str] = field(default_factory=dict)
    #: the roles a user mapped by hand: an optional one must then exist
    explicit: frozenset[str] = frozenset()


BUILTIN_ROLE_MAP = RoleMap()


@dataclass(frozen=True)
class FmuVariable:
    """One model variable as `lfctl fmu info` lists it (``""`` where the FMU declares none)."""

    name: str  # the variable's name
    value_reference: int  # its FMI value reference
    causality: str  # "input", "output", "parameter", ...
    variability: str  # "fixed", "tunable", "continuous", ...
    type: str  # "Real", "Float64", "Integer", ...
    unit: str  # declared on the variable or on its type
    start: str  # start value as text
    description: str  # the FMU's description of it


#: fmi2Fatal / fmi3Fatal
FATAL = 4
#: the integer types of parameters and their bit widths (FMI 2's Enumeration is an Integer,
#: FMI 3's an Int64)
_INT_BITS = {"Integer": 32, "Int8": 8, "Int16": 16, "Int32": 32, "Int64": 64, "UInt8": 8, "UInt16": 16,
             "UInt32": 32, "UInt64": 64}  # fmt: skip


def _setter(fmi_version: int, kind: str) -> str:
    """fmpy's setter of a variable of type ``kind`` (``setReal``, ``setInt32``, ...)."""
    if kind == "Enumeration":
        return "setInteger" if fmi_version == 2 else "setInt64"
    return f"set{kind}"


def _typed_value(path: Path, name: str, kind: str, value: object) -> object:
    """A scenario's value for parameter ``name`` as its FMI type takes it; ConfigError naming
    the parameter where it cannot (a fraction for an integer, 2 for a Boolean, a text)."""
    if kind in ("Real", "Float64", "Float32"):
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{path}: parameter {name!r} is a {kind}, got {value!r}")
        return float(value)
    if kind == "Boolean":
        if value in (0, 1):  # (True and False are 1 and 0)
            return bool(value)
        raise ConfigError(f"{path}: parameter {name!r} is a Boolean: give true, false, 1 or 0, got {value!r}")
    if kind in _INT_BITS or kind == "Enumeration":
        bits = _INT_BITS.get(kind, 32)
        lo, hi = (0, 2**bits - 1) if kind.startswith("UInt") else (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1)
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or value != int(value)
            or not lo <= value <= hi
        ):
            raise ConfigError(
                f"{path}: parameter {name!r} is an {kind}: give a whole number in [{lo}, {hi}], got {value!r}"
            )
        return int(value)
    raise ConfigError(
        f"{path}: parameter {name!r} has type {kind}, which lfctl does not set (numbers and Booleans only)"
    )


def _bounds(var: Any) -> tuple[float, float]:
    """A numeric variable's declared range: its own min and max, else its declared type's
    (FMI: the variable's attributes override the type's), else unbounded."""
    declared = var.declaredType

    def bound(attr: str, default: float) -> float:
        text = getattr(var, attr, None)
        if text is None and declared is not None:
            text = getattr(declared, attr, None)
        if text is None:
            return default
        try:
            return float(text)
        except (TypeError, ValueError):
            return default  # (a Boolean's or a text's: not a number's range)

    return bound("min", -math.inf), bound("max", math.inf)


def _out_of_range(var: Any, value: object) -> str | None:
    """Why ``value`` is outside ``var``'s declared min and max (None when it is inside, or
    the variable is not a number)."""
    if var.type in ("Boolean", "String", "Binary", "Clock") or isinstance(value, bool):
        return None
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    lo, hi = _bounds(var)
    if lo <= x <= hi or math.isnan(x):  # (NaN is a value xs:double has, no range's)
        return None
    return f"outside its declared range [{lo:g}, {hi:g}]"


_REFUSED = re.compile(r"\bparameter (\w+): (.+)")


def _refused_parameter(log: Sequence[str], parameters: Mapping[str, object]) -> tuple[str, str] | None:
    """The first parameter of ``parameters`` an FMU's log names as refused ("... parameter
    NAME: why"), with the FMU's words for why; None when it names none of them."""
    for line in log:
        found = _REFUSED.search(line)
        if found is not None and found[1] in parameters:
            return found[1], found[2].strip()
    return None


def _status_text(status: int) -> str:
    return FMI_STATUS[status] if 0 <= status < len(FMI_STATUS) else f"illegal status {status}"


class FmuLibrary:
    """One FMU file: model description read, archive extracted and library loaded once.

    Use as a context manager, or call :meth:`close`; closing frees every instance and removes
    the extracted folder.

    Parameters
    ----------
    path : str or Path
        The FMU file (FMI 2.0 or 3.0, Co-Simulation).
    role_map : RoleMap
        Which variables play lfctl's roles (default: the built-in models' names).
    extracted : str or Path, optional
        A folder this FMU file was already extracted into by another :class:`FmuLibrary`
        (in another process: :mod:`lfctl.fmu.host`), used as it is and left in place on
        :meth:`close`; by default the file is extracted into a folder of this library's own.

    Raises
    ------
    FmuError
        No such file, not an FMU, an unsupported FMI version, an archive beyond the limits of
        :mod:`lfctl.fmu.archive`, or extraction failed.
    ConfigError
        A role is unmapped, or mapped to a variable of the wrong causality, type or unit.
    """

    def __init__(
        self, path: str | Path, role_map: RoleMap = BUILTIN_ROLE_MAP, extracted: str | Path | None = None
    ) -> None:
        self.path = Path(path)
        self.role_map = role_map
        self._dir: ExtractionDir | None = None
        self._unzipdir: str | None = None
        self._instances: list[FmuInstance] = []
        # another library's folder holds what it checked and extracted from the file: read
        # that, not the file again (which may have been replaced since)
        source = Path(extracted) if extracted is not None else self.path
        if extracted is None and not self.path.is_file():
            why = "is not a regular file" if os.path.lexists(self.path) else "does not exist"
            raise FmuError(f"FMU file {self.path} {why}", model=str(self.path), call="load")
        self.md = self.describe(source)
        self.fmi_version = int(self.md.fmiVersion.split(".")[0])
        if self.fmi_version not in (2, 3):
            raise FmuError(
                f"{self.path}: FMI {self.md.fmiVersion} is not supported (need 2.0 or 3.0)",
                model=str(self.path),
                call="load",
            )
        if self.md.coSimulation is None:
            raise FmuError(f"{self.path}: not a Co-Simulation FMU", model=str(self.path), call="load")
        have = [p for p in supported_platforms(str(source)) if p != "c-code"]
        if fmpy_platform not in have:
            raise FmuError(
                f"{self.path}: no binary for this platform ({fmpy_platform}); it has "
                f"{', '.join(have) or 'none'} (lfctl does not compile a user FMU's sources)",
                model=str(self.path),
                call="load",
            )
        self.identifier: str = self.md.coSimulation.modelIdentifier
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", self.identifier or ""):
            # it names the library file and our folder: never a path
            raise FmuError(
                f"{self.path}: modelIdentifier {self.identifier!r} is not a C identifier",
                model=str(self.path),
                call="load",
            )
        self.variables = {v.name: v for v in self.md.modelVariables}
        for var in self.md.modelVariables:
            # FMI: a start value lies within the variable's min and max; one outside is a
            # model description no tool can trust (fmpy's validation does not look)
            why = None if var.start is None or var.shape else _out_of_range(var, var.start)
            if why is not None:
                raise FmuError(
                    f"{self.path}: variable {var.name!r} has start value {var.start} {why}",
                    model=str(self.path),
                    call="load",
                )
        #: role -> FMU variable name and declared (or overridden) unit, for messages
        self.role_names: dict[str, str] = {}
        self.role_units: dict[str, str] = {}
        self.vr, self.scale, self.pose_mapped = self._resolve_roles(role_map)
        _LIBRARIES[id(self)] = self
        if extracted is not None:  # another library's folder: not this one's to remove
            self._unzipdir = str(extracted)
            return
        global _swept
        if not _swept:  # once per process: folders left by runs that were killed
            _swept = True
            remove_stale_extractions()
        try:
            self._dir = ExtractionDir(self.identifier)
            extract_archive(self.path, self._dir.files)
            self._unzipdir = str(self._dir.files)
        except BaseException as exc:
            self.close()
            if isinstance(exc, (FmuError, KeyboardInterrupt, SystemExit)):
                raise
            raise FmuError(f"{self.path}: cannot extract: {exc}", model=self.identifier, call="extract") from exc

    @staticmethod
    def describe(path: str | Path) -> Any:
        """Read only the model description of an FMU file (errors as FmuError).

        Parameters
        ----------
        path : str or Path
            The FMU file, or a folder an :class:`FmuLibrary` extracted one into.
        """
        p = Path(path)
        if not p.is_dir():
            xml = read_member(p, "modelDescription.xml")  # limits and its CRC first: fmpy parses it as it streams
            root = _root_element(xml)
            if root is not None and root != "fmiModelDescription":  # (fmpy's own error is a NoneType's)
                raise FmuError(
                    f"{p} has no valid modelDescription.xml: its root element is <{root[:40]}>, "
                    "not <fmiModelDescription>",
                    model=str(p),
                    call="load",
                )
        try:
            return read_model_description(str(p))
        except FileNotFoundError as exc:
            raise FmuError(f"FMU file {p} does not exist", model=str(p), call="load") from exc
        except zipfile.BadZipFile as exc:
            raise FmuError(f"{p} is not an FMU: not a readable zip archive ({exc})", model=str(p), call="load") from exc
        except UnicodeError as exc:  # the FMU is not at fault: a name on its way is not encodable here
            raise file_name_encoding_error(exc) from exc
        except Exception as exc:  # (fmpy's validation lists its findings on lines of their own)
            why = "; ".join(line.strip("- ") for line in str(exc).splitlines() if line.strip())
            raise FmuError(f"{p} has no valid modelDescription.xml: {why}", model=str(p), call="load") from exc

    @staticmethod
    def variables_of(md: Any) -> list[FmuVariable]:
        """Every variable of a model description, with its unit (declared or by its type).

        Parameters
        ----------
        md : fmpy ModelDescription
            As :meth:`describe` returns it.
        """
        rows = []
        for v in md.modelVariables:
            rows.append(
                FmuVariable(
                    v.name,
                    int(v.valueReference),
                    v.causality or "",
                    v.variability or "",
                    v.type,
                    FmuLibrary._unit_of(v) or "",
                    "" if v.start is None else str(v.start),
                    v.description or "",
                )
            )
        return rows

    # -- role mapping ---------------------------------------------------------------------
    def _resolve_roles(self, role_map: RoleMap) -> tuple[dict[str, int], dict[str, float], bool]:
        vr: dict[str, int] = {}
        scale: dict[str, float] = {}
        for role in (*INPUT_ROLES, *OUTPUT_ROLES, *POSE_ROLES):
            name = role_map.names.get(role)
            optional = role in POSE_ROLES and role not in role_map.explicit
            if name is None or (optional and name not in self.variables):
                if optional:
                    continue
                raise ConfigError(f"{self.path}: no variable mapped to role {role!r}")
            var = self.variables.get(name)
            if var is None:
                raise ConfigError(
                    f"{self.path}: variable {name!r} (mapped to role {role!r}) does not exist; "
                    f"`{command('lfctl', 'fmu', 'info', self.path)}` lists the variables"
                )
            want = "input" if role in INPUT_ROLES else ("output" if role in OUTPUT_ROLES else "parameter")
            if var.causality != want:
                raise ConfigError(
                    f"{self.path}: variable {name!r} mapped to role {role!r} has causality "
                    f"{var.causality!r}, expected {want!r}"
                )
            if var.type not in ("Real", "Float64"):
                raise ConfigError(
                    f"{self.path}: variable {name!r} mapped to role {role!r} has type {var.type}, expected a Real/Float64"
                )
            if getattr(var, "dimensions", None):
                raise ConfigError(
                    f"{self.path}: variable {name!r} mapped to role {role!r} is an array, expected a scalar"
                )
            if name in self.role_names.values():
                other = next(r for r, n in self.role_names.items() if n == name)
                raise ConfigError(f"{self.path}: variable {name!r} is mapped to two roles, {other!r} and {role!r}")
            shared = next((r for r, v in vr.items() if v == int(var.valueReference)), None)
            if shared is not None:  # (FMI's aliases share a value reference: one value under two names)
                raise ConfigError(
                    f"{self.path}: variables {self.role_names[shared]!r} (role {shared!r}) and {name!r} (role "
                    f"{role!r}) share value reference {int(var.valueReference)}: one value, so setting one sets "
                    "the other; each role needs a variable of its own"
                )
            unit = role_map.units.get(role) or self._unit_of(var) or ROLE_SI_UNIT[role]
            si, factor = UNIT_TO_SI.get(unit) or self._si_of(unit, ROLE_SI_UNIT[role])
            if si != ROLE_SI_UNIT[role]:
                # an override names where it came from: the variable itself may declare another unit
                declared = self._unit_of(var)
                said = (
                    f"unit {unit!r} of role {role!r} in [vehicles.units] (variable {name!r} declares "
                    f"{repr(declared) if declared else 'none'})"
                    if role_map.units.get(role)
                    else f"variable {name!r} for role {role!r} has unit {unit!r}"
                )
                raise ConfigError(
                    f"{self.path}: {said}; expected one convertible to {ROLE_SI_UNIT[role]} "
                    f"({', '.join(k for k, v in UNIT_TO_SI.items() if v[0] == ROLE_SI_UNIT[role])})"
                )
            vr[role] = int(var.valueReference)
            scale[role] = factor
            self.role_names[role] = name
            self.role_units[role] = unit
        return vr, scale, all(r in vr for r in POSE_ROLES)

    def _si_of(self, unit: str, want: str) -> tuple[str | None, float]:
        """A unit the model description defines (``<UnitDefinitions>``) as ``want``'s base
        units times a factor, with no offset, as (``want``, factor); else (None, 0). An angle's
        ``rad`` exponent may be 0 or 1 (FMI's rad is dimensionless: a yaw rate in 1/s is rad/s)."""
        for u in getattr(self.md, "unitDefinitions", None) or ():
            b = u.baseUnit
            if u.name != unit or b is None:
                continue
            others = (b.kg, b.A, b.K, b.mol, b.cd)
            angle = want.startswith("rad") and b.rad in (0, 1)
            if (b.m, b.s) == _SI_EXPONENTS[want] and not any(others) and (angle or b.rad == 0) and not b.offset:
                factor = float(b.factor)
                if not (math.isfinite(factor) and factor > 0):  # 0 would freeze the vehicle, inf overflow
                    raise ConfigError(f"{self.path}: unit {unit!r} has factor {factor:g}; it must be finite and > 0")
                return want, factor
        return None, 0.0

    @staticmethod
    def _unit_of(var: Any) -> str | None:
        if getattr(var, "unit", None):
            return str(var.unit)
        declared = getattr(var, "declaredType", None)
        if declared is not None and getattr(declared, "unit", None):
            return str(declared.unit)
        return None

    @property
    def extraction(self) -> str | None:
        """The folder the FMU file is extracted into (None once closed)."""
        return self._unzipdir

    # -- instances ------------------------------------------------------------------------
    def instantiate(
        self,
        instance_name: str,
        parameters: Mapping[str, float],
        pose: tuple[float, float, float],
        cmd_row: np.ndarray,
        out_row: np.ndarray,
        start_time_s: float = 0.0,
        make: Callable[..., FmuInstance] | None = None,
    ) -> FmuInstance:
        """Create, parameterise and initialise one instance (see :class:`FmuInstance`).

        Parameters
        ----------
        instance_name : str
            The instance's name (the vehicle's).
        parameters : Mapping[str, float]
            FMU parameter name -> value, set before initialisation, FMU units.
        pose : (north_m, east_m, yaw_rad)
            The vehicle's initial pose, SI; set through the FMU's initial-pose parameters
            when it has them (see :data:`POSE_ROLES`), else ignored here.
        cmd_row : np.ndarray
            Contiguous float64 (2,) the caller writes: speed and yaw-rate commands, FMU units.
        out_row : np.ndarray
            Contiguous float64 (5,) each step fills: north, east, yaw, speed, yaw rate, FMU units.
        start_time_s : float
            The simulation's start time, s.
        make : callable, optional
            Builds the instance from :class:`FmuInstance`'s arguments (a subclass of it);
            default :class:`FmuInstance`.
        """
        if self._unzipdir is None:
            raise FmuError(f"{self.path}: library is closed", model=self.identifier, call="instantiate")
        if self._instances and getattr(self.md.coSimulation, "canBeInstantiatedOnlyOncePerProcess", False):
            raise ConfigError(
                f"{self.path}: {self.identifier} declares canBeInstantiatedOnlyOncePerProcess, and "
                f"{self._instances[0].name!r} has its one instance: lfctl steps every vehicle in one process, "
                f"so {instance_name!r} cannot use it too"
            )
        inst = (make or FmuInstance)(self, instance_name, parameters, pose, cmd_row, out_row, start_time_s)
        self._instances.append(inst)
        return inst

    def close(self) -> None:
        """Free every instance and remove the extracted folder; safe to call twice."""
        try:
            for inst in self._instances:
                inst.free()
        finally:
            self._instances.clear()
            self._unzipdir = None
            if self._dir is not None:
                self._dir.remove()
                self._dir = None
            _LIBRARIES.pop(id(self), None)

    def __enter__(self) -> FmuLibrary:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def check_output_row(lib: FmuLibrary, instance: str, row: Sequence[float], t_s: float) -> None:
    """Raise FmuError if an output of ``row`` is not finite or beyond :data:`OUTPUT_BOUNDS`.

    The message names the FMU (model identifier and file), the instance, the variable and
    its role, the value and the simulation time it is the output at.

    Parameters
    ----------
    lib : FmuLibrary
        The FMU file the instance is of (its roles' names, units and scales).
    instance : str
        The instance's name (the vehicle's).
    row : sequence of float
        Its outputs as read, FMU units, in :data:`OUTPUT_ROLES` order.
    t_s : float
        The simulation time they are the outputs at, s.
    """
    for k, role in enumerate(OUTPUT_ROLES):
        raw = float(row[k])
        si = raw * lib.scale[role]
        if math.isfinite(si) and abs(si) <= OUTPUT_BOUNDS[role]:
            continue
        unit = lib.role_units.get(role, "")
        if not math.isfinite(raw):
            why = "is not a finite number"
        else:
            why = f"is beyond the bound |{role}| <= {OUTPUT_BOUNDS[role]:g} {ROLE_SI_UNIT[role]}"
        raise FmuError(
            f"FMU {lib.identifier} ({lib.path}), instance {instance!r}: output {lib.role_names[role]!r} "
            f"(role {role}) = {raw!r} {unit} at t = {t_s:.6g} s {why}",
            model=lib.identifier,
            call="fmi2GetReal" if lib.fmi_version == 2 else "fmi3GetFloat64",
        )


def _library_member(lib: FmuLibrary) -> str:
    """Where an FMU keeps its library for this platform (FMI 3 names the folder by a tuple)."""
    folder = fmpy_platform_tuple if lib.fmi_version == 3 else fmpy_platform
    return f"binaries/{folder}/{lib.identifier}{sharedLibraryExtension}"


class FmuInstance:
    """One vehicle's FMU instance, stepped through preallocated ctypes arrays.

    ``cmd_row`` (2 floats: speed, yaw rate, in the FMU's units) and ``out_row`` (5 floats:
    north, east, yaw, speed, yaw rate, in the FMU's units) are views into arrays the caller
    owns; :meth:`step` sends the first and fills the second. Build it with
    :meth:`FmuLibrary.instantiate`.

    :meth:`step` does not check the outputs it reads, so that a master stepping many
    vehicles checks them all in one vector operation (``Simulation.step``) and calls
    :meth:`check_outputs` only on a suspect; :meth:`read` (after initialisation and reset)
    checks them. While a thread is inside an FMI call of this instance, :attr:`busy` names
    the call (see :func:`calls_in_progress`).

    Parameters
    ----------
    lib : FmuLibrary
        The loaded FMU file it is an instance of.
    name : str
        The instance's name (the vehicle's).
    parameters : Mapping[str, float]
        FMU parameter name -> value, set before initialisation, FMU units.
    pose : (north_m, east_m, yaw_rad)
        The vehicle's initial pose, SI (used when the FMU has initial-pose parameters).
    cmd_row, out_row : np.ndarray
        The command and output rows (contiguous float64, (2,) and (5,)).
    start_time_s : float
        The simulation's start time, s.
    """

    def __init__(
        self,
        lib: FmuLibrary,
        name: str,
        parameters: Mapping[str, float],
        pose: tuple[float, float, float],
        cmd_row: np.ndarray,
        out_row: np.ndarray,
        start_time_s: float,
    ) -> None:
        self.lib = lib
        self.name = name
        self.messages: deque[str] = deque(maxlen=KEPT_MESSAGES)  # the newest the FMU logged
        # what it logged as Discard, Error or Fatal, the newest, and how many in all
        self._refusals: deque[str] = deque(maxlen=KEPT_MESSAGES)
        self._refused = 0
        self.t_s = start_time_s
        self._start_time_s = start_time_s
        self._freed = False
        #: the FMI call a thread is inside now (None between calls), and how many slow-path
        #: calls were made (with t_s, it tells one call from the next)
        self.busy: str | None = None
        self.calls = 0
        self._slave: Any = None
        #: a call returned Fatal: FMI allows no further call of any instance (not even to free it)
        self._fatal = False
        #: the FMU's own logging is on (with lfctl's debug logging): its messages say why it failed
        self._logging = log.isEnabledFor(logging.DEBUG)
        self._terminate: Any = None  # FMI 3's terminateSimulation flag of the last step
        _INSTANCES[id(self)] = self
        try:
            self._setup(parameters, pose, cmd_row, out_row)
        except BaseException:
            self.free()
            raise

    def _setup(
        self,
        parameters: Mapping[str, float],
        pose: tuple[float, float, float],
        cmd_row: np.ndarray,
        out_row: np.ndarray,
    ) -> None:
        lib, name = self.lib, self.name
        md = lib.md
        common = dict(guid=md.guid, modelIdentifier=lib.identifier, unzipDirectory=lib._unzipdir, instanceName=name)
        prefix = "fmi2" if lib.fmi_version == 2 else "fmi3"
        cwd = os.getcwd()  # fmpy goes into the library's folder to load it, and stays if that fails
        self._load_check(lib)
        slave: Any = None
        try:
            # the library's load runs its constructors (dlopen, with Python's lock held): a
            # call a watchdog must see as much as the FMI ones
            if lib.fmi_version == 2:
                with self._in_call("dlopen"):
                    slave = FMU2Slave(**common)
                self._callbacks = fmi2CallbackFunctions()
                self._callbacks.logger = fmi2CallbackLoggerTYPE(self._log2)
                with self._in_call("fmi2Instantiate"):
                    slave.instantiate(callbacks=self._callbacks, loggingOn=self._logging)
            else:
                with self._in_call("dlopen"):
                    slave = FMU3Slave(**common)
                with self._in_call("fmi3InstantiateCoSimulation"):
                    slave.instantiate(logMessage=self._log3, loggingOn=self._logging)
            self._slave = slave
        except FmuError:
            raise
        except Exception as exc:
            # name the user's .fmu, not the temporary folder it was unpacked into (gone by now)
            why = str(exc).replace(f"{lib._unzipdir}/", f"{lib.path} member ") if lib._unzipdir else str(exc)
            if slave is None:  # the library did not load (fmpy's words name it twice: keep dlerror's)
                member = _library_member(lib)
                raise FmuError(
                    f"{lib.path}: cannot load {member}: {why.rsplit(f'{member}: ', 1)[-1]}",
                    model=lib.identifier,
                    call="load",
                ) from exc
            raise self._error(f"cannot instantiate {lib.identifier} as {name!r}: {why}", "Instantiate") from exc
        finally:
            os.chdir(cwd)  # (a folder removed with the library would leave the process nowhere)
        self._set_parameters(parameters, pose)
        dll = self._slave.dll
        c = self._slave.component
        self._c = c
        n_in, n_out = len(INPUT_ROLES), len(OUTPUT_ROLES)
        self._vr_in = (ctypes.c_uint32 * n_in)(*(lib.vr[r] for r in INPUT_ROLES))
        self._vr_out = (ctypes.c_uint32 * n_out)(*(lib.vr[r] for r in OUTPUT_ROLES))
        if cmd_row.dtype != np.float64 or not cmd_row.flags.c_contiguous or cmd_row.shape != (n_in,):
            raise ValueError(f"cmd_row must be a contiguous float64 array of shape ({n_in},)")
        if out_row.dtype != np.float64 or not out_row.flags.c_contiguous or out_row.shape != (n_out,):
            raise ValueError(f"out_row must be a contiguous float64 array of shape ({n_out},)")
        self._in = (ctypes.c_double * n_in).from_buffer(cmd_row)
        self._out = (ctypes.c_double * n_out).from_buffer(out_row)
        self._do_name = prefix + "DoStep"
        self._set_name = "fmi2SetReal" if lib.fmi_version == 2 else "fmi3SetFloat64"
        self._get_name = "fmi2GetReal" if lib.fmi_version == 2 else "fmi3GetFloat64"
        if lib.fmi_version == 2:
            self._set = dll.fmi2SetReal
            self._get = dll.fmi2GetReal
            self._do = dll.fmi2DoStep
            self._step_args: tuple[Any, ...] = (1,)
            self._nvals: tuple[Any, ...] = ()
        else:
            self._set = dll.fmi3SetFloat64
            self._get = dll.fmi3GetFloat64
            self._do = dll.fmi3DoStep
            self._flags = [fmi3Boolean() for _ in range(3)]  # eventHandlingNeeded, terminateSimulation, earlyReturn
            self._last = fmi3Float64()
            self._step_args = (True, *(ctypes.byref(f) for f in self._flags), ctypes.byref(self._last))
            self._terminate = self._flags[1]
        self._nin, self._nout = n_in, n_out
        self._setup_calls()
        self.read()

    def _load_check(self, lib: FmuLibrary) -> None:
        """The FMU's library for this platform is there: an FmuError of the file (``call``
        "load", exit 2) naming the member otherwise, before anything is loaded."""
        folder = lib._unzipdir
        if folder is None:
            return
        member = _library_member(lib)
        if not os.path.isfile(os.path.join(folder, member)):
            raise FmuError(
                f"{lib.path} has no {member}, the library its modelIdentifier {lib.identifier!r} names",
                model=lib.identifier,
                call="load",
            )

    @contextlib.contextmanager
    def _in_call(self, call: str) -> Iterator[None]:
        """Mark the slow-path FMI call ``call`` as in progress (the hot path does it inline)."""
        self.calls += 1
        self.busy = call
        try:
            yield
        finally:
            self.busy = None
            if _gate_closed:
                _pass_gate()

    # FMU log callbacks: keep messages (errors name the variable), forward to logging.
    def _log2(self, env: object, instance: bytes, status: int, category: bytes, message: bytes) -> None:
        self._keep(status, category, message.replace(b"%%", b"%"))

    def _log3(self, env: object, status: int, category: bytes, message: bytes) -> None:
        self._keep(status, category, message)

    def _keep(self, status: int, category: bytes | None, message: bytes | None) -> None:
        text = (message or b"").decode("utf-8", "replace")
        self.messages.append(text)
        if status >= 2:
            self._refusals.append(text)
            self._refused += 1
        # Errors travel inside the FmuError that follows; warnings are worth a line here.
        level = logging.WARNING if status == 1 else logging.DEBUG
        log.log(level, "%s [%s] %s", self.name, _status_text(status), text)

    def _error(self, message: str, call: str, status: int | None = None) -> FmuError:
        if status == FATAL:
            self._fatal = True
        if status is not None and not self.messages and not self._logging:
            message += " (run with --debug to switch the FMU's own logging on: it may say why)"
        return FmuError(message, model=self.lib.identifier, call=call, status=status, log=self.messages)

    def _setup_calls(self) -> None:
        # Pre-bind argument tuples so the hot path only unpacks them.
        if self.lib.fmi_version == 2:
            self._set_args = (self._c, self._vr_in, self._nin, self._in)
            self._get_args = (self._c, self._vr_out, self._nout, self._out)
        else:
            self._set_args = (self._c, self._vr_in, self._nin, self._in, self._nin)
            self._get_args = (self._c, self._vr_out, self._nout, self._out, self._nout)

    def _checked(self, call: str, fn: Any, *args: Any, **kwargs: Any) -> None:
        if self._freed:
            self._refuse_freed(call=call)
        try:
            with self._in_call(call):
                fn(*args, **kwargs)
        except FMICallException as exc:
            raise self._error(
                f"{self.lib.identifier} ({self.name}): {call} returned {_status_text(exc.status)}", call, exc.status
            ) from exc

    def _set_parameters(self, parameters: Mapping[str, float], pose: tuple[float, float, float]) -> None:
        s = self._slave
        v = self.lib.fmi_version
        # by the variable's type, each with its own setter: FMI 2 value references are unique
        # per type only, so an Integer's may be a Real's too (fmpy's apply_start_values does so)
        typed: dict[str, dict[int, object]] = {}
        for name, value in parameters.items():
            var = self.lib.variables.get(name)
            if var is None:
                from lfctl.fmu.build import default_cache_dir

                built_in = Path(self.lib.path).parent.parent == default_cache_dir()  # (a built model's)
                shown = self.lib.identifier if built_in else self.lib.path
                raise ConfigError(
                    f"vehicles[{self.name}].parameters.{name}: parameter {name!r} does not exist in "
                    f"{self.lib.identifier} (`{command('lfctl', 'fmu', 'info', shown)}` lists its variables)"
                )
            if var.causality != "parameter":
                raise ConfigError(
                    f"vehicles[{self.name}].parameters.{name}: {name!r} has causality {var.causality!r} in "
                    f"{self.lib.identifier}, not a parameter"
                )
            typed.setdefault(_setter(v, var.type), {})[int(var.valueReference)] = _typed_value(
                self.lib.path, name, var.type, value
            )
            why = _out_of_range(var, value)
            if why is not None:  # FMI: a value set outside min and max is the caller's error
                raise ConfigError(f"{self.lib.path}: parameter {name!r} = {value!r} is {why} in {self.lib.identifier}")
        if self.lib.pose_mapped:
            reals = typed.setdefault(_setter(v, "Real" if v == 2 else "Float64"), {})
            for role, value in zip(POSE_ROLES, pose, strict=True):
                reals[self.lib.vr[role]] = value / self.lib.scale[role]
        if v == 2:
            self._checked("fmi2SetupExperiment", s.setupExperiment, None, self._start_time_s)
        for setter, values in typed.items():
            self._checked(
                f"fmi{v}{setter[0].upper()}{setter[1:]}", getattr(s, setter), list(values), list(values.values())
            )
        if v == 2:
            self._checked("fmi2EnterInitializationMode", s.enterInitializationMode)
        else:
            self._checked("fmi3EnterInitializationMode", s.enterInitializationMode, startTime=self._start_time_s)
        before = self._refused
        try:
            self._checked(f"fmi{v}ExitInitializationMode", s.exitInitializationMode)
        except FmuError as exc:
            # the FMU checks its parameters as it leaves initialization (the built-in models'
            # strict bounds, which a model description's min and max cannot say): a value the
            # scenario gave that the FMU names in its refusal (an error it logged in this call,
            # not a line it logged before) is the scenario's error
            new = min(self._refused - before, len(self._refusals))
            refused = _refused_parameter(list(self._refusals)[len(self._refusals) - new :], parameters)
            if refused is None:
                raise
            name, words = refused
            raise ConfigError(
                f"vehicles[{self.name}].parameters.{name} = {parameters[name]!r}: {self.lib.identifier} says: {words}"
            ) from exc

    # -- hot path ------------------------------------------------------------------------
    def step(self, dt_s: float) -> None:
        """Send the command row, advance ``dt_s``, read the output row. Raises FmuError.

        The outputs are not checked here (see the class); call :meth:`check_outputs`.

        Parameters
        ----------
        dt_s : float
            The communication step, s.
        """
        # busy names the FMI call the FMU is in, for a watchdog (calls_in_progress)
        # a Warning (1) is a call that did its work, "not quite right" (logged): go on
        self.busy = self._set_name
        status = self._set(*self._set_args)
        if status <= 1:
            self.busy = self._do_name
            status = self._do(self._c, self.t_s, dt_s, *self._step_args)
            if status <= 1:
                self.busy = self._get_name
                status = self._get(*self._get_args)
        call, self.busy = self.busy, None
        if _gate_closed:  # a watchdog is finishing the run: wait for it
            _pass_gate()
        if status <= 1:
            self.t_s += dt_s
            if self._terminate is not None and self._terminate.value:
                raise self._error(
                    f"{self.lib.identifier} ({self.name}): {self._do_name} at t={self.t_s - dt_s:.6g} s asked to "
                    "end the simulation (terminateSimulation)",
                    self._do_name,
                )
            return
        self._raise_status(call, status)

    def check_outputs(self) -> None:
        """Raise FmuError if an output read last is not finite or beyond :data:`OUTPUT_BOUNDS`
        (see :func:`check_output_row`)."""
        check_output_row(self.lib, self.name, self._out, self.t_s)

    def _raise_status(self, call: str, status: int) -> None:
        if status == 1:  # warning: keep going, it was logged
            return
        raise self._error(
            f"{self.lib.identifier} ({self.name}): {call} at t={self.t_s:.6g} s returned {_status_text(status)}",
            call,
            status,
        )

    def set_real(self, values: Mapping[str, float]) -> None:
        """Set FMU variables by name (slow path: tests, tunable parameters).

        Parameters
        ----------
        values : Mapping[str, float]
            Variable name -> value, FMU units (KeyError for an unknown name).
        """
        vrs = [int(self.lib.variables[n].valueReference) for n in values]
        v = self.lib.fmi_version
        fn = self._slave.setReal if v == 2 else self._slave.setFloat64
        self._checked("fmi2SetReal" if v == 2 else "fmi3SetFloat64", fn, vrs, [float(v) for v in values.values()])

    def read(self) -> None:
        """Refresh the output row without stepping, and check it (:meth:`check_outputs`)."""
        with self._in_call(self._get_name):
            status = self._get(*self._get_args)
        if status != 0:
            self._raise_status(self._get_name, status)
        self.check_outputs()

    def reset(self, parameters: Mapping[str, float], pose: tuple[float, float, float]) -> None:
        """FMI Reset, then parameterise and initialise again at the start time.

        Parameters
        ----------
        parameters : Mapping[str, float]
            FMU parameter name -> value, FMU units.
        pose : (north_m, east_m, yaw_rad)
            The initial pose, SI (used when the FMU has initial-pose parameters).
        """
        self._checked("Reset", self._slave.reset)
        self.t_s = self._start_time_s
        self._set_parameters(parameters, pose)
        self.read()

    def free(self) -> None:
        """Terminate (when possible) and free the instance; safe to call twice."""
        if self._freed:
            return
        self._freed = True
        try:
            if self._slave is None:  # instantiation failed: nothing to free
                return
            if self._fatal:  # FMI: after Fatal no function may be called (freeing crashed some FMUs)
                return
            v = self.lib.fmi_version
            # already in an error state: freeing is still right
            with contextlib.suppress(Exception), self._in_call(f"fmi{v}Terminate"):
                self._slave.terminate()
            fn = self._slave.fmi2FreeInstance if v == 2 else self._slave.fmi3FreeInstance
            with self._in_call(f"fmi{v}FreeInstance"):
                fn(self._slave.component)
            # fmpy's freeInstance would also dlclose; the library is shared, so leave it loaded.
        finally:
            _INSTANCES.pop(id(self), None)
            # the hot path's calls now refuse, without reaching into the freed FMU (a call
            # there reads freed memory, and the next one could end the process)
            self._set = self._do = self._get = self._refuse_freed

    def _refuse_freed(self, *_args: Any, call: str | None = None) -> int:
        call = call or self.busy or "a call"  # the hot path names its call in busy
        self.busy = None  # no call went into the FMU
        raise self._error(
            f"{self.lib.identifier} ({self.name}): {call} after the instance was freed (FmuInstance.free or "
            "FmuLibrary.close): instantiate it again",
            call,
        )


def _root_element(xml: bytes) -> str | None:
    """The name of an XML document's root element (None: it does not parse that far; fmpy
    then says why). Read up to the root's start alone: no entity in its content is expanded."""
    import xml.etree.ElementTree as ET

    parser = ET.XMLPullParser(events=("start",))
    try:
        for start in range(0, len(xml), 4096):
            parser.feed(xml[start : start + 4096])
            for _event, element in parser.read_events():
                return element.tag.rsplit("}", 1)[-1]  # (a namespace's braces left out)
    except ET.ParseError:
        return None
    return None
