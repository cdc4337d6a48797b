"""`lfctl sweep`: run a sweep of many runs on Dask; `lfctl sweep report DIR` rebuilds its
summary and plots from its results table."""

from __future__ import annotations

import argparse
import json
import logging
import signal
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from lfctl.cli import quiet_stdout, stop_exit_code, stopped_by
from lfctl.cli.options import command, counted, integer
from lfctl.data import example_names
from lfctl.errors import LfctlError

if TYPE_CHECKING:
    from lfctl.sweep.engine import SweepProgress
    from lfctl.sweep.results import SweepSummary


class _DaskCommUnread(logging.Filter):
    """Drops asyncio's "exception was never retrieved" for a Dask or Tornado comm's error (a
    cluster's connections cut by an interrupt); passes every other record."""

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        if exc is None or "exception was never retrieved" not in str(record.msg):
            return True
        return type(exc).__module__.split(".")[0] not in ("distributed", "tornado")


def register(sub: Any) -> None:
    """Add the ``sweep`` command to the parser."""
    s = sub.add_parser(
        "sweep",
        help="run many variants of a scenario on Dask (local cores or a cluster); `sweep report DIR`",
        description="Run a sweep file (or a shipped sweep by name: "
        f"{', '.join(example_names('.toml', 'sweeps')) or 'none found'}) on a Dask LocalCluster "
        "(one worker process per core) or a running scheduler, writing one row per run (Parquet and CSV), a "
        "summary per variant with 95 % confidence intervals, and plots. `lfctl sweep report DIR` rebuilds the "
        "summary and plots of a sweep's folder from its rows.",
    )
    s.add_argument("sweep", metavar="SWEEP", help="sweep TOML file or a shipped sweep's name; or `report`")
    s.add_argument("dir", nargs="?", metavar="DIR", help="with `report`: the sweep's folder")
    where = s.add_mutually_exclusive_group()
    where.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="a running Dask scheduler, tcp://HOST:8786 or HOST:8786 (default: a local cluster)",
    )
    where.add_argument(
        "--scheduler-file",
        metavar="FILE",
        help="the file a Dask scheduler writes its address to (dask scheduler --scheduler-file FILE; "
        "dask-jobqueue, dask-mpi), waited for up to 60 s",
    )
    s.add_argument(
        "--workers",
        type=integer(1, 10**6),
        metavar="N",
        help="local worker processes (default: one per core; at most the runs left and 4 a core, said when "
        "capped); with --scheduler or --scheduler-file, wait for N workers to join",
    )
    s.add_argument("--out", metavar="DIR", help="the sweep's folder (default: sweeps/<name>)")
    s.add_argument("--resume", action="store_true", help="finish the sweep in --out: skip runs it has rows for")
    s.add_argument(
        "--logs",
        choices=("none", "failed", "all"),
        default="none",
        help="MCAP logs to keep in DIR/logs: none (default), failed (every run records, the logs of runs that "
        "succeed are deleted), all",
    )
    s.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=run)


def _runs_left(p: Any, out_dir: Path, args: argparse.Namespace) -> bool:
    """Runs are left to do (a ``--resume`` of a finished sweep has none: it waits for no
    scheduler). A journal that cannot be read counts as runs left: the sweep says why."""
    if not args.resume:
        return True
    from lfctl.sweep.results import read_journal

    try:
        done = {r.get("run") for r in read_journal(out_dir)}
    except (OSError, LfctlError):
        return True
    return any(r.run not in done for r in p.runs)


def _duration(seconds: float | None) -> str:
    if seconds is None:
        return "?"
    m, s = divmod(int(round(seconds)), 60)
    h, m = divmod(m, 60)
    return f"{h}h{m:02d}m" if h else (f"{m}m{s:02d}s" if m else f"{s}s")


def _bar(state: SweepProgress) -> str:
    finished = state.skipped + state.done
    width = 24
    filled = int(width * finished / state.total) if state.total else width
    line = (
        f"\r[{'#' * filled}{'.' * (width - filled)}] {finished}/{state.total} runs  {state.failed} failed  "
        f"{state.rate_per_min:.1f} runs/min  ETA {_duration(state.eta_s)}"
    )
    if state.stopping:
        line += f"  stopping: {state.running} running (Ctrl-C again cancels them)"
    return line + "\033[K"


def _print_summary(summary: SweepSummary, out: TextIO) -> None:
    print(summary.markdown, file=out)
    plots = [f for f in summary.files if f.suffix == ".png"]
    tables = [f.name for f in summary.files if f.suffix != ".png"]
    if summary.files:
        folder = summary.files[0].parent
        print(f"results      {folder}/: {', '.join(tables)}", file=out)
        if plots:
            print(f"plots        {plots[0].parent}/ ({len(plots)} PNG)", file=out)


