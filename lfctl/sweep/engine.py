"""Running a sweep on Dask: a ``LocalCluster`` (one worker process per core, one thread each)
or a running scheduler (``tcp://HOST:8786``).

Runs are submitted as workers free up (as many in flight as the cluster has threads), so a
stop request holds back everything not yet started. Each finished run's row is appended to
the folder's journal at once; at the end (or on a stop, or a cancel) the results table,
summary and plots are written from every row in the folder.

- A run that raises is a row with status ``error`` (the task catches it; the sweep goes on).
- A run whose worker dies is retried on another worker by the scheduler; the local cluster
  retries once (``distributed.scheduler.allowed-failures = 1``), a scheduler of your own as
  its configuration says (Dask's default is 3). When the retries are spent the row says
  ``crashed``.
- ``stop()`` true: nothing more is submitted, running runs finish, their rows are written.
- ``cancel()`` true (the CLI's second Ctrl-C), or a ``KeyboardInterrupt``: running runs are
  cancelled, finished rows written, and ``KeyboardInterrupt`` goes on up. ``cancel`` is asked
  between rows, so every row in the journal has also been given to ``progress``; an
  interrupt raised at any moment can land between the two.
- ``resume``: runs with a row in the folder's journal are skipped; the folder must hold the
  same sweep (same plan digest) run by the same lfctl code.

Every worker must import the same lfctl as this process (checked by a digest of its code
and vehicle models); logs are written by the workers under the sweep's folder, so on a
cluster that folder must be on a shared file system.
"""

from __future__ import annotations

import collections
import contextlib
import json
import logging
import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import tomllib
import uuid
from collections.abc import Callable, Iterator
from concurrent.futures import CancelledError
from dataclasses import dataclass, field
from multiprocessing import resource_tracker
from pathlib import Path
from typing import Any

from distributed import WorkerPlugin

from lfctl import __version__
from lfctl.data import loaded_code
from lfctl.errors import ConfigError, LfctlError
from lfctl.sim.camera_pool import usable_cores
from lfctl.sweep.results import (
    JOURNAL,
    SweepSummary,
    append_row,
    read_journal,
    read_meta,
    report,
    write_meta,
    write_tables,
)
from lfctl.sweep.spec import Run, SweepPlan, SweepSpec, load_sweep, plan
from lfctl.sweep.task import LOG_MODES, execute, failed_row, log_name

__all__ = [
    "QUIET_WORKERS",
    "SweepProgress",
    "SweepResult",
    "local_cluster",
    "run_sweep",
    "scheduler_address",
    "scheduler_processes",
    "worker_environment",
]

log = logging.getLogger("lfctl.sweep")

#: how often the loop wakes without a finished run (progress, stop requests), s
_TICK_S = 0.5
#: Dask settings of the workers lfctl starts (the local cluster, :func:`scheduler_processes`):
#: what feeds only the dashboard, off or slower. Dask's statistical profiler samples the
#: running task's stack every 10 ms and its event loop ticks every 20 ms and reads the
#: system's counters every 0.5 s; beside a CPU-bound run a worker's event loop took about
#: 6 % of a core with the defaults and 1 % with these (8 convoy runs of 2 s each, its
#: process's CPU time less the run's thread's). The same settings suit a cluster of one's
#: own; :func:`worker_environment` gives them as environment variables.
QUIET_WORKERS: dict[str, object] = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
}


def worker_environment(settings: dict[str, object] | None = None) -> dict[str, str]:
    """Dask settings as the environment variables a ``dask worker`` reads
    (``DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False``, ...).

    Parameters
    ----------
    settings : dict, optional
        Dotted Dask keys and their values (default :data:`QUIET_WORKERS`).
    """
    items = (QUIET_WORKERS if settings is None else settings).items()
    return {"DASK_" + "__".join(k.replace("-", "_").upper() for k in key.split(".")): str(v) for key, v in items}


