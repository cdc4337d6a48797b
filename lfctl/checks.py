"""Checks every input from a user's hands goes through: numbers, names, ports, paths, files.

Scenario files (:mod:`lfctl.config`), mission and parameter files (:mod:`lfctl.link`) and
command-line options (:mod:`lfctl.cli`) use these, so one rule gives one message everywhere:
:class:`~lfctl.errors.ConfigError` naming the key, the value and what was expected, which
the command line turns into exit code 2.
"""

from __future__ import annotations

import contextlib
import errno
import math
import os
import re
import secrets
import stat
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from lfctl.errors import ConfigError

__all__ = [
    "NAME_PATTERN",
    "Bound",
    "check_connection",
    "check_host_port",
    "check_inside",
    "check_name",
    "check_port",
    "check_text",
    "printable",
    "read_text_file",
    "save_text",
    "target_mode",
    "write_whole",
]

#: names that become parts of file names, MAVLink names and MCAP topics: letters, digits, -, _
NAME_PATTERN = re.compile(r"[A-Za-z0-9_-]{1,64}")


def _show(value: object) -> str:
    """A value for an error message: repr, cut to 60 characters."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _num(value: float, integer: bool) -> str:
    """A range end as people write it: 0.0001, 1e6, 65535."""
    if integer:
        return str(int(value))
    return f"{value:g}".replace("e+0", "e").replace("e+", "e")


@dataclass(frozen=True)
class Bound:
    """A closed or open interval a number must lie in; NaN and infinities never do.

    Parameters
    ----------
    lo, hi : float
        The ends; ``-inf`` / ``inf`` for "any finite number" on that side.
    lo_open, hi_open : bool
        True when the end itself is excluded.
    integer : bool
        The number must be a whole number (an int; bool is refused).
    """

    lo: float
    hi: float
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False

    def text(self) -> str:
        """The interval as the error messages and the reference write it: ``within (0, 1]``."""
        lo, hi = _num(self.lo, self.integer), _num(self.hi, self.integer)
        if math.isinf(self.lo) and math.isinf(self.hi):
            return "a whole number" if self.integer else "a finite number"
        if math.isinf(self.hi):
            return f"{'>' if self.lo_open else '>='} {lo}" + (", whole" if self.integer else "")
        if math.isinf(self.lo):
            return f"{'<' if self.hi_open else '<='} {hi}" + (", whole" if self.integer else "")
        if self.integer:
            return f"within {lo}..{hi}"
        return f"within {'(' if self.lo_open else '['}{lo}, {hi}{')' if self.hi_open else ']'}"

    def contains(self, value: float) -> bool:
        """True when ``value`` is a finite number inside the interval."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return False
        if self.integer and not isinstance(value, int):
            return False
        if isinstance(value, float) and not math.isfinite(value):  # (an int of any size is finite)
            return False
        above = value > self.lo if self.lo_open else value >= self.lo
        below = value < self.hi if self.hi_open else value <= self.hi
        return above and below

    def check(self, key: str, value: float, unit: str = "") -> float:
        """``value`` when it is inside; else :class:`ConfigError` naming ``key``, the value and the range.

        Parameters
        ----------
        key : str
            What the value is (a dotted scenario key or an option such as ``--rate``).
        value : float
            The number given.
        unit : str
            Appended to the range in the message (``Hz``, ``m``).
        """
        if not self.contains(value):
            what = "an integer " if self.integer and not isinstance(value, int) else ""
            raise ConfigError(f"{key} must be {what}{self.text()}{' ' + unit if unit else ''}, got {_show(value)}")
        return value


def check_name(key: str, value: object) -> str:
    """A name that may become part of a file name or a topic: 1-64 of letters, digits, ``-``, ``_``.

    Parameters
    ----------
    key : str
        What it names (for the message).
    value : object
        The name given.
    """
    if not isinstance(value, str) or not NAME_PATTERN.fullmatch(value):
        raise ConfigError(f"{key} must be 1-64 letters, digits, '-' or '_', got {_show(value)}")
    return value


def check_text(key: str, value: object, max_len: int = 256) -> str:
    """Free text kept or shown as given: printable, no control characters, at most ``max_len``.

    Parameters
    ----------
    key : str
        What it is (for the message).
    value : object
        The text given.
    max_len : int
        The longest accepted.
    """
    if not isinstance(value, str):
        raise ConfigError(f"{key} must be a string, got {_show(value)}")
    if len(value) > max_len:
        raise ConfigError(f"{key} must be at most {max_len} characters, got {len(value)}")
    if any(not ch.isprintable() for ch in value):
        raise ConfigError(f"{key} must not hold control characters, got {_show(value)}")
    return value