def run(args: argparse.Namespace) -> int:
    """Run the sweep (or rebuild a report); print the summary."""
    from lfctl.errors import ConfigError

    if args.sweep == "report":
        if args.dir is None:
            raise ConfigError("lfctl sweep report needs the sweep's folder: lfctl sweep report DIR")
        from lfctl.sweep.results import report

        _print_summary(report(args.dir), sys.stdout)
        return 0
    if args.dir is not None:
        raise ConfigError(f"unexpected argument {args.dir!r}: a sweep's folder is given with --out")
    from lfctl.sweep.engine import run_sweep
    from lfctl.sweep.spec import load_sweep, plan

    if not args.debug:  # Dask reports each worker's start and stop; a dead one is the sweep's to report, as a row
        import distributed  # noqa: F401  (its logging settings first: they give loggers under it levels of their own)

        for name in ["distributed", *logging.root.manager.loggerDict]:  # (distributed.client: WARNING)
            if name.split(".")[0] == "distributed":
                logging.getLogger(name).setLevel(logging.CRITICAL)
        # a cluster interrupted while it starts leaves its comms' futures failed and unread,
        # which asyncio reports with a traceback as they are collected (after "lfctl:
        # interrupted"): those, and only those, are kept back
        asyncio_log = logging.getLogger("asyncio")
        if not any(isinstance(f, _DaskCommUnread) for f in asyncio_log.filters):
            asyncio_log.addFilter(_DaskCommUnread())

    p = plan(load_sweep(args.sweep))  # every variant is built and checked before anything runs
    out_dir = Path(args.out) if args.out else Path("sweeps") / p.spec.name
    pipe = not sys.stdout.isatty()  # a pipe gets one JSON line per run; people get the text
    human = sys.stderr if pipe else sys.stdout
    show_bar = not args.quiet and sys.stderr.isatty()
    spec = p.spec
    sizes = (
        counted(len(p.variants), "variant"),
        counted(len(spec.seeds), "seed"),
        counted(spec.repetitions, "repetition"),
    )
    print(
        f"sweep        {spec.name}: {' x '.join(sizes)} = {counted(len(p.runs), 'run')}  ({spec.scenario.name})",
        file=human,
    )
    print(f"folder       {out_dir}", file=human, flush=True)
    if args.scheduler_file is not None and not Path(args.scheduler_file).exists() and _runs_left(p, out_dir, args):
        from lfctl.sweep.engine import WORKERS_WAIT_S

        print(
            f"scheduler    waiting for {args.scheduler_file} to be written (up to {WORKERS_WAIT_S:g} s)",
            file=human,
            flush=True,
        )

    announced, stopping, reader_gone = threading.Event(), threading.Event(), threading.Event()

    def progress(state: SweepProgress, row: dict[str, Any] | None) -> None:
        if not announced.is_set():
            announced.set()
            print(f"engine       {state.engine}", file=human, flush=True)
        if state.stopping and not stopping.is_set() and not show_bar:  # the bar says it itself
            stopping.set()
            print(
                f"stopping     no more runs start; {state.running} running finish (Ctrl-C again cancels them)",
                file=sys.stderr,
                flush=True,
            )
        if row is not None and pipe and not reader_gone.is_set():
            try:
                print(json.dumps(row, default=str), flush=True)
            except BrokenPipeError:  # `lfctl sweep ... | head`: stop as on Ctrl-C, the folder whole
                quiet_stdout()
                reader_gone.set()
                stopped_by(signal.SIGPIPE)
                requested.set()
                print("stdout       its reader left (a closed pipe): the sweep stops", file=sys.stderr, flush=True)
        if show_bar:
            print(_bar(state), end="", file=sys.stderr, flush=True)

    # Ctrl-C / SIGTERM: stop submitting and let running runs finish; a second one cancels them
    # (the engine acts on it between rows, so each row in the folder has also been printed);
    # a third interrupts whatever is going on (a cluster still starting, say)
    requested, cancelled = threading.Event(), threading.Event()

    def ask_stop(signum: int, frame: object) -> None:
        stopped_by(signum)
        if cancelled.is_set():
            raise KeyboardInterrupt
        (cancelled if requested.is_set() else requested).set()

    handlers = {sig: signal.signal(sig, ask_stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        result = run_sweep(
            p,
            out_dir,
            scheduler=args.scheduler,
            scheduler_file=args.scheduler_file,
            workers=args.workers,
            resume=args.resume,
            logs=args.logs,
            progress=progress,
            stop=requested.is_set,
            cancel=cancelled.is_set,
        )
    except KeyboardInterrupt:
        if show_bar:
            print(file=sys.stderr)
        if (out_dir / "sweep.json").exists():
            what = "cancelled the running runs" if cancelled.is_set() else "interrupted"
            print(f"{what}; the finished runs are in {out_dir} (--resume goes on)", file=sys.stderr)
        else:
            print("interrupted before the sweep began: nothing was written", file=sys.stderr)
        raise
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)
    if show_bar:
        print(file=sys.stderr)
    print(file=human)
    _print_summary(result.summary, human)
    for r in result.failed[:10]:
        print(
            f"failed       run {r['run']} (variant {r['variant']}, seed {r['seed']}): {r['status']}: {r['error']}",
            file=human,
        )
    if len(result.failed) > 10:
        print(f"failed       ... {len(result.failed) - 10} more (runs.csv: status, error)", file=human)
    if result.stopped:
        print(
            f"stopped      {len(result.rows)} of {len(p.runs)} runs have rows; "
            f"`{command('lfctl', 'sweep', args.sweep, '--out', out_dir, '--resume')}` finishes the sweep",
            file=human,
        )
    if result.stopped or reader_gone.is_set():  # (its reader gone at the last row: not every row was read)
        return stop_exit_code()
    return 1 if result.failed else 0
