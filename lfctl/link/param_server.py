"""The MAVLink parameter protocol over a table of :class:`~lfctl.link.params.Param`, answered
as ArduPilot answers it: the vehicle endpoint's parameters (component 1) and, on a real
rover, the companion's ``LFC_*`` (component 191) go through the same code.

The same table is also a file over MAVLink FTP, ``@PARAM/param.pck``, in ArduPilot's packed
format (``AP_Filesystem_Param``), which MAVProxy and pymavlink's ``mavftp`` fetch instead of
the parameter list when the vehicle serves it: a 6-byte header (magic 0x671b, or 0x671c with
default values; the number of parameters in the file; the number the vehicle has), then per
parameter one byte of type (AP_Param's: 1 int8, 2 int16, 3 int32, 4 float) and flags (bit 0:
its default follows its value), one byte of the name's length past the part it shares with
the previous name (minus one, high nibble) and that shared length (low nibble), the rest of
the name, then the value (and the default), little-endian. A file of this format written
back sets the parameters it names (ArduPilot's parameter upload), each as a PARAM_SET would.
"""

from __future__ import annotations

import errno
import math
import re
import struct
import time
from collections.abc import Callable, Hashable
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.link.ftp import FtpFile, ReadFails
from lfctl.link.params import INT8, INT16, INT32, REAL32, Param

__all__ = [
    "PACKED_MAGIC",
    "PACKED_MAGIC_DEFAULTS",
    "ParamServer",
    "ascii_upper",
    "pack_params",
    "param_text",
    "unpack_params",
]

#: ``@PARAM/param.pck``'s magic numbers: without and with default values
PACKED_MAGIC, PACKED_MAGIC_DEFAULTS = 0x671B, 0x671C
_PACKED_HEADER = struct.Struct("<HHH")
#: AP_Param's type numbers in the packed file, and each one's struct format, by MAV_PARAM_TYPE
_AP_TYPE = {INT8: (1, "b"), INT16: (2, "h"), INT32: (3, "i"), REAL32: (4, "f")}
_AP_FORMAT = {ap: fmt for ap, fmt in _AP_TYPE.values()}


def param_text(value: str | bytes) -> str:
    """A MAVLink char field as text (a parameter's name: up to 16 bytes, NUL-padded), to its
    first NUL, as ArduPilot reads it (a C string: ``param_upload_parse``'s name too).

    Parameters
    ----------
    value : str or bytes
        The field as pymavlink gives it.
    """
    text = value.decode(errors="replace") if isinstance(value, (bytes, bytearray)) else str(value)
    return text.split("\x00", 1)[0]


def ascii_upper(text: str) -> str:
    """``text`` with its ASCII letters in upper case and nothing else changed, as C's
    ``strcasecmp`` compares two names (``"ß".upper()`` is ``"SS"``, no name's letters).

    Parameters
    ----------
    text : str
        A parameter's name.
    """
    return text.translate(_UPPER)


_UPPER = str.maketrans("abcdefghijklmnopqrstuvwxyz", "ABCDEFGHIJKLMNOPQRSTUVWXYZ")


def _packed_value(fmt: str, value: float) -> bytes:
    """``value`` as the packed file holds it (an integer type's value is an integer already)."""
    return struct.pack("<" + fmt, value if fmt == "f" else int(value))


def pack_params(
    params: dict[str, Param],
    defaults: dict[str, float] | None = None,
    start: int = 0,
    count: int = 0,
) -> bytes:
    """``params`` as ``@PARAM/param.pck`` (the module's docstring gives the format).

    Parameters
    ----------
    params : dict of str to Param
        The table, in list order.
    defaults : dict of str to float, optional
        Each parameter's default: given, the file is the "with defaults" kind (magic
        0x671c), each parameter not at its default followed by it.
    start, count : int
        The first parameter in the file (its index in the list) and how many (0: the rest),
        as ``param.pck?start=N&count=C`` asks.
    """
    names = list(params)[start:]
    if count:
        names = names[:count]
    out = bytearray(
        _PACKED_HEADER.pack(PACKED_MAGIC if defaults is None else PACKED_MAGIC_DEFAULTS, len(names), len(params))
    )
    last = b""
    for name in names:
        p = params[name]
        ap_type, fmt = _AP_TYPE[p.kind]
        raw = name.encode()
        common = 0
        while common < min(len(raw), len(last), 15) and raw[common] == last[common]:
            common += 1
        if common == len(raw):  # a name that is the start of the one before: one byte of it told
            common -= 1
        default = None if defaults is None else defaults.get(name)
        with_default = default is not None and default != p.value
        out += bytes([ap_type | (int(with_default) << 4), common | ((len(raw) - common - 1) << 4)])
        out += raw[common:] + _packed_value(fmt, p.value)
        if with_default:
            out += _packed_value(fmt, default)
        last = raw
    return bytes(out)


