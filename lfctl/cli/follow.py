"""`lfctl follow`: the follower stack as a real rover's companion computer."""

from __future__ import annotations

import argparse
import dataclasses
import math
from pathlib import Path
from typing import Any

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
        "--mavlink", required=True, help="connection to the rover, e.g. udpout:ROVER_IP:14550 or /dev/ttyUSB0,921600"
    )
    fo.add_argument("--camera", default="0", help="camera index, video file or stream URL (default 0)")
    fo.add_argument("--target", type=int, default=1, help="the rover's system id (default 1)")
    fo.add_argument(
        "--scenario", type=Path, help="camera intrinsics and mount, banner, gains and rates from this scenario"
    )
    fo.add_argument("--range", type=float, help="commanded range to the leader, m (default: the scenario's slot, 1.5)")
    fo.add_argument("--bearing", type=float, help="commanded bearing to the leader, deg (default: the scenario's, 0)")
    fo.add_argument("--rate", type=float, help="setpoint rate, Hz (default: the scenario's sim.guidance_rate_hz, 20)")
    fo.add_argument("--arm", action="store_true", help="also arm the rover (default: you arm it)")
    fo.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for the rover's heartbeat")
    fo.add_argument("--signing-passphrase", help="MAVLink 2 signing: the passphrase the rover's key was set up with")
    fo.add_argument("--max-frames", type=int, help="stop after this many camera frames")
    fo.add_argument("--steps", type=int, help="stop after this many setpoints")
    fo.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Connect to the rover and follow until the camera ends or the limits are reached."""
    from lfctl.config import load_config, parse_config
    from lfctl.errors import ConfigError
    from lfctl.follower.rover import follow_rover
    from lfctl.follower.stack import formation_settings
    from lfctl.link.companion import Companion
    from lfctl.link.signing import signing_key_from_passphrase
    from lfctl.video import VideoSource
    from lfctl.vision.perception import BannerPerception

    cfg = load_config(args.scenario) if args.scenario else parse_config(DEFAULT_SCENARIO, "follow")
    slot = cfg.slots()[cfg.followers[0].name]
    range_m = slot.range_m if args.range is None else args.range
    bearing_rad = slot.bearing_rad if args.bearing is None else math.radians(args.bearing)
    rate_hz = cfg.sim.guidance_rate_hz if args.rate is None else args.rate
    if not 0 < rate_hz <= 100:
        raise ConfigError(f"--rate must be within (0, 100] Hz, got {rate_hz:g}")
    with VideoSource(args.camera) as video:
        first = video.read()
        if first is None:
            raise ConfigError(f"camera {args.camera!r} gave no frame")
        h, w = first.shape[:2]
        camera = dataclasses.replace(cfg.camera, width_px=w, height_px=h)
        perception = BannerPerception.from_config(camera, cfg.banner, (range_m, bearing_rad), kind=camera.tracker)
        companion = Companion.open(args.mavlink, args.target, signing_key_from_passphrase(args.signing_passphrase))
        try:
            done = follow_rover(
                companion,
                video,
                perception,
                formation_settings(cfg, range_m, bearing_rad, cfg.guidance.controller),
                rate_hz=rate_hz,
                status_rate_hz=cfg.sim.status_rate_hz,
                arm=args.arm,
                timeout_s=args.timeout,
                max_frames=args.max_frames,
                max_steps=args.steps,
                name=cfg.followers[0].name,
            )
        finally:
            companion.close()
    print(f"sent {done.steps} setpoints; {done.frames} frames")
    return 0