@contextlib.contextmanager
def scheduler_processes(
    n_workers: int, allowed_failures: int = 1, timeout_s: float = 60.0, scheduler_file: str | Path | None = None
) -> Iterator[str]:
    """A ``dask scheduler`` and ``dask worker`` processes (``n_workers``, one thread each) on
    127.0.0.1, started as a cluster's would be; yields the scheduler's address and stops
    them on exit. They end by themselves if this process dies (idle and death timeouts).
    For trying ``--scheduler`` on one machine, and for the tests and the benchmark.

    Parameters
    ----------
    n_workers : int
        Worker processes.
    allowed_failures : int
        The scheduler's ``distributed.scheduler.allowed-failures``: retries of a task whose
        worker died.
    timeout_s : float
        How long to wait for the scheduler and every worker, s.
    scheduler_file : str or Path, optional
        Where the scheduler writes its address (``--scheduler-file``; it removes the file
        when it stops); default a file in a folder of its own.

    Raises
    ------
    LfctlError
        They did not come up in time.
    """
    from distributed import Client

    env = {
        **os.environ,
        **worker_environment({**QUIET_WORKERS, "distributed.scheduler.allowed-failures": allowed_failures}),
    }
    dask = [sys.executable, "-m", "dask"]
    quiet = {"env": env, "stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    procs: list[subprocess.Popen[bytes]] = []
    with tempfile.TemporaryDirectory(prefix="lfctl-dask-") as tmp:
        file = Path(scheduler_file) if scheduler_file is not None else Path(tmp) / "scheduler.json"
        try:
            procs.append(
                subprocess.Popen(
                    [*dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                     "--scheduler-file", str(file), "--idle-timeout", "600"],
                    **quiet,
                )
            )  # fmt: skip
            try:  # (its file is read again while the scheduler is writing it; a scheduler that ended stops the wait)
                address = scheduler_address(file, stop=lambda: procs[0].poll() is not None, wait_s=timeout_s)
            except LfctlError:
                address = None
            if address is None:
                raise LfctlError(f"dask scheduler did not start within {timeout_s:g} s")
            procs.append(
                subprocess.Popen(
                    [*dask, "worker", address, "--nworkers", str(n_workers), "--nthreads", "1",
                     "--host", "127.0.0.1", "--no-dashboard", "--death-timeout", "60"],
                    **quiet,
                )
            )  # fmt: skip
            with Client(address, timeout=f"{timeout_s}s") as client:
                try:
                    client.wait_for_workers(n_workers, timeout=timeout_s)
                except TimeoutError:
                    raise LfctlError(f"{n_workers} dask workers did not join within {timeout_s:g} s") from None
            yield address
        finally:
            for p in reversed(procs):
                p.terminate()
            for p in reversed(procs):
                try:
                    p.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()


#: this process's lfctl code as it was imported: the digest of the sources when this module
#: was (a worker that imported other code says so after the files have been put back)
_LOADED_CODE = loaded_code()
#: how long the scheduler may leave the sweep's question (its workers' threads) unanswered
#: before the sweep takes it for gone, s
SCHEDULER_SILENT_S = 20.0


def _worker_identity() -> tuple[str, str, str]:
    """On a worker: lfctl's version, its code digest as imported, and where it was imported
    from. Importing what a run needs here keeps the imports out of the first run's time."""
    import cv2  # noqa: F401

    import lfctl.sweep.task  # noqa: F401

    return __version__, _LOADED_CODE, str(Path(__file__).resolve().parents[1])


class OtherCode(LfctlError):
    """A run reached a worker whose lfctl is not the sweep's (one that joined after the
    start's check, or a restarted one that imported other files)."""

    def __init__(self, worker: str, identity: tuple[str, str, str]) -> None:
        super().__init__(worker, identity)
        self.worker, self.identity = worker, identity

    def __str__(self) -> str:
        version, code, where = self.identity
        return f"{self.worker} (lfctl {version}, code {code[:12]}, from {where})"


def checked_run(task: Callable[[Any, str, str], dict[str, Any]], expected: tuple[str, str], *args: Any) -> Any:
    """On a worker: ``task(*args)`` when this worker's lfctl (version and code as imported) is
    ``expected``, the sweep's; else :class:`OtherCode`, and the run is not run.

    Parameters
    ----------
    task : callable
        What the run is (:func:`lfctl.sweep.task.execute`).
    expected : tuple of str
        The sweep's lfctl version and code digest.
    *args
        The task's arguments: the run, the sweep's folder, which logs to keep.
    """
    if (__version__, _LOADED_CODE) != tuple(expected):
        from distributed import get_worker

        raise OtherCode(get_worker().address, _worker_identity())
    return task(*args)


@dataclass(frozen=True)
class SweepProgress:
    """Where a sweep stands, as the progress callback sees it."""

    total: int  # runs in the plan
    skipped: int  # runs with a row already (resume)
    done: int  # runs finished in this session, failed ones included
    failed: int  # of those, status error or crashed
    running: int  # submitted and not finished
    elapsed_s: float  # since the first submission
    stopping: bool  # a stop was asked: nothing more is submitted
    engine: str  # what runs the sweep (cluster, workers)

    @property
    def rate_per_min(self) -> float:
        """Runs finished per minute in this session."""
        return 60.0 * self.done / self.elapsed_s if self.elapsed_s > 0 else 0.0

    @property
    def eta_s(self) -> float | None:
        """Seconds to the end at the rate so far (None before the first run finishes)."""
        left = self.total - self.skipped - self.done
        return left * self.elapsed_s / self.done if self.done else None


@dataclass
class SweepResult:
    """A sweep that ran (to its end, to a stop, or as far as it went before a cancel)."""

    out_dir: Path  # the sweep's folder
    plan: SweepPlan  # what was planned
    rows: list[dict[str, Any]]  # every row in the folder, by run number (resumed ones too)
    summary: SweepSummary  # per variant, as report() wrote it
    stopped: bool  # a stop was asked before every run was submitted
    wall_s: float  # this session, from the first submission to the last row
    engine: str  # what ran it
    files: list[Path] = field(default_factory=list)  # tables, summary, plots written

    @property
    def complete(self) -> bool:
        """Every planned run has a row."""
        return len(self.rows) == len(self.plan.runs)

    @property
    def failed(self) -> list[dict[str, Any]]:
        """The rows of runs that failed (status ``error`` or ``crashed``)."""
        return [r for r in self.rows if r["status"] != "ok"]


class _IgnoreSigint(WorkerPlugin):
    """Local workers share the terminal's process group, so Ctrl-C would reach them too;
    they ignore it (set up again in a worker that replaces a dead one) and the sweep decides
    what stops."""

    name = "lfctl-ignore-sigint"

    def setup(self, worker: Any) -> None:
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _say_scenario_warnings(p: SweepPlan) -> None:
    """Warn once of what each run would warn of as it starts (a slot out of view, an event
    after the run's end: :func:`~lfctl.sim.runner.scenario_warnings`), naming the variants
    it holds for; the runs on the workers leave it out (:func:`lfctl.sweep.task.execute`).

    Parameters
    ----------
    p : SweepPlan
        The sweep.
    """
    from lfctl.sim.runner import scenario_warnings

    found: dict[str, list[int]] = {}
    for v in p.variants:
        for text in scenario_warnings(v.config):
            found.setdefault(text, []).append(v.index)
    for text, indices in found.items():
        if len(indices) == len(p.variants):
            which = "every run"
        else:
            shown = ", ".join(map(str, indices[:10])) + (f" and {len(indices) - 10} more" if len(indices) > 10 else "")
            which = f"variant{'s' if len(indices) > 1 else ''} {shown}"
        log.warning("%s: %s", which, text)


def _followers(p: SweepPlan) -> list[str]:
    names: list[str] = []
    for v in p.variants:
        names += [f.name for f in v.config.followers if f.name not in names]
    return names


def _prepare(folder: Path, p: SweepPlan, resume: bool, code: str) -> list[dict[str, Any]] | None:
    """Check the sweep's folder; returns the rows already there, or None for a folder to
    make (:func:`_make`: an empty or missing one), without writing anything."""
    if (folder / "sweep.json").exists():
        meta = read_meta(folder)
        if not resume:
            raise ConfigError(
                f"{folder} already holds sweep {meta.get('name')!r}: finish it with --resume, or give another --out"
            )
        if meta.get("digest") != p.digest:
            raise ConfigError(
                f"{folder} holds a different sweep (plan {str(meta.get('digest'))[:12]}, this one {p.digest[:12]}): "
                "its rows would not match; use another --out"
            )
        if meta.get("code") != code:
            raise ConfigError(
                f"{folder} was run by other lfctl code (digest {str(meta.get('code'))[:12]}, now {code[:12]}): "
                "resuming would mix two versions' results; use another --out"
            )
        rows = read_journal(folder)
        planned = {r.run: r.variant for r in p.runs}
        for row in rows:
            if planned.get(row["run"], -1) != row["variant"]:
                raise ConfigError(
                    f"{folder / JOURNAL}: a row of run {row['run']}, variant {row['variant']}, which is not one of "
                    f"this sweep's {len(p.runs)} runs"
                )
        return rows
    if folder.exists() and not folder.is_dir():
        raise ConfigError(f"{folder} is there and is not a folder: choose another --out")
    if folder.exists() and any(folder.iterdir()):
        raise ConfigError(f"{folder} exists and is not a sweep's folder: choose another --out")
    _files_beside(p)  # a bad name: refused before anything is made
    _check_makeable(folder)
    return None


def _check_makeable(folder: Path) -> None:
    """Refuse an --out that cannot be made (under a file, in a folder this user may not write
    to, or in /proc), before the cluster starts; nothing is left behind."""
    above = next((q for q in folder.parents if q.exists()), None)
    if above is None:
        return
    if not above.is_dir():
        raise ConfigError(f"--out {folder}: cannot make it: {above} is not a folder")
    try:  # a folder made and removed at once where --out would be made (os.access says yes to root, /proc no)
        os.rmdir(tempfile.mkdtemp(prefix=".lfctl-probe-", dir=above))
    except OSError as exc:
        raise ConfigError(f"--out {folder}: cannot make a folder in {above}: {exc.strerror or exc}") from None


def _make(folder: Path, p: SweepPlan, code: str) -> None:
    """Make a new sweep's folder: its description, sweep file, scenario, variants and the
    files the scenario names beside it."""
    beside = _files_beside(p)
    try:
        (folder / "variants").mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"--out {folder}: cannot make it: {exc.strerror or exc}") from None
    spec = p.spec
    write_meta(
        folder,
        {
            "name": spec.name,
            "description": spec.description,
            "digest": p.digest,
            "code": code,
            "lfctl": __version__,
            "scenario": str(spec.scenario),
            "keys": spec.keys,
            "followers": _followers(p),
            "variants": len(p.variants),
            "seeds": list(spec.seeds),
            "repetitions": spec.repetitions,
            "runs": len(p.runs),
            "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        },
    )
    (folder / "sweep.toml").write_text(spec.source)
    shutil.copyfile(spec.scenario, folder / "scenario.toml")
    for v in p.variants:
        (folder / "variants" / f"variant-{v.index:04d}.toml").write_text(v.source)
    # the files the scenario names beside it (a mission file, a user FMU), at the same place
    # beside scenario.toml and the variants, so each runs again from the sweep's folder
    for rel in beside:
        for where in (folder, folder / "variants"):
            dest = where / rel
            if not dest.resolve().is_relative_to(where.resolve()):  # a link in the way
                raise ConfigError(f"{rel} would be copied outside the sweep's folder, to {dest.resolve()}")
            dest.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(spec.scenario.parent / rel, dest)


#: the files a sweep writes at the top of its folder (the scenario's own files are copied beside them)
_OWN_FILES = frozenset(
    {"sweep.toml", "scenario.toml", "sweep.json", "runs.jsonl", "runs.csv", "runs.parquet"}
    | {"summary.csv", "summary.parquet", "summary.md"}
)


def _files_beside(p: SweepPlan) -> list[Path]:
    """The mission files and user FMUs the variants name by a relative path (as written in
    their TOML: beside the scenario), normalised. Absolute paths, and ``~`` ones, are used
    where they are and not copied."""
    found: set[Path] = set()
    for v in p.variants:
        table = tomllib.loads(v.source)
        named = [table.get("mission", {}).get("file"), *(veh.get("fmu") for veh in table.get("vehicles", []))]
        for text in named:
            if not isinstance(text, str) or not text or text.startswith("~") or Path(text).is_absolute():
                continue
            rel = Path(os.path.normpath(text))
            if rel.parts and rel.parts[0] != "..":  # resolve_paths has kept it inside the folder
                if str(rel) in _OWN_FILES or rel.parts[0] in ("logs", "plots") or rel.match("variants/variant-*.toml"):
                    raise ConfigError(f"{text}: a file the scenario names beside it would take a sweep file's place")
                found.add(rel)
    return sorted(found)


def _local_cluster(n_workers: int) -> Any:
    """The sweep's ``LocalCluster``: ``n_workers`` processes of one thread, quiet, on 127.0.0.1.

    It is made by a thread with SIGINT blocked, so its threads (its event loop, which starts
    and restarts the worker processes) have it blocked and so do the processes: Ctrl-C in the
    terminal reaches only lfctl's main thread, which decides what stops, even while a worker
    is still importing (an interrupt there printed Dask's tracebacks and ended the sweep with
    exit 1). The main thread waits for it with Ctrl-C open (a third press interrupts).
    multiprocessing's resource tracker is started first, here: started from the cluster's
    thread, it would unblock SIGINT there before the workers are spawned
    (``resource_tracker.ensure_running`` leaves SIGINT unblocked when it is done).
    """
    import dask
    from distributed import LocalCluster

    resource_tracker.ensure_running()
    made: dict[str, Any] = {}

    def make() -> None:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            with dask.config.set({**QUIET_WORKERS, "distributed.scheduler.allowed-failures": 1}):
                made["cluster"] = LocalCluster(
                    n_workers=n_workers,
                    threads_per_worker=1,
                    processes=True,
                    host="127.0.0.1",
                    dashboard_address="127.0.0.1:0",  # its HTTP server binds a port even without a dashboard: any free one
                    silence_logs=logging.CRITICAL,  # a dead worker is the sweep's to report, as a row
                )
        except BaseException as exc:  # raised again in the caller's thread
            made["error"] = exc

    starter = threading.Thread(target=make, name="lfctl-cluster-start", daemon=True)
    starter.start()
    starter.join()
    if "error" in made:
        raise made["error"]
    return made["cluster"]


@contextlib.contextmanager
def local_cluster(n_workers: int) -> Iterator[str]:
    """The ``LocalCluster`` a sweep starts (its workers ignore Ctrl-C), kept up across
    sweeps: yields its scheduler's address (for ``run_sweep(..., scheduler=address)``) and
    closes it on exit.

    Parameters
    ----------
    n_workers : int
        Worker processes, one thread each.
    """
    from distributed import Client

    cluster = _local_cluster(n_workers)
    try:
        with Client(cluster) as client:
            client.register_plugin(_IgnoreSigint())  # kept by the scheduler for every worker
        yield str(cluster.scheduler_address)
    finally:
        cluster.close()


def _check_address(scheduler: str, source: str = "--scheduler") -> tuple[str, int]:
    """``--scheduler`` (or what ``source`` names) is ``tcp://`` or ``tls://``, a host and a
    port within 1..65535: its host and port."""
    from distributed.comm.addressing import parse_address, parse_host_port

    also = " (or HOST:8786)" if source == "--scheduler" else ""
    form = f"{source} must be an address such as tcp://HOST:8786{also}, got {scheduler!r}"
    if not scheduler.startswith(("tcp://", "tls://")):
        raise ConfigError(form)
    try:
        host, port = parse_host_port(parse_address(scheduler)[1])
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"{form}: {exc}") from None
    if not host or not 1 <= int(port) <= 65535:
        raise ConfigError(f"{form}: the host must be given and the port within 1..65535")
    return host, int(port)


