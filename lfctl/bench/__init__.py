"""The benchmarks `lfctl bench` runs. Each module has ``main(quick)``, prints a Markdown
table and ends with one JSON line, and measures against a baseline in the same run; run one
with ``python -m lfctl.bench.<name>`` or ``lfctl bench <name>``."""

from __future__ import annotations

import contextlib
import importlib
import json
import os
import signal
import stat
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from lfctl.checks import printable, save_text, target_mode
from lfctl.errors import ConfigError

__all__ = ["NAMES", "BenchOutcome", "run_all", "run_one"]

#: every benchmark, in the order `lfctl bench` runs them
NAMES = ("cosim", "vision", "formation", "link", "record", "e2e", "sweep")


@dataclass(frozen=True)
class BenchOutcome:
    """One benchmark run as a child process: its table, its JSON result or why it failed."""

    name: str  # the benchmark (one of NAMES)
    table: list[str]  # what it printed before its JSON line (its Markdown table)
    result: dict[str, object] | None  # its JSON line, parsed; None when it failed
    error: str = ""  # why it failed ("" when it did not)


def run_one(name: str, quick: bool = False, fuzz: bool = False, soak_s: float | None = None) -> None:
    """Run one benchmark in this process (its output is the result).

    Parameters
    ----------
    name : str
        One of :data:`NAMES`.
    quick : bool
        Shorter runs, for a smoke check.
    fuzz : bool
        ``link`` only: the fuzz and soak benchmark (:mod:`lfctl.bench.link_fuzz`) instead.
    soak_s : float, optional
        With ``fuzz``: the soak's length, s.
    """
    if fuzz:
        from lfctl.bench import link_fuzz

        link_fuzz.main(quick, soak_s)
        return
    importlib.import_module(f"lfctl.bench.{name}").main(quick)


def _run_child(name: str, quick: bool) -> BenchOutcome:
    cmd = [sys.executable, "-m", f"lfctl.bench.{name}", *(["--quick"] if quick else [])]
    # in a session of its own, with whatever it starts (vision's pool, e2e's cameras, sweep's
    # workers): a Ctrl-C reaches it once, from here, and nothing it started outlives it
    with (
        _hangup_stops(),
        subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
        ) as child,
    ):
        try:
            stdout, stderr = child.communicate()
        except BaseException:  # Ctrl-C, SIGTERM (lfctl's KeyboardInterrupt) or SIGHUP
            _stop_child(child)
            raise
    proc = subprocess.CompletedProcess(cmd, child.returncode, stdout, stderr)
    print(proc.stdout, end="", flush=True)
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines or not lines[-1].startswith("{"):
        # its last line (a traceback's is the error), not the whole of it
        last = printable(proc.stderr.strip().splitlines()[-1]) if proc.stderr.strip() else "no JSON line"
        print(
            f"lfctl bench {name} failed (exit {proc.returncode}): {last}; "
            f"`lfctl --debug bench {name}{' --quick' if quick else ''}` shows all",
            file=sys.stderr,
        )
        return BenchOutcome(name, lines, None, f"exit {proc.returncode}: {last}")
    return BenchOutcome(name, lines[:-1], json.loads(lines[-1]))


@contextlib.contextmanager
def _hangup_stops() -> Iterator[None]:
    """SIGHUP (the terminal closed, the shell passing it to its jobs) stops the benchmark as
    Ctrl-C does: in a session of its own it hears no hangup, and ran on with nobody to read it."""

    def hangup(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGHUP, hangup)
    except ValueError:  # (not the main thread: its signals are not ours to take)
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGHUP, previous)


#: how long a benchmark stopped by Ctrl-C may take to end (its pool's jobs running, its
#: cluster closing) before it and what it started are killed, s
STOP_S = 30.0


def _stop_child(child: subprocess.Popen[str]) -> None:
    """Stop a benchmark's process as a Ctrl-C would (SIGINT to its process group), give it
    :data:`STOP_S` to end, reading what it writes meanwhile (a full pipe would hold it, its
    workers' tracebacks say, until the kill), then kill whatever of its group is left: a
    process it started that outlived it (a pool worker waiting for its next job) would run
    on for ever. (subprocess.run killed the benchmark alone after 0.25 s, which left
    vision's pool workers blocked on their queue.)"""
    try:
        with contextlib.suppress(ProcessLookupError, subprocess.TimeoutExpired):
            os.killpg(child.pid, signal.SIGINT)
            child.communicate(timeout=STOP_S)
    finally:
        with contextlib.suppress(ProcessLookupError):  # (all of it ended)
            os.killpg(child.pid, signal.SIGKILL)
        child.wait()


def run_all(names: tuple[str, ...] = NAMES, quick: bool = False, out_dir: Path = Path()) -> list[BenchOutcome]:
    """Run benchmarks one by one, each in its own process, and write ``bench-results.md`` and
    ``bench-results.json`` in ``out_dir``.

    Parameters
    ----------
    names : tuple of str
        Which benchmarks.
    quick : bool
        Shorter runs.
    out_dir : Path
        Where the result files go.
    """
    md_path, json_path = out_dir / "bench-results.md", out_dir / "bench-results.json"
    for path in (md_path, json_path):  # before an hour of benchmarks, not after
        _check_result_file(path)
    outcomes = []
    for name in names:
        print(f"== lfctl bench {name}", flush=True)
        outcomes.append(_run_child(name, quick))
    md = ["# lfctl bench results", ""]
    for o in outcomes:
        md += [f"## {o.name}", "", *(o.table if o.result is not None else [f"FAILED ({o.error})"]), ""]
    save_text(md_path, "\n".join(md) + "\n")
    results = {o.name: o.result for o in outcomes if o.result is not None}
    save_text(json_path, json.dumps(results, indent=1) + "\n")
    return outcomes


def _check_result_file(path: Path) -> None:
    """A results file can be written: absent, a regular file (through a link) or a device
    (``/dev/null``), in a folder this process may write in; a ConfigError naming it otherwise
    (a folder, a named pipe, whose write would block until someone reads it)."""
    mode = target_mode(path)
    if mode is not None and not (stat.S_ISREG(mode) or stat.S_ISCHR(mode)):  # a device (/dev/null) is written
        raise ConfigError(
            f"{path} is not a regular file: lfctl bench writes its results there (move it, or run elsewhere)"
        )
    folder = path.resolve().parent
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ConfigError(f"cannot write {path}: the folder {folder} is not writable")
