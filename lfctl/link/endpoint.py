"""A simulated vehicle as an ArduPilot-Rover-compatible MAVLink endpoint.

HEARTBEAT (GROUND_ROVER, ARDUPILOTMEGA, Rover mode numbers), streamed telemetry at rates a
ground station may change (SET_MESSAGE_INTERVAL), REQUEST_MESSAGE, COMMAND_LONG/INT with
COMMAND_ACK as Rover answers them, parameters with real effect, the mission protocol for the
MISSION, FENCE and RALLY lists (:mod:`lfctl.link.mission_server`), GUIDED targets in every
form Rover takes (:mod:`lfctl.link.guided`), the geofence with its breach action, RTL and
SmartRTL, and the GCS failsafe. Time comes in as ``t_s``; bytes go out through the link it is
given. What the vehicle then does with its mode and targets is the simulation's
(:mod:`lfctl.sim.driver`).

Nothing a peer sends can end or stall it: every datagram is bounded in size and number per
tick (the rest is dropped and counted), every field is checked before use (NaN, inf, out of
range: refused with the result Rover gives, state kept), a handler that fails anyway is
counted (:attr:`LinkStats.handler_errors`) and logged, never raised, and signed links check
signatures before any replay state changes (:mod:`lfctl.link.signing`).
"""

from __future__ import annotations

import base64
import hashlib
import logging
import math
import struct
import time
from collections.abc import Callable, Collection, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from typing import Any, Protocol

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl import __version__
from lfctl.checks import printable
from lfctl.frames import FLT_EPSILON, HALF_EARTH_M, ned_to_geodetic, on_earth, wrap_pi
from lfctl.link.fence import (
    FENCE_ALL,
    FENCE_TYPE_ALT_MIN,
    FENCE_TYPE_CIRCLE,
    FENCE_TYPE_POLYGON,
    Fence,
    breach_name,
    fence_names,
    rally_points,
)
from lfctl.link.ftp import FtpFile, FtpServer
from lfctl.link.guided import GuidedTarget, Pose, attitude_target, global_to_local, position_target
from lfctl.link.mission import (
    DO_JUMP,
    LOCATION_ALT_MAX_M,
    RAW_XY,
    MissionItem,
    home_item,
    is_nav_command,
    jump_tag_item,
    validate_item,
)
from lfctl.link.mission_server import FENCE, MISSION, MISSION_TYPES, RALLY, MissionServer
from lfctl.link.param_server import ParamServer
from lfctl.link.params import ARMING_CHECK_ALL, ARMING_CHECK_PARAMETERS, Param, default_params
from lfctl.link.port import pack_next, statustext_messages
from lfctl.link.rc import PilotInput, RcOverrides
from lfctl.link.signing import VerifyingMAVLink, advance_signing_clock, setup_signing
from lfctl.link.smartrtl import clean as clean_way_back
from lfctl.link.transport import MAX_PEERS

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

#: a stream is sent at a tick this close before it is due, s (the ticks' float times)
DUE_SLACK_S = 1e-6
#: the schedule of the in-memory link and of network peers that set no rate (VehicleEndpoint._audience)
SHARED = "shared"
#: ArduPilot Rover custom mode numbers by name (the modes the endpoint knows)
MODES = {"MANUAL": 0, "HOLD": 4, "FOLLOW": 6, "AUTO": 10, "RTL": 11, "SMART_RTL": 12, "GUIDED": 15}
#: modes a ground station cannot arm in (as Rover: RTL and SmartRTL)
NOT_ARMABLE = frozenset((MODES["RTL"], MODES["SMART_RTL"]))
#: the slowest speed Rover's waypoint navigation takes (AR_WPNAV_SPEED_MIN), m/s
WP_SPEED_MIN_MPS = 0.05
#: SPEED_TYPE_ENUM_END: DO_CHANGE_SPEED's speed type past the last, DENIED as a climb speed
SPEED_TYPE_ENUM_END = 4
#: the largest int32: a MISSION_ITEM's x or y that is not a place must fit the item's integers
INT32_MAX = 2**31 - 1
#: MAV_CMD_COMPONENT_ARM_DISARM's param2 values that arm past the checks, as Rover 4.6:
#: ArduPilot's magic_force_arm_value (MAVProxy's `arm throttle force`) and its
#: magic_force_arm_disarm_value (MAVLink's force value, which MAVSDK's `arm_force` sends)
FORCE_ARM = (2989.0, 21196.0)
MODE_NAMES = {v: k for k, v in MODES.items()}
#: Rover's other modes, which lfctl does not fly (named when refused)
OTHER_ROVER_MODES = {1: "ACRO", 3: "STEERING", 5: "LOITER", 7: "SIMPLE", 8: "DOCK", 9: "CIRCLE", 16: "INITIALISING"}
ACRO_MODE = 1
#: MIS_DONE_BEHAVE's values that leave AUTO at a mission's end (Rover's DoneBehaviour)
MIS_DONE_ACRO, MIS_DONE_MANUAL = 2, 3
#: Rover's INITIALISING mode, which never starts on request (ModeInitializing::_enter)
INITIALISING_MODE = 16
#: Rover's AP_Arming::update, run once a second from boot: the "PreArm:" texts go out when more
#: than PREARM_DISPLAY_S have passed since the last display (whether anything failed then or
#: not), or, once the common checks have gone from passing to failing, more than PREARM_SOON_S
PREARM_DISPLAY_S, PREARM_SOON_S = 30.0, 4.0
#: the least time between two "sticks ignored" texts, s (:meth:`VehicleEndpoint._from_my_gcs`)
RC_REFUSED_TEXT_S = 2.0
#: Rover's autopilot modes (``is_autopilot_mode``): HEARTBEAT's GUIDED_ENABLED, NAV_CONTROLLER_OUTPUT
AUTOPILOT_MODES = frozenset(MODES[n] for n in ("AUTO", "GUIDED", "RTL", "SMART_RTL"))
#: component ids: a ground station (MAV_COMP_ID_MISSIONPLANNER) and a companion computer
GCS_COMPID = 190
COMPANION_COMPID = 191
#: the Rover release whose answers the vehicle gives (AUTOPILOT_VERSION's flight_sw_version,
#: an official build: ground stations gate features on it)
ROVER_VERSION = (4, 6, 0)
#: SET_POSITION_TARGET_LOCAL_NED type_mask using only the velocity and the yaw rate
TYPE_MASK_SPEED_YAWRATE = 1479
#: inbound work per tick: the most datagrams and bytes read (more are dropped and counted)
MAX_DATAGRAMS_PER_TICK = 256
MAX_BYTES_PER_TICK = 32 * 1024
#: a datagram longer than this is not what a ground station sends (one frame is <= 280 bytes)
MAX_DATAGRAM_BYTES = 4 * 1024
#: the most senders remembered for routing (ArduPilot's MAVLINK_MAX_ROUTES)
MAX_ROUTES = 20
#: a route on a network peer not heard from for this long is gone: nothing is passed to it,
#: and it gives way to a new one once the table is full, s (the UDP link's peers time out after 30 s)
ROUTE_IDLE_S = 30.0
#: the most packets a tick passes on between network peers for one sender (each copy counts):
#: a flood from one peer is not multiplied to every other without limit, nor starves the others
MAX_PASSED_ON_PER_TICK = 512
#: the most senders a tick passes packets on for (the rest's are dropped, counted: a flood
#: from many ports)
MAX_PASSED_ON_SENDERS = 32
#: a packet passed on is not passed on again within this long, s (a relay looping the port's
#: output back into it); and the most such packets remembered
PASSED_ON_MEMORY_S = 1.0
PASSED_ON_MEMORY_MAX = 4096
#: GUIDED stops a rate or heading target not renewed within this, s: fixed in Rover 4.6
#: (``ModeGuided::update``; a GUID_TIMEOUT parameter came to Rover after 4.6)
GUIDED_TIMEOUT_S = 3.0
#: SmartRTL gives up its way back when no point could be kept for this long, s (Rover's
#: SMARTRTL_TIMEOUT: the points used up and none cleaned away)
SRTL_TIMEOUT_S = 15.0
#: SmartRTL's breadcrumbs are taken this often, s (Rover schedules ModeSmartRTL::save_position
#: at 3 Hz)
SRTL_SAVE_PERIOD_S = 1.0 / 3.0
#: MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
REPOSITION_CHANGE_MODE = 1

#: default stream rates (Hz), as Rover's SRn_ parameters set them: every group (below) at 1 Hz
#: (GCS_MAVLINK_Parameters: SRn_EXT_STAT, _POSITION, _RC_CHAN, _EXTRA1-3 all 1), so each of its
#: messages at 1 Hz; HEARTBEAT at 1 Hz in no group; the rest only when asked for or set
STREAMS = {
    "HEARTBEAT": 1.0,
    "SYS_STATUS": 1.0,
    "GPS_RAW_INT": 1.0,
    "GLOBAL_POSITION_INT": 1.0,
    "LOCAL_POSITION_NED": 1.0,
    "ATTITUDE": 1.0,
    "VFR_HUD": 1.0,
    "MISSION_CURRENT": 1.0,
    # in no group: sent as home is set or moves, with GPS_GLOBAL_ORIGIN (AP_AHRS::set_home), and
    # when asked for
    "HOME_POSITION": 0.0,
    "FENCE_STATUS": 1.0,
    "NAV_CONTROLLER_OUTPUT": 1.0,
    "POSITION_TARGET_GLOBAL_INT": 1.0,
    "EXTENDED_SYS_STATE": 0.0,  # 0: not streamed unless asked for (QGroundControl asks)
    "RC_CHANNELS": 1.0,
    "ATTITUDE_QUATERNION": 0.0,  # sent when asked for (MAVSDK's attitude quaternion)
    "GPS_GLOBAL_ORIGIN": 0.0,  # sent when asked for, with GET_HOME_POSITION, and as home is set
    "SYSTEM_TIME": 1.0,  # the EXTRA3 group's (MAVSDK's unix epoch time)
    # sent when asked for (and as each item is done): the last item reached, as Rover repeats it
    "MISSION_ITEM_REACHED": 0.0,
}
#: MISSION_ITEM_REACHED's seq before any item was reached since the autopilot started (Rover's
#: AP_MISSION_CMD_INDEX_NONE, what a GCS_MAVLINK channel starts with)
NO_ITEM_REACHED = 0xFFFF
#: PARAM_VALUE's rate as Rover's parameter stream has it (SRn_PARAMS, 10 Hz by default), s,
#: and the slowest Rover lets a rate set for it be, ms (a vehicle must always be able to send
#: its parameters: a stop is this default instead)
PARAM_STREAM_PERIOD_S = 0.1
PARAM_SLOWEST_MS = 1000
#: messages Rover knows (GCS_MAVLINK::mavlink_id_to_ap_message_id) for equipment lfctl's
#: vehicles have not fitted: a battery monitor, a rangefinder, an RPM sensor, ESC telemetry,
#: an ADS-B receiver. As a Rover without them, a request or a rate for one is ACCEPTED and
#: nothing is sent (MAVSDK's set_rate_battery succeeds).
NOT_FITTED_NAMES = ("BATTERY_STATUS", "DISTANCE_SENSOR", "RANGEFINDER", "RPM", "ESC_TELEMETRY_1_TO_4", "ADSB_VEHICLE")
#: messages Rover knows whose sender a rover leaves empty (GCS_MAVLINK's base methods, which
#: Rover does not override): asked for (MAVROS asks for both), ACCEPTED and nothing is sent
EMPTY_NAMES = ("POSITION_TARGET_LOCAL_NED", "ATTITUDE_TARGET")
#: the camera's and the gimbal's messages Rover knows (mavlink_id_to_ap_message_id, with
#: AP_CAMERA_ENABLED and HAL_MOUNT_ENABLED, on in its builds), in no stream group: as a Rover
#: with neither set up (CAM1_TYPE, MNT1_TYPE 0), a request or a rate for one is ACCEPTED and
#: nothing is sent (a vehicle's camera component answers for itself, :mod:`lfctl.link.camera`)
NO_CAMERA_NAMES = (
    "CAMERA_FEEDBACK",
    "CAMERA_INFORMATION",
    "CAMERA_SETTINGS",
    "CAMERA_CAPTURE_STATUS",
    "GIMBAL_DEVICE_ATTITUDE_STATUS",
    "AUTOPILOT_STATE_FOR_GIMBAL_DEVICE",
    "GIMBAL_MANAGER_INFORMATION",
    "GIMBAL_MANAGER_STATUS",
)
MSG_IDS = {
    name: getattr(mav, f"MAVLINK_MSG_ID_{name}")
    for name in (*STREAMS, *NOT_FITTED_NAMES, *EMPTY_NAMES, *NO_CAMERA_NAMES, "AUTOPILOT_VERSION", "PARAM_VALUE")
}
NOT_FITTED = frozenset(MSG_IDS[name] for name in (*NOT_FITTED_NAMES, *EMPTY_NAMES, *NO_CAMERA_NAMES))
#: what Rover's routing never passes on between its links (MAVLink_routing::check_and_forward:
#: a radio's own reports, and ADS-B traffic, which has its own stream rate)
NEVER_PASSED_ON = frozenset(
    (mav.MAVLINK_MSG_ID_RADIO, mav.MAVLINK_MSG_ID_RADIO_STATUS, mav.MAVLINK_MSG_ID_ADSB_VEHICLE)
)
#: REQUEST_DATA_STREAM's groups (MAV_DATA_STREAM), as Rover's GCS_MAVLink puts the messages
#: this vehicle sends in them
DATA_STREAMS: dict[int, tuple[str, ...]] = {
    mav.MAV_DATA_STREAM_EXTENDED_STATUS: (
        "SYS_STATUS",
        "MISSION_CURRENT",
        "GPS_RAW_INT",
        "NAV_CONTROLLER_OUTPUT",
        "FENCE_STATUS",
        "POSITION_TARGET_GLOBAL_INT",
    ),
    mav.MAV_DATA_STREAM_POSITION: ("GLOBAL_POSITION_INT", "LOCAL_POSITION_NED"),
    mav.MAV_DATA_STREAM_RC_CHANNELS: ("RC_CHANNELS",),
    mav.MAV_DATA_STREAM_EXTRA1: ("ATTITUDE",),
    mav.MAV_DATA_STREAM_EXTRA2: ("VFR_HUD",),
    # with the messages of equipment not fitted, whose rate the group sets though none is sent
    # (ADS-B is in Rover's ADSB group)
    mav.MAV_DATA_STREAM_EXTRA3: ("SYSTEM_TIME", *(n for n in NOT_FITTED_NAMES if n != "ADSB_VEHICLE")),
}
DATA_STREAMS[mav.MAV_DATA_STREAM_ALL] = tuple(n for names in DATA_STREAMS.values() for n in names)
ID_NAMES = {v: k for k, v in MSG_IDS.items()}
#: the streams that carry the global position (:meth:`VehicleEndpoint._send_by_id`)
_GLOBAL_STREAMS = frozenset(("GPS_RAW_INT", "GLOBAL_POSITION_INT", "VFR_HUD"))
#: POSITION_TARGET_GLOBAL_INT's type_mask as Rover sends it: the position only (velocities,
#: accelerations, yaw and yaw rate ignored, and the mask's top four bits set)
POSITION_ONLY_TYPE_MASK = (
    mav.POSITION_TARGET_TYPEMASK_VX_IGNORE
    | mav.POSITION_TARGET_TYPEMASK_VY_IGNORE
    | mav.POSITION_TARGET_TYPEMASK_VZ_IGNORE
    | mav.POSITION_TARGET_TYPEMASK_AX_IGNORE
    | mav.POSITION_TARGET_TYPEMASK_AY_IGNORE
    | mav.POSITION_TARGET_TYPEMASK_AZ_IGNORE
    | mav.POSITION_TARGET_TYPEMASK_YAW_IGNORE
    | mav.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
    | 0xF000
)
#: SYS_STATUS's battery fields (voltage mV, current cA, remaining %) as a Rover without a
#: battery monitor sends them: lfctl models no battery. Rover's send_sys_status sends the
#: monitor's voltage, 0 with none (not MAVLink's UINT16_MAX "not sent", which MAVSDK shows as
#: 65.535 V), and -1 for the current and the remaining energy it does not measure
BATTERY_NOT_MEASURED = (0, -1, -1)
#: SYS_STATUS sensors a rover has, all present, enabled and healthy (what MAVSDK's health reads)
SENSORS = (
    mav.MAV_SYS_STATUS_SENSOR_3D_GYRO
    | mav.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | mav.MAV_SYS_STATUS_SENSOR_3D_MAG
    | mav.MAV_SYS_STATUS_SENSOR_GPS
    | mav.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    | mav.MAV_SYS_STATUS_AHRS
    | mav.MAV_SYS_STATUS_PREARM_CHECK
)
#: SYS_STATUS's controllers, present in every mode and enabled and healthy in the autopilot
#: modes, as Rover's GCS_Rover::update_vehicle_sensor_status_flags: the first two where its
#: mode is attitude_stabilized (every one of lfctl's but MANUAL and HOLD), the last two where it
#: is_autopilot_mode (AUTO, GUIDED, RTL and SmartRTL; the same modes)
CONTROLLERS = (
    mav.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
    | mav.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
    | mav.MAV_SYS_STATUS_SENSOR_YAW_POSITION
    | mav.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
)
#: a disarmed vehicle's home follows it once it is this far from it, m (Rover's
#: DISTANCE_HOME_MINCHANGE)
HOME_MIN_CHANGE_M = 0.5
#: a reboot's silence, s: the autopilot neither sends nor hears anything while it restarts
REBOOT_S = 2.0
#: MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN's param6 that reboots an armed vehicle (ArduPilot's
#: magic_force_reboot_value; MAVProxy's `reboot force` sends it)
FORCE_REBOOT = 20190226
#: FS_ACTION's and FENCE_ACTION's values (Rover's FailsafeAction; FENCE_ACTION's 0 reports only)
ACTION_NONE, ACTION_RTL, ACTION_HOLD, ACTION_SMARTRTL, ACTION_SMARTRTL_HOLD, ACTION_TERMINATE, ACTION_LOITER_HOLD = (
    range(7)
)
#: the modes each action tries in turn, the first that starts kept (Terminate disarms
#: instead); lfctl's vehicle has no LOITER mode, so "LOITER or HOLD" holds
ACTION_MODES = {
    ACTION_RTL: ("RTL", "HOLD"),
    ACTION_HOLD: ("HOLD",),
    ACTION_SMARTRTL: ("SMART_RTL", "RTL", "HOLD"),
    ACTION_SMARTRTL_HOLD: ("SMART_RTL", "HOLD"),
    ACTION_LOITER_HOLD: ("HOLD",),
}
#: FS_GCS_ENABLE's "the failsafe, but a mission in AUTO goes on"
FS_GCS_CONTINUE_MISSION = 2
#: FS_OPTIONS' bit for a failsafe that acts in HOLD too
FS_OPTION_ACTIVE_IN_HOLD = 1
#: after a circle breach, AC_Fence's backup circle: this much farther out it is breached again, m
CIRCLE_BACKUP_M = 20.0
#: farther than this outside the circle, a breach's action is HOLD (AC_FENCE_GIVE_UP_DISTANCE), m
FENCE_GIVE_UP_M = 100.0
#: a mode change while breached gives the pilot this long before a new breach is acted on
#: (AC_Fence::manual_recovery_start, AC_FENCE_MANUAL_RECOVERY_TIME_MIN), s
FENCE_RECOVERY_S = 10.0