#: how long a sweep on a scheduler of one's own waits for ``--workers N`` to join (and for
#: ``--scheduler-file``'s file to be written), and how long any cluster may go without a
#: worker while runs wait (its workers died and none came back) before the sweep stops, s
WORKERS_WAIT_S = 60.0


def scheduler_address(
    scheduler_file: str | Path, stop: Callable[[], bool] | None = None, wait_s: float | None = None
) -> str | None:
    """The address in a Dask scheduler file (``dask scheduler --scheduler-file PATH`` writes
    it, as do dask-jobqueue's and dask-mpi's schedulers, a JSON object with ``"address"``).
    A scheduler that is still starting has not written it yet: the file is waited for (and
    read again while it is half written) for up to ``wait_s`` (default
    :data:`WORKERS_WAIT_S`), in slices, so that a stop is heard: None when ``stop()`` came
    true first.

    Parameters
    ----------
    scheduler_file : str or Path
        The file.
    stop : callable, optional
        Asked while waiting; True ends the wait (the address is then None).
    wait_s : float, optional
        How long to wait for the file and an address in it, s.

    Raises
    ------
    ConfigError
        The path is a folder or cannot be read, or the file holds no address after the wait.
    LfctlError
        No file there after the wait.
    """
    path = Path(scheduler_file)
    wait = WORKERS_WAIT_S if wait_s is None else wait_s
    deadline = time.monotonic() + wait
    problem = None
    while True:
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            problem = None
        except (OSError, UnicodeDecodeError) as exc:  # a folder, no permission, not text
            reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
            raise ConfigError(f"--scheduler-file {path}: cannot read it ({reason})") from None
        else:
            try:
                got = json.loads(text)
            except ValueError as exc:
                problem = f"not JSON ({exc})"
            else:
                address = got.get("address") if isinstance(got, dict) else None
                if isinstance(address, str) and address:
                    return address
                problem = 'no "address" in it, as a Dask scheduler writes (`dask scheduler --scheduler-file`)'
        if stop is not None and stop():
            return None
        if time.monotonic() > deadline:
            if problem is None:
                raise LfctlError(
                    f"--scheduler-file {path}: no such file after {wait:g} s "
                    "(the scheduler writes it once it listens: `dask scheduler --scheduler-file PATH`)"
                )
            raise ConfigError(f"--scheduler-file {path}: {problem}, still after {wait:g} s")
        time.sleep(min(_TICK_S / 5, max(0.0, deadline - time.monotonic())))


