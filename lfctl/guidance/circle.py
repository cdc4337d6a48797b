"""A mission's circle (NAV_LOITER_TURNS), driven as ArduPilot Rover's circle mode drives it:
first to the circle's edge on the line from its centre through the vehicle, then round it
at a steady speed until the turns asked for are done.

Rover's ``ModeCircle`` moves a target point round the circle and has its position controller
follow it. Here the vehicle steers by a guidance field round the circle instead: along the
tangent, turned towards the circle by ``atan(radial error / lookahead)``, with the circle's
own turn rate (speed / radius) as the heading controller's feed-forward. The turns are
counted as the vehicle goes round the centre once it is on the circle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from lfctl.frames import wrap_pi
from lfctl.guidance.smc import BearingGains, SlidingModeController

__all__ = ["LATERAL_ACCEL_MAX_MPS2", "RADIUS_MIN_M", "CircleGuidance", "CircleOutput", "circle_radius_m"]

#: the smallest circle Rover drives, m (``AR_CIRCLE_RADIUS_MIN``)
RADIUS_MIN_M = 0.1
#: the sideways acceleration Rover allows round a circle, m/s^2 (``ATC_TURN_MAX_G`` 0.6 g)
LATERAL_ACCEL_MAX_MPS2 = 0.6 * 9.80665


def circle_radius_m(param3: float) -> float:
    """The radius a Rover keeps for a NAV_LOITER_TURNS whose param3 is ``param3``, m (its sign
    is the direction: negative counter-clockwise). AP_Mission stores it in one byte: whole
    metres up to 255, and above that tens of metres (at most 2550).

    Parameters
    ----------
    param3 : float
        The item's radius, m.
    """
    r = abs(param3)
    if not math.isfinite(r):
        raise ValueError(f"radius must be a number, got {param3!r}")
    if r <= 255.0:
        return float(math.trunc(r))
    return 10.0 * min(255, math.trunc(r * 0.1))


@dataclass(frozen=True)
class CircleOutput:
    """One step round a circle."""

    speed_mps: float  # forward speed command
    yaw_rate_radps: float  # yaw-rate command, positive right
    heading_cmd_rad: float  # the heading steered
    target_ned_m: tuple[float, float]  # the point it drives for (the edge, then its own place on the circle)
    distance_m: float  # to that point
    cross_track_m: float  # from the circle, positive right of its direction of travel


class CircleGuidance:
    """Drive to a circle's edge, then round it.

    Parameters
    ----------
    centre_ned_m : (north_m, east_m)
        The circle's centre, local NED, m.
    radius_m : float
        Its radius, m (at least :data:`RADIUS_MIN_M`; the caller raises it to the vehicle's
        turning radius first).
    ccw : bool
        Counter-clockwise seen from above (else clockwise).
    turns : float
        How many times round; 0 is done at once.
    speed_mps : float
        Speed round the circle, m/s (limited by :meth:`speed_limit_mps`).
    reach_m : float
        How near the edge counts as on it, m.
    lookahead_m : float
        The guidance field's lookahead, m: a vehicle this far outside the circle steers 45 deg
        in from the tangent.
    heading : BearingGains
        The heading controller's gains (and the vehicle's yaw-rate limit).
    start_ned_m : (north_m, east_m)
        Where the vehicle is as the circle begins.
    start_yaw_rad : float
        Its heading then (the way out to the edge when it starts at the centre).
    """

    def __init__(
        self,
        centre_ned_m: tuple[float, float],
        radius_m: float,
        ccw: bool,
        turns: float,
        speed_mps: float,
        reach_m: float,
        lookahead_m: float,
        heading: BearingGains,
        start_ned_m: tuple[float, float],
        start_yaw_rad: float,
    ) -> None:
        if not radius_m >= RADIUS_MIN_M:
            raise ValueError(f"radius_m must be >= {RADIUS_MIN_M}, got {radius_m!r}")
        if not (turns >= 0 and math.isfinite(turns)):
            raise ValueError(f"turns must be >= 0, got {turns!r}")
        if not lookahead_m > 0:
            raise ValueError(f"lookahead_m must be > 0, got {lookahead_m!r}")
        self.centre = (float(centre_ned_m[0]), float(centre_ned_m[1]))
        self.radius_m = float(radius_m)
        self.sign = -1.0 if ccw else 1.0
        self.turns = float(turns)
        self.reach_m = float(reach_m)
        self.lookahead_m = float(lookahead_m)
        self._gains = heading
        self.heading = SlidingModeController(heading)
        self.speed_mps = 0.0
        self.set_speed(speed_mps)
        dn, de = start_ned_m[0] - self.centre[0], start_ned_m[1] - self.centre[1]
        self.entry_bearing_rad = math.atan2(de, dn) if (dn, de) != (0.0, 0.0) else float(start_yaw_rad)
        self.on_circle = False
        self.angle_rad = 0.0  # gone round since reaching the edge, in the circle's direction
        self._last_bearing: float | None = None

    def speed_limit_mps(self) -> float:
        """The fastest the circle is driven, m/s: what Rover's lateral-acceleration limit
        allows (``sqrt(a r)``, its ``check_config_speed``), and what the vehicle's yaw-rate
        limit allows with a fifth of it to spare for correcting (lfctl's)."""
        return min(
            math.sqrt(LATERAL_ACCEL_MAX_MPS2 * self.radius_m), 0.8 * self._gains.max_yaw_rate_radps * self.radius_m
        )

    def set_speed(self, speed_mps: float) -> bool:
        """A new speed round the circle, as Rover's ``ModeCircle::set_desired_speed``: taken
        when positive, limited to :meth:`speed_limit_mps`. True when it was cut to the limit.

        Parameters
        ----------
        speed_mps : float
            The speed asked for, m/s.
        """
        if not speed_mps > 0:
            return False
        limit = self.speed_limit_mps()
        self.speed_mps = min(float(speed_mps), limit)
        return speed_mps > limit

    @property
    def done(self) -> bool:
        """The turns are done (at once for 0 turns, as Rover's ``verify_circle``)."""
        return self.angle_rad >= self.turns * 2.0 * math.pi

    def _point_at(self, bearing_rad: float) -> tuple[float, float]:
        return (
            self.centre[0] + self.radius_m * math.cos(bearing_rad),
            self.centre[1] + self.radius_m * math.sin(bearing_rad),
        )

    def step(self, north_m: float, east_m: float, yaw_rad: float, dt_s: float) -> CircleOutput:
        """Commands for this guidance step.

        Parameters
        ----------
        north_m, east_m : float
            The vehicle's position, NED, m.
        yaw_rad : float
            Its heading, rad.
        dt_s : float
            Time since the previous step, s.
        """
        dn, de = north_m - self.centre[0], east_m - self.centre[1]
        d = math.hypot(dn, de)
        bearing = math.atan2(de, dn) if d > 0 else self.entry_bearing_rad
        self.on_circle = self.on_circle or abs(d - self.radius_m) <= self.reach_m
        if not self.on_circle:
            target = self._point_at(self.entry_bearing_rad)
            heading_cmd = math.atan2(target[1] - east_m, target[0] - north_m)
            err = wrap_pi(heading_cmd - yaw_rad)
            rate = self.heading.step(err, dt_s)
            speed = self.speed_mps * max(0.0, math.cos(err)) ** 2
            distance = math.hypot(target[0] - north_m, target[1] - east_m)
            return CircleOutput(speed, rate, heading_cmd, target, distance, 0.0)
        if self._last_bearing is not None:
            self.angle_rad += self.sign * wrap_pi(bearing - self._last_bearing)
        self._last_bearing = bearing
        radial = d - self.radius_m  # outside: positive
        heading_cmd = wrap_pi(bearing + self.sign * (math.pi / 2.0 + math.atan(radial / self.lookahead_m)))
        err = wrap_pi(heading_cmd - yaw_rad)
        rate = self.heading.step(err, dt_s, self.sign * self.speed_mps / self.radius_m)
        speed = self.speed_mps * max(0.0, math.cos(err)) ** 2
        # right of the direction of travel is inside a clockwise circle, outside an anticlockwise one
        return CircleOutput(speed, rate, heading_cmd, self._point_at(bearing), abs(radial), -self.sign * radial)
