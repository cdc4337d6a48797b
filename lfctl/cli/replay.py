"""`lfctl replay`: a tracker on a log's recorded camera frames, scored against the truth."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from lfctl.cli.options import TRACKER_KINDS, command, name


def register(sub: Any) -> None:
    """Add the ``replay`` command to the parser."""
    rp = sub.add_parser(
        "replay",
        help="re-run a tracker on a log's recorded camera frames and compare",
        description="Decode the recorded camera frames and run a tracker on them; compare with the recorded track and the truth.",
    )
    rp.add_argument("file", type=Path, help="an .mcap log recorded with sensing = 'camera'")
    rp.add_argument("--tracker", choices=tuple(TRACKER_KINDS), default="full", help="tracker to replay (default: full)")
    rp.add_argument("--follower", type=name, help="which follower's camera (default: the first)")
    rp.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Replay and print both success rates."""
    from lfctl.record.replay import MIN_VISIBLE, replay

    r = replay(args.file, TRACKER_KINDS[args.tracker], args.follower)
    print(f"replayed {r.frames} frames of {r.follower} from {args.file}")
    scored = f"(IoU >= 0.5 on {r.scored} frames with at least {MIN_VISIBLE:.0%} of the banner visible)"
    if r.recorded_success is None:
        print(f"  recorded tracker: none (its companion tracked these frames outside the simulator)  {scored}")
    else:
        print(f"  recorded tracker (full):  success {r.recorded_success:.3f}  {scored}")
    print(f"  replayed tracker ({args.tracker}): success {r.replayed_success:.3f}")
    recorded = f"recorded {r.recorded_markers:.3f}, " if r.recorded_markers is not None else ""
    print(f"  four markers found: {recorded}replayed {r.replayed_markers:.3f}")
    if r.unreadable:
        print(f"  skipped {r.unreadable} recorded images that do not decode (or differ in size)")
    if r.truncated:
        print(
            f"  the log is truncated (not finished): these are the frames before the cut (`{command('lfctl', 'audit', args.file)}`)"
        )
    if r.damaged:
        print(
            "  the log is damaged (a chunk skipped, a record passed over, or bytes after its end: "
            f"`{command('lfctl', 'audit', args.file)}` says where): these are the frames that could be read"
        )
    return 0
