"""Mission items: validation with the MAVLink result codes, conversion to the leader's local
waypoints, and the QGC WPL 110 / QGroundControl .plan file formats."""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.checks import read_text_file, save_text
from lfctl.errors import ConfigError
from lfctl.frames import FLT_EPSILON, geodetic_to_ned

log = logging.getLogger(__name__)

__all__ = [
    "ACTED_ON",
    "CIRCLE_EXCLUSION",
    "CIRCLE_INCLUSION",
    "CONDITION_DELAY",
    "CONDITION_DISTANCE",
    "DO_CHANGE_SPEED",
    "DO_FENCE_ENABLE",
    "DO_JUMP",
    "DO_JUMP_TAG",
    "DO_SET_HOME",
    "DO_SET_REVERSE",
    "FLOWN",
    "JUMP_TAG",
    "LOCATION_ALT_MAX_M",
    "MAX_EXPANDED",
    "MAX_FILE_BYTES",
    "MAX_FILE_ITEMS",
    "MAX_SITE_M",
    "MAX_VERTICES",
    "MISSION_TEXT_NAMES",
    "NAV_DELAY",
    "NAV_LOITER_TIME",
    "NAV_LOITER_TURNS",
    "NAV_LOITER_UNLIM",
    "NAV_RETURN_TO_LAUNCH",
    "NAV_WAYPOINT",
    "NOTHING_FITTED",
    "NOTHING_FITTED_REACHED",
    "PLACES",
    "POLYGON_EXCLUSION",
    "POLYGON_INCLUSION",
    "RALLY_POINT",
    "RAW_XY",
    "RETURN_POINT",
    "SKIPPED",
    "SKIPPED_NAV",
    "SKIPPED_SAID",
    "STORES_LOCATION",
    "SUPPORTED",
    "Leg",
    "MissionFile",
    "MissionItem",
    "as_stored",
    "check_site",
    "command_name",
    "far_place",
    "hands_over",
    "home_item",
    "int_as",
    "is_nav",
    "jump_tag_item",
    "jump_tag_items",
    "load_mission",
    "load_mission_file",
    "local_mission",
    "mission_text",
    "nav_count",
    "save_mission",
    "seconds_until_utc",
    "to_legs",
    "validate_item",
    "walk_mission",
]

NAV_WAYPOINT = mav.MAV_CMD_NAV_WAYPOINT  # 16
NAV_LOITER_UNLIM = mav.MAV_CMD_NAV_LOITER_UNLIM  # 17
NAV_LOITER_TURNS = mav.MAV_CMD_NAV_LOITER_TURNS  # 18
NAV_LOITER_TIME = mav.MAV_CMD_NAV_LOITER_TIME  # 19
NAV_RETURN_TO_LAUNCH = mav.MAV_CMD_NAV_RETURN_TO_LAUNCH  # 20
NAV_GUIDED_ENABLE = mav.MAV_CMD_NAV_GUIDED_ENABLE  # 92
NAV_DELAY = mav.MAV_CMD_NAV_DELAY  # 93
CONDITION_DELAY = mav.MAV_CMD_CONDITION_DELAY  # 112
CONDITION_DISTANCE = mav.MAV_CMD_CONDITION_DISTANCE  # 114
DO_JUMP = mav.MAV_CMD_DO_JUMP  # 177
DO_CHANGE_SPEED = mav.MAV_CMD_DO_CHANGE_SPEED  # 178
DO_SET_HOME = mav.MAV_CMD_DO_SET_HOME  # 179
DO_SET_REVERSE = mav.MAV_CMD_DO_SET_REVERSE  # 194
DO_FENCE_ENABLE = mav.MAV_CMD_DO_FENCE_ENABLE  # 207
NAV_SET_YAW_SPEED = mav.MAV_CMD_NAV_SET_YAW_SPEED  # 213
JUMP_TAG = mav.MAV_CMD_JUMP_TAG  # 600
DO_JUMP_TAG = mav.MAV_CMD_DO_JUMP_TAG  # 601


def _commands(*names: str) -> frozenset[int]:
    """The MAV_CMD numbers of these names (without ``MAV_CMD_``)."""
    return frozenset(getattr(mav, f"MAV_CMD_{name}") for name in names)


#: the navigation commands a Rover flies: to a place (waypoint; loiter for a time or for
#: ever), home or the nearest rally point (RTL), a wait where it stands (NAV_DELAY), turns
#: round a circle (NAV_LOITER_TURNS, as Rover 4.5 and later drive it), or a turn to a
#: heading at a speed (NAV_SET_YAW_SPEED); and a NAV_GUIDED_ENABLE that hands nothing over
#: (param1 0: :func:`hands_over`), done at once
FLOWN = frozenset(
    (
        NAV_WAYPOINT,
        NAV_LOITER_UNLIM,
        NAV_LOITER_TURNS,
        NAV_LOITER_TIME,
        NAV_RETURN_TO_LAUNCH,
        NAV_DELAY,
        NAV_SET_YAW_SPEED,
    )
)
#: the commands that run beside the navigation and act on what lfctl has: the speed, home,
#: driving in reverse, the fence; and the conditions that hold the ones after them back
ACTED_ON = frozenset(
    (DO_CHANGE_SPEED, DO_SET_HOME, DO_SET_REVERSE, DO_FENCE_ENABLE, CONDITION_DELAY, CONDITION_DISTANCE)
)
#: the commands ArduPilot's mission library carries out itself on hardware lfctl does not
#: have (servos, relays, cameras, a gripper, a sprayer, an auxiliary switch, a parachute, a
#: gimbal, scripts), and the gimbal's region of interest Rover's mode sends to its mount:
#: taken, and said to act on nothing when their turn comes
NOTHING_FITTED = _commands(
    "DO_SET_RELAY", "DO_REPEAT_RELAY", "DO_SET_SERVO", "DO_REPEAT_SERVO", "DO_DIGICAM_CONFIGURE",
    "DO_DIGICAM_CONTROL", "DO_SET_CAM_TRIGG_DIST", "IMAGE_START_CAPTURE",
    "IMAGE_STOP_CAPTURE", "VIDEO_START_CAPTURE", "VIDEO_STOP_CAPTURE", "DO_GRIPPER", "DO_SPRAYER",
    "DO_AUX_FUNCTION", "DO_PARACHUTE", "DO_SEND_SCRIPT_MESSAGE", "DO_SET_RESUME_REPEAT_DIST",
    "DO_GIMBAL_MANAGER_PITCHYAW", "DO_SET_ROI", "DO_SET_ROI_LOCATION", "DO_SET_ROI_NONE",
    "SET_CAMERA_ZOOM", "SET_CAMERA_FOCUS", "SET_CAMERA_SOURCE",
)  # fmt: skip
#: of :data:`NOTHING_FITTED`, the ones Rover's own mode checks, not its mission library
#: (ModeAuto::verify_command's "do commands (always return true)"): said done, with
#: MISSION_ITEM_REACHED, as Rover's verify_command_callback sends it
NOTHING_FITTED_REACHED = _commands("DO_SET_ROI", "DO_SET_ROI_LOCATION", "DO_SET_ROI_NONE")
#: the commands a mission may hold that a Rover passes over when their turn comes (aircraft's
#: take-offs and landings, splines, a video camera's old command no part of Rover checks),
#: and a NAV_GUIDED_ENABLE that hands over to an offboard computer, which a Rover waits on
#: and lfctl passes over (:func:`hands_over`): taken, as Rover's mission library takes them,
#: and tried and passed over in turn
SKIPPED = _commands(
    "NAV_LAND", "NAV_TAKEOFF", "NAV_CONTINUE_AND_CHANGE_ALT", "NAV_LOITER_TO_ALT", "NAV_SPLINE_WAYPOINT",
    "NAV_GUIDED_ENABLE", "NAV_ALTITUDE_WAIT", "NAV_VTOL_TAKEOFF", "NAV_VTOL_LAND",
    "NAV_PAYLOAD_PLACE", "NAV_SCRIPT_TIME", "NAV_ATTITUDE_TIME", "CONDITION_YAW",
    "DO_LAND_START", "DO_GO_AROUND", "DO_INVERTED_FLIGHT", "DO_AUTOTUNE_ENABLE", "DO_VTOL_TRANSITION",
    "DO_ENGINE_CONTROL", "DO_WINCH", "DO_PAUSE_CONTINUE", "DO_GUIDED_LIMITS", "DO_MOUNT_CONTROL",
    "DO_RETURN_PATH_START", "DO_CONTROL_VIDEO",
)  # fmt: skip
#: the skipped ones that are navigation (AP_Mission::is_nav_cmd): tried ("Mission: N
#: Takeoff") and passed over, as a Rover's mission moves on when one fails to start
SKIPPED_NAV = frozenset(
    c
    for c in SKIPPED
    if c <= mav.MAV_CMD_NAV_LAST
    or c in (mav.MAV_CMD_NAV_SET_YAW_SPEED, mav.MAV_CMD_NAV_SCRIPT_TIME, mav.MAV_CMD_NAV_ATTITUDE_TIME)
)
#: the skipped DO commands a Rover says it skips ("Skipping invalid cmd #N"): all but the
#: limits of a guided turn within AUTO, which it takes without a word (lfctl skips that turn)
SKIPPED_SAID = SKIPPED - SKIPPED_NAV - {mav.MAV_CMD_DO_GUIDED_LIMITS}
#: every command a mission may hold, as ArduPilot's mission library takes them on upload
#: (AP_Mission::mavlink_int_to_mission_cmd); any other is MAV_MISSION_UNSUPPORTED. A
#: JUMP_TAG marks its place with a tag (param1) and does nothing else; a DO_JUMP_TAG is a
#: DO_JUMP to the first JUMP_TAG of its tag (none: the mission ends there)
SUPPORTED = FLOWN | ACTED_ON | NOTHING_FITTED | SKIPPED | {DO_JUMP, JUMP_TAG, DO_JUMP_TAG}
#: the navigation commands that end a leg somewhere: a waypoint the summary counts
PLACES = frozenset((NAV_WAYPOINT, NAV_LOITER_UNLIM, NAV_LOITER_TIME, NAV_RETURN_TO_LAUNCH))
#: the commands that store a place (AP_Mission::stores_location): their latitude and
#: longitude are checked on upload, and a download gives their frame
STORES_LOCATION = _commands(
    "NAV_WAYPOINT", "NAV_LOITER_UNLIM", "NAV_LOITER_TURNS", "NAV_LOITER_TIME", "NAV_LAND", "NAV_TAKEOFF",
    "NAV_CONTINUE_AND_CHANGE_ALT", "NAV_LOITER_TO_ALT", "NAV_SPLINE_WAYPOINT", "NAV_GUIDED_ENABLE",
    "NAV_VTOL_TAKEOFF", "NAV_VTOL_LAND", "NAV_PAYLOAD_PLACE", "DO_SET_HOME", "DO_LAND_START",
    "DO_GO_AROUND", "DO_SET_ROI", "DO_SET_ROI_LOCATION", "DO_RETURN_PATH_START",
)  # fmt: skip
#: the commands whose x and y are not a place: the float MISSION_ITEM carries them as they
#: are, where for every other command it carries degrees (AP_Mission's conversions between
#: MISSION_ITEM and MISSION_ITEM_INT)
RAW_XY = _commands("DO_DIGICAM_CONTROL", "DO_DIGICAM_CONFIGURE", "NAV_ATTITUDE_TIME", "DO_GIMBAL_MANAGER_PITCHYAW")
POLYGON_INCLUSION = mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION  # 5001
POLYGON_EXCLUSION = mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION  # 5002
CIRCLE_INCLUSION = mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION  # 5003
CIRCLE_EXCLUSION = mav.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION  # 5004
RALLY_POINT = mav.MAV_CMD_NAV_RALLY_POINT  # 5100
RETURN_POINT = mav.MAV_CMD_NAV_FENCE_RETURN_POINT  # 5000
#: the most vertices in one fence polygon (ArduPilot's fence storage holds about this many)
MAX_VERTICES = 100
#: the frames a place may be given in (AP_Mission::mavlink_int_to_mission_cmd: above mean sea
#: level, home or the terrain; a rover's waypoints are flown on the ground whatever the frame)
NAV_FRAMES = {
    mav.MAV_FRAME_MISSION,
    mav.MAV_FRAME_GLOBAL,
    mav.MAV_FRAME_GLOBAL_RELATIVE_ALT,
    mav.MAV_FRAME_GLOBAL_TERRAIN_ALT,
    mav.MAV_FRAME_GLOBAL_INT,
    mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
}
#: the frames of a fence vertex or circle, or a rally point (NAV_FRAMES but MAV_FRAME_MISSION)
PLACE_FRAMES = NAV_FRAMES - {mav.MAV_FRAME_MISSION}
#: the largest altitude a place may carry, m, in any frame (ArduPilot's LOCATION_ALT_MAX_M:
#: a mission item's or a command's location beyond it is refused)
LOCATION_ALT_MAX_M = 83_000.0
MAX_EXPANDED = 2000  # DO_JUMP repeats are unrolled up to this many legs
#: the most items a mission file may hold, home included (MISSION_COUNT is 16 bits)
MAX_FILE_ITEMS = 65535
#: the largest mission file read, bytes (a full WPL file of MAX_FILE_ITEMS lines fits)
MAX_FILE_BYTES = 16 * 1024 * 1024
#: the largest magnitude a MAVLink float carries
_FLOAT32_MAX = 3.4028234663852886e38
#: the largest magnitude a Python float holds
_FLOAT64_MAX = 1.7976931348623157e308