#: how long what answers at --scheduler may take to speak first, as a Dask scheduler does, s
PROBE_S = 10.0


def _probe(scheduler: str) -> None:
    """What listens at a ``tcp://`` address speaks first, as a Dask scheduler does (its
    handshake): a peer that takes the connection and says nothing would hold Dask's client
    for ever (its timeout does not cover the handshake)."""
    try:
        with socket.create_connection(_check_address(scheduler), timeout=PROBE_S) as conn:
            conn.settimeout(PROBE_S)
            if not conn.recv(1):
                raise LfctlError(f"what answers at {scheduler} closed the connection at once: not a Dask scheduler")
    except TimeoutError:
        raise LfctlError(
            f"what answers at {scheduler} said nothing within {PROBE_S:g} s: not a Dask scheduler (which speaks first)"
        ) from None
    except OSError as exc:
        raise LfctlError(f"cannot reach the Dask scheduler at {scheduler}: {exc.strerror or exc}") from None


#: a local cluster starts at most this many worker processes a core (each is a Python process
#: of about 110 MB; past the cores they only take turns)
LOCAL_WORKERS_PER_CORE = 4


def local_workers(asked: int | None, runs_left: int, cores: int) -> tuple[int, str]:
    """How many worker processes a local cluster starts: ``asked`` (default one a core), at
    most the runs left and :data:`LOCAL_WORKERS_PER_CORE` a core; and what was capped, said
    (empty when nothing was).

    Parameters
    ----------
    asked : int or None
        ``--workers``.
    runs_left : int
        Runs to do.
    cores : int
        Cores this process may run on.
    """
    n = asked or cores
    bound = LOCAL_WORKERS_PER_CORE * max(cores, 1)
    if n > bound:
        n = bound
    if n > runs_left >= 1:
        n = runs_left
    if asked is None or n == asked:
        return n, ""
    if n == runs_left and n < bound:
        why = f"the {_count(runs_left, 'run')} left"
    else:
        why = f"{LOCAL_WORKERS_PER_CORE} a core on {_count(cores, 'core')}"
    return n, f" (--workers {asked}: capped at {n}, {why})"


