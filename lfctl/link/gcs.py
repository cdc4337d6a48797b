"""The ground-station client (`lfctl gcs`, tests, the lockstep run's own mission upload):
pymavlink, system 255, component 190. Every wait has a timeout and a clear error."""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from typing import Any

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.errors import LinkTimeoutError, MissionProtocolError
from lfctl.link.endpoint import GCS_COMPID, MODE_NAMES, MODES, pack_next, setup_signing
from lfctl.link.mission import MissionItem

GCS_SYSID = 255
RESULT_NAMES = {v.name: k for k, v in mav.enums["MAV_RESULT"].items()}


def _result_name(enum: str, value: int) -> str:
    e = mav.enums[enum].get(value)
    return e.name if e is not None else str(value)


def open_connection(connect: str, sysid: int, compid: int, signing_key: bytes | None = None) -> Any:
    """A pymavlink connection (ardupilotmega dialect) as ``sysid``/``compid``, signing with
    ``signing_key`` when given, or LinkTimeoutError."""
    # MAVLink 2 from the first packet: mavutil otherwise starts in MAVLink 1 and, on the first
    # MAVLink 2 packet it hears, replaces its parser, losing any signing set up on it
    os.environ["MAVLINK20"] = "1"
    try:
        conn = mavutil.mavlink_connection(
            connect, source_system=sysid, source_component=compid, dialect="ardupilotmega", autoreconnect=False
        )
    except Exception as exc:  # pymavlink raises plain exceptions for bad strings and ports
        raise LinkTimeoutError(f"cannot open MAVLink connection {connect!r}: {exc}") from exc
    if signing_key is not None:
        setup_signing(conn.mav, signing_key)
    return conn


