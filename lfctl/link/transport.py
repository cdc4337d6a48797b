"""Where MAVLink bytes travel: real UDP sockets (``--realtime``) or an in-memory link
(lockstep runs), behind one interface, so the codec and handlers are the same code."""

from __future__ import annotations

import errno
import logging
import random
import socket
import time
from collections import deque
from collections.abc import Callable, Collection

from lfctl.errors import LinkError

log = logging.getLogger(__name__)

__all__ = ["Address", "Fanout", "LossyLink", "MemoryLink", "UdpLink"]

#: a datagram's peer: (host, port); in memory ("memory", 0)
Address = tuple[str, int]
#: a ground station that has sent nothing valid for this long stops getting telemetry (but
#: the one heard last, which keeps it as a Rover's UDP port keeps the client it heard), s
PEER_TIMEOUT_S = 30.0
#: ground stations a vehicle talks to at once
MAX_PEERS = 16
#: with the table full, a new peer takes the place of the one heard from longest ago once
#: that one has been silent this long (a ground station in use sends its HEARTBEAT every
#: second; a one-shot `lfctl gcs` call that has exited never sends again), s
STALE_PEER_S = 5.0
#: a refused peer is logged at most once in this long (with the count since), s
REFUSAL_LOG_S = 10.0


class UdpLink:
    """``udpin`` socket plus optional ``udpout`` targets, with peers managed here.

    pymavlink's ``udpin`` replies to the last sender, so a stray datagram redirects the
    stream; this link replies only to peers that sent *valid* MAVLink (the endpoint says so
    with :meth:`accept_peer`), plus fixed ``udpout`` targets. A peer silent for
    :data:`PEER_TIMEOUT_S` is forgotten, but the one heard last: as a Rover's UDP port keeps
    sending to the client it heard, a script that sends one command and then only listens
    keeps its telemetry. When :data:`MAX_PEERS` are held, a new peer takes the place of the
    one heard from longest ago if that one has been silent for :data:`STALE_PEER_S` (one-shot
    `lfctl gcs` calls one after another, each from a new source port); when all are still
    talking, it is refused (counted, and logged at most every :data:`REFUSAL_LOG_S`), so a
    flood of new source ports cannot evict a ground station that is in use. The port is bound exclusively: a second program (or a second run)
    cannot share it.

    Parameters
    ----------
    bind : Address or None
        Where to listen (``udpin``); None: a free port on 127.0.0.1.
    outs : list of Address, optional
        Fixed ``udpout`` targets that get everything sent.
    clock : callable
        Seconds, monotonic (tests pass their own).

    Raises
    ------
    LinkError
        The port is in use or cannot be bound.
    """

    def __init__(
        self, bind: Address | None, outs: list[Address] | None = None, clock: Callable[[], float] = time.monotonic
    ) -> None:
        where = bind or ("127.0.0.1", 0)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            # a burst from a ground station (a 100-item mission, a parameter dump) must not overflow
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 * 1024 * 1024)
            self.sock.bind(where)  # no SO_REUSEADDR: nobody else may receive this vehicle's commands
        except (OSError, OverflowError) as exc:
            self.sock.close()
            reason = getattr(exc, "strerror", None) or str(exc)
            if isinstance(exc, OSError) and exc.errno == errno.EADDRINUSE:
                reason += " (another program, or another lfctl run, holds it)"
            raise LinkError(f"udpin:{where[0]}:{where[1]}", reason) from exc
        self.sock.setblocking(False)
        self.outs = list(outs or [])
        self.peers: dict[Address, float] = {}  # peer -> when it last sent valid MAVLink
        self.refused_peers = 0
        self._refusals_unlogged = 0
        self._refusal_logged_at: float | None = None
        self.tx_datagrams = 0
        self.rx_datagrams = 0
        self._clock = clock

    @property
    def port(self) -> int:
        """The UDP port it listens on."""
        return int(self.sock.getsockname()[1])

    def _forget_silent(self, now: float) -> None:
        for addr, heard in list(self.peers.items()):
            if now - heard > PEER_TIMEOUT_S:
                del self.peers[addr]

    def accept_peer(self, addr: Address) -> None:
        """A sender whose datagram parsed as MAVLink: reply to it from now on (while it keeps
        sending). With the table full, a new peer replaces the one heard from longest ago if
        that one has been silent for :data:`STALE_PEER_S`, and is refused otherwise.

        Parameters
        ----------
        addr : Address
            The sender, (host, port).
        """
        if addr in self.outs:
            return
        now = self._clock()
        if addr not in self.peers:
            self._forget_silent(now)
            if len(self.peers) >= MAX_PEERS:
                oldest = min(self.peers, key=self.peers.__getitem__)
                if now - self.peers[oldest] < STALE_PEER_S:
                    self._refuse(addr, now)
                    return
                del self.peers[oldest]
        self.peers[addr] = now

    def _refuse(self, addr: Address, now: float) -> None:
        self.refused_peers += 1
        self._refusals_unlogged += 1
        if self._refusal_logged_at is not None and now - self._refusal_logged_at < REFUSAL_LOG_S:
            return
        log.warning(
            "UDP port %d: refused %s new peer%s (latest %s:%d): all %d peers sent within %.0f s "
            "(a flood of source ports, or more ground stations than it serves at once)",
            self.port,
            self._refusals_unlogged,
            "" if self._refusals_unlogged == 1 else "s",
            addr[0],
            addr[1],
            MAX_PEERS,
            STALE_PEER_S,
        )
        self._refusal_logged_at = now
        self._refusals_unlogged = 0

    def send(self, data: bytes, exclude: Collection[Address] = ()) -> int:
        """Send to every ``udpout`` target and every peer heard lately (a refused send is
        skipped); returns the datagrams sent.

        Parameters
        ----------
        data : bytes
            One packed MAVLink packet.
        exclude : collection of Address, optional
            Not to these (the sender of a message passed on: MAVLink routing never sends a
            message back where it came from).
        """
        return sum(self._sendto(data, addr) for addr in self.reachable() if addr not in exclude)

    def send_to(self, data: bytes, addr: Address) -> None:
        """Send to one peer, if :meth:`send` would (a ``udpout`` target, a peer heard lately).

        Parameters
        ----------
        data : bytes
            One packed MAVLink packet.
        addr : Address
            The peer, (host, port).
        """
        if addr in self.reachable():
            self._sendto(data, addr)

    def reachable(self) -> list[Address]:
        """Where :meth:`send` sends: every ``udpout`` target and every peer heard within
        :data:`PEER_TIMEOUT_S`, or last heard."""
        now = self._clock()
        last = max(self.peers, key=self.peers.__getitem__) if self.peers else None
        return [*self.outs, *(a for a, heard in self.peers.items() if now - heard <= PEER_TIMEOUT_S or a == last)]

    def _sendto(self, data: bytes, addr: Address) -> bool:
        """One datagram to ``addr``; whether it went (one refused is skipped: nobody listening
        on a udpout port yet is not an error)."""
        try:
            self.sock.sendto(data, addr)
        except OSError:
            return False
        self.tx_datagrams += 1
        return True

    def recv(self, max_datagrams: int = 256) -> list[tuple[bytes, Address]]:
        """Datagrams waiting on the socket, with their senders, without blocking.

        Parameters
        ----------
        max_datagrams : int
            Return at most this many (the rest wait in the socket for the next call).
        """
        out = []
        for _ in range(max_datagrams):
            try:
                data, addr = self.sock.recvfrom(65535)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:  # e.g. ICMP port unreachable from a previous sendto
                continue
            self.rx_datagrams += 1
            out.append((data, addr))
        return out

    def close(self) -> None:
        """Close the socket."""
        self.sock.close()