def _connect(
    scheduler: str | None,
    workers: int | None,
    stop: Callable[[], bool] | None = None,
    found_in: str = "",
    runs_left: int = 0,
) -> tuple[Any, Any, str]:
    """A client and its cluster (None for a scheduler of one's own) and their description
    (the scheduler's address named as ``found_in`` the file it came from, if it did). A
    local cluster starts :func:`local_workers` processes for ``runs_left``. Waiting for a
    scheduler's workers ends early when ``stop()`` is true (the sweep then stops before any
    run)."""
    from distributed import Client

    if scheduler is None:
        n, capped = local_workers(workers, runs_left, usable_cores())
        cluster = _local_cluster(n)
        client = Client(cluster)
        client.register_plugin(_IgnoreSigint())
        return (
            client,
            cluster,
            f"Dask LocalCluster, {n} worker process{'es' * (n != 1)} x 1 thread{capped}; a crashed run is retried once",
        )
    if scheduler.startswith("tcp://"):
        _probe(scheduler)
    try:
        client = Client(scheduler, timeout="10s")
    except (OSError, TimeoutError) as exc:
        raise LfctlError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
    except TypeError as exc:  # tls:// without Dask's TLS settings
        given = f"the address in --scheduler-file {found_in}" if found_in else "--scheduler"
        raise ConfigError(f"{given} {scheduler}: {exc} (set distributed.comm.tls in Dask's config)") from None
    except Exception as exc:  # a peer that is not a Dask scheduler: its bytes make no sense as one
        raise LfctlError(
            f"what answers at {scheduler} is not a Dask scheduler ({type(exc).__name__}: {str(exc)[:200]})"
        ) from None
    want = workers or 1
    deadline = time.monotonic() + WORKERS_WAIT_S
    while True:  # in slices: a Ctrl-C is heard while the workers are awaited
        try:
            have = len(client.nthreads(callback_timeout=_TICK_S))
        except TimeoutError:
            have = 0
        if have >= want or (stop is not None and stop()):
            break
        if time.monotonic() > deadline:
            client.close()
            raise LfctlError(
                f"the scheduler at {scheduler} has {_count(have, 'worker')} after {WORKERS_WAIT_S:g} s, "
                f"waiting for {want}"
            )
        time.sleep(_TICK_S / 2)
    retries = client.run_on_scheduler(lambda dask_scheduler: dask_scheduler.allowed_failures)
    nthreads = client.nthreads()
    threads = sum(nthreads.values())
    desc = (
        f"Dask scheduler {scheduler}{f' (from {found_in})' if found_in else ''}, {_count(len(nthreads), 'worker')}, {_count(threads, 'thread')}; "
        f"a crashed run is retried {'once' if retries == 1 else _count(retries, 'time')} "
        "(distributed.scheduler.allowed-failures)"
    )
    return client, None, desc


