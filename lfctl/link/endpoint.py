"""A simulated vehicle as an ArduPilot-Rover-compatible MAVLink endpoint.

HEARTBEAT (GROUND_ROVER, ARDUPILOTMEGA, Rover mode numbers), streamed telemetry at rates a
ground station may change (SET_MESSAGE_INTERVAL), REQUEST_MESSAGE, COMMAND_LONG/INT with
COMMAND_ACK, parameters with real effect, the mission protocol (*_INT, mission_type MISSION:
upload with per-item timeouts and retries, download, clear, set current), GUIDED setpoints
from a companion (SET_POSITION_TARGET_LOCAL_NED, BODY_NED, type_mask 1479) with a timeout,
and failsafes (GCS heartbeat lost -> HOLD; companion silent -> stop). Time comes in as
``t_s``; bytes go out through the link it is given.
"""

from __future__ import annotations

import base64
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.frames import ned_to_geodetic, wrap_pi
from lfctl.link.mission import MissionItem, validate_item
from lfctl.link.port import pack_next
from lfctl.link.signing import setup_signing

__all__ = [
    "COMPANION_COMPID",
    "GCS_COMPID",
    "MODES",
    "MODE_NAMES",
    "TYPE_MASK_SPEED_YAWRATE",
    "LinkStats",
    "Param",
    "VehicleEndpoint",
    "packet_record",
]

log = logging.getLogger(__name__)

#: ArduPilot Rover custom mode numbers by name (the modes the endpoint knows)
MODES = {"MANUAL": 0, "HOLD": 4, "FOLLOW": 6, "AUTO": 10, "GUIDED": 15}
MODE_NAMES = {v: k for k, v in MODES.items()}
#: component ids: a ground station (MAV_COMP_ID_MISSIONPLANNER) and a companion computer
GCS_COMPID = 190
COMPANION_COMPID = 191
#: SET_POSITION_TARGET_LOCAL_NED type_mask using only the velocity and the yaw rate
TYPE_MASK_SPEED_YAWRATE = 1479
MISSION_ITEM_TIMEOUT_S = 0.25
MISSION_RETRIES = 10  # at 20 % loss each way a round trip fails 36 % of the time

#: default stream rates (Hz), as ArduPilot's SRx_ parameters would set them
STREAMS = {
    "HEARTBEAT": 1.0,
    "SYS_STATUS": 1.0,
    "GPS_RAW_INT": 5.0,
    "GLOBAL_POSITION_INT": 10.0,
    "LOCAL_POSITION_NED": 10.0,
    "ATTITUDE": 10.0,
    "MISSION_CURRENT": 1.0,
    "HOME_POSITION": 0.5,
}
MSG_IDS = {name: getattr(mav, f"MAVLINK_MSG_ID_{name}") for name in (*STREAMS, "AUTOPILOT_VERSION", "PARAM_VALUE")}
ID_NAMES = {v: k for k, v in MSG_IDS.items()}


@dataclass
class Param:
    """A vehicle parameter.

    Parameters
    ----------
    value : float
        Its value now, in ``unit``.
    lo, hi : float
        The range a ground station may set it within, in ``unit``.
    unit : str
        Its unit as a ground station shows it (``""`` for none).
    description : str
        What it does.
    readonly : bool
        Refuse any set.
    """

    value: float
    lo: float
    hi: float
    unit: str
    description: str
    readonly: bool = False


