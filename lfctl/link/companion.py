"""`lfctl follow`: the follower stack on a real rover. A camera (or video) gives the leader's
range and bearing through the tracker and marker pose; the rover's own LOCAL_POSITION_NED and
ATTITUDE give odometry; the formation controller's speed and yaw rate go to the rover as
GUIDED setpoints (SET_POSITION_TARGET_LOCAL_NED, BODY_NED, type_mask 1479) from component 191,
with the formation status (NAMED_VALUE_FLOAT) and STATUSTEXT on track lost/reacquired."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.errors import LinkTimeoutError
from lfctl.link.endpoint import COMPANION_COMPID, MODES, TYPE_MASK_SPEED_YAWRATE
from lfctl.link.gcs import open_connection

log = logging.getLogger(__name__)


@dataclass
class RoverOdometry:
    """What the rover reports about itself (local NED, heading, speed)."""

    t_s: float = 0.0
    north_m: float = 0.0
    east_m: float = 0.0
    yaw_rad: float = 0.0
    speed_mps: float = 0.0
    mode: int = -1
    armed: bool = False
    heard: bool = False


class RoverLink:
    """A MAVLink connection to the rover as its companion computer (component 191)."""

    def __init__(
        self, connect: str, target_system: int = 1, timeout_s: float = 10.0, signing_key: bytes | None = None
    ) -> None:
        self.conn = open_connection(connect, target_system, COMPANION_COMPID, signing_key)
        self.target = target_system
        self.timeout_s = timeout_s
        self.odom = RoverOdometry()
        self._t0 = time.monotonic()

    def start(self) -> None:
        """Say hello and wait for the rover's heartbeat; ask for position and attitude at 20 Hz."""
        deadline = time.monotonic() + self.timeout_s
        while time.monotonic() < deadline:
            self.conn.mav.heartbeat_send(
                mav.MAV_TYPE_ONBOARD_CONTROLLER, mav.MAV_AUTOPILOT_INVALID, 0, 0, mav.MAV_STATE_ACTIVE
            )
            self.poll(0.2)
            if self.odom.heard:
                for msg_id in (mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED, mav.MAVLINK_MSG_ID_ATTITUDE):
                    self.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 50_000)
                return
        raise LinkTimeoutError(f"no HEARTBEAT from rover system {self.target} within {self.timeout_s:g} s")

    def command(self, cmd: int, *p: float) -> None:
        params = [*p, *([0.0] * (7 - len(p)))]
        self.conn.mav.command_long_send(self.target, 1, cmd, 0, *params)

    def set_guided(self) -> None:
        self.command(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES["GUIDED"])

    def arm(self) -> None:
        self.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)

    def poll(self, timeout_s: float = 0.0) -> None:
        """Read everything waiting (up to ``timeout_s`` for the first message)."""
        m = self.conn.recv_match(blocking=timeout_s > 0, timeout=timeout_s)
        while m is not None:
            if m.get_srcSystem() == self.target and m.get_srcComponent() == 1:
                kind = m.get_type()
                o = self.odom
                if kind == "HEARTBEAT":
                    o.heard, o.mode, o.armed = True, m.custom_mode, bool(m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
                elif kind == "LOCAL_POSITION_NED":
                    o.north_m, o.east_m, o.speed_mps = m.x, m.y, math.hypot(m.vx, m.vy)
                    o.t_s = time.monotonic() - self._t0
                elif kind == "ATTITUDE":
                    o.yaw_rad = m.yaw
            m = self.conn.recv_match(blocking=False)

    def setpoint(self, speed_mps: float, yaw_rate_radps: float) -> None:
        t_ms = int((time.monotonic() - self._t0) * 1000) & 0xFFFFFFFF
        self.conn.mav.set_position_target_local_ned_send(
            t_ms,
            self.target,
            1,
            mav.MAV_FRAME_BODY_NED,
            TYPE_MASK_SPEED_YAWRATE,
            0,
            0,
            0,
            speed_mps,
            0,
            0,
            0,
            0,
            0,
            0,
            yaw_rate_radps,
        )

    def report(self, range_err_m: float, bearing_err_deg: float, quality: float) -> None:
        t_ms = int((time.monotonic() - self._t0) * 1000) & 0xFFFFFFFF
        for name, value in ((b"rng_err", range_err_m), (b"brg_err", bearing_err_deg), (b"trk_q", quality)):
            self.conn.mav.named_value_float_send(t_ms, name, float(value))

    def statustext(self, text: str) -> None:
        self.conn.mav.statustext_send(mav.MAV_SEVERITY_WARNING, text.encode()[:50])

    def close(self) -> None:
        self.conn.close()


def follow_loop(
    rover: RoverLink,
    next_measurement: Callable[[float], Any],
    controller: Any,
    period_s: float = 0.05,
    max_steps: int | None = None,
) -> int:
    """Run: measurement -> controller -> setpoint, every ``period_s``; stop (zero) at the end."""
    from lfctl.guidance.formation import Odometry
    from lfctl.vision.track_state import TrackStatus

    steps, last = 0, None
    try:
        while max_steps is None or steps < max_steps:
            t_s = time.monotonic() - rover._t0
            rover.poll()
            meas = next_measurement(t_s)
            if meas is None:
                break
            o = rover.odom
            out = controller.step(meas, Odometry(t_s, o.north_m, o.east_m, o.yaw_rad, o.speed_mps))
            rover.setpoint(out.speed_mps, out.yaw_rate_radps)
            if steps % 10 == 0:
                st = controller.settings
                rover.report(
                    out.range_est_m - st.range_cmd_m if math.isfinite(out.range_est_m) else math.nan,
                    math.degrees(out.bearing_est_rad - st.bearing_cmd_rad)
                    if math.isfinite(out.bearing_est_rad)
                    else math.nan,
                    1.0 if out.status is TrackStatus.TRACKING else 0.0,
                )
            if last is not None and out.status is not last and TrackStatus.LOST in (out.status, last):
                rover.statustext("Leader lost, stopping" if out.status is TrackStatus.LOST else "Leader reacquired")
            last = out.status
            steps += 1
            time.sleep(max(0.0, period_s - ((time.monotonic() - rover._t0) - t_s)))
    finally:
        for _ in range(3):
            rover.setpoint(0.0, 0.0)  # leave the rover stopped
    return steps
