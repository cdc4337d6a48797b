"""`lfctl bench`: run the benchmarks (all, or one by name)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from lfctl.bench import NAMES
from lfctl.cli.options import number

#: what each benchmark measures, for its --help (one for each of NAMES)
WHAT = {
    "cosim": "the co-simulation master against a bare fmpy loop",
    "vision": "the trackers and ArUco on the labelled real footage and the rendered tiers, with OpenCV's "
    "trackers as peers (about 6 min on 2 cores; --quick about 2)",
    "formation": "the sliding-mode follower against a proportional baseline",
    "link": "the MAVLink endpoint against a minimal pymavlink responder (--fuzz: hostile datagrams and a soak)",
    "record": "what recording costs a lockstep run, and what the video keeps",
    "e2e": "the whole product as lfctl sim runs it: real-time factor on one core and on all, the cost split",
    "sweep": "runs per minute of a sweep with 1 and with N workers",
}


def register(sub: Any) -> None:
    """Add the ``bench`` command to the parser."""
    b = sub.add_parser(
        "bench",
        help="run benchmarks (all, or one by name)",
        description=f"Run the benchmarks ({', '.join(NAMES)}); each prints a table and a JSON line. "
        "Without NAME every one runs, each in its own process, and the results are also written to "
        "bench-results.md and bench-results.json here (one benchmark by name prints only).",
        epilog="What each measures: " + "; ".join(f"{name}: {WHAT[name]}" for name in NAMES) + ".",
    )
    b.add_argument("name", nargs="?", metavar="NAME", help=f"one benchmark: {', '.join(NAMES)}")
    b.add_argument("--quick", action="store_true", help="shorter runs (for a smoke check)")
    b.add_argument(
        "--fuzz",
        action="store_true",
        help="with link: 100,000 hostile datagrams and a soak against a recording --realtime run",
    )
    b.add_argument(
        "--soak-s",
        type=number(0, 86400, lo_open=True, unit="s"),
        metavar="S",
        help="with --fuzz: the soak's length (default 600 s)",
    )
    b.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """One benchmark here, or every one in its own process."""
    from lfctl.bench import run_all, run_one
    from lfctl.errors import ConfigError, LfctlError

    if args.name is not None and args.name not in NAMES:  # '' too (an unset "$NAME"): not every benchmark
        raise ConfigError(f"unknown benchmark {args.name!r} (known: {', '.join(NAMES)})")
    if args.fuzz and args.name != "link":
        raise ConfigError("--fuzz goes with the link benchmark: lfctl bench link --fuzz")
    if args.soak_s is not None and not args.fuzz:
        raise ConfigError("--soak-s goes with --fuzz: lfctl bench link --fuzz --soak-s S")
    if args.name is not None:
        print(f"== lfctl bench {args.name}{' --fuzz' if args.fuzz else ''}", flush=True)
        run_one(args.name, args.quick, args.fuzz, args.soak_s)
        return 0
    outcomes = run_all(NAMES, args.quick, Path())
    print("wrote bench-results.md and bench-results.json")
    failed = [o.name for o in outcomes if o.result is None]
    if failed:
        raise LfctlError(f"benchmarks failed: {', '.join(failed)}")
    return 0
