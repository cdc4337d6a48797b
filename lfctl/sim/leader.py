"""The leader in the co-simulation: its autopilot flies the mission its MAVLink endpoint
holds (AUTO), follows GUIDED setpoints, or holds, as an ArduPilot Rover would."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from lfctl.config import Config
from lfctl.guidance.leader import AutopilotSettings, LeaderAutopilot
from lfctl.guidance.smc import BearingGains
from lfctl.link.endpoint import MODES, VehicleEndpoint
from lfctl.link.mission import Leg, to_legs
from lfctl.sim.scripted import scripted_command
from lfctl.sim.world import WorldState

__all__ = ["LeaderDriver", "autopilot_settings"]


def autopilot_settings(cfg: Config) -> AutopilotSettings:
    """The leader AUTO settings a scenario asks for.

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


class LeaderDriver:
    """Turns the leader endpoint's mode and mission into speed and yaw-rate commands.

    The autopilot is rebuilt whenever the endpoint's mission or current item changes (a
    ground station uploaded, or set the current item).

    Parameters
    ----------
    cfg : Config
        The scenario.
    endpoint : VehicleEndpoint
        The leader's MAVLink face (mode, arming, mission, parameters).
    home : (lat_deg, lon_deg, alt_m)
        Where local NED is anchored.
    step_s : float
        The guidance period, s.
    on_reached : callable, optional
        Told ``(t_s, index, active, count)`` when a waypoint is reached (the recorder).
    """

    def __init__(
        self,
        cfg: Config,
        endpoint: VehicleEndpoint,
        home: tuple[float, float, float],
        step_s: float,
        on_reached: Callable[[float, int, int, int], None] | None = None,
    ) -> None:
        self.cfg = cfg
        self.endpoint = endpoint
        self.home = home
        self.step_s = step_s
        self.on_reached = on_reached
        self.command: tuple[float, float] = (0.0, 0.0)  # speed (m/s), yaw rate (rad/s)
        self.reached: list[tuple[int, float]] = []  # (waypoint index from 0, t_s)
        self._autopilot: LeaderAutopilot | None = None
        self._version = -1
        self._legs: list[Leg] = []

    def update(self, t_s: float, world: WorldState) -> tuple[float, float]:
        """The leader's command at ``t_s`` (kept in :attr:`command`).

        Parameters
        ----------
        t_s : float
            Now, s.
        world : WorldState
            The truth (the leader is vehicle 0).
        """
        self.command = self._command(t_s, world)
        return self.command

    def _command(self, t_s: float, world: WorldState) -> tuple[float, float]:
        ep = self.endpoint
        if not ep.armed:
            return 0.0, 0.0
        if ep.mode == MODES["GUIDED"]:
            return ep.guided_command() or (0.0, 0.0)
        if ep.mode != MODES["AUTO"]:
            return 0.0, 0.0
        if not ep.mission:
            return scripted_command(self.cfg.script, t_s) if not self.cfg.mission.waypoints else (0.0, 0.0)
        me = world.vehicle(0)
        if ep.mission_version != self._version:
            self._version = ep.mission_version
            self._legs = to_legs(ep.mission, self.home, max(1, ep.current_seq))
            settings = dataclasses.replace(
                autopilot_settings(self.cfg),
                cruise_speed_mps=ep.param("WP_SPEED"),
                acceptance_radius_m=ep.param("WP_RADIUS"),
            )
            self._autopilot = LeaderAutopilot(
                [(g.north_m, g.east_m, g.hold_s) for g in self._legs],
                settings,
                (me.north_m, me.east_m),
                [g.speed_mps for g in self._legs],
            )
        assert self._autopilot is not None
        out = self._autopilot.step(t_s, me.north_m, me.east_m, me.yaw_rad, self.step_s)
        for k in out.los.reached:
            seq = self._legs[k].seq
            ep.reached(seq)
            self.reached.append((seq - 1, t_s))
            if self.on_reached is not None:
                self.on_reached(t_s, seq - 1, ep.current_seq, len(ep.mission) - 1)
        return out.speed_mps, out.yaw_rate_radps