@dataclass(frozen=True)
class MissionItem:
    """One item as MISSION_ITEM_INT carries it (x, y in degE7, z in m).

    Parameters
    ----------
    seq : int
        Its place in the mission; 0 is home.
    frame : int
        MAV_FRAME of its position.
    command : int
        MAV_CMD (an upload takes those in :data:`SUPPORTED`).
    param1, param2, param3, param4 : float
        The command's parameters (a waypoint's param1 is its hold time, s).
    x, y : int
        Latitude and longitude, degE7.
    z : float
        Altitude, m.
    autocontinue : int
        1: go on to the next item when this one is done.
    """

    seq: int
    frame: int
    command: int
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: int = 0
    y: int = 0
    z: float = 0.0
    autocontinue: int = 1

    @property
    def lat_deg(self) -> float:
        """Latitude, degrees."""
        return self.x / 1e7

    @property
    def lon_deg(self) -> float:
        """Longitude, degrees."""
        return self.y / 1e7

    @property
    def file_xy(self) -> tuple[float, float]:
        """Params 5 and 6 as a plan or waypoint file holds them: degrees, but x and y as they
        are for an item in MAV_FRAME_MISSION (a DO command's numbers, not a place), as
        QGroundControl converts them to and from MISSION_ITEM_INT."""
        if self.frame == mav.MAV_FRAME_MISSION:
            return float(self.x), float(self.y)
        return self.lat_deg, self.lon_deg


def home_item(lat_deg: float, lon_deg: float, alt_m: float) -> MissionItem:
    """Item 0: home, as ArduPilot keeps it.

    Parameters
    ----------
    lat_deg, lon_deg : float
        Home's position, degrees.
    alt_m : float
        Home's altitude, m.
    """
    return MissionItem(
        0, mav.MAV_FRAME_GLOBAL_INT, NAV_WAYPOINT, x=int(round(lat_deg * 1e7)), y=int(round(lon_deg * 1e7)), z=alt_m
    )


#: DO_JUMP repeat counts ArduPilot keeps (-1: for ever)
JUMP_REPEAT_MAX = 32767
#: the fastest DO_CHANGE_SPEED lfctl takes, m/s
SPEED_MAX_MPS = 100.0


def _whole(x: float) -> bool:
    return math.isfinite(x) and x == int(x)


#: the params (1-4) a mission item may leave NaN, by command (AP_Mission::sanity_check_params)
NAN_ALLOWED = {
    mav.MAV_CMD_NAV_WAYPOINT: (4,),
    mav.MAV_CMD_NAV_LAND: (4,),
    mav.MAV_CMD_NAV_TAKEOFF: (4,),
    mav.MAV_CMD_NAV_VTOL_TAKEOFF: (4,),
    mav.MAV_CMD_NAV_VTOL_LAND: (3, 4),
}


