"""One MAVLink identity (system, component) sending and receiving messages, over a pymavlink
connection (UDP, TCP, serial: what a real rover or ground station uses) or over an in-memory
link (the lockstep simulation). The ground station and the companion both talk through it,
so their protocol code does not care which."""

from __future__ import annotations

import os
import re
import socket
from collections import deque
from collections.abc import Callable
from typing import Any, Protocol

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.checks import NET_PREFIXES, check_host_port
from lfctl.errors import ConfigError, LinkError
from lfctl.link.signing import setup_signing

__all__ = ["CHECK_LINK", "STATUSTEXT_MAX_BYTES", "DatagramLink", "MavPort", "pack_next", "statustext_messages"]

#: the longest line of text sent (in 50-byte STATUSTEXT chunks), bytes
STATUSTEXT_MAX_BYTES = 200

#: what to check when a vehicle does not answer
CHECK_LINK = "is the vehicle up, the address right, and, if it signs its link, the passphrase the same?"


def statustext_messages(data: bytes, severity: int, text_id: int) -> list[Any]:
    """STATUSTEXT messages for one line of text: one when it fits in 50 bytes, else (MAVLink
    2, as ArduPilot sends a long text) 50-byte chunks sharing ``text_id``, a short chunk (an
    empty one if need be) ending it.

    Parameters
    ----------
    data : bytes
        The line, at most :data:`STATUSTEXT_MAX_BYTES` (longer is cut).
    severity : int
        MAV_SEVERITY.
    text_id : int
        The chunks' id (1-65535), new for each long line.
    """
    data = data[:STATUSTEXT_MAX_BYTES]
    if len(data) <= 50:
        return [mav.MAVLink_statustext_message(severity, data)]
    chunks = [data[k : k + 50] for k in range(0, len(data), 50)]
    if len(chunks[-1]) == 50:
        chunks.append(b"")
    return [mav.MAVLink_statustext_message(severity, chunk, text_id, seq) for seq, chunk in enumerate(chunks)]


class DatagramLink(Protocol):
    """What carries MAVLink bytes: ``send`` a datagram, ``recv`` the waiting ones."""

    def send(self, data: bytes) -> None:
        """Send one datagram.

        Parameters
        ----------
        data : bytes
            One packed MAVLink packet.
        """

    def recv(self, max_datagrams: int = ...) -> list[tuple[bytes, tuple[str, int]]]:
        """Every datagram waiting (with its sender's address), without blocking.

        Parameters
        ----------
        max_datagrams : int
            Return at most this many (the rest wait for the next call).
        """


def pack_next(msg: Any, m: Any) -> bytes:
    """``msg`` packed by the MAVLink object ``m``, which then moves to its next sequence
    number, as ``MAVLink.send`` does (``pack`` alone leaves it: every packet would carry the
    same seq, and a ground station counts all but one of them lost).

    Parameters
    ----------
    msg : pymavlink message
        The message to pack.
    m : pymavlink MAVLink object
        The sender's codec (system, component, sequence, signing).
    """
    data = msg.pack(m)
    m.seq = (m.seq + 1) % 256
    m.total_packets_sent += 1
    m.total_bytes_sent += len(data)
    return data


def _check_network_address(connect: str) -> None:
    """A network connection string's host and port, checked before pymavlink takes them: it
    takes ``udpout:999.1.1.1:14550`` and then drops every datagram it cannot send, so a
    mistyped address looked like a vehicle that never answers.

    Raises
    ------
    LinkError
        Not HOST:PORT with a port in 1..65535 (0 too where we listen), or a host that does
        not resolve to an address.
    """
    kind, sep, rest = connect.partition(":")
    if not (sep and kind in NET_PREFIXES):
        _check_serial_device(connect)
        return
    try:
        host, port = check_host_port("the address", rest, allow_any_port=kind in ("udp", "udpin", "tcpin"))
    except ConfigError as exc:
        raise LinkError(connect, str(exc)) from None
    try:
        socket.getaddrinfo(host.strip("[]"), port)
    except (OSError, UnicodeError) as exc:
        raise LinkError(connect, f"host {host!r} is not an address here ({exc})") from None


def _check_serial_device(connect: str) -> None:
    """LinkError for a string pymavlink would open as a serial port when there is no such
    device: it says only that it cannot import pyserial, or waits. Every other form it takes
    (its other prefixes, HOST:PORT, a log file) is left to it."""
    lowered = connect.lower()
    if lowered.startswith(_OTHER_PREFIXES) or lowered.endswith((".bin", ".px4log", ".log")):
        return
    device = connect if os.path.exists(connect) else connect.partition(",")[0]
    if ":" in device and device.rsplit(".", 1)[-1].lower() not in ("mavlink", "log", "raw", "tlog"):
        return  # HOST:PORT: pymavlink's legacy UDP form
    if os.path.exists(device) or re.fullmatch(r"(\\\\\.\\)?COM\d+", device, re.IGNORECASE):
        return
    raise LinkError(
        connect,
        f"no such serial device {device!r} here (unplugged, or a typo?), nor a log file; a network link is "
        "udpin:HOST:PORT, udpout:HOST:PORT, udp:, udpbcast:, tcp:HOST:PORT or tcpin:",
    )


