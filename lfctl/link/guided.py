"""GUIDED targets as ArduPilot Rover takes them: what each setpoint message asks the vehicle
to do (``Rover/GCS_MAVLink_Rover.cpp``, ``mode_guided.cpp``).

A target is one of

- ``rate``: a turn rate and a speed (a companion's SET_POSITION_TARGET_LOCAL_NED with
  velocity and yaw rate, SET_ATTITUDE_TARGET with a body yaw rate);
- ``heading``: a heading and a speed (velocity alone, velocity or speed with a heading,
  a heading alone, SET_ATTITUDE_TARGET's quaternion; not MAV_CMD_NAV_SET_YAW_SPEED, which
  Rover's newest source is built without);
- ``location``: a place to drive to and stop at (a position setpoint, MAV_CMD_DO_REPOSITION,
  a MISSION_ITEM with current = 2).

Rate and heading targets stop the vehicle when no new one arrives for 3 s (Rover 4.6's);
a location target holds until reached. Pure: message fields and the vehicle's pose in, a
target (or the reason it is ignored) out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from lfctl.frames import FLT_EPSILON, geodetic_to_ned, wrap_pi

__all__ = [
    "MASK_ACC_IGNORE",
    "MASK_POS_IGNORE",
    "MASK_VEL_IGNORE",
    "MASK_YAW_IGNORE",
    "MASK_YAW_RATE_IGNORE",
    "GuidedTarget",
    "Pose",
    "attitude_target",
    "position_target",
]

#: POSITION_TARGET_TYPEMASK bits
MASK_POS_IGNORE = 0b0000_0000_0111
MASK_VEL_IGNORE = 0b0000_0011_1000
MASK_ACC_IGNORE = 0b0001_1100_0000
MASK_YAW_IGNORE = 0b0100_0000_0000
MASK_YAW_RATE_IGNORE = 0b1000_0000_0000
#: ATTITUDE_TARGET_TYPEMASK bits
ATT_YAW_RATE_IGNORE = 0b0000_0100
ATT_THROTTLE_IGNORE = 0b0100_0000

Kind = Literal["rate", "heading", "location"]


@dataclass(frozen=True)
class Pose:
    """The vehicle now, as setpoints are interpreted against it.

    Parameters
    ----------
    north_m, east_m : float
        Position, local NED, m.
    yaw_rad : float
        Heading, rad from north.
    """

    north_m: float
    east_m: float
    yaw_rad: float


@dataclass(frozen=True)
class GuidedTarget:
    """What GUIDED drives to.

    Parameters
    ----------
    kind : "rate", "heading" or "location"
        See the module docstring.
    t_s : float
        When it arrived (rate and heading targets time out from here), s.
    speed_mps : float
        Forward speed, m/s (negative: backwards); for a location target the speed to go
        at (0: WP_SPEED).
    yaw_rate_radps : float
        Turn rate of a rate target, rad/s, positive right.
    heading_rad : float
        Heading of a heading target, rad from north.
    north_m, east_m : float
        Where a location target is, local NED, m.
    """

    kind: Kind
    t_s: float
    speed_mps: float = 0.0
    yaw_rate_radps: float = 0.0
    heading_rad: float = 0.0
    north_m: float = 0.0
    east_m: float = 0.0

    @property
    def times_out(self) -> bool:
        """Rate and heading targets stop the vehicle when not renewed in time."""
        return self.kind != "location"


def _finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


def position_target(
    t_s: float,
    frame: str,
    type_mask: int,
    x: float,
    y: float,
    vx: float,
    vy: float,
    yaw: float,
    yaw_rate: float,
    pose: Pose,
    speed_max_mps: float,
    origin_offset_m: tuple[float, float] = (0.0, 0.0),
) -> GuidedTarget | str:
    """The target of a SET_POSITION_TARGET_LOCAL_NED or _GLOBAL_INT, or why it is ignored.

    Parameters
    ----------
    t_s : float
        When it arrived, s.
    frame : "local", "local_offset", "body" or "global"
        ``local``: x, y from the local origin; ``local_offset``: from the vehicle; ``body``:
        from the vehicle, rotated by its heading (velocity and yaw too); ``global``: x, y
        already converted to local north, east by the caller.
    type_mask : int
        POSITION_TARGET_TYPEMASK: which fields to ignore.
    x, y : float
        Position (m; see ``frame``).
    vx, vy : float
        Velocity, m/s.
    yaw : float
        Heading, rad.
    yaw_rate : float
        Turn rate, rad/s.
    pose : Pose
        The vehicle now.
    speed_max_mps : float
        The speed a velocity may ask for at most (WP_SPEED), m/s.
    origin_offset_m : (float, float)
        Where the local frame's origin is in the vehicle's local NED (0, 0 here: the
        simulated vehicles' origin is home).
    """
    pos = not type_mask & MASK_POS_IGNORE
    vel = not type_mask & MASK_VEL_IGNORE
    acc = not type_mask & MASK_ACC_IGNORE
    has_yaw = not type_mask & MASK_YAW_IGNORE
    has_rate = not type_mask & MASK_YAW_RATE_IGNORE
    used = [v for v, on in ((x, pos), (y, pos), (vx, vel), (vy, vel), (yaw, has_yaw), (yaw_rate, has_rate)) if on]
    if not _finite(*used):
        return "a field it uses is not a number"
    if acc:
        return "acceleration is not ignored: set ACC_IGNORE in type_mask"
    body = frame == "body"
    if pos:
        if frame == "local":
            n, e = origin_offset_m[0] + x, origin_offset_m[1] + y
        elif frame == "local_offset":
            n, e = pose.north_m + x, pose.east_m + y
        elif body:
            c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
            n, e = pose.north_m + x * c - y * s, pose.east_m + x * s + y * c
        else:
            n, e = x, y
        return GuidedTarget("location", t_s, north_m=n, east_m=e)
    if has_yaw and has_rate:  # Rover's handlers take one or the other: such a setpoint does nothing
        return "both yaw and yaw rate are given (Rover takes one of them, and ignores this)"
    speed, heading = 0.0, 0.0
    if vel:
        speed = max(-speed_max_mps, min(speed_max_mps, math.hypot(vx, vy)))
        heading = math.atan2(vy, vx) + (pose.yaw_rad if body else 0.0)
    if has_yaw:
        heading = yaw + (pose.yaw_rad if body else 0.0)
    if vel and (has_yaw or has_rate) and vx <= -FLT_EPSILON:  # Rover's is_negative(vx)
        speed = -speed  # with a heading or turn rate given, the sign of vx says forward or back
    if vel and has_rate and not has_yaw:
        return GuidedTarget("rate", t_s, speed_mps=speed, yaw_rate_radps=yaw_rate)
    if vel or has_yaw:
        return GuidedTarget("heading", t_s, speed_mps=speed if vel else 0.0, heading_rad=wrap_pi(heading))
    if has_rate:
        return GuidedTarget("rate", t_s, speed_mps=0.0, yaw_rate_radps=yaw_rate)
    return "it sets nothing (every field ignored)"


def attitude_target(
    t_s: float,
    type_mask: int,
    q: tuple[float, float, float, float],
    body_yaw_rate: float,
    thrust: float,
    speed_default_mps: float,
) -> GuidedTarget | str:
    """The target of a SET_ATTITUDE_TARGET (thrust as a fraction of the default speed), or
    why it is ignored.

    Parameters
    ----------
    t_s : float
        When it arrived, s.
    type_mask : int
        ATTITUDE_TARGET_TYPEMASK.
    q : (w, x, y, z)
        Attitude quaternion; its yaw is the heading when the body yaw rate is ignored.
    body_yaw_rate : float
        Turn rate, rad/s.
    thrust : float
        -1..1: the speed as a fraction of ``speed_default_mps``.
    speed_default_mps : float
        The vehicle's default speed (WP_SPEED), m/s.
    """
    if type_mask & ATT_THROTTLE_IGNORE:
        return "thrust is ignored in type_mask: a rover needs it for its speed"
    if not _finite(thrust, body_yaw_rate, *q):
        return "a field it uses is not a number"
    speed = speed_default_mps * max(-1.0, min(1.0, thrust))
    if type_mask & ATT_YAW_RATE_IGNORE:
        # Rover's Quaternion::get_euler_yaw, as it is: not normalised, so an all-zero
        # quaternion is yaw atan2(0, 1) = 0, north (a real Rover drives north on it too)
        w, x, y, z = q
        heading = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
        return GuidedTarget("heading", t_s, speed_mps=speed, heading_rad=wrap_pi(heading))
    return GuidedTarget("rate", t_s, speed_mps=speed, yaw_rate_radps=body_yaw_rate)


def global_to_local(lat_e7: int, lon_e7: int, home: tuple[float, float, float]) -> tuple[float, float]:
    """A degE7 latitude and longitude as local north, east (m) from home.

    Parameters
    ----------
    lat_e7, lon_e7 : int
        Position, degrees x 1e7.
    home : (lat_deg, lon_deg, alt_m)
        The local origin.
    """
    n, e, _ = geodetic_to_ned(lat_e7 / 1e7, lon_e7 / 1e7, home[2], *home)
    return n, e
