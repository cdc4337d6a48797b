"""`lfctl audit`: check a run's MCAP log; `--plot`, `--recover`."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from pathlib import Path
from typing import Any


def register(sub: Any) -> None:
    """Add the ``audit`` command to the parser."""
    a = sub.add_parser(
        "audit",
        help="check a run's MCAP log: integrity, provenance, formation/link/mission figures",
        description="Audit an MCAP run log. Exit 0 when intact (and, with --strict, within the scenario's limits), "
        "1 otherwise, 2 when the path is not a regular file. Reading is bounded (docs/audit.md).",
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
    from lfctl.record.audit import audit, check_thresholds, format_report, plot, recover, recover_target_problem
    from lfctl.record.mcap_read import regular_file_problem

    if not args.file.exists() and not args.file.is_symlink():
        raise ConfigError(f"{args.file} does not exist")
    problem = regular_file_problem(args.file)  # a FIFO would block, a directory cannot be read
    if problem:
        raise ConfigError(problem)
    if args.plot is not None and args.plot.exists() and not args.plot.is_dir():
        raise ConfigError(f"--plot {args.plot}: not a directory")
    made_plot_dir = False
    if args.plot is not None and not args.plot.exists():
        # made now, so a folder that cannot be is said before a long audit (removed again
        # below if nothing is plotted into it)
        try:
            args.plot.mkdir(parents=True)
        except OSError as exc:
            raise ConfigError(f"--plot {args.plot}: cannot make the folder ({exc.strerror or exc})") from None
        made_plot_dir = True
    problem = recover_target_problem(args.recover, args.file) if args.recover is not None else None
    if problem:  # said before a long audit
        raise ConfigError(f"--recover {args.recover}: {problem}")
    report = audit(args.file)
    # --strict's limits are a section of their own: a run outside them is not a broken log
    limits = check_thresholds(report) if args.strict else None
    limits_ok = limits is None or not any(f.level == "error" for f in limits)
    if args.json:
        doc = {
            "file": report.path,
            "ok": report.ok and limits_ok,
            "findings": [f.__dict__ for f in report.findings],
            "figures": report.figures,
        }
        if limits is not None:
            doc["limits"] = [f.__dict__ for f in limits]
        print(json.dumps(doc, indent=1))
    else:
        print(format_report(report))
        if limits is not None:
            print("limits (--strict): " + ("OK" if limits_ok else "FAILED"))
            print("\n".join(f"  {f.line()}" for f in limits) or "  within the scenario's [audit] limits")
    if args.plot:
        made = plot(report, args.plot)
        for p in made:
            print(f"plot: {p}", file=sys.stderr)
        if not made:
            print(f"no plots: nothing readable in {args.file}", file=sys.stderr)
            if made_plot_dir:
                with contextlib.suppress(OSError):  # (something else put a file there meanwhile)
                    args.plot.rmdir()
    if args.recover:
        n = recover(report, args.recover)
        print(f"recovered {n} messages into {args.recover}", file=sys.stderr)
    return 0 if report.ok and limits_ok else 1
