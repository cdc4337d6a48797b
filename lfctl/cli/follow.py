"""`lfctl follow`: the follower stack as a real rover's companion computer."""

from __future__ import annotations

import argparse
import dataclasses
import logging
import math
import os
import sys
import time
from functools import partial
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from lfctl.config import Config
    from lfctl.follower.rover import RoverStep
    from lfctl.link.port import MavPort
    from lfctl.vision.camera_model import CameraModel

from lfctl.cli.options import connection, integer, number

log = logging.getLogger(__name__)

#: the setpoint rates `lfctl follow` takes, Hz
RATE_HZ = (1.0, 100.0)

#: a rover without a global position this long after the first step has none: said once in /log, s
NO_FIX_AFTER_S = 2.0
#: the most MAVLink packets ``/mavlink/<rover>`` logs per second (STATUSTEXT always); the rest
#: are counted, and the count goes to /log
MAVLINK_MAX_PER_S = 500

#: the rover `lfctl follow` runs without a scenario
DEFAULT_SCENARIO = '[[vehicles]]\nname = "leader"\nrole = "leader"\n[[vehicles]]\nname = "rover"\nrole = "follower"\n'


def register(sub: Any) -> None:
    """Add the ``follow`` command to the parser."""
    fo = sub.add_parser(
        "follow",
        help="the follower stack on a real rover: camera -> tracker -> formation control -> GUIDED setpoints",
        description="Run the follower's vision and guidance against a real ArduPilot rover (or lfctl sim --realtime) as its companion computer (component 191).",
    )
    fo.add_argument(
        "--mavlink",
        required=True,
        type=connection,
        help="connection to the rover, e.g. udpout:ROVER_IP:14550 or /dev/ttyUSB0,921600",
    )
    fo.add_argument(
        "--camera",
        default="0",
        help="camera index, video file (or a shipped clip by name: bikes.mp4), stream URL, or rtp://HOST:PORT for "
        "RTP/UDP H.264 (default 0)",
    )
    fo.add_argument(
        "--camera-wait",
        type=number(0, 10**6, unit="s"),
        metavar="S",
        help="seconds to wait for a camera or stream that is not there yet (default: until it comes, said every "
        "10 s; a file is not waited for)",
    )
    fo.add_argument("--target", type=integer(1, 255), default=1, help="the rover's system id (default 1)")
    fo.add_argument(
        "--scenario",
        help="camera intrinsics and mount, banner, gains and rates from this scenario (a file, or a shipped name)",
    )
    fo.add_argument(
        "--follower",
        help="which of the scenario's followers this rover is: its slot, its target's banner, its name "
        "(default: the first)",
    )
    fo.add_argument(
        "--range",
        type=number(0, 1000, lo_open=True, unit="m"),
        help="commanded range to the leader, m (default: the scenario's slot, 1.5)",
    )
    fo.add_argument(
        "--bearing",
        type=number(-180, 180, unit="deg"),
        help="commanded bearing to the leader, deg (default: the scenario's, 0)",
    )
    fo.add_argument(
        "--rate",
        type=number(*RATE_HZ, unit="Hz"),
        help="setpoint rate, 1-100 Hz (default: the scenario's sim.guidance_rate_hz, 20); the rover stops "
        "when setpoints are more than 3 s apart (Rover 4.6)",
    )
    fo.add_argument("--arm", action="store_true", help="also arm the rover (default: you arm it)")
    fo.add_argument(
        "--timeout",
        type=number(0, 3600, lo_open=True, unit="s"),
        default=10.0,
        help="seconds to wait for the rover's heartbeat",
    )
    fo.add_argument("--signing-passphrase", help="MAVLink 2 signing: the passphrase the rover's key was set up with")
    fo.add_argument("--max-frames", type=integer(1, 10**9), help="stop after this many camera frames")
    fo.add_argument("--steps", type=integer(1, 10**9), help="stop after this many setpoints")
    fo.add_argument(
        "--live",
        nargs="?",
        const="",
        metavar="HOST:PORT",
        help="serve the rover's view on a Foxglove WebSocket: pose, map position, camera video with the track, "
        "formation errors, events, MAVLink packets (default: [live] foxglove, 127.0.0.1:8765; port 0: any free port)",
    )
    fo.add_argument(
        "--video",
        nargs="?",
        const="",
        metavar="HOST:PORT",
        help="stream the camera (annotated as [live] video_annotated says) as RTP/UDP H.264 to a ground station "
        "(default: [live] video, 127.0.0.1:5600; on a rover, the ground station's address), announced as the "
        "rover's camera (MAVLink camera component 100: QGroundControl finds the stream by itself)",
    )
    fo.add_argument(
        "--no-camera-component",
        action="store_true",
        help="with --video: do not announce the stream as a MAVLink camera component (the rover has its own "
        "camera at component 100, or the ground station is set to the port by hand)",
    )
    fo.set_defaults(func=run)


