"""One MAVLink identity (system, component) sending and receiving messages, over a pymavlink
connection (UDP, TCP, serial: what a real rover or ground station uses) or over an in-memory
link (the lockstep simulation). The ground station and the companion both talk through it,
so their protocol code does not care which."""

from __future__ import annotations

import contextlib
import errno
import io
import logging
import os
import re
import select
import socket
import time
from collections import deque
from collections.abc import Callable, Collection
from typing import Any, Protocol

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.checks import NET_PREFIXES, check_host_port
from lfctl.errors import ConfigError, LfctlError, LinkError
from lfctl.link.signing import setup_signing

__all__ = ["CHECK_LINK", "STATUSTEXT_MAX_BYTES", "DatagramLink", "MavPort", "pack_next", "statustext_messages"]

#: the packets a port remembers having sent, to know them if they come back
SENT_REMEMBERED = 64
#: the longest line of text sent (in 50-byte STATUSTEXT chunks), bytes
STATUSTEXT_MAX_BYTES = 200

log = logging.getLogger(__name__)

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

    def send(self, data: bytes, exclude: Collection[tuple[str, int]] = ()) -> Any:
        """Send one datagram.

        Parameters
        ----------
        data : bytes
            One packed MAVLink packet.
        exclude : collection of (host, port), optional
            Network peers not to send it to (a link in memory has none).
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


def _open_error(connect: str, exc: BaseException) -> LfctlError:
    """What a failed open says: a file that is no terminal (``/dev/null``, where pyserial's
    words are "Inappropriate ioctl for device") is the connection string's error (exit 2), a
    device the user may not open names the ``dialout`` group; else the words as they came."""
    codes = set()
    seen: BaseException | None = exc
    while seen is not None and len(codes) < 8:  # (the exception and what it was raised from)
        code = getattr(seen, "errno", None)
        code = (
            code if isinstance(code, int) else (seen.args[0] if seen.args and isinstance(seen.args[0], int) else None)
        )
        codes.add(code)
        seen = seen.__cause__ or seen.__context__
    device = connect.partition(",")[0]
    if errno.ENOTTY in codes:
        return ConfigError(f"--mavlink {connect!r}: {device} is not a serial port (no terminal device: {exc})")
    if errno.EACCES in codes:
        return LinkError(
            connect,
            f"{exc} (a serial port belongs to the dialout group on Debian and Ubuntu: "
            "sudo usermod -aG dialout $USER, then log in again)",
        )
    return LinkError(connect, str(exc))


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


#: the most datagrams, and the longest time, one :meth:`MavPort.recv` reads looking for a
#: message before it gives its caller back control (a flood of junk does not hold the caller)
MAX_DATAGRAMS_PER_RECV = 256
MAX_RECV_S = 0.02
#: a serial device that went away is tried again this often, s
REOPEN_S = 1.0
#: the longest a write to a serial device waits for room in its buffer, s (a UART drains it
#: at its baud; a USB device that stopped reading never does)
SERIAL_WRITE_WAIT_S = 0.25
#: a datagram longer than this is junk, not parsed (a vehicle's are at most a few MAVLink
#: packets; pymavlink parses byte by byte: 64 KB of junk cost it 40 ms)
MAX_DATAGRAM_BYTES = 8 * 1024
#: MAVLink's start bytes (2, 1): a datagram is parsed from the first of them
_STARTS = (b"\xfd", b"\xfe")
#: the most peers a ``udpin`` port answers at once (each that sent a good packet, the latest
#: kept: pymavlink's own list grows with every sender)
MAX_UDP_CLIENTS = 8


def _reset_parser(parser: Any) -> None:
    """Forget what a MAVLink parser holds of an unfinished packet: a datagram carries whole
    packets, so a cut one must not swallow the next datagram's."""
    parser.buf = bytearray()
    parser.buf_index = 0
    parser.expected_length = mav.HEADER_LEN_V1 + 2
    parser.have_prefix_error = False


