"""The follower stack on a real rover (`lfctl follow`): frames from a camera, the rover's
own odometry over MAVLink, setpoints back to it as its companion computer, paced by the
wall clock. The stack (:class:`~lfctl.follower.stack.Follower`) and the perception
(:class:`~lfctl.vision.perception.BannerPerception`) are the ones `lfctl sim` runs."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.follower.stack import Follower, FollowerEvent, formation_param_values
from lfctl.guidance.formation import FormationOutput, FormationSettings, Odometry
from lfctl.link.companion import (
    ODOMETRY_MSG_IDS,
    ROVER_STREAM_MAX_HZ,
    STATUS_NAMES,
    Companion,
    answer_name,
    unanswered,
)
from lfctl.link.endpoint import COMPANION_COMPID, MODES
from lfctl.link.gcs import mode_name
from lfctl.link.params import set_values
from lfctl.video import REOPEN_S, STOP_WAIT_S, STREAM_TIMEOUT_S, Reopening, VideoSource
from lfctl.vision.perception import BannerPerception, Perception
from lfctl.vision.track_state import TrackStatus

__all__ = ["RoverRun", "RoverStep", "follow_rover"]

#: setpoints of zero sent when the run ends, :data:`STOP_SPACING_S` apart, so the rover is
#: left standing: spread out, so that a lossy link that drops a burst does not leave it
#: driving on its last setpoint until its GUIDED timeout (3 s) stops it
STOP_SETPOINTS = 3
STOP_SPACING_S = 0.15
#: the rover's LOCAL_POSITION_NED older than this, or three control periods if that is
#: longer, is said to be missing (the stack then steers on the last position it had: the
#: camera still closes the loop)
ODOMETRY_STALE_S = 1.0
#: while the rover's odometry is missing, it is asked for again this often, s
REASK_S = 2.0
#: the odometry's rate is measured over this long, s: under :data:`SLOW_SHARE` of the rate
#: asked for, something set the rover's stream rates since (a ground station's
#: REQUEST_DATA_STREAM on the same link replaces them on ArduPilot), and it is asked again
RATE_WINDOW_S = 3.0
SLOW_SHARE = 0.5
#: a live camera that gives no frame for this long, or three control periods if that is
#: longer, is silent: the rover is held (zero setpoints) until frames come again, s
CAMERA_SILENT_S = 1.0
#: a silent camera is back once this many frames have come, each within the silence's
#: length of the last: FFmpeg's decoder hands over the frames it still held as a stream ends,
#: one at each read timeout, and those are no return
BACK_FRAMES = 3
#: the rover's HEARTBEAT older than this is said to be missing (MAVLink's heartbeats come
#: once a second): its mode and arming are then not known, and setpoints are not counted as
#: carried out
HEARTBEAT_STALE_S = 3.0

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
    #: steps while the rover said, in a HEARTBEAT no older than :data:`HEARTBEAT_STALE_S`,
    #: that it was in GUIDED and armed, and its odometry came: the setpoints it carried out
    #: (in another mode ArduPilot ignores them, and so it does with no position estimate
    #: and EKF origin, when it sends no LOCAL_POSITION_NED either; disarmed, it keeps the
    #: newest and drives on it once armed, and its motors do nothing until then)
    guided: int = 0
    junk: int = 0  # what the link brought that was no MAVLink of the dialect (cut, corrupt, unknown ids)
    passed_over: int = 0  # odometry messages passed over: not a number, or past any ground vehicle's
    interrupted: bool = False  # ended by Ctrl-C (SIGINT) or SIGTERM
    #: a live camera's frames passed over for a newer one: it made them faster than the steps
    #: took them (each step takes the newest)
    skipped: int = 0
    #: times a live camera went silent (no frame for :data:`CAMERA_SILENT_S`): the rover held
    #: still meanwhile (the setpoints are zeros)
    camera_gaps: int = 0
    camera_silent_s: float = 0.0  # how long the camera was silent in all, s

    def summary(self) -> str:
        """One line: what was sent, how many the rover took, and how often the target was seen."""
        line = f"sent {self.steps} setpoints"
        if self.steps:
            line += f" (the rover in GUIDED, armed and with odometry for {self.guided})"
        line += f"; {self.frames} frames"
        if self.skipped:
            line += f" (and {self.skipped} older ones passed over for the newest)"
        if self.steps:
            line += f"; target tracking in {self.tracking}, occluded in {self.occluded}, lost in {self.lost} steps"
            if self.tracking == 0:
                line += " (never seen: check the camera, the banner and its markers' hue)"
        if self.camera_gaps:
            times = "once" if self.camera_gaps == 1 else f"{self.camera_gaps} times"
            line += f"; the camera silent {times}, {self.camera_silent_s:.1f} s in all (the rover held still)"
        if self.junk or self.passed_over:
            line += f"; passed over: {self.junk} junk packets, {self.passed_over} odometry messages"
        if self.interrupted:
            line += "; interrupted"
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
    open_camera: Callable[[], VideoSource] | None = None,
) -> RoverRun:
    """Follow the leader with a real rover until the video ends (or the limits are reached).

    Waits for the rover's heartbeat, asks for its odometry at ``rate_hz``, puts it in GUIDED
    (and arms it with ``arm``, only once it is in GUIDED: armed in another mode, AUTO or RTL,
    it would drive off on its own), each request waiting for the rover's answer and sent again
    when none comes (a refusal or silence is said in the log with the rover's reason, and the
    run goes on: the rover ignores setpoints until it is in GUIDED and armed), then each period: read the rover's messages (and answer a
    ground station's parameter requests), take a frame, perceive it, run the stack with the
    companion's ``LFC_*`` parameters (set from ``settings`` at the start; a ground station
    may change them). The companion's heartbeat goes out once a second. Odometry that stops
    coming for :data:`ODOMETRY_STALE_S` (or three periods) is said in the log and to the
    ground station, and again when it comes back. The rover's mode and arming changes (its
    pilot or a ground station taking it out of GUIDED, or putting it back) and what its
    autopilot says (STATUSTEXT) are said in the log; the companion never takes the rover
    back into GUIDED itself. A live camera that gives no frame for :data:`CAMERA_SILENT_S`
    (or three periods) holds the rover still (zero setpoints, said in the log and to the
    ground station); one that has stopped is opened again until it gives frames, and the
    target is then looked for afresh (a camera back at another size ends the run). The rover
    is sent zero setpoints at the end, however it ends.

    Parameters
    ----------
    companion : Companion
        The connection to the rover, as its companion computer.
    video : VideoSource
        The camera (closed when the run ends).
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
    open_camera : callable, optional
        Opens a live camera again once it has stopped (default: ``VideoSource(video.name,
        latest=True)``); a source it opens is closed here.
    """
    # a ground station may set them; each must be one it could set
    set_values(companion.params, formation_param_values(settings), "lfctl follow")
    companion.wait_vehicle(timeout_s, rate_hz)
    _check_link_budget(companion, name, rate_hz, status_rate_hz)  # (the odometry's rates as the rover took them)
    _check_speed_limit(companion, name, settings)
    v = companion.vehicle
    log.info(
        "%s: the rover (system %d) answers: %s, %s",
        name,
        companion.target,
        mode_name(v.mode) if v.mode is not None else "mode not known",
        {True: "armed", False: "disarmed", None: "arming not known"}[v.armed],
    )
    _say_heard(companion, name)  # what it said before: its banner, a failing pre-arm check
    guided = MODES["GUIDED"]
    in_guided = _ask(companion, name, "GUIDED", mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, guided)
    if in_guided:
        companion.vehicle.mode = guided  # its answer follows the change; its HEARTBEAT may lag
        log.info("%s: the rover took GUIDED", name)
    # what the log has said of the rover: a change after it (even one during the requests) is said
    state = (companion.vehicle.mode, companion.vehicle.armed)
    if arm and not in_guided:
        # armed in the mode it is in, a rover in AUTO or RTL would drive off on its own
        log.warning("%s: not arming the rover: it is not in GUIDED (arm it yourself once it is)", name)
    elif arm and _ask(companion, name, "arm", mav.MAV_CMD_COMPONENT_ARM_DISARM, 1.0):
        companion.vehicle.armed = True
        state = (state[0], True)
        log.info("%s: the rover armed", name)
    elif not arm and companion.vehicle.armed is False:
        log.warning("%s: the rover is disarmed: it takes the setpoints once it is armed", name)
    stack = Follower(name, settings, companion, step_rate_hz=rate_hz, status_rate_hz=status_rate_hz)
    period = 1.0 / rate_hz
    t0 = time.monotonic()
    now = clock if clock is not None else lambda: time.monotonic() - t0
    steps = frames = obeyed = 0
    seen_as = dict.fromkeys(TrackStatus, 0)
    t_s = t_start = now()
    stale = False
    stale_s = max(ODOMETRY_STALE_S, 3.0 / rate_hz)  # an odometry message a period: one late is not missing
    companion.vehicle.t_s = None  # what came while waiting was stamped on the wait's own clock
    companion.vehicle.heartbeat_t_s = t_start  # (heard while waiting; restamped on this clock)
    link = _LinkWatch(companion, name)
    asked_at = -math.inf  # when the odometry was last asked for again
    rate_from = (t_start, companion.vehicle.positions)  # the odometry's rate is measured from here
    restarts = companion.vehicle.restarts  # the rover's restarts seen (each has the odometry asked again)
    slow_said = False
    interrupted = False
    shape = (perception.camera.height, perception.camera.width)
    camera = _Camera(video, companion, name, max(CAMERA_SILENT_S, 3.0 / rate_hz), period, shape, open_camera)
    try:
        while max_steps is None or steps < max_steps:
            t_s = now()
            companion.poll(t_s)
            companion.heartbeat(t_s)
            was_stale = stale
            stale = _say_odometry(companion, name, t_s, t_start, stale, stale_s)
            beating = link.check(t_s)
            restarted = companion.vehicle.restarts > restarts
            if link.came_back or restarted or (stale and t_s - asked_at >= REASK_S):
                # a rover that rebooted (or whose streams stopped) sends only what its own
                # stream rates say (by default 1 Hz or none): asked again, and
                # again while it is missing (a request may be lost, or sent mid-reboot)
                if restarted:
                    log.info("%s: the rover restarted (its clock began again): asked for its odometry again", name)
                elif link.came_back or not was_stale:
                    log.info("%s: asked the rover for its odometry again", name)
                link.came_back = False
                restarts = companion.vehicle.restarts
                companion.ask_streams_again(rate_hz)
                asked_at = t_s
            if t_s - rate_from[0] >= RATE_WINDOW_S:
                came = (companion.vehicle.positions - rate_from[1]) / (t_s - rate_from[0])
                asked = companion.stream_hz.get(mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED, rate_hz)
                if not stale and came < SLOW_SHARE * asked and t_s - asked_at >= REASK_S:
                    _say_slow(name, came, asked, slow_said)
                    slow_said = True
                    companion.ask_streams_again(rate_hz)
                    asked_at = t_s
                rate_from = (t_s, companion.vehicle.positions)
            _say_heard(companion, name)
            state = _say_rover_state(companion, name, state)
            if max_frames is not None and frames >= max_frames:
                break
            frame = camera.read(t_s)
            if frame is None:
                if not camera.live or camera.failed:
                    break  # a file's end is its end; a camera back at another size cannot be followed
                companion.setpoint(t_s, 0.0, 0.0)  # a silent camera: the rover held still
                steps += 1
                v = companion.vehicle
                obeyed += beating and v.t_s is not None and not stale and v.mode == guided and bool(v.armed)
                time.sleep(max(0.0, period - (now() - t_s)))
                continue
            if camera.came_back:  # (where the target went meanwhile, the track does not know)
                perception.restart()
                camera.came_back = False
            frames += 1
            seen = perception.step(t_s, frame)
            v = companion.vehicle
            odom = Odometry(t_s, v.north_m or 0.0, v.east_m or 0.0, v.yaw_rad or 0.0, v.speed_mps or 0.0)
            fix = (v.lat_deg, v.lon_deg, v.alt_m or 0.0) if v.lat_deg is not None and v.lon_deg is not None else None
            n_events = len(stack.events)
            stack.tune_from_params(companion.param)
            out = stack.step(t_s, seen.measurement, odom)
            for event in stack.events[n_events:]:
                log.info("%s", event.text)  # ("NAME: leader lost, ...", as the ground station reads it)
            steps += 1
            obeyed += beating and v.t_s is not None and not stale and v.mode == guided and bool(v.armed)
            seen_as[seen.measurement.status] += 1
            if on_step is not None:
                on_step(RoverStep(t_s, frame, seen, odom, out, stack.settings, stack.events[n_events:], fix))
            time.sleep(max(0.0, period - (now() - t_s)))
    except KeyboardInterrupt:  # Ctrl-C, SIGTERM: the run ends here, its figures said
        interrupted = True
    finally:
        try:
            _leave_standing(companion, t_s)
        finally:
            camera.close(now())
    return RoverRun(
        steps, frames, seen_as[TrackStatus.TRACKING], seen_as[TrackStatus.OCCLUDED], seen_as[TrackStatus.LOST],
        obeyed, companion.port.junk, companion.passed_over, interrupted, camera.skipped, camera.gaps,
        camera.silent_total_s,
    )  # fmt: skip


class _Camera:
    """The follower's camera through a run. A live one that gives no frame for ``silent_s``
    is silent: said once in the log and to the ground station, and read a period at a time
    meanwhile (the run holds the rover still); one that has stopped (a failed read, or a
    stream silent for its read timeout) is closed and opened again on a thread of its own
    until it opens (:class:`~lfctl.video.Reopening`). Frames that come again are said, and
    must be of the size the run's perception is for. A file is read frame after frame to its
    end."""

    def __init__(
        self,
        video: VideoSource,
        companion: Companion,
        name: str,
        silent_s: float,
        period_s: float,
        shape: tuple[int, int],
        opener: Callable[[], VideoSource] | None,
    ) -> None:
        self.video: VideoSource | None = video
        self.source = video.name
        self.live = video.live
        self.companion, self.follower = companion, name
        self.silent_s, self.period_s = silent_s, period_s
        self._opener = opener if opener is not None else partial(VideoSource, video.name, latest=True)
        self._reopening: Reopening | None = None
        self._reopened_at = -math.inf  # when the last tries to open it again began (monotonic s)
        self._skipped = -video.skipped  # (those made while the rover was being set up are not the run's)
        self._shape = shape  # the frames' (height, width) the run's perception is for
        self._last_frame_t: float | None = None
        self._silent_since: float | None = None
        self._said_stopped = False  # that it stopped, this silence
        self._seen = 0  # frames come while silent (see BACK_FRAMES)
        self._seen_t: float | None = None  # the last one's time
        self.came_back = False  # frames again after a silence (until the run has taken note)
        self.failed = False  # back with frames of another size: not to be followed
        self.gaps = 0
        self.silent_total_s = 0.0

    @property
    def skipped(self) -> int:
        """Frames passed over for a newer one in the run, over every source it had."""
        return self._skipped + (self.video.skipped if self.video is not None else 0)

    def read(self, t_s: float) -> np.ndarray | None:
        """The newest frame, or None: a file's end, a live camera silent now (or being opened
        again), or :attr:`failed`."""
        if not self.live:
            assert self.video is not None
            return self.video.read()
        if self.video is None:
            assert self._reopening is not None
            self.video = self._reopening.take()
            if self.video is None:
                self._silent(t_s)
                return None
            self._reopening = None
            log.info("%s: the camera %s opened again: waiting for its frames", self.follower, self.source)
        wait = self.period_s if self._silent_since is not None else self.silent_s
        frame = self.video.read(wait)
        if frame is None:
            self._silent(t_s)
            if self.video.ended:
                self._reopen()
            return None
        shape = frame.shape[:2]
        if shape != self._shape:
            log.warning(
                "%s: the camera %s came back with %dx%d frames, not the %dx%d the run began with: the run ends "
                "(its perception is for the first size; start lfctl follow again)",
                self.follower, self.source, shape[1], shape[0], self._shape[1], self._shape[0],
            )  # fmt: skip
            self.failed = True
            return None
        if self._silent_since is not None:
            if self._seen_t is not None and t_s - self._seen_t > self.silent_s:
                self._seen = 0  # (one frame long after the last: a decoder's held frame)
            self._seen, self._seen_t = self._seen + 1, t_s
            if self._seen < BACK_FRAMES:
                return None  # still held
            gap = t_s - self._silent_since
            self.silent_total_s += gap
            self._silent_since = None
            self._said_stopped = False
            self.came_back = True
            log.warning(  # (as loud as their loss: without -v the end of a warning was never said)
                "%s: the camera's frames are back after %.1f s: looking for the target afresh", self.follower, gap
            )
            self.companion.statustext(f"{self.follower[:20]}: camera back", mav.MAV_SEVERITY_INFO)
        self._last_frame_t = t_s
        return frame

    def _silent(self, t_s: float) -> None:
        """No frame now: a silence that begins is counted and said."""
        if self._silent_since is None:
            self._silent_since = self._last_frame_t if self._last_frame_t is not None else t_s
            self._seen, self._seen_t = 0, None
            self.gaps += 1
            log.warning(
                "%s: the camera %s gives no frames: the rover is held still until they come again",
                self.follower,
                self.source,
            )
            self.companion.statustext(f"{self.follower[:20]}: camera silent, rover held")

    def _reopen(self) -> None:
        """The source in hand has stopped: closed (a stream's port freed) and opened again."""
        assert self.video is not None
        self._skipped += self.video.skipped
        self.video.close()
        self.video = None
        # (said once a silence: a stream that is not back ends again at each read timeout)
        level = logging.INFO if self._said_stopped else logging.WARNING
        log.log(
            level,
            "%s: the camera %s stopped: opening it again until it is back (tries %g s apart or more: a stream's try "
            "waits up to %g s to open and as long for a frame)",
            self.follower,
            self.source,
            REOPEN_S,
            STREAM_TIMEOUT_S,
        )
        self._said_stopped = True
        # (one that opened and stopped at once is tried again a second after the last try, not
        # at every step)
        now = time.monotonic()
        self._reopening = Reopening(self._opener, max(0.0, self._reopened_at + REOPEN_S - now))
        self._reopened_at = max(now, self._reopened_at + REOPEN_S)

    def close(self, t_s: float) -> None:
        """End the run's use of the camera: a silence under way is counted, tries to open it
        again end, and the source in hand is closed (a read stuck in a silent stream's driver
        is waited for up to :data:`~lfctl.video.STOP_WAIT_S` only: Ctrl-C ends the run at once)."""
        if self._silent_since is not None:
            self.silent_total_s += t_s - self._silent_since
            self._silent_since = None
        if self._reopening is not None:
            self._reopening.stop()
        if self.video is not None:
            self._skipped += self.video.skipped
            self.video.close(STOP_WAIT_S)
            self.video = None


#: a start-up request's words: (what was asked for, what was refused, what the rover must be)
_ASKED = {
    "GUIDED": ("the request for GUIDED", "GUIDED", "in GUIDED (set it from the ground station or the transmitter)"),
    "arm": ("the request to arm", "to arm", "armed (arm it yourself)"),
}


def _ask(companion: Companion, name: str, what: str, cmd: int, *params: float) -> bool:
    """A start-up command (``what``: ``GUIDED``, ``arm``), awaited; whether the rover took it.
    A refusal or silence is said in the log with what the rover said meanwhile (Rover says
    its reason before it answers: "Flight mode change failed", "Arm: ...")."""
    result = companion.request(cmd, *params)
    if result == mav.MAV_RESULT_ACCEPTED:
        _say_heard(companion, name)
        return True
    said = [text for _severity, text in companion.heard]
    companion.heard.clear()
    answer = answer_name(result) + ("; it said: " + " / ".join(said) if said else "")
    request, refused, must_be = _ASKED[what]
    log.warning(
        "%s: the rover %s (%s): it ignores the setpoints until it is %s; the follower goes on and says when it is",
        name,
        f"did not answer {request}" if unanswered(result) else f"refused {refused}",
        answer,
        must_be,
    )
    return False


class _LinkWatch:
    """Says in the log what happens on the rover's link besides its messages: its HEARTBEAT
    stopping and coming back, another autopilot talking on it, a flood that a step cannot
    read whole, packets that are no MAVLink; each once, until it changes."""

    def __init__(self, companion: Companion, name: str) -> None:
        self.companion, self.name = companion, name
        self.beating = True
        self.came_back = False  # the HEARTBEAT came back since it was missing (until taken)
        self.others: set[int] = set()
        self.said_companion = False
        self.said_overload = self.said_junk = False  # (what came while starting is said too)

    def check(self, t_s: float) -> bool:
        """Say what changed; whether the rover's HEARTBEAT is fresh."""
        c, name = self.companion, self.name
        last = c.vehicle.heartbeat_t_s
        beating = last is not None and t_s - last <= HEARTBEAT_STALE_S
        if beating != self.beating:
            if beating:
                log.warning("%s: the rover's HEARTBEAT is back", name)  # (as loud as its loss)
                self.came_back = True
            else:
                log.warning(
                    "%s: no HEARTBEAT from the rover (system %d) for %g s: rebooted, or the link is down; "
                    "its mode and arming are not known, the setpoints go on",
                    name,
                    c.target,
                    HEARTBEAT_STALE_S,
                )
            self.beating = beating
        for sysid in sorted(c.other_autopilots - self.others):
            log.warning(
                "%s: system %d's autopilot talks on this link; the companion follows system %d (--target)",
                name,
                sysid,
                c.target,
            )
            self.others.add(sysid)
        if c.other_companion and not self.said_companion:
            self.said_companion = True
            log.warning(
                "%s: another companion (system %d, component %d) talks on this link: two companions command "
                "the rover in turn; stop the other (a follower in lfctl sim has its own unless its scenario "
                "says companion = false)",
                name,
                c.target,
                COMPANION_COMPID,
            )
        if c.overloaded and not self.said_overload:
            self.said_overload = True
            log.warning(
                "%s: the link brings more than a step reads (a flood?): the rest waits for the next step; "
                "the heartbeat and the setpoints keep their rate",
                name,
            )
        if c.port.junk and not self.said_junk:
            self.said_junk = True
            log.warning(
                "%s: passed over a packet that is no MAVLink of the dialect (cut, corrupt, or an unknown "
                "message id); the closing line counts them",
                name,
            )
        return beating


def _say_heard(companion: Companion, name: str) -> None:
    """What the rover's autopilot said since the last call, in the log: its warnings (a
    failing pre-arm check, a mode change refused, a failsafe) as warnings, the rest as info."""
    while companion.heard:
        severity, text = companion.heard.popleft()
        level = logging.WARNING if severity <= mav.MAV_SEVERITY_WARNING else logging.INFO
        log.log(level, "%s: the rover says: %s", name, text)


def _say_rover_state(
    companion: Companion, name: str, was: tuple[int | None, bool | None]
) -> tuple[int | None, bool | None]:
    """Say in the log when the rover's mode or arming changes (its HEARTBEAT): out of GUIDED,
    or disarmed, it ignores the setpoints, and the companion does not take it back (its
    pilot or ground station did that); back in GUIDED and armed it follows again."""
    v = companion.vehicle
    mode, armed = v.mode, v.armed
    if mode is not None and mode != was[0]:
        if mode == MODES["GUIDED"]:
            log.info("%s: the rover is in GUIDED: it takes the setpoints%s", name, "" if armed else " once armed")
        else:
            log.warning(
                "%s: the rover is in %s, not GUIDED: it ignores the setpoints until it is put back in GUIDED "
                "(the follower does not take it back)",
                name,
                mode_name(mode),
            )
    if armed is not None and armed != was[1]:
        if armed:
            log.info("%s: the rover is armed", name)
        else:
            log.warning("%s: the rover is disarmed: it does not move until it is armed again", name)
    return mode, armed


def _say_odometry(companion: Companion, name: str, t_s: float, t_start: float, stale: bool, stale_s: float) -> bool:
    """Whether the rover's odometry is missing now (none for ``stale_s``, or none yet that long
    after the start); the change is said in the log and to the ground station (STATUSTEXT,
    the name cut so that the line fits one), once each way."""
    last = companion.vehicle.t_s
    now_stale = t_s - (t_start if last is None else last) > stale_s
    who = name[:20]
    if now_stale and not stale and last is None:
        log.warning(
            "%s: no odometry (LOCAL_POSITION_NED) in the first %g s: an ArduPilot rover sends none without a "
            "position estimate and EKF origin (a GPS fix, or another position source with the origin set by "
            "SET_GPS_GLOBAL_ORIGIN), and then ignores every SET_POSITION_TARGET_LOCAL_NED: it moves once it has one",
            name,
            stale_s,
        )
        companion.statustext(f"{who}: no odometry yet")
    elif now_stale and not stale:
        log.warning(
            "%s: no odometry (LOCAL_POSITION_NED) for %g s: the stack steers on its last position", name, stale_s
        )
        companion.statustext(f"{who}: no odometry for {stale_s:g} s")
    elif stale and not now_stale:
        log.warning("%s: odometry (LOCAL_POSITION_NED) back", name)  # (as loud as its loss)
        companion.statustext(f"{who}: odometry back", mav.MAV_SEVERITY_INFO)
    return now_stale


def _leave_standing(companion: Companion, t_s: float) -> None:
    """The run's last setpoints: :data:`STOP_SETPOINTS` of zero, :data:`STOP_SPACING_S` apart."""
    for k in range(STOP_SETPOINTS):
        if k:
            time.sleep(STOP_SPACING_S)
        companion.setpoint(t_s + k * STOP_SPACING_S, 0.0, 0.0)


#: the share of a serial port's bytes a second past which the companion's traffic is said to
#: overrun it (the rover sends its own streams on the port too)
LINK_BUDGET_SHARE = 0.8


def _frame_bytes(msg_id: int, signed: bool) -> int:
    """The most bytes one MAVLink 2 packet of ``msg_id`` takes on the wire."""
    size = mav.HEADER_LEN_V2 + mav.mavlink_map[msg_id].unpacker.size + 2
    return size + (mav.MAVLINK_SIGNATURE_BLOCK_LEN if signed else 0)


def _check_link_budget(companion: Companion, name: str, rate_hz: float, status_rate_hz: float) -> None:
    """Say when a serial port's baud cannot carry the setpoints at ``rate_hz`` (with the
    status) or the odometry asked for: a UART sends baud / 10 bytes a second (8N1) each way;
    what the companion cannot send queues in the operating system's buffer, so the setpoints
    reach the rover late and the step waits on the write, and ArduPilot skips a stream's
    message when the port has no room for it."""
    port = companion.port
    if not port.serial:
        return
    capacity = int(port.connection.baud) / 10
    signed = port.mav.signing.sign_outgoing  # (a rover that checks signatures signs its own)
    up = rate_hz * _frame_bytes(mav.MAVLINK_MSG_ID_SET_POSITION_TARGET_LOCAL_NED, signed)
    up += status_rate_hz * len(STATUS_NAMES) * _frame_bytes(mav.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT, signed)
    # each at the rate the rover took (one with SCHED_LOOP_RATE raised takes rate_hz), else
    # at the fastest its default loop sends
    taken = {i: companion.stream_hz.get(i, min(rate_hz, ROVER_STREAM_MAX_HZ)) for i in ODOMETRY_MSG_IDS}
    odometry_hz = max(taken.values())
    down = sum(hz * _frame_bytes(i, signed) for i, hz in taken.items())
    limit = LINK_BUDGET_SHARE * capacity
    if max(up, down) > limit:
        late = [
            *(["setpoints that do not fit queue and reach the rover late"] if up > limit else []),
            *(["the rover sends the odometry slower than asked"] if down > limit else []),
        ]
        log.warning(
            "%s: at %s baud the serial port carries %d bytes/s each way: the setpoints at %g Hz need %d and the "
            "odometry asked for at %g Hz %d%s: %s (a faster SERIALn_BAUD with the same ,BAUD here, or a lower --rate)",
            name,
            port.connection.baud,
            capacity,
            rate_hz,
            up,
            odometry_hz,
            down,
            ", signed" if signed else "",
            ", and ".join(late),
        )


def _check_speed_limit(companion: Companion, name: str, settings: FormationSettings) -> None:
    """Say when the rover will not drive as fast as the follower may ask: ArduPilot Rover holds
    a GUIDED speed setpoint to its ``WP_SPEED`` (either way; GCS_MAVLink_Rover's
    handle_set_position_target_local_ned), so a follower whose top speed is above it falls
    behind a leader that drives faster, with nothing else to say so."""
    wp_speed = companion.read_param("WP_SPEED")
    top = max(abs(settings.range.max_speed_mps), abs(settings.range.min_speed_mps))
    if wp_speed is None:
        log.info("%s: the rover did not say its WP_SPEED: its limit on the setpoints' speed is not known", name)
    elif top > wp_speed:
        log.warning(
            "%s: the rover holds GUIDED speed to its WP_SPEED, %g m/s, under the follower's %g m/s: it may fall "
            "behind a faster leader (set WP_SPEED on the rover to at least %g)",
            name,
            wp_speed,
            top,
            top,
        )


def _say_slow(name: str, came_hz: float, rate_hz: float, said: bool) -> None:
    """The rover's LOCAL_POSITION_NED comes at ``came_hz``, under half the ``rate_hz`` asked
    for: said as a warning the first time (with what to set on the rover), in the log's
    detail after."""
    if said:
        log.info("%s: LOCAL_POSITION_NED at %.1f Hz, not %g: asked again", name, came_hz, rate_hz)
        return
    log.warning(
        "%s: the rover sends LOCAL_POSITION_NED at %.1f Hz, not the %g Hz asked for: asked again (a ground "
        "station's REQUEST_DATA_STREAM on the same link sets ArduPilot's stream rates; on the companion's port "
        "set SERIALn_OPTIONS bit 12 (ArduPilot 4.6 and older; MAVn_OPTIONS' option from 4.7), which ignores "
        "those requests, or the link is too slow for the rate)",
        name,
        came_hz,
        rate_hz,
    )