def default_params(sysid: int) -> dict[str, Param]:
    """Parameters with real effect, ArduPilot names where ArduPilot has one (``LFC_*`` are
    lfctl's formation slot).

    Parameters
    ----------
    sysid : int
        This vehicle's system id (``SYSID_THISMAV``).
    """
    return {
        "SYSID_THISMAV": Param(sysid, 1, 255, "", "this vehicle's MAVLink system id", readonly=True),
        "WP_SPEED": Param(0.3, 0.05, 2.0, "m/s", "AUTO cruise speed"),
        "WP_RADIUS": Param(0.3, 0.05, 10.0, "m", "waypoint acceptance radius"),
        "CRUISE_SPEED": Param(0.5, 0.05, 2.0, "m/s", "speed limit in AUTO and GUIDED"),
        "GUID_TIMEOUT": Param(1.0, 0.1, 10.0, "s", "GUIDED: stop when no setpoint arrives for this long"),
        "FS_GCS_ENABLE": Param(1, 0, 1, "", "1: HOLD when the ground station's heartbeat is lost"),
        "FS_GCS_TIMEOUT": Param(5.0, 1.0, 60.0, "s", "ground station heartbeat timeout"),
        "LFC_RANGE": Param(1.5, 0.3, 10.0, "m", "formation: commanded range to the target"),
        "LFC_BEARING": Param(0.0, -180.0, 180.0, "deg", "formation: commanded bearing to the target"),
        "LFC_COAST": Param(2.0, 0.0, 10.0, "s", "formation: coast this long on the filter when the target is hidden"),
    }


@dataclass
class LinkStats:
    """What an endpoint has read from its link."""

    datagrams: int = 0  # datagrams read
    messages: int = 0  # messages parsed and dispatched
    bad: int = 0  # garbage, truncated frames, bad CRC
    other_sysid: int = 0  # addressed to another vehicle
    unknown: int = 0  # message ids we do not handle


@dataclass
class _Upload:
    count: int
    items: dict[int, MissionItem] = field(default_factory=dict)
    next_seq: int = 0
    sent_at: float = -math.inf
    retries: int = 0
    sysid: int = 0
    compid: int = 0


