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

A reversed vehicle (MAV_CMD_DO_SET_REVERSE, Rover's AR_WPNav flag) drives its mission legs,
GUIDED places and way home backwards; a GUIDED heading target is steered with the body, as
Rover's ModeGuided does. A speed round a circle it cannot keep is cut and said.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Sequence

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.config import Config
from lfctl.frames import wrap_pi
from lfctl.guidance.circle import RADIUS_MIN_M, CircleGuidance, circle_radius_m
from lfctl.guidance.leader import AutopilotSettings, LeaderAutopilot
from lfctl.guidance.los import LosOutput
from lfctl.guidance.smc import BearingGains, SlidingModeController
from lfctl.link.endpoint import MODES, WP_SPEED_MIN_MPS, NavReport, VehicleEndpoint
from lfctl.link.mission import (
    ACTED_ON,
    CONDITION_DELAY,
    CONDITION_DISTANCE,
    DO_CHANGE_SPEED,
    DO_JUMP,
    DO_JUMP_TAG,
    JUMP_TAG,
    NAV_DELAY,
    NAV_GUIDED_ENABLE,
    NAV_LOITER_TIME,
    NAV_LOITER_TURNS,
    NAV_LOITER_UNLIM,
    NAV_RETURN_TO_LAUNCH,
    NAV_SET_YAW_SPEED,
    NAV_WAYPOINT,
    NOTHING_FITTED,
    NOTHING_FITTED_REACHED,
    PLACES,
    SKIPPED_NAV,
    SKIPPED_SAID,
    Leg,
    MissionItem,
    command_name,
    int_as,
    is_nav_command,
    mission_text,
    nav_count,
    seconds_until_utc,
    walk_mission,
    watched_items,
)
from lfctl.sim.scripted import scripted_command
from lfctl.sim.world import WorldState

#: the navigation items a Rover drives in its AUTO WP submode (do_nav_wp): an edit of the
#: mission ahead restarts the one under way only in it (ModeAuto::update)
WP_SUBMODE = frozenset({NAV_WAYPOINT, NAV_LOITER_TIME, NAV_LOITER_UNLIM})

__all__ = ["VehicleDriver", "autopilot_settings", "speed_max"]


@dataclasses.dataclass
class _Turn:
    """A NAV_SET_YAW_SPEED under way, as Rover's ModeAuto HeadingAndSpeed submode holds it
    (or a NAV_GUIDED_ENABLE of param1 0, which has no heading and is done at once)."""

    leg: int
    heading_cd: float | None  # Rover's _desired_yaw_cd (None: a NAV_GUIDED_ENABLE)
    speed_mps: float  # Rover's _desired_speed
    reached: bool  # Rover's _reached_heading: checked by the mission at its next update
    kept: float | None  # the waypoints' speed as it began (a ground station's DO_CHANGE_SPEED)


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
        self._leg = 0  # the leg under way
        self._queue: list[MissionItem] = []  # its DO commands and conditions still to run
        self._condition: tuple[int, str, float] | None = None  # (item, "time" | "distance", until)
        self._holding: tuple[int, float] | None = None  # (leg, since when) waiting at its end
        self._tail: tuple[MissionItem, ...] = ()  # the items after the last navigation item
        self._paused: tuple[object, ...] = ()  # the mission AUTO left part-way (its key), to resume
        self._built: list[MissionItem] | None = None  # the mission the legs were made from
        self._restarts = 0  # the endpoint's mission restarts (from item 0) the legs know of
        self._completed = False  # ... and it is finished
        self._pos = (0.0, 0.0)  # where the vehicle is this step, local NED, m
        self._yaw = 0.0  # the way it drives this step (its tail's, in reverse), rad
        self._body_yaw = 0.0  # the way its body points this step, rad
        self._distance = 0.0  # how far it is from the leg's end, m
        self._goto: LeaderAutopilot | None = None
        self._goto_key: tuple[object, ...] = ()
        self._goto_done = False
        self._return_route: list[tuple[float, float]] = []  # RTL's or SmartRTL's, chosen as it began
        self._heading = SlidingModeController(autopilot_settings(cfg).heading)
        # the circle under way: (leg, guidance, the waypoints' speed as it began: DO_CHANGE_SPEED)
        self._circle: tuple[int, CircleGuidance, float | None] | None = None
        self._turn: _Turn | None = None  # the heading and speed under way
        # the leg whose navigation item has started: Rover's submode is still the one before
        # while the first DO command ahead of a navigation item starts
        self._nav_started = -1
        self._watched: tuple[tuple[object, ...], ...] = ()  # the navigation items ahead, as last read

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
        if ep.mode != MODES["AUTO"]:
            # AUTO entered again restarts the item under way (Rover's resume), with the DO
            # command that was running and the DO_JUMP counts as they were
            self._paused = self._key or self._paused
            self._key = ()
        # as Rover, whose mode's update runs every loop, armed or not (Rover::update_current_mode):
        # AUTO runs its mission from the moment it is entered (AP_Mission says "Mission: 1
        # WP"), GUIDED and RTL steer for their place (NAV_CONTROLLER_OUTPUT, the target); the
        # motors of a disarmed vehicle stay still
        cmd = self._mode_command(t_s, world)
        return cmd if ep.armed else (0.0, 0.0)

    def _mode_command(self, t_s: float, world: WorldState) -> tuple[float, float]:
        """The mode's command, as if armed."""
        ep = self.endpoint
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
        running = self._autopilot is not None and bool(self._key) and bool(self._legs) and not self._completed
        if not ep.mission and not running:
            return (
                scripted_command(self.cfg.script, t_s)
                if self.scripted and not self.cfg.mission.waypoints
                else (0.0, 0.0)
            )
        # a mission emptied under way (an upload of no items: Rover's truncate(0), which no
        # state check refuses): AP_Mission::update does nothing while it has no items, so the
        # item under way is never done, and ModeAuto drives on to its place (a circle round)
        frozen = not ep.mission
        me = world.vehicle(self.index)
        self._pos = (me.north_m, me.east_m)
        self._yaw = me.yaw_rad + math.pi if ep.reversed else me.yaw_rad  # the way it drives
        self._body_yaw = me.yaw_rad
        key = (ep.mission_version, ep.mission_edits)
        if self._key != key or self._autopilot is None:
            edited = self._autopilot is not None and self._key[:1] == key[:1]
            # a new mission uploaded while this one is flown: Rover writes it over the old
            # one and goes on with the item of the same number, as after an edit
            uploaded = running and ep.mission is not self._built and ep.current_seq == self._legs[self._leg].seq
            if self._autopilot is not None and ep.mission_complete:
                # a finished mission, edited or replaced, stays finished until AUTO is entered again
                self._key = key
            elif (edited or uploaded) and self._legs:
                # one under way goes on, or restarts the item under way (:meth:`_take_edit`)
                self._key = key
                self._take_edit(t_s)
            else:
                self._start_mission(t_s)
        ap = self._autopilot
        assert ap is not None
        if ap.settings.cruise_speed_mps != ep.speed_mps:
            # a speed set on the way (a mission's or a ground station's DO_CHANGE_SPEED, RTL's
            # start, WP_SPEED): the latest wins, as Rover's one speed limit for its waypoints
            ap.settings = dataclasses.replace(ap.settings, cruise_speed_mps=ep.speed_mps)
        ap.set_acceptance_radius(ep.param("WP_RADIUS"))  # set on the way: as Rover, at once
        if self._holding is not None and not ap.waiting(t_s) and not frozen:
            self._finish(self._holding[0], t_s)  # its wait is over: the next item begins before it is reached
        yaw = self._yaw
        stepped = False
        # a circle or a heading leg under way steers itself; one done lets the next leg begin,
        # which may be another (bounded: each is a leg)
        for _ in range(len(self._legs) + 1):
            if ep.mission_complete:
                break
            if self._turn is not None and self._turn.leg == self._leg:
                cmd = self._heading_leg(t_s, me.yaw_rad)
            elif self._circle is not None and self._circle[0] == self._leg:
                cmd = self._round(t_s, yaw)
            else:
                break
            stepped = True
            if cmd is not None:
                return cmd
        else:
            return 0.0, 0.0  # (legs of no turns, or turns done at once, went on past the bound)
        if stepped and ep.mission_complete:
            return 0.0, 0.0  # the mission ended
        out = ap.step(t_s, me.north_m, me.east_m, yaw, self.step_s)
        self._distance = out.los.distance_to_go_m
        for k in () if frozen else out.los.reached:
            self._arrive(k, t_s)
        if not ep.mission_complete and not frozen:
            self._run_items(t_s)
        # after the items reached moved the current one
        ep.steering(_nav_report(out.los, ep.reversed, ap.follower.waypoints))
        return (-out.speed_mps if ep.reversed else out.speed_mps), out.yaw_rate_radps

    def _take_edit(self, t_s: float) -> None:
        """The mission flown was edited in place (a partial update) or written over by a new
        one, as Rover takes it: the items still to come are read as they come (AP_Mission
        reads each from storage, the DO commands waiting their turn too), and the item under
        way goes on as it began (``replace_cmd`` does not restart it), unless the change
        touched one of the navigation items AP_Mission_ChangeDetector watches
        (:func:`~lfctl.link.mission.watched_items`) while the vehicle drives a waypoint:
        ModeAuto::update then restarts the item under way (``restart_current_nav_cmd``),
        which starts the item of that number again from where the vehicle is with its new
        content, drops the DO command or condition that was running, keeps the DO_JUMP
        counts (by item number), and then says so. A mission too short to have that number
        fails the restart, and the item under way goes on; one with no navigation item from
        that number on fails it too, once the mission has completed."""
        ep, k = self.endpoint, self._leg
        now = self._legs[k]
        self._built = ep.mission
        watched, self._watched = self._watched, watched_items(ep.mission, now.seq, now.jumps)
        if watched != self._watched and now.command in WP_SUBMODE:
            if now.seq < len(ep.mission):
                self._start_mission(t_s)
                if self._legs:
                    ep.statustext("Auto mission changed, restarted command", mav.MAV_SEVERITY_CRITICAL)
                    return
            ep.statustext("Auto mission changed but failed to restart command", mav.MAV_SEVERITY_CRITICAL)
            if not self._legs:
                return  # (the mission completed)
        # the legs after the one under way, as the mission now has them (the item under way
        # may no longer be a navigation item: AP_Mission goes on from the item after it)
        ap = self._autopilot
        assert ap is not None
        legs, tail = walk_mission(ep.mission, self.home, now.seq + 1, self._pos, ep.rtl_destination, now.jumps)
        self._legs[k + 1 :], self._tail = legs, tail
        ap.replace_after(
            k,
            [(g.north_m, g.east_m, g.hold_s) for g in legs],
            [j for j, g in enumerate(legs, start=k + 1) if g.command == NAV_LOITER_TIME],
        )
        # the DO commands still waiting their turn, as they are now (get_next_do_cmd reads
        # each from storage; one that is no longer a DO command ends them, as its search does)
        waiting = []
        for it in self._queue:
            now_it = ep.mission[it.seq] if it.seq < len(ep.mission) else None
            if now_it is None or is_nav_command(now_it.command) or now_it.command in (DO_JUMP, DO_JUMP_TAG):
                break
            waiting.append(now_it)
        self._queue = waiting

    def _start_mission(self, t_s: float) -> None:
        """(Re)start the mission from its current item, from where the vehicle is: a new or
        changed mission, a new current item, AUTO entered again (Rover restarts the item
        under way, its wait and the DO commands with it), or an edit of the items ahead."""
        ep = self.endpoint
        # the item to start from, as AP_Mission::resume: the one under way, re-read from the
        # mission as it is now; one past its end (a shorter mission uploaded since) starts
        # the mission from item 1 (start(), its jump counts afresh)
        start = max(1, ep.current_seq)
        fresh = start >= len(ep.mission)
        if fresh:
            start = 1
        # not finished: DO_JUMP's counts go on, kept by item number over edits and uploads
        # (AP_Mission resets them only for a finished mission, a restart from item 0, or
        # DO_SET_MISSION_CURRENT's reset, param2 1: each bumps the endpoint's mission_restarts)
        same = bool(self._legs) and not fresh and not self._completed and self._restarts == ep.mission_restarts
        self._restarts = ep.mission_restarts
        # AUTO entered again with a condition holding the DO commands back: AP_Mission::resume
        # restarts from the condition's item number (set_current_cmd(_do_cmd.index)), as the
        # mission has it now: the condition, the DO commands after it, then the navigation
        # item (an item set current meanwhile is started from instead)
        if same and self._paused and self._condition is not None and ep.current_seq == self._legs[self._leg].seq:
            start = self._condition[0]
        self._paused = ()
        jumps = self._legs[self._leg].jumps if same else ()
        self._key = (ep.mission_version, ep.mission_edits)
        self._built, self._completed = ep.mission, False
        self._legs, self._tail = walk_mission(ep.mission, self.home, start, self._pos, ep.rtl_destination, jumps)
        settings = dataclasses.replace(
            autopilot_settings(self.cfg), cruise_speed_mps=ep.speed_mps, acceptance_radius_m=ep.param("WP_RADIUS")
        )
        self._autopilot = LeaderAutopilot(
            [(g.north_m, g.east_m, g.hold_s) for g in self._legs],
            settings,
            self._pos,
            one_per_step=True,
            # Rover's do_nav_wp stops on a loiter's point however short the loiter
            stop_at=[k for k, g in enumerate(self._legs) if g.command == NAV_LOITER_TIME],
        )
        self._holding, self._queue, self._condition, self._circle = None, [], None, None
        self._turn, self._nav_started = None, -1  # (Rover's _enter: the Stop submode)
        if self._legs:
            ep.missions.current_seq = self._legs[0].seq  # MISSION_CURRENT: the navigation item
            self._begin(0, t_s)
        elif not ep.mission_complete:
            self._end_mission(t_s)

    def _begin(self, k: int, t_s: float) -> None:
        """Leg ``k`` begins, as AP_Mission advances to a navigation item: the first item
        before it starts first, then the navigation item (its place taken now, RTL's speed,
        a NAV_DELAY's wait), then the rest of the items before it in turn."""
        ep, leg = self.endpoint, self._legs[k]
        ap = self._autopilot
        assert ap is not None
        self._leg, self._queue, self._condition = k, list(leg.before), None
        self._watched = watched_items(ep.mission, leg.seq, leg.jumps)
        # as AP_Mission says each counted jump as it passes it: the ones before the first
        # item met, then the search's items, then the rest
        self._say_jumps(leg.jumped[: leg.jumps_first])
        checks: list[Callable[[], None]] = []
        self._search(t_s, checks=checks)
        self._say_jumps(leg.jumped[leg.jumps_first :])
        item = ep.mission[leg.seq]
        ep.statustext(mission_text(item), mav.MAV_SEVERITY_INFO)
        if leg.command == NAV_RETURN_TO_LAUNCH:  # home or a rally point as they are now
            self._place(k, ep.rtl_destination(*self._pos))
            # Rover's RTL start: the item enters ModeRTL (its speed; Mode::enter drives forwards)
            ep.set_speed(ep.param("RTL_SPEED") or ep.param("WP_SPEED"))
            ep.reversed = False
        elif leg.command in (NAV_DELAY, NAV_SET_YAW_SPEED, NAV_GUIDED_ENABLE) or (item.x, item.y) == (0, 0):
            # here: where the vehicle is as the item begins, with nothing to drive (the leg
            # starts there too): it is reached at once and stops there, as Rover's start_stop,
            # not driven back to once the vehicle has coasted past it
            self._place(k, self._pos)
            if ap.follower.index == k:
                ap.follower.prev = self._pos
        if leg.command == NAV_LOITER_TURNS:
            self._start_circle(k, item)
        if leg.command == NAV_DELAY:
            wait = leg.hold_s
            if item.param1 <= 0:  # until a time of day, from now (reached a step later at the soonest)
                now = ep.epoch_us / 1e6 + t_s
                wait = seconds_until_utc(now, int(item.param2), int(item.param3), int(item.param4))
                ap.holds[k] = wait
            ep.statustext(f"Delaying {int(wait)} sec", mav.MAV_SEVERITY_INFO)
        if leg.command == NAV_SET_YAW_SPEED:
            self._start_turn(k, item)
        elif leg.command == NAV_GUIDED_ENABLE:  # param1 0: nothing to hand over, done at once
            self._turn = _Turn(k, None, 0.0, True, ep.desired_speed_mps)
        self._nav_started = k
        # AP_Mission checks the DO command its search started only once the navigation
        # item has started (update() verifies _do_cmd after advance_current_nav_cmd)
        for check in checks:
            check()
        self._distance = math.dist(self._pos, ap.follower.waypoints[k])
        self._run_items(t_s)

    def _start_turn(self, k: int, item: MissionItem) -> None:
        """Leg ``k`` is a NAV_SET_YAW_SPEED: its heading and speed as Rover's
        ``do_nav_set_yaw_speed`` sets them. The heading is param1's degrees (param3 1, as
        AP_Mission keeps it in a byte: from the vehicle's heading now, wrapped to +-180°;
        else as given, not wrapped), in centidegrees; the speed param2's, limited to
        ``WP_SPEED`` either way (negative: backwards)."""
        ep = self.endpoint
        heading_cd = item.param1 * 100.0
        if int_as(item.param3, 0, 255) > 0:
            heading_cd = _wrap_180_cd(_yaw_sensor_cd(self._body_yaw) + heading_cd)
        limit = ep.param("WP_SPEED")
        self._turn = _Turn(k, heading_cd, max(-limit, min(limit, item.param2)), False, ep.desired_speed_mps)

    def _heading_leg(self, t_s: float, body_yaw: float) -> tuple[float, float] | None:
        """A step of the heading leg under way: its command; None once the mission has
        found it done (the item is then done, and the next leg has begun from where the
        vehicle is). As Rover's HeadingAndSpeed submode: the body is turned to the heading at
        the leg's speed until it is within 5° of it (compared unwrapped, as Rover compares
        ``_desired_yaw_cd`` with ``yaw_sensor``, 0-360°: a heading given below 0° or above
        360° is never reached), then the vehicle stops; the mission checks that at its next
        update."""
        ep, ap, turn = self.endpoint, self._autopilot, self._turn
        assert turn is not None and ap is not None
        if turn.reached and ep.mission:  # (never checked while the mission has no items)
            ap.follower.index, ap.follower.prev = turn.leg + 1, self._pos  # the next leg from here
            self._finish(turn.leg, t_s)
            if self._turn is turn:
                self._turn = None
            return None
        if turn.heading_cd is not None and ep.desired_speed_mps != turn.kept:
            # a ground station's DO_CHANGE_SPEED in the heading leg: Rover's ModeAuto gives it
            # to the leg alone, the waypoints' speed stays as it was
            turn.speed_mps = ep.speed_mps
            ep.desired_speed_mps = turn.kept
        self._distance = 0.0  # Rover's get_distance_to_destination in this submode
        self._run_items(t_s)
        if turn.heading_cd is None or turn.reached:
            return 0.0, 0.0
        target = math.radians(turn.heading_cd / 100.0)
        rate = self._heading.step(wrap_pi(target - body_yaw), self.step_s)
        turn.reached = abs(turn.heading_cd - _yaw_sensor_cd(body_yaw)) < 500
        return turn.speed_mps, rate

    def _start_circle(self, k: int, item: MissionItem) -> None:
        """Leg ``k`` is a NAV_LOITER_TURNS: set up its circle as Rover's ``do_circle`` and
        ``ModeCircle::set_center`` do. The radius is param3's as AP_Mission keeps it (its sign
        the direction, negative counter-clockwise), at least 0.1 m and raised to
        ``TURN_RADIUS``; the turns param1's as AP_Mission keeps them (whole up to 255, or in
        256ths below one); the speed ``CIRC_SPEED``, else ``WP_SPEED`` (not a DO_CHANGE_SPEED
        from before the circle: one during it is the circle's alone), limited to what the turn
        allows. Rover's warnings are said."""
        ep, leg = self.endpoint, self._legs[k]
        radius = max(circle_radius_m(item.param3), RADIUS_MIN_M)
        turn_radius = ep.param("TURN_RADIUS")
        if radius < turn_radius:
            radius = turn_radius
            ep.statustext(f"Circle: radius increased to TURN_RADIUS ({turn_radius:4.1f})", mav.MAV_SEVERITY_WARNING)
        settings = autopilot_settings(self.cfg)
        speed = ep.param("CIRC_SPEED") or ep.param("WP_SPEED")
        circle = CircleGuidance(
            (leg.north_m, leg.east_m),
            radius,
            math.copysign(1.0, item.param3) < 0,  # (a kept -0 too: counter-clockwise, its radius under 1 m)
            max(0.0, item.param1),  # as kept (as_stored): whole turns, or 256ths below one
            speed,
            max(turn_radius, 0.2 if radius >= 0.5 else 0.1),  # Rover's reached_edge distance
            settings.lookahead_m or 0.8,
            settings.heading,
            self._pos,
            self._yaw,
        )
        if speed > circle.speed_limit_mps():
            ep.statustext(f"Circle: max speed is {circle.speed_mps:4.1f}", mav.MAV_SEVERITY_WARNING)
        self._circle = (k, circle, ep.desired_speed_mps)

    def _round(self, t_s: float, yaw: float) -> tuple[float, float] | None:
        """A step of the circle under way: its command; None once its turns are done (the
        item is then done, and the next leg has begun from where the vehicle is)."""
        ep, ap = self.endpoint, self._autopilot
        assert self._circle is not None and ap is not None
        k, circle, kept = self._circle
        if ep.desired_speed_mps != kept:
            # a ground station's DO_CHANGE_SPEED while it circles: Rover's ModeAuto gives it to
            # the circle alone, the waypoints' speed stays as it was
            self._circle_speed(circle, ep.speed_mps)
            ep.desired_speed_mps = kept
        if circle.done and ep.mission:  # (never done while the mission has no items)
            ap.follower.index, ap.follower.prev = k + 1, self._pos  # the next leg from here
            # the circle is still Rover's submode while the first DO command ahead starts
            self._finish(k, t_s)
            if self._circle is not None and self._circle[0] == k:
                self._circle = None
            return None
        out = circle.step(*self._pos, yaw, self.step_s)
        self._distance = out.distance_m
        self._run_items(t_s)
        heading = out.heading_cmd_rad + math.pi if ep.reversed else out.heading_cmd_rad
        to_target = math.atan2(out.target_ned_m[1] - self._pos[1], out.target_ned_m[0] - self._pos[0])
        ep.steering(NavReport(heading, to_target, out.distance_m, out.cross_track_m, out.target_ned_m))
        return (-out.speed_mps if ep.reversed else out.speed_mps), out.yaw_rate_radps

    def _circle_speed(self, circle: CircleGuidance, speed_mps: float) -> None:
        """A new speed round the circle; one it cannot keep is cut to its limit and said, as
        Rover's ModeCircle::set_desired_speed (check_config_speed)."""
        if circle.set_speed(speed_mps):
            self.endpoint.statustext(f"Circle: max speed is {circle.speed_mps:4.1f}", mav.MAV_SEVERITY_WARNING)

    def _say_jumps(self, jumps: tuple[tuple[int, int, int], ...]) -> None:
        for jump, taken, repeats in jumps:
            self.endpoint.statustext(f"Mission: {jump} Jump {taken}/{repeats}", mav.MAV_SEVERITY_INFO)

    def _search(self, t_s: float, verified: bool = True, checks: list[Callable[[], None]] | None = None) -> None:
        """What AP_Mission's search for the next navigation item does with the items before
        it: each navigation item it cannot start is tried (and said), and the first DO
        command or condition it meets is started; the others wait their turn. ``verified``:
        the items started are checked afterwards (MISSION_ITEM_REACHED when done); not after
        the last navigation item, where the mission completes first. ``checks``: where the
        checks go, to be run once the navigation item has started."""
        started, rest = False, []
        for it in self._queue:
            if it.command in SKIPPED_NAV or not started:
                started = started or it.command not in SKIPPED_NAV
                self._start_item(it, t_s, verified, checks)
            else:
                rest.append(it)
        self._queue = rest

    def _place(self, k: int, where: tuple[float, float]) -> None:
        """Leg ``k`` ends at ``where`` after all (a place known only as it begins)."""
        assert self._autopilot is not None
        self._autopilot.follower.waypoints[k] = (float(where[0]), float(where[1]))
        self._legs[k] = dataclasses.replace(self._legs[k], north_m=where[0], east_m=where[1])

    def _arrive(self, k: int, t_s: float) -> None:
        """The vehicle got to leg ``k``'s end: Rover's words for it, the summary's count, and
        the item done unless it waits there."""
        ep, leg = self.endpoint, self._legs[k]
        ap = self._autopilot
        assert ap is not None
        if leg.command == NAV_RETURN_TO_LAUNCH:
            ep.statustext("Reached destination", mav.MAV_SEVERITY_INFO)
        elif leg.command != NAV_DELAY:
            said = leg.hold_s
            if leg.command == NAV_LOITER_UNLIM and leg.seq < len(ep.mission):
                # AP_Mission keeps a loiter for ever's radius in the p1 do_nav_wp reads as its
                # wait (signed 16 bits): Rover says it, though the loiter never ends
                said = abs(ep.mission[leg.seq].param3)
            wait = f". Loiter for {int(said)} seconds" if 0 < int(said) < 32768 else ""
            ep.statustext(f"Reached waypoint #{leg.seq}{wait}", mav.MAV_SEVERITY_INFO)
        waits = ap.holds[k] > 0
        if leg.command in PLACES:
            self.reached.append((leg.seq - 1, t_s))
            self.reached_of = nav_count(ep.mission)
            number = ep.missions.mission_number
            if self._reached_in[0] != number:
                self._reached_in = (number, set())
            self._reached_in[1].add(leg.seq - 1)
            if self.on_reached is not None:
                # the item current once this one is done: itself while it waits, else the next
                after = leg.seq if waits or k + 1 >= len(self._legs) else self._legs[k + 1].seq
                self.on_reached(t_s, leg.seq - 1, after, len(ep.mission) - 1, self.reached_of, number)
        if ap.holds[k] == math.inf:
            return  # a loiter for ever: the mission waits here until it is moved on
        if waits:
            self._holding = (k, t_s)
        else:
            self._finish(k, t_s)

    def _finish(self, k: int, t_s: float) -> None:
        """Leg ``k``'s item is done (arrived, and waited as long as it says): the ground
        station is told, and the next leg begins, or the mission ends; what is left of this
        leg's items (behind a condition not yet met) is dropped, as Rover's mission drops it."""
        ep, leg = self.endpoint, self._legs[k]
        self._holding, self._queue, self._condition = None, [], None
        if leg.command == NAV_LOITER_TIME:
            ep.statustext("Finished active loiter", mav.MAV_SEVERITY_WARNING)
        last = k == len(self._legs) - 1
        ep.reached(leg.seq, last=False, next_seq=leg.seq if last else self._legs[k + 1].seq)
        if last:
            self._end_mission(t_s)
        else:
            self._begin(k + 1, t_s)

    def _end_mission(self, t_s: float) -> None:
        """No navigation item is left: the first item after the last one starts (a payload's
        servo, say), then the mission is complete (AP_Mission's advance finds no more), so
        that item is never checked and no MISSION_ITEM_REACHED says it was done."""
        self._queue = list(self._tail)
        self._search(t_s, verified=False)
        self._queue, self._condition = [], None
        self._completed = True
        self.endpoint.complete_mission()

    def _run_items(self, t_s: float) -> None:
        """Run the current leg's DO commands and conditions in turn, as ArduPilot's mission
        library runs them beside the navigation: a condition holds back the ones after it
        (not the driving) until its time has passed or the vehicle is that near its target."""
        while self._queue or self._condition is not None:
            if self._condition is not None:
                seq, kind, value = self._condition
                if (kind == "time" and t_s < value) or (kind == "distance" and self._distance >= value):
                    return
                self._condition = None
                self.endpoint.item_done(seq)
                continue
            self._start_item(self._queue.pop(0), t_s)

    def _start_item(
        self, it: MissionItem, t_s: float, verified: bool = True, checks: list[Callable[[], None]] | None = None
    ) -> None:
        """Start one DO command or condition of the mission (or try a navigation item a
        Rover skips), saying so as ArduPilot's mission library does; ``verified``: check it
        (Rover's verify_command: MISSION_ITEM_REACHED when done, "Skipping invalid cmd #N"
        for one Rover has no case for); ``checks``: leave that check there, to run later
        (the first DO command of a leg is checked once its navigation item has started)."""
        ep, cmd = self.endpoint, it.command
        ep.statustext(mission_text(it), mav.MAV_SEVERITY_INFO)
        if cmd in SKIPPED_NAV:
            return
        check: Callable[[], None] | None = None
        if cmd == CONDITION_DELAY:
            self._condition = (it.seq, "time", t_s + condition_delay_s(it.param1))
        elif cmd == CONDITION_DISTANCE:
            self._condition = (it.seq, "distance", float(int(max(0.0, it.param1))))  # whole metres
        elif cmd == DO_CHANGE_SPEED:
            self._change_speed(it.param2)
            check = functools.partial(ep.item_done, it.seq)
        elif cmd in ACTED_ON:
            ep.run_mission_item(it, verified=False)
            check = functools.partial(ep.item_done, it.seq)
        elif cmd in NOTHING_FITTED:
            ep.statustext(f"Mission {it.seq}: {command_name(cmd)} not fitted", mav.MAV_SEVERITY_INFO)
            if cmd in NOTHING_FITTED_REACHED:
                check = functools.partial(ep.item_done, it.seq)
        elif cmd == JUMP_TAG:
            pass  # a place the tag names: the mission library says it and moves on
        else:  # a DO command a Rover does not carry out
            check = functools.partial(_skip, ep, it.seq, cmd if cmd in SKIPPED_SAID else None)
        if check is None or not verified:
            return
        if checks is not None:
            checks.append(check)
        else:
            check()

    def _change_speed(self, speed_mps: float) -> None:
        """A mission's DO_CHANGE_SPEED, as Rover's ``do_change_speed`` and
        ``ModeAuto::set_desired_speed``: for the submode running as it starts, which is the
        one before while it is the first DO command ahead of a navigation item (a circle or
        a heading leg just done keeps it, and the waypoints' speed stays as it was)."""
        ep, circle, turn = self.endpoint, self._circle, self._turn
        if circle is not None and circle[0] == self._nav_started:
            if speed_mps > 0:  # Rover's ModeCircle::set_desired_speed: the circle's alone
                self._circle_speed(circle[1], speed_mps)
                ep.statustext(f"speed: {speed_mps:.1f} m/s", mav.MAV_SEVERITY_INFO)
        elif turn is not None and turn.leg == self._nav_started and turn.heading_cd is not None:
            turn.speed_mps = speed_mps  # HeadingAndSpeed takes any speed, the leg's alone
            ep.statustext(f"speed: {speed_mps:.1f} m/s", mav.MAV_SEVERITY_INFO)
        elif speed_mps >= WP_SPEED_MIN_MPS:  # set_speed_max takes no slower (-1: none)
            ep.set_speed(speed_mps)
            ep.statustext(f"speed: {speed_mps:.1f} m/s", mav.MAV_SEVERITY_INFO)  # Rover's do_change_speed

    @property
    def distinct_reached(self) -> int:
        """Distinct waypoints reached of the mission last reached in (a mission flown twice
        counts each once; an earlier, replaced mission's not at all)."""
        return len(self._reached_in[1])

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
            # Rover's ModeGuided (HeadingAndSpeed) turns the body to the heading and drives as
            # asked: DO_SET_REVERSE, AR_WPNav's flag, does not reach it
            rate = self._heading.step(wrap_pi(g.heading_rad - me.yaw_rad), self.step_s)
            return g.speed_mps, rate
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
        smart = ep.mode == MODES["SMART_RTL"]
        key: tuple[object, ...] = ("srtl" if smart else "rtl", ep.modes[-1][0], ep.path_generation if smart else 0)
        if key != self._goto_key:  # the mode just entered: its way is chosen once, as it starts
            # SmartRTL: the way back as recorded (what is left of it); RTL: home or the rally
            # point best now (Rover's ModeRTL::_enter), kept if home or the points move
            self._return_route = list(reversed(ep.path)) if smart else [ep.rtl_destination(me.north_m, me.east_m)]
        done, cmd = self._drive_to(self._return_route, key, speed, t_s, world)
        if smart and self._goto is not None:  # each point is used up as it sets out for it (AP_SmartRTL::pop_point)
            del ep.path[max(0, len(self._goto.follower.waypoints) - self._goto.follower.index - 1) :]
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
        self._goto.set_acceptance_radius(ep.param("WP_RADIUS"))
        yaw = me.yaw_rad + math.pi if ep.reversed else me.yaw_rad
        out = self._goto.step(t_s, me.north_m, me.east_m, yaw, self.step_s)
        ep.steering(_nav_report(out.los, ep.reversed, self._goto.follower.waypoints))
        arrived = self._goto.done and not self._goto_done
        self._goto_done = self._goto.done
        return arrived, ((-out.speed_mps if ep.reversed else out.speed_mps), out.yaw_rate_radps)


def condition_delay_s(seconds: float) -> float:
    """How long a CONDITION_DELAY of ``seconds`` holds the items after it, s, with Rover's
    arithmetic (``do_wait_delay``, ``verify_wait_delay``): whole milliseconds in a signed
    32-bit integer (held at its ends, as an ARM flight controller converts it), compared
    unsigned, so a negative delay waits about 49.7 days, not none.

    Parameters
    ----------
    seconds : float
        The item's param1 (finite), s.
    """
    ms = min(2**31 - 1, max(-(2**31), math.trunc(seconds * 1000.0)))
    return (ms % 2**32) / 1000.0


def _skip(ep: VehicleEndpoint, seq: int, command: int | None) -> None:
    """A DO command a Rover does not carry out, checked: Rover's verify_command says it
    skips ``command`` (its ``default:``; None for DO_GUIDED_LIMITS, which it checks), and it
    is done."""
    if command is not None:
        ep.statustext(f"Skipping invalid cmd #{command}", mav.MAV_SEVERITY_WARNING)
    ep.item_done(seq)


def _yaw_sensor_cd(yaw_rad: float) -> int:
    """A heading as Rover's AHRS ``yaw_sensor`` keeps it: whole centidegrees, 0 to 36000."""
    cd = int(math.degrees(wrap_pi(yaw_rad)) * 100.0)
    return cd + 36000 if cd < 0 else cd


def _wrap_180_cd(cd: float) -> float:
    """ArduPilot's ``wrap_180_cd``: centidegrees to (-18000, 18000]."""
    res = math.fmod(cd, 36000.0)
    if res < 0:
        res += 36000.0
    return res - 36000.0 if res > 18000.0 else res


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
