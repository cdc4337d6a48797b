"""The leader's autopilot (AUTO): LOS waypoint guidance + sliding-mode heading control, with
a speed profile that slows for sharp turns, and stops on the waypoints where the mission
waits or stops and on the last one."""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field, replace

from lfctl.frames import wrap_pi
from lfctl.guidance.los import LosOutput, WaypointFollower
from lfctl.guidance.smc import BearingGains, SlidingModeController, clamp

__all__ = ["CREEP_MPS", "AutopilotOutput", "AutopilotSettings", "LeaderAutopilot"]

#: the slowest a vehicle approaching a point it stops on is asked to go, m/s (Rover's slowest
#: waypoint speed, AR_WPNav's): its last few centimetres are driven, not approached for ever
CREEP_MPS = 0.05


@dataclass(frozen=True)
class AutopilotSettings:
    """Leader AUTO settings.

    Parameters
    ----------
    cruise_speed_mps : float
        Speed on straight legs, m/s.
    acceptance_radius_m : float
        Waypoint switching radius, >= 0, m.
    lookahead_m : float or None
        LOS lookahead on the path, m (None: pure pursuit of the waypoint).
    turn_slowdown : float
        Fraction of the cruise speed shed for a 180 deg turn at the next waypoint (0..1).
    slow_distance_m : float
        Distance before a waypoint over which the turn slowdown is blended in, m.
    decel_mps2 : float
        Deceleration used to stop on a waypoint (a wait there, the last one), m/s^2.
    heading : BearingGains
        Sliding-mode heading gains.
    """

    cruise_speed_mps: float = 0.3
    acceptance_radius_m: float = 0.3
    lookahead_m: float | None = 0.8
    turn_slowdown: float = 0.6
    slow_distance_m: float = 0.8
    decel_mps2: float = 0.3
    heading: BearingGains = field(
        default_factory=lambda: BearingGains(eta_radps=1.0, lam_s=0.1, phi_rad=0.35, max_yaw_rate_radps=1.5)
    )


@dataclass(frozen=True)
class AutopilotOutput:
    """One step of the leader autopilot."""

    speed_mps: float  # forward speed command
    yaw_rate_radps: float  # yaw-rate command, positive right
    los: LosOutput  # the waypoint guidance behind it (reached waypoints, distance to go)
    holding_s: float  # remaining wait at a waypoint (0 when driving)


