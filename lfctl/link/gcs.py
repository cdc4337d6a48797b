"""The ground-station client (`lfctl gcs`, tests, the lockstep run's own mission upload):
pymavlink, system 255, component 190. Every wait has a timeout and a clear error."""

from __future__ import annotations

import contextlib
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.checks import printable
from lfctl.errors import LinkTimeoutError, MissionProtocolError
from lfctl.frames import on_earth
from lfctl.link.endpoint import GCS_COMPID, MODE_NAMES, MODES
from lfctl.link.fence import RALLY_POINT, validate_fence
from lfctl.link.mission import PLACE_FRAMES, MissionItem, command_name, validate_item
from lfctl.link.mission_server import FENCE, MISSION, MISSION_TYPES
from lfctl.link.param_server import ascii_upper
from lfctl.link.port import CHECK_LINK, MavPort

__all__ = ["GCS_SYSID", "FleetTable", "GroundStation", "VehicleRow", "result_name"]

#: the ground station's system id, as QGroundControl and MAVProxy use
GCS_SYSID = 255
#: a command answered IN_PROGRESS: the longest wait for its final answer, s
IN_PROGRESS_MAX_S = 10.0
#: a parameter list that brings no new parameter for this long asks for the missing ones by
#: index, PARAM_READS_PER_ROUND at a time (ArduPilot queues 20 reads and drops the rest); it
#: gives up after PARAM_ROUNDS rounds in a row that brought none, s
PARAM_GAP_S = 1.0
PARAM_ROUNDS = 3
PARAM_READS_PER_ROUND = 20
#: a mission upload stops when the vehicle has asked for this many items per item (a lost
#: item is asked for again; one asked for without end is a fault), plus a few
UPLOAD_SENDS_PER_ITEM = 5
UPLOAD_SENDS_SPARE = 20
#: a downloaded item not come is asked for again after this long at least, s (four round
#: trips of the count's request if longer: a slow radio link's answers are not overtaken)
DOWNLOAD_RESEND_S = 0.25
#: the formation values (NAMED_VALUE_FLOAT) kept per vehicle in `lfctl gcs watch`
FORMATION_NAMES_MAX = 16


def _result_name(enum: str, value: int) -> str:
    e = mav.enums[enum].get(value)
    return e.name if e is not None else str(value)


def result_name(result: int) -> str:
    """A COMMAND_ACK result's name (``MAV_RESULT_ACCEPTED``), or the number if MAVLink has none.

    Parameters
    ----------
    result : int
        A MAV_RESULT value.
    """
    return _result_name("MAV_RESULT", result)


