"""Where MAVLink bytes travel: real UDP sockets (``--realtime``) or an in-memory link
(lockstep runs), behind one interface, so the codec and handlers are the same code."""

from __future__ import annotations

import random
import socket
from collections import deque
from collections.abc import Callable

Address = tuple[str, int]


class UdpLink:
    """``udpin`` socket plus optional ``udpout`` targets, with peers managed here.

    pymavlink's ``udpin`` replies to the last sender, so a stray datagram redirects the
    stream; this link replies only to peers that sent *valid* MAVLink (the endpoint says so
    with :meth:`accept_peer`), plus fixed ``udpout`` targets.
    """

    def __init__(self, bind: Address | None, outs: list[Address] | None = None) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        # a burst from a ground station (a 100-item mission, a parameter dump) must not overflow
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 * 1024 * 1024)
        self.sock.bind(bind or ("127.0.0.1", 0))
        self.sock.setblocking(False)
        self.outs = list(outs or [])
        self.peers: list[Address] = []
        self.tx_datagrams = 0
        self.rx_datagrams = 0

    @property
    def port(self) -> int:
        return int(self.sock.getsockname()[1])

    def accept_peer(self, addr: Address) -> None:
        """A sender whose datagram parsed as MAVLink: reply to it from now on."""
        if addr not in self.peers and addr not in self.outs:
            self.peers.append(addr)
            del self.peers[:-8]  # a handful of ground stations at most

    def send(self, data: bytes) -> None:
        for addr in (*self.outs, *self.peers):
            try:
                self.sock.sendto(data, addr)
                self.tx_datagrams += 1
            except OSError:  # nobody listening on a udpout port yet: not an error
                pass

    def recv(self, max_datagrams: int = 2048) -> list[tuple[bytes, Address]]:
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
        self.sock.close()


class LossyLink:
    """A link that drops a fraction of datagrams both ways (seeded): for loss tests and the
    link benchmark."""

    def __init__(self, inner: UdpLink, loss: float, seed: int = 7) -> None:
        self.inner, self.loss, self.rng = inner, loss, random.Random(seed)

    @property
    def port(self) -> int:
        return self.inner.port

    @property
    def sock(self) -> socket.socket:
        return self.inner.sock

    def accept_peer(self, addr: Address) -> None:
        self.inner.accept_peer(addr)

    def send(self, data: bytes) -> None:
        if self.rng.random() >= self.loss:
            self.inner.send(data)

    def recv(self, max_datagrams: int = 2048) -> list[tuple[bytes, Address]]:
        return [d for d in self.inner.recv(max_datagrams) if self.rng.random() >= self.loss]

    def close(self) -> None:
        self.inner.close()


class MemoryLink:
    """One end of an in-memory pair: what one end sends, the other receives, in order."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.inbox: deque[tuple[bytes, Address]] = deque()
        self.other: MemoryLink | None = None
        self.tap: Callable[[bytes], None] | None = None
        self.tx_datagrams = 0
        self.rx_datagrams = 0

    @staticmethod
    def pair(a: str, b: str) -> tuple[MemoryLink, MemoryLink]:
        x, y = MemoryLink(a), MemoryLink(b)
        x.other, y.other = y, x
        return x, y

    def accept_peer(self, addr: Address) -> None:
        pass

    def send(self, data: bytes) -> None:
        assert self.other is not None
        self.tx_datagrams += 1
        self.other.inbox.append((data, ("memory", 0)))

    def recv(self, max_datagrams: int = 256) -> list[tuple[bytes, Address]]:
        out = []
        while self.inbox and len(out) < max_datagrams:
            out.append(self.inbox.popleft())
        self.rx_datagrams += len(out)
        return out

    def close(self) -> None:
        self.inbox.clear()


class Fanout:
    """Several links as one (an endpoint reachable over UDP and in memory at once)."""

    def __init__(self, *links: UdpLink | MemoryLink) -> None:
        self.links = list(links)

    def accept_peer(self, addr: Address) -> None:
        for link in self.links:
            if isinstance(link, UdpLink) and addr[0] != "memory":
                link.accept_peer(addr)

    def send(self, data: bytes) -> None:
        for link in self.links:
            link.send(data)

    def recv(self, max_datagrams: int = 256) -> list[tuple[bytes, Address]]:
        out = []
        for link in self.links:
            out.extend(link.recv(max_datagrams))
        return out

    def close(self) -> None:
        for link in self.links:
            link.close()