class LeaderAutopilot:
    """Drives a list of waypoints: ``(north_m, east_m)`` or ``(north_m, east_m, hold_s)``.

    Parameters
    ----------
    waypoints : sequence of sequences of float
        The route in local NED, m; a third value is a wait at that waypoint, s.
    settings : AutopilotSettings
        Speeds, radii and heading gains.
    start_ned_m : (north_m, east_m)
        Where the leader starts: the first segment's start, m.
    one_per_step : bool
        Reach at most one waypoint a step, even where several are within reach (a mission's
        items waiting where the one before ended): each begins, and may change its wait or
        speed, before the next is reached.
    stop_at : collection of int
        Waypoints it stops on though it waits there 0 s (a NAV_LOITER_TIME of 0 s); it stops
        on every waypoint with a wait and on the last one anyway.
    """

    def __init__(
        self,
        waypoints: Sequence[Sequence[float]],
        settings: AutopilotSettings,
        start_ned_m: tuple[float, float],
        one_per_step: bool = False,
        stop_at: Collection[int] = (),
    ) -> None:
        self.settings = settings
        self._most = 1 if one_per_step else None
        self.holds = [float(w[2]) if len(w) > 2 else 0.0 for w in waypoints]
        self._stop_at = frozenset(stop_at)
        self.follower = WaypointFollower(
            [(w[0], w[1]) for w in waypoints],
            settings.acceptance_radius_m,
            settings.lookahead_m,
            start_ned_m,
            stops=self.stops_at,  # asked each step: a wait may be set as its leg begins
        )
        self.heading = SlidingModeController(settings.heading)
        self._hold_until = -math.inf
        self._prev_cmd: float | None = None
        self._last_los: LosOutput | None = None

    @property
    def done(self) -> bool:
        """All waypoints reached."""
        return self.follower.done

    def set_acceptance_radius(self, radius_m: float) -> None:
        """The waypoint radius from the next step on (a ground station's WP_RADIUS, which
        Rover's AR_WPNav reads every update; the same one changes nothing).

        Parameters
        ----------
        radius_m : float
            The radius, >= 0, m.
        """
        if radius_m != self.settings.acceptance_radius_m:
            self.settings = replace(self.settings, acceptance_radius_m=radius_m)
            self.follower.acceptance_radius_m = radius_m

    def replace_after(self, index: int, waypoints: Sequence[Sequence[float]], stop_at: Collection[int] = ()) -> None:
        """The waypoints after ``index`` replaced (a mission edited ahead of the vehicle):
        the one under way and those before it are kept, with the progress made.

        Parameters
        ----------
        index : int
            The last waypoint kept.
        waypoints : sequence of sequences of float
            The new ones after it, as the constructor takes them.
        stop_at : collection of int
            Of the new ones, those it stops on though it waits there 0 s (their indices in
            the whole route, as the constructor's).
        """
        self.holds[index + 1 :] = [float(w[2]) if len(w) > 2 else 0.0 for w in waypoints]
        self.follower.waypoints[index + 1 :] = [(float(w[0]), float(w[1])) for w in waypoints]
        self._stop_at = frozenset({i for i in self._stop_at if i <= index} | set(stop_at))

    def stops_at(self, index: int) -> bool:
        """Whether it stops on waypoint ``index``: a wait there, the last one, or one of ``stop_at``.

        Parameters
        ----------
        index : int
            The waypoint.
        """
        if not 0 <= index < len(self.holds):
            return False
        return index == len(self.holds) - 1 or self.holds[index] > 0 or index in self._stop_at

    def waiting(self, t_s: float) -> bool:
        """Whether it is still waiting at a waypoint at ``t_s`` (its next step stands still).

        Parameters
        ----------
        t_s : float
            Now, s.
        """
        return t_s < self._hold_until

    def step(self, t_s: float, north_m: float, east_m: float, yaw_rad: float, dt_s: float) -> AutopilotOutput:
        """Commands for this guidance step: zero while waiting at a waypoint and once done.

        Parameters
        ----------
        t_s : float
            Now, s.
        north_m, east_m : float
            The leader's position, NED, m.
        yaw_rad : float
            The leader's heading, rad.
        dt_s : float
            Time since the previous step, s.
        """
        st = self.settings
        if self.waiting(t_s) and self._last_los is not None:  # waiting at a waypoint
            # the waypoint was reached once, when the wait began: not again on every tick
            return AutopilotOutput(0.0, 0.0, replace(self._last_los, reached=()), self._hold_until - t_s)
        los = self.follower.step(north_m, east_m, yaw_rad, self._most)
        self._last_los = los
        for i in los.reached:
            if self.holds[i] > 0:
                self._hold_until = t_s + self.holds[i]
        if los.done or t_s < self._hold_until:
            self.heading.reset()
            self._prev_cmd = None
            return AutopilotOutput(0.0, 0.0, los, max(0.0, self._hold_until - t_s))
        err = wrap_pi(los.heading_cmd_rad - yaw_rad)
        ff = 0.0  # equivalent control: the turn rate of the commanded heading itself
        if self._prev_cmd is not None and dt_s > 0 and not los.reached:
            ff = clamp(wrap_pi(los.heading_cmd_rad - self._prev_cmd) / dt_s, -0.5, 0.5)
        self._prev_cmd = los.heading_cmd_rad
        yaw_rate = self.heading.step(err, dt_s, ff)
        # speed: slow for the coming turn and for a large heading error; stop where it ends or waits
        speed = st.cruise_speed_mps
        turn = self.follower.next_turn_rad()
        blend = clamp(1.0 - (los.distance_to_go_m - st.acceptance_radius_m) / st.slow_distance_m, 0.0, 1.0)
        speed *= 1.0 - st.turn_slowdown * (turn / math.pi) * blend
        speed *= max(0.0, math.cos(err)) ** 2
        if self.stops_at(self.follower.index):  # onto the point itself, as Rover's stop waypoints
            speed = min(speed, max(CREEP_MPS, math.sqrt(2.0 * st.decel_mps2 * los.distance_to_go_m)))
        return AutopilotOutput(speed, yaw_rate, los, 0.0)