#: pymavlink's connection prefixes besides the network ones lfctl checks (it opens each itself)
_OTHER_PREFIXES = ("uds:", "unix:", "wsserver:", "ws:", "wss:", "mcast:", "csv:")


class MavPort:
    """Send and receive MAVLink messages as ``sysid``/``compid``.

    Build one with :meth:`open` (a pymavlink connection string) or :meth:`memory` (an
    in-memory link and a ``pump`` that lets the other end run).

    Parameters
    ----------
    sysid, compid : int
        Who we are.
    connection : pymavlink connection, optional
        A ``mavutil`` connection to talk through; give it or ``link``, not both.
    link : DatagramLink, optional
        An in-memory link to talk through instead.
    pump : callable, optional
        With ``link``: called before reading, so the other end can answer.

    Attributes
    ----------
    tap : callable or None
        Sees every packet sent and received, as the vehicle endpoint's tap does:
        ``tap(direction, msg, raw)`` with ``"out"`` (sent by this port) or ``"in"``
        (received; garbage the parser could not frame is not shown), the pymavlink message
        and its bytes as they travelled. Called in the sender's or reader's thread: keep it
        cheap, and do not raise.
    """

    def __init__(
        self,
        sysid: int,
        compid: int,
        *,
        connection: Any = None,
        link: DatagramLink | None = None,
        pump: Callable[[], None] | None = None,
    ) -> None:
        if (connection is None) == (link is None):
            raise ValueError("MavPort needs a connection or a link, not both")
        self.sysid = sysid
        self.compid = compid
        self.connection = connection
        self.link = link
        self.pump = pump
        if connection is not None:
            self.mav = connection.mav
        else:
            self.mav = mav.MAVLink(None, srcSystem=sysid, srcComponent=compid)
            self.mav.robust_parsing = True
            self._parser = mav.MAVLink(None)
            self._parser.robust_parsing = True
        self._queue: deque[Any] = deque()
        self.tap: Callable[[str, Any, bytes], None] | None = None

    @staticmethod
    def open(connect: str, sysid: int, compid: int, signing_key: bytes | None = None) -> MavPort:
        """A port on a pymavlink connection string (``udpout:HOST:PORT``, ``udpin:...``,
        ``tcp:...``, ``/dev/ttyUSB0,921600``), signing with ``signing_key`` when given.

        Parameters
        ----------
        connect : str
            The pymavlink connection string.
        sysid, compid : int
            Who we are.
        signing_key : bytes, optional
            MAVLink 2 signing key (see :mod:`lfctl.link.signing`).

        Raises
        ------
        LinkError
            The connection could not be opened (bad string, port in use, no such device).
        """
        _check_network_address(connect)
        # MAVLink 2 from the first packet: mavutil otherwise starts in MAVLink 1 and, on the first
        # MAVLink 2 packet it hears, replaces its parser, losing any signing set up on it
        os.environ["MAVLINK20"] = "1"
        try:
            conn = mavutil.mavlink_connection(
                connect, source_system=sysid, source_component=compid, dialect="ardupilotmega", autoreconnect=False
            )
        except Exception as exc:  # pymavlink raises plain exceptions for bad strings and ports
            raise LinkError(connect, str(exc)) from exc
        if signing_key is not None:
            setup_signing(conn.mav, signing_key)
        return MavPort(sysid, compid, connection=conn)

    @staticmethod
    def memory(link: DatagramLink, sysid: int, compid: int, pump: Callable[[], None] | None = None) -> MavPort:
        """A port on an in-memory link; ``pump`` runs the other end before each read.

        Parameters
        ----------
        link : DatagramLink
            Our end of the link.
        sysid, compid : int
            Who we are.
        pump : callable, optional
            Lets the other end handle what we sent and answer.
        """
        return MavPort(sysid, compid, link=link, pump=pump)

    def send(self, msg: Any) -> None:
        """Send one message (sequence number and signature as the codec says).

        Parameters
        ----------
        msg : pymavlink message
            The message, from our system and component.
        """
        if self.connection is not None:
            self.connection.mav.send(msg)
            data = bytes(msg.get_msgbuf())  # what pymavlink packed (and signed) for it
        else:
            assert self.link is not None
            data = pack_next(msg, self.mav)
            self.link.send(data)
        if self.tap is not None:
            self.tap("out", msg, data)

    def recv(self, timeout_s: float = 0.0) -> Any | None:
        """The next message received, waiting up to ``timeout_s`` (in memory: none after a
        pump of the other end), or None.

        Parameters
        ----------
        timeout_s : float
            Longest wait, s; 0 returns at once.
        """
        if self.connection is not None:
            m = self.connection.recv_match(blocking=timeout_s > 0, timeout=timeout_s if timeout_s > 0 else None)
        else:
            if not self._queue:
                if self.pump is not None:
                    self.pump()
                assert self.link is not None
                for data, _addr in self.link.recv():
                    self._queue.extend(m for m in (self._parser.parse_buffer(data) or []) if m.get_type() != "BAD_DATA")
            m = self._queue.popleft() if self._queue else None
        if m is not None and self.tap is not None and m.get_type() != "BAD_DATA":
            self.tap("in", m, bytes(m.get_msgbuf()))
        return m

    def close(self) -> None:
        """Close the connection (an in-memory link is its owner's to close)."""
        if self.connection is not None:
            self.connection.close()
