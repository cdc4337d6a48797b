"""The run's MAVLink side: one endpoint per vehicle, the leader's mission set-up, and each
follower's companion. Lockstep runs talk in memory through the real codec and handlers;
``--realtime`` adds a UDP port per vehicle for QGroundControl, MAVProxy, MAVSDK or
`lfctl gcs`, and, with live video, a MAVLink camera component per follower that announces
its stream. Owns its sockets; close() releases them."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.checks import read_text_file
from lfctl.config import Config
from lfctl.data import loaded_code
from lfctl.errors import ConfigError
from lfctl.link.camera import CameraComponent, CameraRouter
from lfctl.link.companion import Companion
from lfctl.link.endpoint import COMPANION_COMPID, GCS_COMPID, VehicleEndpoint
from lfctl.link.gcs import GCS_SYSID, GroundStation
from lfctl.link.mission import (
    MAX_FILE_BYTES,
    MissionItem,
    check_site,
    load_mission_file,
    local_mission,
)
from lfctl.link.mission_server import CAPACITY, FENCE, MISSION, MISSION_TYPES, RALLY, list_problem
from lfctl.link.params import formation_params, set_values
from lfctl.link.port import MavPort
from lfctl.link.signing import signing_key_from_passphrase
from lfctl.link.transport import Fanout, MemoryLink, UdpLink
from lfctl.sim.world import WorldState

__all__ = ["Links", "ScenarioMission", "scenario_mission", "search_degps"]

#: wall seconds an endpoint may spend on inbound UDP per tick in --realtime (the rest waits):
#: a flood of junk must not slow the simulation below real time
REALTIME_RECEIVE_BUDGET_S = 0.002


@dataclass(frozen=True)
class ScenarioMission:
    """A scenario's ``mission.file``, read and checked.

    Parameters
    ----------
    path : Path
        The file.
    lists : dict
        Its mission, fence and rally points, by MAV_MISSION_TYPE.
    data : bytes
        The file's bytes as read (attached to the run's log).
    """

    path: Path
    lists: dict[int, list[MissionItem]]
    data: bytes


def search_degps(cfg: Config, follower: str) -> float:
    """The rate a follower looks round at once it has lost its target, deg/s: the scenario's
    ``guidance.search_yaw_rate_degps`` for a follower of the leader that no other vehicle
    follows; 0 for any other. A follower that turns to search turns its banner away from one
    behind it, which then loses it too and, its target out of sight, can take up the banner
    of another vehicle (every vehicle's is the same): a follower that is followed holds
    still, and so keeps its banner towards the one behind.

    Parameters
    ----------
    cfg : Config
        The scenario.
    follower : str
        The follower's name.
    """
    slots = cfg.slots()
    followed = any(slot.target == follower for slot in slots.values())
    if slots[follower].target != cfg.vehicles[0].name or followed:
        return 0.0
    return math.degrees(cfg.guidance.search_yaw_rate_radps)


def scenario_mission(cfg: Config) -> ScenarioMission | None:
    """Read ``mission.file`` (None without one) and check it as the leader's upload would and
    against the scenario's home, so that a bad file stops the run before it starts.

    Parameters
    ----------
    cfg : Config
        The scenario.

    Raises
    ------
    ConfigError
        The file cannot be read or parsed, holds no mission, an item the leader would refuse
        (naming it and the MAV_MISSION result), or a place far from the scenario's home.
    """
    if cfg.mission.file is None:
        return None
    path = Path(cfg.mission.file).expanduser()
    text = read_text_file(path, "mission.file", MAX_FILE_BYTES)
    found = load_mission_file(path, text)
    where = f"mission.file {path}"
    lists = {MISSION: found.mission, FENCE: found.fence, RALLY: found.rally}
    for kind, items in lists.items():
        if (bad := list_problem(items, kind)) is not None:
            seq, result = bad
            name = mav.enums["MAV_MISSION_RESULT"][result].name
            room = (
                f" (room for {CAPACITY[kind]} items, it has {len(items)})" if result == mav.MAV_MISSION_NO_SPACE else ""
            )
            raise ConfigError(f"{where}: the leader would refuse its {MISSION_TYPES[kind]} at item {seq}: {name}{room}")
    if len(found.mission) <= 1:
        raise ConfigError(f'{where}: holds no mission items (a Rover refuses AUTO: "No Mission. Can\'t set AUTO.")')
    lc = cfg.link
    check_site(found, (lc.home_lat_deg, lc.home_lon_deg, lc.home_alt_m), where)
    return ScenarioMission(path, lists, text.encode())


class Links:
    """Every vehicle's endpoint and the in-memory peers that drive them.

    Vehicle i is system i + 1 (the leader 1). In lockstep the leader is put in AUTO and armed
    at once (its mission, if any, uploaded first through the mission protocol); with
    ``realtime`` a mission is only stored, for a ground station to start. Each follower's
    companion asks for GUIDED and arms.

    Parameters
    ----------
    cfg : Config
        The scenario: vehicles, ``[link]``, ``[mission]``, slots.
    realtime : bool
        Also give each vehicle a UDP port (``link.udp_base_port + i``), signed with
        ``link.signing_passphrase`` if one is set.
    tap : callable, optional
        Sees every packet of every endpoint: ``tap(vehicle, direction, msg, raw, to)``, ``to``
        the one network peer it was sent to alone, or None (the recorder).
    video_ports : dict, optional
        Follower -> the UDP port its camera's RTP stream goes to: with ``realtime`` each such
        follower's system gets a camera component (100) on its UDP port that announces it.
    start_ns : int, optional
        The run's start on the epoch clock, ns (the log's): SYSTEM_TIME counts from it.
    """

    def __init__(
        self,
        cfg: Config,
        realtime: bool,
        tap: Callable[[str, str, Any, bytes, Any], None] | None = None,
        video_ports: dict[str, int] | None = None,
        start_ns: int | None = None,
        mission: ScenarioMission | None = None,
    ) -> None:
        lc = cfg.link
        self.home = (lc.home_lat_deg, lc.home_lon_deg, lc.home_alt_m)
        self.endpoints: list[VehicleEndpoint] = []
        self.peers: list[MemoryLink] = []  # the in-memory other ends (GCS for the leader, companion for followers)
        self.udp: list[UdpLink] = []
        self.cameras: list[CameraComponent] = []  # the followers' camera components (live video)
        self.camera_of: dict[str, CameraComponent] = {}  # each streaming follower's, by its name
        gcs_out = []
        if lc.gcs_udpout:
            host, port = lc.gcs_udpout.rsplit(":", 1)
            gcs_out = [(host, int(port))]
        for i, v in enumerate(cfg.vehicles):
            end, peer = MemoryLink.pair(v.name, f"{v.name}-peer")
            link: Any = end
            if realtime:
                udp = UdpLink((lc.udp_host, lc.udp_base_port + i), gcs_out)
                self.udp.append(udp)
                link = Fanout(udp, end)
            ep_tap = (lambda d, m, raw, to=None, _n=v.name: tap(_n, d, m, raw, to)) if tap is not None else None
            key = signing_key_from_passphrase(lc.signing_passphrase) if realtime else None
            # (a follower with no companion streams the camera its outside companion steers by:
            # no camera component offers it to a ground station, whose VIDEO_STOP_STREAMING
            # would blind that companion)
            if realtime and video_ports is not None and v.name in video_ports and v.companion:
                camera = CameraComponent(
                    1 + i,
                    udp.send,
                    video_port=video_ports[v.name],
                    width=cfg.camera.width_px,
                    height=cfg.camera.height_px,
                    fps=cfg.sim.camera_rate_hz,
                    bitrate_kbps=cfg.live.video_bitrate_kbps,
                    hfov_deg=math.degrees(cfg.camera.hfov_rad),
                    name=f"{v.name} camera",
                    signing_key=key,
                    tap=ep_tap,
                    send_to=udp.send_to,
                )
                self.cameras.append(camera)
                self.camera_of[v.name] = camera
                link = CameraRouter(link, [camera], key)
            ep = VehicleEndpoint(
                v.name, 1 + i, link, self.home, tap=ep_tap, signing_key=key, custom_version=_code_hash()
            )
            ep.routed_components = {c.compid for c in self.cameras if c.sysid == 1 + i}
            if start_ns is not None:
                ep.epoch_us = start_ns // 1000  # SYSTEM_TIME on the log's clock
            # where it starts, before the set-up below ticks it: a disarmed vehicle's home is
            # where it stands, and the lockstep leader is armed before its first step
            ep.state = {**ep.state, "north_m": v.north_m, "east_m": v.east_m, "yaw_rad": v.yaw_rad}
            # the scenario's speeds and radii: AUTO's for the leader, the formation's speed
            # limit for followers' GUIDED setpoints (both Rover's WP_SPEED)
            ep.params["WP_SPEED"].value = cfg.mission.cruise_speed_mps if i == 0 else cfg.guidance.max_speed_mps
            # ... which is also its cruise: VFR_HUD's throttle reads CRUISE_THROTTLE (50 %) there
            ep.params["CRUISE_SPEED"].value = ep.params["WP_SPEED"].value
            ep.params["WP_RADIUS"].value = cfg.mission.acceptance_radius_m
            if realtime:
                ep.time_budget_s = REALTIME_RECEIVE_BUDGET_S
                # each peer a channel of its own: its packets counted and its telemetry
                # scheduled apart, what a peer sends another (a ground station's requests to
                # lfctl follow's components, their answers and reports) passed on, and the
                # in-memory companion's reports to every peer
                ep.network = udp
            self.endpoints.append(ep)
            self.peers.append(peer)
        # each follower's companion (component 191 of its system) on the in-memory link; a
        # follower with ``companion = false`` has one that reaches nobody (its stack's
        # perception still runs on the camera, its setpoints go nowhere), and waits in HOLD,
        # disarmed, as a Rover does, for a companion on its UDP port
        self.companions = [
            Companion(
                MavPort.memory(
                    self.peers[i] if v.companion else MemoryLink(f"{v.name}-nobody"), 1 + i, COMPANION_COMPID
                ),
                1 + i,
            )
            for i, v in enumerate(cfg.vehicles)
            if i > 0
        ]
        leader = self.endpoints[0]
        if mission is None and cfg.mission.file is not None:
            mission = scenario_mission(cfg)
        if mission is not None or cfg.mission.waypoints:
            lists = (
                mission.lists
                if mission is not None
                else {MISSION: local_mission(list(cfg.mission.waypoints), self.home), FENCE: [], RALLY: []}
            )
            if realtime:
                for kind, items in lists.items():  # stored, as on a real rover; a GCS starts it
                    if items or kind == MISSION:
                        leader.missions.store(kind, items)
            else:
                # lockstep: upload through the mission protocol at t = 0, then AUTO and arm
                # no heartbeats: a one-shot set-up is not a ground station whose loss is a failsafe
                port = MavPort.memory(self.peers[0], GCS_SYSID, GCS_COMPID, pump=lambda: leader.tick(0.0, leader.state))
                gcs = GroundStation(port, target_system=1, timeout_s=2.0, heartbeats=False)
                for kind, items in lists.items():
                    if items or kind == MISSION:
                        gcs.upload(items, mission_type=kind)
                gcs.set_mode("AUTO")
                gcs.arm(True)
        elif not realtime:
            leader.force_mode("AUTO")  # no mission: the scripted profile drives it
            leader.set_armed(True)
        slots = cfg.slots()
        for ep, comp, v in zip(self.endpoints[1:], self.companions, cfg.followers, strict=True):
            values = {
                "LFC_RANGE": slots[v.name].range_m,
                "LFC_BEARING": math.degrees(slots[v.name].bearing_rad),
                "LFC_COAST": cfg.guidance.coast_s,
                "LFC_SEARCH": search_degps(cfg, v.name),
                "LFC_LOOKAHEAD": cfg.guidance.trail_lookahead_m,
            }
            if v.companion:
                set_values(ep.params, values, f"{v.name}'s slot and guidance")  # a ground station may set them
                comp.set_guided()  # as a companion computer does at start-up
                comp.arm()
            else:  # its companion (lfctl follow) holds its own: a Rover has none of them
                for name in formation_params():
                    del ep.params[name]

    @property
    def ports(self) -> dict[str, int]:
        """Each vehicle's UDP port, by name (empty in lockstep)."""
        return {ep.name: udp.port for ep, udp in zip(self.endpoints, self.udp, strict=False)}

    def tick(self, t_s: float, world: WorldState, speed_cmds_mps: Sequence[float] | None = None) -> None:
        """Advance every endpoint to ``t_s`` with its vehicle's truth (see
        :meth:`~lfctl.link.endpoint.VehicleEndpoint.tick`).

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        world : WorldState
            The truth now; vehicle i feeds endpoint i.
        speed_cmds_mps : sequence of float, optional
            Each vehicle's forward-speed command now, m/s (its throttle in VFR_HUD); None:
            the endpoints report the throttle each vehicle's speed needs.
        """
        # each vehicle's values as Python floats, as world.vehicle(i) gives them, read off
        # the arrays at once (no VehicleState built per endpoint per tick)
        pos, yaw, speed, rate = (
            world.pos_ned_m.tolist(),
            world.yaw_rad.tolist(),
            world.speed_mps.tolist(),
            world.yaw_rate_radps.tolist(),
        )
        for i, ep in enumerate(self.endpoints):
            state = {
                "north_m": pos[i][0],
                "east_m": pos[i][1],
                "yaw_rad": yaw[i],
                "speed_mps": speed[i],
                "yaw_rate_radps": rate[i],
            }
            if speed_cmds_mps is not None:
                state["speed_cmd_mps"] = speed_cmds_mps[i]
            ep.tick(t_s, state)
            self.peers[i].recv()  # telemetry to the in-memory peer: nobody reads it in a run
        for camera in self.cameras:
            camera.tick(t_s)

    def close(self) -> None:
        """Close the UDP sockets."""
        for udp in self.udp:
            udp.close()


def _code_hash() -> str:
    """The first 8 characters of the running lfctl's code digest (``lfctl --version``): what
    its vehicles say where a Rover's AUTOPILOT_VERSION carries its firmware's git hash; empty
    when the digest is unknown."""
    digest = loaded_code()
    return digest[:8] if digest.isalnum() else ""  # (as `lfctl --version` tells it from "unknown (why)")
