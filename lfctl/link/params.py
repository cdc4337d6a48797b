"""Vehicle parameters: ArduPilot Rover's names, defaults, units and ranges where Rover has the
parameter (``LFC_*`` are lfctl's formation slot), and parameter files as MAVProxy and
QGroundControl write them."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lfctl.checks import printable, read_text_file, save_text
from lfctl.errors import ConfigError

__all__ = [
    "INT8",
    "INT16",
    "INT32",
    "MAV_FLOAT_MAX",
    "REAL32",
    "Param",
    "ParamFileError",
    "default_params",
    "formation_params",
    "load_param_file",
    "save_param_file",
    "set_values",
]

#: a parameter name: ArduPilot's 16-character limit, letters, digits and underscores
MAX_NAME_LEN = 16
#: the most lines a parameter file may have (ArduPilot has about 1,500 parameters)
MAX_FILE_LINES = 20_000
#: the largest parameter file read, bytes
MAX_FILE_BYTES = 2 * 1024 * 1024
#: the largest magnitude a parameter's value may have: what PARAM_SET's 32-bit float carries
#: (`lfctl gcs param set` bounds its value the same)
MAV_FLOAT_MAX = 3.4e38
#: MAV_PARAM_TYPE values the parameters use
INT8, INT16, INT32, REAL32 = 2, 4, 6, 9
#: ARMING_CHECK's bits lfctl has checks for: all of them, and the parameter checks
ARMING_CHECK_ALL, ARMING_CHECK_PARAMETERS = 1, 1 << 5


@dataclass
class Param:
    """A vehicle parameter.

    Parameters
    ----------
    value : float
        Its value now, in ``unit``.
    lo, hi : float
        The range a ground station may set it within, in ``unit``.
    unit : str
        Its unit as a ground station shows it (``""`` for none).
    description : str
        What it does.
    readonly : bool
        Refuse any set.
    kind : int
        Its MAV_PARAM_TYPE, ArduPilot's: REAL32 (9) for an ``AP_Float``, INT8 (2), INT16
        (4) or INT32 (6) for an ``AP_Int8`` / ``AP_Int16`` / ``AP_Int32`` (PARAM_VALUE says
        it; MAVSDK's ``get_param_int`` needs it).
    group : str
        The name of the top-level ``AP_Param`` group Rover keeps it in, the part of its name
        ``AP_Param::find`` matches in its own case (``strncmp``), the rest in any case
        (``strncasecmp``, ``strcasecmp``): ``"SCHED_"`` (``SCHED_LOOP_RATE``),
        ``"ARMING_"`` (``ARMING_CHECK``); ``""``, the whole name in any case, for a top-level
        scalar (``CRUISE_SPEED``) or one in a group named ``""`` (``ParametersG2``'s
        ``TURN_RADIUS`` and its subgroups' ``WP_SPEED``, ``SRTL_POINTS``; ``AP_Vehicle``'s
        ``FENCE_*``). lfctl's ``LFC_*`` are ``"LFC_"``, as a script's table
        (``AP_Param::add_table``, a top-level group of its prefix) would be.
    """

    value: float
    lo: float
    hi: float
    unit: str
    description: str
    readonly: bool = False
    kind: int = REAL32
    group: str = ""

    def accepts(self, value: float) -> bool:
        """Whether a ground station may set ``value`` (finite, in range once stored, not
        read-only).

        Parameters
        ----------
        value : float
            The value asked for.
        """
        return not self.readonly and math.isfinite(value) and self.lo <= self.stored(value) <= self.hi

    def stored(self, value: float) -> float:
        """``value`` as this parameter keeps it: an integer parameter truncates, after
        ArduPilot's 0.01 nudge away from zero (``AP_Param::set_float``: 0.5 -> 0, 0.999 -> 1).

        Parameters
        ----------
        value : float
            A finite value.
        """
        if self.kind == REAL32:
            return float(value)
        return float(math.trunc(value + math.copysign(0.01, value)))


def default_params(sysid: int) -> dict[str, Param]:
    """Every parameter with real effect, at ArduPilot Rover's defaults.

    Parameters
    ----------
    sysid : int
        This vehicle's system id (``SYSID_THISMAV``).
    """
    return {
        "SYSID_THISMAV": Param(sysid, 1, 255, "", "this vehicle's MAVLink system id", readonly=True, kind=INT16),
        "WP_SPEED": Param(2.0, 0.0, 100.0, "m/s", "AUTO, GUIDED and RTL speed; GUIDED setpoints are limited to it"),
        "WP_RADIUS": Param(2.0, 0.0, 100.0, "m", "waypoint acceptance radius"),
        "CRUISE_SPEED": Param(2.0, 0.0, 100.0, "m/s", "speed at the cruise throttle"),
        "CRUISE_THROTTLE": Param(50, 0, 100, "%", "throttle at CRUISE_SPEED (VFR_HUD's throttle)", kind=INT8),
        "RTL_SPEED": Param(0.0, 0.0, 100.0, "m/s", "RTL and SmartRTL speed; 0: WP_SPEED"),
        "RALLY_LIMIT_KM": Param(
            0.5, 0.0, 1000.0, "km", "RTL goes home when every rally point is farther than this; 0: no limit"
        ),
        "RALLY_INCL_HOME": Param(
            1,
            0,
            1,
            "",
            "1: RTL goes home when it is nearer than the nearest rally point; 0: to the rally point",
            kind=INT8,
        ),
        "SRTL_ACCURACY": Param(
            2.0,
            0.0,
            10.0,
            "m",
            "SmartRTL: a point of the way back each time the vehicle has moved this far; 0: none kept (at boot)",
        ),
        "SRTL_POINTS": Param(
            300,
            0,
            500,
            "",
            "SmartRTL: the most points of the way back (taken at boot); 0: none kept",
            kind=INT16,
        ),
        "SCHED_LOOP_RATE": Param(
            50,
            50,
            400,
            "Hz",
            "the main loop's rate (taken at boot): a message is sent at most 0.8 x this often",
            kind=INT16,
            group="SCHED_",  # Rover's GOBJECT(scheduler, "SCHED_", AP_Scheduler)
        ),
        "CIRC_SPEED": Param(0.0, 0.0, 10.0, "m/s", "speed round a mission's NAV_LOITER_TURNS circle; 0: WP_SPEED"),
        "MIS_DONE_BEHAVE": Param(
            0, 0, 3, "", "at a mission's end: 0 hold in AUTO, 1 loiter in AUTO, 2 ACRO, 3 MANUAL", kind=INT8
        ),
        "MIS_RESTART": Param(
            0,
            0,
            1,
            "",
            "entering AUTO: 0 resumes the mission, 1 restarts it from its first item (DO_JUMP's counts afresh)",
            kind=INT8,
            group="MIS_",  # Rover's GOBJECT(mission, "MIS_", AP_Mission): its AP_Int8 _restart
        ),
        "TURN_RADIUS": Param(
            0.9, 0.0, 10.0, "m", "the vehicle's turning radius: a mission's circle is at least this large"
        ),
        "FS_ACTION": Param(
            2,
            0,
            6,
            "",
            "on a failsafe: 0 nothing, 1 RTL or HOLD, 2 HOLD, 3 SmartRTL or RTL or HOLD, 4 SmartRTL or HOLD, "
            "5 disarm, 6 LOITER or HOLD (lfctl has no LOITER: HOLD)",
            kind=INT8,
        ),
        "FS_TIMEOUT": Param(1.5, 1.0, 100.0, "s", "a failsafe acts once its condition has lasted this long"),
        "FS_OPTIONS": Param(0, 0, 1, "", "bitmask: 1 a failsafe acts in HOLD too", kind=INT32),
        "FS_GCS_ENABLE": Param(
            0,
            0,
            2,
            "",
            "1: the failsafe (FS_ACTION) once SYSID_MYGCS is silent for FS_GCS_TIMEOUT; 2: the same, "
            "but a mission in AUTO goes on",
            kind=INT8,
        ),
        "FS_GCS_TIMEOUT": Param(
            5.0, 2.0, 120.0, "s", "the ground station (SYSID_MYGCS: its heartbeat or its sticks) is lost after this"
        ),
        "FENCE_ENABLE": Param(0, 0, 1, "", "1: check the geofence", kind=INT8),
        "FENCE_TYPE": Param(
            6, 0, 15, "", "bitmask: 2 circle of FENCE_RADIUS around home, 4 polygons and circles uploaded", kind=INT8
        ),
        "FENCE_ACTION": Param(
            1,
            0,
            6,
            "",
            "on breach: 0 report, 1 RTL or HOLD, 2 HOLD, 3 SmartRTL or RTL or HOLD, 4 SmartRTL or HOLD, "
            "5 disarm, 6 LOITER or HOLD (lfctl has no LOITER: HOLD)",
            kind=INT8,
        ),
        "FENCE_RADIUS": Param(300.0, 30.0, 10000.0, "m", "circle fence radius around home"),
        "FENCE_MARGIN": Param(2.0, 1.0, 10.0, "m", "distance inside the fence that counts as near it"),
        "ARMING_CHECK": Param(
            1,
            0,
            0x7FFFFF,
            "",
            "pre-arm checks: 0 none, 1 all, else a bitmask (32: parameters)",
            kind=INT32,
            group="ARMING_",  # Rover's GOBJECT(arming, "ARMING_", AP_Arming)
        ),
        "SYSID_MYGCS": Param(
            255, 1, 255, "", "the ground station whose RC_CHANNELS_OVERRIDE and MANUAL_CONTROL are taken", kind=INT16
        ),
        "RC_OVERRIDE_TIME": Param(
            3.0,
            -1.0,
            120.0,
            "s",
            "an RC override lasts this long after it last came; 0: none taken, -1: until released",
        ),
        **formation_params(),
    }


def formation_params() -> dict[str, Param]:
    """lfctl's formation parameters, ``LFC_*``, at their defaults: the slot, the coast, the
    search and the law. A simulated follower has them among its vehicle's parameters; on a
    real rover its companion (``lfctl follow``, component 191) has them. Their names are
    found as a script's table of prefix ``LFC_`` would be (:attr:`Param.group`)."""
    table = {
        "LFC_RANGE": Param(1.5, 0.1, 1000.0, "m", "formation: commanded range to the target"),
        "LFC_BEARING": Param(0.0, -180.0, 180.0, "deg", "formation: commanded bearing to the target"),
        "LFC_COAST": Param(2.0, 0.0, 3600.0, "s", "formation: coast this long on the filter when the target is hidden"),
        "LFC_SEARCH": Param(
            0.0, 0.0, 360.0, "deg/s", "formation: once the target is lost, turn one full turn at this rate; 0: hold"
        ),
        "LFC_LAW": Param(
            0,
            0,
            2,
            "",
            "formation: the law: 0 sliding mode (the paper's), 1 P (AP_Follow), 2 trail (its path)",
            kind=INT8,
        ),
        "LFC_LOOKAHEAD": Param(
            0.3, 0.01, 100.0, "m", "formation: the trail law steers for the point this far along the path"
        ),
    }
    for p in table.values():
        p.group = "LFC_"
    return table


def set_values(params: dict[str, Param], values: dict[str, float], source: str) -> None:
    """Start parameters at ``values`` (a scenario's, a command line's), each inside its range:
    one outside is a ConfigError naming it, as a ground station could not set it back.

    Parameters
    ----------
    params : dict of str to Param
        The table.
    values : dict of str to float
        Values by name.
    source : str
        Where the values come from, for the message.
    """
    for name, value in values.items():
        p = params[name]
        if not p.lo <= value <= p.hi:
            raise ConfigError(
                f"{source}: {name} would be {value:g}, outside its {p.lo:g}..{p.hi:g} {p.unit}".rstrip()
                + " (a ground station could not set it back)"
            )
        p.value = p.stored(value)


class ParamFileError(ConfigError):
    """A parameter file does not parse.

    Parameters
    ----------
    path : Path
        The file.
    line : int
        The 1-based line number (0 for the whole file).
    reason : str
        What is wrong there.
    """

    def __init__(self, path: Path, line: int, reason: str) -> None:
        self.path = path
        self.line = line
        self.reason = reason
        where = f"{path}:{line}" if line else str(path)
        super().__init__(f"{where}: {reason}")


def _valid_name(name: str) -> bool:
    return 0 < len(name) <= MAX_NAME_LEN and all(c.isalnum() or c == "_" for c in name) and name.isascii()


def load_param_file(path: str | Path) -> dict[str, float]:
    """Read a parameter file: MAVProxy's ``NAME VALUE`` (or ``NAME,VALUE``) lines, or
    QGroundControl's tab-separated ``sysid compid NAME VALUE type`` lines; ``#`` starts a comment.

    Parameters
    ----------
    path : str or Path
        The file.

    Raises
    ------
    ParamFileError
        A line that is neither form, a bad name, a value that is not a finite number, or a
        file too long.
    """
    p = Path(path)
    try:
        text = read_text_file(p, "parameter file", MAX_FILE_BYTES)
    except ConfigError as exc:
        raise ParamFileError(p, 0, str(exc)) from None
    out: dict[str, float] = {}
    for k, raw in enumerate(text.splitlines(), start=1):
        if k > MAX_FILE_LINES:
            raise ParamFileError(p, k, f"more than {MAX_FILE_LINES} lines: not a parameter file")
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.split("\t") if "\t" in line else line.replace(",", " ").split()
        parts = [s.strip() for s in parts if s.strip()]
        if len(parts) == 5:  # QGroundControl: vehicle id, component id, name, value, type
            name, value_text = parts[2], parts[3]
        elif len(parts) == 2:  # MAVProxy / Mission Planner
            name, value_text = parts
        else:
            raise ParamFileError(p, k, f"expected 'NAME VALUE' or QGroundControl's 5 columns, got {raw.strip()!r}")
        if not _valid_name(name):
            raise ParamFileError(p, k, f"bad parameter name {name!r} (letters, digits, _; at most {MAX_NAME_LEN})")
        try:
            value = float(value_text)
        except ValueError:
            raise ParamFileError(p, k, f"{name}: value {value_text!r} is not a number") from None
        if not math.isfinite(value):
            raise ParamFileError(p, k, f"{name}: value {value_text!r} is not finite")
        if abs(value) > MAV_FLOAT_MAX:
            raise ParamFileError(
                p, k, f"{name}: value {value_text!r} is beyond what MAVLink's float carries (+-{MAV_FLOAT_MAX:g})"
            )
        out[name] = value
    return out


def _number(value: float) -> str:
    """A parameter's value as text that reads back to the same value: a whole number in full
    (a bitmask such as 1048574 must not become 1.04857e+06), else the shortest decimal of its
    32-bit float, as PARAM_VALUE carries it (0.7, not 0.699999988)."""
    if math.isfinite(value) and float(value).is_integer():
        return str(int(value))
    return np.format_float_positional(np.float32(value), trim="-")


def save_param_file(values: dict[str, float], path: str | Path, fmt: str = "mavproxy", sysid: int = 1) -> None:
    """Write a parameter file.

    Parameters
    ----------
    values : dict
        Parameter name -> value.
    path : str or Path
        The file to write.
    fmt : "mavproxy" or "qgc"
        MAVProxy's ``NAME VALUE`` lines, or QGroundControl's tab-separated table.
    sysid : int
        The vehicle's system id (the QGroundControl format names it).

    Raises
    ------
    ConfigError
        A name or a value :func:`load_param_file` could not read back (named), or an unknown
        format; nothing is written then.
    """
    bad = [f"{name!r} = {value}" for name, value in values.items() if not _valid_name(name) or not math.isfinite(value)]
    if bad:
        shown = ", ".join(bad[:5]) + (", ..." if len(bad) > 5 else "")
        raise ConfigError(
            f"not saving {path}: {len(bad)} parameters could not be loaded back (a name of letters, digits "
            f"and _ up to {MAX_NAME_LEN}, a finite value): {printable(shown)}"
        )
    if fmt == "mavproxy":
        lines = [f"{name:<16} {_number(value)}" for name, value in sorted(values.items())]
    elif fmt == "qgc":
        lines = ["# Onboard parameters for Vehicle " + str(sysid), "#", "# Vehicle-Id Component-Id Name Value Type"]
        lines += [f"{sysid}\t1\t{name}\t{value!r}\t9" for name, value in sorted(values.items())]
    else:
        raise ConfigError(f"parameter file format must be 'mavproxy' or 'qgc', got {fmt!r}")
    save_text(path, "\n".join(lines) + "\n")