@dataclass(frozen=True)
class NavReport:
    """Where a vehicle's autopilot is steering, for NAV_CONTROLLER_OUTPUT (local NED angles,
    from north, clockwise)."""

    nav_bearing_rad: float  # the heading it steers
    target_bearing_rad: float  # from the vehicle to its destination
    distance_m: float  # to its destination
    cross_track_m: float  # from the leg it follows, positive right of it
    destination_ned_m: tuple[float, float]  # where it is going, local NED (POSITION_TARGET_GLOBAL_INT)


@dataclass
class LinkStats:
    """What an endpoint has read from its link, and what it refused."""

    datagrams: int = 0  # datagrams read
    remote: int = 0  # of them from the network (not the in-memory link)
    messages: int = 0  # messages parsed and dispatched
    bad: int = 0  # garbage, truncated frames, bad CRC, bad or missing signature
    other_sysid: int = 0  # addressed to another vehicle
    unknown: int = 0  # message ids we do not handle (ids outside the dialect: not answered at all)
    dropped: int = 0  # datagrams too long, or over the per-tick byte budget
    rebooting: int = 0  # messages that came while the autopilot restarted (recorded, not acted on)
    over_budget: int = 0  # ticks that stopped reading at the wall-time budget
    handler_errors: int = 0  # a handler failed on a message (a bug: logged, never raised)
    not_passed_on: int = 0  # messages for other peers dropped over the per-tick limits (MAX_PASSED_ON_*)
    send_errors: int = 0  # a message of ours held a value its field cannot (a bug: logged, not sent)


def _finite(*values: float) -> bool:
    return all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)


def _ms(duration_s: float) -> int:
    """A duration in whole ms, as Rover's ``millis()`` differences count it (to the nearest:
    the ticks' float sums land a hair either side of a whole ms)."""
    return round(duration_s * 1000)


def _c_uint32(value: float) -> int | None:
    """A float command parameter through C's cast to ``uint32_t``, as Rover reads a message
    id: the fraction cut off; None where C leaves the cast undefined (NaN, infinite, under 0
    or past 2^32)."""
    return math.trunc(value) if _finite(value) and -1 < value < 2**32 else None


def _c_int32(value: float) -> int | None:
    """A float command parameter through C's cast to ``int32_t`` (see :func:`_c_uint32`)."""
    return math.trunc(value) if _finite(value) and -(2**31) - 1 < value < 2**31 else None


def _as_int(value: float, lo: int, hi: int) -> int | None:
    """A float parameter as a whole number in [lo, hi], or None."""
    if not _finite(value) or value != int(value) or not lo <= value <= hi:
        return None
    return int(value)


class StreamRates:
    """One channel's telemetry schedule, as a Rover keeps one for each of its links: each
    message's period (infinite: not sent), when it is next due, and the periods
    REQUEST_DATA_STREAM set for its groups (the link's SRn_ parameters, set in RAM: Rover does
    not save them, so a reboot starts every link at its defaults again)."""

    def __init__(self) -> None:
        self.groups: dict[int, float] = {}
        self.param_period_s = PARAM_STREAM_PERIOD_S  # PARAM_VALUE's rate (the link's SRn_PARAMS)
        self.intervals = {MSG_IDS[name]: _period(rate) for name, rate in STREAMS.items()}
        self.intervals.update(dict.fromkeys(NOT_FITTED, math.inf))  # rates kept, nothing sent
        # a message not streamed by default is not due until asked for
        self.next_due = {i: math.inf for i, period in self.intervals.items() if math.isinf(period)}

    def stream(self, msg_id: int, period_s: float, t_s: float) -> None:
        """Send ``msg_id`` every ``period_s`` from ``t_s`` (infinite: stop it, not sending it
        once more)."""
        self.intervals[msg_id] = period_s
        self.next_due[msg_id] = t_s if math.isfinite(period_s) else math.inf

    def soon(self, msg_id: int, t_s: float) -> None:
        """Send ``msg_id`` at ``t_s`` (a change a ground station should hear of now), then on
        its period as before; not if it is stopped."""
        if math.isfinite(self.intervals.get(msg_id, math.inf)):
            self.next_due[msg_id] = t_s

    def due(self, t_s: float) -> list[int]:
        """The messages due at ``t_s``, each then due again a period on."""
        out = []
        for msg_id, period in self.intervals.items():
            due = self.next_due.get(msg_id, t_s)  # (a stream's first send is due now)
            if t_s + DUE_SLACK_S >= due:
                out.append(msg_id)
                # the stream keeps its phase: due again a period after it was due (after the
                # tick it went in, a 0.1 s period that fell a float's width past a tick slipped
                # a tick each time, and a 4 Hz stream on 50 Hz ticks ran at 3.85 Hz); one that
                # has fallen a period behind (a pause, a new rate) starts again from now
                after = due + period
                self.next_due[msg_id] = (after if after > t_s else t_s + period) if math.isfinite(period) else math.inf
        return out


