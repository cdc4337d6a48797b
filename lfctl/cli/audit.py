"""`lfctl audit`: check a run's MCAP log; `--plot`, `--recover`."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any


def register(sub: Any) -> None:
    """Add the ``audit`` command to the parser."""
    a = sub.add_parser(
        "audit",
        help="check a run's MCAP log: integrity, provenance, formation/link/mission figures",
        description="Audit an MCAP run log. Exit 0 when intact (and, with --strict, within the scenario's limits), 1 otherwise.",
    )
    a.add_argument("file", type=Path, help="an .mcap log (logs/<run>.mcap)")
    a.add_argument("--json", action="store_true", help="machine-readable report")
    a.add_argument("--plot", type=Path, metavar="DIR", help="write PNG plots here")
    a.add_argument("--strict", action="store_true", help="also fail when the scenario's [audit] limits are exceeded")
    a.add_argument("--recover", type=Path, metavar="OUT", help="write every intact record into a new, finished file")
    a.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Audit the file; print the report (or JSON); plot and recover when asked."""
    from lfctl.errors import ConfigError
    from lfctl.record.audit import audit, check_thresholds, format_report, plot, recover

    if not args.file.exists():
        raise ConfigError(f"{args.file} does not exist")
    report = audit(args.file)
    if args.strict:
        report.findings.extend(check_thresholds(report))
    if args.json:
        print(
            json.dumps(
                {
                    "file": report.path,
                    "ok": report.ok,
                    "findings": [f.__dict__ for f in report.findings],
                    "figures": report.figures,
                },
                indent=1,
            )
        )
    else:
        print(format_report(report))
    if args.plot:
        for p in plot(report, args.plot):
            print(f"plot: {p}", file=sys.stderr)
    if args.recover:
        n = recover(report, args.recover)
        print(f"recovered {n} messages into {args.recover}", file=sys.stderr)
    return 0 if report.ok else 1