class GroundStation:
    """A MAVLink ground station (system 255, component 190) on a pymavlink connection string
    (``udpout:127.0.0.1:14561``) or on a :class:`MavPort` (an in-memory link in lockstep runs).

    Parameters
    ----------
    connect : str or MavPort
        Where the vehicle is.
    target_system : int
        The vehicle's system id.
    timeout_s : float
        Longest wait for each answer, s.
    heartbeats : bool
        Send the ground station's heartbeat (once a second) while waiting.
    signing_key : bytes, optional
        MAVLink 2 signing key, for a connection string.
    """

    def __init__(
        self,
        connect: str | MavPort,
        target_system: int = 1,
        timeout_s: float = 3.0,
        heartbeats: bool = True,
        signing_key: bytes | None = None,
    ) -> None:
        self.target = target_system
        self.heartbeats = heartbeats
        self.timeout_s = timeout_s
        self._hb_at = -math.inf
        #: the target's STATUSTEXTs heard while waiting for answers, (monotonic time, text
        #: escaped), the newest 20: a refusal's reason (:meth:`said_since`)
        self.said: deque[tuple[float, str]] = deque(maxlen=20)
        self.port = (
            connect if isinstance(connect, MavPort) else MavPort.open(connect, GCS_SYSID, GCS_COMPID, signing_key)
        )

    # -- plumbing ---------------------------------------------------------------------------
    def send(self, msg: Any) -> None:
        """Send one message to the vehicle.

        Parameters
        ----------
        msg : pymavlink message
            The message (addressed to :attr:`target` where it has a target).
        """
        self.port.send(msg)

    def heartbeat(self, force: bool = False) -> None:
        """The GCS heartbeat (at most once a second unless forced; never with
        ``heartbeats=False``).

        Parameters
        ----------
        force : bool
            Send now even if one went out less than a second ago.
        """
        now = time.monotonic()
        if self.heartbeats and (force or now - self._hb_at >= 1.0):
            self._hb_at = now
            self.send(
                mav.MAVLink_heartbeat_message(
                    mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, mav.MAV_STATE_ACTIVE, 3
                )
            )

    def next_message(self, timeout_s: float) -> Any | None:
        """The next message from anyone, or None.

        Parameters
        ----------
        timeout_s : float
            Longest wait, s; 0 returns at once.
        """
        return self.port.recv(timeout_s)

    def wait(
        self, kinds: tuple[str, ...], timeout_s: float | None = None, where: Callable[[Any], bool] | None = None
    ) -> Any:
        """The next message of one of ``kinds`` from the target, sending heartbeats meanwhile.

        Parameters
        ----------
        kinds : tuple of str
            Message names, e.g. ``("COMMAND_ACK",)``.
        timeout_s : float, optional
            Longest wait, s (default :attr:`timeout_s`).
        where : callable, optional
            Only a message for which ``where(msg)`` is true counts.

        Raises
        ------
        LinkTimeoutError
            None came in time.
        """
        limit = self.timeout_s if timeout_s is None else timeout_s
        deadline = time.monotonic() + limit
        spins = 0
        while time.monotonic() < deadline and spins < 100_000:
            spins += 1
            self.heartbeat()
            m = self.next_message(min(0.1, max(0.0, deadline - time.monotonic())))
            if m is None:
                continue
            if m.get_type() == "STATUSTEXT" and m.get_srcSystem() == self.target and m.get_srcComponent() == 1:
                # the autopilot's (not its camera's or companion's): a refusal's reason
                self.said.append((time.monotonic(), printable(text_field(m.text))))
            if m.get_type() in kinds and m.get_srcSystem() == self.target and (where is None or where(m)):
                return m
        raise LinkTimeoutError("/".join(kinds), sysid=self.target, timeout_s=limit, detail=CHECK_LINK)

    def said_since(self, t0: float, linger_s: float = 0.5) -> list[str]:
        """What the vehicle said (STATUSTEXT) since ``t0``, waiting up to ``linger_s`` for a
        first text when none has come yet (a refusal's reason may follow its answer).

        Parameters
        ----------
        t0 : float
            ``time.monotonic()`` as the request went out.
        linger_s : float
            Longest wait for a text, s.
        """
        deadline = time.monotonic() + linger_s
        while not any(t >= t0 for t, _text in self.said) and time.monotonic() < deadline:
            with contextlib.suppress(LinkTimeoutError):
                self.wait(("STATUSTEXT",), timeout_s=max(0.0, deadline - time.monotonic()))
        return [text for t, text in self.said if t >= t0]

    def wait_heartbeat(self) -> Any:
        """The vehicle's next HEARTBEAT (from its autopilot, component 1)."""
        self.heartbeat(force=True)
        return self.wait(("HEARTBEAT",), where=lambda m: m.get_srcComponent() == 1)

    # -- commands ------------------------------------------------------------------------------
    def command(self, cmd: int, *params: float, retries: int = 3) -> int:
        """COMMAND_LONG with retries; returns the MAV_RESULT of its COMMAND_ACK.

        Parameters
        ----------
        cmd : int
            The MAV_CMD.
        *params : float
            param1, param2, ... (up to 7; the rest are 0).
        retries : int
            Sends (confirmation 0, 1, ...), sharing :attr:`timeout_s` between them.

        Raises
        ------
        LinkTimeoutError
            No COMMAND_ACK after every try.
        """
        p = [*params, *([0.0] * (7 - len(params)))]
        for attempt in range(retries):
            self.send(mav.MAVLink_command_long_message(self.target, 1, cmd, attempt, *p))
            try:
                ack = self.wait(("COMMAND_ACK",), timeout_s=self.timeout_s / retries, where=self._ack_of(cmd))
            except LinkTimeoutError:
                continue
            if ack.result != mav.MAV_RESULT_IN_PROGRESS:
                return int(ack.result)
            try:  # being carried out: sent again it would start afresh; its final answer follows
                final = self.wait(
                    ("COMMAND_ACK",),
                    timeout_s=IN_PROGRESS_MAX_S,
                    where=lambda m: self._ack_of(cmd)(m) and m.result != mav.MAV_RESULT_IN_PROGRESS,
                )
            except LinkTimeoutError:
                return int(mav.MAV_RESULT_IN_PROGRESS)  # no final answer: the caller says so
            return int(final.result)
        raise LinkTimeoutError(
            f"COMMAND_ACK for {_result_name('MAV_CMD', cmd)}",
            sysid=self.target,
            timeout_s=self.timeout_s,
            detail=f"{retries} tries",
        )

    def _ack_of(self, cmd: int) -> Callable[[Any], bool]:
        """Which COMMAND_ACK answers our ``cmd``: the autopilot's (component 1, as it was sent
        there; a camera's or a companion's is not), addressed to us (0: a MAVLink 1 ack)."""
        me = self.port.sysid, self.port.compid

        def ours(m: Any) -> bool:
            to_system, to_component = getattr(m, "target_system", 0), getattr(m, "target_component", 0)
            to_us = to_system == 0 or (to_system == me[0] and to_component in (0, me[1]))
            return m.command == cmd and m.get_srcComponent() == 1 and to_us

        return ours

    def home(self, timeout_s: float | None = None) -> tuple[float, float, float] | None:
        """The vehicle's home (latitude deg, longitude deg, altitude m above mean sea level),
        asked for with MAV_CMD_GET_HOME_POSITION; None when no HOME_POSITION comes in time.

        Parameters
        ----------
        timeout_s : float, optional
            Longest wait, s (default :attr:`timeout_s`).
        """
        self.send(mav.MAVLink_command_long_message(self.target, 1, mav.MAV_CMD_GET_HOME_POSITION, 0, *[0.0] * 7))
        try:
            m = self.wait(("HOME_POSITION",), timeout_s=timeout_s)
        except LinkTimeoutError:
            return None
        return m.latitude / 1e7, m.longitude / 1e7, m.altitude / 1000.0

    def set_mode(self, name: str) -> int:
        """Ask for a Rover mode (MAV_CMD_DO_SET_MODE); returns the MAV_RESULT.

        Parameters
        ----------
        name : str
            ``AUTO``, ``GUIDED``, ``HOLD``, ... (any case; MissionProtocolError for another).
        """
        if name.upper() not in MODES:
            raise MissionProtocolError(f"unknown mode {name!r} (known: {', '.join(MODES)})")
        return self.command(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES[name.upper()])

    def arm(self, on: bool = True) -> int:
        """Ask to arm (or disarm); returns the MAV_RESULT.

        Parameters
        ----------
        on : bool
            True to arm, False to disarm.
        """
        return self.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1.0 if on else 0.0)

    # -- parameters -----------------------------------------------------------------------------
    def param_get(self, name: str) -> float:
        """A parameter's value (PARAM_REQUEST_READ).

        Parameters
        ----------
        name : str
            The parameter, e.g. ``WP_SPEED``.
        """
        self.send(mav.MAVLink_param_request_read_message(self.target, 1, name.encode(), -1))
        return self._param_answer(name)

    def param_set(self, name: str, value: float) -> float:
        """Set a parameter; returns the value now in force (the old one if refused).

        Parameters
        ----------
        name : str
            The parameter.
        value : float
            The new value, in the parameter's unit.
        """
        self.send(mav.MAVLink_param_set_message(self.target, 1, name.encode(), float(value), mav.MAV_PARAM_TYPE_REAL32))
        return self._param_answer(name)

    def _param_answer(self, name: str) -> float:
        """The PARAM_VALUE for ``name``; MissionProtocolError when the vehicle says it has no
        such parameter (lfctl's "Unknown parameter NAME"), LinkTimeoutError naming it when
        nothing comes (a Rover does not answer for a name it lacks)."""
        unknown = f"Unknown parameter {name}"

        def answer(m: Any) -> bool:  # (the autopilot's: a companion's LFC_* reach a ground station too)
            if m.get_srcComponent() != 1:
                return False
            if m.get_type() == "PARAM_VALUE":
                # a Rover answers a set with the parameter's own name, whatever case it was
                # asked in (AP_Param::find takes most of a name in any case)
                return ascii_upper(_pid(m)) == ascii_upper(name)
            return text_field(m.text) == unknown

        try:
            m = self.wait(("PARAM_VALUE", "STATUSTEXT"), where=answer)
        except LinkTimeoutError as e:
            raise LinkTimeoutError(
                f"PARAM_VALUE for {name}",
                sysid=self.target,
                timeout_s=e.timeout_s,
                detail=f"does the vehicle have a parameter {name}? {CHECK_LINK}",
            ) from None
        if m.get_type() == "STATUSTEXT":
            raise MissionProtocolError(f"system {self.target} has no parameter {name!r}")
        return float(m.param_value)

    def param_list(self) -> dict[str, float]:
        """Every parameter and its value (PARAM_REQUEST_LIST), in the vehicle's order. As
        MAVProxy and QGroundControl fetch them: the indexes still missing when the list
        stalls for :data:`PARAM_GAP_S` are asked for one by one (PARAM_REQUEST_READ by index),
        :data:`PARAM_READS_PER_ROUND` at a time, the next round once one is answered whole
        or stalls; :data:`PARAM_ROUNDS` rounds in a row that bring none end it. A parameter
        sent again (another ground station's set) is no progress.

        Raises
        ------
        LinkTimeoutError
            No PARAM_VALUE at all, or indexes still missing after the last round (named).
        """
        self.send(mav.MAVLink_param_request_list_message(self.target, 1))
        # the autopilot's (a companion's own, LFC_*, reach a ground station too); 0xFFFF: an
        # answer to a set or read by name
        listed = lambda m: m.get_srcComponent() == 1 and m.param_index != 0xFFFF  # noqa: E731
        first = self.wait(("PARAM_VALUE",), where=lambda m: listed(m) and m.param_index < m.param_count)
        count = int(first.param_count)
        got: dict[int, tuple[str, float]] = {int(first.param_index): (_pid(first), float(first.param_value))}
        rounds, progress_at, before = 0, time.monotonic(), 0
        asked: set[int] = set()  # the round of reads under way
        while len(got) < count:
            try:
                m = self.wait(("PARAM_VALUE",), timeout_s=max(0.0, progress_at + PARAM_GAP_S - time.monotonic()))
            except LinkTimeoutError:
                m = None
            if m is not None and listed(m) and m.param_index < count and m.param_index not in got:
                got[int(m.param_index)] = (_pid(m), float(m.param_value))
                progress_at = time.monotonic()
                asked.discard(int(m.param_index))
                if asked or before == 0:
                    continue  # (the list goes on, or the round's answers do)
            elif time.monotonic() < progress_at + PARAM_GAP_S:
                continue  # a parameter sent again, or another's: no progress, but the list may go on
            missing = [k for k in range(count) if k not in got]
            rounds = 0 if len(got) > before else rounds + 1  # (rounds in a row that brought none)
            before = len(got)
            if rounds >= PARAM_ROUNDS:
                shown = ", ".join(map(str, missing[:10])) + (", ..." if len(missing) > 10 else "")
                raise LinkTimeoutError(
                    "PARAM_VALUE",
                    sysid=self.target,
                    timeout_s=PARAM_GAP_S,
                    detail=f"got {len(got)} of {count} parameters; still missing index {shown} after "
                    f"{PARAM_ROUNDS} rounds of requests that brought none; {CHECK_LINK}",
                )
            if not missing:
                break
            asked = set(missing[:PARAM_READS_PER_ROUND])  # (the next round as soon as one is answered whole)
            for k in sorted(asked):
                self.send(mav.MAVLink_param_request_read_message(self.target, 1, b"", k))
            progress_at = time.monotonic()
        return {name: value for _k, (name, value) in sorted(got.items())}

    # -- missions --------------------------------------------------------------------------------
    def upload(
        self,
        items: list[MissionItem],
        item_timeout_s: float = 1.0,
        restarts: int = 5,
        mission_type: int = mav.MAV_MISSION_TYPE_MISSION,
    ) -> None:
        """Mission (or fence, or rally) upload; MissionProtocolError names the item and
        result if refused; no items clear the list.

        The vehicle drives the transfer (it re-requests a lost item); when the vehicle falls
        silent (our MISSION_COUNT or its final MISSION_ACK lost) the upload starts again. A
        MAV_MISSION_ERROR that comes before the vehicle has asked for anything is passed over:
        it answers an item of an earlier transfer that reached the vehicle after that transfer
        ended (one of ours sent twice), as Rover answers such an item.

        Parameters
        ----------
        items : list of MissionItem
            The mission, item 0 = home.
        item_timeout_s : float
            The vehicle is taken as silent after three times this with no request, s.
        restarts : int
            How many times the upload may start again from MISSION_COUNT.
        mission_type : int
            MAV_MISSION_TYPE: the mission (item 0 = home), the fence or the rally points.

        Raises
        ------
        MissionProtocolError
            The vehicle refused the mission or asked for an item it does not have.
        LinkTimeoutError
            It stayed silent through every restart.
        """
        stray: int | None = None  # a refusal that came before anything was asked for
        strays, ever_asked = 0, False
        for _attempt in range(restarts + 1):
            sends = 0
            self.send(mav.MAVLink_mission_count_message(self.target, 1, len(items), mission_type))
            asked = False
            last: MissionItem | None = None  # the item sent last: a refusal is of it
            quiet_until = time.monotonic() + item_timeout_s * 3  # a request moves it on; nothing else does
            while True:
                try:
                    m = self.wait(
                        ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"),
                        timeout_s=max(0.0, quiet_until - time.monotonic()),
                        where=lambda m: m.mission_type == mission_type,
                    )
                except LinkTimeoutError:
                    break  # restart from MISSION_COUNT
                if m.get_type() == "MISSION_ACK":
                    if m.type == mav.MAV_MISSION_ERROR and not asked:
                        stray, strays = m.type, strays + 1
                        continue  # a stray item's answer, from before our count
                    if m.type != mav.MAV_MISSION_ACCEPTED:
                        result = _result_name("MAV_MISSION_RESULT", m.type)
                        what = MISSION_TYPES.get(mission_type, "list")
                        at = (
                            "" if last is None else f" on item {last.seq} ({command_name(last.command)}), the last sent"
                        )
                        raise MissionProtocolError(
                            f"{what} refused by system {self.target}{at}: {result}", result=result
                        )
                    return
                if not 0 <= m.seq < len(items):
                    raise MissionProtocolError(
                        f"mission upload: vehicle asked for item {m.seq}, the mission has {len(items)} items (0..{len(items) - 1})",
                        received_seq=m.seq,
                    )
                sends += 1
                if sends > UPLOAD_SENDS_PER_ITEM * len(items) + UPLOAD_SENDS_SPARE:
                    raise MissionProtocolError(
                        f"mission upload: system {self.target} asked for item {m.seq} again and again "
                        f"({sends} items sent for {len(items)}): stopped",
                        received_seq=m.seq,
                    )
                asked = ever_asked = True
                last = items[m.seq]
                quiet_until = time.monotonic() + item_timeout_s * 3
                self._send_item(last, mission_type)
        if stray is not None and not ever_asked:
            result = _result_name("MAV_MISSION_RESULT", stray)
            raise MissionProtocolError(
                f"{MISSION_TYPES.get(mission_type, 'list')} refused by system {self.target} before any item was "
                f"asked for: {result} ({strays} times in {restarts + 1} counts)",
                result=result,
            )
        raise LinkTimeoutError(
            "answer to the mission upload", sysid=self.target, detail=f"{restarts + 1} attempts from MISSION_COUNT"
        )

    def _send_item(self, it: MissionItem, mission_type: int) -> None:
        self.send(
            mav.MAVLink_mission_item_int_message(
                self.target, 1, it.seq, it.frame, it.command, 0, it.autocontinue,
                it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, mission_type,
            )
        )  # fmt: skip

    def download(self, retries: int = 5, mission_type: int = mav.MAV_MISSION_TYPE_MISSION) -> list[MissionItem]:
        """Mission (or fence, or rally) download, re-requesting what is lost; a mission's item 0 = home.

        Parameters
        ----------
        retries : int
            Requests for the count, sharing :attr:`timeout_s`. Each item is asked for again
            after a few round trips (at least :data:`DOWNLOAD_RESEND_S`), then after twice as
            long each time up to ``timeout_s / retries``, for up to :attr:`timeout_s`.
        mission_type : int
            MAV_MISSION_TYPE: the mission, the fence or the rally points.

        Raises
        ------
        LinkTimeoutError
            No MISSION_COUNT came.
        MissionProtocolError
            An item never came within :attr:`timeout_s`.
        """
        count = None
        for _ in range(retries):
            sent_at = time.monotonic()
            self.send(mav.MAVLink_mission_request_list_message(self.target, 1, mission_type))
            try:
                count = int(
                    self.wait(
                        ("MISSION_COUNT",),
                        timeout_s=self.timeout_s / retries,
                        where=lambda m: m.mission_type == mission_type and _to_us(m),
                    ).count
                )
                break
            except LinkTimeoutError:
                continue
        if count is None:
            raise LinkTimeoutError(
                "MISSION_COUNT", sysid=self.target, timeout_s=self.timeout_s, detail=f"{retries} requests"
            )
        # an item not come is asked for again after a few round trips (the count's, then each
        # item's answered at once), at least DOWNLOAD_RESEND_S; each time again for one item
        # it waits twice as long, up to a retry's share of the timeout (a slow link is not
        # flooded with requests it then answers twice), until the timeout
        cap = max(DOWNLOAD_RESEND_S, self.timeout_s / retries)
        resend_s = min(cap, max(DOWNLOAD_RESEND_S, 4 * (time.monotonic() - sent_at)))
        items: list[MissionItem] = []
        while len(items) < count:
            seq = len(items)
            deadline, asked, wait_s = time.monotonic() + self.timeout_s, 0, resend_s
            m = None
            while m is None and time.monotonic() < deadline:
                sent_at = time.monotonic()
                self.send(mav.MAVLink_mission_request_int_message(self.target, 1, seq, mission_type))
                asked += 1
                with contextlib.suppress(LinkTimeoutError):
                    m = self.wait(
                        ("MISSION_ITEM_INT",),
                        timeout_s=min(wait_s, max(0.0, deadline - time.monotonic())),
                        where=lambda m, s=seq: m.seq == s and m.mission_type == mission_type and _to_us(m),
                    )
                wait_s = min(2 * wait_s, cap)
            if m is not None and asked == 1:  # answered at once: this link's round trip now
                resend_s = min(cap, max(DOWNLOAD_RESEND_S, 4 * (time.monotonic() - sent_at)))
            if m is None:
                raise MissionProtocolError(
                    f"mission download: expected item {seq}, received none within {self.timeout_s:g} s "
                    f"({asked} requests)",
                    expected_seq=seq,
                )
            items.append(
                MissionItem(
                    m.seq, m.frame, m.command, m.param1, m.param2, m.param3, m.param4, m.x, m.y, m.z, m.autocontinue
                )
            )
        problem = downloaded_problem(items, mission_type)
        if problem is not None:
            self.send(mav.MAVLink_mission_ack_message(self.target, 1, mav.MAV_MISSION_ERROR, mission_type))
            raise MissionProtocolError(f"{MISSION_TYPES[mission_type]} download: {problem}: not saved")
        self.send(mav.MAVLink_mission_ack_message(self.target, 1, mav.MAV_MISSION_ACCEPTED, mission_type))
        return items

    def clear(self, mission_type: int = mav.MAV_MISSION_TYPE_MISSION) -> None:
        """Clear the vehicle's mission, fence or rally points (MissionProtocolError if it refuses).

        Parameters
        ----------
        mission_type : int
            MAV_MISSION_TYPE: the mission, the fence, the rally points, or ALL.
        """
        t0 = time.monotonic()
        self.send(mav.MAVLink_mission_clear_all_message(self.target, 1, mission_type))
        m = self.wait(("MISSION_ACK",), where=lambda m: m.mission_type == mission_type)
        if m.type != mav.MAV_MISSION_ACCEPTED:
            result = _result_name("MAV_MISSION_RESULT", m.type)
            what = MISSION_TYPES.get(mission_type, "list")
            why = "; ".join(self.said_since(t0))
            raise MissionProtocolError(f"{what} clear refused: {result}" + (f" ({why})" if why else ""), result=result)

    def close(self) -> None:
        """Close the connection."""
        self.port.close()


