"""Helpers the tests import (``from support import ...``): plain functions, where
conftest.py holds fixtures (two conftest modules exist, so importing from "conftest" would
depend on which was loaded first)."""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest

from lfctl.bench.common import free_udp_ports

__all__ = [
    "LEADER_AND_FOLLOWER",
    "free_udp_ports",
    "left_stopped",
    "list_file",
    "loopback_udp",
    "rtp_camera",
    "wait_until",
]

#: a scenario's two vehicles as the small closed-loop tests write them: the leader at home,
#: follower ``f1`` 1.5 m behind it (TOML, to put between a scenario's other tables)
LEADER_AND_FOLLOWER = """[[vehicles]]
name = "leader"
role = "leader"
[[vehicles]]
name = "f1"
role = "follower"
north_m = -1.5
"""


def loopback_udp() -> socket.socket:
    """A UDP socket bound to 127.0.0.1 on a port the kernel picks: a test's sender, which
    would otherwise be bound to every interface when it first sends."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    return s


def wait_until(predicate: Callable[[], bool], timeout_s: float = 10.0) -> bool:
    """Poll ``predicate`` every 20 ms until it holds or ``timeout_s`` passes; whether it held
    (for what another thread or process does in its own time)."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def left_stopped(rover: Any) -> bool:
    """The rover's last guided target is zero speed and zero turn rate."""
    g = rover.guided
    return g is not None and g.kind == "rate" and (g.speed_mps, g.yaw_rate_radps) == (0.0, 0.0)


def list_file(items: list[Any], mission_type: int = 0, options: int = 0, start: int = 0) -> bytes:
    """A list of MissionItem as ArduPilot's ``@MISSION/*.dat`` file, as MAVProxy's `wp
    ftpload` writes it: the 10-byte header (magic 0x763d, list type, options, first item,
    count), then each item's MISSION_ITEM_INT payload."""
    import struct

    from pymavlink.dialects.v20 import ardupilotmega as mav

    out = struct.pack("<HHHHH", 0x763D, mission_type, options, start, len(items))
    unit = mav.MAVLink_mission_item_int_message
    for it in items:
        m = unit(1, 1, it.seq, it.frame, it.command, 0, 1, it.param1, it.param2, it.param3, it.param4,
                 it.x, it.y, it.z, mission_type)  # fmt: skip
        out += unit.unpacker.pack(*(getattr(m, f) for f in unit.ordered_fieldnames))
    return out


@contextlib.contextmanager
def rtp_camera(frames: Sequence[Any], sending: Callable[[int], bool] = lambda k: True) -> Iterator[int]:
    """A camera streaming RTP/UDP H.264 to 127.0.0.1 at 30 Hz while the block runs, as a rover's
    does: ``frames`` (BGR, one size) over and over; at each tick it sends frame ``k`` (the
    count sent so far) only while ``sending(k)`` holds. Yields the port it sends to (free
    a moment before: FFmpeg binds it to receive)."""
    from lfctl.record.rtp import RtpH264Sender
    from lfctl.record.video import H264Encoder

    probe = loopback_udp()
    port = probe.getsockname()[1]
    probe.close()
    h, w = frames[0].shape[:2]
    stop = threading.Event()

    def send() -> None:
        sender, encoder = RtpH264Sender("127.0.0.1", port), H264Encoder(w, h, 30.0, 2000, gop=15)
        k = 0
        while not stop.is_set():
            if sending(k):
                sender.send(encoder.encode(frames[k % len(frames)]).data, k / 30.0)
                k += 1
            stop.wait(1 / 30)
        sender.close()

    worker = threading.Thread(target=send, daemon=True)
    worker.start()
    try:
        yield port
    finally:
        stop.set()
        worker.join(5)


def unmakeable_folder(name: str) -> Path:
    """A folder path no one here can make, not even root (under sysfs): a home or cache that
    is not writable. Skips the test where there is no such place."""
    path = Path("/sys") / name
    try:
        path.mkdir()
    except OSError:
        return path
    path.rmdir()
    pytest.skip("no folder here that even root cannot make")
