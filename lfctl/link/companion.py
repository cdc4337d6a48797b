"""The follower's companion computer on its vehicle's MAVLink: component 191 of the vehicle's
system, as on an ArduPilot Rover with a companion board.

It puts the vehicle in GUIDED and arms it, streams setpoints
(SET_POSITION_TARGET_LOCAL_NED, frame BODY_NED, type_mask 1479: forward speed and yaw
rate), reports the formation status to the ground station (NAMED_VALUE_FLOAT ``rng_err``,
``brg_err``, ``trk_q``) and says when the leader is lost or found again (STATUSTEXT). It
reads back the vehicle's HEARTBEAT, LOCAL_POSITION_NED and ATTITUDE (its odometry on a real
rover) and GLOBAL_POSITION_INT (where it is on the map, when it knows). One class for both
worlds: on a :class:`MavPort` over UDP or serial to a real rover, or over the in-memory link
to a simulated vehicle's endpoint.

On a real rover it is a MAVLink component of its own, as a companion board is: it sends its
HEARTBEAT once a second (:meth:`Companion.heartbeat`), holds the formation parameters
``LFC_*`` (:func:`lfctl.link.params.formation_params`) and answers the parameter protocol for
them, over MAVLink FTP too (``@PARAM/param.pck``), and refuses commands addressed to it
(COMMAND_ACK UNSUPPORTED). A ground station reaches it through the rover's MAVLink routing: ArduPilot
forwards what is addressed to component 191, or to every component, to the link the
companion talks on.
"""

from __future__ import annotations

import logging
import math
import time
from collections import deque
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.checks import printable
from lfctl.errors import LinkTimeoutError, VehicleKindError
from lfctl.frames import HALF_EARTH_M, on_earth
from lfctl.link.camera import CameraComponent
from lfctl.link.endpoint import COMPANION_COMPID, MODES, TYPE_MASK_SPEED_YAWRATE
from lfctl.link.ftp import FtpServer
from lfctl.link.gcs import result_name, text_field
from lfctl.link.param_server import ParamServer
from lfctl.link.params import formation_params
from lfctl.link.port import CHECK_LINK, MavPort, statustext_messages

__all__ = ["COMPANION_COMPID", "Companion", "VehicleReport", "answer_name", "unanswered"]

#: the formation status names a ground station shows (NAMED_VALUE_FLOAT, 10 characters at most)
STATUS_NAMES = (b"rng_err", b"brg_err", b"trk_q")
#: the vehicles lfctl commands: an ArduPilot Rover (GCS_Rover::frame_type: a rover, or a boat)
ROVER_TYPES = frozenset((mav.MAV_TYPE_GROUND_ROVER, mav.MAV_TYPE_SURFACE_BOAT))
#: what the companion asks the vehicle to stream at the control rate (MAV_CMD_SET_MESSAGE_INTERVAL)
ODOMETRY_MSG_IDS = (
    mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
    mav.MAVLINK_MSG_ID_ATTITUDE,
    mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
)
#: the fastest a Rover sends a message at its default main loop (SCHED_LOOP_RATE 50 Hz: at
#: most 0.8 x that, 25 ms); ArduPilot 4.6 refuses a SET_MESSAGE_INTERVAL faster than its own
#: loop allows, and the odometry is then asked for at this rate
ROVER_STREAM_MAX_HZ = 40.0
#: the companion's HEARTBEAT period, s (MAVLink's 1 Hz)
HEARTBEAT_PERIOD_S = 1.0
#: a command that waits for its answer (:meth:`Companion.request`): how long each try waits for
#: the COMMAND_ACK, s, and how many tries go out (the same COMMAND_LONG again, its
#: confirmation counting up, as MAVLink's command protocol asks of a sender)
COMMAND_TRY_S = 1.0
COMMAND_TRIES = 3
#: the longest a command answered IN_PROGRESS is waited for, from its first send, s
IN_PROGRESS_MAX_S = 10.0
#: the vehicle's STATUSTEXTs kept for the caller (:attr:`Companion.heard`), the newest
HEARD_MAX = 100
#: the most messages, and the longest time, one :meth:`Companion.poll` takes: a link that
#: brings more (a flood) leaves the rest for the next step, so the heartbeat and the
#: setpoints keep their rate (a rover sends about 60 a second)
POLL_MAX_MESSAGES = 500
POLL_MAX_S = 0.05
#: the other autopilots heard on the link that are remembered (each is said once)
OTHER_AUTOPILOTS_MAX = 16
log = logging.getLogger(__name__)