class LossyLink:
    """A link that drops a fraction of datagrams both ways (seeded): for loss tests and the
    link benchmark.

    Parameters
    ----------
    inner : UdpLink
        The link that carries what is not dropped.
    loss : float
        Probability (0..1) that a datagram is dropped, each way.
    seed : int
        Seed of the drops.
    """

    def __init__(self, inner: UdpLink, loss: float, seed: int = 7) -> None:
        self.inner, self.loss, self.rng = inner, loss, random.Random(seed)

    @property
    def port(self) -> int:
        """The inner link's UDP port."""
        return self.inner.port

    @property
    def sock(self) -> socket.socket:
        """The inner link's socket."""
        return self.inner.sock

    def accept_peer(self, addr: Address) -> None:
        """Reply to this sender from now on (see :meth:`UdpLink.accept_peer`).

        Parameters
        ----------
        addr : Address
            The sender, (host, port).
        """
        self.inner.accept_peer(addr)

    def send(self, data: bytes, exclude: Collection[Address] = ()) -> None:
        """Send, unless this datagram is dropped.

        Parameters
        ----------
        data : bytes
            One packed MAVLink packet.
        exclude : collection of Address, optional
            Peers not to send it to.
        """
        if self.rng.random() >= self.loss:
            self.inner.send(data, exclude)

    def recv(self, max_datagrams: int = 2048) -> list[tuple[bytes, Address]]:
        """The datagrams waiting that are not dropped, with their senders.

        Parameters
        ----------
        max_datagrams : int
            Return at most this many (the rest wait for the next call); default 2048.
        """
        return [d for d in self.inner.recv(max_datagrams) if self.rng.random() >= self.loss]

    def close(self) -> None:
        """Close the inner link."""
        self.inner.close()