def validate_item(item: MissionItem, count: int | None) -> int:
    """MAV_MISSION_ACCEPTED or the MAV_MISSION_* error for this item (seq 0 of a list is home).

    First, as ArduPilot's ``AP_Mission::sanity_check_params`` for every command: params 1-4
    must not be infinite, nor NaN, except where a NaN means "unset" (param4, the yaw, of
    NAV_WAYPOINT, NAV_LAND, NAV_TAKEOFF and NAV_VTOL_TAKEOFF; params 3 and 4 of
    NAV_VTOL_LAND). Then the parameters the command uses must be in range.

    Parameters
    ----------
    item : MissionItem
        The item as uploaded.
    count : int or None
        The mission's item count (DO_JUMP must land inside it); None for an item that is no
        list's (a "go here" or an altitude change): decoded alone, as Rover's
        ``AP_Mission::mavlink_int_to_mission_cmd`` decodes it, its seq not home's and a
        DO_JUMP's target not checked (only an upload's ``append_item`` checks it).
    """
    may_be_nan = NAN_ALLOWED.get(item.command, ())
    for k, value in enumerate((item.param1, item.param2, item.param3, item.param4)):
        if math.isinf(value) or (math.isnan(value) and k + 1 not in may_be_nan):
            return mav.MAV_MISSION_INVALID_PARAM1 + k
    if item.command not in SUPPORTED:
        return mav.MAV_MISSION_UNSUPPORTED
    cmd = NAV_WAYPOINT if item.seq == 0 and count is not None else item.command  # home: a place, whatever the command
    if cmd in STORES_LOCATION:
        if not -90.0 <= item.lat_deg <= 90.0:
            return mav.MAV_MISSION_INVALID_PARAM5_X
        if not -180.0 <= item.lon_deg <= 180.0:
            return mav.MAV_MISSION_INVALID_PARAM6_Y
        if not (math.isfinite(item.z) and abs(item.z) < LOCATION_ALT_MAX_M):
            return mav.MAV_MISSION_INVALID_PARAM7
        if item.frame not in NAV_FRAMES:
            return mav.MAV_MISSION_UNSUPPORTED_FRAME
    timed = (NAV_WAYPOINT, NAV_LOITER_TIME, NAV_DELAY, CONDITION_DELAY, CONDITION_DISTANCE)
    if cmd in timed and not math.isfinite(item.param1):
        return mav.MAV_MISSION_INVALID_PARAM1  # a hold, delay or distance (a negative one: as Rover takes it)
    if cmd == NAV_DELAY and item.param1 <= 0:  # until a time of day (UTC): hour, minute, second
        for k, (value, top) in enumerate(((item.param2, 23), (item.param3, 59), (item.param4, 59))):
            if not (_whole(value) and -1 <= value <= top):  # -1: any
                return mav.MAV_MISSION_INVALID_PARAM2 + k
    if cmd == DO_JUMP and count is not None and not 1 <= math.trunc(item.param1) < count:  # Rover cuts a fraction off
        return mav.MAV_MISSION_ERROR  # MissionItemProtocol_Waypoints::append_item's answer
    # a tag needs no JUMP_TAG on upload: one may come later
    if cmd in (DO_JUMP, DO_JUMP_TAG) and not -1 <= math.trunc(item.param2) <= JUMP_REPEAT_MAX:
        return mav.MAV_MISSION_INVALID_PARAM2
    if cmd == DO_CHANGE_SPEED and not item.param2 <= SPEED_MAX_MPS:
        # any other speed is stored, as on Rover (AP_Mission checks none); one under 0.05 m/s
        # (-1 "no change", 0) changes nothing when the item runs
        return mav.MAV_MISSION_INVALID_PARAM2
    if cmd in (DO_SET_HOME, DO_SET_REVERSE, DO_FENCE_ENABLE) and not math.isfinite(item.param1):
        return mav.MAV_MISSION_INVALID_PARAM1
    return mav.MAV_MISSION_ACCEPTED


def int_as(x: float, lo: int, hi: int) -> float:
    """``x`` through C's float-to-integer conversion into a field of ``[lo, hi]``: cut to a
    whole number, held at the field's ends (as an ARM flight controller converts it)."""
    return float(min(hi, max(lo, math.trunc(x)))) if math.isfinite(x) else 0.0


#: for the commands lfctl does not carry out, what AP_Mission keeps of an item and gives
#: back in a download (``AP_Mission::mission_cmd_to_mavlink_int``): the params kept (by
#: number) and, for a command that stores no place, which of x, y and z it keeps; the rest
#: come back 0, as its zero-initialised packet has them
KEPT_FIELDS: dict[int, tuple[str, str]] = {
    getattr(mav, f"MAV_CMD_{command}"): (params, xyz)
    for command, params, xyz in (
        ("NAV_LAND", "14", ""), ("NAV_TAKEOFF", "1", ""), ("NAV_CONTINUE_AND_CHANGE_ALT", "1", ""),
        ("NAV_LOITER_TO_ALT", "24", ""), ("NAV_SPLINE_WAYPOINT", "1", ""), ("NAV_GUIDED_ENABLE", "1", ""),
        ("CONDITION_YAW", "1234", ""), ("DO_SET_RELAY", "12", ""), ("DO_REPEAT_RELAY", "123", ""),
        ("DO_SET_SERVO", "12", ""), ("DO_REPEAT_SERVO", "1234", ""), ("DO_LAND_START", "", ""),
        ("DO_GO_AROUND", "", ""), ("DO_SET_ROI", "1", ""), ("DO_DIGICAM_CONFIGURE", "1234", "xyz"),
        ("DO_DIGICAM_CONTROL", "1234", "xy"), ("DO_MOUNT_CONTROL", "123", ""), ("DO_SET_CAM_TRIGG_DIST", "13", ""),
        ("DO_PARACHUTE", "1", ""), ("DO_SPRAYER", "1", ""), ("DO_AUX_FUNCTION", "12", ""),
        ("DO_INVERTED_FLIGHT", "1", ""), ("DO_GRIPPER", "12", ""), ("DO_GUIDED_LIMITS", "1234", ""),
        ("DO_AUTOTUNE_ENABLE", "1", ""), ("NAV_ALTITUDE_WAIT", "123", ""), ("NAV_VTOL_TAKEOFF", "", ""),
        ("NAV_VTOL_LAND", "1", ""), ("DO_VTOL_TRANSITION", "1", ""), ("DO_ENGINE_CONTROL", "123", ""),
        ("NAV_PAYLOAD_PLACE", "1", ""), ("NAV_SET_YAW_SPEED", "123", ""), ("DO_WINCH", "1234", ""),
        ("DO_SET_RESUME_REPEAT_DIST", "1", ""), ("DO_SEND_SCRIPT_MESSAGE", "1234", ""),
        ("SET_CAMERA_ZOOM", "12", ""), ("SET_CAMERA_FOCUS", "12", ""), ("SET_CAMERA_SOURCE", "123", ""),
        ("DO_RETURN_PATH_START", "", ""),
        ("NAV_SCRIPT_TIME", "1234", "xy"), ("NAV_ATTITUDE_TIME", "1234", "x"), ("DO_PAUSE_CONTINUE", "1", ""),
        ("DO_GIMBAL_MANAGER_PITCHYAW", "1234", "xz"),
    )
}  # fmt: skip


def _directed(radius: float, param3: float) -> float:
    """A loiter's kept radius given back with its direction, as AP_Mission does: the flag is
    ``param3 < 0`` (so -0 sent is clockwise) and a counter-clockwise radius is given back
    negated (so a radius kept as 0 comes back as -0)."""
    return -radius if param3 < 0 else radius


def as_stored(item: MissionItem) -> MissionItem:
    """A mission item as a Rover keeps it, and so gives it back when the mission is
    downloaded and reads it when the item runs (``AP_Mission::mavlink_int_to_mission_cmd``
    and back): for the commands lfctl carries out, the params the command has no room for
    are 0 and each kept param takes its field's type (a waypoint's wait a 16-bit whole
    number, 2.5 s kept as 2; DO_JUMP's target and count whole; a loiter's direction
    kept apart from its radius, as ``param3 < 0``: a radius of -0.5 comes back as -0,
    counter-clockwise, and one of -0 as 0, clockwise, as ArduPilot reads it; a circle's
    turns whole, or 256ths below one).
    A command that stores no place (DO_JUMP, DO_CHANGE_SPEED, the conditions, ...) has x,
    y and z 0, but for the few that keep numbers there (a camera's, a gimbal's); for the
    other commands the params and numbers they have no room for are 0 (:data:`KEPT_FIELDS`),
    the rest as sent.

    Parameters
    ----------
    item : MissionItem
        An item that passed :func:`validate_item`.
    """
    if item.command not in STORES_LOCATION:
        xyz = KEPT_FIELDS.get(item.command, ("", ""))[1]
        item = replace(
            item,
            x=item.x if "x" in xyz else 0,
            y=item.y if "y" in xyz else 0,
            z=item.z if "z" in xyz else 0.0,
        )
    c, p1, p2, p3, p4 = item.command, item.param1, item.param2, item.param3, item.param4
    u16 = 65535
    if c == NAV_WAYPOINT:
        params = (int_as(p1, 0, u16), 0.0, 0.0, 0.0)
    elif c == NAV_LOITER_UNLIM:  # (the direction a flag of its own, set by param3 < 0)
        params = (0.0, 0.0, _directed(int_as(abs(p3), 0, u16), p3), 0.0)
    elif c == NAV_LOITER_TURNS:
        r = math.trunc(abs(p3)) if abs(p3) <= 255 else 10 * min(255, math.trunc(abs(p3) * 0.1))
        # turns in a byte; 0 < turns < 1 in 256ths of a turn (a flag says so)
        turns = math.trunc(p1 * 256.0) / 256.0 if 0.0 < p1 < 1.0 else int_as(min(255.0, p1), 0, 255)
        params = (turns, 0.0, _directed(float(r), p3), 1.0 if p4 > 0 else 0.0)
    elif c == NAV_LOITER_TIME:
        params = (int_as(p1, 0, u16), 0.0, -1.0 if p3 < 0 else 1.0, 1.0 if p4 > 0 else 0.0)
    elif c == NAV_RETURN_TO_LAUNCH:
        params = (0.0, 0.0, 0.0, 0.0)
    elif c == NAV_DELAY:  # seconds a float, the time of day's fields 8-bit
        params = (p1, int_as(p2, -128, 127), int_as(p3, -128, 127), int_as(p4, -128, 127))
    elif c in (CONDITION_DELAY, CONDITION_DISTANCE):
        params = (p1, 0.0, 0.0, 0.0)
    elif c in (DO_JUMP, DO_JUMP_TAG):
        params = (int_as(p1, 0, u16), int_as(p2, -32768, 32767), 0.0, 0.0)
    elif c == JUMP_TAG:
        params = (int_as(p1, 0, u16), 0.0, 0.0, 0.0)
    elif c == DO_CHANGE_SPEED:
        params = (int_as(p1, 0, 255), p2, p3, 0.0)
    elif c in (DO_SET_HOME, DO_SET_REVERSE, DO_FENCE_ENABLE):
        params = (int_as(p1, 0, u16), 0.0, 0.0, 0.0)
    elif c in KEPT_FIELDS:
        kept = KEPT_FIELDS[c][0]
        q = [p if str(k) in kept else 0.0 for k, p in enumerate((p1, p2, p3, p4), start=1)]
        params = (q[0], q[1], q[2], q[3])
    else:
        return item
    return replace(item, param1=params[0], param2=params[1], param3=params[2], param4=params[3])