class NetworkSide(Protocol):
    """The UDP side of an endpoint's link, where each peer is a channel of its own
    (:class:`lfctl.link.transport.UdpLink`)."""

    def send(self, data: bytes, exclude: Collection[Any] = ()) -> int:
        """Send to every peer (and fixed target) but those in ``exclude``; the copies sent."""
        ...

    def send_to(self, data: bytes, addr: Any) -> None:
        """Send to one peer or target, if it is reachable."""
        ...

    def reachable(self) -> list[Any]:
        """Every peer and fixed target a send reaches now."""
        ...


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
        The local NED frame's origin (the EKF origin), for global positions and missions.
    mode : str
        The Rover mode to start in (a key of :data:`MODES`).
    armed : bool
        Start armed.
    tap : callable, optional
        Sees every packet: ``tap(direction, msg, raw)`` with ``"in"`` or ``"out"``, the
        pymavlink message and its bytes (the recorder); ``tap("out", msg, raw, peer)`` for
        one sent to one network peer alone (:attr:`network`).
    signing_key : bytes, optional
        MAVLink 2 signing key: sign what is sent, and accept only signed packets except from
        the in-memory link.
    custom_version : str
        AUTOPILOT_VERSION's flight_custom_version, up to 8 ASCII characters: where a Rover puts
        its firmware's git hash (QGroundControl shows it as the firmware's); the simulator
        gives the first 8 of the running lfctl's code digest (``lfctl --version``). Empty:
        zeros.
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
        tap: Callable[..., None] | None = None,
        signing_key: bytes | None = None,
        custom_version: str = "",
    ) -> None:
        raw = custom_version.encode("ascii")[:8]
        self.custom_version = list(raw) + [0] * (8 - len(raw))
        self.name = name
        self.sysid = sysid
        self.link = link
        self.home = home
        self.mav = mav.MAVLink(None, srcSystem=sysid, srcComponent=1)
        self.mav.robust_parsing = True
        self.parser = self._parser(None)
        self.signed_parser: VerifyingMAVLink | None = None
        if signing_key is not None:
            # MAVLink 2 signing for the links that leave the machine (UDP): sign what we send,
            # accept only correctly signed packets from there; the in-memory companion link
            # stays unsigned
            setup_signing(self.mav, signing_key)
            self.signed_parser = self._parser(signing_key)
        self.params = default_params(sysid)
        # (a repeated warning is held back per sender's address: a client's own tries again)
        self.param_server = ParamServer(self.params, self.send, self.statustext, lambda: self._channel)
        self.missions = MissionServer(
            self.send,
            self.statustext,
            self._list_changed,
            running=self._mission_running,
            home=self._home_item,
            on_edit=self._list_edited,
            on_received=self._list_received,
            nav_index=lambda: self.mission_current,
        )
        self.ftp = FtpServer(self._ftp_files(), self._send_ftp, self.statustext)
        self.mission_version = 0  # bumps when the mission or the current item changes
        self.mission_restarts = 0  # bumps when the mission restarts or is reset (DO_JUMP's counts afresh)
        self.mission_edits = 0  # bumps when items of the mission are changed in place (a partial update)
        self.fence = Fence()
        self.rally: list[tuple[float, float]] = []
        self.stats = LinkStats()
        self._unsendable: set[str] = set()  # kinds of message a send_error has been logged for
        self.tap = tap
        #: components of this system that are not the autopilot and are reached another way
        #: (the vehicle's cameras): what is addressed to them is not acted on here
        self.routed_components: set[int] = set()
        # the senders seen, (system, component, channel), as ArduPilot's MAVLink routing learns
        # its routes (at most MAX_ROUTES), with when each was last heard, s. The channel a
        # message came on is "memory", or the network peer's address: each peer of the UDP port
        # is a channel of its own, as each of a Rover's links is, so a ground station and a
        # companion both on the port reach each other through it as through a Rover's radio
        # and companion ports. A route on a peer silent for ROUTE_IDLE_S is gone, and makes
        # room for a new one when the table is full (lfctl follow started again from another
        # port leaves its old one behind)
        self._routes: dict[tuple[int, int, Any], float] = {}
        self._channel: Any = "memory"
        self._pass_on_left: dict[Any, int] = {}  # copies each sender may still have passed on this tick
        self._passed_on: dict[tuple[Any, ...], float] = {}  # packets passed on lately, and when
        self._sender: Any = None
        self.statustexts: list[tuple[float, str]] = []
        self.t_s = 0.0
        self._boot_mode = MODES[mode]  # the mode it starts in, and starts in again on a reboot
        self._boot_t_s = 0.0  # when the autopilot last started: time_boot_ms counts from here
        self._booting_until = -math.inf  # rebooting (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN) until then
        self._reboot_due = False  # a reboot was accepted: it starts after the ACK has gone out
        #: PREFLIGHT_STORAGE param1 2: each parameter's value then; the ones still at it take
        #: their defaults at the reboot (a parameter set since is stored, as AP_Param keeps it)
        self._params_erased: dict[str, float] | None = None
        #: each network peer's next sequence number: a Rover counts packets per link, and a
        #: peer that gets only some of the packets (its own rates, answers to it alone) must
        #: not see the others' as lost
        self._seqs: dict[Any, int] = {}
        self._audience: Any = None  # while a stream's messages go out: whose schedule (see tick)
        self._ready_said = True  # "ArduPilot Ready" after a reboot has gone out
        self._start(armed)
        self.modes: list[tuple[float, int]] = [(0.0, self.mode)]  # (t_s, mode) from the start
        #: UTC at t_s = 0, us (SYSTEM_TIME): when the endpoint was made, unless the run sets it
        #: to its log's start so that SYSTEM_TIME and the log share a clock
        self.epoch_us = time.time_ns() // 1000
        #: the link's UDP side, each peer a channel of its own (set for a realtime run's UDP
        #: port; None: the link is one channel): the autopilot's packets are counted and
        #: scheduled per peer, the in-memory companion's reports go to every peer, and what one
        #: peer sends another's components is passed on (:meth:`_pass_on`)
        self.network: NetworkSide | None = None
        #: wall seconds a tick may spend on inbound traffic (None: no limit; set for UDP links
        #: in --realtime, never in lockstep, whose runs must not depend on the machine's speed)
        self.time_budget_s: float | None = None
        self.state: dict[str, float] = {
            "north_m": 0.0,
            "east_m": 0.0,
            "yaw_rad": 0.0,
            "speed_mps": 0.0,
            "yaw_rate_radps": 0.0,
        }

    def _start(self, armed: bool = False) -> None:
        """The autopilot's state as it starts, at construction and again after a reboot:
        what a Rover keeps in RAM. What it keeps in storage (parameters, mission, fence,
        rally points) and the link's counters are not touched."""
        self.mode = self._boot_mode
        self.armed = armed
        self.mission_complete = False  # the last item reached (Rover: AP_Mission's MISSION_COMPLETE)
        #: home, local NED: follows the vehicle while it is disarmed (moves of HOME_MIN_CHANGE_M
        #: or more) until a ground station sets it (MAV_CMD_DO_SET_HOME), as Rover's update_home
        self.home_ned: tuple[float, float] | None = None
        self.home_up_m = 0.0  # home's height above the (flat) ground, as a ground station set it
        self.home_locked = False
        self.guided: GuidedTarget | None = None  # None: GUIDED stops
        self.reversed = False  # MAV_CMD_DO_SET_REVERSE
        self.desired_speed_mps: float | None = None  # MAV_CMD_DO_CHANGE_SPEED (None: WP_SPEED)
        self.path: list[tuple[float, float]] = []  # SmartRTL's way back, oldest first (used up as driven)
        self.path_generation = 0  # each arming starts a new way back: counted
        self._path_cleaned = False  # the way, full, was cleaned and nothing added since
        self._srtl_points: int | None = None  # SRTL_POINTS as the autopilot started (None: not yet taken)
        self._loop_rate_hz: int | None = None  # SCHED_LOOP_RATE as the autopilot started (None: not yet taken)
        self._path_active = False  # a way back is kept (SRTL_POINTS and SRTL_ACCURACY > 0, not given up)
        self._path_saved_s = 0.0  # when a point was last kept, s
        self._path_sample_due = -math.inf  # when the next breadcrumb is taken, s (3 Hz, in phase)
        if armed:
            self._start_path()
        self._nav: tuple[NavReport, tuple[object, ...]] | None = None  # see steering()
        self.fence_breach: str | None = None
        self._breached_fences = 0  # FENCE_TYPE bits breached at the last check (AC_Fence's)
        self._circle_backup_m = 0.0  # AC_Fence's backup circle's radius (0: the circle not breached)
        self._fence_recovery_until = -math.inf  # no new breach acted on before this (manual recovery), s
        self.fence_breaches = 0
        self._fence_breach_ms = 0
        self._text_id = 0
        #: the telemetry schedule of the in-memory link, of fixed targets and of every network
        #: peer that has set no rate; a peer that sets one (REQUEST_DATA_STREAM,
        #: SET_MESSAGE_INTERVAL) has its own from then on, as each of a Rover's links has its
        #: SRn_ rates (at most MAX_PEERS; the one heard from longest ago makes room). Rover
        #: saves neither kind of rate: a reboot starts them all at the defaults
        self._rates = StreamRates()
        self._peer_rates: dict[Any, StreamRates] = {}
        #: messages to send once at the next tick, and to whom: None every channel (a change
        #: all should hear of), or the network peer whose request they answer
        self._once: list[tuple[int, Any]] = []
        self._reached_seq = NO_ITEM_REACHED  # the last MISSION_ITEM_REACHED sent since the start
        self._gcs_seen: float | None = None
        self.rc = RcOverrides()  # RC_CHANNELS_OVERRIDE and MANUAL_CONTROL: MANUAL's sticks
        self._rc_refused: set[int] = set()  # senders told that their sticks are not taken ...
        self._rc_refused_for = 0  # ... while SYSID_MYGCS is this
        self._rc_refused_text_t = -math.inf  # when the last of those texts went out
        self._guided_stale_reported = False
        self._guided_arrived = False  # GUIDED reached its place (and stopped there)
        # Rover's AP_Arming state (its RAM, zero at boot): s since boot of the next once-a-second
        # update and of the last display, whether the common checks passed when last run, and
        # whether their turn to failing is to be said soon (report_immediately)
        self._prearm_update_s = 1.0
        self._prearm_shown_s = 0.0
        self._prearm_common_passed = False
        self._prearm_soon = False
        # the fences turned on, FENCE_TYPE bits (AC_Fence's _enabled_fences, in RAM): at boot
        # every configured one but the floor with FENCE_ENABLE set, else none; then as
        # FENCE_ENABLE changes (:meth:`_follow_fence_enable`) and DO_FENCE_ENABLE asks, which
        # leaves the parameter as it is, as on Rover
        self._fence_enable_seen = math.nan  # (its _last_enabled: none yet, so the first look sets them)
        self.fences_enabled = 0
        self._follow_fence_enable()
        self._gcs_failsafe = False  # the ground station is lost (Rover's failsafe.bits)
        self._gcs_failsafe_since = 0.0  # since when, s (failsafe.start_time)
        self._failsafe_triggered = False  # the failsafe has acted (failsafe.triggered)

    @staticmethod
    def _parser(signing_key: bytes | None) -> Any:
        p = VerifyingMAVLink(None)
        p.robust_parsing = True
        if signing_key is not None:
            setup_signing(p, signing_key)
        return p

    # -- views the simulation reads ---------------------------------------------------------
    @property
    def mission(self) -> list[MissionItem]:
        """The mission in force (item 0 = home; empty when there is none)."""
        return self.missions.lists[MISSION]

    @property
    def current_seq(self) -> int:
        """The mission item the vehicle is heading for (0: none)."""
        return self.missions.current_seq

    @property
    def mission_current(self) -> int:
        """The item MISSION_CURRENT names, as Rover's ``AP_Mission::get_current_nav_index``:
        0 while no item is under way (after an upload, a restart or a disarm); while the
        mission is not running, the navigation command at or after the item set, as
        ``set_current_cmd`` loads it (a DO command set before it still runs first)."""
        seq = self.current_seq
        if seq == 0 or self.mode == MODES["AUTO"]:
            return seq
        seen: set[int] = set()
        mission = self.mission
        while 0 < seq < len(mission) and seq not in seen:
            seen.add(seq)
            it = mission[seq]
            if is_nav_command(it.command):
                return seq
            # a DO_JUMP with repeats to make is followed (one of 0 repeats is passed, as Rover's)
            jump = int(it.param1) if it.command == DO_JUMP and it.param2 != 0 else -1
            seq = jump if 0 < jump < len(mission) else seq + 1
        return self.current_seq

    def param(self, name: str) -> float:
        """A parameter's value now.

        Parameters
        ----------
        name : str
            The parameter (KeyError for an unknown one).
        """
        return self.params[name].value

    @property
    def speed_mps(self) -> float:
        """The speed AUTO, GUIDED and RTL drive at: a DO_CHANGE_SPEED, else WP_SPEED, m/s."""
        return self.desired_speed_mps if self.desired_speed_mps is not None else self.param("WP_SPEED")

    @property
    def path_started(self) -> bool:
        """Whether a way back is kept: from the first arming (lfctl's; Rover's starts with a
        position), unless ``SRTL_POINTS`` or ``SRTL_ACCURACY`` was 0 as the autopilot started
        or the points ran out (Rover's AP_SmartRTL ``is_active``)."""
        return self._path_active  # (set by the first arming's _start_path)

    def _smartrtl_points(self) -> int:
        """The points the way back has room for: ``SRTL_POINTS`` as the autopilot started,
        or 0 (none kept) when it or ``SRTL_ACCURACY`` was 0 then. Rover's AP_SmartRTL::init
        sizes the way once, at boot (``SRTL_POINTS`` is ``@RebootRequired``; ``SRTL_ACCURACY``
        is read then only to see whether it is 0, and live for the spacing), so a change
        takes a reboot. Taken at the first tick after a start, so a scenario's values count
        as a Rover's stored ones do (or at an arming before it)."""
        if self._srtl_points is None:
            points = int(self.param("SRTL_POINTS"))
            self._srtl_points = points if points > 0 and self.param("SRTL_ACCURACY") > 0 else 0
        return self._srtl_points

    def _loop_period_us(self) -> int:
        """The main loop's period, us: ``SCHED_LOOP_RATE`` as the autopilot started, held to
        50-2000 Hz, as Rover's AP_Scheduler::init takes it at boot (``@RebootRequired``: a
        change takes a reboot), in integers (1 000 000 / Hz). Taken at the first tick after a
        start, as :meth:`_smartrtl_points`."""
        if self._loop_rate_hz is None:
            self._loop_rate_hz = min(max(int(self.param("SCHED_LOOP_RATE")), 50), 2000)
        return 1_000_000 // self._loop_rate_hz

    def _cap_ms(self, interval_ms: int) -> int:
        """A message's interval, whole ms, as Rover's ``cap_message_interval`` holds it: no
        message goes out faster than 0.8 x the loop rate, so an interval with
        ``interval_ms * 800`` under the loop period (us) is raised to the period / 800
        (truncated, as Rover's float to uint16_t: 25 ms at Rover's default 50 Hz); 0 (not
        sent) stays 0."""
        period_us = self._loop_period_us()
        if interval_ms == 0 or interval_ms * 800 >= period_us:
            return interval_ms
        return int(period_us / 800.0)

    def _start_path(self) -> None:
        """A new way back (AP_SmartRTL::set_home, as the vehicle arms: where it is as the
        tick ends is the way's first point)."""
        self.path = []
        self.path_generation += 1
        self._path_active = self._smartrtl_points() > 0
        self._path_saved_s = self.t_s
        self._path_sample_due = -math.inf  # (the way's first point: this tick's)

    def home_point(self) -> tuple[float, float]:
        """Home in local NED, m: where the vehicle was when last disarmed (or a ground station
        put it); the origin before the first tick."""
        return self.home_ned if self.home_ned is not None else (0.0, 0.0)

    def _home_geodetic(self) -> tuple[float, float, float]:
        """Home's latitude, longitude (degrees) and altitude (m)."""
        return ned_to_geodetic(*self.home_point(), -self.home_up_m, *self.home)

    def _home_item(self) -> MissionItem:
        """Home as a mission's item 0 (a download's, as Rover answers it)."""
        return home_item(*self._home_geodetic())

    def _mission_running(self) -> bool:
        """The mission is being flown: AUTO, its last item not yet reached."""
        return self.mode == MODES["AUTO"] and len(self.mission) > 1 and not self.mission_complete

    def _update_home(self) -> None:
        """Rover's update_home: while disarmed and not set by a ground station, home follows
        the vehicle once it has moved HOME_MIN_CHANGE_M from it."""
        if self.armed or self.home_locked:
            return
        here = (self.state["north_m"], self.state["east_m"])
        if self.home_ned is None or math.dist(here, self.home_ned) >= HOME_MIN_CHANGE_M:
            self.home_ned = here
            self._home_set()

    def _home_set(self) -> None:
        """Home was set (or moved): HOME_POSITION and GPS_GLOBAL_ORIGIN go out on every link,
        as Rover's AP_AHRS::set_home sends them (HOME_POSITION is in no stream group)."""
        self._once += [(MSG_IDS["HOME_POSITION"], None), (MSG_IDS["GPS_GLOBAL_ORIGIN"], None)]

    def set_home(self, north_m: float, east_m: float, up_m: float = 0.0) -> None:
        """Put home here and keep it there (MAV_CMD_DO_SET_HOME): it no longer follows the
        disarmed vehicle; a STATUSTEXT says where, as Rover's does.

        Parameters
        ----------
        north_m, east_m : float
            Home, local NED, m.
        up_m : float
            Home's height above the ground (which is flat, at the scenario's home altitude),
            m: HOME_POSITION's altitude, and GLOBAL_POSITION_INT's ``relative_alt`` is the
            vehicle's height above it, as on a Rover.
        """
        self.home_ned = (north_m, east_m)
        self.home_up_m = up_m
        self.home_locked = True
        lat, lon, alt = self._home_geodetic()
        self.statustext(f"Set HOME to {lat:.6f} {lon:.6f} at {alt:.2f}m", mav.MAV_SEVERITY_INFO)
        self._home_set()

    # -- outgoing --------------------------------------------------------------------------
    def send(self, msg: Any) -> None:
        """Send one message from the autopilot (component 1).

        Parameters
        ----------
        msg : pymavlink message
            The message (not sent while the autopilot restarts).
        """
        if self.rebooting:
            return
        net = self.network
        reachable = net.reachable() if net is not None else []
        # an answer, or a stream, for some network peers alone (each packed for its peer, and
        # recorded as it went); else to every channel
        alone = self._peers_of(msg) or ([self._audience] if self._audience not in (None, SHARED) else [])
        try:
            if alone:
                assert net is not None
                for peer in alone:
                    if peer in reachable:
                        packed = self._pack_for(msg, peer)
                        if self.tap is not None:
                            self.tap("out", msg, packed, peer)
                        net.send_to(packed, peer)
            else:
                data = pack_next(msg, self.mav)
        except struct.error as exc:  # a bug, but the run goes on: the first of each kind is logged
            self.stats.send_errors += 1
            if msg.get_type() not in self._unsendable:
                self._unsendable.add(msg.get_type())
                log.error("%s: %s not sent, a field out of its range (%s): %s", self.name, msg.get_type(), exc, msg)
            return
        if not alone:
            # the in-memory link gets this packing, which is the record's; each network peer its
            # own, with its own sequence number (the shared schedule's streams not to the peers
            # that keep their own)
            if self.tap is not None:
                self.tap("out", msg, data)
            if net is None:
                self.link.send(data)
                return
            self.link.send(data, reachable)  # (the in-memory link alone)
            for peer in reachable:
                if self._audience is None or peer not in self._peer_rates:
                    net.send_to(self._pack_for(msg, peer), peer)
        if len(self._seqs) > 4 * MAX_PEERS:  # peers long gone (those with their own rates kept)
            self._seqs = {p: n for p, n in self._seqs.items() if p in reachable or p in self._peer_rates}

    def _asker(self) -> Any:
        """Who an answer to the message in hand goes to: the network peer it came from, as a
        Rover answers on the link a request came on; None (every channel) for one from the
        in-memory link, or a link that is one channel."""
        return self._channel if self.network is not None and self._channel != "memory" else None

    @contextmanager
    def _answering(self) -> Iterator[None]:
        """What is sent within goes to whoever sent the message in hand (:meth:`_asker`)."""
        before, self._audience = self._audience, self._asker()
        try:
            yield
        finally:
            self._audience = before

    def _answer(self, msg: Any) -> None:
        """Send ``msg`` to whoever sent the message in hand (:meth:`_asker`)."""
        with self._answering():
            self.send(msg)

    def _pack_for(self, msg: Any, peer: Any) -> bytes:
        """``msg`` packed for one network peer, with that peer's next sequence number."""
        m = self.mav
        shared, m.seq = m.seq, self._seqs.get(peer, 0)
        try:
            return pack_next(msg, m)
        finally:
            self._seqs[peer], m.seq = m.seq, shared

    def _peers_of(self, msg: Any) -> list[Any]:
        """The network peers a message addressed to a system (and component) goes to alone, as
        a Rover answers on the link a request came on: those its addressee was heard on lately,
        when none of them is the in-memory link. Empty (to every peer, as before): a message
        to no one in particular, or one to an addressee not heard from on the network alone."""
        target = getattr(msg, "target_system", 0)
        if not target or self.network is None:
            return []
        peers = self._live_channels(target, getattr(msg, "target_component", 0))
        return [] if "memory" in peers else peers

    def statustext(self, text: str, severity: int = mav.MAV_SEVERITY_WARNING) -> None:
        """A STATUSTEXT a ground station shows (also logged, and kept in :attr:`statustexts`).

        Parameters
        ----------
        text : str
            The line (longer than 50 bytes: sent in chunks, as ArduPilot does; at most 200).
        severity : int
            MAV_SEVERITY (default WARNING).
        """
        text = printable(text)  # a peer's bytes in it (a parameter name) are escaped: MAVProxy prints it raw
        self.statustexts.append((self.t_s, text))
        log.log(logging.WARNING if severity <= mav.MAV_SEVERITY_WARNING else logging.INFO, "%s: %s", self.name, text)
        data = text.encode()
        if len(data) > 50:
            self._text_id = self._text_id % 65535 + 1
        for msg in statustext_messages(data, severity, self._text_id):
            self.send(msg)

    # -- incoming --------------------------------------------------------------------------
    def receive(self) -> int:
        """Read and handle the datagrams waiting on the link, within the per-tick budget
        (:data:`MAX_DATAGRAMS_PER_TICK`, :data:`MAX_BYTES_PER_TICK`, and :attr:`time_budget_s`
        of wall time when set); what is over it waits in the socket. Returns the messages handled."""
        n = read = 0
        budget = MAX_BYTES_PER_TICK
        self._pass_on_left.clear()
        deadline = time.perf_counter() + self.time_budget_s if self.time_budget_s else None
        while read < MAX_DATAGRAMS_PER_TICK and budget > 0:
            batch = self.link.recv(min(32, MAX_DATAGRAMS_PER_TICK - read))
            if not batch:
                break
            read += len(batch)
            for data, addr in batch:
                self.stats.datagrams += 1
                self.stats.remote += addr[0] != "memory"
                if len(data) > MAX_DATAGRAM_BYTES or len(data) > budget:
                    self.stats.dropped += 1
                    continue
                budget -= len(data)
                n += self._datagram(data, addr)
            if deadline is not None and time.perf_counter() > deadline:
                self.stats.over_budget += 1
                break
        return n

    def _datagram(self, data: bytes, addr: tuple[str, int]) -> int:
        """Every MAVLink frame in one datagram: frames are cut out by their header's length
        (junk between them is skipped at C speed) and each is decoded on its own.

        A frame whose message id is outside the dialect is not a message: pymavlink cannot
        check its CRC (it needs the id's CRC extra), so about one random datagram in a hundred
        would pass as one. Like ArduPilot's parser, which fails such a frame's CRC, the
        endpoint counts it (``stats.unknown``) and neither answers, records nor takes its
        sender as a peer: a burst of junk from many ports must not fill the peer table."""
        signed = self.signed_parser is not None and addr[0] != "memory"
        parser = self.signed_parser if signed else self.parser
        good: list[Any] = []
        unknown = 0
        i, size = 0, len(data)
        while i < size:
            j = _first_frame(data, i)
            if j < 0:
                break
            end = j + _frame_length(data, j)
            if end > size or end == j:
                i = j + 1  # a marker byte in junk, or a frame cut short
                continue
            msgs = parser.parse_buffer(data[j:end]) or []
            _reset(parser)
            ok = [m for m in msgs if m.get_type() != "BAD_DATA" and not isinstance(m, mav.MAVLink_unknown)]
            unknown += sum(isinstance(m, mav.MAVLink_unknown) for m in msgs)
            if ok:
                good += ok
                i = end
            else:
                i = j + 1
        self.stats.unknown += unknown
        self.stats.bad += 0 if good or unknown else 1
        if good:
            self.link.accept_peer(addr)
        self._channel = "memory" if addr[0] == "memory" else addr
        self._sender = addr  # the datagram's sender (a report is not routed back to it)
        for m in good:
            self._learn_route(m)
            self._handle(m, signed)
        return len(good)

    def _learn_route(self, m: Any) -> None:
        """Remember who sent ``m`` and on which channel (ArduPilot's ``learn_route``)."""
        route = (m.get_srcSystem(), m.get_srcComponent(), self._channel)
        if route[0] == 0 or route[:2] == (self.sysid, 1):  # (no sender, or this autopilot's own id)
            return
        if route not in self._routes and len(self._routes) >= MAX_ROUTES:
            idle = [r for r, heard in self._routes.items() if r[2] != "memory" and self.t_s - heard > ROUTE_IDLE_S]
            for r in idle:
                del self._routes[r]
        if route in self._routes or len(self._routes) < MAX_ROUTES:
            self._routes[route] = self.t_s

    def _handle(self, m: Any, signed: bool) -> None:
        try:
            if self.tap is not None:
                self.tap("in", m, bytes(m.get_msgbuf()))  # what reached the port, acted on or not
            if self.rebooting:  # restarting (from this frame on, if the datagram asked for it)
                self.stats.rebooting += 1
                return
            if self._channel != "memory":
                self._pass_on(m)
            self._dispatch(m, signed)
        except Exception:  # a bug in a handler: counted and logged, the run goes on
            self.stats.handler_errors += 1
            log.exception("%s: handling %s failed", self.name, m.get_type())

    def _for_me(self, m: Any, field: str = "target_system") -> bool:
        """To be acted on by this vehicle's autopilot, as Rover's MAVLink routing decides
        (``MAVLink_routing::check_and_forward``): aimed at system 0 or this one and, where the
        message names one, at component 0 or 1, or at another component that Rover would not
        forward it to: one it has heard from on no other channel (a message Rover cannot
        pass on is acted on by the autopilot itself). What is aimed at the vehicle's cameras,
        or at a component heard on another channel (the in-memory link, another network
        peer), is passed on by Rover and not acted on."""
        target = getattr(m, field, self.sysid)
        component = getattr(m, "target_component", 0)
        if target not in (0, self.sysid) or (component not in (0, 1) and self._forwarded(target, component)):
            self.stats.other_sysid += 1
            return False
        return True

    def _pass_on(self, m: Any) -> None:
        """Pass a network peer's message on to the other peers as Rover's routing passes it
        between its links (``MAVLink_routing::check_and_forward``): one addressed to a system
        and component heard from another peer goes to that peer (a ground station's request to
        ``lfctl follow``'s companion, 191, or its camera, 100; their answers back to the ground
        station; one for another system to every peer that system was heard on, whatever the
        component), and what anyone sends to no one in particular (a HEARTBEAT, a camera's
        stream information, a companion's STATUSTEXT, a ground station's HEARTBEAT to the
        companion) to every other peer, but RADIO, RADIO_STATUS and ADSB_VEHICLE, which Rover
        never passes on. Never back to the sender; nothing bearing the
        autopilot's own id (its own are answered here); a packet already passed on within
        :data:`PASSED_ON_MEMORY_S` not again (a relay that sends the port's output back into
        it, MAVProxy with ``--master`` and ``--out`` both on the port, would loop it for ever,
        as mavlink-router's de-duplication prevents); at most :data:`MAX_PASSED_ON_PER_TICK`
        copies a tick for each sender (the rest counted in ``stats.not_passed_on``)."""
        if (m.get_srcSystem(), m.get_srcComponent()) == (self.sysid, 1):
            return  # its own id come back, or forged
        target = getattr(m, "target_system", 0)
        if target:
            component = getattr(m, "target_component", 0)
            if self.network is None or (target, component) == (self.sysid, 1):
                return
            # another system: wherever it was heard, any component (check_and_forward's !match_system)
            heard_as = component if target == self.sysid else 0
            to = [c for c in self._live_channels(target, heard_as) if c not in ("memory", self._channel)]
            if not to:
                return
        elif self.network is None or m.get_msgId() in NEVER_PASSED_ON:
            return
        else:
            to = []
        if not self._first_pass(m):
            return
        left = self._pass_on_left.get(self._channel, MAX_PASSED_ON_PER_TICK)
        if left <= 0 or (len(self._pass_on_left) >= MAX_PASSED_ON_SENDERS and self._channel not in self._pass_on_left):
            self.stats.not_passed_on += 1
            return
        data = bytes(m.get_msgbuf())
        assert self.network is not None
        if to:
            for channel in to:
                self.network.send_to(data, channel)
            sent = len(to)
        else:
            sent = self.network.send(data, (self._sender,))
        self._pass_on_left[self._channel] = left - sent

    def _first_pass(self, m: Any) -> bool:
        """Whether ``m`` (its sender, sequence number, message id and bytes) has not been passed
        on within :data:`PASSED_ON_MEMORY_S`; remembers it."""
        key = (m.get_srcSystem(), m.get_srcComponent(), m.get_seq(), m.get_msgId(), bytes(m.get_msgbuf()[-8:]))
        seen = self._passed_on.get(key)
        if seen is not None and self.t_s - seen <= PASSED_ON_MEMORY_S:
            return False
        if len(self._passed_on) >= PASSED_ON_MEMORY_MAX:
            self._passed_on = {k: t for k, t in self._passed_on.items() if self.t_s - t <= PASSED_ON_MEMORY_S}
            if len(self._passed_on) >= PASSED_ON_MEMORY_MAX:
                self._passed_on.clear()  # (a flood of distinct packets: forget, as the budget limits them)
        self._passed_on[key] = self.t_s
        return True

    def _forwarded(self, target: int, component: int) -> bool:
        """Whether Rover would pass a message for ``(target, component)`` on to another
        channel: to a broadcast system, to every sender heard elsewhere; else to that one."""
        if component in self.routed_components:
            return True
        return any(channel != self._channel for channel in self._live_channels(target, 0 if target == 0 else component))

    def _live_channels(self, target: int, component: int) -> list[Any]:
        """The channels ``(target, component)`` was heard on, each once, in the routes' order:
        0 for either is any; a network peer's only while it talks (:data:`ROUTE_IDLE_S`: a
        peer gone quiet is gone), the in-memory link's always."""
        return list(
            dict.fromkeys(
                channel
                for (sysid, compid, channel), heard in self._routes.items()
                if target in (0, sysid)
                and component in (0, compid)
                and (channel == "memory" or self.t_s - heard <= ROUTE_IDLE_S)
            )
        )

    def _dispatch(self, m: Any, signed: bool = False) -> None:
        self.stats.messages += 1
        kind = m.get_type()
        if kind == "SETUP_SIGNING":
            self._setup_signing(m, signed)
            return
        handler = getattr(self, f"_on_{kind.lower()}", None)
        if handler is None:
            self.stats.unknown += 1
            return
        handler(m)

    def _setup_signing(self, m: Any, signed: bool) -> None:
        """SETUP_SIGNING: a new key, taken only over a link already signed and while disarmed
        (an all-zero key and timestamp would turn signing off: refused, the UDP links stay signed)."""
        if not self._for_me(m) or self.signed_parser is None or not signed:
            self.statustext("Signing: SETUP_SIGNING only over a signed link")
            return
        if self.armed:
            self.statustext("ERROR: Won't setup signing when armed")
            return
        key = bytes(m.secret_key)
        if len(key) != 32 or not any(key):
            self.statustext("Signing: refused an empty key")
            return
        setup_signing(self.mav, key)
        old = self.signed_parser
        self.signed_parser = self._parser(key)
        self.signed_parser.signing.timestamp = max(old.signing.timestamp, int(m.initial_timestamp))
        self.mav.signing.timestamp = self.signed_parser.signing.timestamp
        self.statustext("Signing: new key in use", mav.MAV_SEVERITY_INFO)

    def _on_named_value_float(self, m: Any) -> None:
        self._forward_report(m)

    def _on_statustext(self, m: Any) -> None:
        self._forward_report(m)

    def _forward_report(self, m: Any) -> None:
        """The in-memory companion's report, routed to the ground station: to every peer on
        the network (one that came over the network, ``lfctl follow``'s, :meth:`_pass_on`
        passes on to every peer but its sender, as Rover's routing never sends a message back
        where it came from)."""
        if self.network is not None and m.get_srcComponent() != 1 and self._channel == "memory":
            self.network.send(bytes(m.get_msgbuf()))

    def _on_heartbeat(self, m: Any) -> None:
        if m.get_srcSystem() == int(self.param("SYSID_MYGCS")):  # Rover's handle_heartbeat: any type
            self._gcs_alive()

    def _gcs_alive(self) -> None:
        """The ground station was heard from: the GCS failsafe's clock restarts (the next
        check, with ``FS_GCS_ENABLE`` on, clears a failsafe)."""
        self._gcs_seen = self.t_s

    def _on_file_transfer_protocol(self, m: Any) -> None:
        """MAVLink FTP: the parameters and the three lists as files (:mod:`lfctl.link.ftp`)."""
        if self._for_me(m):  # (its target_network is not looked at, as Rover)
            with self._answering():  # (the banner a parameter file's opening sends, to the asker)
                self.ftp.handle(bytes(m.payload), m.get_srcSystem(), m.get_srcComponent())

    def _on_log_request_list(self, m: Any) -> None:
        """A simulated vehicle keeps no onboard (dataflash) logs, its run goes to the MCAP
        file: MAVLink's answer for none, one LOG_ENTRY with id 0 and num_logs 0, so a ground
        station's log list (QGroundControl's Onboard Logs, MAVProxy's `log list`) is empty
        at once instead of waiting out its timeout."""
        if self._for_me(m):
            self.send(mav.MAVLink_log_entry_message(0, 0, 0, 0, 0))

    def _send_ftp(self, payload: bytes, sysid: int, compid: int) -> None:
        self.send(mav.MAVLink_file_transfer_protocol_message(0, sysid, compid, list(payload)))

    def _ftp_files(self) -> dict[str, FtpFile]:
        """The files a Rover serves over MAVLink FTP that this vehicle has: its parameters
        (``@PARAM/param.pck``) and its mission, fence and rally points (``@MISSION``)."""
        files = {
            "@PARAM/param.pck": self.param_server.ftp_file(on_open=self._banner),  # Rover's banner, as a list's
        }
        for mtype, name in MISSION_TYPES.items():
            files[f"@MISSION/{name}.dat"] = FtpFile(
                lambda _query, mtype=mtype: self.missions.packed(mtype),
                lambda data, sysid, compid, mtype=mtype: self.missions.upload_packed(
                    mtype, data, sysid, compid, self.t_s
                ),
                partial(self.missions.packed_size, mtype),
            )
        return files

    # -- pilot input ----------------------------------------------------------------------------
    def _from_my_gcs(self, m: Any) -> bool:
        """Sticks are taken from ``SYSID_MYGCS`` only, as Rover. Rover is silent about the
        rest; lfctl tells each other sender once per ``SYSID_MYGCS``, at most one text every
        :data:`RC_REFUSED_TEXT_S` seconds (a burst from many senders is not a burst of texts)."""
        sysid, mine = m.get_srcSystem(), int(self.param("SYSID_MYGCS"))
        if sysid == mine:
            return True
        if self._rc_refused_for != mine:  # a new SYSID_MYGCS: everyone else may be told again
            self._rc_refused_for, self._rc_refused = mine, set()
        if sysid not in self._rc_refused and self.t_s >= self._rc_refused_text_t + RC_REFUSED_TEXT_S:
            self._rc_refused.add(sysid)  # at most 256 senders
            self._rc_refused_text_t = self.t_s
            what = "Manual control" if m.get_type() == "MANUAL_CONTROL" else "RC override"
            self.statustext(f"{what} from {sysid} ignored: SYSID_MYGCS {mine}", mav.MAV_SEVERITY_WARNING)
        return False

    def _on_rc_channels_override(self, m: Any) -> None:
        if not self._for_me(m) or not self._from_my_gcs(m):
            return
        channels = [getattr(m, f"chan{k}_raw", 0) for k in range(1, 19)]
        self.rc.from_rc_override(channels, self.t_s)
        self._gcs_alive()  # Rover counts the ground station's sticks as its heartbeat

    def _on_manual_control(self, m: Any) -> None:
        if m.target != self.sysid:  # Rover: only control aimed at this vehicle (0 is not "all" here)
            self.stats.other_sysid += 1
            return
        if not self._from_my_gcs(m):
            return
        self.rc.from_manual_control(m.y, m.z, self.t_s)
        self._gcs_alive()

    def pilot_input(self) -> PilotInput:
        """The sticks MANUAL drives by now: the live overrides on the steering and throttle
        channels (:mod:`lfctl.link.rc`), centred where there is none."""
        return self.rc.pilot(self.t_s, self.param("RC_OVERRIDE_TIME"))

    # -- modes --------------------------------------------------------------------------------
    def _on_timesync(self, m: Any) -> None:
        """TIMESYNC: a request (``tc1`` 0) is answered with the autopilot's clock, ns since
        boot, and the request's ``ts1``, on the asker's link alone, as Rover's
        ``handle_timesync`` answers on its channel (MAVROS and MAVSDK estimate the link's time
        offset from it); an answer to someone else's is not ours."""
        if m.tc1 != 0 or getattr(m, "target_system", 0) not in (0, self.sysid):
            return
        self._answer(mav.MAVLink_timesync_message(self._boot_us() * 1000, m.ts1))

    def _on_set_mode(self, m: Any) -> None:
        """SET_MODE (the message): as DO_SET_MODE, and answered as Rover answers it, with a
        COMMAND_ACK whose command is the message's id, 11 (scripts wait for it)."""
        if not self._for_me(m):
            return
        result = self._mode_command(m.base_mode, m.custom_mode)
        self.send(
            mav.MAVLink_command_ack_message(
                mav.MAVLINK_MSG_ID_SET_MODE, result, 0, 0, m.get_srcSystem(), m.get_srcComponent()
            )
        )

    def _mode_command(self, base_mode: int, custom_mode: int) -> int:
        """A mode change a ground station asked for (SET_MODE, DO_SET_MODE): only a custom
        mode is taken (else DENIED), FAILED when the mode is refused (Rover's
        ``_set_mode_common``); base_mode 128 alone is the safety switch (:meth:`_safety_switch`),
        custom_mode 0 off and 1 on, any other DENIED."""
        if base_mode == mav.MAV_MODE_FLAG_DECODE_POSITION_SAFETY:
            if custom_mode not in (0, 1):
                return mav.MAV_RESULT_DENIED  # neither off (0) nor on (1): Rover's "invalid parameters"
            return self._safety_switch(custom_mode == 0)
        if not base_mode & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return mav.MAV_RESULT_DENIED
        return mav.MAV_RESULT_ACCEPTED if self.set_mode(custom_mode) else mav.MAV_RESULT_FAILED

    @staticmethod
    def _safety_switch(outputs_on: bool) -> int:
        """The safety switch asked for (SET_MODE with base_mode 128 alone, custom_mode 0 off
        and 1 on; MAV_CMD_DO_SET_SAFETY_SWITCH_STATE): the vehicle is a board without one, its
        outputs always live (SYS_STATUS says so), as Rover on such a board answers: off is
        ACCEPTED (``force_safety_off`` does nothing), on FAILED (``force_safety_on`` cannot)."""
        return mav.MAV_RESULT_ACCEPTED if outputs_on else mav.MAV_RESULT_FAILED

    def set_mode(self, custom_mode: int) -> bool:
        """Switch mode as Rover would (the next HEARTBEAT goes out at once); False, with a
        STATUSTEXT, when the mode is unknown or cannot start: FOLLOW (lfctl follows through
        GUIDED), AUTO without a mission, SmartRTL with no way back recorded.

        Parameters
        ----------
        custom_mode : int
            The Rover mode number (a value of :data:`MODES`).
        """
        custom_mode &= 0xFF  # Rover's mode number is a byte: 260 is HOLD's 4
        if custom_mode == self.mode:
            return True  # as Rover: already there, nothing changes (a GUIDED target is kept)
        if custom_mode == INITIALISING_MODE:
            return self._refuse_mode(None)  # Rover's ModeInitializing never starts: its failure alone
        if custom_mode in OTHER_ROVER_MODES:  # a Rover mode lfctl's vehicle has not: it fails as Rover's do
            return self._refuse_mode(f"{OTHER_ROVER_MODES[custom_mode]} mode not supported")
        if custom_mode not in MODE_NAMES:
            self.statustext(f"No such mode {custom_mode}", mav.MAV_SEVERITY_WARNING)  # AP_Vehicle's words
            return False
        if custom_mode == MODES["FOLLOW"]:
            # ArduPilot's FOLLOW chases another vehicle's GLOBAL_POSITION_INT; lfctl follows by
            # camera, through GUIDED and the companion: refuse rather than accept and do nothing
            return self._refuse_mode("FOLLOW mode not supported: use GUIDED")
        if custom_mode == MODES["AUTO"] and len(self.mission) < 2:
            return self._refuse_mode("No Mission. Can't set AUTO.", mav.MAV_SEVERITY_NOTICE)  # Rover's, at NOTICE
        if custom_mode == MODES["SMART_RTL"] and not self.path_started:
            return self._refuse_mode(
                "SmartRTL unavailable: no path recorded"
                if not self.path_generation
                else "SmartRTL unavailable: no path kept"
            )
        self._enter(custom_mode)
        return True

    def _refuse_mode(self, why: str | None, severity: int = mav.MAV_SEVERITY_WARNING) -> bool:
        """A mode that cannot start: its reason (if any), then Rover's "Flight mode change failed"."""
        if why is not None:
            self.statustext(why, severity)
        self.statustext("Flight mode change failed", mav.MAV_SEVERITY_WARNING)
        return False

    def _enter(self, custom_mode: int) -> None:
        if custom_mode != self.mode and self._breached_fences:  # Rover's set_mode
            self._fence_recovery_until = self.t_s + FENCE_RECOVERY_S
            self.statustext("Manual recovery started", mav.MAV_SEVERITY_INFO)  # AC_Fence::manual_recovery_start
        if custom_mode != self.mode:
            log.info("%s: mode %s -> %s", self.name, MODE_NAMES[self.mode], MODE_NAMES[custom_mode])
            self.modes.append((self.t_s, custom_mode))
            if custom_mode in AUTOPILOT_MODES:
                # Rover's autopilot modes start forwards (Mode::enter clears the reversed
                # flag) at their default speed (each mode's _enter)
                self.reversed = False
                self.desired_speed_mps = None
            if custom_mode == MODES["AUTO"] and self.param("MIS_RESTART") == 1 and self.missions.set_current(1):
                # AP_Mission::start_or_resume with MIS_RESTART 1: start(), from the first item
                # with DO_JUMP's counts afresh, whether the mission was finished or not
                self.mission_restarts += 1
                self.mission_version += 1
                self.mission_complete = False
            elif custom_mode == MODES["AUTO"] and self.mission_complete and self.missions.set_current(1):
                # a finished mission starts again from its first item (AP_Mission::resume)
                self.mission_version += 1
                self.mission_complete = False
        if custom_mode == MODES["SMART_RTL"] and self.mode != custom_mode:
            # the way back cleaned of its straight runs' points and its loops before it is
            # driven (ModeSmartRTL's WaitForPathCleanup: a thorough cleanup)
            self.path = clean_way_back(self.path, self.param("SRTL_ACCURACY"), self._smartrtl_points())
        self.mode = custom_mode
        if custom_mode == MODES["GUIDED"]:
            self.guided = None  # entering GUIDED stops until a target comes
            self._guided_arrived = False
        self._guided_stale_reported = False
        self._soon(MSG_IDS["HEARTBEAT"])  # tell the ground stations now

    def force_mode(self, name: str) -> None:
        """Put the vehicle in a mode without Rover's checks (the simulation's own set-up,
        e.g. AUTO for a scripted leader that has no mission).

        Parameters
        ----------
        name : str
            A key of :data:`MODES`.
        """
        self._enter(MODES[name])

    # -- commands -------------------------------------------------------------------------
    def _ack(self, m: Any, result: int) -> None:
        self.send(mav.MAVLink_command_ack_message(m.command, result, 0, 0, m.get_srcSystem(), m.get_srcComponent()))

    def _on_command_long(self, m: Any) -> None:
        if not self._for_me(m):
            return
        p = [m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7]
        self._ack(m, self._command(m.command, p, None, mav.MAV_FRAME_GLOBAL, m.target_component))
        if self._reboot_due:
            self.reboot()

    def _on_command_int(self, m: Any) -> None:
        if not self._for_me(m):
            return
        p = [m.param1, m.param2, m.param3, m.param4, float(m.x), float(m.y), m.z]
        self._ack(m, self._command(m.command, p, (m.x, m.y), m.frame, m.target_component))
        if self._reboot_due:
            self.reboot()

    def _command(
        self, cmd: int, p: list[float], latlon_e7: tuple[int, int] | None, frame: int, target_component: int = 0
    ) -> int:
        """The MAV_RESULT of one command; ``latlon_e7`` is COMMAND_INT's x, y (degE7), ``frame``
        its frame (a COMMAND_LONG's is GLOBAL, as ArduPilot reads a location in one),
        ``target_component`` the component the command was addressed to (0: all)."""
        if cmd == mav.MAV_CMD_COMPONENT_ARM_DISARM:
            return self._arm_command(p[0], p[1])
        if cmd == mav.MAV_CMD_DO_SET_MODE:
            base, custom = _as_int(p[0], 0, 255), _as_int(p[1], 0, 2**31 - 1)
            if base is None or custom is None:
                return mav.MAV_RESULT_DENIED
            return self._mode_command(base, custom)
        if cmd == mav.MAV_CMD_REQUEST_MESSAGE:
            msg_id = _c_uint32(p[0])
            if msg_id is None:
                return mav.MAV_RESULT_DENIED
            if msg_id == mav.MAVLINK_MSG_ID_MESSAGE_INTERVAL:  # as Rover: GET_MESSAGE_INTERVAL of param2's id
                return self._get_interval(p[1])
            if msg_id == MSG_IDS["PARAM_VALUE"]:
                # as Rover: PARAM_VALUE is its parameter stream (param2 is not read), and asking
                # for it sends the next parameters of a list under way, nothing otherwise; lfctl
                # sends a list whole at once, so none is ever under way and nothing goes out
                return mav.MAV_RESULT_ACCEPTED
            if msg_id not in (*self._rates.intervals, MSG_IDS["AUTOPILOT_VERSION"]):
                return mav.MAV_RESULT_FAILED  # as ArduPilot: a message it does not send (no text)
            self._once.append((msg_id, self._asker()))
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            if p[0] != 1.0:
                return mav.MAV_RESULT_FAILED  # as Rover: param1 must be 1
            self._once.append((MSG_IDS["AUTOPILOT_VERSION"], self._asker()))
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN:
            return self._reboot_command(p, target_component)
        if cmd == mav.MAV_CMD_PREFLIGHT_STORAGE:
            # as Rover (QGroundControl's "Reset all to firmware's defaults"): param1 2 erases the
            # parameters, which take their defaults when the autopilot next starts; any other
            # storage action is not one lfctl's vehicle has
            if p[0] != 2.0:
                return mav.MAV_RESULT_DENIED
            self._params_erased = {name: prm.value for name, prm in self.params.items()}
            self.statustext("All parameters reset, reboot board", mav.MAV_SEVERITY_WARNING)
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_DO_SEND_BANNER:
            with self._answering():  # as Rover's send_banner: on the asking link
                self._banner()
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_DO_SET_SAFETY_SWITCH_STATE:
            if p[0] not in (mav.SAFETY_SWITCH_STATE_SAFE, mav.SAFETY_SWITCH_STATE_DANGEROUS):
                return mav.MAV_RESULT_DENIED
            return self._safety_switch(p[0] == mav.SAFETY_SWITCH_STATE_DANGEROUS)
        if cmd == mav.MAV_CMD_RUN_PREARM_CHECKS:
            if self.armed:
                return mav.MAV_RESULT_TEMPORARILY_REJECTED
            self._say_failures("PreArm", self._run_prearm_checks())
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_DO_SET_HOME:
            return self._set_home_command(p, latlon_e7, frame)
        if cmd == mav.MAV_CMD_GET_HOME_POSITION:
            self._once += [(MSG_IDS["HOME_POSITION"], self._asker()), (MSG_IDS["GPS_GLOBAL_ORIGIN"], self._asker())]
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_SET_MESSAGE_INTERVAL:
            return self._set_interval(p[0], p[1], p[2])
        if cmd == mav.MAV_CMD_GET_MESSAGE_INTERVAL:
            return self._get_interval(p[0])
        if cmd == mav.MAV_CMD_MISSION_START:
            if not (abs(p[0]) < FLT_EPSILON and abs(p[1]) < FLT_EPSILON):  # Rover's is_zero (NaN is not)
                return mav.MAV_RESULT_DENIED  # first / last item: not supported, as Rover
            return mav.MAV_RESULT_ACCEPTED if self.set_mode(MODES["AUTO"]) else mav.MAV_RESULT_FAILED
        if cmd == mav.MAV_CMD_DO_SET_MISSION_CURRENT:
            return self._set_current_command(p[0], p[1])
        if cmd == mav.MAV_CMD_DO_JUMP_TAG:
            # as Rover's handle_command_do_jump_tag: the first JUMP_TAG of the tag becomes the
            # current item (AP_Mission::jump_to_tag); no such tag, FAILED
            if not (_finite(p[0]) and 0 <= p[0] <= 65535):
                return mav.MAV_RESULT_DENIED  # not a tag (Rover: above UINT16_MAX)
            seq = jump_tag_item(self.mission, math.trunc(p[0]))
            if seq == 0 or not self.set_current(seq):
                return mav.MAV_RESULT_FAILED
            self._once.append((MSG_IDS["MISSION_CURRENT"], None))
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return mav.MAV_RESULT_ACCEPTED if self.set_mode(MODES["RTL"]) else mav.MAV_RESULT_FAILED
        if cmd == mav.MAV_CMD_DO_REPOSITION:
            return self._reposition(p, latlon_e7, frame)
        if cmd == mav.MAV_CMD_DO_SET_REVERSE:
            if not _finite(p[0]):
                return mav.MAV_RESULT_DENIED
            self.reversed = p[0] == 1.0
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_DO_CHANGE_SPEED:
            return self._change_speed(p[0], p[1])
        if cmd == mav.MAV_CMD_DO_FENCE_ENABLE:
            return self._fence_enable_command(p[0], p[1])
        # anything else, MAV_CMD_NAV_SET_YAW_SPEED too: Rover 4.5 took it (deprecated), Rover's
        # newest source is built without it (AP_MAVLINK_MAV_CMD_NAV_SET_YAW_SPEED_ENABLED 0)
        return mav.MAV_RESULT_UNSUPPORTED

    def prearm_failures(self) -> list[str]:
        """What keeps this vehicle from arming now, as Rover's pre-arm checks say it, in
        their order (none with ``ARMING_CHECK`` 0, or once armed): the fence (whatever
        ``ARMING_CHECK``'s bits, see :meth:`_fence_failure`), then, with the parameter checks
        on (``ARMING_CHECK`` 1 or bit 32), a ``WP_SPEED`` of 0, then its mode (RTL and SmartRTL
        do not allow arming, ``Mode::allows_arming``)."""
        checks = int(self.param("ARMING_CHECK"))
        if self.armed or checks == 0:
            return []
        failures = []
        if (fence := self._fence_failure()) is not None:
            failures.append(fence)
        if checks & (ARMING_CHECK_ALL | ARMING_CHECK_PARAMETERS) and self.param("WP_SPEED") <= 0:
            failures.append("WP_SPEED too low")
        if self.mode in NOT_ARMABLE:
            failures.append("Mode not armable")
        return failures

    def _arm_command(self, arm: float, force: float = 0.0) -> int:
        if not _finite(arm) or arm not in (0.0, 1.0):
            return mav.MAV_RESULT_UNSUPPORTED  # as Rover: neither arm (1) nor disarm (0)
        if arm == 1.0 and force not in FORCE_ARM:
            failures = self._run_prearm_checks()  # a ground station switches to HOLD first, as MAVSDK does
            self._say_failures("Arm", failures)
            if failures:
                return mav.MAV_RESULT_FAILED
        if arm == 1.0 and not self.armed and self.param("ARMING_CHECK") == 0 and force not in FORCE_ARM:
            # Rover's, on an arm that runs the checks (AP_Arming::arm's do_arming_checks): not a forced one
            self.statustext("Warning: Arming Checks Disabled", mav.MAV_SEVERITY_WARNING)
        self.set_armed(arm == 1.0)
        return mav.MAV_RESULT_ACCEPTED

    def set_armed(self, armed: bool) -> None:
        """Arm or disarm (home stays where the vehicle was while disarmed, see :attr:`home_ned`).
        As Rover's ``AP_Arming_Rover::disarm``: disarmed in any mode but AUTO, the mission is
        reset (``AP_Mission::reset``), so AUTO next starts it from its first item with
        DO_JUMP's counts afresh; disarmed in AUTO, it resumes where it was.

        Parameters
        ----------
        armed : bool
            Arm (True) or disarm.
        """
        if armed:
            self._update_home()  # where it stands now, unless a ground station put home
        if armed != self.armed:
            self.armed = armed
            self.statustext("Throttle armed" if armed else "Throttle disarmed", mav.MAV_SEVERITY_INFO)  # Rover's
            if armed:  # SmartRTL's way back starts here afresh (AP_Arming_Rover::arm: smart_rtl.set_home)
                self._start_path()
            if not armed and self.mode != MODES["AUTO"] and len(self.mission) > 1:
                complete = self.mission_complete
                self.set_current(1, reset=True)
                # AP_Mission::reset leaves no item under way (MISSION_CURRENT seq 0) and the
                # mission's state as it was; AUTO then starts it from item 1
                self.missions.current_seq = 0
                self.mission_complete = complete
        self._soon(MSG_IDS["HEARTBEAT"])  # tell the ground stations now

    def _set_interval(self, msg_id_f: float, interval_us: float, response_target: float = 0.0) -> int:
        """MAV_CMD_SET_MESSAGE_INTERVAL as ArduPilot takes it: -1 stops the message, 0 puts
        back its default rate, under 1 ms is 1 ms, over 60 s is 60 s; a message this vehicle
        does not send is DENIED (one for equipment it has not fitted, :data:`NOT_FITTED`, is
        ACCEPTED and stays unsent). The interval is kept in whole ms, as Rover's. One faster
        than 0.8 x ``SCHED_LOOP_RATE`` (under 25 ms at Rover's default 50 Hz) is DENIED with
        Rover's "Requested rate for message ID ... too fast. Increase SCHED_LOOP_RATE", as
        Rover 4.6's ``set_message_interval`` (older Rovers slowed it to that silently). A response
        target (param3) other than 0, the sender's own link, is DENIED before anything else is
        looked at, as Rover's
        ``handle_command_set_message_interval``. PARAM_VALUE's rate is Rover's parameter
        stream's: never stopped (-1 and 0 are its default, 100 ms), never slower than
        :data:`PARAM_SLOWEST_MS`."""
        if response_target != 0:  # NaN too: Rover's is_zero is false for it
            return mav.MAV_RESULT_DENIED
        # Rover casts param1 to uint32_t and param2 to int32_t: a fraction is cut off (-1.5 is
        # -1, stop; 0.5 is 0, the default); a value no such integer holds (NaN too), which C
        # leaves undefined, lfctl DENIES
        msg_id, interval = _c_uint32(msg_id_f), _c_int32(interval_us)
        if msg_id is None or interval is None or interval < -1:
            return mav.MAV_RESULT_DENIED
        interval_us = interval
        known = msg_id == MSG_IDS["PARAM_VALUE"] or msg_id in self._rates.intervals
        # whole ms as Rover keeps it (interval_us / 1000 in integers; under 1 ms is 1, over 60 s
        # is 60 s); 0 for -1 (stop) and 0 (the default)
        ms = min(max(interval_us // 1000, 1), 60000) if interval_us > 0 else 0
        if known and ms and self._cap_ms(ms) > ms:  # faster than 0.8 x the loop rate: refused
            self.statustext(
                f"Requested rate for message ID {msg_id} too fast. Increase SCHED_LOOP_RATE", mav.MAV_SEVERITY_INFO
            )
            return mav.MAV_RESULT_DENIED
        if msg_id == MSG_IDS["PARAM_VALUE"]:
            # as Rover's set_ap_message_interval for its parameter stream: never stopped (-1,
            # 0 ms, is 100 ms, as is the default, 0) and never slower than 1 s; a faster rate
            # is kept (whole ms, down to 0.8 x the loop rate, as for any message)
            period = PARAM_STREAM_PERIOD_S if ms == 0 else min(ms, PARAM_SLOWEST_MS) / 1000
            self._channel_rates(own=True).param_period_s = period
            return mav.MAV_RESULT_ACCEPTED
        if msg_id not in self._rates.intervals:
            self.statustext(f"No ap_message for mavlink id ({msg_id})", mav.MAV_SEVERITY_INFO)
            return mav.MAV_RESULT_DENIED  # Rover's newest source (MAVSDK: "Command Denied"); older: FAILED
        rates = self._channel_rates(own=True)
        if interval_us == -1:
            rates.stream(msg_id, math.inf, self.t_s)
        elif interval_us == 0:  # its group's rate, as a REQUEST_DATA_STREAM last set it (Rover's SRx_)
            default = _period(STREAMS.get(ID_NAMES.get(msg_id, ""), 0.0))
            rates.stream(msg_id, rates.groups.get(msg_id, default), self.t_s)
        else:
            rates.stream(msg_id, ms / 1000, self.t_s)
        return mav.MAV_RESULT_ACCEPTED

    def _channel_rates(self, own: bool = False) -> StreamRates:
        """The telemetry schedule of the channel the message in hand came on. ``own``: a
        network peer about to set a rate gets one of its own (a copy of the defaults, and its
        groups' rates), as each of a Rover's links keeps its own; else a peer that has none
        reads the shared one."""
        channel = self._channel
        if channel == "memory" or self.network is None:
            return self._rates
        rates = self._peer_rates.get(channel)
        if rates is None and own:
            if len(self._peer_rates) >= MAX_PEERS:  # the one heard from longest ago makes room
                heard = {c: -math.inf for c in self._peer_rates}
                for (_, _, c), t in self._routes.items():
                    if c in heard:
                        heard[c] = max(heard[c], t)
                del self._peer_rates[min(heard, key=heard.__getitem__)]
            rates = self._peer_rates[channel] = StreamRates()
        return rates or self._rates

    def _soon(self, msg_id: int) -> None:
        """Send ``msg_id`` at this tick on every channel that streams it."""
        for rates in (self._rates, *self._peer_rates.values()):
            rates.soon(msg_id, self.t_s)

    def _get_interval(self, msg_id_f: float) -> int:
        """MAV_CMD_GET_MESSAGE_INTERVAL as ArduPilot answers it: MESSAGE_INTERVAL with the
        interval, -1 for a message stopped; 0 and FAILED for one not sent (its id cut to the
        field's 16 bits, as ArduPilot's C does)."""
        msg_id = _c_uint32(msg_id_f)  # Rover's cast (a value no uint32_t holds: DENIED)
        if msg_id is None:
            return mav.MAV_RESULT_DENIED
        if msg_id == MSG_IDS["PARAM_VALUE"]:  # Rover's parameter stream: always has a rate
            period_us = int(round(self._channel_rates().param_period_s * 1e6))
            self._answer(mav.MAVLink_message_interval_message(msg_id, period_us))
            return mav.MAV_RESULT_ACCEPTED
        period = self._channel_rates().intervals.get(msg_id)
        if period is None:
            self._answer(mav.MAVLink_message_interval_message(msg_id & 0xFFFF, 0))
            return mav.MAV_RESULT_FAILED
        interval_us = -1 if math.isinf(period) else int(round(period * 1e6))
        self._answer(mav.MAVLink_message_interval_message(msg_id, interval_us))
        return mav.MAV_RESULT_ACCEPTED

    def _on_request_data_stream(self, m: Any) -> None:
        """REQUEST_DATA_STREAM (MAVProxy and Mission Planner send it): the messages of Rover's
        stream group at the rate asked for, read as Rover reads it (:func:`_stream_interval_ms`;
        start_stop 0 stops them). HEARTBEAT and HOME_POSITION are in no group, as on Rover."""
        if not self._for_me(m) or m.start_stop not in (0, 1):
            return
        names = DATA_STREAMS.get(m.req_stream_id, ())  # other groups: messages not sent here
        interval_ms = _stream_interval_ms(int(m.req_message_rate)) if m.start_stop == 1 else 0
        rates = self._channel_rates(own=bool(names))
        # no faster than 0.8 x the loop rate (Rover's set_ap_message_interval); 0: not sent
        period = self._cap_ms(interval_ms) / 1000 if interval_ms else math.inf
        for name in names:
            rates.groups[MSG_IDS[name]] = period
            rates.stream(MSG_IDS[name], period, self.t_s)

    def _change_speed(self, speed_type: float, speed: float) -> int:
        # as Rover: climb and descent speeds (and SPEED_TYPE_ENUM_END) are DENIED, any other
        # type is a ground speed; lfctl also DENIES a type or speed that is not a number, and
        # a speed over 100 m/s
        kind = _as_int(speed_type, 0, 255)
        if kind is None or kind in (mav.SPEED_TYPE_CLIMB_SPEED, mav.SPEED_TYPE_DESCENT_SPEED, SPEED_TYPE_ENUM_END):
            return mav.MAV_RESULT_DENIED
        if not (_finite(speed) and speed <= 100.0):
            return mav.MAV_RESULT_DENIED
        if not self._takes_speed(speed):
            return mav.MAV_RESULT_FAILED
        self.desired_speed_mps = float(speed)
        return mav.MAV_RESULT_ACCEPTED

    def _takes_speed(self, speed: float) -> bool:
        """Whether the mode takes a new speed now (Rover's ``Mode::set_desired_speed``): AUTO,
        GUIDED, RTL and SmartRTL, at least :data:`WP_SPEED_MIN_MPS` (a speed of 0 or less, or
        MAVLink's -1 "no change", FAILS on Rover); GUIDED only while it drives to a place or
        has arrived there, not while stopped as it starts nor for a rate or heading target
        with its own speed."""
        if speed < WP_SPEED_MIN_MPS or self.mode not in (
            MODES["AUTO"], MODES["GUIDED"], MODES["RTL"], MODES["SMART_RTL"]
        ):  # fmt: skip
            return False
        return self.mode != MODES["GUIDED"] or (
            self.guided.kind == "location" if self.guided is not None else self._guided_arrived
        )

    def _reposition(self, p: list[float], latlon_e7: tuple[int, int] | None, frame: int) -> int:
        """MAV_CMD_DO_REPOSITION as Rover's ``handle_command_int_do_reposition``: a
        COMMAND_INT only (a COMMAND_LONG is UNSUPPORTED: Rover reads no location from one for
        it); outside GUIDED only with the change-mode flag; a place off the globe, at 0, 0, or
        whose altitude is not a number, beyond 83 km or in a frame Rover cannot read is
        DENIED; GUIDED is entered, then a speed (param1 > 0) must be one GUIDED takes now
        (FAILED from a GUIDED just entered, which is stopped) and becomes the waypoint speed
        (which a later DO_CHANGE_SPEED replaces, and later targets keep), then the place is
        the target (FAILED outside the fence, the vehicle left in GUIDED, stopped)."""
        if latlon_e7 is None:
            return mav.MAV_RESULT_UNSUPPORTED
        change_modes = _finite(p[1]) and int(p[1]) & REPOSITION_CHANGE_MODE
        if self.mode != MODES["GUIDED"] and not change_modes:
            return mav.MAV_RESULT_DENIED
        where = _command_latlon(p, latlon_e7)
        if where is None or where == (0, 0) or self._height_above_ground(p[6], frame) is None:
            return mav.MAV_RESULT_DENIED
        n, e = global_to_local(*where, self.home)
        if self.mode != MODES["GUIDED"] and not self.set_mode(MODES["GUIDED"]):
            return mav.MAV_RESULT_FAILED
        speed = p[0] if _finite(p[0]) and p[0] > 0 else 0.0
        if speed > 0 and not self._takes_speed(speed):
            return mav.MAV_RESULT_FAILED
        if speed > 0:  # the waypoint speed, as Rover's set_speed_max: a DO_CHANGE_SPEED replaces it
            self.desired_speed_mps = speed
        if not self._within_fence(n, e):  # (GUIDED entered first: as Rover, it is left there, stopped)
            return mav.MAV_RESULT_FAILED
        self.guided = GuidedTarget("location", self.t_s, north_m=n, east_m=e)
        return mav.MAV_RESULT_ACCEPTED

    def _set_home_command(self, p: list[float], latlon_e7: tuple[int, int] | None, frame: int) -> int:
        """MAV_CMD_DO_SET_HOME: param1 = 1 (or no position) puts home where the vehicle is,
        else at the command's latitude, longitude and altitude (param7 / z, in the command's
        frame); either way it stays there."""
        here = p[0] == 1.0
        where = None if here else _command_latlon(p, latlon_e7)
        if not here and where != (0, 0) and p[0] != 0.0:
            return mav.MAV_RESULT_FAILED  # as Rover: here (1, or at 0, 0) or there (0)
        if not here and where is None:
            return mav.MAV_RESULT_DENIED
        if here or where == (0, 0):
            self.set_home(self.state["north_m"], self.state["east_m"])
            return mav.MAV_RESULT_ACCEPTED
        up = self._height_above_ground(p[6], frame)
        if up is None:
            return mav.MAV_RESULT_DENIED  # as Rover: a frame it cannot read a location in
        self.set_home(*global_to_local(*where, self.home), up)
        return mav.MAV_RESULT_ACCEPTED

    def _height_above_ground(self, alt_m: float, frame: int) -> float | None:
        """A command's altitude as a height above lfctl's flat ground, m: above mean sea level
        (GLOBAL), above home (RELATIVE_ALT) or above the terrain (TERRAIN_ALT, the ground);
        None for another frame, or an altitude beyond :data:`LOCATION_ALT_MAX_M` either way
        (as Rover's location_from_command_t, before the frame is applied)."""
        if not _finite(alt_m) or abs(alt_m) > LOCATION_ALT_MAX_M:
            return None
        if frame in (mav.MAV_FRAME_GLOBAL, mav.MAV_FRAME_GLOBAL_INT):
            return alt_m - self.home[2]
        if frame in (mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT):
            return self.home_up_m + alt_m
        if frame in (mav.MAV_FRAME_GLOBAL_TERRAIN_ALT, mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT):
            return alt_m
        return None

    # -- parameters -------------------------------------------------------------------------
    def _reboot_command(self, p: list[float], target_component: int = 0) -> int:
        """MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN as Rover takes it: param1 1 reboots the autopilot
        (3, into its bootloader, and shutting down are not lfctl's: UNSUPPORTED); an armed
        vehicle only with param6 = :data:`FORCE_REBOOT`. The ACK goes out first, as on Rover.
        Addressed to another component of this system (one the autopilot acts for, having no
        route to it), it is DENIED before anything else, as Rover's ``handle_preflight_reboot``:
        a reboot meant for a camera or a companion must not restart the autopilot."""
        if target_component not in (0, 1):
            return mav.MAV_RESULT_DENIED
        if self.armed and p[5] != FORCE_REBOOT:
            return mav.MAV_RESULT_FAILED  # checked first, as Rover: armed, any param1 is FAILED
        if p[0] != 1.0:
            return mav.MAV_RESULT_UNSUPPORTED
        self._reboot_due = True
        return mav.MAV_RESULT_ACCEPTED

    def reboot(self) -> None:
        """Restart the autopilot: for :data:`REBOOT_S` it sends nothing and acts on nothing
        that comes in (what arrives is still recorded); then it starts as it started at first
        (disarmed, in the mode it was created in, every channel's stream rates at their
        defaults: Rover saves neither SET_MESSAGE_INTERVAL's nor REQUEST_DATA_STREAM's; home
        following the vehicle, no GUIDED target, time_boot_ms and every channel's MAVLink
        sequence from 0) and says "ArduPilot Ready". Parameters, the mission
        (from its first item), the fence and the rally points are kept, as a Rover keeps them
        in storage; parameters erased (PREFLIGHT_STORAGE) and not set since come back at
        Rover's defaults. The vehicle stays where it is; disarmed, it stops."""
        self._reboot_due = False
        if self._params_erased is not None:
            erased, self._params_erased = self._params_erased, None
            for name, fresh in default_params(self.sysid).items():
                if self.params[name].value == erased[name]:  # not set since the erase
                    self.params[name].value = fresh.value
        self._start()
        self.missions.restart()
        self.ftp.reset()  # its sessions were in RAM
        self.mission_version += 1
        self.mav.seq = 0
        self._seqs.clear()  # every channel's sequence starts again
        self.modes.append((self.t_s, self.mode))
        self._boot_t_s = self.t_s + REBOOT_S
        self._booting_until = self._boot_t_s
        self._ready_said = False
        log.info("%s: rebooting", self.name)

    @property
    def rebooting(self) -> bool:
        """The autopilot is restarting (see :meth:`reboot`)."""
        return self.t_s < self._booting_until

    def _boot_ms(self) -> int:
        """time_boot_ms: ms since the autopilot last started, as uint32."""
        return int((self.t_s - self._boot_t_s) * 1000) & 0xFFFFFFFF

    def _boot_us(self) -> int:
        """A time_usec that counts from boot: us since the autopilot last started."""
        return int((self.t_s - self._boot_t_s) * 1e6)

    def _banner(self) -> None:
        """Rover's banner (MAV_CMD_DO_SEND_BANNER, and before a parameter list as on Rover):
        the firmware line a log and a ground station's console start with, then which
        simulated vehicle this is (Rover's second line is its board's serial number)."""
        self.statustext(f"lfctl V{__version__} (Rover, ArduPilot MAVLink)", mav.MAV_SEVERITY_INFO)
        self.statustext(f"lfctl sim: {self.name}, sysid {self.sysid}", mav.MAV_SEVERITY_INFO)

    # a list and a read are answered to the asker alone, as Rover sends them on the asking
    # link; a set's new value goes to every peer (GCS::send_parameter_value)
    def _on_param_request_list(self, m: Any) -> None:
        if self._for_me(m):
            with self._answering():
                self._banner()  # as Rover: a parameter list starts with the banner
                self.param_server.request_list()

    def _on_param_request_read(self, m: Any) -> None:
        if self._for_me(m):
            with self._answering():
                self.param_server.request_read(m)

    def _on_param_set(self, m: Any) -> None:
        if self._for_me(m):
            self.param_server.set(m)

    # -- missions, fence, rally -------------------------------------------------------------
    def _list_changed(self, mission_type: int, items: list[MissionItem]) -> None:
        if mission_type == MISSION:
            # a new mission; a finished one stays finished (AP_Mission's state) until AUTO is
            # entered again, which starts the new one from its first item
            self.mission_version += 1
        elif mission_type == FENCE:
            self.fence = Fence.from_items(items, self.home)
        elif mission_type == RALLY:
            self.rally = rally_points(items, self.home)

    def _list_received(self, mission_type: int) -> None:
        """An upload ended accepted. As Rover's MissionItemProtocol_*::complete: a mission's
        (of no items, or a partial update, too) is "Flight plan received", which scripts wait
        for; a fence's and the rally points' end without a word (a clear is never said)."""
        if mission_type == MISSION:
            self.statustext("Flight plan received", mav.MAV_SEVERITY_INFO)

    def _list_edited(self, mission_type: int, items: list[MissionItem]) -> None:
        """Items changed in place (a partial update): the mission is the same mission, edited
        (not finished again, its DO_JUMP counts kept); the fence and rally points as they are now."""
        if mission_type == MISSION:
            self.mission_edits += 1
        elif mission_type == FENCE:
            self.fence = Fence.from_items(items, self.home)
        elif mission_type == RALLY:
            self.rally = rally_points(items, self.home)

    def store_mission(self, items: list[MissionItem]) -> None:
        """Make ``items`` (item 0 = home) the mission in force, item 1 current, as a finished
        upload does; a stored mission on a real rover is loaded this way at boot.

        Parameters
        ----------
        items : list of MissionItem
            The validated mission.
        """
        self.missions.store(MISSION, items)

    def _on_mission_count(self, m: Any) -> None:
        if self._for_me(m):
            self.missions.on_count(m, self.t_s)

    def _on_mission_item_int(self, m: Any) -> None:
        if not self._for_me(m):
            return
        item = MissionItem(
            m.seq, m.frame, m.command, m.param1, m.param2, m.param3, m.param4, m.x, m.y, m.z, m.autocontinue
        )
        self._mission_item(m, item)

    def _on_mission_item(self, m: Any) -> None:
        # the float (non-_INT) item: ArduPilot still takes it; convert, refusing what is not a number
        if not self._for_me(m):
            return
        mtype = getattr(m, "mission_type", MISSION)
        # degrees, but for the few commands whose x and y are not a place (carried as they are)
        raw = m.command in RAW_XY
        x_max, y_max, scale = (INT32_MAX, INT32_MAX, 1.0) if raw else (90.0, 180.0, 1e7)
        if not _finite(m.x) or abs(m.x) > x_max:
            self.missions._ack(m.get_srcSystem(), m.get_srcComponent(), mav.MAV_MISSION_INVALID_PARAM5_X, mtype)
            return
        if not _finite(m.y) or abs(m.y) > y_max:
            self.missions._ack(m.get_srcSystem(), m.get_srcComponent(), mav.MAV_MISSION_INVALID_PARAM6_Y, mtype)
            return
        to_int = int if raw else round  # AP_Mission: a raw x is cast (truncated), degrees rounded
        item = MissionItem(
            m.seq, m.frame, m.command, m.param1, m.param2, m.param3, m.param4,
            int(to_int(m.x * scale)), int(to_int(m.y * scale)), m.z, m.autocontinue,
        )  # fmt: skip
        self._mission_item(m, item, float_item=True)

    def _mission_item(self, m: Any, item: MissionItem, float_item: bool = False) -> None:
        mtype = getattr(m, "mission_type", MISSION)
        if m.current in (2, 3) and mtype == MISSION:
            # as Rover's handle_mission_item: the item decoded alone (no upload involved), an
            # item it cannot read answered with that; then a guided "go here" (2), or an
            # altitude change (3, MAVProxy's `guided changealt`: Rover, having no altitude to
            # change, does nothing)
            result = validate_item(item, None)
            if result == mav.MAV_MISSION_ACCEPTED and m.current == 2 and not self._guided_location(item):
                result = mav.MAV_MISSION_ERROR
            self.missions._ack(m.get_srcSystem(), m.get_srcComponent(), result, mtype)
            return
        if float_item:  # before the item is handled, as Rover's handle_mission_item
            self.missions.warn_float(mtype, "got MISSION_ITEM; GCS should send MISSION_ITEM_INT")
        self.missions.on_item(item, mtype, m.get_srcSystem(), m.get_srcComponent(), self.t_s)

    def _guided_location(self, item: MissionItem) -> bool:
        if self.mode != MODES["GUIDED"]:
            return False  # only in GUIDED, as Rover
        if not on_earth(item.lat_deg, item.lon_deg):
            return False
        n, e = global_to_local(item.x, item.y, self.home)
        if not self._within_fence(n, e):
            return False
        self.guided = GuidedTarget("location", self.t_s, north_m=n, east_m=e)
        return True

    def _on_mission_request_list(self, m: Any) -> None:
        if self._for_me(m):
            self.missions.on_request_list(m)

    def _on_mission_request_int(self, m: Any) -> None:
        if self._for_me(m):
            self.missions.on_request_item(m)

    def _on_mission_request(self, m: Any) -> None:
        # old clients ask with MISSION_REQUEST: answered with the float MISSION_ITEM, as Rover
        if self._for_me(m):
            self.missions.on_request_item(m, float_item=True)

    def _on_mission_write_partial_list(self, m: Any) -> None:
        if self._for_me(m):
            self.missions.on_write_partial(m, self.t_s)

    def _on_mission_ack(self, m: Any) -> None:
        pass  # the end of a download: nothing to do

    def _on_mission_clear_all(self, m: Any) -> None:
        if self._for_me(m):
            self.missions.on_clear(m, self.t_s)

    def _on_mission_set_current(self, m: Any) -> None:
        # as Rover: the echo carries the number asked for (0 too: scripts take it for an ACK)
        if self._for_me(m) and self.set_current(m.seq):
            self.send(self._mission_current(m.seq))

    def _mission_current(self, seq: int) -> Any:
        """MISSION_CURRENT as Rover sends it: ``seq``; total, the last item's number (home,
        item 0, not counted: 0 for home alone, as Rover's ``send_mission_current``, where the
        message's definition would have UINT16_MAX); the mission's state (no mission, not
        started, active, complete) and mission_mode 1 while the mode flies it (AUTO)."""
        items = len(self.mission)
        total = max(items - 1, 0)
        if items < 2:
            state = mav.MISSION_STATE_NO_MISSION
        elif self.mission_complete:
            state = mav.MISSION_STATE_COMPLETE
        elif self.mode == MODES["AUTO"]:
            state = mav.MISSION_STATE_ACTIVE
        else:
            state = mav.MISSION_STATE_NOT_STARTED
        return mav.MAVLink_mission_current_message(seq, total, state, int(self.mode == MODES["AUTO"]))

    def _set_current_command(self, seq_param: float, reset_param: float) -> int:
        """MAV_CMD_DO_SET_MISSION_CURRENT as Rover's ``handle_command_do_set_mission_current``
        (GCS_Common): param1 an item that is not the mission's (home, item 0, counts) is
        DENIED; a mission of home alone has no item to head for, FAILED. param2 1 ("reset
        mission") resets the mission first (``AP_Mission::reset``: DO_JUMP's counts afresh, a
        finished mission no longer finished) and restarts it at the item (``resume``); any
        other param2 is taken as 0, not refused. Accepted, the new current item is told at
        once (MISSION_CURRENT), as Rover volunteers it."""
        # Rover casts param1 to an unsigned integer: a fraction is cut off
        seq = math.trunc(seq_param) if _finite(seq_param) and seq_param >= 0 else None
        if seq is None or seq >= len(self.mission):
            return mav.MAV_RESULT_DENIED
        if not self.set_current(seq, reset=reset_param == 1.0):
            return mav.MAV_RESULT_FAILED
        self._once.append((MSG_IDS["MISSION_CURRENT"], None))
        return mav.MAV_RESULT_ACCEPTED

    def set_current(self, seq: int, reset: bool = False) -> bool:
        """Make mission item ``seq`` the one to head for (False when there is no such item).
        As Rover's ``AP_Mission::set_current_cmd``: 0 restarts the mission from item 1, and
        a restart, or any item of a finished mission, starts DO_JUMP's counts afresh.

        Parameters
        ----------
        seq : int
            The item, 0 .. count - 1.
        reset : bool
            Reset the mission first, as ``AP_Mission::reset`` (DO_SET_MISSION_CURRENT's
            param2 1): DO_JUMP's counts start afresh whichever item is asked for.
        """
        restart = reset or seq == 0 or self.mission_complete
        if not self.missions.set_current(max(1, seq)):
            return False
        if restart:
            self.mission_restarts += 1
        self.mission_version += 1
        self.mission_complete = False
        return True

    def reached(self, seq: int, last: bool | None = None, next_seq: int | None = None) -> None:
        """The autopilot finished mission item ``seq`` (arrived, and waited as long as the
        item says): tell the ground station, and head for the next navigation item.

        Parameters
        ----------
        seq : int
            The item finished.
        last : bool, optional
            It ends the mission (default: it is the list's last item; the autopilot knows
            better when DO_JUMPs follow it).
        next_seq : int, optional
            The navigation item that comes next (MISSION_CURRENT; default: the item after).
        """
        self._item_reached(seq)
        after = seq + 1 if next_seq is None else next_seq
        self.missions.current_seq = min(after, max(0, len(self.mission) - 1))
        if seq >= len(self.mission) - 1 if last is None else last:
            self.complete_mission()

    def complete_mission(self) -> None:
        """The mission is done, said as Rover's ``exit_mission``, which then does what
        ``MIS_DONE_BEHAVE`` says: 0 stop in AUTO, 1 loiter in AUTO (holding its place, where
        nothing pushes a simulated vehicle off it: it stays stopped), 2 ACRO (which lfctl's
        vehicle has not: refused as a ground station's request is, and it stops in AUTO, as
        Rover does when the mode will not start), 3 MANUAL."""
        self.mission_complete = True
        self.statustext("Mission Complete", mav.MAV_SEVERITY_NOTICE)
        behave = int(self.param("MIS_DONE_BEHAVE"))
        if behave == MIS_DONE_ACRO:
            self.set_mode(ACRO_MODE)
        elif behave == MIS_DONE_MANUAL:
            self.set_mode(MODES["MANUAL"])

    def set_speed(self, speed_mps: float) -> None:
        """The speed a mission item sets for the waypoints after it (DO_CHANGE_SPEED, RTL's
        start), as Rover's one speed limit for them: the same a ground station's
        DO_CHANGE_SPEED sets, kept when the current item moves, dropped when a mode is
        entered.

        Parameters
        ----------
        speed_mps : float
            The speed, m/s.
        """
        self.desired_speed_mps = float(speed_mps)

    def item_done(self, seq: int) -> None:
        """A DO command or condition of the mission is done (MISSION_ITEM_REACHED, as Rover
        sends it for the ones its own mode carries out); the current item does not move.

        Parameters
        ----------
        seq : int
            The item.
        """
        self._item_reached(seq)

    def _item_reached(self, seq: int) -> None:
        """Send MISSION_ITEM_REACHED for ``seq`` and remember it: as Rover's channels keep the
        last one, a REQUEST_MESSAGE (or a rate) for it sends it again."""
        self._reached_seq = seq
        self.send(mav.MAVLink_mission_item_reached_message(seq))

    def run_mission_item(self, item: MissionItem, verified: bool = True) -> None:
        """Carry out a mission's DO command on the vehicle as the same command from a ground
        station would (DO_SET_HOME, DO_SET_REVERSE; DO_FENCE_ENABLE as AP_Mission runs it, see
        :meth:`_fence_enable_item`), then say it is done.

        Parameters
        ----------
        item : MissionItem
            The item whose turn has come.
        verified : bool
            Say it is done (MISSION_ITEM_REACHED); False for an item the mission never checks
            (the one started after the last navigation item, as the mission completes).
        """
        if item.command == mav.MAV_CMD_DO_FENCE_ENABLE:  # AP_Mission's own, not the command's
            self._fence_enable_item(item.param1)
        else:
            p = [item.param1, item.param2, item.param3, item.param4, float(item.x), float(item.y), item.z]
            # a mission's MISSION frame is above mean sea level, as AP_Mission reads a place in it
            frame = mav.MAV_FRAME_GLOBAL if item.frame == mav.MAV_FRAME_MISSION else item.frame
            self._command(item.command, p, (item.x, item.y), frame)
        if verified:
            self.item_done(item.seq)

    def rtl_destination(self, north_m: float, east_m: float) -> tuple[float, float]:
        """Where RTL drives from (north, east), as Rover's ``calc_best_rally_or_home_location``:
        the nearest rally point the fence allows (one outside a fence turned on is not valid,
        ``AP_Rally_Rover::is_valid``), unless it is farther than ``RALLY_LIMIT_KM`` (0: no
        limit) or, with ``RALLY_INCL_HOME`` 1, home is as near or nearer: then home.

        Parameters
        ----------
        north_m, east_m : float
            The vehicle, local NED, m.
        """
        home = self.home_point()

        def distance(p: tuple[float, float]) -> float:
            return math.hypot(p[0] - north_m, p[1] - east_m)

        valid = [p for p in self.rally if self._within_fence(*p)]
        if not valid:
            return home
        nearest = min(valid, key=distance)
        limit_m = self.param("RALLY_LIMIT_KM") * 1000.0
        if limit_m > 0 and distance(nearest) > limit_m:
            return home
        if self.param("RALLY_INCL_HOME") and not distance(nearest) < distance(home):
            return home
        return nearest

    def _configured_fences(self) -> int:
        """The fences FENCE_TYPE configures, FENCE_TYPE bits (AC_Fence's _configured_fences)."""
        return int(self.param("FENCE_TYPE")) & FENCE_ALL

    def _present_fences(self) -> int:
        """The configured fences there is something to check for, as Rover's
        ``AC_Fence::present``: the polygons only with some fence item uploaded."""
        present = self._configured_fences()
        return present & ~FENCE_TYPE_POLYGON if self.fence.empty else present

    def _fence_present(self) -> bool:
        """A fence there is to check (:meth:`_present_fences`)."""
        return bool(self._present_fences())

    def _checked_fences(self) -> int:
        """The fences the vehicle is checked against now: turned on and configured."""
        return self.fences_enabled & self._configured_fences()

    def _follow_fence_enable(self) -> None:
        """As Rover's ``AC_Fence::update``: a change of FENCE_ENABLE turns every configured
        fence but the floor on (1) or every fence off (0); setting it to what it was changes
        nothing, so what DO_FENCE_ENABLE did stands until then."""
        value = self.param("FENCE_ENABLE")
        if value != self._fence_enable_seen:
            self._fence_enable_seen = value
            self.fences_enabled = self._configured_fences() & ~FENCE_TYPE_ALT_MIN if value else 0

    def _fence_enable_command(self, action_p: float, fences_p: float) -> int:
        """MAV_CMD_DO_FENCE_ENABLE, as Rover 4.6's GCS_Fence: param1 0 off, 1 on (FAILED when none
        of the fences asked for is there to check), 2 the floor off (a rover has none); param2
        the FENCE_TYPE bits it is for (0: all). It turns fences on and off in RAM, as
        ``AC_Fence::enable``: FENCE_ENABLE is not changed, and a reboot forgets it."""
        action, fences = _as_int(action_p, 0, 65535), _as_int(fences_p, 0, 255)
        if action is None or fences is None:
            return mav.MAV_RESULT_DENIED
        fences = fences or FENCE_ALL
        if action == 1 and not self._present_fences() & fences:
            return mav.MAV_RESULT_FAILED  # none of them there to check
        if action in (0, 1):
            self._turn_fences(action == 1, fences)
        elif action == 2:
            self.fences_enabled &= ~FENCE_TYPE_ALT_MIN
        else:
            return mav.MAV_RESULT_FAILED
        return mav.MAV_RESULT_ACCEPTED

    def _turn_fences(self, on: bool, fences: int) -> int:
        """Turn the configured ones of ``fences`` (FENCE_TYPE bits) on or off, as
        ``AC_Fence::enable``; the fences that changed."""
        before = self.fences_enabled
        chosen = self._configured_fences() & fences
        self.fences_enabled = before | chosen if on else before & ~chosen
        return before ^ self.fences_enabled

    def _fence_enable_item(self, action_p: float) -> None:
        """A mission's DO_FENCE_ENABLE, as Rover 4.6's ``AP_Mission::start_command_fence``:
        param1 0 turns every configured fence off, 1 on (``enable_configured``), 2 the floor
        off, each said at NOTICE for the fences it changed ("Circle and Polygon fences
        enabled", ``print_fence_message``); any other value does nothing."""
        action = _as_int(action_p, 0, 65535)
        if action in (0, 1):
            changed = self._turn_fences(action == 1, FENCE_ALL)
            if changed:
                self.statustext(
                    f"{fence_names(changed)} {'enabled' if action else 'disabled'}", mav.MAV_SEVERITY_NOTICE
                )
        elif action == 2:
            self.fences_enabled &= ~FENCE_TYPE_ALT_MIN
            self.statustext(f"{fence_names(FENCE_TYPE_ALT_MIN)} disabled", mav.MAV_SEVERITY_NOTICE)

    def _fence_failure(self) -> str | None:
        """The fence's pre-arm failure, as Rover's ``AC_Fence::pre_arm_check`` words it (run
        by ``AP_Arming::fence_checks``, which no ``ARMING_CHECK`` bit turns off), or None:
        "Fences enabled, but none selected" with ``FENCE_ENABLE`` on and no fence to check;
        with a fence turned on (the parameter, or DO_FENCE_ENABLE), an inclusion circle
        narrower than ``FENCE_MARGIN`` ("Polygon fence margin is less than inclusion circle
        radius", Rover 4.6's words; its newer source says "greater than"), then "Vehicle
        breaching Polygon fence" (or Circle, or both) while the vehicle is outside the fence.
        The checks on values lfctl's parameter ranges already rule out (a negative radius or
        margin) cannot fail here."""
        if self.param("FENCE_ENABLE") and not self._fence_present():
            return "Fences enabled, but none selected"
        if not self.fences_enabled or not self._configured_fences():
            return None
        margin = self.param("FENCE_MARGIN")
        if self._configured_fences() & FENCE_TYPE_POLYGON and any(r < margin for *_, r in self.fence.inclusion_circles):
            return "Polygon fence margin is less than inclusion circle radius"
        if self._breached_fences:
            return f"Vehicle breaching {fence_names(self._breached_fences)}"
        return None

    def _within_fence(self, north_m: float, east_m: float) -> bool:
        """A destination the fence allows (Rover refuses guided targets outside it, and rally
        points outside it are not taken: AC_Fence::check_destination_within_fence): checked
        against the fences turned on."""
        return not self._breaches(north_m, east_m, destination=True)

    def _breaches(self, north_m: float, east_m: float, destination: bool = False) -> int:
        """The fences turned on that (north, east) breaches (FENCE_RADIUS for the circle), as
        FENCE_TYPE bits (0: none); ``destination``: a place asked for, not the vehicle's."""
        fences, radius = self._checked_fences(), self.param("FENCE_RADIUS")
        if not fences:
            return 0
        return self.fence.breaches(north_m, east_m, fences, radius, self.home_point(), destination)

    # -- GUIDED ---------------------------------------------------------------------------------
    def _pose(self) -> Pose:
        return Pose(self.state["north_m"], self.state["east_m"], self.state["yaw_rad"])

    def _on_set_position_target_local_ned(self, m: Any) -> None:
        if not self._for_me(m) or self.mode != MODES["GUIDED"]:
            return  # Rover takes setpoints in GUIDED only
        frames = {
            mav.MAV_FRAME_LOCAL_NED: "local",
            mav.MAV_FRAME_LOCAL_OFFSET_NED: "local_offset",
            mav.MAV_FRAME_BODY_NED: "body",
            mav.MAV_FRAME_BODY_OFFSET_NED: "body",
        }
        frame = frames.get(m.coordinate_frame)
        if frame is None:
            return
        target = position_target(
            self.t_s, frame, m.type_mask, m.x, m.y, m.vx, m.vy, m.yaw, m.yaw_rate, self._pose(), self.param("WP_SPEED")
        )
        self._take_target(target, "SET_POSITION_TARGET_LOCAL_NED")

    def _on_set_position_target_global_int(self, m: Any) -> None:
        if not self._for_me(m) or self.mode != MODES["GUIDED"]:
            return
        if m.coordinate_frame not in (
            mav.MAV_FRAME_GLOBAL, mav.MAV_FRAME_GLOBAL_INT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT,
            mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_FRAME_GLOBAL_TERRAIN_ALT, mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
        ):  # fmt: skip
            return
        n, e = 0.0, 0.0
        if not m.type_mask & 0b111:
            if not on_earth(m.lat_int / 1e7, m.lon_int / 1e7):
                return
            n, e = global_to_local(m.lat_int, m.lon_int, self.home)
        target = position_target(
            self.t_s, "global", m.type_mask, n, e, m.vx, m.vy, m.yaw, m.yaw_rate, self._pose(), self.param("WP_SPEED")
        )
        self._take_target(target, "SET_POSITION_TARGET_GLOBAL_INT")

    def _on_set_attitude_target(self, m: Any) -> None:
        if not self._for_me(m) or self.mode != MODES["GUIDED"]:
            return
        q = tuple(float(v) for v in m.q)
        target = attitude_target(self.t_s, m.type_mask, q, m.body_yaw_rate, m.thrust, self.param("WP_SPEED"))  # type: ignore[arg-type]
        self._take_target(target, "SET_ATTITUDE_TARGET")

    def _take_target(self, target: GuidedTarget | str, message: str) -> None:
        if isinstance(target, str):
            if "ACC_IGNORE" in target:
                self.statustext(f"Ignoring {message}; set ACC_IGNORE in mask", mav.MAV_SEVERITY_INFO)
            return
        if target.kind == "location":
            lat, lon, _alt = ned_to_geodetic(target.north_m, target.east_m, 0.0, *self.home)
            far = max(abs(target.north_m), abs(target.east_m))
            if not (far <= HALF_EARTH_M and on_earth(lat, lon)):
                # past a pole or farther than half the Earth (a 1e38, a fuzzer's): Rover's
                # Location would fold it back over the pole or wrap it; refused here, named
                self.statustext(
                    f"Ignoring {message}; target {target.north_m:.4g} m N {target.east_m:.4g} m E is off the Earth",
                    mav.MAV_SEVERITY_INFO,
                )
                return
            if not self._within_fence(target.north_m, target.east_m):
                return
        self.guided = target
        self._guided_stale_reported = False

    def guided_target(self) -> GuidedTarget | None:
        """The GUIDED target in force; a rate or heading target not renewed within
        :data:`GUIDED_TIMEOUT_S` is dropped (the vehicle stops) with Rover's STATUSTEXT, once."""
        g = self.guided
        if g is None:
            return None
        if g.times_out and self.t_s - g.t_s > GUIDED_TIMEOUT_S:
            if not self._guided_stale_reported:
                self._guided_stale_reported = True
                self.statustext("target not received last 3secs, stopping")  # Rover 4.6's words
            return None
        return g

    def guided_command(self) -> tuple[float, float] | None:
        """The (speed, yaw rate) of a fresh rate target (a companion's setpoint), else None."""
        g = self.guided_target()
        if g is None or g.kind != "rate":
            return None
        return g.speed_mps, g.yaw_rate_radps

    def guided_reached(self) -> None:
        """The vehicle reached its GUIDED location: tell the ground station (item 0), once."""
        if self.guided is not None and self.guided.kind == "location":
            self._item_reached(0)
            self.guided = None  # stop there
            self._guided_arrived = True

    # -- the tick -----------------------------------------------------------------------------
    def tick(self, t_s: float, state: dict[str, float]) -> None:
        """Advance to ``t_s``: handle input, run timeouts, the fence and the failsafes, keep
        the way back for SmartRTL, stream telemetry.

        Parameters
        ----------
        t_s : float
            Now, s.
        state : dict
            The vehicle now: ``north_m``, ``east_m``, ``yaw_rad``, ``speed_mps``,
            ``yaw_rate_radps`` (local NED, SI), and optionally ``speed_cmd_mps``, the speed it
            is commanded (VFR_HUD's throttle, see :meth:`throttle_pct`).
        """
        self.t_s = t_s
        self.state = state
        if self.rebooting:
            self.receive()  # heard by nobody
            return
        if not self._ready_said:
            self._ready_said = True
            self.statustext("ArduPilot Ready", mav.MAV_SEVERITY_INFO)  # AP_Vehicle::setup's last words
        self._smartrtl_points()  # (taken once after each start, before what comes in)
        self._loop_period_us()  # (likewise)
        self._update_home()
        if self.signed_parser is not None:
            advance_signing_clock(self.signed_parser.signing, time.time())
        self.receive()
        if self.rebooting:
            return  # a reboot was asked for
        self.missions.tick(t_s)
        self.ftp.tick()
        self._check_gcs_failsafe(t_s)
        self._follow_fence_enable()
        self._report_prearm(t_s)
        self._check_fence()
        self._record_path()
        once, self._once = self._once, []
        # each schedule's due messages to its own: the shared one's to the in-memory link and
        # every peer that set no rate, a peer's own to it alone
        live = self.network.reachable() if self.network is not None else []
        try:
            for msg_id, self._audience in once:
                self._send_by_id(msg_id)
            for audience, rates in ((SHARED, self._rates), *self._peer_rates.items()):
                self._audience = audience
                due = rates.due(t_s)
                if audience is SHARED or audience in live:  # (a peer out of reach: its rates kept)
                    for msg_id in due:
                        self._send_by_id(msg_id)
        finally:
            self._audience = None

    def _report_prearm(self, t_s: float) -> None:
        """As Rover's AP_Arming::update, once a second from boot: while a disarmed vehicle fails
        a pre-arm check, each failure as a "PreArm:" text when more than 30 s have passed since
        the last display (which moves every 30 s, failing or not), or more than 4 s once the
        common checks (here the fence's) have gone from passing to failing. A vehicle failing
        from boot says so first after 30 s; the checks of Rover's own (its mode, WP_SPEED) wait
        for the 30 s turn."""
        since_boot = t_s - self._boot_t_s
        if since_boot < self._prearm_update_s:
            return
        now = float(math.floor(since_boot))  # this second's update (one a tick longer than 1 s missed)
        self._prearm_update_s = now + 1.0
        display = now - self._prearm_shown_s > PREARM_DISPLAY_S or (
            self._prearm_soon and now - self._prearm_shown_s > PREARM_SOON_S
        )
        if display:
            self._prearm_soon, self._prearm_shown_s = False, now
        failures = self._run_prearm_checks()
        if display:
            self._say_failures("PreArm", failures)

    def _run_prearm_checks(self) -> list[str]:
        """The pre-arm checks run (:meth:`prearm_failures`), as Rover's pre_arm_checks: when
        the common ones (AP_Arming's own, here the fence) turn from passing to failing, their
        failure is to be said soon; armed, or with ``ARMING_CHECK`` 0, they are not run."""
        failures = self.prearm_failures()
        if not self.armed and self.param("ARMING_CHECK") != 0:
            passed = self._fence_failure() is None
            if self._prearm_common_passed and not passed:
                self._prearm_soon = True
            self._prearm_common_passed = passed
        return failures

    def _say_failures(self, prefix: str, failures: list[str]) -> None:
        """Each pre-arm failure as Rover's check_failed says it: "PreArm: ..." or, on an arm, "Arm: ..."."""
        for failure in failures:
            self.statustext(f"{prefix}: {failure}", mav.MAV_SEVERITY_CRITICAL)

    def _check_gcs_failsafe(self, t_s: float) -> None:
        """Rover's ``gcs_failsafe_check`` and ``failsafe_trigger``, armed or not. With
        ``FS_GCS_ENABLE`` on and ``SYSID_MYGCS`` once heard (a HEARTBEAT, or its sticks), the
        ground station is lost once it has been silent for ``FS_GCS_TIMEOUT``; the failsafe
        acts once that has lasted more than ``FS_TIMEOUT``, unless the vehicle is in RTL, or in
        HOLD without ``FS_OPTIONS`` bit 0 (it acts on a later check, if the mode changes while
        the ground station is still lost). Acting: "GCS Failsafe", every RC override
        dropped, and ``FS_ACTION`` (:meth:`_take_action`), or with ``FS_GCS_ENABLE`` 2 in AUTO
        the mission goes on. The ground station heard again: "GCS Failsafe Cleared" (if it
        acted). With ``FS_GCS_ENABLE`` 0 nothing is checked, and the failsafe's state is left
        as it was. Times are compared in whole ms, as Rover's ``millis()``."""
        if not self.param("FS_GCS_ENABLE") or self._gcs_seen is None:
            return
        lost = _ms(t_s - self._gcs_seen) >= _ms(self.param("FS_GCS_TIMEOUT"))
        if lost and not self._gcs_failsafe:
            self._gcs_failsafe_since = t_s
        self._gcs_failsafe = lost
        if self._failsafe_triggered and not lost:
            self._failsafe_triggered = False
            self.statustext("GCS Failsafe Cleared", mav.MAV_SEVERITY_INFO)
        in_hold = self.mode == MODES["HOLD"] and not int(self.param("FS_OPTIONS")) & FS_OPTION_ACTIVE_IN_HOLD
        if (
            not lost
            or self._failsafe_triggered
            or _ms(t_s - self._gcs_failsafe_since) <= _ms(self.param("FS_TIMEOUT"))
            or self.mode == MODES["RTL"]
            or in_hold
        ):
            return
        self._failsafe_triggered = True
        self.statustext("GCS Failsafe", mav.MAV_SEVERITY_WARNING)
        self.rc.clear()
        if self.mode == MODES["AUTO"] and int(self.param("FS_GCS_ENABLE")) == FS_GCS_CONTINUE_MISSION:
            self.statustext("Failsafe - Continuing Auto Mode", mav.MAV_SEVERITY_WARNING)
        else:
            self._take_action(int(self.param("FS_ACTION")))

    def _take_action(self, action: int) -> None:
        """A failsafe's or a fence breach's action, as Rover's ``FailsafeAction``: the modes of
        :data:`ACTION_MODES` in turn until one starts, or disarm (Terminate); 0 (and any
        other value) does nothing."""
        if action == ACTION_TERMINATE:
            self.set_armed(False)
            return
        for name in ACTION_MODES.get(action, ()):
            if self.set_mode(MODES[name]):
                return

    def _check_fence(self) -> None:
        """As Rover's ``fence_check`` on ``AC_Fence::check``: a fence newly breached is
        counted (FENCE_STATUS: one breach for each fence, the time of the first while none
        was breached) and acted on (armed), without a word, as Rover says nothing of a breach
        (only "Manual recovery started" as the mode changes, :meth:`_enter`). The circle is breached again each time the vehicle goes
        :data:`CIRCLE_BACKUP_M` farther out than where it last breached it (AC_Fence's backup
        circle), so a vehicle driven on outwards meets the action again; and more than
        :data:`FENCE_GIVE_UP_M` outside the circle the action is HOLD, whatever FENCE_ACTION
        says (``AC_FENCE_GIVE_UP_DISTANCE``; a polygon's breach has no distance). For
        :data:`FENCE_RECOVERY_S` after a mode change made while breached (the fence's own, or a
        ground station's taking the vehicle back) no new breach is acted on, as Rover's
        ``set_mode`` starts AC_Fence's manual recovery; what is breached is still kept."""
        if not self._checked_fences():
            self.fence_breach = None
            self._breached_fences = 0
            self._circle_backup_m = 0.0
            return
        n, e = self.state["north_m"], self.state["east_m"]
        # as Rover's AC_Fence::check: what is breached is kept armed or not (arming needs none)
        before, self._breached_fences = self._breached_fences, self._breaches(n, e)
        new = self._breached_fences & ~before
        breach = breach_name(self._breached_fences)
        outside_m = 0.0
        if self._breached_fences & FENCE_TYPE_CIRCLE:
            home = self.home_point()
            out = math.hypot(n - home[0], e - home[1])
            if new & FENCE_TYPE_CIRCLE or out >= self._circle_backup_m:
                new |= FENCE_TYPE_CIRCLE
                self._circle_backup_m = out + CIRCLE_BACKUP_M
                outside_m = out - self.param("FENCE_RADIUS")
        else:
            self._circle_backup_m = 0.0
        if new:
            if not before:  # AC_Fence::record_breach: the time of the first of a run of breaches
                self._fence_breach_ms = self._boot_ms()
            self.fence_breaches += bin(new).count("1")  # ... and a count for each fence
            log.warning("%s: fence breached: %s", self.name, breach)  # (lfctl's log, not a STATUSTEXT)
            # recorded during the manual recovery too, as Rover 4.6's AC_Fence::check records
            # before it looks at the recovery; only the action waits for the pilot's time
            if self.armed and self.t_s >= self._fence_recovery_until:
                self._fence_action(give_up=outside_m > FENCE_GIVE_UP_M)
            self._soon(MSG_IDS["FENCE_STATUS"])
        self.fence_breach = breach

    def _fence_action(self, give_up: bool = False) -> None:
        action = int(self.param("FENCE_ACTION"))
        if action == ACTION_NONE:
            return
        # too far out to drive back: stop where it is
        self._take_action(ACTION_HOLD if give_up else action)

    def steering(self, report: NavReport | None) -> None:
        """Where the vehicle's autopilot steers now (its driver tells it at each guidance
        step), for NAV_CONTROLLER_OUTPUT. It holds until the mode, the arming, the reversing,
        the mission or the GUIDED target changes, whichever comes first.

        Parameters
        ----------
        report : NavReport or None
            The heading steered, the bearing and distance to the destination and the
            cross-track error; None: no destination (nothing is sent).
        """
        self._nav = None if report is None else (report, self._nav_context())

    @property
    def nav(self) -> NavReport | None:
        """The last :meth:`steering` report; None outside Rover's autopilot modes and once what
        it steered for has changed."""
        if self._nav is None or self.mode not in AUTOPILOT_MODES or self._nav[1] != self._nav_context():
            return None
        return self._nav[0]

    def _guided_nav_bearing(self) -> int | None:
        """NAV_CONTROLLER_OUTPUT's nav_bearing in GUIDED without a place to drive to, or None
        (not GUIDED, or a place it is on its way to: the driver's report says that). As
        Rover's ModeGuided, which reports in every submode: stopped, or on a turn-rate and
        speed target, everything 0; on a heading and speed target, that heading (-180 to 180,
        whole degrees, as the int16 field takes Rover's wrap_180 of it) until it times out;
        no bearing to a destination, no distance, no cross-track error."""
        g = self.guided
        if self.mode != MODES["GUIDED"] or (g is not None and g.kind == "location"):
            return None
        live = g is not None and not (g.times_out and self.t_s - g.t_s > GUIDED_TIMEOUT_S)
        if live and g is not None and g.kind == "heading" and math.isfinite(g.heading_rad):
            return int(math.degrees(wrap_pi(g.heading_rad)))
        return 0

    def _nav_context(self) -> tuple[object, ...]:
        return (self.mode, self.armed, self.reversed, self.mission_version, self.guided)

    def system_status(self) -> int:
        """HEARTBEAT's MAV_STATE as Rover's ``vehicle_system_status``: CRITICAL from a
        failsafe's acting until it clears (Rover's ``failsafe.triggered``: whatever its action
        did, even nothing; a failsafe that waits, the vehicle in RTL or HOLD, has not acted),
        STANDBY in HOLD, ACTIVE otherwise, armed or not
        (QGroundControl takes an armed vehicle that is ACTIVE as moving, and then offers no
        Disarm)."""
        if self._failsafe_triggered:
            return int(mav.MAV_STATE_CRITICAL)
        return int(mav.MAV_STATE_STANDBY if self.mode == MODES["HOLD"] else mav.MAV_STATE_ACTIVE)

    def throttle_pct(self) -> int:
        """The throttle VFR_HUD reports, percent (0-100): Rover's speed controller's base
        throttle, the commanded speed times ``CRUISE_THROTTLE`` / ``CRUISE_SPEED``, its
        magnitude, to at most 100, truncated to a whole percent as Rover's ``int16_t``; 0
        disarmed or with either parameter 0.

        The command is the state's ``speed_cmd_mps``; a vehicle ticked without one reports
        what its speed needs (the command it would hold at steady state).
        """
        cruise_speed, cruise_throttle = self.param("CRUISE_SPEED"), self.param("CRUISE_THROTTLE")
        if not self.armed or cruise_speed <= 0 or cruise_throttle <= 0:
            return 0
        command = self.state.get("speed_cmd_mps", self.state["speed_mps"])
        if not math.isfinite(command):
            return 0
        return int(min(100.0, abs(command) * cruise_throttle / cruise_speed))  # int16_t: truncated

    def _record_path(self) -> None:
        """SmartRTL's breadcrumbs: where the vehicle has been since it first armed, in every
        mode but SmartRTL (Rover's ``ModeSmartRTL::save_position``, at 3 Hz: the first tick at or
        after each third of a second), a point each ``SRTL_ACCURACY`` (AP_SmartRTL::add_point). When the ``SRTL_POINTS`` are used up
        the way is cleaned (its straight runs' points and its loops dropped); when that frees
        none for :data:`SRTL_TIMEOUT_S`, SmartRTL is given up until the next arming."""
        if not self._path_active or self.mode == MODES["SMART_RTL"] or self.t_s < self._path_sample_due:
            return
        due = self._path_sample_due + SRTL_SAVE_PERIOD_S  # (in phase; after a pause, from now)
        self._path_sample_due = due if due > self.t_s else self.t_s + SRTL_SAVE_PERIOD_S
        here = (self.state["north_m"], self.state["east_m"])
        accuracy = self.param("SRTL_ACCURACY")
        if self.path and math.hypot(here[0] - self.path[-1][0], here[1] - self.path[-1][1]) < accuracy:
            self._path_saved_s = self.t_s  # nothing to keep here (Rover's add_point succeeds)
            return
        room = self._smartrtl_points()
        if len(self.path) >= room and not self._path_cleaned and accuracy > 0:
            self.path = clean_way_back(self.path, accuracy, room)
            self._path_cleaned = True
        if len(self.path) < room:
            self.path.append(here)
            self._path_saved_s = self.t_s
            self._path_cleaned = False
        elif self.t_s - self._path_saved_s > SRTL_TIMEOUT_S:
            self._path_active = False
            self.statustext("SmartRTL deactivated: buffer full", mav.MAV_SEVERITY_WARNING)  # AP_SmartRTL's words

    def _send_by_id(self, msg_id: int) -> None:
        name = ID_NAMES.get(msg_id)
        s = self.state
        t_ms = self._boot_ms()
        if name in _GLOBAL_STREAMS:  # the position in degrees only for the two that carry it
            lat, lon, alt = ned_to_geodetic(s["north_m"], s["east_m"], 0.0, *self.home)
        vn, ve = s["speed_mps"] * math.cos(s["yaw_rad"]), s["speed_mps"] * math.sin(s["yaw_rad"])
        hdg = int(round(math.degrees(s["yaw_rad"]) % 360 * 100)) % 36000
        if name == "HEARTBEAT":
            base = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mav.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
            if self.mode in AUTOPILOT_MODES:
                base |= mav.MAV_MODE_FLAG_GUIDED_ENABLED  # Rover: an autopilot mode
            elif self.mode == MODES["MANUAL"]:
                base |= mav.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED  # Rover: a mode with manual input
            self.send(
                mav.MAVLink_heartbeat_message(
                    mav.MAV_TYPE_GROUND_ROVER,
                    mav.MAV_AUTOPILOT_ARDUPILOTMEGA,
                    base,
                    self.mode,
                    self.system_status(),
                    3,
                )
            )
        elif name == "SYS_STATUS":
            # the geofence as Rover's AC_Fence reports it: present when there is a fence to
            # check, enabled with a fence turned on unless FENCE_ACTION is 0 (report only),
            # healthy unless breached (MAVProxy says "fence breach" when the health bit drops)
            fence = mav.MAV_SYS_STATUS_GEOFENCE
            present = self._fence_present()
            acting = present and self.fences_enabled and int(self.param("FENCE_ACTION")) != ACTION_NONE
            controlling = CONTROLLERS if self.mode in AUTOPILOT_MODES else 0
            enabled = SENSORS | controlling | (fence if acting else 0)
            health = SENSORS | controlling | (fence if not (present and self.fence_breach is not None) else 0)
            if self.prearm_failures():  # QGroundControl's "Ready To Fly" / "Not Ready"
                health &= ~mav.MAV_SYS_STATUS_PREARM_CHECK
            if self.param("ARMING_CHECK") == 0:  # no checks: the verdict present only (GCS_Common)
                enabled &= ~mav.MAV_SYS_STATUS_PREARM_CHECK
                health &= ~mav.MAV_SYS_STATUS_PREARM_CHECK
            present_bits = SENSORS | CONTROLLERS | (fence if present else 0)
            self.send(
                mav.MAVLink_sys_status_message(
                    present_bits, enabled, health, 0, *BATTERY_NOT_MEASURED, 0, 0, 0, 0, 0, 0
                )
            )
        elif name == "NAV_CONTROLLER_OUTPUT":
            # Rover's, in an autopilot mode with a destination: bearings in whole degrees,
            # the distance in whole metres, no pitch, altitude or speed error
            nav = self.nav
            if nav is not None and math.isfinite(nav.distance_m):
                self.send(
                    mav.MAVLink_nav_controller_output_message(
                        0.0, 0.0, _whole_degrees(nav.nav_bearing_rad), _whole_degrees(nav.target_bearing_rad),
                        min(int(nav.distance_m), 0xFFFF), 0.0, 0.0, -nav.cross_track_m,  # Rover's: + left
                    )
                )  # fmt: skip
            elif nav is None and (heading := self._guided_nav_bearing()) is not None:
                self.send(mav.MAVLink_nav_controller_output_message(0.0, 0.0, heading, 0, 0, 0.0, 0.0, 0.0))
        elif name == "POSITION_TARGET_GLOBAL_INT":
            # Rover's, where its mode has a destination: the place only (everything else
            # ignored), at the ground's altitude above sea level, as MAVProxy's map shows it
            nav = self.nav
            if nav is not None and all(map(math.isfinite, nav.destination_ned_m)):
                d_lat, d_lon, d_alt = ned_to_geodetic(*nav.destination_ned_m, 0.0, *self.home)
                self.send(
                    mav.MAVLink_position_target_global_int_message(
                        t_ms, mav.MAV_FRAME_GLOBAL, POSITION_ONLY_TYPE_MASK, int(round(d_lat * 1e7)),
                        int(round(d_lon * 1e7)), d_alt, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                    )
                )  # fmt: skip
        elif name == "EXTENDED_SYS_STATE":
            # ArduPilot's for a vehicle that reports no VTOL or landed state
            self.send(
                mav.MAVLink_extended_sys_state_message(mav.MAV_VTOL_STATE_UNDEFINED, mav.MAV_LANDED_STATE_UNDEFINED)
            )
        elif name == "RC_CHANNELS":
            # Rover's: each channel's input, here a live override or 0; no receiver, so no
            # channel counted as received (chancount 0) and the RSSI unknown (255)
            values = self.rc.values(self.t_s, self.param("RC_OVERRIDE_TIME"))
            self.send(mav.MAVLink_rc_channels_message(t_ms, 0, *values, 255))
        elif name == "GPS_RAW_INT":
            # cog is the GPS's course over ground, the way the vehicle moves: backing up, the
            # heading's opposite (AP_GPS::send_mavlink_gps_raw's ground_course)
            cog = (hdg + 18000) % 36000 if s["speed_mps"] < 0 else hdg
            self.send(
                mav.MAVLink_gps_raw_int_message(
                    self._boot_us(), 3, int(round(lat * 1e7)), int(round(lon * 1e7)), int(round(alt * 1000)),
                    100, 100, int(round(abs(s["speed_mps"]) * 100)), cog, 12,
                )
            )  # fmt: skip
        elif name == "GLOBAL_POSITION_INT":
            self.send(
                mav.MAVLink_global_position_int_message(
                    t_ms, int(round(lat * 1e7)), int(round(lon * 1e7)), int(round(alt * 1000)),
                    int(round(-self.home_up_m * 1000)),  # above home, as Rover's relative_alt
                    int(round(vn * 100)), int(round(ve * 100)), 0, hdg,
                )
            )  # fmt: skip
        elif name == "LOCAL_POSITION_NED":
            self.send(mav.MAVLink_local_position_ned_message(t_ms, s["north_m"], s["east_m"], 0.0, vn, ve, 0.0))
        elif name == "VFR_HUD":
            # as Rover fills it: its ground speed as the airspeed too, the heading in whole
            # degrees, the throttle's magnitude (percent), the altitude above sea level
            speed = abs(s["speed_mps"])
            yaw_cd = int(math.degrees(s["yaw_rad"]) * 100)  # Rover's yaw_sensor: truncated centidegrees
            heading = (yaw_cd + 36000 if yaw_cd < 0 else yaw_cd) // 100 % 360
            self.send(mav.MAVLink_vfr_hud_message(speed, speed, heading, self.throttle_pct(), alt, 0.0))
        elif name == "ATTITUDE_QUATERNION":
            half = wrap_pi(s["yaw_rad"]) / 2.0  # level: a turn about down alone
            self.send(
                mav.MAVLink_attitude_quaternion_message(
                    t_ms, math.cos(half), 0.0, 0.0, math.sin(half), 0.0, 0.0, s["yaw_rate_radps"], [0.0] * 4
                )
            )
        elif name == "SYSTEM_TIME":
            # UTC as a board with GPS time has it: the run's start plus the simulation time
            # (as the run's log stamps its messages), and the time since boot
            self.send(mav.MAVLink_system_time_message(self.epoch_us + int(self.t_s * 1e6), t_ms))
        elif name == "GPS_GLOBAL_ORIGIN":
            # where local NED is anchored (the EKF origin's place on a Rover)
            o_lat, o_lon, o_alt = self.home
            self.send(
                mav.MAVLink_gps_global_origin_message(
                    int(round(o_lat * 1e7)), int(round(o_lon * 1e7)), int(round(o_alt * 1000)), self._boot_us()
                )
            )
        elif name == "ATTITUDE":
            self.send(
                mav.MAVLink_attitude_message(t_ms, 0.0, 0.0, wrap_pi(s["yaw_rad"]), 0.0, 0.0, s["yaw_rate_radps"])
            )
        elif name == "MISSION_CURRENT":
            self.send(self._mission_current(self.mission_current))
        elif name == "MISSION_ITEM_REACHED":
            # as Rover's: the last item reached since the autopilot started, or 65535 (none yet)
            self.send(mav.MAVLink_mission_item_reached_message(self._reached_seq))
        elif name == "HOME_POSITION":
            hn, he = self.home_point()
            hlat, hlon, halt = self._home_geodetic()
            self.send(
                mav.MAVLink_home_position_message(
                    int(round(hlat * 1e7)), int(round(hlon * 1e7)), int(round(halt * 1000)),
                    hn, he, -self.home_up_m, [math.nan] * 4, 0, 0, 0, self._boot_us(),
                )  # as Rover's send_home_position: no orientation (NaN), the time since boot
            )  # fmt: skip
        elif name == "FENCE_STATUS":
            if self.fences_enabled:  # GCS_Fence's send_fence_status: with a fence turned on
                breach_type = mav.FENCE_BREACH_BOUNDARY if self.fence_breach else mav.FENCE_BREACH_NONE
                self.send(
                    mav.MAVLink_fence_status_message(
                        int(self.fence_breach is not None),
                        self.fence_breaches,
                        breach_type,
                        self._fence_breach_ms,
                        mav.FENCE_MITIGATE_NONE,  # a rover has AC_Avoid, not limiting here
                    )
                )
        elif name == "AUTOPILOT_VERSION":
            caps = (
                mav.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
                | mav.MAV_PROTOCOL_CAPABILITY_MISSION_INT
                | mav.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | mav.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | mav.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
                | mav.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
                | mav.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET
                | mav.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
                | mav.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
                | mav.MAV_PROTOCOL_CAPABILITY_FTP
                | mav.MAV_PROTOCOL_CAPABILITY_MAVLINK2
            )
            self.send(
                mav.MAVLink_autopilot_version_message(
                    caps,
                    _version_word(*ROVER_VERSION),
                    0,
                    0,
                    0,
                    self.custom_version,
                    [0] * 8,
                    [0] * 8,
                    0,
                    0,
                    self.sysid,
                    _board_uid(self.name),
                )
            )


def _board_uid(name: str) -> list[int]:
    """AUTOPILOT_VERSION's uid2 for the vehicle called ``name``: a board's is its processor's
    unique id, which ground stations and MAVSDK (``hardware_uid``) tell vehicles apart by; a
    simulated vehicle's is 18 bytes of a hash of its name, the same from run to run."""
    return list(hashlib.blake2b(f"lfctl vehicle {name}".encode(), digest_size=18).digest())


def _version_word(major: int, minor: int, patch: int) -> int:
    """AUTOPILOT_VERSION's flight_sw_version as ArduPilot packs it: major, minor, patch and
    the firmware type (FIRMWARE_VERSION_TYPE_OFFICIAL) a byte each."""
    return major << 24 | minor << 16 | patch << 8 | mav.FIRMWARE_VERSION_TYPE_OFFICIAL


def _whole_degrees(angle_rad: float) -> int:
    """A bearing in whole degrees, 0-359, truncated (Rover's centidegrees / 100)."""
    return int(math.degrees(angle_rad) % 360.0) % 360 if math.isfinite(angle_rad) else 0


def _period(rate_hz: float) -> float:
    """A stream's period, s, in whole ms as Rover's ``get_interval_for_stream`` makes it
    (1000 / Hz in integers: 3 Hz is 333 ms); infinite (not sent) at 0 Hz."""
    return max(1000 // rate_hz, 1) / 1000 if rate_hz > 0 else math.inf


def _stream_interval_ms(rate: int) -> int:
    """REQUEST_DATA_STREAM's rate (uint16, Hz) as Rover's stream rate makes it an interval, ms:
    kept in an int16 (32768 and more are negative), 1000 / Hz in C's integers, as uint32, at
    most 60000. 0 is not sent: a rate of 0, or over 1000 Hz (1000 / Hz is 0) or -1000 and
    below; -1 to -1000 (65535 to 64536) is 60 s, the wrapped negative's cap."""
    freq = rate - 65536 if rate >= 32768 else rate
    if freq == 0:
        return 0
    ms = int(1000 / freq)  # (C's division truncates toward zero, as int() does)
    return 60000 if ms < 0 or ms > 60000 else ms


def _command_latlon(p: list[float], latlon_e7: tuple[int, int] | None) -> tuple[int, int] | None:
    """A command's latitude and longitude, degE7: COMMAND_INT's x, y, or COMMAND_LONG's
    param5, param6 in degrees; None when not finite or off the globe."""
    if latlon_e7 is not None:
        lat_e7, lon_e7 = latlon_e7
    else:
        if not _finite(p[4], p[5]):
            return None
        lat_e7, lon_e7 = int(round(p[4] * 1e7)), int(round(p[5] * 1e7))
    if not on_earth(lat_e7 / 1e7, lon_e7 / 1e7):
        return None
    return lat_e7, lon_e7


def _first_frame(data: bytes, start: int = 0) -> int:
    """Offset of the first MAVLink frame marker (0xFD, 0xFE) at or after ``start``, or -1
    (found in C, so a long run of junk costs nothing in Python)."""
    found = [i for i in (data.find(b"\xfd", start), data.find(b"\xfe", start)) if i >= 0]
    return min(found) if found else -1


def _frame_length(data: bytes, j: int) -> int:
    """The length the frame starting at ``j`` declares (0 when its header is cut short)."""
    if data[j] == 0xFD:  # MAVLink 2: 10-byte header, payload, CRC, 13-byte signature if flagged
        if j + 3 > len(data):
            return 0
        return 10 + data[j + 1] + 2 + (13 if data[j + 2] & 0x01 else 0)
    if j + 2 > len(data):  # MAVLink 1: 6-byte header, payload, CRC
        return 0
    return 6 + data[j + 1] + 2


def _reset(parser: Any) -> None:
    """Forget any partial frame the parser holds."""
    parser.buf = bytearray()
    parser.buf_index = 0
    parser.expected_length = mav.HEADER_LEN_V1 + 2


def _jsonable(value: Any) -> Any:
    """A decoded MAVLink field as a JSON value: text for char arrays, base64 for bytes, a
    string for NaN and infinities, lists element by element; never raises."""
    if isinstance(value, bool) or value is None:
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, str):
        return value.rstrip("\x00")
    if isinstance(value, (bytes, bytearray, memoryview)):
        raw = bytes(value)
        try:
            return raw.decode("ascii").rstrip("\x00")
        except UnicodeDecodeError:
            return "base64:" + base64.b64encode(raw).decode()
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return repr(value)


def packet_record(direction: str, msg: Any, raw: bytes, to: Any = None) -> dict[str, Any]:
    """A packet as the /mavlink/<link> recording topic carries it: the raw bytes always,
    the fields decoded as far as they decode (JSON-safe, whatever the values).

    Parameters
    ----------
    direction : "in" or "out"
        Received by the endpoint, or sent by it.
    msg : pymavlink message
        The decoded message.
    raw : bytes
        The packet as it travelled.
    to : (host, port), optional
        The one network peer an endpoint sent it to (recorded as ``to``, "host:port"); None:
        sent to the in-memory link and to each network peer that takes it (a stream: those
        keeping no rates of their own), each peer's copy packed with its own sequence number.
    """
    fields: dict[str, Any] = {}
    try:
        names = list(msg.get_fieldnames())
    except Exception:  # an unknown message id decodes with no field list
        names = []
    for k in names:
        try:
            value = getattr(msg, k)
            # most fields are plain ints and finite floats, which _jsonable returns as they
            # are: skip its call for them (tens of thousands of fields a minute)
            kind = type(value)
            if kind is int or (kind is float and math.isfinite(value)):
                fields[k] = value
            else:
                fields[k] = _jsonable(value)
        except Exception as exc:
            fields[k] = f"<not decodable: {type(exc).__name__}>"
    seq, sysid, compid, msgid = (
        int(msg.get_seq()),
        int(msg.get_srcSystem()),
        int(msg.get_srcComponent()),
        int(msg.get_msgId()),
    )
    if msgid < 0:  # a message id the dialect does not know: pymavlink keeps no header, the bytes do
        seq, sysid, compid, msgid = _raw_header(bytes(raw)) or (seq, sysid, compid, msgid)
    return {
        "direction": direction,
        "sysid": sysid,
        "compid": compid,
        "msgid": msgid,
        "name": str(msg.get_type()),
        "seq": seq,
        "fields": fields,
        "raw": base64.b64encode(bytes(raw)).decode(),
        **({"to": f"{to[0]}:{to[1]}"} if to is not None else {}),
    }


def _raw_header(raw: bytes) -> tuple[int, int, int, int] | None:
    """(seq, sysid, compid, msgid) from a frame's header, None when it is cut short."""
    if raw[:1] == b"\xfd" and len(raw) >= 10:  # MAVLink 2: 24-bit message id
        return raw[4], raw[5], raw[6], int.from_bytes(raw[7:10], "little")
    if raw[:1] == b"\xfe" and len(raw) >= 6:
        return raw[2], raw[3], raw[4], raw[5]
    return None