def _count(n: int, what: str) -> str:
    """``1 worker``, ``2 workers``."""
    return f"{n} {what}{'' if n == 1 else 's'}"


def _identity(run: Callable[[Callable[[], Any]], Any], who: str, fix: str) -> Any:
    """:func:`_worker_identity` as ``run`` (the client's run on the scheduler or the workers)
    returns it; a process that cannot unpickle or import lfctl is named."""
    try:
        return run(_worker_identity)
    except Exception as exc:
        raise LfctlError(f"{who} cannot import lfctl ({type(exc).__name__}: {exc}): {fix}") from None


def _check_workers(client: Any, code: str) -> None:
    """The scheduler and every worker import this lfctl. The scheduler unpickles the runs it
    is given, so it needs lfctl too; asking it first also takes its imports (1.3 s on a fresh
    ``dask scheduler`` here) out of the first run's time. (Workers that join later are
    checked by each run: :func:`checked_run`.)"""
    ours = _identity(client.run_on_scheduler, "the Dask scheduler", "install this lfctl where it runs")
    if tuple(ours[:2]) != (__version__, code):
        raise LfctlError(
            f"the Dask scheduler runs other lfctl code (lfctl {ours[0]}, code {ours[1][:12]}, from {ours[2]}) than "
            f"this process (lfctl {__version__}, code {code[:12]}): install the same lfctl everywhere"
        )
    seen = _identity(client.run, "Dask workers", "install this lfctl on every worker")
    wrong = {w: v for w, v in seen.items() if tuple(v[:2]) != (__version__, code)}
    if wrong:
        listed = ", ".join(str(OtherCode(w, tuple(v))) for w, v in sorted(wrong.items()))
        raise LfctlError(
            f"workers run other lfctl code than this process (lfctl {__version__}, code {code[:12]}): {listed}; "
            "install the same lfctl everywhere"
        )