class LiveView:
    """What `lfctl follow --live` / `--video` show of each step: the rover's pose, its
    LocationFix from its own global position, the camera (H.264) with its annotations, the
    stack's state and events, and the MAVLink packets of the companion's link on the
    Foxglove WebSocket (the topics of a simulated follower's log); the camera as RTP/UDP
    H.264 to a ground station.

    Its clock (:meth:`clock`) starts with the view, as the log's times do: give it to
    :func:`~lfctl.follower.rover.follow_rover` so steps and packets share it.

    Parameters
    ----------
    cfg : Config
        The scenario (camera, rates, [live]).
    name : str
        The rover's name in the topics.
    camera : CameraModel
        The camera, at the frames' size.
    live, video : (host, port) or None
        Where to serve Foxglove, and where to send the video.
    """

    def __init__(
        self, cfg: Config, name: str, camera: CameraModel, live: tuple[str, int] | None, video: tuple[str, int] | None
    ) -> None:
        from lfctl.record.rtp import RtpH264Sender
        from lfctl.record.video import H264Encoder
        from lfctl.record.writer import SCENE_REPEAT_S, Recorder

        self.cfg, self.name, self.camera = cfg, name, camera
        start_ns, self._t0 = time.time_ns(), time.monotonic()  # the log's epoch and the run's clock, paired
        # its frames are H.264 whatever the scenario records (`[recording] image_format = "jpeg"`
        # put them on a CompressedImage labelled jpeg, a topic its layout does not name)
        h264 = dataclasses.replace(cfg, recording=dataclasses.replace(cfg.recording, image_format="h264"))
        self.rec = Recorder(None, h264, live=live, start_ns=start_ns) if live is not None else None
        if self.rec is not None:  # /log from the start: a viewer subscribed to it sees the first event
            self.rec.event(0.0, "lfctl", f"follow: {name}'s companion computer (component 191)")
        self.sender = RtpH264Sender(*video) if video is not None else None
        rate = cfg.sim.guidance_rate_hz
        self.image = H264Encoder(
            camera.width, camera.height, rate, cfg.recording.video_bitrate_kbps, cfg.recording.video_gop
        )
        self.stream = H264Encoder(camera.width, camera.height, rate, cfg.live.video_bitrate_kbps, max(1, round(rate)))
        self._calibrated_at = -math.inf
        self._calibration_every_s = SCENE_REPEAT_S
        self._watching = False
        self._first_step_s: float | None = None
        self._has_fix: bool | None = None  # what /log last said: None before it said anything
        self._window_end_s = -math.inf
        self._in_window = 0
        #: packets /mavlink/<name> did not log (over :data:`MAVLINK_MAX_PER_S`)
        self.skipped_packets = 0

    def streaming(self, on: bool) -> None:
        """The ground station started (``on``) or stopped the video (VIDEO_START_STREAMING,
        VIDEO_STOP_STREAMING to the camera component): the stream is sent or paused; the
        companion goes on tracking its camera either way.

        Parameters
        ----------
        on : bool
            Send the stream.
        """
        if self.sender is not None:
            self.sender.paused = not on

    @property
    def port(self) -> int | None:
        """The Foxglove WebSocket's port (None without ``--live``)."""
        return self.rec.live_port if self.rec is not None else None

    def clock(self) -> float:
        """Seconds since the view opened: the run's clock, on which the log is stamped."""
        return time.monotonic() - self._t0

    def watch(self, port: MavPort) -> None:
        """Log every packet through the companion's ``port`` on ``/mavlink/<name>`` (nothing
        without ``--live``); the companion's STATUSTEXT (target lost, found) then reaches
        /log that way, as a simulated follower's does.

        Parameters
        ----------
        port : MavPort
            The companion's port to the rover.
        """
        if self.rec is not None:
            port.tap = self.mavlink
            self._watching = True

    def mavlink(self, direction: str, msg: Any, raw: bytes) -> None:
        """One packet of the companion's link on ``/mavlink/<name>``, as the simulator logs a
        vehicle endpoint's: ``direction`` as the rover sees it (``in``: the companion sent it
        to the rover; ``out``: it came from the rover's side of the link), the raw bytes, the
        fields decoded as far as they decode. At most :data:`MAVLINK_MAX_PER_S` a second
        (STATUSTEXT always): the rest are counted in :attr:`skipped_packets`.

        Parameters
        ----------
        direction : str
            As the port's tap says it: ``out`` sent by the companion, ``in`` received.
        msg : pymavlink message
            The packet decoded.
        raw : bytes
            The packet as it travelled.
        """
        from lfctl.link.endpoint import packet_record

        rec = self.rec
        if rec is None:
            return
        t = self.clock()
        if t >= self._window_end_s:
            self._window_end_s, self._in_window = t + 1.0, 0
        if self._in_window >= MAVLINK_MAX_PER_S and msg.get_type() != "STATUSTEXT":
            if self.skipped_packets == 0:
                rec.event(
                    t,
                    self.name,
                    f"over {MAVLINK_MAX_PER_S} MAVLink packets/s: /mavlink/{self.name} skips the rest (counted)",
                    "warning",
                )
            self.skipped_packets += 1
            return
        self._in_window += 1
        rec.mavlink(t, self.name, packet_record("in" if direction == "out" else "out", msg, raw))

    def __call__(self, step: RoverStep) -> None:
        """Show one step.

        Parameters
        ----------
        step : RoverStep
            What the step saw and did.
        """
        import numpy as np

        from lfctl.vision.draw import annotate

        t, seen, out, slot = step.t_s, step.seen, step.output, step.settings
        m = seen.measurement
        if self.sender is not None:
            frame = step.frame
            if self.cfg.live.video_annotated:
                frame = annotate(frame, seen.track, f"{self.name} {m.status.value}")
            self.sender.send(self.stream.encode(frame).data, t)
        rec = self.rec
        if rec is None:
            return
        if t - self._calibrated_at >= self._calibration_every_s:  # and again, for viewers that join later
            rec.calibration(t, self.name, self.camera)
            self._calibrated_at = t
        self._say_fix(t, step.fix is not None)
        odo = step.odometry
        rec.poses(t, (self.name,), np.array([[odo.north_m, odo.east_m]]), np.array([odo.yaw_rad]), fix=[step.fix])
        rec.camera(t, self.name, seen.track, seen.pose, m, None, self.image.encode(step.frame).data)
        payload = {
            "status": out.status.value,
            "speed_cmd_mps": round(out.speed_mps, 5),
            "yaw_rate_cmd_degps": round(math.degrees(out.yaw_rate_radps), 4),
            "range_cmd_m": slot.range_cmd_m,
            "bearing_cmd_deg": round(math.degrees(slot.bearing_cmd_rad), 4),
            "law": out.law,
        }
        if out.range_est_m is not None and out.bearing_est_rad is not None:
            # a rover has no truth: its errors are the stack's own estimate
            payload["range_error_m"] = round(out.range_est_m - slot.range_cmd_m, 5)
            payload["bearing_error_deg"] = round(math.degrees(out.bearing_est_rad - slot.bearing_cmd_rad), 4)
        rec.controller(t, self.name, payload)
        if not self._watching:  # watched, the companion's STATUSTEXT says it
            for e in step.events:
                rec.event(e.t_s, self.name, e.text, "warning" if e.kind == "lost" else "info")
        rec.serve()  # (once: after the first step has made the channels)

    def _say_fix(self, t_s: float, has_fix: bool) -> None:
        """/log says, once each time it changes, whether the rover has a global position (a
        rover that never had one: after :data:`NO_FIX_AFTER_S`, its GLOBAL_POSITION_INT may be
        on its way)."""
        assert self.rec is not None
        if self._first_step_s is None:
            self._first_step_s = t_s
        if has_fix == self._has_fix or (
            self._has_fix is None and not has_fix and t_s - self._first_step_s < NO_FIX_AFTER_S
        ):
            return
        if has_fix:
            if self._has_fix is not None:  # a first fix in time is no news
                self.rec.event(t_s, self.name, f"global position now known: LocationFix on /{self.name}/fix")
        else:
            self.rec.event(
                t_s,
                self.name,
                f"no global position from the rover (no GPS, or no EKF origin; GLOBAL_POSITION_INT "
                f"{'lost' if self._has_fix else 'at 0, 0 or not sent'}): no LocationFix on /{self.name}/fix",
                "warning",
            )
        self._has_fix = has_fix

    def close(self) -> None:
        """Stop serving and sending (saying first how many packets /mavlink skipped, if any)."""
        if self.rec is not None:
            if self.skipped_packets:
                self.rec.event(
                    self.clock(),
                    self.name,
                    f"/mavlink/{self.name} skipped {self.skipped_packets} packets (over {MAVLINK_MAX_PER_S}/s)",
                    "warning",
                )
            self.rec.close()
        if self.sender is not None:
            self.sender.close()