def _pid(m: Any) -> str:
    return text_field(m.param_id)


def mode_name(custom_mode: int) -> str:
    """The Rover mode's name (``AUTO``), or ``mode N`` for a number Rover does not define."""
    return MODE_NAMES.get(custom_mode, f"mode {custom_mode}")


def _to_us(m: Any) -> bool:
    """A message addressed to this ground station (or to every one)."""
    return m.target_system in (0, GCS_SYSID) and m.target_component in (0, GCS_COMPID)


def downloaded_problem(items: list[MissionItem], mission_type: int) -> str | None:
    """What makes a downloaded list unfit to keep (a value no vehicle stores, which the file it
    is saved to could not be uploaded from), or None.

    A mission's items are checked as an upload's are (:func:`~lfctl.link.mission.validate_item`;
    a command lfctl's vehicles do not take is kept: a real vehicle may); a fence's as Rover
    checks a whole fence; rally points for their place.

    Parameters
    ----------
    items : list of MissionItem
        As downloaded (a mission's item 0 is home).
    mission_type : int
        MAV_MISSION_TYPE of the list.
    """
    if mission_type == MISSION:
        for it in items:
            result = validate_item(it, len(items))
            if result not in (mav.MAV_MISSION_ACCEPTED, mav.MAV_MISSION_UNSUPPORTED):
                return (
                    f"item {it.seq} ({command_name(it.command)}: params {it.param1:g}, {it.param2:g}, {it.param3:g}, "
                    f"{it.param4:g}, at {it.lat_deg:.7f}, {it.lon_deg:.7f}, {it.z:g}) refused by an upload ({_result_name('MAV_MISSION_RESULT', result)})"
                )
        return None
    for it in items:
        if it.frame not in PLACE_FRAMES:
            return f"item {it.seq} ({command_name(it.command)}) is in frame {it.frame}, not a global one"
    if mission_type == FENCE:
        found = validate_fence(items)
        return None if found is None else f"item {found[0]}: {found[2]}"
    for it in items:
        if it.command != RALLY_POINT:
            return f"item {it.seq} ({command_name(it.command)}) is not a rally point"
        if not (on_earth(it.lat_deg, it.lon_deg) and math.isfinite(it.z)):
            return f"item {it.seq}: no place on the Earth ({it.lat_deg}, {it.lon_deg}, {it.z})"
    return None