def unpack_params(data: bytes) -> list[tuple[str, float]]:
    """The (name, value) pairs of an uploaded ``@PARAM/param.pck``, checked as ArduPilot
    checks an upload: the header's magic (0x671b: an upload carries no defaults) and its
    length (the third number is the file's length), each parameter's type, flags and name.

    Parameters
    ----------
    data : bytes
        The file.

    Raises
    ------
    ValueError
        What is wrong with the file, and where.
    """
    out: list[tuple[str, float]] = []
    _read_params(data, out)
    return out


def _read_params(data: bytes, out: list[tuple[str, float]]) -> None:
    """:func:`unpack_params`, each pair put in ``out`` as it is read (so the caller keeps
    those before a damaged one, as ArduPilot's param_upload_parse has set them by then)."""
    if len(data) < _PACKED_HEADER.size:
        raise ValueError(f"{len(data)} bytes, fewer than the header's {_PACKED_HEADER.size}")
    magic, count, length = _PACKED_HEADER.unpack_from(data)
    if magic != PACKED_MAGIC:
        raise ValueError(f"magic 0x{magic:04x}, not 0x{PACKED_MAGIC:04x}")
    if length != len(data):
        raise ValueError(f"the header gives the file's length as {length}, it is {len(data)} bytes")
    pos, last = _PACKED_HEADER.size, b""
    for k in range(count):
        where = f"parameter {k + 1} of {count} (byte {pos})"
        if pos + 2 > len(data):
            raise ValueError(f"{where}: the file ends")
        kind, flags, lens = data[pos] & 0x0F, data[pos] >> 4, data[pos + 1]
        fmt = _AP_FORMAT.get(kind)
        if fmt is None:
            raise ValueError(f"{where}: type {kind}, not 1-4")
        if flags:
            raise ValueError(f"{where}: flags {flags} (an upload carries no defaults)")
        common, name_len = lens & 0x0F, (lens >> 4) + 1
        if common > len(last) or common + name_len > 16:
            raise ValueError(f"{where}: a name of {common} + {name_len} bytes after {last.decode(errors='replace')!r}")
        size = struct.calcsize("<" + fmt)
        if pos + 2 + name_len + size > len(data):
            raise ValueError(f"{where}: the file ends")
        raw = last[:common] + data[pos + 2 : pos + 2 + name_len]
        (value,) = struct.unpack_from("<" + fmt, data, pos + 2 + name_len)
        out.append((raw.decode(errors="replace"), float(value)))
        pos, last = pos + 2 + name_len + size, raw


#: a warning of lfctl's own (an unknown parameter, a value refused) is not said again within
#: this long, s: a client's tries again of the same request get it once
REPEAT_S = 1.0


