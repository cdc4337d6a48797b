"""Helpers the tests import (``from support import ...``): plain functions, where
conftest.py holds fixtures (two conftest modules exist, so importing from "conftest" would
depend on which was loaded first)."""

from __future__ import annotations

import socket
import time
from collections.abc import Callable
from typing import Any

from lfctl.bench.common import free_udp_ports

__all__ = ["LEADER_AND_FOLLOWER", "free_udp_ports", "left_stopped", "list_file", "loopback_udp", "wait_until"]

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