def _lean_post_message(m: Any) -> None:
    """What pymavlink's ``mavfile.post_message`` does that lfctl needs (the time it came).
    Its own keeps the last message of every type name, every parameter and every sender:
    a peer sending new message ids or names would grow them without bound."""
    m._timestamp = time.time()


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
    junk : int
        Received bytes that were no MAVLink packet (a cut or corrupt frame, noise), and
        packets of message ids the dialect lacks: dropped, counted here (the latter still
        shown to :attr:`tap`, as they travelled).
    received, lost : int
        Good packets received, and those missing from each sender's sequence numbers.

    Over UDP each datagram is read on its own (a cut packet at its end is junk, not the
    start of the next datagram's), and what pymavlink would keep of every message is not kept.
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
        self.junk = 0
        #: the connection's peer closed it (a TCP link's end of file or reset): nothing more
        #: will come (said once in the log)
        self.closed = False
        self.received = 0
        self.lost = 0
        self._seq: dict[tuple[int, int], int] = {}
        self._udp = False
        #: a serial device that went away is opened again this often until it is back (a
        #: flight controller on USB that reboots leaves and comes back as a new device)
        self._serial = connection is not None and isinstance(connection, mavutil.mavserial)
        self._reopen_at = 0.0
        #: writes to a serial device that took no bytes for :data:`SERIAL_WRITE_WAIT_S`, in a row
        self.stalled = 0
        #: the unsent rest of a packet a stalled write began: sent before the next one, so the
        #: line never carries half a packet (the rover would read the next one's bytes as its rest)
        self._tail = b""
        if connection is not None:
            self.mav = connection.mav
            self.mav.robust_parsing = True
            connection.post_message = _lean_post_message
            self._udp = isinstance(connection, mavutil.mavudp)
            # pymavlink prints "EOF on TCP socket" and tries again on every read once the peer
            # has closed (150,000 lines a second): the port notes it once and reads no more
            connection.handle_eof = connection.handle_disconnect = self._peer_closed
            if self._serial:  # (pymavlink's own write prints "Device ... is dead" on stdout)
                connection.write = self._serial_write
        else:
            self.mav = mav.MAVLink(None, srcSystem=sysid, srcComponent=compid)
            self.mav.robust_parsing = True
            self._parser = mav.MAVLink(None)
            self._parser.robust_parsing = True
        self._queue: deque[Any] = deque()
        self.tap: Callable[[str, Any, bytes], None] | None = None
        #: the packets sent lately (the companion's and a camera's): one heard back is an echo
        self._sent: deque[bytes] = deque(maxlen=SENT_REMEMBERED)

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
        # pymavlink prints each refused TCP connect ("[Errno 111] Connection refused sleeping") to
        # stdout, where `gcs watch` writes its JSON: kept off it, in lfctl's log (--debug)
        chatter = io.StringIO()
        try:
            with contextlib.redirect_stdout(chatter) if connect.startswith("tcp:") else contextlib.nullcontext():
                conn = mavutil.mavlink_connection(
                    connect, source_system=sysid, source_component=compid, dialect="ardupilotmega", autoreconnect=False
                )
        except Exception as exc:  # pymavlink raises plain exceptions for bad strings and ports
            raise _open_error(connect, exc) from exc
        finally:
            for line in chatter.getvalue().splitlines():
                log.debug("%s: pymavlink: %s", connect, line)
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

    @property
    def serial(self) -> bool:
        """Whether the port is a serial device's."""
        return self._serial

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
        self._sent.append(data)
        if self.tap is not None:
            self.tap("out", msg, data)

    def write(self, data: bytes) -> None:
        """Put one packet another component of this program packed (its own ids, sequence
        number and signature: a camera beside the companion) on the link as it is.

        Parameters
        ----------
        data : bytes
            The packed packet.
        """
        if self.connection is not None:
            self.connection.write(data)
        else:
            assert self.link is not None
            self.link.send(data)
        self._sent.append(bytes(data))

    def echo(self, m: Any) -> bool:
        """Whether a received message is one this port sent lately, heard back: a relay that
        loops a link's traffic into it (neither a Rover nor mavlink-router sends a packet back
        where it came from; a misconfigured MAVProxy ``--out`` can).

        Parameters
        ----------
        m : pymavlink message
            A message this port received.
        """
        return bool(self._sent) and bytes(m.get_msgbuf()) in self._sent

    def recv(self, timeout_s: float = 0.0) -> Any | None:
        """The next message received, waiting up to ``timeout_s`` (in memory: none after a
        pump of the other end), or None.

        Parameters
        ----------
        timeout_s : float
            Longest wait, s; 0 returns at once.
        """
        if self._queue:
            m = self._queue.popleft()
        elif self._udp:
            m = self._recv_udp(timeout_s)
        elif self.connection is not None:
            m = self._recv_stream(timeout_s)
        else:
            if self.pump is not None:
                self.pump()
            assert self.link is not None
            for data, _addr in self.link.recv():
                self._take_datagram(data, self._parser)
            m = self._queue.popleft() if self._queue else None
        if m is not None and self.tap is not None:
            self.tap("in", m, bytes(m.get_msgbuf()))
        return m

    def _good(self, m: Any) -> bool:
        """A message of the dialect (not junk the parser framed, nor an id it lacks); the rest
        counted in :attr:`junk`. The good ones are counted in :attr:`received`, and the gaps
        in each sender's sequence numbers in :attr:`lost` (as a ground station counts link loss)."""
        kind = m.get_type()
        if kind == "BAD_DATA" or kind.startswith("UNKNOWN_"):
            self.junk += 1
            if kind != "BAD_DATA" and self.tap is not None:
                self.tap("in", m, bytes(m.get_msgbuf()))  # framed: a log keeps it, the caller never sees it
            return False
        self.received += 1
        src = (m.get_srcSystem(), m.get_srcComponent())
        last = self._seq.get(src)
        if last is not None:
            self.lost += (m.get_seq() - last - 1) % 256
        elif len(self._seq) >= 256:  # (a crowd of senders: forget them, not the count)
            self._seq.clear()
        self._seq[src] = m.get_seq()
        return True

    def _peer_closed(self) -> None:
        if self.closed:
            return
        self.closed = True
        if self._serial:
            self._reopen_at = time.monotonic() + REOPEN_S
            # closed at once: Linux gives a USB device that comes back its old name
            # (/dev/ttyACM0) only once nobody holds the old one open
            with contextlib.suppress(OSError):
                self.connection.port.close()
            log.warning(
                "MAVLink serial device %s went away (a flight controller on USB that reboots, or unplugged): "
                "opened again when it is back",
                self.connection.device,
            )
        else:
            log.warning("MAVLink link closed by its peer (end of file): nothing more comes on it")

    def _serial_write(self, buf: bytes) -> int:
        """A write to the serial device, waiting up to :data:`SERIAL_WRITE_WAIT_S` for room;
        one that fails (the device went away) is noted as a read's failure is, not printed,
        and the bytes are lost. A device that takes no bytes in that time (a flight controller
        on USB that stopped reading) keeps the rest of a packet it began for the next write
        (half a packet would cost the next one too), loses those it did not begin, and the
        writes after it wait no more, until it takes a whole one again (said once): pyserial's
        own write waited for it for ever, and then Ctrl-C's last zero setpoints too."""
        if self.closed:
            return -1
        data = self._tail + bytes(buf)
        begun = len(self._tail)
        give_up = time.monotonic() + (0.0 if self.stalled else SERIAL_WRITE_WAIT_S)  # (stalled: no wait)
        try:
            fd = self.connection.port.fileno()
            while data:
                with contextlib.suppress(BlockingIOError):
                    data = data[os.write(fd, data) :]
                left = give_up - time.monotonic()
                if data and (left <= 0 or not select.select([], [fd], [], left)[1]):
                    self.stalled += 1
                    if self.stalled == 1:
                        log.warning(
                            "MAVLink serial device %s takes no bytes (a flight controller on USB that stopped "
                            "reading it?): what is sent is lost until it does",
                            self.connection.device,
                        )
                    # the rest of the packet begun goes first next time; one not begun is lost whole
                    sent = begun + len(buf) - len(data)
                    self._tail = data if sent > begun else data[: begun - sent]
                    return max(0, sent - begun)
        except (OSError, ValueError):
            self._tail = b""
            self._peer_closed()
            return -1
        self._tail = b""
        self.stalled = 0
        return len(buf)

    def _reopen(self) -> None:
        """Open a serial device that went away again, if it is back (tried every
        :data:`REOPEN_S`)."""
        import serial  # (pyserial: pymavlink's serial connections use it)

        conn = self.connection
        self._reopen_at = time.monotonic() + REOPEN_S
        try:
            port = serial.Serial(conn.device, conn.baud, timeout=0, dsrdtr=False, rtscts=False, xonxoff=False)
        except (OSError, ValueError):  # not back yet
            return
        conn.port, conn.fd, conn.portdead = port, port.fileno(), False
        self.closed, self._tail = False, b""  # (a device that came back has no packet begun)
        log.warning("MAVLink serial device %s is back: reading it again", conn.device)

    def _recv_stream(self, timeout_s: float) -> Any | None:
        """The next message on a stream connection (serial, TCP: a packet may come in
        pieces), waiting up to ``timeout_s``; at most :data:`MAX_RECV_S` past that is spent
        on bytes that make no message. On a link its peer closed, none (after the wait)."""
        if self.closed and self._serial and time.monotonic() >= self._reopen_at:
            self._reopen()
        if self.closed:
            time.sleep(max(0.0, timeout_s))
            return None
        conn = self.connection
        deadline = time.monotonic() + timeout_s
        give_up = deadline + MAX_RECV_S
        while True:
            try:
                m = conn.recv_msg()
            except OSError:  # (a reset: noted by _peer_closed before pymavlink raises it)
                self._peer_closed()
                m = None
            if self.closed:
                return None
            if m is not None and self._good(m):
                return m
            now = time.monotonic()
            if now >= give_up or (m is None and now >= deadline):
                return None
            if m is None:
                conn.select(min(0.05, max(0.0, deadline - now)))

    def _take_datagram(self, data: bytes, parser: Any) -> int:
        """The messages of one datagram into the queue, read on their own, from its first
        start byte; how many."""
        starts = [i for i in (data.find(b) for b in _STARTS) if i >= 0]
        if len(data) > MAX_DATAGRAM_BYTES or not starts:
            self.junk += 1
            return 0
        if min(starts):
            self.junk += 1  # (bytes before the first packet)
            data = data[min(starts) :]
        _reset_parser(parser)
        got = [m for m in (parser.parse_buffer(data) or []) if self._good(m)]
        if len(parser.buf) > parser.buf_index:  # a packet cut short at the datagram's end
            self.junk += 1
        _reset_parser(parser)
        self._queue.extend(got)
        return len(got)

    def _recv_udp(self, timeout_s: float) -> Any | None:
        """The next message over UDP: datagrams are read one at a time, each on its own, up
        to :data:`MAX_DATAGRAMS_PER_RECV` while they hold none, waiting up to ``timeout_s``
        for the first. A ``udpin`` port answers the senders of good packets (the latest
        :data:`MAX_UDP_CLIENTS`); a ``udpbcast`` one the last of them."""
        conn = self.connection
        deadline = time.monotonic() + timeout_s
        give_up = deadline + MAX_RECV_S
        for _ in range(MAX_DATAGRAMS_PER_RECV):
            now = time.monotonic()
            if now >= give_up:
                return None
            wait = max(0.0, deadline - now)
            try:
                ready, _, _ = select.select([conn.port], [], [], wait)
                if not ready:
                    return None
                data, addr = conn.port.recvfrom(65535)
            except (OSError, ValueError):  # ICMP port unreachable (no peer yet), a closed socket
                if wait <= 0:
                    return None
                continue
            if self._take_datagram(data, conn.mav):
                self._heard_from(addr)
                return self._queue.popleft()
        return None

    def _heard_from(self, addr: tuple[str, int]) -> None:
        conn = self.connection
        if conn.udp_server:
            conn.clients.add(addr)
            conn.clients_last_alive[addr] = time.time()
            while len(conn.clients) > MAX_UDP_CLIENTS:
                oldest = min(conn.clients, key=lambda a: conn.clients_last_alive.get(a, 0.0))
                conn.clients.discard(oldest)
                conn.clients_last_alive.pop(oldest, None)
        elif conn.broadcast:
            conn.last_address = addr

    def close(self) -> None:
        """Close the connection (an in-memory link is its owner's to close)."""
        if self.connection is not None:
            self.connection.close()
