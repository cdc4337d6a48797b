"""The follower stack on a real rover (`lfctl follow`): frames from a camera, the rover's
own odometry over MAVLink, setpoints back to it as its companion computer, paced by the
wall clock. The stack (:class:`~lfctl.follower.stack.Follower`) and the perception
(:class:`~lfctl.vision.perception.BannerPerception`) are the ones `lfctl sim` runs."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.follower.stack import Follower, FollowerEvent, formation_param_values
from lfctl.guidance.formation import FormationOutput, FormationSettings, Odometry
from lfctl.link.companion import Companion
from lfctl.link.params import set_values
from lfctl.video import VideoSource
from lfctl.vision.perception import BannerPerception, Perception
from lfctl.vision.track_state import TrackStatus

__all__ = ["RoverRun", "RoverStep", "follow_rover"]

#: setpoints of zero sent when the run ends, so the rover is left standing
STOP_SETPOINTS = 3
#: the rover's LOCAL_POSITION_NED older than this, or three control periods if that is
#: longer, is said to be missing (the stack then steers on the last position it had: the
#: camera still closes the loop)
ODOMETRY_STALE_S = 1.0

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RoverStep:
    """One guidance step on the rover, for whoever shows or logs it (`lfctl follow --live`)."""

    t_s: float  # on the run's clock (default: since the loop started), s
    frame: np.ndarray  # the camera frame, BGR
    seen: Perception  # what perception made of it
    odometry: Odometry  # the rover's own position and heading then
    output: FormationOutput  # the stack's command and estimate
    settings: FormationSettings  # the slot it held
    events: list[FollowerEvent]  # target lost or found in this step
    #: the rover's global position then, (latitude deg, longitude deg, altitude m above mean
    #: sea level), from its GLOBAL_POSITION_INT; None while it has none (no GPS) or sent none
    fix: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class RoverRun:
    """How a run on a rover went."""

    steps: int  # guidance steps run (setpoints sent, not counting the final stops)
    frames: int  # frames read from the camera
    tracking: int = 0  # steps whose frame showed the target (TRACKING)
    occluded: int = 0  # steps coasting on a hidden target (OCCLUDED), or before it was first found
    lost: int = 0  # steps with the target lost (LOST)

    def summary(self) -> str:
        """One line: what was sent, and how often the target was seen."""
        line = f"sent {self.steps} setpoints; {self.frames} frames"
        if self.steps:
            line += f"; target tracking in {self.tracking}, occluded in {self.occluded}, lost in {self.lost} steps"
            if self.tracking == 0:
                line += " (never seen: check the camera, the banner and its markers' hue)"
        return line


def follow_rover(
    companion: Companion,
    video: VideoSource,
    perception: BannerPerception,
    settings: FormationSettings,
    *,
    rate_hz: float,
    status_rate_hz: float,
    arm: bool = False,
    timeout_s: float = 10.0,
    max_frames: int | None = None,
    max_steps: int | None = None,
    name: str = "rover",
    on_step: Callable[[RoverStep], None] | None = None,
    clock: Callable[[], float] | None = None,
) -> RoverRun:
    """Follow the leader with a real rover until the video ends (or the limits are reached).

    Waits for the rover's heartbeat, asks for its odometry at ``rate_hz``, puts it in GUIDED
    (and arms it with ``arm``), then each period: read the rover's messages (and answer a
    ground station's parameter requests), take a frame, perceive it, run the stack with the
    companion's ``LFC_*`` parameters (set from ``settings`` at the start; a ground station
    may change them). The companion's heartbeat goes out once a second. Odometry that stops
    coming for :data:`ODOMETRY_STALE_S` (or three periods) is said in the log and to the
    ground station, and again when it comes back. The rover is sent zero setpoints at the
    end, however it ends.

    Parameters
    ----------
    companion : Companion
        The connection to the rover, as its companion computer.
    video : VideoSource
        The camera.
    perception : BannerPerception
        The camera's perception (intrinsics, banner, tracker).
    settings : FormationSettings
        The slot and control law.
    rate_hz : float
        Control rate: setpoints and frames per second.
    status_rate_hz : float
        Formation status reports per second.
    arm : bool
        Also arm the rover.
    timeout_s : float
        Longest wait for the rover's heartbeat, s.
    max_frames, max_steps : int, optional
        Stop after this many frames or setpoints.
    name : str
        The follower's name in its STATUSTEXT lines.
    on_step : callable, optional
        Sees every step (:class:`RoverStep`) after its setpoint went out.
    clock : callable, optional
        The run's clock, s, for the steps' ``t_s`` (default: seconds since the loop
        started); give the one the steps are logged on, so they and the link's packets share it.
    """
    # a ground station may set them; each must be one it could set
    set_values(companion.params, formation_param_values(settings), "lfctl follow")
    companion.wait_vehicle(timeout_s, rate_hz)
    companion.set_guided()
    if arm:
        companion.arm()
    stack = Follower(name, settings, companion, step_rate_hz=rate_hz, status_rate_hz=status_rate_hz)
    period = 1.0 / rate_hz
    t0 = time.monotonic()
    now = clock if clock is not None else lambda: time.monotonic() - t0
    steps = frames = 0
    seen_as = dict.fromkeys(TrackStatus, 0)
    t_s = t_start = now()
    stale = False
    stale_s = max(ODOMETRY_STALE_S, 3.0 / rate_hz)  # an odometry message a period: one late is not missing
    companion.vehicle.t_s = None  # what came while waiting was stamped on the wait's own clock
    try:
        while max_steps is None or steps < max_steps:
            t_s = now()
            companion.poll(t_s)
            companion.heartbeat(t_s)
            stale = _say_odometry(companion, name, t_s, t_start, stale, stale_s)
            frame = video.read() if max_frames is None or frames < max_frames else None
            if frame is None:
                break
            frames += 1
            seen = perception.step(t_s, frame)
            v = companion.vehicle
            odom = Odometry(t_s, v.north_m or 0.0, v.east_m or 0.0, v.yaw_rad or 0.0, v.speed_mps or 0.0)
            fix = (v.lat_deg, v.lon_deg, v.alt_m or 0.0) if v.lat_deg is not None and v.lon_deg is not None else None
            n_events = len(stack.events)
            stack.tune_from_params(companion.param)
            out = stack.step(t_s, seen.measurement, odom)
            steps += 1
            seen_as[seen.measurement.status] += 1
            if on_step is not None:
                on_step(RoverStep(t_s, frame, seen, odom, out, stack.settings, stack.events[n_events:], fix))
            time.sleep(max(0.0, period - (now() - t_s)))
    finally:
        for _ in range(STOP_SETPOINTS):
            companion.setpoint(t_s, 0.0, 0.0)
    return RoverRun(
        steps, frames, seen_as[TrackStatus.TRACKING], seen_as[TrackStatus.OCCLUDED], seen_as[TrackStatus.LOST]
    )


def _say_odometry(companion: Companion, name: str, t_s: float, t_start: float, stale: bool, stale_s: float) -> bool:
    """Whether the rover's odometry is missing now (none for ``stale_s``, or none yet that long
    after the start); the change is said in the log and to the ground station (STATUSTEXT,
    the name cut so that the line fits one), once each way."""
    last = companion.vehicle.t_s
    now_stale = t_s - (t_start if last is None else last) > stale_s
    who = name[:20]
    if now_stale and not stale:
        log.warning(
            "%s: no odometry (LOCAL_POSITION_NED) for %g s: the stack steers on its last position", name, stale_s
        )
        companion.statustext(f"{who}: no odometry for {stale_s:g} s")
    elif stale and not now_stale:
        log.info("%s: odometry (LOCAL_POSITION_NED) back", name)
        companion.statustext(f"{who}: odometry back", mav.MAV_SEVERITY_INFO)
    return now_stale
