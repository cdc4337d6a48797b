"""The vehicle side of the MAVLink mission protocol, for the three lists ArduPilot keeps apart:
the MISSION (item 0 is home), the FENCE and the RALLY points.

Upload (MISSION_COUNT, then the vehicle asks for each item with MISSION_REQUEST, as Rover's
MissionItemProtocol asks, and takes MISSION_ITEM_INT, with per-item timeouts and retries, and
ends with MISSION_ACK), download (MISSION_REQUEST_LIST,
MISSION_COUNT, MISSION_REQUEST_INT -> MISSION_ITEM_INT), clear (MISSION_CLEAR_ALL) and the
current item. An upload is checked item by item and as a whole before it replaces the list
in force; a refused upload leaves it as it was (a partial update, MISSION_WRITE_PARTIAL_LIST,
edits the list in place item by item as Rover's does: one refused half way keeps what came).
An item that comes when no upload of its list is under way is MAV_MISSION_ERROR, as Rover
answers it. No operation on one list touches another.

Each list is also a file over MAVLink FTP, as ArduPilot's ``AP_Filesystem_Mission`` serves
it (``@MISSION/mission.dat``, ``fence.dat``, ``rally.dat``; MAVProxy's ``wp ftp``, ``fence
ftp``, ``rally ftp`` and their ``ftpload``): a 10-byte header (magic 0x763d, the
MAV_MISSION_TYPE, options, the first item's number, the number of items, each a
little-endian uint16), then each item as MISSION_ITEM_INT's 38-byte payload. An uploaded file
is checked as an upload by the mission protocol is, item by item and whole, and replaces the
list, or (option 1, "no clear": the mission only) replaces and adds items from its first.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.link.fence import FENCE_COMMANDS, RALLY_COMMANDS, validate_fence
from lfctl.link.mission import (
    PLACE_FRAMES,
    POLYGON_EXCLUSION,
    POLYGON_INCLUSION,
    RAW_XY,
    RETURN_POINT,
    STORES_LOCATION,
    MissionItem,
    as_stored,
    int_as,
    validate_item,
)

__all__ = ["LIST_FILE_MAGIC", "MISSION_TYPES", "ListChange", "MissionServer", "item_result", "list_problem"]

MISSION, FENCE, RALLY = mav.MAV_MISSION_TYPE_MISSION, mav.MAV_MISSION_TYPE_FENCE, mav.MAV_MISSION_TYPE_RALLY
#: the lists a vehicle keeps, by MAV_MISSION_TYPE
MISSION_TYPES = {MISSION: "mission", FENCE: "fence", RALLY: "rally"}
#: the most items each list takes (ArduPilot's storage on a typical board)
CAPACITY = {MISSION: 2000, FENCE: 200, RALLY: 50}
#: an item asked for that has not come is asked for again after this long, s (Rover: 1 s;
#: sooner here, so an upload over a lossy link does not wait a second for each lost packet)
ITEM_TIMEOUT_S = 0.25
#: an upload that has had no item for this long is cancelled (Rover's upload_timeout_ms)
UPLOAD_TIMEOUT_S = 8.0


#: a list file's magic number (``@MISSION/*.dat``), and its header: magic, MAV_MISSION_TYPE,
#: options, the first item's number, the number of items
LIST_FILE_MAGIC = 0x763D
_FILE_HEADER = struct.Struct("<HHHHH")
#: the option that updates the mission from the file's first item on, keeping the rest
NO_CLEAR = 1
#: a list file's item: MISSION_ITEM_INT's payload, in pymavlink's wire order
_ITEM = mav.MAVLink_mission_item_int_message


@dataclass
class _Upload:
    mission_type: int
    count: int  # how many items the list will hold
    sysid: int
    compid: int
    items: dict[int, MissionItem] = field(default_factory=dict)
    next_seq: int = 0
    sent_at: float = -math.inf
    received_at: float = 0.0  # the count, or the last item taken
    #: a partial update (MISSION_WRITE_PARTIAL_LIST) of the list in force, items next_seq..last
    partial: bool = False
    last: int = -1  # the last item asked for (a whole upload: count - 1)


@dataclass(frozen=True)
class ListChange:
    """A list replaced, cleared, or edited in place (a partial update that ended accepted).

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
    edit : bool
        Items changed in place (MISSION_WRITE_PARTIAL_LIST): the same mission, edited.
    """

    kind: str
    t_s: float
    sysid: int
    compid: int
    items: int
    edit: bool = False


#: the frame a downloaded item with a place carries for the frame it was stored in: Rover's
#: AP_Mission::mission_cmd_to_mavlink_int names the altitude frame without the _INT (MAVProxy
#: writes it into the files it saves)
DOWNLOAD_FRAME = {
    mav.MAV_FRAME_GLOBAL_INT: mav.MAV_FRAME_GLOBAL,
    mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: mav.MAV_FRAME_GLOBAL_RELATIVE_ALT,
    mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT: mav.MAV_FRAME_GLOBAL_TERRAIN_ALT,
}


def item_result(item: MissionItem, mission_type: int, count: int) -> int:
    """MAV_MISSION_ACCEPTED, or the MAV_MISSION_* result an upload of ``item`` gets.

    Parameters
    ----------
    item : MissionItem
        One item of the list.
    mission_type : int
        MAV_MISSION_TYPE: the mission, the fence or the rally points.
    count : int
        How many items the list has.
    """
    if mission_type == MISSION:
        return validate_item(item, count)
    if mission_type == FENCE:  # as MissionItemProtocol_Fence's converter: the rest when the list is whole
        if item.frame not in PLACE_FRAMES:
            return mav.MAV_MISSION_UNSUPPORTED_FRAME
        if item.command not in FENCE_COMMANDS:
            return mav.MAV_MISSION_UNSUPPORTED
        if item.command in (POLYGON_INCLUSION, POLYGON_EXCLUSION) and not item.param1 <= 255:
            return mav.MAV_MISSION_INVALID_PARAM1  # (a vertex count is a byte)
        return mav.MAV_MISSION_ACCEPTED
    # as MissionItemProtocol_Rally's converter
    if item.command not in RALLY_COMMANDS:
        return mav.MAV_MISSION_UNSUPPORTED
    if not (-90.0 <= item.lat_deg <= 90.0):
        return mav.MAV_MISSION_INVALID_PARAM5_X
    if not (-180.0 <= item.lon_deg <= 180.0):
        return mav.MAV_MISSION_INVALID_PARAM6_Y
    if not -32768 <= item.z <= 32767:
        return mav.MAV_MISSION_INVALID_PARAM7  # a rally point's altitude is an int16, m
    if item.frame not in PLACE_FRAMES:
        return mav.MAV_MISSION_UNSUPPORTED_FRAME  # a place above sea level, home or the terrain
    return mav.MAV_MISSION_ACCEPTED


def list_problem(items: list[MissionItem], mission_type: int) -> tuple[int, int] | None:
    """The first item an upload of the whole list would be refused at, as (seq,
    MAV_MISSION_RESULT), or None when it would be taken (a list longer than the vehicle has
    room for: the first item past its room, MAV_MISSION_NO_SPACE).

    Parameters
    ----------
    items : list of MissionItem
        The list (a mission's item 0 is home).
    mission_type : int
        MAV_MISSION_TYPE.
    """
    if len(items) > CAPACITY[mission_type]:
        return CAPACITY[mission_type], mav.MAV_MISSION_NO_SPACE  # the first item there is no room for
    for it in items:
        if (result := item_result(it, mission_type, len(items))) != mav.MAV_MISSION_ACCEPTED:
            return it.seq, result
    bad = validate_fence(items) if mission_type == FENCE else None
    return None if bad is None else bad[:2]


def _item_message(
    it: MissionItem, sysid: int, compid: int, current: int, mission_type: int, float_item: bool = False
) -> Any:
    """A downloaded item: MISSION_ITEM_INT, or (``float_item``) the float MISSION_ITEM an old
    client's MISSION_REQUEST gets, its x and y in degrees but for :data:`RAW_XY`'s commands."""
    frame, z = DOWNLOAD_FRAME.get(it.frame, it.frame), it.z
    params = (it.param1, it.param2, it.param3, it.param4)
    if mission_type == FENCE:
        # MissionItemProtocol_Fence: no altitude; param1 what the stored AC_PolyFenceItem
        # keeps (a polygon's vertex count, a byte; a circle's radius; a return point none)
        if it.command in (POLYGON_INCLUSION, POLYGON_EXCLUSION):
            p1 = int_as(it.param1, 0, 255)
        else:
            p1 = 0.0 if it.command == RETURN_POINT else it.param1
        frame, z, params = mav.MAV_FRAME_GLOBAL, 0.0, (p1, 0.0, 0.0, 0.0)
    elif mission_type == RALLY:
        # MissionItemProtocol_Rally: a place and its altitude alone, whole metres (an int16)
        z, params = int_as(it.z, -32768, 32767), (0.0, 0.0, 0.0, 0.0)
    elif it.command not in STORES_LOCATION:
        frame = mav.MAV_FRAME_GLOBAL  # the others (DO_CHANGE_SPEED, DO_JUMP, ...), as Rover's
    # Rover's mission items always continue; a fence's or a rally point's item is built
    # afresh, autocontinue 0
    head = (sysid, compid, it.seq, frame, it.command, current, int(mission_type == MISSION), *params)
    if not float_item:
        return mav.MAVLink_mission_item_int_message(*head, it.x, it.y, z, mission_type)
    scale = 1.0 if it.command in RAW_XY else 1e-7
    return mav.MAVLink_mission_item_message(*head, it.x * scale, it.y * scale, z, mission_type)


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
    on_edit : callable, optional
        Told ``(mission_type, items)`` when items of a list are changed in place (a partial
        update: the mission's and the rally points' as each item comes, the fence's once
        the last has come); the list is the same object, edited.
    running : callable, optional
        Whether the mission is being flown (AUTO): it cannot be cleared then, as on Rover.
    home : callable, optional
        Home now, as item 0 (:func:`~lfctl.link.mission.home_item`): a mission download's
        item 0, as Rover answers it whatever was uploaded as item 0.
    on_received : callable, optional
        Told ``mission_type`` when an upload of a list ends accepted (a whole one, one of no
        items, or a partial update), before the ACK goes out: where Rover's
        ``MissionItemProtocol::complete`` speaks (a MISSION_CLEAR_ALL is not an upload).
    nav_index : callable, optional
        The current navigation command's item number (MISSION_CURRENT's seq; 0: none); a
        downloaded mission item's ``current`` is 1 where its command id equals it, as Rover
        sets it (default: the current item).
    """

    def __init__(
        self,
        send: Callable[[Any], None],
        statustext: Callable[[str], None],
        on_change: Callable[[int, list[MissionItem]], None],
        running: Callable[[], bool] | None = None,
        home: Callable[[], MissionItem] | None = None,
        on_edit: Callable[[int, list[MissionItem]], None] | None = None,
        on_received: Callable[[int], None] | None = None,
        nav_index: Callable[[], int] | None = None,
    ) -> None:
        self.send = send
        self.statustext = statustext
        self.on_change = on_change
        self.on_edit = on_edit or (lambda mission_type, items: None)
        self.on_received = on_received or (lambda mission_type: None)
        self.running = running or (lambda: False)
        self.home = home
        self.nav_index = nav_index or (lambda: self.current_seq)
        self.lists: dict[int, list[MissionItem]] = {t: [] for t in MISSION_TYPES}
        self._revision = 0  # bumps when a list's items change (a file's items are packed again)
        self._packed: dict[int, tuple[tuple[int, ...], bytes]] = {}  # each list's items as a file's, past home
        self.changes: list[ListChange] = []
        self.current_seq = 0
        self._uploads: dict[int, _Upload] = {}  # by mission type: a fence and a mission may come at once
        self._t_s = 0.0
        # Rover's warnings about the float messages said since each list's upload last began
        self._warned: dict[int, set[str]] = {t: set() for t in MISSION_TYPES}

    # -- helpers ---------------------------------------------------------------------------
    def warn_float(self, mission_type: int, text: str) -> None:
        """Rover's warning that a client used a float message (MISSION_ITEM, MISSION_REQUEST)
        where the ``_INT`` one is meant: once until an upload of the list begins again
        (``MissionItemProtocol``'s ``mission_item_warning_sent``, ``mission_request_warning_sent``).

        Parameters
        ----------
        mission_type : int
            MAV_MISSION_TYPE of the list.
        text : str
            The warning.
        """
        warned = self._warned.get(mission_type)
        if warned is not None and text not in warned:
            warned.add(text)
            self.statustext(text)

    def _begin(self, up: _Upload) -> None:
        """An upload (or a partial one) begins: it is asked for its first item."""
        self._uploads[up.mission_type] = up
        self._warned[up.mission_type].clear()
        self._request_next(up, up.received_at)

    def _ack(self, sysid: int, compid: int, result: int, mission_type: int) -> None:
        self.send(mav.MAVLink_mission_ack_message(sysid, compid, result, mission_type))

    def store(
        self, mission_type: int, items: list[MissionItem], sysid: int = 0, compid: int = 0, uploaded: bool = False
    ) -> None:
        """Make ``items`` the list of this type in force (checked already).

        Parameters
        ----------
        mission_type : int
            MAV_MISSION_TYPE of the list.
        items : list of MissionItem
            The items (a mission's item 0 is home).
        sysid, compid : int
            Who changed it (0: the vehicle itself, e.g. a mission stored at boot).
        uploaded : bool
            A ground station's upload (the mission protocol's or MAVLink FTP's): as on a
            Rover, whose upload writes the items over the old ones (``AP_Mission::truncate``,
            ``replace_cmd``, ``add_cmd``), the mission item under way stays the one of that
            number; else (a clear, a mission stored at boot) no item is under way.
        """
        self.lists[mission_type] = [as_stored(it) for it in items] if mission_type == MISSION else list(items)
        self._revision += 1
        if mission_type == MISSION and not uploaded:
            self.current_seq = 0  # no item under way (AUTO starts at item 1)
        self.changes.append(ListChange(MISSION_TYPES[mission_type], self._t_s, sysid, compid, len(items)))
        self.on_change(mission_type, self.lists[mission_type])

    def _uploading(self, mission_type: int, src: tuple[int, int]) -> bool:
        """An upload of this list is running (for anyone): refuse ``src`` what would clash
        with it, as Rover does (MAV_MISSION_DENIED)."""
        if mission_type not in self._uploads:
            return False
        self._ack(*src, mav.MAV_MISSION_DENIED, mission_type)
        return True

    # -- upload ----------------------------------------------------------------------------
    def _may_upload(self, mtype: int, src: tuple[int, int]) -> bool:
        """Whether ``src`` may start an upload of this list now; if not, it is told why: a
        list type there is none of (MAV_MISSION_UNSUPPORTED), or another's upload of it
        under way (MAV_MISSION_DENIED); its own may start again."""
        if mtype not in MISSION_TYPES:
            self._ack(*src, mav.MAV_MISSION_UNSUPPORTED, mtype)
            return False
        up = self._uploads.get(mtype)
        if up is not None and (up.sysid, up.compid) != src:
            self._ack(*src, mav.MAV_MISSION_DENIED, mtype)
            return False
        return True

    def on_count(self, m: Any, t_s: float) -> None:
        """MISSION_COUNT: an upload starts (0 items: the list is cleared). While one runs, its
        sender may start again; anyone else is refused (MAV_MISSION_DENIED) until it ends.

        Parameters
        ----------
        m : pymavlink message
            The message as received.
        t_s : float
            Now, s.
        """
        self._t_s = t_s
        mtype, src = _addressed(m)
        if not self._may_upload(mtype, src):
            return
        if m.count == 0:
            # as Rover: an upload with nothing to ask for is complete at once (and said so)
            self._uploads.pop(mtype, None)
            self.store(mtype, [], *src, uploaded=True)
            self.on_received(mtype)
            self._ack(*src, mav.MAV_MISSION_ACCEPTED, mtype)
            return
        if m.count > CAPACITY[mtype]:
            # the text first: a client that reads the vehicle's texts once it has the NACK finds it
            self.statustext(
                f"{MISSION_TYPES[mtype].capitalize()} upload refused: {m.count} items, room for {CAPACITY[mtype]}"
            )
            self._ack(*src, mav.MAV_MISSION_NO_SPACE, mtype)
            return
        self._begin(_Upload(mtype, m.count, *src, received_at=t_s, last=m.count - 1))

    def _request_next(self, up: _Upload, t_s: float) -> None:
        """Ask for the next item. As Rover's ``MissionItemProtocol::queued_request_send``:
        with MISSION_REQUEST (40), which ArduPilot's ground stations (MAVProxy, MAVSDK for an
        ArduPilot vehicle, QGroundControl) answer with MISSION_ITEM_INT, taken without a word."""
        up.sent_at = t_s
        self.send(mav.MAVLink_mission_request_message(up.sysid, up.compid, up.next_seq, up.mission_type))

    def on_write_partial(self, m: Any, t_s: float) -> None:
        """MISSION_WRITE_PARTIAL_LIST: items ``start_index`` .. ``end_index`` of a list are
        uploaded again (MAVProxy's ``wp changealt``, ``wp move``, ``wp update``), each
        replacing the item there, or added at the end when its number is the list's count. As
        Rover: a range past the list's end, or backwards, is "Flight plan update rejected" and
        MAV_MISSION_ERROR; while another's upload runs, MAV_MISSION_DENIED. The items are
        checked as an upload's; each is in force as it comes, as Rover writes it (the fence's
        once the last has come and the polygon checks), and an update that stops half way keeps
        what came; a mission's current item stays.

        Parameters
        ----------
        m : pymavlink message
            The message as received.
        t_s : float
            Now, s.
        """
        self._t_s = t_s
        mtype, src = _addressed(m)
        if not self._may_upload(mtype, src):
            return
        base = self.lists[mtype]
        first, last = m.start_index, m.end_index
        if not 0 <= first <= last <= len(base):  # Rover reads the int16 indexes as unsigned
            self.statustext(f"Flight plan update rejected: items {first}..{last} of {len(base)}")
            self._ack(*src, mav.MAV_MISSION_ERROR, mtype)
            return
        if last >= CAPACITY[mtype]:
            self._ack(*src, mav.MAV_MISSION_NO_SPACE, mtype)
            return
        count = max(len(base), last + 1)
        self._begin(_Upload(mtype, count, *src, next_seq=first, received_at=t_s, partial=True, last=last))

    def on_item(self, item: MissionItem, mission_type: int, sysid: int, compid: int, t_s: float) -> None:
        """One uploaded item (from MISSION_ITEM_INT, or a converted MISSION_ITEM). As Rover's
        GCS_MAVLINK::handle_mission_item: an item of a list there is none of is
        MAV_MISSION_UNSUPPORTED, and one that comes when no upload of its list is under way
        MAV_MISSION_ERROR, nothing changed (so is the last item sent again after its upload
        ended: ArduPilot has no special case for it, its ACK is not sent again).

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
        if mission_type not in MISSION_TYPES:
            self._ack(sysid, compid, mav.MAV_MISSION_UNSUPPORTED, mission_type)
            return
        up = self._uploads.get(mission_type)
        if up is None:
            self._ack(sysid, compid, mav.MAV_MISSION_ERROR, mission_type)  # not part of an upload
            return
        if (sysid, compid) != (up.sysid, up.compid):
            self._ack(sysid, compid, mav.MAV_MISSION_DENIED, mission_type)  # another's upload
            return
        if item.seq > up.next_seq:
            # an item not asked for yet: Rover's answer; the upload goes on
            self._ack(sysid, compid, mav.MAV_MISSION_INVALID_SEQUENCE, mission_type)
            return
        if item.seq < up.next_seq:
            self._request_next(up, t_s)  # a duplicate (our request was lost): ask again for the next
            return
        result = self._check_item(item, up)
        if result != mav.MAV_MISSION_ACCEPTED:
            self._refuse(up, item.seq, result)
            return
        up.items[item.seq] = item
        up.next_seq += 1
        up.received_at = t_s
        if up.partial and up.mission_type != FENCE:
            self._edit(up.mission_type, {item.seq: item})  # as Rover's replace_item: in force at once
        if up.next_seq <= up.last:
            self._request_next(up, t_s)
            return
        del self._uploads[mission_type]
        if up.partial:
            self._finish_partial(up)
            return
        items = [up.items[i] for i in range(up.count)]
        if up.mission_type == FENCE and (bad := validate_fence(items)) is not None:
            self._refuse_fence(up, bad)
            return
        self.store(up.mission_type, items, up.sysid, up.compid, uploaded=True)
        self.on_received(up.mission_type)
        self._ack(up.sysid, up.compid, mav.MAV_MISSION_ACCEPTED, up.mission_type)

    def _edit(self, mission_type: int, items: dict[int, MissionItem]) -> None:
        """Items of a list changed in place (each replacing the one at its number, or added
        at the end): the same list object, so the mission being flown is the same mission,
        edited (its DO_JUMP counts, its state and its number stay, as Rover's replace_cmd
        leaves them); a mission's items as Rover keeps them (:func:`as_stored`), as
        :meth:`store` keeps a whole list."""
        held = self.lists[mission_type]
        _put(held, {k: as_stored(it) for k, it in items.items()} if mission_type == MISSION else items)
        self._revision += 1
        self.on_edit(mission_type, held)

    def _finish_partial(self, up: _Upload) -> None:
        """A partial update's last item came: the fence's items are checked whole and put in
        force now; the update is ACCEPTED and, ending so, counted as an edit of the list (one
        that stops half way keeps what came, as Rover's, but is no accepted change)."""
        if up.mission_type == FENCE:  # the fence in force is as it was when the update began
            whole = list(self.lists[FENCE])
            _put(whole, up.items)
            if (bad := validate_fence(whole)) is not None:
                self._refuse_fence(up, bad)
                return
            self._edit(FENCE, up.items)
        held = self.lists[up.mission_type]
        self.changes.append(ListChange(MISSION_TYPES[up.mission_type], self._t_s, up.sysid, up.compid, len(held), True))
        self.on_received(up.mission_type)
        self._ack(up.sysid, up.compid, mav.MAV_MISSION_ACCEPTED, up.mission_type)

    def _check_item(self, item: MissionItem, up: _Upload) -> int:
        return item_result(item, up.mission_type, up.count)

    def _refuse_fence(self, up: _Upload, bad: tuple[int, int, str]) -> None:
        """A whole fence refused (:func:`validate_fence`): Rover's words for the problem, then
        its verdict (AC_PolyFence_loader::write_fence's)."""
        seq, result, why = bad
        self._refuse(up, seq, result, why, "Fence validation failed")

    def _refuse(self, up: _Upload, seq: int, result: int, *texts: str) -> None:
        self._uploads.pop(up.mission_type, None)  # the list in force stays as it was
        for text in texts:  # what the vehicle says of the problem, before the NACK
            self.statustext(text)
        name = mav.enums["MAV_MISSION_RESULT"][result].name
        self.statustext(f"{MISSION_TYPES[up.mission_type].capitalize()} rejected at item {seq}: {name}")
        self._ack(up.sysid, up.compid, result, up.mission_type)

    def tick(self, t_s: float) -> None:
        """Re-ask for an item that did not come; cancel an upload that has had none for
        :data:`UPLOAD_TIMEOUT_S` (MAV_MISSION_OPERATION_CANCELLED).

        Parameters
        ----------
        t_s : float
            Now, s.
        """
        self._t_s = t_s
        for mtype, up in list(self._uploads.items()):
            if t_s - up.received_at > UPLOAD_TIMEOUT_S:
                del self._uploads[mtype]
                self._ack(up.sysid, up.compid, mav.MAV_MISSION_OPERATION_CANCELLED, up.mission_type)
                # Rover's words ("Mission upload timeout"), then which item did not come
                self.statustext(
                    f"{MISSION_TYPES[mtype].capitalize()} upload timeout: item {up.next_seq} "
                    f"did not come in {UPLOAD_TIMEOUT_S:g} s"
                )
            elif t_s - up.sent_at > ITEM_TIMEOUT_S:
                self._request_next(up, t_s)

    # -- the lists as files (MAVLink FTP) --------------------------------------------------
    def packed(self, mission_type: int) -> bytes:
        """The list as its ``@MISSION`` file (the module's docstring gives the format): each
        item as a download gives it (the mission's item 0 is home now), addressed to no one.

        Parameters
        ----------
        mission_type : int
            MAV_MISSION_TYPE of the list.
        """
        items = self.lists[mission_type]
        live_home = mission_type == MISSION and self.home is not None and bool(items)
        nav = self.nav_index()
        key = (self._revision, nav, len(items))
        cached = self._packed.get(mission_type)
        if cached is None or cached[0] != key:  # (a full mission takes ~7 ms to pack: not on each open)
            cached = key, b"".join(self._packed_item(it, mission_type, nav) for it in items[live_home:])
            self._packed[mission_type] = cached
        head = _FILE_HEADER.pack(LIST_FILE_MAGIC, mission_type, 0, 0, len(items))
        home = self._packed_item(self.home(), mission_type, nav) if live_home and self.home else b""
        return head + home + cached[1]

    def _packed_item(self, it: MissionItem, mission_type: int, nav: int) -> bytes:
        current = int(mission_type == MISSION and it.command == nav)  # as a download's (``nav``: nav_index())
        m = _item_message(it, 0, 0, current, mission_type)
        return _ITEM.unpacker.pack(*(getattr(m, f) for f in _ITEM.ordered_fieldnames))

    def packed_size(self, mission_type: int) -> int:
        """The size of the list's file (:meth:`packed`), bytes.

        Parameters
        ----------
        mission_type : int
            MAV_MISSION_TYPE of the list.
        """
        return _FILE_HEADER.size + len(self.lists[mission_type]) * _ITEM.unpacker.size

    def upload_packed(self, mission_type: int, data: bytes, sysid: int, compid: int, t_s: float) -> str | None:
        """Take an uploaded ``@MISSION`` file: the list it holds replaces the list in force
        (or, with the "no clear" option, updates the mission from its first item), checked as
        an upload by the mission protocol is. Returns None when it was taken, else why not
        (nothing changed).

        Parameters
        ----------
        mission_type : int
            MAV_MISSION_TYPE of the file written.
        data : bytes
            The file.
        sysid, compid : int
            Who wrote it.
        t_s : float
            Now, s.
        """
        self._t_s = t_s
        name = MISSION_TYPES[mission_type]
        if len(data) < _FILE_HEADER.size:
            return f"{len(data)} bytes, fewer than the header's {_FILE_HEADER.size}"
        magic, dtype, options, start, count = _FILE_HEADER.unpack_from(data)
        size = _ITEM.unpacker.size
        if magic != LIST_FILE_MAGIC:
            return f"magic 0x{magic:04x}, not 0x{LIST_FILE_MAGIC:04x}"
        if dtype != mission_type:
            return f"its header is for list type {dtype}, the file is the {name}'s ({mission_type})"
        if options & ~NO_CLEAR:
            return f"options 0x{options:x}: only 0x{NO_CLEAR:x} (no clear) is known"
        if len(data) != _FILE_HEADER.size + count * size:
            return f"the header gives {count} items, the file has {len(data) - _FILE_HEADER.size} bytes after it, not {count * size}"
        if mission_type in self._uploads:
            return f"an upload of the {name} by the mission protocol is under way"
        items = []
        for i in range(count):
            raw = data[_FILE_HEADER.size + i * size : _FILE_HEADER.size + (i + 1) * size]
            if not any(raw):
                return f"item {start + i} is all zeros (the file was not written whole)"
            f = dict(zip(_ITEM.ordered_fieldnames, _ITEM.unpacker.unpack(raw), strict=True))
            items.append(
                MissionItem(start + i, f["frame"], f["command"], f["param1"], f["param2"], f["param3"], f["param4"],
                            f["x"], f["y"], f["z"], f["autocontinue"])
            )  # fmt: skip
        if options & NO_CLEAR:
            if mission_type != MISSION:
                return f"the {name} is only replaced whole (no clear is for the mission)"
            held = self.lists[MISSION]
            if start > len(held):
                return f"its first item {start} is past the mission's end ({len(held)} items)"
            whole = list(held)
            _put(whole, {it.seq: it for it in items})
            if (why := _list_refusal(whole, MISSION)) is not None:
                return why
            self._edit(MISSION, {it.seq: it for it in items})
            self.changes.append(ListChange(name, t_s, sysid, compid, len(held), True))
        else:
            if start:
                return f"its first item is {start}: a whole {name} starts at 0 (or give the no-clear option)"
            if (why := _list_refusal(items, mission_type)) is not None:
                return why
            self.store(mission_type, items, sysid, compid, uploaded=True)
        self.on_received(mission_type)
        return None

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
        if self._uploading(mtype, src):
            return
        self.send(mav.MAVLink_mission_count_message(*src, len(self.lists[mtype]), mtype))

    def on_request_item(self, m: Any, float_item: bool = False) -> None:
        """MISSION_REQUEST_INT (or the old MISSION_REQUEST): one item of a download.

        Parameters
        ----------
        m : pymavlink message
            The message as received.
        float_item : bool
            Answer with the float MISSION_ITEM (the old MISSION_REQUEST's answer, as Rover's).
        """
        mtype, src = _addressed(m)
        items = self.lists.get(mtype)
        if items is None:
            self._ack(*src, mav.MAV_MISSION_UNSUPPORTED, mtype)
            return
        if self._uploading(mtype, src):
            return
        if not 0 <= m.seq < len(items):
            if not float_item:  # as Rover, the count first, "to educate the GCS" (not for MISSION_REQUEST)
                self.send(mav.MAVLink_mission_count_message(*src, len(items), mtype))
            self._ack(*src, mav.MAV_MISSION_INVALID_SEQUENCE, mtype)
            return
        if float_item:
            self.warn_float(mtype, "got MISSION_REQUEST; use MISSION_REQUEST_INT!")
        it = items[m.seq]
        if mtype == MISSION and m.seq == 0 and self.home is not None:
            it = self.home()  # as Rover's AP_Mission reads item 0: home now
        # as Rover's MissionItemProtocol_Waypoints::get_item: 1 where the item's command id
        # equals the current navigation command's index (not its seq), so almost never
        current = int(mtype == MISSION and it.command == self.nav_index())
        self.send(_item_message(it, *src, current, mtype, float_item))

    def on_clear(self, m: Any, t_s: float) -> None:
        """MISSION_CLEAR_ALL: clear the list named (MAV_MISSION_TYPE_ALL is no list: as Rover,
        MAV_MISSION_UNSUPPORTED and nothing cleared).

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
        # as Rover: not while it is being uploaded, nor the mission while it is flown
        # (MAV_MISSION_ERROR; nothing is cleared)
        flown = mtype == MISSION and self.running()
        if flown or mtype in self._uploads:
            self._ack(*src, mav.MAV_MISSION_ERROR, mtype)
            if flown:
                self.statustext("Mission is running: not cleared")
            return
        self.store(mtype, [], *src)
        self._ack(*src, mav.MAV_MISSION_ACCEPTED, mtype)

    @property
    def mission_number(self) -> int:
        """How many times the mission list has been stored (replaced or cleared): which
        mission is in force, 1 for the first."""
        return sum(1 for c in self.changes if c.kind == "mission" and not c.edit)

    def restart(self) -> None:
        """The autopilot restarted: an upload under way is lost (its ground station times
        out) and the mission starts again from its first item; the lists stay."""
        self._uploads.clear()
        self.current_seq = 0  # no item under way until AUTO starts the mission at item 1

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


def _list_refusal(items: list[MissionItem], mission_type: int) -> str | None:
    """Why a whole list would be refused (:func:`list_problem`; a fence's with Rover's
    words), or None."""
    problem = list_problem(items, mission_type)
    if problem is None:
        return None
    seq, result = problem
    why = f"item {seq}: {mav.enums['MAV_MISSION_RESULT'][result].name}"
    bad = validate_fence(items) if mission_type == FENCE else None
    return why if bad is None or bad[0] != seq else f"{why} ({bad[2]})"


def _put(held: list[MissionItem], items: dict[int, MissionItem]) -> None:
    """``items`` into ``held`` by number: each replaces the one there, or comes at the end."""
    for seq in sorted(items):
        if seq < len(held):
            held[seq] = items[seq]
        else:
            held.append(items[seq])


def _addressed(m: Any) -> tuple[int, tuple[int, int]]:
    """A mission message's list (MISSION when the sender speaks MAVLink 1) and its sender."""
    return getattr(m, "mission_type", MISSION), (m.get_srcSystem(), m.get_srcComponent())