def text_field(value: str | bytes) -> str:
    """A MAVLink char[] field as text (pymavlink gives bytes or str, NUL-padded), its control
    characters escaped: a peer's STATUSTEXT is shown on terminals (an escape sequence in it
    would clear the screen or retitle the window)."""
    return printable((value.decode(errors="replace") if isinstance(value, bytes) else value).rstrip("\x00"))


@dataclass
class VehicleRow:
    """What a ground station last heard from one vehicle (``None``: not heard yet)."""

    sysid: int  # the vehicle's system id
    mode: str | None = None  # its Rover mode's name (HEARTBEAT)
    armed: bool | None = None  # its HEARTBEAT's safety-armed flag
    lat_deg: float | None = None  # latitude, degrees (GLOBAL_POSITION_INT)
    lon_deg: float | None = None  # longitude, degrees
    speed_mps: float | None = None  # horizontal speed, m/s
    formation: dict[str, float] = field(default_factory=dict)  # the companion's NAMED_VALUE_FLOATs
    text: str = ""  # the last STATUSTEXT
    last_heard_s: float = -math.inf  # when anything last came from it, on the watcher's clock, s
    autopilot: bool = False  # its autopilot (component 1) has sent a HEARTBEAT: a vehicle, not a stray
    north_m: float | None = None  # position north of home, m (LOCAL_POSITION_NED)
    east_m: float | None = None  # position east of home, m
    mission_seq: int | None = None  # the current mission item (MISSION_CURRENT)
    mission_total: int | None = None  # the last item's number (None: the vehicle does not say)


