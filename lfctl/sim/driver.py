"""Each vehicle's autopilot in the co-simulation, as ArduPilot Rover runs its modes: the
mode, mission and targets its MAVLink endpoint holds become speed and yaw-rate commands.

- AUTO: LOS waypoint guidance with sliding-mode heading control over the mission's legs
  (DO_JUMP unrolled, DO_CHANGE_SPEED applied); a scenario's scripted leader (no mission)
  drives its speed / yaw-rate profile instead;
- GUIDED: a rate target passes through, a heading target is held with the heading law, a
  location target is driven to and stopped at (MISSION_ITEM_REACHED 0 on arrival);
- RTL: to the nearest rally point or home, then stop; SmartRTL: back along the way it came;
- MANUAL: the ground station's sticks (RC_CHANNELS_OVERRIDE, MANUAL_CONTROL;
  :mod:`lfctl.link.rc`) as speed and yaw rate; no live override: stop;
- HOLD, disarmed: stop.

A reversed vehicle (MAV_CMD_DO_SET_REVERSE) drives its targets backwards.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.config import Config
from lfctl.frames import wrap_pi
from lfctl.guidance.leader import AutopilotSettings, LeaderAutopilot
from lfctl.guidance.los import LosOutput
from lfctl.guidance.smc import BearingGains, SlidingModeController
from lfctl.link.endpoint import MODES, NavReport, VehicleEndpoint
from lfctl.link.mission import Leg, nav_count, to_legs
from lfctl.sim.scripted import scripted_command
from lfctl.sim.world import WorldState

__all__ = ["VehicleDriver", "autopilot_settings", "speed_max"]


def autopilot_settings(cfg: Config) -> AutopilotSettings:
    """The AUTO settings a scenario asks for.

    Parameters
    ----------
    cfg : Config
        The scenario (``[guidance]`` gains, ``[mission]`` speeds and radii).
    """
    g, m = cfg.guidance, cfg.mission
    return AutopilotSettings(
        cruise_speed_mps=min(m.cruise_speed_mps, g.max_speed_mps),
        acceptance_radius_m=m.acceptance_radius_m,
        lookahead_m=m.lookahead_m if m.lookahead_m > 0 else None,
        turn_slowdown=g.turn_slowdown,
        heading=BearingGains(
            eta_radps=g.heading_eta_radps,
            lam_s=g.heading_lambda_s,
            phi_rad=g.heading_phi_rad,
            max_yaw_rate_radps=g.max_yaw_rate_radps,
        ),
    )


class VehicleDriver:
    """Turns one vehicle endpoint's mode, mission and targets into commands.

    The AUTO autopilot is rebuilt whenever the endpoint's mission, current item or speed
    changes (a ground station uploaded, set the current item, or changed the speed).

    Parameters
    ----------
    cfg : Config
        The scenario.
    endpoint : VehicleEndpoint
        The vehicle's MAVLink face (mode, arming, mission, targets, parameters).
    index : int
        The vehicle's row in the world state.
    home : (lat_deg, lon_deg, alt_m)
        Where local NED is anchored.
    step_s : float
        The guidance period, s.
    scripted : bool
        Drive ``[script]``'s profile in AUTO when there is no mission (the scenario's leader).
    on_reached : callable, optional
        Told ``(t_s, index, active, count, waypoints, mission)`` when a mission waypoint is
        reached (the recorder): ``waypoints`` is the NAV items in the mission it belongs to,
        ``mission`` that mission's number (:attr:`MissionServer.mission_number`).
    """

    def __init__(
        self,
        cfg: Config,
        endpoint: VehicleEndpoint,
        index: int,
        home: tuple[float, float, float],
        step_s: float,
        scripted: bool = False,
        on_reached: Callable[[float, int, int, int, int, int], None] | None = None,
    ) -> None:
        self.cfg = cfg
        self.endpoint = endpoint
        self.index = index
        self.home = home
        self.step_s = step_s
        self.scripted = scripted
        self.on_reached = on_reached
        self.command: tuple[float, float] = (0.0, 0.0)  # speed (m/s), yaw rate (rad/s)
        self.reached: list[tuple[int, float]] = []  # (waypoint index from 0, t_s)
        self.reached_of: int | None = None  # waypoints (NAV items) in the mission last reached in
        self._reached_in: tuple[int, set[int]] = (0, set())  # that mission's number, its items reached
        self._autopilot: LeaderAutopilot | None = None
        self._key: tuple[object, ...] = ()
        self._legs: list[Leg] = []
        self._goto: LeaderAutopilot | None = None
        self._goto_key: tuple[object, ...] = ()
        self._goto_done = False
        self._heading = SlidingModeController(autopilot_settings(cfg).heading)

    def update(self, t_s: float, world: WorldState) -> tuple[float, float]:
        """The vehicle's command at ``t_s`` (kept in :attr:`command`); where it steers goes to
        the endpoint's :meth:`~lfctl.link.endpoint.VehicleEndpoint.steering` (NAV_CONTROLLER_OUTPUT), None when it has no destination.

        Parameters
        ----------
        t_s : float
            Now, s.
        world : WorldState
            The truth.
        """
        self.endpoint.steering(None)  # told again by the modes that steer for a destination
        self.command = self._command(t_s, world)
        return self.command

    def link_command(self) -> tuple[float, float]:
        """The command for the vehicle's FMU at a link tick: a GUIDED rate target fresh from
        the endpoint (a companion's setpoints arrive faster than guidance runs), else :attr:`command`."""
        ep = self.endpoint
        if ep.armed and ep.mode == MODES["MANUAL"]:
            return self._manual()
        if ep.armed and ep.mode == MODES["GUIDED"]:
            rate = ep.guided_command()
            if rate is not None:
                return rate
            if ep.guided is None or ep.guided.kind == "rate":
                return 0.0, 0.0
        return self.command if ep.armed else (0.0, 0.0)

    def _command(self, t_s: float, world: WorldState) -> tuple[float, float]:
        ep = self.endpoint
        if not ep.armed:
            return 0.0, 0.0
        if ep.mode == MODES["GUIDED"]:
            return self._guided(t_s, world)
        if ep.mode == MODES["AUTO"]:
            return self._auto(t_s, world)
        if ep.mode in (MODES["RTL"], MODES["SMART_RTL"]):
            return self._return(t_s, world)
        self._goto = None
        if ep.mode == MODES["MANUAL"]:
            return self._manual()
        return 0.0, 0.0

    # -- MANUAL --------------------------------------------------------------------------------
    def _manual(self) -> tuple[float, float]:
        """The sticks as Rover's MANUAL passes them to its motors, for a vehicle commanded in
        speed and yaw rate: the throttle stick is a fraction of full throttle, and full
        throttle is the speed Rover projects from its feed-forward (:func:`speed_max`), up to
        the scenario's ``max_speed_mps`` either way; the steering stick at full throw is the
        vehicle's tightest turn (``max_yaw_rate_degps``). Backing up turns the other way, as
        Rover's default ``PILOT_STEER_TYPE`` (a car's steering)."""
        ep = self.endpoint
        pilot = ep.pilot_input()
        g = self.cfg.guidance
        full = speed_max(ep.param("CRUISE_SPEED"), ep.param("CRUISE_THROTTLE"))
        speed = max(-g.max_speed_mps, min(g.max_speed_mps, pilot.throttle * full))
        turn = -1.0 if pilot.throttle < 0 else 1.0
        return speed, turn * pilot.steering * g.max_yaw_rate_radps

    # -- AUTO ----------------------------------------------------------------------------------
    def _auto(self, t_s: float, world: WorldState) -> tuple[float, float]:
        ep = self.endpoint
        if not ep.mission:
            return (
                scripted_command(self.cfg.script, t_s)
                if self.scripted and not self.cfg.mission.waypoints
                else (0.0, 0.0)
            )
        me = world.vehicle(self.index)
        key = (ep.mission_version, ep.speed_mps)
        if key != self._key and not (self._autopilot is not None and self._done(key)):
            self._key = key
            self._legs = to_legs(ep.mission, self.home, max(1, ep.current_seq))
            settings = dataclasses.replace(
                autopilot_settings(self.cfg),
                cruise_speed_mps=ep.speed_mps,
                acceptance_radius_m=ep.param("WP_RADIUS"),
            )
            self._autopilot = LeaderAutopilot(
                [(g.north_m, g.east_m, g.hold_s) for g in self._legs],
                settings,
                (me.north_m, me.east_m),
                [g.speed_mps for g in self._legs],
            )
        assert self._autopilot is not None
        yaw = me.yaw_rad + math.pi if ep.reversed else me.yaw_rad
        out = self._autopilot.step(t_s, me.north_m, me.east_m, yaw, self.step_s)
        for k in out.los.reached:
            seq = self._legs[k].seq
            ep.reached(seq, last=k == len(self._legs) - 1)
            self.reached.append((seq - 1, t_s))
            self.reached_of = nav_count(ep.mission)
            number = ep.missions.mission_number
            if self._reached_in[0] != number:
                self._reached_in = (number, set())
            self._reached_in[1].add(seq - 1)
            if self.on_reached is not None:
                self.on_reached(t_s, seq - 1, ep.current_seq, len(ep.mission) - 1, self.reached_of, number)
        # after the items reached moved the current one
        ep.steering(_nav_report(out.los, ep.reversed, self._autopilot.follower.waypoints))
        return (-out.speed_mps if ep.reversed else out.speed_mps), out.yaw_rate_radps

    @property
    def distinct_reached(self) -> int:
        """Distinct waypoints reached of the mission last reached in (a mission flown twice
        counts each once; an earlier, replaced mission's not at all)."""
        return len(self._reached_in[1])

    def _done(self, key: tuple[int, float]) -> bool:
        """The mission in force is finished and only the speed changed (a WP_SPEED set, a
        parameter file loaded): AUTO stays where it ended, as Rover's does, instead of flying
        its last leg again (and reporting its last item reached twice)."""
        return self.endpoint.mission_complete and bool(self._key) and key[0] == self._key[0]

    # -- GUIDED --------------------------------------------------------------------------------
    def _guided(self, t_s: float, world: WorldState) -> tuple[float, float]:
        ep = self.endpoint
        g = ep.guided_target()
        if g is None:
            self._goto = None
            return 0.0, 0.0
        if g.kind == "rate":
            return g.speed_mps, g.yaw_rate_radps
        me = world.vehicle(self.index)
        if g.kind == "heading":
            yaw = me.yaw_rad + math.pi if ep.reversed else me.yaw_rad
            rate = self._heading.step(wrap_pi(g.heading_rad - yaw), self.step_s)
            return (-g.speed_mps if ep.reversed else g.speed_mps), rate
        speed = g.speed_mps if g.speed_mps > 0 else ep.speed_mps
        done, cmd = self._drive_to([(g.north_m, g.east_m)], (g.t_s, g.north_m, g.east_m, speed), speed, t_s, world)
        if done:
            ep.guided_reached()
        return cmd

    # -- RTL, SmartRTL --------------------------------------------------------------------------
    def _return(self, t_s: float, world: WorldState) -> tuple[float, float]:
        ep = self.endpoint
        me = world.vehicle(self.index)
        # Rover's RTL speed (RTL_SPEED, else WP_SPEED) until a DO_CHANGE_SPEED in the mode
        speed = ep.desired_speed_mps or ep.param("RTL_SPEED") or ep.param("WP_SPEED")
        if ep.mode == MODES["SMART_RTL"] and ep.path:
            route = list(reversed(ep.path))
            key: tuple[object, ...] = ("srtl", ep.modes[-1][0])
        else:
            route = [ep.rtl_destination(me.north_m, me.east_m)]
            key = ("rtl", ep.modes[-1][0], route[0])
        done, cmd = self._drive_to(route, key, speed, t_s, world)
        if done:
            ep.statustext("Reached destination", mav.MAV_SEVERITY_INFO)
        return cmd

    def _drive_to(
        self, route: list[tuple[float, float]], key: tuple[object, ...], speed: float, t_s: float, world: WorldState
    ) -> tuple[bool, tuple[float, float]]:
        """Drive a route and stop at its end: (just arrived, command)."""
        ep = self.endpoint
        me = world.vehicle(self.index)
        if key != self._goto_key or self._goto is None:
            self._goto_key = key
            self._goto_done = False
            settings = dataclasses.replace(
                autopilot_settings(self.cfg), cruise_speed_mps=speed, acceptance_radius_m=ep.param("WP_RADIUS")
            )
            self._goto = LeaderAutopilot(route, settings, (me.north_m, me.east_m))
        elif self._goto.settings.cruise_speed_mps != speed:
            # a new speed on the way (DO_CHANGE_SPEED): the same route, from where it has got to
            self._goto.settings = dataclasses.replace(self._goto.settings, cruise_speed_mps=speed)
        yaw = me.yaw_rad + math.pi if ep.reversed else me.yaw_rad
        out = self._goto.step(t_s, me.north_m, me.east_m, yaw, self.step_s)
        ep.steering(_nav_report(out.los, ep.reversed, self._goto.follower.waypoints))
        arrived = self._goto.done and not self._goto_done
        self._goto_done = self._goto.done
        return arrived, ((-out.speed_mps if ep.reversed else out.speed_mps), out.yaw_rate_radps)


def speed_max(cruise_speed_mps: float, cruise_throttle_pct: float) -> float:
    """The speed at full throttle, m/s, as Rover's ``Mode::calc_speed_max`` projects it: the
    cruise speed over the cruise throttle, or the cruise speed itself when the cruise throttle
    is not a sane 5-100 %; at most 30 m/s.

    Parameters
    ----------
    cruise_speed_mps : float
        ``CRUISE_SPEED``, m/s.
    cruise_throttle_pct : float
        ``CRUISE_THROTTLE``, percent.
    """
    throttle = cruise_throttle_pct / 100.0
    full = cruise_speed_mps if throttle > 1.0 or throttle < 0.05 else cruise_speed_mps / throttle
    return min(30.0, max(0.0, full))


def _nav_report(los: LosOutput, reversed_: bool, waypoints: Sequence[tuple[float, float]]) -> NavReport | None:
    """Where the waypoint guidance over ``waypoints`` (local NED) steers, as
    NAV_CONTROLLER_OUTPUT gives it: towards its active waypoint (the last once all are
    reached; None when there are none, as in a mission of home alone). A vehicle driving in
    reverse steers its tail, so its body heads the other way."""
    if not waypoints:
        return None
    heading = los.heading_cmd_rad + math.pi if reversed_ else los.heading_cmd_rad
    destination = waypoints[min(los.active_index, len(waypoints) - 1)]
    return NavReport(heading, los.los_angle_rad, los.distance_to_go_m, los.cross_track_m, destination)