class MemoryLink:
    """One end of an in-memory pair: what one end sends, the other receives, in order.

    Make both ends with :meth:`pair`; an end made alone reaches nobody (what it sends is
    dropped, and it receives nothing).

    Parameters
    ----------
    name : str
        This end's name (for logs and debugging).
    """

    def __init__(self, name: str) -> None:
        self.name = name
        self.inbox: deque[tuple[bytes, Address]] = deque()
        self.other: MemoryLink | None = None
        self.tx_datagrams = 0
        self.rx_datagrams = 0

    @staticmethod
    def pair(a: str, b: str) -> tuple[MemoryLink, MemoryLink]:
        """Two connected ends.

        Parameters
        ----------
        a, b : str
            The two ends' names.
        """
        x, y = MemoryLink(a), MemoryLink(b)
        x.other, y.other = y, x
        return x, y

    def accept_peer(self, addr: Address) -> None:
        """Nothing to do: the other end is the only peer.

        Parameters
        ----------
        addr : Address
            The sender, (host, port).
        """

    def send(self, data: bytes, exclude: Collection[Address] = ()) -> None:
        """Queue a datagram for the other end.

        Parameters
        ----------
        data : bytes
            One packed MAVLink packet.
        exclude : collection of Address, optional
            Network peers not to send it to: none is on this link (an endpoint's link may be
            in memory alone, or in memory and UDP, :class:`Fanout`).
        """
        self.tx_datagrams += 1
        if self.other is not None:
            self.other.inbox.append((data, ("memory", 0)))

    def recv(self, max_datagrams: int = 256) -> list[tuple[bytes, Address]]:
        """What the other end sent, oldest first, each from ``("memory", 0)``.

        Parameters
        ----------
        max_datagrams : int
            Return at most this many (the rest wait for the next call); default 256.
        """
        out = []
        while self.inbox and len(out) < max_datagrams:
            out.append(self.inbox.popleft())
        self.rx_datagrams += len(out)
        return out

    def close(self) -> None:
        """Drop what is waiting."""
        self.inbox.clear()


class Fanout:
    """Several links as one (an endpoint reachable over UDP and in memory at once).

    Parameters
    ----------
    *links : UdpLink or MemoryLink
        The links, all sent to and read from.
    """

    def __init__(self, *links: UdpLink | MemoryLink) -> None:
        self.links = list(links)

    def accept_peer(self, addr: Address) -> None:
        """Tell the UDP links to reply to a UDP sender (in-memory senders need nothing).

        Parameters
        ----------
        addr : Address
            The sender, (host, port).
        """
        for link in self.links:
            if isinstance(link, UdpLink) and addr[0] != "memory":
                link.accept_peer(addr)

    def send(self, data: bytes, exclude: Collection[Address] = ()) -> None:
        """Send on every link.

        Parameters
        ----------
        data : bytes
            One packed MAVLink packet.
        exclude : collection of Address, optional
            UDP peers not to send it to (the in-memory links get it).
        """
        for link in self.links:
            link.send(data, exclude)

    def recv(self, max_datagrams: int = 256) -> list[tuple[bytes, Address]]:
        """What every link has waiting, link by link.

        Parameters
        ----------
        max_datagrams : int
            At most this many from each link.
        """
        out = []
        for link in self.links:
            out.extend(link.recv(max_datagrams))
        return out

    def close(self) -> None:
        """Close every link."""
        for link in self.links:
            link.close()
