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
    from lfctl.cli.options import integer, whole_path
    from lfctl.data import docs_dir
    from lfctl.record.mcap_read import MAX_MESSAGES

    a = sub.add_parser(
        "audit",
        help="check a run's MCAP log: integrity, provenance, formation/link/mission figures",
        description="Audit an MCAP run log. Exit 0 when intact (and, with --strict, within the scenario's limits), "
        f"1 otherwise, 2 when the path is not a regular file. Reading is bounded ({whole_path(docs_dir() / 'audit.md')}).",
    )
    a.add_argument("file", type=Path, help="an .mcap log (logs/<run>.mcap)")
    a.add_argument("--json", action="store_true", help="machine-readable report")
    a.add_argument("--plot", type=Path, metavar="DIR", help="write PNG plots here")
    a.add_argument("--strict", action="store_true", help="also fail when the scenario's [audit] limits are exceeded")
    a.add_argument("--recover", type=Path, metavar="OUT", help="write every intact record into a new, finished file")
    a.add_argument(
        "--max-messages",
        type=integer(1, 10**9),
        default=MAX_MESSAGES,
        metavar="N",
        help=f"read at most N messages (default {MAX_MESSAGES:,}: a one-follower camera run logs about 1.1 million "
        "an hour; memory grows by about 0.6 KB a message)",
    )
    a.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Audit the file; print the report (or JSON); plot and recover when asked."""
    from lfctl.errors import ConfigError
    from lfctl.record.audit import (
        audit,
        check_thresholds,
        format_report,
        plot,
        recover,
        recover_target_problem,
        run_values,
    )
    from lfctl.record.mcap_read import ReadLimits, regular_file_problem

    if not args.file.exists() and not args.file.is_symlink():
        raise ConfigError(f"{args.file} does not exist")
    problem = regular_file_problem(args.file)  # a FIFO would block, a directory cannot be read
    if problem:
        raise ConfigError(problem)
    if args.plot is not None and args.plot.exists() and not args.plot.is_dir():
        raise ConfigError(f"--plot {args.plot}: not a directory")
    problem = recover_target_problem(args.recover, args.file) if args.recover is not None else None
    if problem:  # said before a long audit
        raise ConfigError(f"--recover {args.recover}: {problem}")
    made = _make_folder(args.plot) if args.plot is not None else []
    plotted: list[Path] = []
    try:
        report = audit(args.file, ReadLimits(messages=args.max_messages))
        # --strict's limits are a section of their own: a run outside them is not a broken log
        limits = check_thresholds(report) if args.strict else None
        limits_ok = limits is None or not any(f.level == "error" for f in limits)
        if args.json:
            doc = {
                "file": report.path,
                "ok": report.ok and limits_ok,
                "findings": [f.__dict__ for f in report.findings],
                "figures": {**report.figures, "run": run_values(report.figures.get("run") or {})},
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
            plotted = plot(report, args.plot)
            for p in plotted:
                print(f"plot: {p}", file=sys.stderr)
            if not plotted:
                print(f"no plots: nothing readable in {args.file}", file=sys.stderr)
    finally:
        if not plotted:  # the folders made for plots that never came (none, an error, Ctrl-C)
            for folder in reversed(made):
                with contextlib.suppress(OSError):  # (something else put a file there meanwhile)
                    folder.rmdir()
    if args.recover:
        n = recover(report, args.recover)
        print(f"recovered {n} messages into {args.recover}", file=sys.stderr)
    return 0 if report.ok and limits_ok else 1


def _make_folder(folder: Path) -> list[Path]:
    """Make ``folder`` and the folders above it that are missing, now, so one that cannot be
    is said before a long audit; the folders made, from the top down."""
    from lfctl.errors import ConfigError

    missing = [f for f in (folder, *folder.parents) if not f.exists()][::-1]
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"--plot {folder}: cannot make the folder ({exc.strerror or exc})") from None
    return missing