def run_sweep(
    sweep: SweepSpec | SweepPlan | str | Path,
    out_dir: str | Path | None = None,
    *,
    scheduler: str | None = None,
    scheduler_file: str | Path | None = None,
    workers: int | None = None,
    resume: bool = False,
    logs: str = "none",
    progress: Callable[[SweepProgress, dict[str, Any] | None], None] | None = None,
    stop: Callable[[], bool] | None = None,
    cancel: Callable[[], bool] | None = None,
    task: Callable[[Any, str, str], dict[str, Any]] | None = None,
    plots: bool = True,
) -> SweepResult:
    """Run a sweep and write its folder; returns the rows and summary.

    Parameters
    ----------
    sweep : SweepSpec, SweepPlan, str or Path
        The sweep: a file, a shipped sweep's name, or one already read or planned.
    out_dir : str or Path, optional
        The sweep's folder (default ``sweeps/<name>``).
    scheduler : str, optional
        A running Dask scheduler (``tcp://HOST:8786``); default a ``LocalCluster`` here.
    scheduler_file : str or Path, optional
        Instead of ``scheduler``: the scheduler file it writes (``dask scheduler
        --scheduler-file``), waited for up to 60 s (:func:`scheduler_address`).
    workers : int, optional
        Local cluster: worker processes (default one per usable core). With ``scheduler``
        or ``scheduler_file``: wait (up to 60 s) until that many workers have joined
        (default 1).
    resume : bool
        Finish the sweep in ``out_dir``: skip the runs it has rows for.
    logs : "none", "failed" or "all"
        Which runs' MCAP logs to keep in ``<out_dir>/logs``.
    progress : callable, optional
        ``progress(state, row)``: at the start (row None), after each finished run (its
        row), and about twice a second (row None).
    stop : callable, optional
        Asked in the loop; True stops submitting and lets running runs finish.
    cancel : callable, optional
        Asked in the loop, between rows (at least twice a second); True cancels the running
        runs, writes the results of the finished ones and raises ``KeyboardInterrupt``.
    task : callable, optional
        What a worker runs per run: ``task(run, out_dir, logs) -> row`` (default
        :func:`lfctl.sweep.task.execute`); it must be importable by the workers.
    plots : bool
        Draw the plots at the end.

    Raises
    ------
    ConfigError
        A bad sweep file or variant, a folder that holds another sweep, bad options.
    LfctlError
        The scheduler cannot be reached, or its workers run other lfctl code.
    KeyboardInterrupt
        ``cancel()`` was true, or an interrupt arrived; the finished rows are written.
    """
    from distributed import wait

    if logs not in LOG_MODES:
        raise ConfigError(f"--logs (logs) must be one of {', '.join(LOG_MODES)}, got {logs!r}")
    if workers is not None and workers < 1:
        raise ConfigError(f"--workers (workers) must be >= 1, got {workers}")
    if scheduler is not None and scheduler_file is not None:
        raise ConfigError("give --scheduler or --scheduler-file (scheduler or scheduler_file), not both")
    if scheduler is not None:
        if "://" not in scheduler:  # HOST:PORT, as Dask takes it: TCP
            scheduler = f"tcp://{scheduler}"
        _check_address(scheduler)
    p = sweep if isinstance(sweep, SweepPlan) else plan(sweep if isinstance(sweep, SweepSpec) else load_sweep(sweep))
    # the folder the kernel would write to: "nosuch/.." (or a link and "..") is the folder above,
    # which must pass the same checks
    folder = (Path(out_dir) if out_dir is not None else Path("sweeps") / p.spec.name).resolve()
    code = _LOADED_CODE
    done_rows = _prepare(folder, p, resume, code)  # (checks only: a new folder is made once the cluster is up)
    made = done_rows is not None
    have = {int(r["run"]) for r in done_rows or []}
    todo = collections.deque(r for r in p.runs if r.run not in have)
    if todo:
        _say_scenario_warnings(p)
    fn = task or execute
    where = str(folder.resolve())
    session = uuid.uuid4().hex[:8]
    client = cluster = None
    engine = "nothing to run"
    stopping = False
    started = last_row = time.perf_counter()
    done = failed = 0
    pending: dict[Any, Any] = {}
    lost: list[int] = []  # runs the scheduler lost (it restarted or went away, or the connection broke)
    other: list[OtherCode] = []  # runs refused by workers with other lfctl code
    silent = False  # the scheduler stopped answering
    unstaffed = False  # the cluster had no worker for WORKERS_WAIT_S

    def state() -> SweepProgress:
        return SweepProgress(
            len(p.runs), len(have), done, failed, len(pending), time.perf_counter() - started, stopping, engine
        )

    try:
        if todo and scheduler_file is not None:
            scheduler = scheduler_address(scheduler_file, stop)
            if scheduler is None:  # stopped while the file was awaited: nothing runs
                engine = f"no Dask scheduler: stopped while waiting for {scheduler_file}"
            else:
                _check_address(scheduler, f"the address in --scheduler-file {scheduler_file}")
        if todo and (scheduler is not None or scheduler_file is None):
            try:
                client, cluster, engine = _connect(scheduler, workers, stop, str(scheduler_file or ""), len(todo))
            except LfctlError as exc:
                if scheduler_file is None or isinstance(exc, ConfigError):
                    raise
                raise LfctlError(
                    f"{exc} (its address came from --scheduler-file {scheduler_file}: a scheduler that was "
                    "killed leaves its file behind)"
                ) from None
            _check_workers(client, code)
        if not made:
            if cancel is not None and cancel():  # cancelled while the cluster started: nothing made
                raise KeyboardInterrupt
            if folder.exists() and any(folder.iterdir()):  # (another process's sweep, made meanwhile?)
                raise ConfigError(f"{folder}: another sweep was started there meanwhile; use another --out")
            _make(folder, p, code)
            made = True
        if todo:
            log.info("sweep %s: %d runs to do on %s", p.spec.name, len(todo), engine)
        started = last_row = heard = time.perf_counter()
        slots, slots_at = 1, -math.inf
        staffed = started  # when the cluster last had a worker
        if progress is not None:
            progress(state(), None)
        while todo or pending:
            if cancel is not None and cancel():
                raise KeyboardInterrupt
            if not stopping and stop is not None and stop():
                stopping = True
                if progress is not None:  # said at once, even when nothing is left to wait for
                    progress(state(), None)
            if client is None:  # (stopped before a scheduler was found)
                break
            if time.perf_counter() - slots_at > 1.0:  # workers may join or leave: asked once a second
                slots_at = time.perf_counter()
                try:  # (briefly: a scheduler that has stopped answering must not hold the loop)
                    threads, heard = sum(client.nthreads(callback_timeout=_TICK_S).values()), slots_at
                    slots = max(1, threads)
                    if threads:
                        staffed = slots_at
                    elif slots_at - staffed > WORKERS_WAIT_S:  # every worker gone, none restarted or joining
                        unstaffed = True
                        lost.extend(r.run for r in pending.values())
                        break
                except TimeoutError:
                    if slots_at - heard > SCHEDULER_SILENT_S:
                        silent = True
                        lost.extend(r.run for r in pending.values())
                        break
            if not stopping and todo:
                while todo and len(pending) < slots:
                    run = todo.popleft()
                    key = f"lfctl-sweep-{p.spec.name}-{session}-run{run.run}"
                    future = client.submit(checked_run, fn, (__version__, code), run, where, logs, key=key, pure=False)
                    pending[future] = run
            if not pending:
                break
            try:
                finished = wait(list(pending), timeout=_TICK_S, return_when="FIRST_COMPLETED").done
            except TimeoutError:
                finished = set()
            except CancelledError:  # distributed's wait raises when a future was cancelled
                finished = {f for f in pending if f.done()}
            for fut in finished:
                run = pending.pop(fut)
                if fut.status == "cancelled":  # not by us: the scheduler lost it. No row: --resume runs it
                    lost.append(run.run)
                    stopping = True
                    continue
                if fut.status == "error" and isinstance(fut.exception(), OtherCode):  # not run: no row
                    other.append(fut.exception())
                    todo.appendleft(run)  # (left to --resume)
                    stopping = True
                    continue
                row = _row(fut, run, folder if logs != "none" else None)
                fut.release()
                append_row(folder, row)
                last_row = time.perf_counter()
                done += 1
                failed += row["status"] != "ok"
                if progress is not None:
                    progress(state(), row)
            if not finished and progress is not None:
                progress(state(), None)
    except KeyboardInterrupt:
        if client is not None and pending:
            client.cancel(list(pending), force=True)
        if made:
            _finish(folder, p, plots)
        raise
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    wall = last_row - started  # not the cluster's closing
    rows, summary = _finish(folder, p, plots)
    kept = f"the {len(rows)} finished rows are in {folder}, --resume runs the rest"
    if other:
        workers = ", ".join(sorted({str(e) for e in other}))
        raise LfctlError(
            f"the sweep stopped: a worker runs other lfctl code than this process (lfctl {__version__}, code "
            f"{code[:12]}): {workers}; install the same lfctl everywhere; {kept}"
        )
    if unstaffed:
        raise LfctlError(
            f"the Dask cluster has had no worker for {WORKERS_WAIT_S:g} s (they died and none was restarted or "
            f"joined): the sweep stopped, {_count(len(lost), 'running run')} lost; {kept}"
        )
    if silent:
        raise LfctlError(
            f"the Dask scheduler has not answered for {SCHEDULER_SILENT_S:g} s: the sweep stopped, its "
            f"{len(lost)} running runs lost; {kept}"
        )
    if lost:
        n = len(lost)
        raise LfctlError(
            f"lost {n} run{'s' if n != 1 else ''} (run{'s' if n != 1 else ''} {', '.join(map(str, lost[:10]))}): "
            f"the connection to the Dask scheduler broke (it stopped or restarted); {kept}"
        )
    return SweepResult(folder, p, rows, summary, bool(todo), wall, engine, summary.files)