def _here(address: str) -> bool:
    """Whether ``address`` is one of this machine's (a socket binds to it)."""
    import socket

    family = socket.AF_INET6 if ":" in address else socket.AF_INET
    try:
        with socket.socket(family, socket.SOCK_DGRAM) as s:
            s.bind((address, 0))
    except OSError:
        return False
    return True


def _check_not_own_input(stream_to: tuple[str, int], camera: str) -> None:
    """Refuse a ``--video`` sent to what ``--camera rtp://`` reads on this machine: its port on
    its address (any of this machine's when it reads on every address), or the port after it,
    RTCP's, which FFmpeg binds on every address. The two H.264 streams would mix in one
    receiver and the tracker would see the broken frames (as in a rehearsal with both left at
    5600)."""
    import socket

    from lfctl.errors import ConfigError
    from lfctl.video import rtp_address

    if not camera.startswith("rtp://"):
        return
    try:
        at, port = rtp_address(camera)
    except ConfigError:
        return  # (the camera's own check says what is wrong with it)
    to_host, to_port = stream_to
    if to_port not in (port, port + 1):
        return
    to = to_host.strip("[]")
    try:
        if ":" not in to:
            to = socket.gethostbyname(to)
        if ":" not in at:
            at = socket.gethostbyname(at)
    except OSError:
        return
    everywhere = at in ("0.0.0.0", "::") or to_port == port + 1
    if to == at or (everywhere and _here(to)):
        raise ConfigError(
            f"--video {to_host}:{to_port} sends to what --camera {camera} reads: the two streams would mix and the "
            "tracker would see broken frames; give --video a port no stream on this machine uses (a rehearsal's "
            "take the simulator's --video port and every second one after it)"
        )