#: the parameter protocol's requests
PARAM_REQUESTS = ("PARAM_REQUEST_LIST", "PARAM_REQUEST_READ", "PARAM_SET")
#: the vehicle's time_boot_ms going back by more than this, ms, is a restart (less: packets
#: that came out of order)
RESTART_BACK_MS = 1000
#: the largest magnitude of each odometry field the companion takes from its vehicle: half
#: the Earth's circumference from the local origin (LOCAL_POSITION_NED x, y, m: ArduPilot's
#: public origin stays where it was set, however far the vehicle goes, but no place is
#: farther), 1000 m/s (vx, vy), a turn and a half of yaw (ATTITUDE, rad; ArduPilot's is within
#: +-pi)
PLAUSIBLE = {"x": HALF_EARTH_M, "y": HALF_EARTH_M, "vx": 1e3, "vy": 1e3, "yaw": 3 * math.pi}


@dataclass
class VehicleReport:
    """What the vehicle last said about itself (local NED, heading, speed, mode, global position).

    ``t_s`` is when its LOCAL_POSITION_NED arrived, on the companion's clock; ``None`` for
    what has not been heard yet. An ArduPilot vehicle whose EKF has no global position (no
    GPS, no origin set) still sends GLOBAL_POSITION_INT, at latitude and longitude 0: that
    leaves ``lat_deg``, ``lon_deg`` and ``alt_m`` None.
    """

    heard: bool = False  # a HEARTBEAT from the vehicle's autopilot has come
    heartbeat_t_s: float | None = None  # when its last HEARTBEAT came, on the companion's clock
    mode: int | None = None  # its custom mode (Rover mode number, see endpoint.MODES)
    armed: bool | None = None  # its HEARTBEAT's safety-armed flag
    mav_type: int | None = None  # its HEARTBEAT's MAV_TYPE
    autopilot: int | None = None  # its HEARTBEAT's MAV_AUTOPILOT
    positions: int = 0  # LOCAL_POSITION_NED messages taken, all told (their rate: the odometry's)
    boot_ms: int | None = None  # the last LOCAL_POSITION_NED's time_boot_ms
    restarts: int = 0  # times that clock went back (the autopilot restarted), all told
    t_s: float | None = None
    north_m: float | None = None  # position, local NED, m (LOCAL_POSITION_NED)
    east_m: float | None = None  # position, local NED, m
    speed_mps: float | None = None  # horizontal speed, m/s
    yaw_rad: float | None = None  # heading, rad (ATTITUDE)
    global_t_s: float | None = None  # when its GLOBAL_POSITION_INT last arrived, s
    lat_deg: float | None = None  # latitude, deg (GLOBAL_POSITION_INT); None without a global position
    lon_deg: float | None = None  # longitude, deg
    alt_m: float | None = None  # altitude above mean sea level, m


def answer_name(result: int | None) -> str:
    """What :meth:`Companion.request` got, in words: the MAV_RESULT's name, or that no answer
    came to any try.

    Parameters
    ----------
    result : int or None
        Its return value.
    """
    if result == mav.MAV_RESULT_IN_PROGRESS:
        return f"answered IN_PROGRESS, no final answer within {IN_PROGRESS_MAX_S:g} s"
    return f"no answer to {COMMAND_TRIES} tries" if result is None else result_name(result)


def unanswered(result: int | None) -> bool:
    """Whether :meth:`Companion.request` got no final answer (none at all, or IN_PROGRESS only).

    Parameters
    ----------
    result : int or None
        Its return value.
    """
    return result is None or result == mav.MAV_RESULT_IN_PROGRESS


def _autopilot(m: Any) -> bool:
    """A HEARTBEAT a vehicle's autopilot sends (not a ground station's, a camera's or an
    onboard program's: their autopilot field is INVALID, or their type a GCS)."""
    return m.autopilot != mav.MAV_AUTOPILOT_INVALID and m.type != mav.MAV_TYPE_GCS


def _enum_name(enum: str, value: int | None) -> str:
    """A MAVLink enum's entry by name (the number where the dialect has none)."""
    entry = mav.enums[enum].get(value) if value is not None else None
    return entry.name if entry is not None else f"{enum} {value}"


def _time_ms(t_s: float) -> int:
    return int(t_s * 1000) & 0xFFFFFFFF