class GroundStation:
    """A MAVLink ground station on a pymavlink connection string (``udpout:127.0.0.1:14561``)
    or on any object with ``send(bytes)`` / ``recv()`` (an in-memory link) plus a ``pump``
    callable that lets the other side run."""

    def __init__(
        self,
        connect: str | Any,
        target_system: int = 1,
        timeout_s: float = 3.0,
        pump: Callable[[], None] | None = None,
        heartbeats: bool = True,
        signing_key: bytes | None = None,
    ) -> None:
        self.target = target_system
        self.heartbeats = heartbeats
        self.timeout_s = timeout_s
        self.pump = pump
        self._hb_at = -math.inf
        if isinstance(connect, str):
            self.conn: Any = open_connection(connect, GCS_SYSID, GCS_COMPID, signing_key)
            self.mav = self.conn.mav
            self.link = None
        else:
            self.conn = None
            self.link = connect
            self.mav = mav.MAVLink(None, srcSystem=GCS_SYSID, srcComponent=GCS_COMPID)
            self.mav.robust_parsing = True
            self._parser = mav.MAVLink(None)
            self._parser.robust_parsing = True
            self._queue: list[Any] = []

    # -- plumbing ---------------------------------------------------------------------------
    def send(self, msg: Any) -> None:
        if self.conn is not None:
            self.conn.mav.send(msg)
        else:
            self.link.send(pack_next(msg, self.mav))

    def heartbeat(self, force: bool = False) -> None:
        """The GCS heartbeat (at most once a second unless forced)."""
        now = time.monotonic()
        if self.heartbeats and (force or now - self._hb_at >= 1.0):
            self._hb_at = now
            self.send(
                mav.MAVLink_heartbeat_message(
                    mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, mav.MAV_STATE_ACTIVE, 3
                )
            )

    def _next(self, timeout_s: float) -> Any | None:
        if self.conn is not None:
            return self.conn.recv_match(blocking=True, timeout=timeout_s)
        if not self._queue:
            if self.pump is not None:
                self.pump()
            for data, _addr in self.link.recv():
                self._queue.extend(m for m in (self._parser.parse_buffer(data) or []) if m.get_type() != "BAD_DATA")
        return self._queue.pop(0) if self._queue else None

    def wait(
        self, kinds: tuple[str, ...], timeout_s: float | None = None, where: Callable[[Any], bool] | None = None
    ) -> Any:
        """The next message of one of ``kinds`` from the target (LinkTimeoutError if none)."""
        limit = self.timeout_s if timeout_s is None else timeout_s
        deadline = time.monotonic() + limit
        spins = 0
        while time.monotonic() < deadline and spins < 100_000:
            spins += 1
            self.heartbeat()
            m = self._next(min(0.1, max(0.0, deadline - time.monotonic())))
            if m is None:
                continue
            if m.get_type() in kinds and m.get_srcSystem() == self.target and (where is None or where(m)):
                return m
        raise LinkTimeoutError(
            f"no {'/'.join(kinds)} from system {self.target} within {limit:g} s (is the vehicle up, the address "
            "right, and, if it signs its link, the passphrase the same?)"
        )

    def wait_heartbeat(self) -> Any:
        self.heartbeat(force=True)
        return self.wait(("HEARTBEAT",), where=lambda m: m.get_srcComponent() == 1)

    # -- commands ------------------------------------------------------------------------------
    def command(self, cmd: int, *params: float, retries: int = 3) -> int:
        """COMMAND_LONG with retries; returns the MAV_RESULT of its COMMAND_ACK."""
        p = [*params, *([0.0] * (7 - len(params)))]
        for attempt in range(retries):
            self.send(mav.MAVLink_command_long_message(self.target, 1, cmd, attempt, *p))
            try:
                ack = self.wait(("COMMAND_ACK",), timeout_s=self.timeout_s / retries, where=lambda m: m.command == cmd)
                return int(ack.result)
            except LinkTimeoutError:
                continue
        raise LinkTimeoutError(
            f"no COMMAND_ACK for command {_result_name('MAV_CMD', cmd)} from system {self.target} after {retries} tries"
        )

    def set_mode(self, name: str) -> int:
        if name.upper() not in MODES:
            raise MissionProtocolError(f"unknown mode {name!r} (known: {', '.join(MODES)})")
        return self.command(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES[name.upper()])

    def arm(self, on: bool = True) -> int:
        return self.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1.0 if on else 0.0)

    # -- parameters -----------------------------------------------------------------------------
    def param_get(self, name: str) -> float:
        self.send(mav.MAVLink_param_request_read_message(self.target, 1, name.encode(), -1))
        m = self.wait(("PARAM_VALUE",), where=lambda m: _pid(m) == name)
        return float(m.param_value)

    def param_set(self, name: str, value: float) -> float:
        self.send(mav.MAVLink_param_set_message(self.target, 1, name.encode(), float(value), mav.MAV_PARAM_TYPE_REAL32))
        m = self.wait(("PARAM_VALUE",), where=lambda m: _pid(m) == name)
        return float(m.param_value)

    def param_list(self) -> dict[str, float]:
        self.send(mav.MAVLink_param_request_list_message(self.target, 1))
        first = self.wait(("PARAM_VALUE",))
        out = {_pid(first): float(first.param_value)}
        while len(out) < first.param_count:
            m = self.wait(("PARAM_VALUE",))
            out[_pid(m)] = float(m.param_value)
        return out

    # -- missions --------------------------------------------------------------------------------
    def upload(self, items: list[MissionItem], item_timeout_s: float = 1.0, restarts: int = 5) -> None:
        """Mission upload; MissionProtocolError names the item and result if refused.

        The vehicle drives the transfer (it re-requests a lost item); when the vehicle falls
        silent (our MISSION_COUNT or its final MISSION_ACK lost) the upload starts again.
        """
        for _attempt in range(restarts + 1):
            self.send(mav.MAVLink_mission_count_message(self.target, 1, len(items), mav.MAV_MISSION_TYPE_MISSION))
            while True:
                try:
                    m = self.wait(
                        ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"), timeout_s=item_timeout_s * 3
                    )
                except LinkTimeoutError:
                    break  # restart from MISSION_COUNT
                if m.get_type() == "MISSION_ACK":
                    if m.type != mav.MAV_MISSION_ACCEPTED:
                        raise MissionProtocolError(
                            f"mission refused by system {self.target}: {_result_name('MAV_MISSION_RESULT', m.type)}"
                        )
                    return
                if not 0 <= m.seq < len(items):
                    raise MissionProtocolError(
                        f"mission upload: vehicle asked for item {m.seq}, the mission has {len(items)} items (0..{len(items) - 1})"
                    )
                self._send_item(items[m.seq])
        raise LinkTimeoutError(f"mission upload to system {self.target}: no answer after {restarts + 1} attempts")

    def _send_item(self, it: MissionItem) -> None:
        self.send(
            mav.MAVLink_mission_item_int_message(
                self.target, 1, it.seq, it.frame, it.command, 0, it.autocontinue,
                it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, mav.MAV_MISSION_TYPE_MISSION,
            )
        )  # fmt: skip

    def download(self, retries: int = 5) -> list[MissionItem]:
        """Mission download, re-requesting what is lost."""
        count = None
        for _ in range(retries):
            self.send(mav.MAVLink_mission_request_list_message(self.target, 1, mav.MAV_MISSION_TYPE_MISSION))
            try:
                count = int(self.wait(("MISSION_COUNT",), timeout_s=self.timeout_s / retries).count)
                break
            except LinkTimeoutError:
                continue
        if count is None:
            raise LinkTimeoutError(f"no MISSION_COUNT from system {self.target} after {retries} requests")
        items: list[MissionItem] = []
        while len(items) < count:
            seq = len(items)
            for _ in range(retries):
                self.send(mav.MAVLink_mission_request_int_message(self.target, 1, seq, mav.MAV_MISSION_TYPE_MISSION))
                try:
                    m = self.wait(
                        ("MISSION_ITEM_INT",), timeout_s=self.timeout_s / retries, where=lambda m, s=seq: m.seq == s
                    )
                    break
                except LinkTimeoutError:
                    continue
            else:
                raise MissionProtocolError(
                    f"mission download: expected item {seq}, received none after {retries} requests"
                )
            items.append(
                MissionItem(
                    m.seq, m.frame, m.command, m.param1, m.param2, m.param3, m.param4, m.x, m.y, m.z, m.autocontinue
                )
            )
        self.send(
            mav.MAVLink_mission_ack_message(self.target, 1, mav.MAV_MISSION_ACCEPTED, mav.MAV_MISSION_TYPE_MISSION)
        )
        return items

    def clear(self) -> None:
        self.send(mav.MAVLink_mission_clear_all_message(self.target, 1, mav.MAV_MISSION_TYPE_MISSION))
        m = self.wait(("MISSION_ACK",))
        if m.type != mav.MAV_MISSION_ACCEPTED:
            raise MissionProtocolError(f"mission clear refused: {_result_name('MAV_MISSION_RESULT', m.type)}")

    def close(self) -> None:
        if self.conn is not None:
            self.conn.close()


def _pid(m: Any) -> str:
    pid = m.param_id
    return (pid.decode(errors="replace") if isinstance(pid, bytes) else pid).rstrip("\x00")


def mode_name(custom_mode: int) -> str:
    return MODE_NAMES.get(custom_mode, f"mode {custom_mode}")