def run(args: argparse.Namespace) -> int:
    """Connect to the rover and follow until the camera ends or the limits are reached."""
    from lfctl.cli.sim import announce_live, live_address, live_layout
    from lfctl.config import load_config, parse_config
    from lfctl.data import footage_dir, resolve_footage, resolve_scenario
    from lfctl.errors import ConfigError
    from lfctl.follower.rover import follow_rover
    from lfctl.follower.stack import formation_settings
    from lfctl.link.camera import CameraComponent
    from lfctl.link.companion import Companion
    from lfctl.link.signing import signing_key_from_passphrase
    from lfctl.video import missing_source, open_live
    from lfctl.vision.banner import BannerGeometry
    from lfctl.vision.camera_model import CameraModel, at_frame_size
    from lfctl.vision.frames import colourless
    from lfctl.vision.perception import BannerPerception, banner_in_picture

    cfg = load_config(resolve_scenario(args.scenario)) if args.scenario else parse_config(DEFAULT_SCENARIO, "follow")
    args.camera = resolve_footage(args.camera)  # a shipped clip by name, as lfctl track takes it
    camera = str(args.camera)
    if not (camera.isdigit() or "://" in camera or camera.startswith("/dev/") or os.path.lexists(camera)):
        # (a camera device not there yet is waited for: a USB camera enumerating)
        raise ConfigError(missing_source(camera, footage_dir()))
    live = live_address(args.live, cfg.live.foxglove, "--live")
    stream_to = live_address(args.video, cfg.live.video, "--video")
    if args.no_camera_component and stream_to is None:
        raise ConfigError("--no-camera-component is for --video: without it no stream is sent nor announced")
    if stream_to is not None:
        _check_not_own_input(stream_to, str(args.camera))
    if not cfg.followers:
        raise ConfigError(
            f"{args.scenario}: the scenario has no follower; lfctl follow runs its first follower's stack "
            '(its slot, gains and the banner it looks for): add a [[vehicles]] entry with role = "follower"'
        )
    names = [v.name for v in cfg.followers]
    me = names[0] if args.follower is None else args.follower
    if me not in names:
        raise ConfigError(f"--follower {me!r}: the scenario's followers are {', '.join(names)}")
    slot = cfg.slots()[me]
    range_m = slot.range_m if args.range is None else args.range
    bearing_rad = slot.bearing_rad if args.bearing is None else math.radians(args.bearing)
    rate_hz = cfg.sim.guidance_rate_hz if args.rate is None else args.rate
    if not RATE_HZ[0] <= rate_hz <= RATE_HZ[1]:  # the scenario's guidance rate may be outside
        raise ConfigError(f"--rate must be within [{RATE_HZ[0]:g}, {RATE_HZ[1]:g}] Hz, got {rate_hz:g}")

    def waiting(why: str) -> None:
        end = "Ctrl-C ends" if args.camera_wait is None else f"for up to {args.camera_wait:g} s"
        log.warning("waiting for the camera: %s; trying again (%s)", why, end)

    video, first = open_live(args.camera, args.camera_wait, waiting)  # a camera's newest frame each step
    with video:
        if not video.live:
            video.unread(first)  # a file's first frame is followed too (a camera's would be old by then)
        h, w = first.shape[:2]
        try:
            camera, scaled = at_frame_size(cfg.camera, w, h)
        except ConfigError as exc:  # (its message names the scenario's key)
            raise ConfigError(
                f"camera {args.camera!r}: its frames are {w}x{h} px, which lfctl cannot take ({exc})"
            ) from None
        if scaled:
            log.warning("%s (the camera gave another size than [camera] says)", scaled)
        banner = cfg.banner_of(slot.target)  # with ArUco tags, the target's own id
        if colourless(first) and banner.kind != "aruco":
            log.warning(
                "the camera's first frame has no colour (every pixel grey: a monochrome or infrared camera?): "
                "the tracker follows the banner by its hue and saturation and will not find it"
            )
        perception = BannerPerception.from_config(camera, banner, (range_m, bearing_rad), kind=camera.tracker)
        if not banner_in_picture(perception.camera, BannerGeometry.from_config(banner), range_m, bearing_rad):
            log.warning(
                "the slot (%g m, %g deg) leaves the target's banner out of the %dx%d picture: once there "
                "the follower will not see its target (a wider lens, camera.hfov_deg, or a smaller bearing)",
                range_m,
                math.degrees(bearing_rad),
                w,
                h,
            )
        view = None
        if live is not None or stream_to is not None:
            view = LiveView(cfg, me, CameraModel.from_config(camera), live, stream_to)
            if view.rec is not None and live is not None:  # said once it serves, after the first step
                layout = live_layout(me, me, "h264", scene=False)  # its view follows the rover
                view.rec.on_serve = partial(announce_live, host=live[0], layout=layout)
        key = signing_key_from_passphrase(args.signing_passphrase)
        companion = Companion.open(args.mavlink, args.target, key)
        if view is not None:
            view.watch(companion.port)
            if view.sender is not None and stream_to is not None and not args.no_camera_component:
                camera_component = CameraComponent(
                    args.target,
                    companion.port.write,
                    video_port=stream_to[1],
                    width=w,
                    height=h,
                    fps=rate_hz,
                    bitrate_kbps=cfg.live.video_bitrate_kbps,
                    hfov_deg=math.degrees(2 * math.atan(w / 2 / perception.camera.K[0, 0])),  # (a calibration's too)
                    name=f"{me} camera",
                    signing_key=key,
                    tap=companion.camera_tap,
                )
                camera_component.on_streaming = view.streaming
                companion.offer_video(camera_component)
        # (the run's lines are the log's: without -v only warnings; say it has begun)
        print(
            f"lfctl follow: {me}'s companion for system {args.target} on {args.mavlink}, camera {args.camera}, "
            f"{rate_hz:g} Hz; Ctrl-C ends it" + ("" if args.verbose or args.debug else " (-v says more)"),
            file=sys.stderr,
            flush=True,
        )
        try:
            done = follow_rover(
                companion,
                video,
                perception,
                formation_settings(cfg, range_m, bearing_rad, cfg.guidance.controller, camera),
                rate_hz=rate_hz,
                status_rate_hz=cfg.sim.status_rate_hz,
                arm=args.arm,
                timeout_s=args.timeout,
                max_frames=args.max_frames,
                max_steps=args.steps,
                name=me,
                on_step=view,
                clock=view.clock if view is not None else None,
            )
        finally:
            companion.close()
            if view is not None:
                view.close()
    print(done.summary())
    if done.interrupted:
        raise KeyboardInterrupt  # said and ended as any command stopped so
    return 0