#: the short names ArduPilot's mission library gives the commands it starts, in its
#: "Mission: N NAME" text (AP_Mission::Mission_Command::type)
MISSION_TEXT_NAMES = {
    getattr(mav, f"MAV_CMD_{command}"): name
    for command, name in (
        ("NAV_WAYPOINT", "WP"), ("NAV_SPLINE_WAYPOINT", "SplineWP"), ("NAV_RETURN_TO_LAUNCH", "RTL"),
        ("NAV_LOITER_UNLIM", "LoitUnlim"), ("NAV_LOITER_TIME", "LoitTime"), ("NAV_GUIDED_ENABLE", "GuidedEnable"),
        ("NAV_LOITER_TURNS", "LoitTurns"), ("NAV_LOITER_TO_ALT", "LoitAltitude"), ("NAV_SET_YAW_SPEED", "SetYawSpd"),
        ("CONDITION_DELAY", "CondDelay"), ("CONDITION_DISTANCE", "CondDist"), ("DO_CHANGE_SPEED", "ChangeSpeed"),
        ("DO_SET_HOME", "SetHome"), ("DO_SET_SERVO", "SetServo"), ("DO_SET_RELAY", "SetRelay"),
        ("DO_REPEAT_SERVO", "RepeatServo"), ("DO_REPEAT_RELAY", "RepeatRelay"), ("DO_CONTROL_VIDEO", "CtrlVideo"),
        ("DO_DIGICAM_CONFIGURE", "DigiCamCfg"), ("DO_DIGICAM_CONTROL", "DigiCamCtrl"),
        ("DO_SET_CAM_TRIGG_DIST", "SetCamTrigDst"), ("DO_SET_ROI", "SetROI"), ("DO_SET_REVERSE", "SetReverse"),
        ("DO_SET_RESUME_REPEAT_DIST", "SetRepeatDist"), ("DO_GUIDED_LIMITS", "GuidedLimits"),
        ("NAV_TAKEOFF", "Takeoff"), ("NAV_LAND", "Land"), ("NAV_CONTINUE_AND_CHANGE_ALT", "ContinueAndChangeAlt"),
        ("NAV_ALTITUDE_WAIT", "AltitudeWait"), ("NAV_VTOL_TAKEOFF", "VTOLTakeoff"), ("NAV_VTOL_LAND", "VTOLLand"),
        ("DO_INVERTED_FLIGHT", "InvertedFlight"), ("DO_FENCE_ENABLE", "FenceEnable"),
        ("DO_AUTOTUNE_ENABLE", "AutoTuneEnable"), ("DO_VTOL_TRANSITION", "VTOLTransition"),
        ("DO_ENGINE_CONTROL", "EngineControl"), ("CONDITION_YAW", "CondYaw"), ("DO_LAND_START", "LandStart"),
        ("NAV_DELAY", "Delay"), ("DO_GRIPPER", "Gripper"), ("NAV_PAYLOAD_PLACE", "PayloadPlace"),
        ("DO_PARACHUTE", "Parachute"), ("DO_SPRAYER", "Sprayer"), ("DO_AUX_FUNCTION", "AuxFunction"),
        ("DO_MOUNT_CONTROL", "MountControl"), ("DO_WINCH", "Winch"), ("DO_SEND_SCRIPT_MESSAGE", "Scripting"),
        ("DO_GO_AROUND", "Go Around"), ("NAV_SCRIPT_TIME", "NavScriptTime"), ("NAV_ATTITUDE_TIME", "NavAttitudeTime"),
        ("DO_PAUSE_CONTINUE", "PauseContinue"), ("DO_GIMBAL_MANAGER_PITCHYAW", "GimbalPitchYaw"),
        ("DO_RETURN_PATH_START", "ReturnPathStart"), ("JUMP_TAG", "Tag"), ("DO_JUMP_TAG", "JumpToTag"),
        ("IMAGE_START_CAPTURE", "ImageStartCapture"), ("IMAGE_STOP_CAPTURE", "ImageStopCapture"),
        ("SET_CAMERA_ZOOM", "SetCameraZoom"), ("SET_CAMERA_FOCUS", "SetCameraFocus"),
        ("SET_CAMERA_SOURCE", "SetCameraSource"), ("VIDEO_START_CAPTURE", "VideoStartCapture"),
        ("VIDEO_STOP_CAPTURE", "VideoStopCapture"),
    )
}  # fmt: skip


def mission_text(item: MissionItem) -> str:
    """What ArduPilot's mission library says as it starts an item: ``Mission: 3 WP`` (``?``
    for a command its table has no name for), a JUMP_TAG with its p1 (``Mission: 4 Tag 0``).

    Parameters
    ----------
    item : MissionItem
        The item it starts.
    """
    text = f"Mission: {item.seq} {MISSION_TEXT_NAMES.get(item.command, '?')}"
    # AP_Mission::start_command adds the item's p1, which for a JUMP_TAG is not its tag (that
    # is kept in content.jump.target): a Rover says "Tag 0" whatever the tag
    return f"{text} 0" if item.command == JUMP_TAG else text


def jump_tag_items(items: list[MissionItem]) -> dict[float, int]:
    """Each tag of a mission (home first) to the item number of its first JUMP_TAG, as
    ``AP_Mission::get_index_of_jump_tag`` finds it (a tag missing here: item 0, none).

    Parameters
    ----------
    items : list of MissionItem
        The mission, item 0 = home.
    """
    first: dict[float, int] = {}
    for k, it in enumerate(items[1:], start=1):
        if it.command == JUMP_TAG:
            first.setdefault(it.param1, k)
    return first


def jump_tag_item(items: list[MissionItem], tag: float) -> int:
    """The item number of the first JUMP_TAG of ``tag`` in a mission (home first), or 0 when
    none has it (:func:`jump_tag_items`).

    Parameters
    ----------
    items : list of MissionItem
        The mission, item 0 = home.
    tag : float
        The tag (a DO_JUMP_TAG's param1, as stored: a whole number).
    """
    return jump_tag_items(items).get(tag, 0)


def command_name(cmd: int) -> str:
    """A MAV_CMD's name without its prefix (``DO_SET_SERVO``), or its number when it has none.

    Parameters
    ----------
    cmd : int
        The command.
    """
    entry = mav.enums["MAV_CMD"].get(cmd)
    return entry.name.removeprefix("MAV_CMD_") if entry is not None else str(cmd)


def is_nav(item: MissionItem) -> bool:
    """Whether an item is a place to go (a waypoint the vehicle reaches: a waypoint, a loiter,
    RTL's home or rally point), not a wait, a DO command or a condition.

    Parameters
    ----------
    item : MissionItem
        A mission item.
    """
    return item.command in PLACES


def nav_count(mission: list[MissionItem]) -> int:
    """The waypoints (places, :func:`is_nav`) of a mission whose item 0 is home.

    Parameters
    ----------
    mission : list of MissionItem
        The mission, home first (empty: none).
    """
    return sum(1 for it in mission[1:] if is_nav(it))


@dataclass(frozen=True)
class Leg:
    """One leg for the autopilot: a navigation item, where it ends, how long it waits there,
    and the DO commands and conditions that begin with it."""

    seq: int  # the mission item this leg ends at
    north_m: float  # the target, local NED, m
    east_m: float  # the target, local NED, m
    #: wait there, s: math.inf for ever (NAV_LOITER_UNLIM); a NAV_DELAY until a time of day
    #: is 0 here (its wait is known only when it begins: :func:`seconds_until_utc`)
    hold_s: float
    command: int = NAV_WAYPOINT  # the navigation command (:data:`FLOWN`)
    #: the DO commands and conditions between the navigation item before this one and this
    #: one that a Rover runs, in turn as the leg begins, as ArduPilot's mission library runs them
    before: tuple[MissionItem, ...] = ()
    #: the times each DO_JUMP had been taken as this leg was reached in the walk, (item,
    #: times) for each jump taken so far: a mission resumed here goes on counting from them,
    #: against the repeats its items have then (a Rover reads each jump from storage)
    jumps: tuple[tuple[int, int], ...] = ()
    #: the counted jumps taken on the way from the leg before to this one, (item, times
    #: taken, repeats), as Rover says each ("Mission: 3 Jump 1/2"); a jump repeated for ever
    #: is not counted, and not said
    jumped: tuple[tuple[int, int, int], ...] = ()
    #: how many of :attr:`jumped` were taken before the first of :attr:`before` was met: said
    #: before it (a DO_JUMP_TAG back to a JUMP_TAG says the jump, then the tag)
    jumps_first: int = 0