class VehicleEndpoint:
    """One vehicle's MAVLink face. Feed it datagrams with :meth:`receive`, call :meth:`tick`.

    Parameters
    ----------
    name : str
        The vehicle's name (in logs).
    sysid : int
        Its MAVLink system id; the autopilot is component 1.
    link : DatagramLink
        Where its bytes go and come from (a UDP, in-memory or fan-out link).
    home : (lat_deg, lon_deg, alt_m)
        The local NED frame's origin, for global positions and missions.
    mode : str
        The Rover mode to start in (a key of :data:`MODES`).
    armed : bool
        Start armed.
    tap : callable, optional
        Sees every packet: ``tap(direction, msg, raw)`` with ``"in"`` or ``"out"``, the
        pymavlink message and its bytes (the recorder).
    signing_key : bytes, optional
        MAVLink 2 signing key: sign what is sent, and accept only signed packets except from
        the in-memory link.
    """

    def __init__(
        self,
        name: str,
        sysid: int,
        link: Any,
        home: tuple[float, float, float],
        *,
        mode: str = "HOLD",
        armed: bool = False,
        tap: Callable[[str, Any, bytes], None] | None = None,
        signing_key: bytes | None = None,
    ) -> None:
        self.name = name
        self.sysid = sysid
        self.link = link
        self.home = home
        self.mav = mav.MAVLink(None, srcSystem=sysid, srcComponent=1)
        self.mav.robust_parsing = True
        self._signing_key = signing_key
        self.parser = self._parser(None)
        self.signed_parser: Any = None
        if signing_key is not None:
            # MAVLink 2 signing for the links that leave the machine (UDP): sign what we send,
            # accept only correctly signed packets from there; the in-memory companion link
            # stays unsigned
            setup_signing(self.mav, signing_key)
            self.signed_parser = self._parser(signing_key)
        self.mode = MODES[mode]
        self.armed = armed
        self.params = default_params(sysid)
        self.mission: list[MissionItem] = []
        self.mission_version = 0  # bumps when the mission or the current item changes
        self.current_seq = 0
        self.stats = LinkStats()
        self.tap = tap
        self.statustexts: list[tuple[float, str]] = []
        self._intervals = {MSG_IDS[name]: 1.0 / rate for name, rate in STREAMS.items()}
        self._next_due: dict[int, float] = {}
        self._once: list[int] = []
        self._upload: _Upload | None = None
        self._download_to: tuple[int, int] | None = None
        self._setpoint: tuple[float, float, float] | None = None  # t, speed, yaw rate
        self._gcs_seen: float | None = None
        self._guided_stale_reported = False
        self._gcs_failsafe = False
        self.t_s = 0.0
        self.forward: Callable[[bytes], None] | None = None  # routes companion reports to the GCS
        self.state: dict[str, float] = {
            "north_m": 0.0,
            "east_m": 0.0,
            "yaw_rad": 0.0,
            "speed_mps": 0.0,
            "yaw_rate_radps": 0.0,
        }

    @staticmethod
    def _parser(signing_key: bytes | None) -> Any:
        p = mav.MAVLink(None)
        p.robust_parsing = True
        if signing_key is not None:
            setup_signing(p, signing_key)
        return p

    # -- outgoing --------------------------------------------------------------------------
    def send(self, msg: Any) -> None:
        """Send one message from the autopilot (component 1).

        Parameters
        ----------
        msg : pymavlink message
            The message.
        """
        data = pack_next(msg, self.mav)
        self.link.send(data)
        if self.tap is not None:
            self.tap("out", msg, data)

    def statustext(self, text: str, severity: int = mav.MAV_SEVERITY_WARNING) -> None:
        """A STATUSTEXT a ground station shows (also logged, and kept in :attr:`statustexts`).

        Parameters
        ----------
        text : str
            The line; cut to 50 bytes.
        severity : int
            MAV_SEVERITY (default WARNING).
        """
        self.statustexts.append((self.t_s, text))
        log.log(logging.WARNING if severity <= mav.MAV_SEVERITY_WARNING else logging.INFO, "%s: %s", self.name, text)
        self.send(mav.MAVLink_statustext_message(severity, text.encode()[:50]))

    def param(self, name: str) -> float:
        """A parameter's value now.

        Parameters
        ----------
        name : str
            The parameter (KeyError for an unknown one).
        """
        return self.params[name].value

    # -- incoming --------------------------------------------------------------------------
    def receive(self) -> int:
        """Read and handle every datagram waiting on the link; returns messages handled."""
        n = 0
        for data, addr in self.link.recv():
            self.stats.datagrams += 1
            parser = self.signed_parser if (self.signed_parser is not None and addr[0] != "memory") else self.parser
            msgs = parser.parse_buffer(data) or []
            good = [m for m in msgs if m.get_type() != "BAD_DATA"]
            self.stats.bad += len(msgs) - len(good)
            if not good and not msgs:
                self.stats.bad += 1  # a fragment (or a rejected, unsigned packet): drop it
                if parser is self.signed_parser:
                    self.signed_parser = self._parser(self._signing_key)
                    # keep the replay protection: streams' last timestamps and our clock
                    self.signed_parser.signing.stream_timestamps = parser.signing.stream_timestamps
                    self.signed_parser.signing.timestamp = parser.signing.timestamp
                else:
                    self.parser = self._parser(None)
            if good:
                self.link.accept_peer(addr)
            for m in good:
                if self.tap is not None:
                    self.tap("in", m, bytes(m.get_msgbuf()))
                self._dispatch(m)
                n += 1
        return n

    def _for_me(self, m: Any, field: str = "target_system") -> bool:
        target = getattr(m, field, self.sysid)
        if target not in (0, self.sysid):
            self.stats.other_sysid += 1
            return False
        return True

    def _dispatch(self, m: Any) -> None:
        self.stats.messages += 1
        kind = m.get_type()
        handler = getattr(self, f"_on_{kind.lower()}", None)
        if handler is None:
            self.stats.unknown += 1
            return
        handler(m)

    def _on_named_value_float(self, m: Any) -> None:
        if self.forward is not None and m.get_srcComponent() != 1:
            self.forward(bytes(m.get_msgbuf()))  # the companion's report, routed to the GCS

    def _on_statustext(self, m: Any) -> None:
        if self.forward is not None and m.get_srcComponent() != 1:
            self.forward(bytes(m.get_msgbuf()))

    def _on_heartbeat(self, m: Any) -> None:
        if m.type == mav.MAV_TYPE_GCS:
            self._gcs_seen = self.t_s
            if self._gcs_failsafe:
                self._gcs_failsafe = False
                self.statustext("Failsafe cleared: ground station heartbeat back", mav.MAV_SEVERITY_INFO)

    def _on_set_mode(self, m: Any) -> None:
        if self._for_me(m) and m.custom_mode in MODE_NAMES:
            self.set_mode(m.custom_mode)

    def set_mode(self, custom_mode: int) -> bool:
        """Switch mode (the next HEARTBEAT goes out at once); False for a mode Rover does not
        have, and for FOLLOW, which lfctl does through GUIDED.

        Parameters
        ----------
        custom_mode : int
            The Rover mode number (a value of :data:`MODES`).
        """
        if custom_mode not in MODE_NAMES:
            return False
        if custom_mode == MODES["FOLLOW"]:
            # ArduPilot's FOLLOW chases another vehicle's GLOBAL_POSITION_INT; lfctl follows by
            # camera, through GUIDED and the companion: refuse rather than accept and do nothing
            self.statustext("FOLLOW mode not supported: use GUIDED", mav.MAV_SEVERITY_WARNING)
            return False
        if custom_mode != self.mode:
            log.info("%s: mode %s -> %s", self.name, MODE_NAMES[self.mode], MODE_NAMES[custom_mode])
        self.mode = custom_mode
        self._guided_stale_reported = False
        self._next_due[MSG_IDS["HEARTBEAT"]] = self.t_s  # tell the ground station now
        return True

    def _ack(self, m: Any, result: int) -> None:
        self.send(mav.MAVLink_command_ack_message(m.command, result, 0, 0, m.get_srcSystem(), m.get_srcComponent()))

    def _on_command_long(self, m: Any) -> None:
        if not self._for_me(m):
            return
        self._ack(m, self._command(m.command, [m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7]))

    def _on_command_int(self, m: Any) -> None:
        if not self._for_me(m):
            return
        self._ack(m, self._command(m.command, [m.param1, m.param2, m.param3, m.param4, m.x, m.y, m.z]))

    def _command(self, cmd: int, p: list[float]) -> int:
        if cmd == mav.MAV_CMD_COMPONENT_ARM_DISARM:
            if p[0] not in (0.0, 1.0):
                return mav.MAV_RESULT_DENIED
            self.armed = p[0] == 1.0
            self._next_due[MSG_IDS["HEARTBEAT"]] = self.t_s  # tell the ground station now
            self.statustext("Armed" if self.armed else "Disarmed", mav.MAV_SEVERITY_INFO)
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_DO_SET_MODE:
            ok = int(p[0]) & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED and self.set_mode(int(p[1]))
            return mav.MAV_RESULT_ACCEPTED if ok else mav.MAV_RESULT_DENIED
        if cmd == mav.MAV_CMD_REQUEST_MESSAGE:
            msg_id = int(p[0])
            if msg_id not in (*self._intervals, MSG_IDS["AUTOPILOT_VERSION"]):
                return mav.MAV_RESULT_UNSUPPORTED
            self._once.append(msg_id)
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            self._once.append(MSG_IDS["AUTOPILOT_VERSION"])
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_GET_HOME_POSITION:
            self._once.append(MSG_IDS["HOME_POSITION"])
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_SET_MESSAGE_INTERVAL:
            msg_id, interval_us = int(p[0]), p[1]
            if msg_id not in self._intervals:
                return mav.MAV_RESULT_UNSUPPORTED
            if interval_us == -1:
                self._intervals[msg_id] = math.inf
            elif interval_us == 0:
                self._intervals[msg_id] = 1.0 / STREAMS[ID_NAMES[msg_id]]
            elif interval_us > 0:
                self._intervals[msg_id] = interval_us / 1e6
            else:
                return mav.MAV_RESULT_DENIED
            self._next_due[msg_id] = self.t_s
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_MISSION_START:
            if len(self.mission) < 2:
                return mav.MAV_RESULT_DENIED
            first = int(p[0])
            if first > 0 and not self.set_current(first):
                return mav.MAV_RESULT_DENIED
            self.set_mode(MODES["AUTO"])
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_DO_SET_MISSION_CURRENT:
            return mav.MAV_RESULT_ACCEPTED if self.set_current(int(p[0])) else mav.MAV_RESULT_DENIED
        return mav.MAV_RESULT_UNSUPPORTED

    # -- parameters -------------------------------------------------------------------------
    def _param_value(self, name: str) -> Any:
        names = list(self.params)
        return mav.MAVLink_param_value_message(
            name.encode(), float(self.params[name].value), mav.MAV_PARAM_TYPE_REAL32, len(names), names.index(name)
        )

    def _on_param_request_list(self, m: Any) -> None:
        if self._for_me(m):
            for name in self.params:
                self.send(self._param_value(name))

    def _on_param_request_read(self, m: Any) -> None:
        if not self._for_me(m):
            return
        names = list(self.params)
        name = m.param_id if m.param_index < 0 else (names[m.param_index] if 0 <= m.param_index < len(names) else None)
        if isinstance(name, bytes):
            name = name.decode(errors="replace")
        if name in self.params:
            self.send(self._param_value(name))
        else:
            self.statustext(f"Unknown parameter {name}")

    def _on_param_set(self, m: Any) -> None:
        if not self._for_me(m):
            return
        name = m.param_id.decode(errors="replace") if isinstance(m.param_id, bytes) else m.param_id
        p = self.params.get(name)
        if p is None:
            self.statustext(f"Unknown parameter {name}")
            return
        if p.readonly or not (p.lo <= m.param_value <= p.hi) or not math.isfinite(m.param_value):
            self.statustext(
                f"{name} rejected: {m.param_value:g} outside {p.lo:g}..{p.hi:g} {p.unit}".rstrip()
                if not p.readonly
                else f"{name} is read-only"
            )
        else:
            p.value = float(m.param_value)
        self.send(self._param_value(name))  # the value now in force, as ArduPilot answers

    # -- mission protocol -----------------------------------------------------------------
    def _mission_ack(self, sysid: int, compid: int, result: int) -> None:
        self.send(mav.MAVLink_mission_ack_message(sysid, compid, result, mav.MAV_MISSION_TYPE_MISSION))

    def _on_mission_count(self, m: Any) -> None:
        if not self._for_me(m):
            return
        if getattr(m, "mission_type", 0) != mav.MAV_MISSION_TYPE_MISSION:
            self._mission_ack(m.get_srcSystem(), m.get_srcComponent(), mav.MAV_MISSION_UNSUPPORTED)
            return
        if m.count == 0:
            self.store_mission([])
            self._mission_ack(m.get_srcSystem(), m.get_srcComponent(), mav.MAV_MISSION_ACCEPTED)
            return
        if m.count > 2000:
            self._mission_ack(m.get_srcSystem(), m.get_srcComponent(), mav.MAV_MISSION_NO_SPACE)
            return
        self._upload = _Upload(m.count, sysid=m.get_srcSystem(), compid=m.get_srcComponent())
        self._request_next()

    def _request_next(self) -> None:
        up = self._upload
        assert up is not None
        up.sent_at = self.t_s
        self.send(
            mav.MAVLink_mission_request_int_message(up.sysid, up.compid, up.next_seq, mav.MAV_MISSION_TYPE_MISSION)
        )

    def _on_mission_item_int(self, m: Any) -> None:
        up = self._upload
        if up is None or not self._for_me(m):
            return
        if m.seq != up.next_seq:
            # a duplicate or reordered item: ask again for the one we need
            self._request_next()
            return
        item = MissionItem(
            m.seq, m.frame, m.command, m.param1, m.param2, m.param3, m.param4, m.x, m.y, m.z, m.autocontinue
        )
        result = validate_item(item, up.count)
        if result != mav.MAV_MISSION_ACCEPTED:
            self._upload = None  # the mission in force stays as it was
            self._mission_ack(up.sysid, up.compid, result)
            self.statustext(f"Mission rejected at item {m.seq}: {mav.enums['MAV_MISSION_RESULT'][result].name}")
            return
        up.items[m.seq] = item
        up.next_seq += 1
        up.retries = 0
        if up.next_seq >= up.count:
            self._upload = None
            self.store_mission([up.items[i] for i in range(up.count)])
            self._mission_ack(up.sysid, up.compid, mav.MAV_MISSION_ACCEPTED)
        else:
            self._request_next()

    def _on_mission_item(self, m: Any) -> None:
        # the float (non-_INT) item: ArduPilot still takes it; convert
        if self._upload is None or not self._for_me(m):
            return
        m2 = mav.MAVLink_mission_item_int_message(
            m.target_system,
            m.target_component,
            m.seq,
            m.frame,
            m.command,
            m.current,
            m.autocontinue,
            m.param1,
            m.param2,
            m.param3,
            m.param4,
            int(round(m.x * 1e7)),
            int(round(m.y * 1e7)),
            m.z,
            getattr(m, "mission_type", 0),
        )
        m2._header = m._header
        self._on_mission_item_int(m2)

    def store_mission(self, items: list[MissionItem]) -> None:
        """Make ``items`` (item 0 = home) the mission in force, item 1 current, as a finished
        upload does; a stored mission on a real rover is loaded this way at boot.

        Parameters
        ----------
        items : list of MissionItem
            The validated mission.
        """
        self.mission = items
        self.current_seq = 1 if len(items) > 1 else 0
        self.mission_version += 1
        self.statustext(f"Mission accepted: {max(0, len(items) - 1)} items", mav.MAV_SEVERITY_INFO)

    def _on_mission_request_list(self, m: Any) -> None:
        if not self._for_me(m):
            return
        self.send(
            mav.MAVLink_mission_count_message(
                m.get_srcSystem(), m.get_srcComponent(), len(self.mission), mav.MAV_MISSION_TYPE_MISSION
            )
        )

    def _on_mission_request_int(self, m: Any) -> None:
        if not self._for_me(m):
            return
        if not 0 <= m.seq < len(self.mission):
            self._mission_ack(m.get_srcSystem(), m.get_srcComponent(), mav.MAV_MISSION_INVALID_SEQUENCE)
            return
        it = self.mission[m.seq]
        self.send(
            mav.MAVLink_mission_item_int_message(
                m.get_srcSystem(),
                m.get_srcComponent(),
                it.seq,
                it.frame,
                it.command,
                int(it.seq == self.current_seq),
                it.autocontinue,
                it.param1,
                it.param2,
                it.param3,
                it.param4,
                it.x,
                it.y,
                it.z,
                mav.MAV_MISSION_TYPE_MISSION,
            )
        )

    _on_mission_request = _on_mission_request_int  # old clients ask with MISSION_REQUEST

    def _on_mission_ack(self, m: Any) -> None:
        pass  # the end of a download: nothing to do

    def _on_mission_clear_all(self, m: Any) -> None:
        if self._for_me(m):
            self.store_mission([])
            self._mission_ack(m.get_srcSystem(), m.get_srcComponent(), mav.MAV_MISSION_ACCEPTED)

    def _on_mission_set_current(self, m: Any) -> None:
        if self._for_me(m) and self.set_current(m.seq):
            self.send(mav.MAVLink_mission_current_message(self.current_seq))

    def set_current(self, seq: int) -> bool:
        """Make mission item ``seq`` the current one; False when there is no such item.

        Parameters
        ----------
        seq : int
            The item, 1 or more (0 is home).
        """
        if not 0 < seq < len(self.mission):
            return False
        self.current_seq = seq
        self.mission_version += 1
        return True

    def reached(self, seq: int) -> None:
        """The autopilot reached mission item ``seq``: tell the ground station and move on.

        Parameters
        ----------
        seq : int
            The item reached.
        """
        self.send(mav.MAVLink_mission_item_reached_message(seq))
        self.current_seq = min(seq + 1, max(0, len(self.mission) - 1))

    # -- GUIDED setpoints from the companion --------------------------------------------------
    def _on_set_position_target_local_ned(self, m: Any) -> None:
        if not self._for_me(m):
            return
        if m.coordinate_frame != mav.MAV_FRAME_BODY_NED or m.type_mask != TYPE_MASK_SPEED_YAWRATE:
            self.statustext(
                f"Setpoint ignored: frame {m.coordinate_frame} type_mask {m.type_mask} (want BODY_NED, 1479)"
            )
            return
        if not (math.isfinite(m.vx) and math.isfinite(m.yaw_rate)):
            return
        self._setpoint = (self.t_s, float(m.vx), float(m.yaw_rate))

    def guided_command(self) -> tuple[float, float] | None:
        """The companion's (speed, yaw rate) if fresh, else None (and a STATUSTEXT once)."""
        if self._setpoint is None:
            return None
        t, v, r = self._setpoint
        if self.t_s - t > self.param("GUID_TIMEOUT"):
            if not self._guided_stale_reported:
                self._guided_stale_reported = True
                self.statustext("Failsafe: companion setpoints stopped, stopping")
            return None
        self._guided_stale_reported = False
        limit = self.param("CRUISE_SPEED")
        return max(-limit, min(limit, v)), r

    # -- the tick -----------------------------------------------------------------------------
    def tick(self, t_s: float, state: dict[str, float]) -> None:
        """Advance to ``t_s``: handle input, run timeouts and failsafes, stream telemetry.

        Parameters
        ----------
        t_s : float
            Now, s.
        state : dict of str to float
            The vehicle's truth now: ``north_m``, ``east_m``, ``yaw_rad``, ``speed_mps`` and
            ``yaw_rate_radps``.
        """
        self.t_s = t_s
        self.state = state
        self.receive()
        up = self._upload
        if up is not None and t_s - up.sent_at > MISSION_ITEM_TIMEOUT_S:
            if up.retries >= MISSION_RETRIES:
                self._upload = None
                self._mission_ack(up.sysid, up.compid, mav.MAV_MISSION_OPERATION_CANCELLED)
                self.statustext(f"Mission upload timed out waiting for item {up.next_seq}")
            else:
                up.retries += 1
                self._request_next()
        if (
            self.param("FS_GCS_ENABLE")
            and self._gcs_seen is not None
            and not self._gcs_failsafe
            and t_s - self._gcs_seen > self.param("FS_GCS_TIMEOUT")
        ):
            self._gcs_failsafe = True
            if self.mode != MODES["HOLD"]:
                self.set_mode(MODES["HOLD"])
            self.statustext("Failsafe: ground station heartbeat lost, HOLD")
        for msg_id in list(self._once):
            self._send_by_id(msg_id)
        self._once.clear()
        for msg_id, period in self._intervals.items():
            if t_s >= self._next_due.get(msg_id, 0.0):
                self._send_by_id(msg_id)
                self._next_due[msg_id] = t_s + period if math.isfinite(period) else math.inf

    def _send_by_id(self, msg_id: int) -> None:
        name = ID_NAMES.get(msg_id)
        s = self.state
        t_ms = int(self.t_s * 1000) & 0xFFFFFFFF
        lat, lon, alt = ned_to_geodetic(s["north_m"], s["east_m"], 0.0, *self.home)
        vn, ve = s["speed_mps"] * math.cos(s["yaw_rad"]), s["speed_mps"] * math.sin(s["yaw_rad"])
        hdg = int(round(math.degrees(s["yaw_rad"]) % 360 * 100)) % 36000
        if name == "HEARTBEAT":
            base = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mav.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
            if self.mode == MODES["AUTO"]:
                base |= mav.MAV_MODE_FLAG_AUTO_ENABLED
            if self.mode == MODES["GUIDED"]:
                base |= mav.MAV_MODE_FLAG_GUIDED_ENABLED
            self.send(
                mav.MAVLink_heartbeat_message(
                    mav.MAV_TYPE_GROUND_ROVER,
                    mav.MAV_AUTOPILOT_ARDUPILOTMEGA,
                    base,
                    self.mode,
                    mav.MAV_STATE_ACTIVE if self.armed else mav.MAV_STATE_STANDBY,
                    3,
                )
            )
        elif name == "SYS_STATUS":
            sensors = mav.MAV_SYS_STATUS_SENSOR_GPS | mav.MAV_SYS_STATUS_SENSOR_3D_GYRO
            self.send(mav.MAVLink_sys_status_message(sensors, sensors, sensors, 200, 12000, 100, 90, 0, 0, 0, 0, 0, 0))
        elif name == "GPS_RAW_INT":
            self.send(
                mav.MAVLink_gps_raw_int_message(
                    int(self.t_s * 1e6),
                    3,
                    int(round(lat * 1e7)),
                    int(round(lon * 1e7)),
                    int(round(alt * 1000)),
                    100,
                    100,
                    int(round(abs(s["speed_mps"]) * 100)),
                    hdg,
                    12,
                )
            )
        elif name == "GLOBAL_POSITION_INT":
            self.send(
                mav.MAVLink_global_position_int_message(
                    t_ms,
                    int(round(lat * 1e7)),
                    int(round(lon * 1e7)),
                    int(round(alt * 1000)),
                    0,
                    int(round(vn * 100)),
                    int(round(ve * 100)),
                    0,
                    hdg,
                )
            )
        elif name == "LOCAL_POSITION_NED":
            self.send(mav.MAVLink_local_position_ned_message(t_ms, s["north_m"], s["east_m"], 0.0, vn, ve, 0.0))
        elif name == "ATTITUDE":
            self.send(
                mav.MAVLink_attitude_message(t_ms, 0.0, 0.0, wrap_pi(s["yaw_rad"]), 0.0, 0.0, s["yaw_rate_radps"])
            )
        elif name == "MISSION_CURRENT":
            # total: the last item's number (home, item 0, not counted); UINT16_MAX without a mission
            total = len(self.mission) - 1 if len(self.mission) > 1 else 0xFFFF
            self.send(mav.MAVLink_mission_current_message(self.current_seq, total))
        elif name == "HOME_POSITION":
            self.send(
                mav.MAVLink_home_position_message(
                    int(round(self.home[0] * 1e7)),
                    int(round(self.home[1] * 1e7)),
                    int(round(self.home[2] * 1000)),
                    0,
                    0,
                    0,
                    [1, 0, 0, 0],
                    0,
                    0,
                    0,
                )
            )
        elif name == "AUTOPILOT_VERSION":
            caps = (
                mav.MAV_PROTOCOL_CAPABILITY_MISSION_INT
                | mav.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | mav.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | mav.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
                | mav.MAV_PROTOCOL_CAPABILITY_MAVLINK2
            )
            self.send(
                mav.MAVLink_autopilot_version_message(
                    caps, 0x04050000, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, self.sysid, [0] * 18
                )
            )


def packet_record(direction: str, msg: Any, raw: bytes) -> dict[str, Any]:
    """A packet as the /mavlink/<link> recording topic carries it: ids, name, sequence,
    fields (text decoded, non-finite numbers as strings) and the raw bytes in base64.

    Parameters
    ----------
    direction : str
        ``"in"`` or ``"out"`` of the endpoint.
    msg : pymavlink message
        The parsed message.
    raw : bytes
        The packet as it travelled.
    """
    fields = {}
    for k in msg.get_fieldnames():
        v = getattr(msg, k)
        if isinstance(v, bytes):
            v = v.decode(errors="replace").rstrip("\x00")
        elif isinstance(v, float) and not math.isfinite(v):
            v = str(v)
        fields[k] = v
    return {
        "direction": direction,
        "sysid": msg.get_srcSystem(),
        "compid": msg.get_srcComponent(),
        "msgid": msg.get_msgId(),
        "name": msg.get_type(),
        "seq": msg.get_seq(),
        "fields": fields,
        "raw": base64.b64encode(raw).decode(),
    }