class Companion:
    """A follower's companion on its vehicle's link.

    Parameters
    ----------
    port : MavPort
        Our identity (the vehicle's system id, component 191) and the way to the vehicle.
    target_system : int
        The vehicle's system id.
    """

    def __init__(self, port: MavPort, target_system: int) -> None:
        self.port = port
        self.target = target_system
        self.vehicle = VehicleReport()
        #: its own parameters (``LFC_*``): a ground station may set them while it runs
        self.params = formation_params()
        self._text_id = 0  # the last long text's chunk id
        self.param_server = ParamServer(self.params, self.port.send, self.statustext)
        self.ftp = FtpServer({"@PARAM/param.pck": self.param_server.ftp_file()}, self._send_ftp, self.statustext)
        #: the vehicle's position and attitude messages passed over for a value that is not a
        #: number or past any ground vehicle's (:data:`PLAUSIBLE`)
        self.passed_over = 0
        #: polls that stopped at :data:`POLL_MAX_MESSAGES` or :data:`POLL_MAX_S` with more waiting
        self.overloaded = 0
        #: other systems whose autopilot (a vehicle's HEARTBEAT, component 1) talks on the link
        self.other_autopilots: set[int] = set()
        #: a companion with this one's ids (the rover's system, component 191) talks on the link:
        #: two companions would both command the rover
        self.other_companion = False
        #: what the vehicle's autopilot said (STATUSTEXT), (MAV_SEVERITY, text escaped), oldest
        #: first, the newest :data:`HEARD_MAX`: a caller reads them off (``popleft``) to show them
        self.heard: deque[tuple[int, str]] = deque(maxlen=HEARD_MAX)
        #: the autopilot's last COMMAND_ACK result for each command, addressed to the companion
        self.acks: dict[int, int] = {}
        # each odometry message's rate the vehicle took (:meth:`wait_vehicle`), Hz
        self.stream_hz: dict[int, float] = {}
        # the autopilot's parameters read (:meth:`read_param`), by name; only those asked for
        self.vehicle_params: dict[str, float] = {}
        self._params_asked: set[str] = set()
        self._heartbeat_t_s: float | None = None
        #: the camera component announcing the video this program sends (:meth:`offer_video`),
        #: None without one, or once another camera with its ids was heard (then it steps aside)
        self.camera: CameraComponent | None = None
        #: another component with the camera's ids talks on the link (the rover's own camera)
        self.camera_clash = False
        #: its own packets (and its camera's) heard back: a relay loops the link's traffic into it
        self.echoes = 0
        #: messages whose handling failed (a bug of ours; each kind said once in the log)
        self.handler_errors = 0
        self._failed_kinds: set[str] = set()

    def param(self, name: str) -> float:
        """One of the companion's parameters now.

        Parameters
        ----------
        name : str
            ``LFC_RANGE``, ``LFC_BEARING``, ... (:func:`lfctl.link.params.formation_params`).
        """
        if name not in self.params:
            raise KeyError(f"{name!r} is not one of the companion's parameters ({', '.join(self.params)})")
        return self.params[name].value

    def heartbeat(self, t_s: float) -> None:
        """Its HEARTBEAT (an onboard controller, active), once each :data:`HEARTBEAT_PERIOD_S`:
        call it as often as you like.

        Parameters
        ----------
        t_s : float
            Now, on the companion's clock, s.
        """
        if self.camera is not None:
            self.camera.tick(t_s)  # (its own HEARTBEAT, once a second)
        if self._heartbeat_t_s is not None and t_s - self._heartbeat_t_s < HEARTBEAT_PERIOD_S:
            return
        self._heartbeat_t_s = t_s
        self._send_heartbeat()

    def camera_tap(self, direction: str, msg: Any, raw: bytes) -> None:
        """A camera component's tap (:class:`CameraComponent`'s ``tap``) into the port's: what
        it sends is shown; what it is handed, the port's read has shown already.

        Parameters
        ----------
        direction : str
            ``out`` (the camera sent it) or ``in`` (it was handed to the camera).
        msg : pymavlink message
            The packet decoded.
        raw : bytes
            The packet as it travelled.
        """
        if direction == "out" and self.port.tap is not None:
            self.port.tap("out", msg, raw)

    def offer_video(self, camera: CameraComponent) -> None:
        """Announce the video this program sends (``lfctl follow --video``) as the rover's
        camera: ``camera``, a MAVLink camera component (100) of the rover's system made to send
        through this link (``send=companion.port.write``, ``tap=companion.camera_tap``), is
        handed what is addressed to it and beats with the companion's :meth:`heartbeat`. The
        rover's routing passes its HEARTBEAT on to the ground station, so that QGroundControl
        asks it for its stream (VIDEO_STREAM_INFORMATION: RTP/UDP H.264 on its port) and shows
        it without a video setting; VIDEO_STOP_STREAMING and VIDEO_START_STREAMING reach
        :attr:`CameraComponent.on_streaming`. It steps aside (said in the log) if another
        component with its ids talks on the link: the rover's own camera.

        Parameters
        ----------
        camera : CameraComponent
            The camera to announce.
        """
        self.camera = camera

    def _send_heartbeat(self) -> None:
        self.port.send(
            mav.MAVLink_heartbeat_message(
                mav.MAV_TYPE_ONBOARD_CONTROLLER, mav.MAV_AUTOPILOT_INVALID, 0, 0, mav.MAV_STATE_ACTIVE, 3
            )
        )

    @staticmethod
    def open(connect: str, target_system: int, signing_key: bytes | None = None) -> Companion:
        """A companion on a pymavlink connection string (a real rover, or ``lfctl sim --realtime``).

        Parameters
        ----------
        connect : str
            ``udpout:ROVER_IP:14550``, ``/dev/ttyUSB0,921600``, ...
        target_system : int
            The rover's system id.
        signing_key : bytes, optional
            MAVLink 2 signing key, when the rover signs its link.
        """
        return Companion(MavPort.open(connect, target_system, COMPANION_COMPID, signing_key), target_system)

    # -- to the vehicle ---------------------------------------------------------------------
    def command(self, cmd: int, *params: float) -> None:
        """A COMMAND_LONG to the vehicle's autopilot (its COMMAND_ACK is not awaited).

        Parameters
        ----------
        cmd : int
            The MAV_CMD.
        *params : float
            param1, param2, ... (up to 7; the rest are 0).
        """
        self._send_command(cmd, 0, params)

    def _send_command(self, cmd: int, confirmation: int, params: tuple[float, ...]) -> None:
        p = [*params, *([0.0] * (7 - len(params)))]
        self.port.send(mav.MAVLink_command_long_message(self.target, 1, cmd, min(confirmation, 255), *p))

    def request(self, cmd: int, *params: float, try_s: float = COMMAND_TRY_S, tries: int = COMMAND_TRIES) -> int | None:
        """A COMMAND_LONG to the vehicle's autopilot that waits for its COMMAND_ACK, sent again
        (confirmation 1, 2, ...) when none comes within ``try_s``. An IN_PROGRESS answer stops
        the sending (the command is being carried out: sent again it would start afresh) and
        waits for the final answer up to :data:`IN_PROGRESS_MAX_S`. Everything else that
        comes meanwhile is taken as :meth:`poll` takes it, one message at a time, and the
        companion's heartbeat goes on; however fast messages come, the wait ends at its
        deadline, ``tries`` x ``try_s``, put back as far as this process stalled (a loaded
        companion computer) so that each try is sent and given its ``try_s``. Returns the MAV_RESULT, None when no answer came (a lossy link, or an
        autopilot that does not answer), or IN_PROGRESS when no final one followed it.

        Parameters
        ----------
        cmd : int
            The MAV_CMD.
        *params : float
            param1, param2, ... (up to 7; the rest are 0).
        try_s : float
            Longest wait for each try's answer, s.
        tries : int
            Sends, at most.
        """
        start = time.monotonic()
        deadline = start + try_s * tries
        sent = 0
        next_send = start
        beat = -math.inf
        progress = None
        self.acks.pop(cmd, None)
        while (now := time.monotonic()) < deadline or sent < tries:
            if sent < tries and now >= next_send:
                self._send_command(cmd, sent, params)
                sent += 1
                next_send = now + try_s
                deadline = max(deadline, next_send)  # (a stall here must not eat the tries left)
            until = min(deadline, next_send) if sent < tries else deadline  # (no send due: the answer)
            beat = self._listen(now, until, start, beat)
            result = self.acks.pop(cmd, None)
            if result == mav.MAV_RESULT_IN_PROGRESS:
                sent = progress = tries  # no more sends: the final answer follows
                deadline = max(deadline, start + IN_PROGRESS_MAX_S)
            elif result is not None:
                return result
        return None if progress is None else mav.MAV_RESULT_IN_PROGRESS

    def read_param(self, name: str, try_s: float = COMMAND_TRY_S, tries: int = COMMAND_TRIES) -> float | None:
        """One of the autopilot's parameters (PARAM_REQUEST_READ by name, sent again when its
        PARAM_VALUE does not come within ``try_s``; what else comes meanwhile is taken as
        :meth:`poll` takes it, and the companion's heartbeat goes on). Returns its value, or
        None when no answer came (a lossy link, or a parameter the autopilot does not have).

        Parameters
        ----------
        name : str
            The parameter's name (``WP_SPEED``).
        try_s : float
            Longest wait for each try's answer, s.
        tries : int
            Sends, at most.
        """
        self._params_asked.add(name)
        self.vehicle_params.pop(name, None)
        start = beat = time.monotonic()
        for _ in range(tries):
            self.port.send(mav.MAVLink_param_request_read_message(self.target, 1, name.encode(), -1))
            until = time.monotonic() + try_s
            while (now := time.monotonic()) < until:
                beat = self._listen(now, until, start, beat)
                if name in self.vehicle_params:
                    return self.vehicle_params[name]
        return None

    def _listen(self, now: float, until: float, start: float, beat: float) -> float:
        """One step of a wait for an answer: the companion's heartbeat when one is due (on the
        wait's own clock, from ``beat``, when it was last sent: the caller's clock may
        differ), then at most one message read, waiting up to ``until``, taken as
        :meth:`poll` takes it (stamped from ``start``). Returns when the heartbeat was last
        sent."""
        if now - beat >= HEARTBEAT_PERIOD_S:
            beat = now
            self._send_heartbeat()
        m = self.port.recv(min(0.05, max(0.0, until - now)))
        if m is not None:
            self._take_safely(m, now - start)
        return beat

    def set_guided(self) -> None:
        """Ask for GUIDED mode (the answer is not awaited: :meth:`request` waits for it)."""
        self.command(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES["GUIDED"])

    def arm(self, on: bool = True) -> None:
        """Ask to arm (or disarm) (the answer is not awaited: :meth:`request` waits for it).

        Parameters
        ----------
        on : bool
            True to arm, False to disarm.
        """
        self.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1.0 if on else 0.0)

    def setpoint(self, t_s: float, speed_mps: float, yaw_rate_radps: float) -> None:
        """A GUIDED setpoint: forward speed and yaw rate (SET_POSITION_TARGET_LOCAL_NED).

        Parameters
        ----------
        t_s : float
            Now, s (the message's time_boot_ms).
        speed_mps : float
            Forward speed, m/s.
        yaw_rate_radps : float
            Yaw rate, rad/s, positive right.
        """
        self.port.send(
            mav.MAVLink_set_position_target_local_ned_message(
                _time_ms(t_s), self.target, 1, mav.MAV_FRAME_BODY_NED, TYPE_MASK_SPEED_YAWRATE,
                0, 0, 0, speed_mps, 0, 0, 0, 0, 0, 0, yaw_rate_radps,
            )
        )  # fmt: skip

    def report(
        self, t_s: float, range_err_m: float | None, bearing_err_deg: float | None, track_quality: float
    ) -> None:
        """The formation status a ground station shows (three NAMED_VALUE_FLOAT); an unknown
        error goes as NaN, MAVLink's "no value".

        Parameters
        ----------
        t_s : float
            Now, s (the messages' time_boot_ms).
        range_err_m : float or None
            Range error, m (``rng_err``); None when unknown.
        bearing_err_deg : float or None
            Bearing error, degrees (``brg_err``): MAVLink's unit at the ground station; None
            when unknown.
        track_quality : float
            0..1 (``trk_q``).
        """
        for name, value in zip(STATUS_NAMES, (range_err_m, bearing_err_deg, track_quality), strict=True):
            v = float(value) if value is not None and math.isfinite(value) else math.nan
            self.port.send(mav.MAVLink_named_value_float_message(_time_ms(t_s), name, v))

    def statustext(self, text: str, severity: int = mav.MAV_SEVERITY_WARNING) -> None:
        """A STATUSTEXT for the ground station.

        Parameters
        ----------
        text : str
            The line (longer than 50 bytes: in chunks; at most 200).
        severity : int
            MAV_SEVERITY (default WARNING).
        """
        data = printable(text).encode()  # a peer's bytes escaped
        if len(data) > 50:
            self._text_id = self._text_id % 65535 + 1
        for msg in statustext_messages(data, severity, self._text_id):
            self.port.send(msg)

    # -- from the vehicle -------------------------------------------------------------------
    def poll(self, t_s: float, timeout_s: float = 0.0) -> int:
        """Read everything waiting (up to ``timeout_s`` for the first message) and keep what
        the vehicle's autopilot says about itself; returns the messages read.

        Parameters
        ----------
        t_s : float
            Now, on the companion's clock (stamps the odometry), s.
        timeout_s : float
            Longest wait for the first message, s.
        """
        n = 0
        m = self.port.recv(timeout_s)
        until = time.monotonic() + POLL_MAX_S  # the read's budget, from the first message (not the wait for it)
        while m is not None:
            n += 1
            self._take_safely(m, t_s)
            if n >= POLL_MAX_MESSAGES or time.monotonic() >= until:
                self.overloaded += 1  # the rest waits for the next step
                break
            m = self.port.recv()
        # after the requests read (a burst going on takes what the ration has left, as the
        # endpoint's does after its reading): a written file whose session went idle is
        # handed over, and bursts go on
        self.ftp.tick()
        return n

    def _take_safely(self, m: Any, t_s: float) -> None:
        """:meth:`_take`, a failure of which (a bug of ours on a peer's message) is counted and
        said once per message kind: the run goes on."""
        try:
            self._take(m, t_s)
        except Exception:
            self.handler_errors += 1
            if m.get_type() not in self._failed_kinds and len(self._failed_kinds) < OTHER_AUTOPILOTS_MAX:
                self._failed_kinds.add(m.get_type())
                log.exception("handling %s from %d/%d failed", m.get_type(), m.get_srcSystem(), m.get_srcComponent())

    def _take(self, m: Any, t_s: float) -> None:
        if self.port.echo(m):  # its own (or its camera's) come back through a looping relay
            self.echoes += 1
            return
        kind = m.get_type()
        cam = self.camera
        if cam is not None:
            if cam.wants(m):
                cam.handle(m)
                return
            if (m.get_srcSystem(), m.get_srcComponent()) == (self.target, cam.compid):
                # another component with its ids: any of its packets (its own heard back are
                # echoes, passed over above; and once the rover has heard ours on this link it
                # no longer forwards the other's HEARTBEAT here, only its broadcasts)
                self.camera, self.camera_clash = None, True
                cam.resume()  # (a stream a ground station had stopped is sent again, unannounced)
                log.warning(
                    "another camera (component %d of system %d) talks on the link: the video is no longer "
                    "announced as the rover's camera (set the stream's port in the ground station instead)",
                    cam.compid,
                    self.target,
                )
        if kind in PARAM_REQUESTS:
            self._param_request(m, kind)
            return
        if kind in ("COMMAND_LONG", "COMMAND_INT"):
            self._command(m)
            return
        if kind == "FILE_TRANSFER_PROTOCOL":
            self._ftp(m)
            return
        if m.get_srcSystem() != self.target or m.get_srcComponent() != 1:
            # (another component of the rover's own system, a gimbal's or a peripheral's that
            # ArduPilot forwards, is not another vehicle's autopilot)
            other = m.get_srcSystem() != self.target
            if kind == "HEARTBEAT" and other and _autopilot(m) and len(self.other_autopilots) < OTHER_AUTOPILOTS_MAX:
                self.other_autopilots.add(m.get_srcSystem())
            if (m.get_srcSystem(), m.get_srcComponent()) == (self.target, COMPANION_COMPID):
                self.other_companion = True  # another companion of this rover (our own echoes passed over above)
            return
        kind, v = m.get_type(), self.vehicle
        if kind == "HEARTBEAT":
            if _autopilot(m):  # (a ground station's or another program's from 1/1 is not the rover's)
                v.heard, v.heartbeat_t_s = True, t_s
                v.mav_type, v.autopilot = m.type, m.autopilot
                v.mode, v.armed = m.custom_mode, bool(m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
        elif kind == "LOCAL_POSITION_NED":
            if v.boot_ms is not None and m.time_boot_ms + RESTART_BACK_MS < v.boot_ms:
                v.restarts += 1  # its clock began again: the autopilot restarted (its stream rates too)
            v.boot_ms = m.time_boot_ms
            if self._plausible(kind, ("x", m.x), ("y", m.y), ("vx", m.vx), ("vy", m.vy)):
                # forward speed, signed (backing up is negative): the ground velocity along the
                # heading (ATTITUDE's, the last that came); its size until a heading has come
                speed = (
                    math.hypot(m.vx, m.vy)
                    if v.yaw_rad is None
                    else m.vx * math.cos(v.yaw_rad) + m.vy * math.sin(v.yaw_rad)
                )
                v.north_m, v.east_m, v.speed_mps, v.t_s = m.x, m.y, speed, t_s
                v.positions += 1
        elif kind == "ATTITUDE":
            if self._plausible(kind, ("yaw", m.yaw)):
                v.yaw_rad = m.yaw
        elif kind == "COMMAND_ACK":
            # ours (0: a MAVLink 1 ack has no target fields)
            if m.target_system in (0, self.port.sysid) and m.target_component in (0, COMPANION_COMPID):
                self.acks[m.command] = m.result
        elif kind == "STATUSTEXT":
            self.heard.append((m.severity, text_field(m.text)))
        elif kind == "PARAM_VALUE" and (name := text_field(m.param_id)) in self._params_asked:
            self.vehicle_params[name] = float(m.param_value)
        elif kind == "GLOBAL_POSITION_INT":
            v.global_t_s = t_s
            known = (m.lat, m.lon) != (0, 0) and on_earth(m.lat / 1e7, m.lon / 1e7)
            v.lat_deg, v.lon_deg, v.alt_m = (m.lat / 1e7, m.lon / 1e7, m.alt / 1000.0) if known else (None, None, None)

    def _plausible(self, kind: str, *fields: tuple[str, float]) -> bool:
        """Whether the vehicle's ``kind`` holds only numbers within :data:`PLAUSIBLE`: one
        that does not is damaged or not the autopilot's, and is passed over (the odometry
        keeps its last values; a NaN or a 1e38 there would stay in the formation filter for
        good). The first is said in the log, naming the field and value, the rest counted in
        :attr:`passed_over`."""
        bad = next(((f, x) for f, x in fields if not abs(x) <= PLAUSIBLE[f]), None)
        if bad is None:
            return True
        if not self.passed_over:
            log.warning(
                "%s from the vehicle with %s = %r, not a number or past %g: passed over (and any like it after it)",
                kind,
                bad[0],
                bad[1],
                PLAUSIBLE[bad[0]],
            )
        self.passed_over += 1
        return False

    def _param_request(self, m: Any, kind: str) -> None:
        """The parameter protocol, for requests addressed to this component or to every
        component of the vehicle; a broadcast that names no ``LFC_*`` parameter (a read by
        index, another parameter) is the autopilot's to answer, and is left to it."""
        if m.target_system not in (0, self.target) or m.target_component not in (0, COMPANION_COMPID):
            return
        if kind == "PARAM_REQUEST_LIST":
            self.param_server.request_list()
            return
        by_index = kind == "PARAM_REQUEST_READ" and m.param_index != -1
        if m.target_component == 0 and (by_index or self.param_server.name_of(m.param_id) is None):
            return
        if kind == "PARAM_REQUEST_READ":
            self.param_server.request_read(m)
            return
        name = self.param_server.name_of(m.param_id)
        before = self.params[name].value if name is not None else None
        self.param_server.set(m)
        if name is not None and self.params[name].value != before:
            log.info("%s set to %g by %d/%d", name, self.params[name].value, m.get_srcSystem(), m.get_srcComponent())

    def _command(self, m: Any) -> None:
        """A command addressed to this component (not a broadcast: the autopilot answers
        those): none is carried out here, each is answered UNSUPPORTED, as MAVLink's command
        protocol asks of a component that has not implemented it."""
        if m.target_system != self.target or m.target_component != COMPANION_COMPID:
            return
        self.port.send(
            mav.MAVLink_command_ack_message(
                m.command, mav.MAV_RESULT_UNSUPPORTED, 0, 0, m.get_srcSystem(), m.get_srcComponent()
            )
        )

    def _ftp(self, m: Any) -> None:
        """MAVLink FTP addressed to this component: its parameters as ``@PARAM/param.pck``
        (:mod:`lfctl.link.ftp`), which MAVProxy's ``param fetch`` reads and a ground station
        may write back; any other file is refused at once."""
        if m.target_system == self.target and m.target_component == COMPANION_COMPID:
            self.ftp.handle(bytes(m.payload), m.get_srcSystem(), m.get_srcComponent())

    def _send_ftp(self, payload: bytes, sysid: int, compid: int) -> None:
        self.port.send(mav.MAVLink_file_transfer_protocol_message(0, sysid, compid, list(payload)))

    def wait_vehicle(self, timeout_s: float, odometry_rate_hz: float) -> dict[int, int | None]:
        """Say hello until the vehicle's heartbeat is heard, then ask for its position (local
        and global) and attitude at ``odometry_rate_hz``, each request waiting for its answer
        (:meth:`request`). A request refused or not answered is said in the log, with what to
        set on the vehicle instead. Returns each message id's MAV_RESULT (None: no answer).

        Parameters
        ----------
        timeout_s : float
            Longest wait for the vehicle, s.
        odometry_rate_hz : float
            Rate of LOCAL_POSITION_NED, ATTITUDE and GLOBAL_POSITION_INT to ask for, Hz.

        Raises
        ------
        LinkTimeoutError
            No heartbeat from the vehicle within ``timeout_s``.
        """
        start = time.monotonic()
        deadline = start + timeout_s
        while time.monotonic() < deadline:
            self._send_heartbeat()
            self.poll(time.monotonic() - start, 0.2)
            if self.vehicle.heard:
                self._check_kind()
                return {msg_id: self._ask_stream(msg_id, odometry_rate_hz) for msg_id in ODOMETRY_MSG_IDS}
        others = sorted(self.other_autopilots)
        detail = CHECK_LINK
        if others:  # heard, but not the one asked for: the likeliest slip
            who = (
                f"system {others[0]}'s autopilot talks"
                if len(others) == 1
                else ("the autopilots of systems " + ", ".join(str(o) for o in others) + " talk")
            )
            detail = f"{who} on this link: --target {others[0]}?"
        elif self.port.serial and self.port.junk and not self.port.received and not self.port.mav.signing.reject_count:
            # (what a UART at another baud reads: noise, never a packet; a bad signature is no hint of it)
            detail = (
                f"only bytes that are no MAVLink came on it ({self.port.junk} bad packets): is the baud the rover's "
                "SERIALn_BAUD, and the port set to MAVLink (SERIALn_PROTOCOL 2)?"
            )
        raise LinkTimeoutError("HEARTBEAT", sysid=self.target, timeout_s=timeout_s, detail=detail)

    def _check_kind(self) -> None:
        """Refuse a vehicle that is not an ArduPilot Rover or boat (its HEARTBEAT's type and
        autopilot): its mode numbers are another vehicle's (15, Rover's GUIDED, is a Copter's
        AUTOTUNE), and a PX4 vehicle's custom mode is laid out otherwise."""
        v = self.vehicle
        if v.autopilot == mav.MAV_AUTOPILOT_ARDUPILOTMEGA and v.mav_type in ROVER_TYPES:
            return
        raise VehicleKindError(
            self.target, f"{_enum_name('MAV_TYPE', v.mav_type)} / {_enum_name('MAV_AUTOPILOT', v.autopilot)}"
        )

    def ask_streams_again(self, rate_hz: float) -> None:
        """Ask for the odometry streams once more, not awaiting the answers (the loop's steps
        go on): a rover that rebooted, or whose streams stopped, sends them only at its own
        stream-rate parameters' rates (by default 1 Hz, or none on older ones). Each at the rate the
        vehicle took when first asked (:attr:`stream_hz`), else ``rate_hz``.

        Parameters
        ----------
        rate_hz : float
            Rate of LOCAL_POSITION_NED, ATTITUDE and GLOBAL_POSITION_INT to ask for, Hz.
        """
        for msg_id in ODOMETRY_MSG_IDS:
            self.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / self.stream_hz.get(msg_id, rate_hz))

    def _ask_stream(self, msg_id: int, rate_hz: float) -> int | None:
        """MAV_CMD_SET_MESSAGE_INTERVAL for one message, awaited. A rate faster than a Rover
        sends at its default loop rate (:data:`ROVER_STREAM_MAX_HZ`) that is refused is asked
        for again at that rate, and said; a refusal or silence after that is said, with the
        ArduPilot stream-rate parameter that sends the message otherwise. The rate taken is
        kept in :attr:`stream_hz`."""
        name = mav.mavlink_map[msg_id].msgname
        result = self.request(mav.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / rate_hz)
        if result == mav.MAV_RESULT_DENIED and rate_hz > ROVER_STREAM_MAX_HZ:
            log.info(
                "the vehicle refused %s at %g Hz: a Rover sends a message at most 0.8 x its SCHED_LOOP_RATE "
                "(%g Hz at its default 50 Hz; raise SCHED_LOOP_RATE and reboot it for more): asked for %g Hz",
                name,
                rate_hz,
                ROVER_STREAM_MAX_HZ,
                ROVER_STREAM_MAX_HZ,
            )
            rate_hz = ROVER_STREAM_MAX_HZ
            result = self.request(mav.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / rate_hz)
        if result == mav.MAV_RESULT_ACCEPTED:
            self.stream_hz[msg_id] = rate_hz
        else:
            log.warning(
                "the vehicle %s %s at %g Hz (%s): set its stream rate instead (ArduPilot: SRn_%s, n the "
                "companion's port among the autopilot's MAVLink ports, counted from 0: not its SERIAL number)",
                "did not answer the request for" if unanswered(result) else "refused",
                name,
                rate_hz,
                answer_name(result),
                "EXTRA1" if msg_id == mav.MAVLINK_MSG_ID_ATTITUDE else "POSITION",
            )
        return result

    def close(self) -> None:
        """Close the connection."""
        self.port.close()