class ParamServer:
    """Answers PARAM_REQUEST_LIST, PARAM_REQUEST_READ and PARAM_SET over ``params``.

    A list gets every parameter with its index; a read by index or by name gets one (a read
    by name, index -1 and the name as it was asked, as ArduPilot answers it); a set stores the
    value as ``AP_Param`` stores it and is answered with the value in force, index -1, whether
    it was taken or not. A name is found as ``AP_Param::find`` finds it (:meth:`name_of`):
    its top-level group's name in its own case, the rest in any case.
    An unknown name or index, a value outside the parameter's range and a read-only parameter
    are each said in a line of text (ArduPilot's own words for a read-only one); the same line
    of lfctl's own is said to one asker once in :data:`REPEAT_S`, as a client tries a request
    again (MAVSDK five times in a few tens of milliseconds) and a Rover says nothing of those
    at all.

    Parameters
    ----------
    params : dict of str to Param
        The table, in list order; its values change with each accepted set.
    send : callable
        Sends one MAVLink message.
    say : callable
        Sends a line of text (STATUSTEXT) with a MAV_SEVERITY.
    asker : callable, optional
        Who sent the request in hand (a network peer): a client's tries again are its own,
        another client's request (a second ``lfctl gcs``) is said its warning at once.
    """

    def __init__(
        self,
        params: dict[str, Param],
        send: Callable[[Any], None],
        say: Callable[[str, int], None],
        asker: Callable[[], Hashable] | None = None,
    ) -> None:
        self.params = params
        self._send = send
        self._say = say
        self._asker = asker
        #: (asker, one of lfctl's own warnings) -> when it was last said, monotonic s
        self._said: dict[tuple[Hashable, str], float] = {}
        #: each parameter's default: its value when the server was made (the table's defaults)
        self.defaults = {name: p.value for name, p in params.items()}

    def value_message(self, name: str, indexed: bool = True, said: str | None = None) -> Any:
        """PARAM_VALUE for ``name``: with its index in the list, or (``indexed`` False) index -1.

        Parameters
        ----------
        name : str
            A parameter of the table.
        indexed : bool
            Give its index (a list, a read by index) or -1 (a set, a read by name).
        said : str, optional
            The name as the request spelled it, to answer with instead (a read by name, a
            read-only parameter's set: Rover answers those with the request's own ``key``).
        """
        names = list(self.params)
        p = self.params[name]
        index = names.index(name) if indexed else 0xFFFF
        return mav.MAVLink_param_value_message((said or name).encode(), float(p.value), p.kind, len(names), index)

    def name_of(self, raw: str | bytes) -> str | None:
        """The parameter a request names, or None: as ``AP_Param::find`` finds it, its
        top-level group's name (:attr:`Param.group`) in its own case and the rest in any
        case (``wp_speed`` is WP_SPEED, ``SCHED_loop_rate`` SCHED_LOOP_RATE,
        ``sched_loop_rate`` nothing).

        Parameters
        ----------
        raw : str or bytes
            The request's ``param_id``.
        """
        name = param_text(raw)
        if name in self.params:
            return name
        folded = ascii_upper(name)
        for known, p in self.params.items():
            if name.startswith(p.group) and ascii_upper(known) == folded:
                return known
        return None

    def request_list(self) -> None:
        """Every parameter, in order (PARAM_REQUEST_LIST)."""
        for name in self.params:
            self._send(self.value_message(name))

    def request_read(self, m: Any) -> None:
        """One parameter, by index (``param_index`` other than -1: a negative one is none, as
        Rover's uint16_t index past the table) or by name (-1) (PARAM_REQUEST_READ).

        Parameters
        ----------
        m : pymavlink message
            The PARAM_REQUEST_READ.
        """
        names = list(self.params)
        if m.param_index != -1:
            if 0 <= m.param_index < len(names):
                self._send(self.value_message(names[m.param_index]))
            else:
                self._warn(f"No parameter at index {m.param_index} (there are {len(names)})")
            return
        name = self.name_of(m.param_id)
        if name is not None:
            self._send(self.value_message(name, indexed=False, said=param_text(m.param_id)))
        else:
            self._warn(f"Unknown parameter {param_text(m.param_id)}")

    def set(self, m: Any) -> str | None:
        """Store a PARAM_SET's value if the parameter takes it, and answer with the value in
        force; returns the parameter's name when the value was stored. The answer names the
        parameter by its name, but a read-only one's (refused, as Rover's
        ``handle_param_set``) by the set's own spelling, as its line of text does.

        Parameters
        ----------
        m : pymavlink message
            The PARAM_SET.
        """
        said = param_text(m.param_id)
        name = self.name_of(said)
        if name is None:
            self._warn(f"Unknown parameter {said}")
            return None
        refused = self.set_value(name, m.param_value, said=said)
        readonly = self.params[name].readonly
        self._send(self.value_message(name, indexed=False, said=said if readonly else None))
        return name if refused is None else None

    def set_value(self, name: str, value: float, quiet: bool = False, said: str | None = None) -> str | None:
        """Store ``value`` in the parameter ``name`` if it takes it (:meth:`Param.accepts`);
        returns None when stored, else why not, which is also said in a line of text unless
        ``quiet``.

        Parameters
        ----------
        name : str
            A parameter of the table.
        value : float
            The value asked for.
        quiet : bool
            Do not say a refusal (the caller says them together).
        said : str, optional
            The name as a PARAM_SET spelled it: a read-only parameter's refusal names it so,
            as Rover's does.
        """
        p = self.params[name]
        if p.accepts(value):
            p.value = p.stored(value)
            return None
        if p.readonly:
            why = f"Param write denied ({said or name})"  # ArduPilot's text, its key as asked
        else:
            why = f"{name} rejected: {value:g} outside {p.lo:g}..{p.hi:g} {p.unit}".rstrip()
        if not quiet:
            if p.readonly:
                self._say(why, mav.MAV_SEVERITY_WARNING)  # (as often as a Rover says it)
            else:
                self._warn(why)
        return why

    def _warn(self, text: str) -> None:
        """Say a warning of lfctl's own, unless the same was said to the same asker within
        :data:`REPEAT_S`."""
        now = time.monotonic()
        key = (self._asker() if self._asker is not None else None, text)
        if now - self._said.get(key, -math.inf) < REPEAT_S:
            return
        if len(self._said) >= 64:  # (names a peer makes up: only the recent ones matter)
            self._said = {k: at for k, at in self._said.items() if now - at < REPEAT_S}
            if len(self._said) >= 1024:  # a flood of them: bounded, each said again
                self._said.clear()
        self._said[key] = now
        self._say(text, mav.MAV_SEVERITY_WARNING)

    def packed(self, query: str = "") -> bytes:
        """``@PARAM/param.pck`` now, for a file read over MAVLink FTP, with the options a
        ground station adds to the name (``?withdefaults=1&start=N&count=C``, as ArduPilot's).

        Parameters
        ----------
        query : str
            What follows the ``?`` in the name asked for (``""``: none).

        Raises
        ------
        ValueError
            An option ArduPilot refuses at the open (its value named): start or count past
            65534, withdefaults other than 0 or 1.
        ReadFails
            start at or past the number of parameters: ArduPilot's open takes it and its read
            of the header fails, EINVAL (``AP_Filesystem_Param::read``); the size the open
            gives is its stat's, 12 bytes a parameter.
        """
        opts = {"start": 0, "count": 0, "withdefaults": 0}
        # as AP_Filesystem_Param::open: the options are looked for at every character, what
        # is not one is skipped, and a value is strtoul's (its leading digits; none: 0)
        for i in range(len(query)):
            for key in opts:
                if query.startswith(f"{key}=", i):
                    digits = re.match(r"\d*", query[i + len(key) + 1 :])
                    opts[key] = int(digits.group()) if digits and digits.group() else 0
                    if opts[key] > (1 if key == "withdefaults" else 0xFFFE):
                        raise ValueError(f"param.pck option {key}={opts[key]} out of range")
        if opts["start"] >= len(self.params):
            raise ReadFails(
                f"param.pck start={opts['start']}: there are {len(self.params)} parameters",
                errno.EINVAL,
                until=_PACKED_HEADER.size,
                size=12 * len(self.params),
            )
        defaults = self.defaults if opts["withdefaults"] else None
        return pack_params(self.params, defaults, opts["start"], opts["count"])

    def ftp_file(self, on_open: Callable[[], None] | None = None) -> FtpFile:
        """The table as MAVLink FTP's ``@PARAM/param.pck``: read with its options
        (:meth:`packed`), written back (:meth:`upload`).

        Parameters
        ----------
        on_open : callable, optional
            Called when the file is opened for reading.
        """
        return FtpFile(self.packed, lambda data, _sysid, _compid: self.upload(data), options=True, on_open=on_open)

    def upload(self, data: bytes) -> str | None:
        """Set the parameters an uploaded ``@PARAM/param.pck`` names, each as a PARAM_SET
        would (out of range or read-only: not set), its name found as :meth:`name_of` finds
        it; a name the table lacks is skipped, as ArduPilot skips it. What was set and what
        was not is said in one line of text (a file may name thousands). Returns None when
        the file was read whole, else why it could not be: a damaged header sets nothing, a
        damaged parameter stops the reading there, those before it set (as ArduPilot's
        param_upload_parse sets each as it reads).

        Parameters
        ----------
        data : bytes
            The file.
        """
        values: list[tuple[str, float]] = []
        try:
            _read_params(data, values)
        except ValueError as exc:
            if not values:
                return f"param.pck not read: {exc}"
            self._set_all(values)
            return f"param.pck read up to {exc}"
        self._set_all(values)
        return None

    def _set_all(self, values: list[tuple[str, float]]) -> None:
        """Set an upload's (name, value) pairs, and say in one line what was and was not."""
        refused: dict[str, str] = {}  # by name: a file may name one many times
        unknown: dict[str, None] = {}
        taken = 0
        for named, value in values:
            name = self.name_of(named)  # (param_upload_parse finds each with AP_Param::find)
            if name is None:
                unknown[param_text(named)] = None
            elif self.set_value(name, value, quiet=True) is not None:
                refused[name] = "read-only" if self.params[name].readonly else f"{value:g}"
            else:
                taken += 1
        line = f"Param upload: {taken} of {len(values)} set"
        if refused:
            line += "; refused " + ", ".join(f"{n} ({w})" for n, w in refused.items())
        if unknown:
            line += "; no such parameter " + ", ".join(unknown)
        self._say(line, mav.MAV_SEVERITY_WARNING if refused or unknown else mav.MAV_SEVERITY_INFO)