PORT = Bound(1, 65535, integer=True)


def printable(text: str, keep: str = "") -> str:
    """``text`` safe to show on a terminal: control characters (an escape sequence's ESC
    among them, but those in ``keep``) and lone surrogates written as Python escapes.

    Parameters
    ----------
    text : str
        Text from elsewhere (a file, a peer).
    keep : str
        Characters to leave as they are (``"\n"``).
    """
    text = text.encode("utf-8", "backslashreplace").decode("utf-8")
    return "".join(ch if ch in keep or ch.isprintable() else repr(ch)[1:-1] for ch in text)


def check_port(key: str, value: object) -> int:
    """A UDP/TCP port, 1..65535.

    Parameters
    ----------
    key : str
        What it is (for the message).
    value : object
        The port given.
    """
    return int(PORT.check(key, value))  # type: ignore[arg-type]


def check_host_port(key: str, value: str, *, allow_any_port: bool = False) -> tuple[str, int]:
    """``HOST:PORT`` split and checked: a host of letters, digits, ``.``, ``-``, ``:`` (IPv6 in
    brackets) and a port within 1..65535 (0..65535 with ``allow_any_port``: 0 asks a server
    for a free port).

    Parameters
    ----------
    key : str
        What it is (for the message).
    value : str
        The text given.
    allow_any_port : bool
        Accept port 0.
    """
    host, sep, port = value.rpartition(":")
    if not sep or not host or not (port.isascii() and port.isdigit()) or len(port) > 5:
        raise ConfigError(f"{key} must be HOST:PORT, got {_show(value)}")
    bare = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    if not re.fullmatch(r"[A-Za-z0-9.:_-]{1,253}", bare):
        raise ConfigError(f"{key}: host must be a name or an address, got {_show(host)}")
    lowest = 0 if allow_any_port else 1
    if not lowest <= int(port) <= 65535:
        raise ConfigError(f"{key} must be HOST:PORT with a port within {lowest}..65535, got {_show(value)}")
    return host, int(port)


#: pymavlink connection prefixes taking HOST:PORT
NET_PREFIXES = ("udpin", "udpout", "udp", "udpbcast", "tcp", "tcpin")


#: a serial device's baud, bits/s (``/dev/ttyAMA0,921600``)
SERIAL_BAUD = Bound(50, 20_000_000, integer=True)


def check_connection(key: str, value: str) -> str:
    """A pymavlink connection string: ``udpin:HOST:PORT``, ``udpout:...``, ``tcp:...``,
    ``tcpin:...``, or a serial device ``/dev/tty...[,BAUD]``.

    Parameters
    ----------
    key : str
        The option (for the message).
    value : str
        The connection given.
    """
    check_text(key, value)
    prefix, sep, rest = value.partition(":")
    if sep and prefix in NET_PREFIXES:
        check_host_port(key, rest)
        return value
    device, comma, baud = value.partition(",")
    if device.startswith(("/dev/", "COM")) and "," not in baud:
        if not comma or SERIAL_BAUD.contains(_int(baud)):
            return value
        # (pymavlink took "/dev/ttyS0," and failed on int(''); "0" and "1e9" read as a bad device)
        raise ConfigError(f"{key} must have a baud {SERIAL_BAUD.text()} after the comma, got {_show(value)}")
    raise ConfigError(
        f"{key} must be udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT or a serial "
        f"device such as /dev/ttyUSB0,921600, got {_show(value)}"
    )


def _int(text: str) -> int | None:
    return int(text) if text.isascii() and text.isdigit() and len(text) <= 9 else None


def check_inside(key: str, base: Path, path: Path) -> Path:
    """``path`` resolved (symbolic links followed), when it lies inside ``base``; else
    :class:`ConfigError`.

    Parameters
    ----------
    key : str
        What the path is (for the message).
    base : Path
        The folder it must stay in.
    path : Path
        Relative to ``base`` or absolute.
    """
    if "\x00" in str(path):
        raise ConfigError(f"{key} must not hold a NUL character, got {_show(str(path))}")
    root = base.resolve()
    full = (root / path).resolve()
    if not full.is_relative_to(root):
        raise ConfigError(f"{key} must stay inside {root}, got {_show(str(path))} (resolves to {full})")
    return full


