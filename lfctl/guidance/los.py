"""Line-of-sight waypoint guidance (paper eq. 12-16) and the leader's waypoint follower.

Angles in NED, from north, clockwise positive, wrapped to (-pi, pi]. ``x`` is north and ``y``
is east, as in the paper's figure 5. The paper writes arctan of a ratio; we use atan2 so the
quadrant is right, and call eq. 14 what it is: a heading error, not a cross-track error.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from lfctl.frames import wrap_pi

#: how near a point the vehicle stops at must have come along its track to have arrived, m
#: (Rover's position controller brings it onto the point; this is the last of its approach)
ARRIVAL_M = 0.05

__all__ = [
    "ARRIVAL_M",
    "LosOutput",
    "WaypointFollower",
    "cross_track_m",
    "distance_to_go_m",
    "heading_error_rad",
    "los_angle_rad",
    "los_heading_rad",
    "path_angle_rad",
]


def los_angle_rad(north_m: float, east_m: float, wp_north_m: float, wp_east_m: float) -> float:
    """Eq. 12: angle of the line of sight from the vehicle to waypoint i.

    ``psi_los = atan2(Y_i - y, X_i - x)``, rad.

    Parameters
    ----------
    north_m, east_m : float
        The vehicle's position, NED, m.
    wp_north_m, wp_east_m : float
        Waypoint i, NED, m.
    """
    return math.atan2(wp_east_m - east_m, wp_north_m - north_m)


def path_angle_rad(prev_north_m: float, prev_east_m: float, wp_north_m: float, wp_east_m: float) -> float:
    """Eq. 13: angle of the active path segment from waypoint i-1 to waypoint i.

    ``psi_d = atan2(Y_i - Y_{i-1}, X_i - X_{i-1})``, rad.

    Parameters
    ----------
    prev_north_m, prev_east_m : float
        Waypoint i-1 (the segment's start), NED, m.
    wp_north_m, wp_east_m : float
        Waypoint i, NED, m.
    """
    return math.atan2(wp_east_m - prev_east_m, wp_north_m - prev_north_m)


def heading_error_rad(path_angle: float, heading_rad: float) -> float:
    """Eq. 14 (named correctly): ``psi_d - psi``, wrapped to (-pi, pi], rad.

    Parameters
    ----------
    path_angle : float
        The path angle ``psi_d`` (see :func:`path_angle_rad`), rad.
    heading_rad : float
        The vehicle's heading ``psi``, rad.
    """
    return wrap_pi(path_angle - heading_rad)


def distance_to_go_m(north_m: float, east_m: float, wp_north_m: float, wp_east_m: float) -> float:
    """Eq. 15: ``S = sqrt((X_i - x)^2 + (Y_i - y)^2)``, m.

    Parameters
    ----------
    north_m, east_m : float
        The vehicle's position, NED, m.
    wp_north_m, wp_east_m : float
        Waypoint i, NED, m.
    """
    return math.hypot(wp_north_m - north_m, wp_east_m - east_m)


def cross_track_m(distance_to_go: float, los_angle: float, path_angle: float) -> float:
    """Eq. 16: signed cross-track error, positive when the vehicle is right of the path.

    The paper's ``e = S sin(psi_los - psi_d)`` is positive when the vehicle is *left* of the
    path (the line of sight then points right of the path); we return ``S sin(psi_d -
    psi_los)`` so that positive means right, the convention of :func:`los_heading_rad`.

    Parameters
    ----------
    distance_to_go : float
        ``S``, the distance to waypoint i (see :func:`distance_to_go_m`), m.
    los_angle : float
        ``psi_los`` (see :func:`los_angle_rad`), rad.
    path_angle : float
        ``psi_d`` (see :func:`path_angle_rad`), rad.
    """
    return distance_to_go * math.sin(wrap_pi(path_angle - los_angle))


def los_heading_rad(path_heading_rad: float, cross_track: float, lookahead_m: float) -> float:
    """Desired heading from lookahead LOS guidance (paper eq. 12-16).

    Parameters
    ----------
    path_heading_rad : float
        Heading of the active path segment in NED, in (-pi, pi].
    cross_track : float
        Signed cross-track error, positive when the vehicle is right of the path, m.
    lookahead_m : float
        Lookahead distance, > 0, m.
    """
    return wrap_pi(path_heading_rad - math.atan2(cross_track, lookahead_m))


def along_track_m(north_m: float, east_m: float, prev: tuple[float, float], wp: tuple[float, float]) -> float:
    """Distance travelled along the segment prev -> wp (negative before prev), m."""
    dn, de = wp[0] - prev[0], wp[1] - prev[1]
    length = math.hypot(dn, de)
    if length == 0.0:
        return 0.0
    return ((north_m - prev[0]) * dn + (east_m - prev[1]) * de) / length


@dataclass(frozen=True)
class LosOutput:
    """One step of waypoint guidance (NED angles from north, clockwise positive)."""

    heading_cmd_rad: float  # the heading to steer
    path_angle_rad: float  # of the active segment (eq. 13)
    los_angle_rad: float  # to the active waypoint (eq. 12)
    cross_track_m: float  # from the active segment, positive right of it (eq. 16, sign flipped)
    distance_to_go_m: float  # to the active waypoint, or to the last one when done (eq. 15)
    active_index: int  # index of the waypoint being approached
    reached: tuple[int, ...]  # waypoints reached in this step
    done: bool  # the last waypoint has been reached


class WaypointFollower:
    """Switches through waypoints inside an acceptance radius and gives the LOS heading.

    A waypoint the vehicle drives through counts as reached when the vehicle is inside
    ``acceptance_radius_m`` of it, or when it has passed the waypoint's perpendicular (so a
    wide turn never circles back). A waypoint it stops at (``stops``) is driven onto, as
    ArduPilot's Rover does (AR_WPNav: a stop point is reached once the vehicle has come along
    its track to the point, and is inside the radius or past the point's perpendicular): it
    counts as reached within :data:`ARRIVAL_M` of the point along the track and inside the
    radius, or past the perpendicular; when its leg begins with the vehicle already past that
    perpendicular (a sharp turn onto a short leg), the leg starts where the vehicle is. A
    waypoint on the segment's start (nothing to drive) is reached at once.

    Parameters
    ----------
    waypoints_ned_m : sequence of (north_m, east_m)
        The route; the vehicle's start pose is the segment start for the first one.
    acceptance_radius_m : float
        Switching radius, >= 0, m (0: a waypoint is reached only by passing it, as Rover's
        WP_RADIUS 0).
    lookahead_m : float or None
        Lookahead distance for LOS on the path (None: pure pursuit of the waypoint, eq. 12).
    start_ned_m : (north_m, east_m)
        Where the vehicle starts: the first segment's start.
    stops : callable, optional
        Whether the vehicle stops at waypoint ``i`` (a wait there, the route's end); asked
        each step, so the answer may change (default: it stops at none).
    """

    def __init__(
        self,
        waypoints_ned_m: Sequence[tuple[float, float]],
        acceptance_radius_m: float,
        lookahead_m: float | None,
        start_ned_m: tuple[float, float] = (0.0, 0.0),
        stops: Callable[[int], bool] | None = None,
    ) -> None:
        if not acceptance_radius_m >= 0 or not math.isfinite(acceptance_radius_m):
            raise ValueError(f"acceptance_radius_m must be >= 0, got {acceptance_radius_m!r}")
        if lookahead_m is not None and not lookahead_m > 0:
            raise ValueError(f"lookahead_m must be > 0 or None, got {lookahead_m!r}")
        self.waypoints = [(float(n), float(e)) for n, e in waypoints_ned_m]
        self.acceptance_radius_m = acceptance_radius_m
        self.lookahead_m = lookahead_m
        self.stops = stops if stops is not None else _never
        self.index = 0
        self.prev = (float(start_ned_m[0]), float(start_ned_m[1]))

    @property
    def done(self) -> bool:
        """True once the last waypoint has been reached."""
        return self.index >= len(self.waypoints)

    def step(self, north_m: float, east_m: float, heading_rad: float, most: int | None = None) -> LosOutput:
        """Advance past reached waypoints and return the heading command (the current
        heading once the route is done).

        Parameters
        ----------
        north_m, east_m : float
            The vehicle's position, NED, m.
        heading_rad : float
            The vehicle's heading, rad.
        most : int, optional
            Advance past at most this many waypoints (default: all that are reached), so
            that whoever steps it sees each one begin before the next is reached.

        Raises
        ------
        ValueError
            A position or heading that is not a number, named (a NaN position passes every
            waypoint's "not yet reached" test and would finish the route).
        """
        for name, value in (("north_m", north_m), ("east_m", east_m), ("heading_rad", heading_rad)):
            if not math.isfinite(value):
                raise ValueError(f"waypoint guidance's {name} is {value!r}: it needs a number")
        reached: list[int] = []
        while not self.done and (most is None or len(reached) < most):
            wp = self.waypoints[self.index]
            dist = distance_to_go_m(north_m, east_m, *wp)
            seg_len = math.hypot(wp[0] - self.prev[0], wp[1] - self.prev[1])
            along = along_track_m(north_m, east_m, self.prev, wp)
            inside = dist <= self.acceptance_radius_m
            if self.stops(self.index):  # driven onto: come along the track to it, then inside
                inside = inside and along >= seg_len - ARRIVAL_M
            if seg_len > 0 and not inside and along < seg_len:
                break
            reached.append(self.index)
            self.prev = wp
            self.index += 1
            if not self.done and self.stops(self.index):
                ahead = self.waypoints[self.index]
                if along_track_m(north_m, east_m, wp, ahead) >= math.dist(wp, ahead) > 0:
                    # already past the point it is to stop on (a sharp turn onto a short leg,
                    # the last one reached at the radius before it): driven to from here, as
                    # Rover's position controller brings it back, not taken as passed
                    self.prev = (float(north_m), float(east_m))
        if self.done:
            last = self.waypoints[-1] if self.waypoints else (north_m, east_m)
            return LosOutput(
                heading_rad,
                heading_rad,
                heading_rad,
                0.0,
                distance_to_go_m(north_m, east_m, *last),
                self.index,
                tuple(reached),
                True,
            )
        wp = self.waypoints[self.index]
        los = los_angle_rad(north_m, east_m, *wp)
        dist = distance_to_go_m(north_m, east_m, *wp)
        path = path_angle_rad(*self.prev, *wp) if wp != self.prev else los
        e = cross_track_m(dist, los, path)
        cmd = los if self.lookahead_m is None else los_heading_rad(path, e, self.lookahead_m)
        return LosOutput(cmd, path, los, e, dist, self.index, tuple(reached), False)

    def next_turn_rad(self) -> float:
        """Absolute heading change at the active waypoint (0 at the last one)."""
        if self.index + 1 >= len(self.waypoints):
            return 0.0
        a = path_angle_rad(*self.prev, *self.waypoints[self.index])
        b = path_angle_rad(*self.waypoints[self.index], *self.waypoints[self.index + 1])
        return abs(wrap_pi(b - a))


def _never(index: int) -> bool:
    """No waypoint is stopped at (a :class:`WaypointFollower`'s default)."""
    return False