def _row(fut: Any, run: Run, logs_in: Path | None = None) -> dict[str, Any]:
    """A finished future's row: the task's, or one saying why there is none (the task
    catches the run's own errors, so these are the engine's: a dead worker, a task that did
    not unpickle). With ``logs_in`` (the sweep's folder, when it keeps logs) a crashed run's
    row names the log its last attempt left, cut short where its worker died."""
    from distributed.scheduler import KilledWorker

    if fut.status == "finished":
        return dict(fut.result())
    exc = fut.exception()
    if isinstance(exc, KilledWorker):
        rel = log_name(run.run)
        kept = rel if logs_in is not None and (logs_in / rel).is_file() else ""
        return failed_row(run, "crashed", f"KilledWorker: every worker that ran it died ({exc})", kept)
    return failed_row(run, "error", f"{type(exc).__name__}: {exc}")


def _finish(folder: Path, p: SweepPlan, plots: bool) -> tuple[list[dict[str, Any]], SweepSummary]:
    """Write the results table, summary and plots from every row in the folder."""
    rows = read_journal(folder)
    tables = write_tables(folder, rows, p.spec.keys, _followers(p))
    summary = report(folder, plots=plots)
    return rows, SweepSummary(summary.rows, summary.markdown, [*tables, *summary.files])