def read_text_file(path: Path, what: str, max_bytes: int) -> str:
    """A regular file's UTF-8 text, refusing FIFOs, devices, folders and files over ``max_bytes``
    before reading them.

    Parameters
    ----------
    path : Path
        The file.
    what : str
        What it should be (``scenario``, ``mission``) for the message.
    max_bytes : int
        The largest size read.
    """
    if "\x00" in str(path):
        raise ConfigError(f"cannot read {what} {_show(str(path))}: the name holds a NUL character")
    try:
        st = os.stat(path)
    except OSError as exc:
        raise ConfigError(f"cannot read {what} {path}: {exc.strerror or exc}") from exc
    if not stat.S_ISREG(st.st_mode):
        kind = "a folder" if stat.S_ISDIR(st.st_mode) else "not a regular file (a FIFO, socket or device)"
        raise ConfigError(f"cannot read {what} {path}: it is {kind}")
    if st.st_size > max_bytes:
        raise ConfigError(f"{what} {path} is {st.st_size} bytes; the limit is {max_bytes}")
    try:
        with open(path, "rb") as f:
            data = f.read(max_bytes + 1)
    except OSError as exc:
        raise ConfigError(f"cannot read {what} {path}: {exc.strerror or exc}") from exc
    if len(data) > max_bytes:  # it grew since the stat
        raise ConfigError(f"{what} {path} is over the limit of {max_bytes} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"cannot read {what} {path}: not UTF-8 text (byte {exc.start})") from exc


@contextlib.contextmanager
def write_whole(path: Path) -> Iterator[Path]:
    """A new file beside ``path`` for the block to write; when the block ends it replaces
    ``path`` in one step (``os.replace``), so a reader, or a run stopped mid-write, finds the
    old file or the new one, never part of one. On an exception the new file is removed and
    ``path`` is left as it was. The new file is hidden (``.<stem>.<pid>.<random>.partial<suffix>``:
    the suffix kept for writers that go by it) and made by this call alone (``O_EXCL``).

    Parameters
    ----------
    path : Path
        The file to write.
    """
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.{secrets.token_hex(4)}.partial{path.suffix}")
    try:
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
    except OSError as exc:  # named as the file asked for, not the hidden one beside it
        raise type(exc)(exc.errno, f"cannot write {path} ({exc.strerror})") from None
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def target_mode(path: Path) -> int | None:
    """The mode of the file a path to be written leads to (through links), None when there
    is none yet; a ConfigError naming it when it cannot be looked at.

    Parameters
    ----------
    path : Path
        The file.
    """
    try:
        return os.stat(path).st_mode
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise ConfigError(f"cannot write {path}: {exc.strerror or exc}") from None


def save_text(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to a file the user named, as a user expects it written.

    A regular file (or a new one) is replaced whole (:func:`write_whole`), through a link to
    it; a device (``/dev/null``, a terminal) or a pipe that someone reads (``/dev/stdout`` on
    a pipe) is written as it is. A folder, and a named pipe no one reads (the write would
    block for ever), are a ConfigError naming the path.

    Parameters
    ----------
    path : str or Path
        The file.
    text : str
        What to write.
    """
    p = Path(path)
    mode = target_mode(p)
    if mode is None or stat.S_ISREG(mode):
        with write_whole(p.resolve()) as tmp:
            tmp.write_text(text, encoding="utf-8")
        return
    if stat.S_ISDIR(mode):
        raise ConfigError(f"{p} is a folder: give a file to write to")
    try:  # a pipe with no reader: ENXIO at once, rather than a write that never ends
        fd = os.open(p, os.O_WRONLY | (os.O_NONBLOCK if stat.S_ISFIFO(mode) else 0))
    except OSError as exc:
        why = "a named pipe no one reads" if exc.errno == errno.ENXIO else (exc.strerror or str(exc))
        raise ConfigError(f"cannot write {p}: {why}") from None
    try:
        with os.fdopen(fd, "wb") as f:
            os.set_blocking(fd, True)
            f.write(text.encode("utf-8"))
    except OSError as exc:  # a full device (/dev/full), a reader gone: named, as a bad path is
        raise ConfigError(f"cannot write {p}: {exc.strerror or exc}") from None
