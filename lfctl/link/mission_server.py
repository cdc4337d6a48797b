"""The vehicle side of the MAVLink mission protocol, for the three lists ArduPilot keeps apart:
the MISSION (item 0 is home), the FENCE and the RALLY points.

Upload (MISSION_COUNT, then the vehicle asks for each item with MISSION_REQUEST_INT, with
per-item timeouts and retries, and ends with MISSION_ACK), download (MISSION_REQUEST_LIST,
MISSION_COUNT, MISSION_REQUEST_INT -> MISSION_ITEM_INT), clear (MISSION_CLEAR_ALL) and the
current item. An upload is checked item by item and as a whole before it replaces the list
in force; a refused upload leaves it as it was. No operation on one list touches another.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.link.fence import FENCE_COMMANDS, RALLY_COMMANDS, validate_fence
from lfctl.link.mission import MissionItem, validate_item

__all__ = ["MISSION_TYPES", "ListChange", "MissionServer"]

MISSION, FENCE, RALLY = mav.MAV_MISSION_TYPE_MISSION, mav.MAV_MISSION_TYPE_FENCE, mav.MAV_MISSION_TYPE_RALLY
#: the lists a vehicle keeps, by MAV_MISSION_TYPE
MISSION_TYPES = {MISSION: "mission", FENCE: "fence", RALLY: "rally"}
#: the most items each list takes (ArduPilot's storage on a typical board)
CAPACITY = {MISSION: 2000, FENCE: 200, RALLY: 50}
ITEM_TIMEOUT_S = 0.25
RETRIES = 10  # at 20 % loss each way a round trip fails 36 % of the time


@dataclass
class _Upload:
    mission_type: int
    count: int
    sysid: int
    compid: int
    items: dict[int, MissionItem] = field(default_factory=dict)
    next_seq: int = 0
    sent_at: float = -math.inf
    retries: int = 0


@dataclass(frozen=True)
class ListChange:
    """A list replaced or cleared.

    Parameters
    ----------
    kind : str
        Which list: ``mission``, ``fence`` or ``rally``.
    t_s : float
        When, s.
    sysid, compid : int
        Who changed it (0, 0: the vehicle itself).
    items : int
        How many items it holds now.
    """

    kind: str
    t_s: float
    sysid: int
    compid: int
    items: int


def _item_message(it: MissionItem, sysid: int, compid: int, current: int, mission_type: int) -> Any:
    return mav.MAVLink_mission_item_int_message(
        sysid, compid, it.seq, it.frame, it.command, current, it.autocontinue,
        it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, mission_type,
    )  # fmt: skip


class MissionServer:
    """The three lists and the protocol that changes them.

    Parameters
    ----------
    send : callable
        Sends a MAVLink message from the vehicle.
    statustext : callable
        Tells the ground station a line of text.
    on_change : callable
        Told ``(mission_type, items)`` when a list is replaced, before the ACK goes out.
    """

    def __init__(
        self,
        send: Callable[[Any], None],
        statustext: Callable[[str], None],
        on_change: Callable[[int, list[MissionItem]], None],
    ) -> None:
        self.send = send
        self.statustext = statustext
        self.on_change = on_change
        self.lists: dict[int, list[MissionItem]] = {t: [] for t in MISSION_TYPES}
        self.changes: list[ListChange] = []
        self.current_seq = 0
        self._uploads: dict[int, _Upload] = {}  # by mission type: a fence and a mission may come at once
        self._t_s = 0.0

    # -- helpers ---------------------------------------------------------------------------
    def _ack(self, sysid: int, compid: int, result: int, mission_type: int) -> None:
        self.send(mav.MAVLink_mission_ack_message(sysid, compid, result, mission_type))

    def store(self, mission_type: int, items: list[MissionItem], sysid: int = 0, compid: int = 0) -> None:
        """Make ``items`` the list of this type in force (checked already).

        Parameters
        ----------
        mission_type : int
            MAV_MISSION_TYPE of the list.
        items : list of MissionItem
            The items (a mission's item 0 is home).
        sysid, compid : int
            Who changed it (0: the vehicle itself, e.g. a mission stored at boot).
        """
        self.lists[mission_type] = list(items)
        if mission_type == MISSION:
            self.current_seq = 1 if len(items) > 1 else 0
        self.changes.append(ListChange(MISSION_TYPES[mission_type], self._t_s, sysid, compid, len(items)))
        self.on_change(mission_type, self.lists[mission_type])

    # -- upload ----------------------------------------------------------------------------
    def on_count(self, m: Any, t_s: float) -> None:
        """MISSION_COUNT: an upload starts (0 items: the list is cleared).

        Parameters
        ----------
        m : pymavlink message
            The message as received.
        t_s : float
            Now, s.
        """
        self._t_s = t_s
        mtype, src = _addressed(m)
        if mtype not in MISSION_TYPES:
            self._ack(*src, mav.MAV_MISSION_UNSUPPORTED, mtype)
            return
        if m.count == 0:
            self._uploads.pop(mtype, None)
            self.store(mtype, [], *src)
            self._ack(*src, mav.MAV_MISSION_ACCEPTED, mtype)
            return
        if m.count > CAPACITY[mtype]:
            self._ack(*src, mav.MAV_MISSION_NO_SPACE, mtype)
            self.statustext(f"Mission upload refused: {m.count} items, room for {CAPACITY[mtype]}")
            return
        self._uploads[mtype] = up = _Upload(mtype, m.count, *src)
        self._request_next(up, t_s)

    def _request_next(self, up: _Upload, t_s: float) -> None:
        up.sent_at = t_s
        self.send(mav.MAVLink_mission_request_int_message(up.sysid, up.compid, up.next_seq, up.mission_type))

    def on_item(self, item: MissionItem, mission_type: int, sysid: int, compid: int, t_s: float) -> None:
        """One uploaded item (from MISSION_ITEM_INT, or a converted MISSION_ITEM).

        Parameters
        ----------
        item : MissionItem
            The item.
        mission_type : int
            The list it says it belongs to.
        sysid, compid : int
            Who sent it.
        t_s : float
            Now, s.
        """
        self._t_s = t_s
        up = self._uploads.get(mission_type)
        if up is None or (sysid, compid) != (up.sysid, up.compid):
            return  # not part of an upload this vehicle is running
        if item.seq != up.next_seq:
            self._request_next(up, t_s)  # a duplicate or reordered item: ask again for the one we need
            return
        result = self._check_item(item, up)
        if result != mav.MAV_MISSION_ACCEPTED:
            self._refuse(up, item.seq, result)
            return
        up.items[item.seq] = item
        up.next_seq += 1
        up.retries = 0
        if up.next_seq < up.count:
            self._request_next(up, t_s)
            return
        del self._uploads[mission_type]
        items = [up.items[i] for i in range(up.count)]
        if up.mission_type == FENCE and (bad := validate_fence(items)) is not None:
            self._refuse(up, *bad)
            return
        self.store(up.mission_type, items, up.sysid, up.compid)
        self._ack(up.sysid, up.compid, mav.MAV_MISSION_ACCEPTED, up.mission_type)

    def _check_item(self, item: MissionItem, up: _Upload) -> int:
        if up.mission_type == MISSION:
            return validate_item(item, up.count)
        allowed = FENCE_COMMANDS if up.mission_type == FENCE else RALLY_COMMANDS
        if item.command not in allowed:
            return mav.MAV_MISSION_UNSUPPORTED
        if not (-90.0 <= item.lat_deg <= 90.0):
            return mav.MAV_MISSION_INVALID_PARAM5_X
        if not (-180.0 <= item.lon_deg <= 180.0):
            return mav.MAV_MISSION_INVALID_PARAM6_Y
        return mav.MAV_MISSION_ACCEPTED

    def _refuse(self, up: _Upload, seq: int, result: int) -> None:
        self._uploads.pop(up.mission_type, None)  # the list in force stays as it was
        self._ack(up.sysid, up.compid, result, up.mission_type)
        name = mav.enums["MAV_MISSION_RESULT"][result].name
        self.statustext(f"{MISSION_TYPES[up.mission_type].capitalize()} rejected at item {seq}: {name}")

    def tick(self, t_s: float) -> None:
        """Re-ask for an item that did not come; give up after the retries.

        Parameters
        ----------
        t_s : float
            Now, s.
        """
        self._t_s = t_s
        for mtype, up in list(self._uploads.items()):
            if t_s - up.sent_at <= ITEM_TIMEOUT_S:
                continue
            if up.retries >= RETRIES:
                del self._uploads[mtype]
                self._ack(up.sysid, up.compid, mav.MAV_MISSION_OPERATION_CANCELLED, up.mission_type)
                self.statustext(f"{MISSION_TYPES[mtype].capitalize()} upload timed out waiting for item {up.next_seq}")
            else:
                up.retries += 1
                self._request_next(up, t_s)

    # -- download, clear, current ----------------------------------------------------------
    def on_request_list(self, m: Any) -> None:
        """MISSION_REQUEST_LIST: the count of the list asked for.

        Parameters
        ----------
        m : pymavlink message
            The message as received.
        """
        mtype, src = _addressed(m)
        if mtype not in MISSION_TYPES:
            self._ack(*src, mav.MAV_MISSION_UNSUPPORTED, mtype)
            return
        self.send(mav.MAVLink_mission_count_message(*src, len(self.lists[mtype]), mtype))

    def on_request_item(self, m: Any) -> None:
        """MISSION_REQUEST_INT (or the old MISSION_REQUEST): one item of a download.

        Parameters
        ----------
        m : pymavlink message
            The message as received.
        """
        mtype, src = _addressed(m)
        items = self.lists.get(mtype)
        if items is None:
            self._ack(*src, mav.MAV_MISSION_UNSUPPORTED, mtype)
            return
        if not 0 <= m.seq < len(items):
            self._ack(*src, mav.MAV_MISSION_INVALID_SEQUENCE, mtype)
            return
        it = items[m.seq]
        current = int(mtype == MISSION and it.seq == self.current_seq)
        self.send(_item_message(it, *src, current, mtype))

    def on_clear(self, m: Any, t_s: float) -> None:
        """MISSION_CLEAR_ALL: clear the list named (MAV_MISSION_TYPE_ALL: all three).

        Parameters
        ----------
        m : pymavlink message
            The message as received.
        t_s : float
            Now, s.
        """
        self._t_s = t_s
        mtype, src = _addressed(m)
        if mtype == mav.MAV_MISSION_TYPE_ALL:
            for t in MISSION_TYPES:
                self.store(t, [], *src)
        elif mtype in MISSION_TYPES:
            self.store(mtype, [], *src)
        else:
            self._ack(*src, mav.MAV_MISSION_UNSUPPORTED, mtype)
            return
        self._ack(*src, mav.MAV_MISSION_ACCEPTED, mtype)

    def set_current(self, seq: int) -> bool:
        """Make mission item ``seq`` current (False when there is no such waypoint item).

        Parameters
        ----------
        seq : int
            The item, 1 .. count - 1.
        """
        if not 0 < seq < len(self.lists[MISSION]):
            return False
        self.current_seq = seq
        return True


def _addressed(m: Any) -> tuple[int, tuple[int, int]]:
    """A mission message's list (MISSION when the sender speaks MAVLink 1) and its sender."""
    return getattr(m, "mission_type", MISSION), (m.get_srcSystem(), m.get_srcComponent())