class FleetTable:
    """Every vehicle a ground station hears: mode, arming, position, speed and its
    companion's formation status (``lfctl gcs watch``)."""

    def __init__(self) -> None:
        self.rows: dict[int, VehicleRow] = {}

    def add(self, m: Any, t_s: float) -> None:
        """Take one received message into its vehicle's row.

        Parameters
        ----------
        m : pymavlink message
            Any message; its source system picks the row.
        t_s : float
            When it was heard, on the watcher's clock, s.
        """
        row = self.rows.setdefault(m.get_srcSystem(), VehicleRow(m.get_srcSystem()))
        row.last_heard_s = t_s
        kind = m.get_type()
        if kind == "HEARTBEAT" and m.get_srcComponent() == 1:
            row.autopilot = True
            row.mode = mode_name(m.custom_mode)
            row.armed = bool(m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
        elif kind == "LOCAL_POSITION_NED":
            row.north_m, row.east_m = float(m.x), float(m.y)
        elif kind == "MISSION_CURRENT":
            total, state = int(getattr(m, "total", 0)), int(getattr(m, "mission_state", 0))
            row.mission_seq = int(m.seq)
            # no mission: Rover says total 0 with the state NO_MISSION, the message's definition
            # UINT16_MAX; a MAVLink 1 MISSION_CURRENT (no total, no state) says nothing
            if 0 < total < 0xFFFF:
                row.mission_total = total
            elif total == 0xFFFF or state == mav.MISSION_STATE_NO_MISSION:
                row.mission_total = 0
            else:
                row.mission_total = None
        elif kind == "GLOBAL_POSITION_INT":
            row.lat_deg, row.lon_deg = m.lat / 1e7, m.lon / 1e7
            row.speed_mps = math.hypot(m.vx, m.vy) / 100
        elif kind == "NAMED_VALUE_FLOAT":
            name = text_field(m.name)
            if name in row.formation or len(row.formation) < FORMATION_NAMES_MAX:  # (new names: not without end)
                row.formation[name] = float(m.value)
        elif kind == "STATUSTEXT":
            row.text = text_field(m.text)