def to_legs(
    items: list[MissionItem],
    home: tuple[float, float, float],
    start_seq: int = 1,
    start: tuple[float, float] = (0.0, 0.0),
    return_to: Callable[[float, float], tuple[float, float]] | None = None,
    jumps: tuple[tuple[int, int], ...] = (),
) -> list[Leg]:
    """Flatten a mission (from ``start_seq``) into legs, unrolling DO_JUMP.

    Where an item's place comes from the vehicle, it is planned from where the leg before
    ends (the autopilot takes it again from where the vehicle is when the item begins): a
    waypoint or loiter at latitude and longitude 0 is "here" (Rover's
    ``Location::sanitize``), a NAV_DELAY waits where it stands, and RTL drives to
    ``return_to`` of that place. At most :data:`MAX_EXPANDED` legs: a DO_JUMP repeated for
    ever (-1) stops there; nothing after a loiter for ever.

    Parameters
    ----------
    items : list of MissionItem
        The mission, item 0 = home.
    home : (lat_deg, lon_deg, alt_m)
        The local NED frame's origin.
    start_seq : int
        The item to start from (the current item).
    start : (north_m, east_m)
        Where the vehicle is as the mission (re)starts, local NED, m.
    return_to : callable, optional
        Where RTL goes from a place, (north_m, east_m) -> (north_m, east_m): home or the
        nearest rally point (:meth:`~lfctl.link.endpoint.VehicleEndpoint.rtl_destination`);
        by default the local origin.
    jumps : tuple of (int, int)
        The times each DO_JUMP has been taken, (item, times), as a leg's :attr:`Leg.jumps`
        keeps them (a mission resumed part-way through a loop); by default none.
    """
    return walk_mission(items, home, start_seq, start, return_to, jumps)[0]


def hands_over(item: MissionItem) -> bool:
    """Whether a NAV_GUIDED_ENABLE hands the vehicle to an offboard computer: its param1 as
    AP_Mission keeps it (``cmd.p1``, a 16-bit whole number) above 0, as Rover's
    ``do_nav_guided_enable`` asks. lfctl passes such an item over (no offboard computer
    drives within AUTO here); one of 0 is done at once, as ``verify_nav_guided_enable``.

    Parameters
    ----------
    item : MissionItem
        A NAV_GUIDED_ENABLE.
    """
    return int_as(item.param1, 0, 65535) > 0


def walk_mission(
    items: list[MissionItem],
    home: tuple[float, float, float],
    start_seq: int = 1,
    start: tuple[float, float] = (0.0, 0.0),
    return_to: Callable[[float, float], tuple[float, float]] | None = None,
    jumps: tuple[tuple[int, int], ...] = (),
) -> tuple[list[Leg], tuple[MissionItem, ...]]:
    """The legs (:func:`to_legs`), and the mission's tail: the DO commands and conditions after
    its last navigation item, of which a Rover starts the first as its last waypoint is done,
    then the mission is complete (a mission without navigation is all tail).

    Between two navigation items a Rover runs the first DO command it finds and the ones
    straight after it: a navigation item it skips (a take-off, say) ends that run
    (``AP_Mission::get_next_do_cmd`` stops at it), though not before the first is found.
    The skipped navigation items stay in the leg's items: the search tries each, and says so.

    Parameters
    ----------
    items, home, start_seq, start, return_to, jumps
        As :func:`to_legs` takes them.
    """
    legs: list[Leg] = []
    before: list[MissionItem] = []
    blocked = False
    here = start
    jumps_run: dict[int, int] = dict(jumps)
    jumped: list[tuple[int, int, int]] = []  # since the last leg: (item, times taken, repeats)
    first_met: int | None = None  # jumps taken since the last leg when its first item before was met
    tags = jump_tag_items(items)  # looked up once: the walk may pass a jump thousands of times
    i = start_seq
    # jumps between items with no waypoint in between (a DO_JUMP to itself, two that point
    # at each other) add no legs: the walk is bounded too, not only the legs it yields
    steps = 0
    while 0 < i < len(items) and len(legs) < MAX_EXPANDED and steps < MAX_EXPANDED * len(items):
        steps += 1
        it = items[i]
        if it.command in FLOWN or (it.command == NAV_GUIDED_ENABLE and not hands_over(it)):
            if it.command == NAV_RETURN_TO_LAUNCH:
                here = return_to(*here) if return_to is not None else (0.0, 0.0)
            elif it.command not in (NAV_DELAY, NAV_SET_YAW_SPEED, NAV_GUIDED_ENABLE) and (it.x, it.y) != (0, 0):
                n, e, _ = geodetic_to_ned(it.lat_deg, it.lon_deg, home[2], *home)
                here = (n, e)
            if it.command == NAV_LOITER_UNLIM:
                hold = math.inf
            elif it.command in (NAV_WAYPOINT, NAV_LOITER_TIME):
                # whole seconds: Rover keeps this time in a 16-bit integer (AP_Mission's p1),
                # which its do_nav_wp reads as signed: 32768 s and more wait none
                whole = math.floor(it.param1) if it.param1 > 0 else 0
                hold = float(whole) if whole < 32768 else 0.0
            elif it.command == NAV_DELAY and it.param1 > 0:  # NAV_DELAY's seconds are a float
                hold = it.param1
            else:
                hold = 0.0
            first = len(jumped) if first_met is None else first_met
            legs.append(
                Leg(it.seq, *here, hold, it.command, tuple(before), tuple(jumps_run.items()), tuple(jumped), first)
            )
            before, blocked, jumped, first_met = [], False, [], None
            if hold == math.inf:
                return legs, ()
        elif it.command in (DO_JUMP, DO_JUMP_TAG):
            target = tags.get(it.param1, 0) if it.command == DO_JUMP_TAG else None
            if target == 0:
                break  # a tag no JUMP_TAG has ends the mission, whatever the count (get_next_cmd)
            if math.isfinite(it.param1) and math.isfinite(it.param2):  # (a stored mission's are)
                # AP_Mission::get_next_cmd: -1 jumps for ever (bounded above), uncounted;
                # else while the times taken are fewer than the repeats the item has now
                repeats = math.trunc(it.param2)
                run = jumps_run.get(i, 0)
                if repeats == -1 or run < repeats:
                    if repeats != -1:
                        jumps_run[i] = run + 1
                        jumped.append((i, run + 1, repeats))
                    i = target if target is not None else math.trunc(it.param1)
                    continue
        elif it.command in SKIPPED_NAV:  # tried, and said, as the search passes it
            blocked = any(b.command not in SKIPPED_NAV for b in before)
            before.append(it)
        elif not blocked:
            before.append(it)
        if before and first_met is None:
            first_met = len(jumped)
        i += 1
    return legs, tuple(before)


#: the navigation items AP_Mission_ChangeDetector watches: the one under way and the next two
CHANGE_WATCHED = 3


def is_nav_command(command: int) -> bool:
    """``AP_Mission::is_nav_cmd``: a navigation command (below NAV_LAST, and a few above)."""
    return command <= mav.MAV_CMD_NAV_LAST or command in (
        mav.MAV_CMD_NAV_SET_YAW_SPEED,
        mav.MAV_CMD_NAV_SCRIPT_TIME,
        mav.MAV_CMD_NAV_ATTITUDE_TIME,
    )


def watched_items(
    items: list[MissionItem], start_seq: int, jumps: tuple[tuple[int, int], ...] = ()
) -> tuple[tuple[object, ...], ...]:
    """The navigation items a Rover's AP_Mission_ChangeDetector compares to tell that the
    mission ahead changed: from ``start_seq`` (the item under way), up to
    :data:`CHANGE_WATCHED` of them, each found as ``AP_Mission::get_next_nav_cmd`` finds it
    (a DO_JUMP with repeats left followed every time, its count not taken; a search that
    meets the same jump twice, or a tag no JUMP_TAG has, ends), each as Rover stores it: its
    number, command, params, place (degE7) and altitude in whole centimetres
    (``mavlink_int_to_mission_cmd``: ``z * 100`` in a float32, cut to an integer), and its
    frame only as the altitude's reference it sets (GLOBAL and GLOBAL_INT alike, as
    ``relative_alt`` and ``terrain_alt``). Items stored as :func:`as_stored` keeps them.

    Parameters
    ----------
    items : list of MissionItem
        The mission, item 0 = home.
    start_seq : int
        The item under way.
    jumps : tuple of (int, int)
        The times each DO_JUMP has been taken, as :attr:`Leg.jumps` keeps them.
    """
    taken = dict(jumps)
    tags = jump_tag_items(items)
    out: list[tuple[object, ...]] = []
    i = start_seq
    while len(out) < CHANGE_WATCHED and 0 < i < len(items):
        seen: set[int] = set()
        while 0 < i < len(items) and items[i].command in (DO_JUMP, DO_JUMP_TAG):
            it = items[i]
            repeats = math.trunc(it.param2)
            if i in seen or (repeats != -1 and taken.get(i, 0) >= repeats):
                i = -1 if i in seen else i + 1  # the same jump again: the search ends
                continue
            seen.add(i)
            i = tags.get(it.param1, 0) if it.command == DO_JUMP_TAG else math.trunc(it.param1)
        if not 0 < i < len(items):
            break
        it = items[i]
        if is_nav_command(it.command):
            relative = it.frame in (
                mav.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                mav.MAV_FRAME_GLOBAL_TERRAIN_ALT,
                mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
            )
            terrain = it.frame in (mav.MAV_FRAME_GLOBAL_TERRAIN_ALT, mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT)
            with np.errstate(over="ignore", invalid="ignore"):
                cm = np.float32(it.z) * np.float32(100.0)  # (past float32's range: inf, kept as 0)
            centimetres = int(cm) if np.isfinite(cm) else 0
            out.append(
                (
                    it.seq,
                    it.command,
                    relative,
                    terrain,
                    it.param1,
                    it.param2,
                    it.param3,
                    it.param4,
                    it.x,
                    it.y,
                    centimetres,
                )
            )
        i += 1
    return tuple(out)


