"""The run's MAVLink side: one endpoint per vehicle, the leader's mission set-up, and each
follower's companion. Lockstep runs talk in memory through the real codec and handlers;
``--realtime`` adds a UDP port per vehicle for QGroundControl, MAVProxy, MAVSDK or
`lfctl gcs`. Owns its sockets; close() releases them."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.config import Config
from lfctl.link.endpoint import (
    COMPANION_COMPID,
    MODES,
    TYPE_MASK_SPEED_YAWRATE,
    VehicleEndpoint,
    pack_next,
    signing_key_from_passphrase,
)
from lfctl.link.gcs import GroundStation
from lfctl.link.mission import local_mission
from lfctl.link.transport import Fanout, MemoryLink, UdpLink
from lfctl.sim.world import WorldState


class Companion:
    """The follower's vision + guidance as MAVLink component 191 of the follower's system."""

    def __init__(self, link: MemoryLink, sysid: int) -> None:
        self.link = link
        self.sysid = sysid
        self.mav = mav.MAVLink(None, srcSystem=sysid, srcComponent=COMPANION_COMPID)

    def _send(self, msg: Any) -> None:
        self.link.send(pack_next(msg, self.mav))
        self.link.recv()  # the vehicle's replies to us (acks): read and dropped

    def start(self) -> None:
        """GUIDED and armed, as a companion computer does at start-up."""
        self._send(
            mav.MAVLink_command_long_message(
                self.sysid,
                1,
                mav.MAV_CMD_DO_SET_MODE,
                0,
                mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                MODES["GUIDED"],
                0,
                0,
                0,
                0,
                0,
            )
        )
        self._send(
            mav.MAVLink_command_long_message(self.sysid, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
        )

    def setpoint(self, t_s: float, speed_mps: float, yaw_rate_radps: float) -> None:
        self._send(
            mav.MAVLink_set_position_target_local_ned_message(
                int(t_s * 1000) & 0xFFFFFFFF, self.sysid, 1, mav.MAV_FRAME_BODY_NED, TYPE_MASK_SPEED_YAWRATE,
                0, 0, 0, speed_mps, 0, 0, 0, 0, 0, 0, yaw_rate_radps,
            )
        )  # fmt: skip

    def report(self, t_s: float, range_err_m: float, bearing_err_deg: float, quality: float) -> None:
        t_ms = int(t_s * 1000) & 0xFFFFFFFF
        for name, value in ((b"rng_err", range_err_m), (b"brg_err", bearing_err_deg), (b"trk_q", quality)):
            self._send(
                mav.MAVLink_named_value_float_message(
                    t_ms, name, float(value) if math.isfinite(value) else float("nan")
                )
            )

    def statustext(self, text: str, severity: int = mav.MAV_SEVERITY_WARNING) -> None:
        self._send(mav.MAVLink_statustext_message(severity, text.encode()[:50]))


class Links:
    """Every vehicle's endpoint and the in-memory peers that drive them."""

    def __init__(self, cfg: Config, realtime: bool, tap: Callable[[str, str, Any, bytes], None] | None = None) -> None:
        lc = cfg.link
        self.home = (lc.home_lat_deg, lc.home_lon_deg, lc.home_alt_m)
        self.endpoints: list[VehicleEndpoint] = []
        self.peers: list[MemoryLink] = []  # the in-memory other ends (GCS for the leader, companion for followers)
        self.udp: list[UdpLink] = []
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
            ep_tap = (lambda d, m, raw, _n=v.name: tap(_n, d, m, raw)) if tap is not None else None
            key = signing_key_from_passphrase(lc.signing_passphrase) if realtime else None
            ep = VehicleEndpoint(v.name, 1 + i, link, self.home, tap=ep_tap, signing_key=key)
            if realtime and gcs_out:
                ep.forward = udp.send
            self.endpoints.append(ep)
            self.peers.append(peer)
        self.companions = [Companion(self.peers[i], 1 + i) for i in range(1, len(cfg.vehicles))]
        leader = self.endpoints[0]
        if cfg.mission.waypoints:
            items = local_mission(list(cfg.mission.waypoints), self.home)
            if realtime:
                leader._accept_mission(items)  # a stored mission, as on a real rover; GCS starts it
            else:
                # lockstep: upload through the mission protocol at t = 0, then AUTO and arm
                # no heartbeats: a one-shot set-up is not a ground station whose loss is a failsafe
                gcs = GroundStation(
                    self.peers[0],
                    target_system=1,
                    timeout_s=2.0,
                    pump=lambda: leader.tick(0.0, leader.state),
                    heartbeats=False,
                )
                gcs.upload(items)
                gcs.set_mode("AUTO")
                gcs.arm(True)
        elif not realtime:
            leader.set_mode(MODES["AUTO"])
            leader.armed = True  # the scripted profile drives it
        leader.params["WP_SPEED"].value = cfg.mission.cruise_speed_mps
        leader.params["WP_RADIUS"].value = cfg.mission.acceptance_radius_m
        slots = cfg.slots()
        for ep, comp, v in zip(self.endpoints[1:], self.companions, cfg.followers, strict=True):
            ep.params["LFC_RANGE"].value = slots[v.name].range_m
            ep.params["LFC_BEARING"].value = math.degrees(slots[v.name].bearing_rad)
            ep.params["LFC_COAST"].value = cfg.guidance.coast_s
            comp.start()

    @property
    def ports(self) -> dict[str, int]:
        return {ep.name: udp.port for ep, udp in zip(self.endpoints, self.udp, strict=False)}

    def tick(self, t_s: float, world: WorldState) -> None:
        for i, ep in enumerate(self.endpoints):
            st = world.vehicle(i)
            ep.tick(
                t_s,
                {
                    "north_m": st.north_m,
                    "east_m": st.east_m,
                    "yaw_rad": st.yaw_rad,
                    "speed_mps": st.speed_mps,
                    "yaw_rate_radps": st.yaw_rate_radps,
                },
            )
            self.peers[i].recv()  # telemetry to the in-memory peer: nobody reads it in a run

    def close(self) -> None:
        for udp in self.udp:
            udp.close()