def seconds_until_utc(now_unix_s: float, hour: int, minute: int, second: int) -> float:
    """How long a NAV_DELAY to a time of day waits, s, with the arithmetic of Rover's
    ``AP_RTC::get_time_utc(hour, minute, second, 0)``: the time is matched from its first
    field that is not -1 down (hour -1, minute 10: ten past the next hour), the fields
    below taken as given (a -1 among them counts as -1), and a time already past wraps by
    the unit above the first field given (a day for an hour).

    Parameters
    ----------
    now_unix_s : float
        Now, seconds since 1970 (UTC).
    hour, minute, second : int
        The time of day; -1 for a field not given.
    """
    day_ms = int(math.floor(now_unix_s * 1000.0)) % 86_400_000
    cur_ms, cur_s = day_ms % 1000, (day_ms // 1000) % 60
    cur_min, cur_h = (day_ms // 60_000) % 60, day_ms // 3_600_000
    fields = ((second, cur_s, 1000, 60_000), (minute, cur_min, 60_000, 3_600_000), (hour, cur_h, 3_600_000, 86_400_000))
    given = [k for k, (value, *_rest) in enumerate(fields) if value != -1]
    top = given[-1] if given else -1  # the milliseconds (0, as Rover asks) are always given
    delay = -cur_ms
    if top == -1:
        return (delay + 1000 if delay < 0 else delay) / 1000.0
    for k, (value, current, unit, wrap) in enumerate(fields[: top + 1]):
        delay += (value - current) * unit
        if k == top and delay < 0:
            delay += wrap
    return delay / 1000.0


def local_mission(waypoints: list[tuple[float, ...]], home: tuple[float, float, float]) -> list[MissionItem]:
    """A scenario's local waypoints (north, east[, hold]) as mission items, item 0 = home.

    Parameters
    ----------
    waypoints : list of tuples of float
        ``(north_m, east_m)`` or ``(north_m, east_m, hold_s)`` in the local NED frame.
    home : (lat_deg, lon_deg, alt_m)
        The local NED frame's origin.
    """
    from lfctl.frames import ned_to_geodetic

    items = [home_item(*home)]
    for k, wp in enumerate(waypoints, start=1):
        lat, lon, _ = ned_to_geodetic(wp[0], wp[1], 0.0, *home)
        hold = float(wp[2]) if len(wp) > 2 else 0.0
        items.append(
            MissionItem(
                k,
                mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                NAV_WAYPOINT,
                param1=hold,
                x=int(round(lat * 1e7)),
                y=int(round(lon * 1e7)),
                z=0.0,
            )
        )
    return items


# -- files ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class MissionFile:
    """What a mission file holds.

    Parameters
    ----------
    mission : list of MissionItem
        The mission, item 0 = home.
    fence : list of MissionItem
        A plan's geofence as FENCE items (none from a WPL file).
    rally : list of MissionItem
        A plan's rally points as RALLY items (none from a WPL file).
    plan : bool
        The file is a QGroundControl plan, whose three lists go together.
    """

    mission: list[MissionItem]
    fence: list[MissionItem]
    rally: list[MissionItem]
    plan: bool


#: farthest a mission file's place may lie from the scenario's home, m (the scenario's bound)
MAX_SITE_M = 100_000.0


def far_place(found: MissionFile, home: tuple[float, float, float]) -> str | None:
    """The first place in a mission file farther than :data:`MAX_SITE_M` from ``home`` (a
    mission item's, where latitude and longitude 0 is "here"; a fence vertex or circle
    centre; a rally point), said as "mission item 1 (NAV_WAYPOINT) at LAT, LON is N km
    from"; None when every place is near.

    Parameters
    ----------
    found : MissionFile
        What the file holds.
    home : (lat_deg, lon_deg, alt_m)
        Where the vehicles are.
    """
    from lfctl.frames import geodetic_to_ned

    lists = (("mission item", found.mission[1:]), ("fence item", found.fence), ("rally point", found.rally))
    for what, items in lists:
        for it in items:
            if what == "mission item" and (it.command not in STORES_LOCATION or (it.x == 0 and it.y == 0)):
                continue  # no place, or "here" (a fence vertex or rally point at 0, 0 is at 0, 0)
            lat, lon = it.lat_deg, it.lon_deg
            n, e, _ = geodetic_to_ned(lat, lon, 0.0, home[0], home[1], 0.0)
            far = math.hypot(n, e)
            if not far <= MAX_SITE_M:
                return (
                    f"{what} {it.seq} ({command_name(it.command)}) at {lat:.7f}, {lon:.7f} is {far / 1000:.0f} km from"
                )
    return None


def check_site(found: MissionFile, home: tuple[float, float, float], where: str) -> None:
    """Refuse a mission file planned for another site: a place farther than
    :data:`MAX_SITE_M` from ``home`` (:func:`far_place`) is a ConfigError naming it, its
    distance and the home.

    Parameters
    ----------
    found : MissionFile
        What the file holds.
    home : (lat_deg, lon_deg, alt_m)
        The local frame's origin the vehicles start about.
    where : str
        The file, for the message.
    """
    far = far_place(found, home)
    if far is not None:
        raise ConfigError(
            f"{where}: {far} the scenario's home {home[0]:.7f}, {home[1]:.7f}: the plan is for another site; "
            "set link.home_lat_deg and link.home_lon_deg to where it was made"
        )


def load_mission(path: str | Path) -> list[MissionItem]:
    """The mission of a QGC WPL 110 (.waypoints/.txt) or QGroundControl .plan file, item 0 =
    home (:func:`load_mission_file` reads a plan's geofence and rally points too).

    Parameters
    ----------
    path : str or Path
        The file, as :func:`load_mission_file` takes it (ConfigError when it cannot be read).
    """
    return load_mission_file(path).mission


def load_mission_file(path: str | Path, text: str | None = None) -> MissionFile:
    """Read a mission file: QGC WPL 110 (the mission) or a QGroundControl .plan (the mission,
    its geofence's polygons and circles as FENCE items, its rally points as RALLY items).

    Parameters
    ----------
    path : str or Path
        The file; a ``.plan`` suffix or JSON text is read as a .plan.
    text : str, optional
        Its text, already read (else it is read here).

    Raises
    ------
    ConfigError
        Unreadable file, or not one of the two formats (the message names the line or key).
    """
    p = Path(path)
    if text is None:
        text = read_text_file(p, "mission", MAX_FILE_BYTES)
    text = text.removeprefix("\ufeff")  # a byte-order mark some editors write: no meaning
    if p.suffix == ".plan" or text.lstrip().startswith("{"):
        found = MissionFile(*_load_plan(p, text), plan=True)
    else:
        found = MissionFile(_load_wpl(p, text), [], [], plan=False)
    if len(found.mission) > MAX_FILE_ITEMS:
        raise ConfigError(f"{p}: {len(found.mission)} items; a mission holds at most {MAX_FILE_ITEMS} (home included)")
    return found


def _item(
    where: str,
    seq: int,
    frame: int,
    command: int,
    params: list[float],
    lat: float,
    lon: float,
    alt: float,
    autocontinue: int,
) -> MissionItem:
    """One item from a file, each field checked against what MISSION_ITEM_INT carries.

    Parameters 1-4 may be NaN (QGroundControl's "unset"); the vehicle decides whether the
    command accepts them. Params 5 and 6 are degrees, scaled by 1e7 for MISSION_ITEM_INT, but
    taken as they are in MAV_FRAME_MISSION (a DO command's numbers), as QGroundControl uploads
    them. ``where`` names the line or item for the message.
    """
    if not 0 <= command <= 65535:
        raise ConfigError(f"{where}: command {command} is not a MAV_CMD (0..65535)")
    if not 0 <= frame <= 255:
        raise ConfigError(f"{where}: frame {frame} is not a MAV_FRAME (0..255)")
    if autocontinue not in (0, 1):
        raise ConfigError(f"{where}: autocontinue must be 0 or 1, got {autocontinue}")
    for i, v in enumerate(params, start=1):
        if not (math.isnan(v) or abs(v) <= _FLOAT32_MAX):
            raise ConfigError(f"{where}: param{i} = {v!r} does not fit a MAVLink float (NaN for unset)")
    if not (math.isfinite(alt) and abs(alt) <= _FLOAT32_MAX):
        raise ConfigError(f"{where}: altitude must be a finite number, got {alt!r}")
    if frame == mav.MAV_FRAME_MISSION:  # not a place: x and y go as they are (QGroundControl's upload)
        for i, v in ((5, lat), (6, lon)):
            if not (math.isfinite(v) and -(2**31) <= round(v) < 2**31):
                raise ConfigError(f"{where}: param{i} = {v!r} does not fit MISSION_ITEM_INT's integer")
        return MissionItem(seq, frame, command, *params, int(round(lat)), int(round(lon)), alt, autocontinue)
    for label, v, limit in (("latitude", lat, 90.0), ("longitude", lon, 180.0)):
        if not (math.isfinite(v) and abs(v) <= limit):
            raise ConfigError(f"{where}: {label} must be within [-{limit:g}, {limit:g}] degrees, got {v!r}")
    return MissionItem(seq, frame, command, *params, int(round(lat * 1e7)), int(round(lon * 1e7)), alt, autocontinue)


def _load_wpl(p: Path, text: str) -> list[MissionItem]:
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if not lines or not lines[0].startswith("QGC WPL 110"):
        raise ConfigError(
            f"{p}: not a QGC WPL 110 file (first line must be 'QGC WPL 110', got {lines[0][:40] if lines else ''!r})"
        )
    if len(lines) - 1 > MAX_FILE_ITEMS:
        raise ConfigError(f"{p}: {len(lines) - 1} items; a mission holds at most {MAX_FILE_ITEMS} (home included)")
    items = []
    for n, ln in enumerate(lines[1:], start=2):
        f = ln.replace("\t", " ").split()
        if len(f) != 12:
            raise ConfigError(f"{p}:{n}: expected 12 tab-separated fields, got {len(f)}")
        try:
            seq, _cur, frame, cmd = int(f[0]), int(f[1]), int(f[2]), int(f[3])
            p1, p2, p3, p4, lat, lon, alt = (float(v) for v in f[4:11])
            auto = int(float(f[11]))
        except (ValueError, OverflowError) as exc:
            raise ConfigError(f"{p}:{n}: bad number ({exc})") from None
        if seq != len(items):
            raise ConfigError(f"{p}:{n}: sequence {seq} out of order (expected {len(items)})")
        frame = {0: mav.MAV_FRAME_GLOBAL_INT, 3: mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT}.get(frame, frame)
        items.append(_item(f"{p}:{n}", seq, frame, cmd, [p1, p2, p3, p4], lat, lon, alt, auto))
    if not items:
        raise ConfigError(f"{p}: no mission items")
    return items


def _load_plan(p: Path, text: str) -> tuple[list[MissionItem], list[MissionItem], list[MissionItem]]:
    try:
        plan = json.loads(text)
    except (ValueError, RecursionError) as exc:  # (JSONDecodeError, or an integer of 4300+ digits)
        raise ConfigError(f"{p}: not a QGroundControl .plan file (not JSON: {str(exc)[:80]})") from None
    if not isinstance(plan, dict) or plan.get("fileType") != "Plan":
        kind = str(plan.get("fileType"))[:40] if isinstance(plan, dict) else type(plan).__name__
        raise ConfigError(f"{p}: not a QGroundControl .plan file (fileType {kind!r}, not 'Plan')")
    if plan.get("version") != 1:
        raise ConfigError(f"{p}: plan version {str(plan.get('version'))[:20]}: QGroundControl's plans are version 1")
    mission = plan.get("mission")
    if not isinstance(mission, dict):
        raise ConfigError(f"{p}: not a QGroundControl .plan file (no 'mission' object)")
    home, raw = mission.get("plannedHomePosition"), mission.get("items")
    if not (isinstance(home, list) and len(home) == 3 and all(_is_number(v) for v in home)):
        raise ConfigError(f"{p}: mission.plannedHomePosition must be [lat, lon, alt], got {str(home)[:60]}")
    if not isinstance(raw, list):
        raise ConfigError(f"{p}: mission.items must be a list, got {type(raw).__name__}")
    if len(raw) >= MAX_FILE_ITEMS:
        raise ConfigError(f"{p}: {len(raw) + 1} items; a mission holds at most {MAX_FILE_ITEMS} (home included)")
    items = [_item(f"{p}: plannedHomePosition", 0, mav.MAV_FRAME_GLOBAL_INT, NAV_WAYPOINT, [0.0] * 4, *home, 1)]
    jump_ids: dict[int, int] = {}  # a SimpleItem's doJumpId: its seq
    simple: set[int] = set()  # the seqs of the plan's own SimpleItems (not a survey's)
    for k, it in enumerate(raw):
        where = f"{p}: mission.items[{k}]"
        if not isinstance(it, dict):
            raise ConfigError(f"{where} must be an object, got {type(it).__name__}")
        if it.get("type") == "ComplexItem":
            for j, inner in enumerate(_complex_items(where, it)):
                items.append(_simple_item(f"{where}.TransectStyleComplexItem.Items[{j}]", inner, len(items)))
        elif it.get("type") == "SimpleItem":
            if _is_int(it.get("doJumpId")):
                jump_ids.setdefault(it["doJumpId"], len(items))
            simple.add(len(items))
            items.append(_simple_item(where, it, len(items)))
        else:
            raise ConfigError(f"{where}: item type {str(it.get('type'))[:40]!r} is not SimpleItem or ComplexItem")
        if len(items) > MAX_FILE_ITEMS:
            raise ConfigError(
                f"{p}: over {MAX_FILE_ITEMS} items; a mission holds at most {MAX_FILE_ITEMS} (home included)"
            )
    for k, it in enumerate(items):
        if it.command == DO_JUMP and k in simple:
            # QGroundControl's DO_JUMP names its target by doJumpId, and goes up with its seq
            target = jump_ids.get(int(it.param1)) if math.isfinite(it.param1) else None
            if target is None:
                raise ConfigError(f"{p}: the DO_JUMP at item {k} jumps to doJumpId {it.param1:g}, which no item has")
            items[k] = replace(it, param1=float(target))
    fence, rally = _plan_fence(p, plan.get("geoFence")), _plan_rally(p, plan.get("rallyPoints"))
    for what, made in (("geoFence", fence), ("rallyPoints", rally)):
        if len(made) > MAX_FILE_ITEMS:  # MISSION_COUNT is 16 bits
            raise ConfigError(f"{p}: {what} makes {len(made)} items; a list holds at most {MAX_FILE_ITEMS}")
    return items, fence, rally


def _latlon(where: str, value: object) -> tuple[float, float]:
    if not (isinstance(value, list) and len(value) >= 2 and all(_is_number(v) for v in value[:2])):
        raise ConfigError(f"{where} must be [latitude, longitude], got {str(value)[:60]}")
    return float(value[0]), float(value[1])


def _plan_fence(p: Path, fence: object) -> list[MissionItem]:
    """A plan's ``geoFence`` as FENCE items: each polygon's vertices (their count in param1),
    then each circle (its radius in param1), inclusion or exclusion as QGroundControl sends
    them; none when the plan has no ``geoFence``."""
    if fence is None:
        return []
    if not isinstance(fence, dict):
        raise ConfigError(f"{p}: geoFence must be an object, got {type(fence).__name__}")
    version = fence.get("version")
    if version == 1:  # QGroundControl 3.x's fence: QGroundControl ignores it, and so does lfctl
        log.warning("%s: geoFence version 1 (QGroundControl 3.x) ignored, as QGroundControl ignores it", p)
        return []
    if version != 2:
        raise ConfigError(
            f"{p}: geoFence version {str(version)[:20]}: QGroundControl reads version 2 (and ignores 1, "
            "or a fence with no version, without a word; lfctl refuses the last)"
        )
    polygons, circles = fence.get("polygons"), fence.get("circles")
    if not isinstance(polygons, list) or not isinstance(circles, list):
        raise ConfigError(f"{p}: geoFence.polygons and geoFence.circles must be lists (both are required)")
    out: list[MissionItem] = []
    for k, poly in enumerate(polygons):
        where = f"{p}: geoFence.polygons[{k}]"
        vertices = poly.get("polygon") if isinstance(poly, dict) else None
        inclusion = poly.get("inclusion") if isinstance(poly, dict) else None
        if not isinstance(vertices, list) or not isinstance(inclusion, bool):
            raise ConfigError(f"{where} must be {{'inclusion': true or false, 'polygon': [[lat, lon], ...]}}")
        if not 3 <= len(vertices) <= MAX_VERTICES:
            raise ConfigError(f"{where}: a polygon has 3 to {MAX_VERTICES} vertices, this one {len(vertices)}")
        cmd = POLYGON_INCLUSION if inclusion else POLYGON_EXCLUSION
        for j, vertex in enumerate(vertices):
            lat, lon = _latlon(f"{where}.polygon[{j}]", vertex)
            out.append(_item(where, len(out), mav.MAV_FRAME_GLOBAL, cmd, [len(vertices), 0, 0, 0], lat, lon, 0.0, 1))
    for k, circle in enumerate(circles):
        where = f"{p}: geoFence.circles[{k}]"
        inner = circle.get("circle") if isinstance(circle, dict) else None
        radius = inner.get("radius") if isinstance(inner, dict) else None
        inclusion = circle.get("inclusion") if isinstance(circle, dict) else None
        if not _is_number(radius) or not isinstance(inclusion, bool):
            raise ConfigError(
                f"{where} must be {{'inclusion': true or false, 'circle': {{'center': [lat, lon], 'radius': m}}}}"
            )
        if not (math.isfinite(radius) and radius >= FLT_EPSILON):  # type: ignore[arg-type]  # as validate_fence
            raise ConfigError(f"{where}: the circle's radius must be above 0 m, got {radius!r}")
        lat, lon = _latlon(f"{where}.circle.center", inner.get("center"))  # type: ignore[union-attr]
        cmd = CIRCLE_INCLUSION if inclusion else CIRCLE_EXCLUSION
        out.append(_item(where, len(out), mav.MAV_FRAME_GLOBAL, cmd, [float(radius), 0, 0, 0], lat, lon, 0.0, 1))
    back = fence.get("breachReturn")
    if back is not None:  # where a breach sends the vehicle: QGroundControl's fence return point
        where = f"{p}: geoFence.breachReturn"
        if not (isinstance(back, list) and len(back) == 3 and all(_is_number(v) for v in back)):
            raise ConfigError(f"{where} must be [latitude, longitude, altitude], got {str(back)[:60]}")
        out.append(_item(where, len(out), mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, RETURN_POINT, [0.0] * 4, *back, 1))
    return out


def _plan_rally(p: Path, rally: object) -> list[MissionItem]:
    """A plan's ``rallyPoints`` as RALLY items (latitude, longitude, altitude above home)."""
    if rally is None:
        return []
    if isinstance(rally, dict) and rally.get("version") == 1:  # as QGroundControl: ignored
        log.warning("%s: rallyPoints version 1 ignored, as QGroundControl ignores it", p)
        return []
    if isinstance(rally, dict) and rally.get("version") != 2:
        raise ConfigError(f"{p}: rallyPoints version {str(rally.get('version'))[:20]}: QGroundControl reads version 2")
    points = rally.get("points", []) if isinstance(rally, dict) else None
    if not isinstance(points, list):
        raise ConfigError(f"{p}: rallyPoints must be {{'points': [[lat, lon, alt], ...]}}")
    out: list[MissionItem] = []
    for k, point in enumerate(points):
        where = f"{p}: rallyPoints.points[{k}]"
        if not (isinstance(point, list) and len(point) == 3 and all(_is_number(v) for v in point)):
            raise ConfigError(f"{where} must be [latitude, longitude, altitude], got {str(point)[:60]}")
        out.append(_item(where, k, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, RALLY_POINT, [0.0] * 4, *point, 1))
    return out


def _plan_geofence(fence: list[MissionItem]) -> dict:
    """FENCE items as a plan's ``geoFence`` (runs of polygon vertices, circles)."""
    polygons: list[dict] = []
    circles: list[dict] = []
    breach: list[float] | None = None
    k = 0
    while k < len(fence):
        it = fence[k]
        if it.command in (POLYGON_INCLUSION, POLYGON_EXCLUSION):
            run = fence[k : k + max(1, int(it.param1))]
            polygons.append(
                {
                    "inclusion": it.command == POLYGON_INCLUSION,
                    "polygon": [[v.lat_deg, v.lon_deg] for v in run],
                    "version": 1,
                }
            )
            k += len(run)
            continue
        if it.command == RETURN_POINT:
            breach = [it.lat_deg, it.lon_deg, it.z]
        if it.command in (CIRCLE_INCLUSION, CIRCLE_EXCLUSION):
            circles.append(
                {
                    "circle": {"center": [it.lat_deg, it.lon_deg], "radius": it.param1},
                    "inclusion": it.command == CIRCLE_INCLUSION,
                    "version": 1,
                }
            )
        k += 1
    out: dict = {"circles": circles, "polygons": polygons, "version": 2}
    if breach is not None:
        out["breachReturn"] = breach
    return out


def _complex_items(where: str, it: dict) -> list[object]:
    """The mission items a QGroundControl complex item (a survey, a corridor scan) carries
    in its file: QGroundControl saves the items it made of a transect-style one under
    ``TransectStyleComplexItem.Items``; the others (a structure scan, a landing pattern) it
    makes again when it loads them, from geometry lfctl does not rebuild."""
    kind = str(it.get("complexItemType"))[:40]
    inner = it.get("TransectStyleComplexItem")
    made = inner.get("Items") if isinstance(inner, dict) else None
    if not isinstance(made, list):
        raise ConfigError(
            f"{where}: complex item {kind!r} carries no mission items in the file (QGroundControl makes them "
            "when it loads it): upload it from QGroundControl, or save the mission from there as .waypoints"
        )
    return made


def _simple_item(where: str, it: object, seq: int) -> MissionItem:
    """One SimpleItem of a .plan (as QGroundControl's MissionItem::save writes it) as item ``seq``."""
    if not isinstance(it, dict):
        raise ConfigError(f"{where} must be an object, got {type(it).__name__}")
    prm = it.get("params", [0] * 7)
    if not (isinstance(prm, list) and len(prm) == 7 and all(v is None or _is_number(v) for v in prm)):
        raise ConfigError(f"{where}.params must be 7 numbers (null for unset), got {str(prm)[:60]}")
    # QGroundControl's null: unset, NaN in a parameter (as it sends it), 0 in a position
    values = [(math.nan if k < 4 else 0.0) if v is None else float(v) for k, v in enumerate(prm)]
    command, frame, auto = it.get("command"), it.get("frame", 3), it.get("autoContinue", True)
    if not _is_int(command):
        raise ConfigError(f"{where}.command must be a whole number, got {str(command)[:40]}")
    if not _is_int(frame):
        raise ConfigError(f"{where}.frame must be a whole number, got {str(frame)[:40]}")
    if not isinstance(auto, bool):
        raise ConfigError(f"{where}.autoContinue must be true or false, got {str(auto)[:40]}")
    frame = {3: mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 0: mav.MAV_FRAME_GLOBAL_INT, 2: mav.MAV_FRAME_MISSION}.get(
        frame, frame
    )
    return _item(where, seq, frame, command, values[:4], *values[4:], int(auto))


def _is_number(v: object) -> bool:
    """A JSON number a float can hold (an integer too large for one is not)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return False
    return isinstance(v, float) or abs(v) <= _FLOAT64_MAX


def _is_int(v: object) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def save_mission(
    items: list[MissionItem],
    path: str | Path,
    fence: list[MissionItem] | None = None,
    rally: list[MissionItem] | None = None,
) -> None:
    """Write QGC WPL 110 (default) or .plan (by extension).

    Parameters
    ----------
    items : list of MissionItem
        The mission, item 0 = home.
    path : str or Path
        The file; a ``.plan`` suffix writes a QGroundControl plan.
    fence, rally : list of MissionItem, optional
        The geofence's and the rally points' items, for a plan (WPL holds the mission only).

    Raises
    ------
    ConfigError
        ``path`` is a folder, or a named pipe no one reads (:func:`lfctl.checks.save_text`).
    """
    p = Path(path)
    if p.suffix == ".plan":
        home = items[0] if items else MissionItem(0, 0, NAV_WAYPOINT)
        plan = {
            "fileType": "Plan",
            "version": 1,
            "groundStation": "lfctl",
            "geoFence": _plan_geofence(fence or []),
            "rallyPoints": {"points": [[it.lat_deg, it.lon_deg, it.z] for it in rally or []], "version": 2},
            "mission": {
                "version": 2,
                "firmwareType": 3,
                "vehicleType": 10,
                "cruiseSpeed": 0.3,
                "hoverSpeed": 0.3,
                "plannedHomePosition": [home.lat_deg, home.lon_deg, home.z],
                "items": [
                    {
                        "type": "SimpleItem",
                        "autoContinue": bool(it.autocontinue),
                        "command": it.command,
                        "doJumpId": it.seq,
                        "frame": it.frame if it.frame != mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT else 3,
                        # NaN (unset) as QGroundControl writes it: null (bare NaN is not JSON;
                        # nor is an infinity, in a parameter the command does not use)
                        "params": [
                            v if math.isfinite(v) else None
                            for v in (it.param1, it.param2, it.param3, it.param4, *it.file_xy, it.z)
                        ],
                    }
                    for it in items[1:]
                ],
            },
        }
        save_text(p, json.dumps(plan, indent=2, allow_nan=False))
        return
    rows = ["QGC WPL 110"]
    for it in items:
        frame = {mav.MAV_FRAME_GLOBAL_INT: 0, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: 3}.get(it.frame, it.frame)
        vals = [
            it.seq,
            int(it.seq == 0),
            frame,
            it.command,
            it.param1,
            it.param2,
            it.param3,
            it.param4,
            *(f"{v:.7f}" if it.frame != mav.MAV_FRAME_MISSION else f"{v:g}" for v in it.file_xy),
            it.z,
            it.autocontinue,
        ]
        rows.append("\t".join(str(v) for v in vals))
    save_text(p, "\n".join(rows) + "\n")
