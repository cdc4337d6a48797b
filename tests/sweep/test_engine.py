"""The sweep engine on real Dask clusters (127.0.0.1 only): a LocalCluster, and a `dask
scheduler` with two `dask worker` processes started here. Runs are a few simulated seconds.

The same sweep file gives the same table with 2 local workers, with 1 worker stopped
halfway and resumed, and on the tcp scheduler; runs that raise and runs that kill their
worker are rows, and do not stop the sweep."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import cloudpickle
import pytest
from distributed import Client

from lfctl import __file__ as lfctl_file
from lfctl import __version__
from lfctl.data import models_dir
from lfctl.errors import ConfigError, LfctlError
from lfctl.sweep import SweepProgress, engine, run_sweep
from lfctl.sweep.engine import _check_workers, _connect, local_cluster, scheduler_processes, worker_environment
from lfctl.sweep.results import read_rows
from lfctl.sweep.spec import Run
from lfctl.sweep.task import execute, log_name

pytestmark = [pytest.mark.integration, pytest.mark.fmu]

cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers cannot import this test module

SWEEP = """
scenario = "convoy"
seeds = 2
[set]
"sim.duration_s" = 2.0
[grid]
"sim.sensing" = ["truth", "camera"]
"camera.tracker" = ["hue", "full"]
"""


def _table(rows: list[dict]) -> list[dict]:
    """The rows without what may differ between two runs of a sweep: the wall time."""
    return [{k: v for k, v in r.items() if k != "wall_time_s"} for r in rows]


@pytest.fixture
def address() -> Iterator[str]:
    """A `dask scheduler` with one `dask worker` process on 127.0.0.1, stopped on leaving."""
    with scheduler_processes(1) as address:
        yield address


def _some_of(written: list[dict], rows: list[dict]) -> None:
    """A sweep that stopped part way wrote some of the reference's rows, each as it is there."""
    assert 1 <= len(written) < len(rows)
    assert _table(written) == _table([r for r in rows if r["run"] in {w["run"] for w in written}])


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[dict]]:
    """The sweep on a LocalCluster of two workers."""
    folder = tmp_path_factory.mktemp("sweep")
    (folder / "s.toml").write_text(SWEEP)
    result = run_sweep(folder / "s.toml", folder / "out", workers=2)
    assert "LocalCluster, 2 worker processes" in result.engine
    return folder, result.rows


def test_a_local_cluster_runs_every_run_and_writes_table_summary_and_plots(reference: tuple[Path, list[dict]]) -> None:
    folder, rows = reference
    assert [r["run"] for r in rows] == list(range(8)) and all(r["status"] == "ok" for r in rows)
    assert read_rows(folder / "out") == rows
    camera = [r for r in rows if r["sim.sensing"] == "camera"]
    truth = [r for r in rows if r["sim.sensing"] == "truth"]
    assert all(0.0 <= r["follower1.track_success"] <= 1.0 for r in camera)
    assert all(r["follower1.track_success"] is None for r in truth)
    assert all(r["sim_time_s"] == pytest.approx(2.0) for r in rows)
    out = folder / "out"
    for name in ("runs.parquet", "runs.csv", "summary.csv", "summary.parquet", "summary.md", "sweep.json"):
        assert (out / name).stat().st_size > 0, name
    assert sorted(p.name for p in (out / "plots").glob("*.png")) == ["camera.tracker.png", "sim.sensing.png"]
    assert len(list((out / "variants").glob("*.toml"))) == 4


def test_the_same_sweep_gives_the_same_table_stopped_and_resumed_on_one_worker(
    reference: tuple[Path, list[dict]], tmp_path: Path
) -> None:
    folder, rows = reference
    seen: list[dict] = []

    def progress(state: object, row: dict | None) -> None:
        if row is not None:
            seen.append(row)

    first = run_sweep(folder / "s.toml", tmp_path / "out", workers=1, progress=progress, stop=lambda: bool(seen))
    assert first.stopped and 1 <= len(first.rows) < 8 and not first.complete
    assert len(read_rows(tmp_path / "out")) == len(first.rows)  # what finished is written
    with pytest.raises(ConfigError, match=r"already holds sweep 's': finish it with --resume, or give another --out$"):
        run_sweep(folder / "s.toml", tmp_path / "out", workers=1)
    seen.clear()
    second = run_sweep(folder / "s.toml", tmp_path / "out", workers=1, resume=True, progress=progress)
    assert second.complete and not second.stopped
    assert sorted(r["run"] for r in seen) == sorted(set(range(8)) - {r["run"] for r in first.rows})
    assert _table(second.rows) == _table(rows)
    changed = (folder / "s.toml").read_text().replace("seeds = 2", "seeds = 3")
    (tmp_path / "s.toml").write_text(changed)
    with pytest.raises(ConfigError, match="holds a different sweep"):
        run_sweep(tmp_path / "s.toml", tmp_path / "out", resume=True)


def _crashing_task(run: Run, out_dir: str, logs: str) -> dict:
    """Seed 2 kills its worker once, then runs; seed 3 kills every worker that runs it."""
    marker = Path(out_dir) / f"killed-run-{run.run}"
    if run.seed == 2 and not marker.exists():
        marker.touch()
        os._exit(3)
    if run.seed == 3:
        os._exit(3)
    return execute(run, out_dir, logs)


def test_runs_that_raise_or_kill_their_worker_are_rows_and_the_sweep_goes_on(tmp_path: Path) -> None:
    (tmp_path / "s.toml").write_text(
        'scenario = "convoy"\nseeds = 3\n[set]\n"sim.duration_s" = 2.0\n"sim.sensing" = "truth"\n'
        '[grid]\n"vehicles[follower1].parameters" = [{}, {no_such_param = 1.0}]\n'
    )
    # one worker: one run in flight, so a dying worker takes no other run with it
    result = run_sweep(tmp_path / "s.toml", tmp_path / "out", workers=1, task=_crashing_task, logs="failed")
    by_run = {r["run"]: r for r in result.rows}
    assert [by_run[n]["status"] for n in range(6)] == ["ok", "ok", "crashed", "error", "error", "crashed"]
    assert (tmp_path / "out" / "killed-run-1").exists()  # run 1 (seed 2) did die once, then ran again
    assert by_run[1]["follower1.tracking_s"] > 1.0 and by_run[1]["sim_time_s"] == pytest.approx(2.0)
    assert by_run[2]["error"].startswith("KilledWorker: every worker that ran it died")
    # a parameter the model does not have: found only when the FMU is loaded, in the run
    assert (
        by_run[3]["error"].startswith("ConfigError: ")
        and "parameter 'no_such_param' does not exist" in by_run[3]["error"]
    )
    assert by_run[0]["log_path"] == "" and not list((tmp_path / "out" / "logs").glob("*.mcap"))  # ok: deleted
    assert [s["failed"] for s in result.summary.rows] == [1, 3]


def _dying_while_recording_task(run: Run, out_dir: str, logs: str) -> dict:
    """Run 1 kills its worker once its log has begun, on every attempt."""
    log = Path(out_dir) / log_name(run.run)

    def die_once_recording() -> None:
        while not (log.exists() and log.stat().st_size > 0):
            time.sleep(0.01)
        os._exit(3)

    if run.run == 1:
        threading.Thread(target=die_once_recording, daemon=True).start()
    return execute(run, out_dir, logs)


def test_a_crashed_runs_row_names_the_log_its_worker_left(tmp_path: Path) -> None:
    (tmp_path / "s.toml").write_text(
        'scenario = "convoy"\n[set]\n"sim.sensing" = "truth"\n[grid]\n"sim.duration_s" = [2.0, 300.0]\n'
    )
    result = run_sweep(
        tmp_path / "s.toml", tmp_path / "out", workers=1, task=_dying_while_recording_task, logs="failed"
    )
    by_run = {r["run"]: r for r in result.rows}
    assert [by_run[0]["status"], by_run[1]["status"]] == ["ok", "crashed"]
    assert by_run[0]["log_path"] == "" and by_run[1]["log_path"] == "logs/run-00001.mcap"
    assert (tmp_path / "out" / "logs" / "run-00001.mcap").is_file()


@pytest.mark.parametrize("how", ["cancel", "interrupt"])
def test_a_second_ctrl_c_cancels_and_writes_what_finished(tmp_path: Path, how: str) -> None:
    # two workers, a short and a long run side by side: when the short one's row comes, the
    # long one is running, and the cancel must drop it
    (tmp_path / "s.toml").write_text(
        'scenario = "convoy"\n[set]\n"sim.sensing" = "truth"\n[grid]\n"sim.duration_s" = [3.0, 400.0, 3.1, 3.2]\n'
    )
    rows: list[dict] = []
    running_then: list[int] = []

    def progress(state: SweepProgress, row: dict | None) -> None:
        if row is not None:
            rows.append(row)
            running_then.append(state.running)
            if how == "interrupt":
                raise KeyboardInterrupt  # Ctrl-C in a Python session, at whatever moment

    with pytest.raises(KeyboardInterrupt):
        # the CLI's second Ctrl-C sets `cancel`, which the engine asks between rows
        cancel = (lambda: bool(rows)) if how == "cancel" else None
        run_sweep(tmp_path / "s.toml", tmp_path / "out", workers=2, progress=progress, logs="all", cancel=cancel)
    written = read_rows(tmp_path / "out")
    assert [r["run"] for r in written] == [rows[0]["run"]] == [0] and written[0]["status"] == "ok"
    assert len(rows) == 1  # a cancel comes before the next row: every written row was reported
    assert running_then == [1]  # the long run was in flight when it was cancelled: it has no row
    log = tmp_path / "out" / written[0]["log_path"]
    assert log.suffix == ".mcap" and log.stat().st_size > 0


def test_a_dask_scheduler_with_two_workers_gives_the_same_table(
    reference: tuple[Path, list[dict]], tmp_path: Path
) -> None:
    folder, rows = reference
    # `dask scheduler` and `dask worker --nworkers 2` processes on 127.0.0.1, stopped on leaving
    with scheduler_processes(2) as address:
        assert address.startswith("tcp://127.0.0.1:")
        result = run_sweep(folder / "s.toml", tmp_path / "out", scheduler=address, workers=2)
        assert f"Dask scheduler {address}, 2 workers, 2 threads; a crashed run is retried once" in result.engine
        assert _table(result.rows) == _table(rows)

        # someone restarts the cluster mid-sweep: the runs it cancels get no row, and --resume runs them
        restarted: list[int] = []

        def restart(state: object, row: dict | None) -> None:
            if row is not None and not restarted:
                restarted.append(row["run"])
                with Client(address) as other:
                    other.restart()

        with pytest.raises(
            LfctlError, match=r"lost \d+ runs? .* the connection to the Dask scheduler broke .* --resume"
        ):
            run_sweep(folder / "s.toml", tmp_path / "again", scheduler=address, progress=restart)
        assert 1 <= len(read_rows(tmp_path / "again")) < 8
        resumed = run_sweep(folder / "s.toml", tmp_path / "again", scheduler=address, resume=True)
    assert _table(resumed.rows) == _table(rows)


def test_a_worker_with_other_lfctl_code_that_joins_mid_sweep_runs_nothing_and_stops_it(
    reference: tuple[Path, list[dict]], tmp_path: Path, address: str
) -> None:
    # the code was checked once, at the start: a worker that joined later ran 54 of 120 runs
    # with its own code, silently. Here the newcomer's lfctl is a copy without the models
    folder, rows = reference
    package = Path(lfctl_file).parent
    for p in package.rglob("*.py"):
        (tmp_path / "tree" / p.relative_to(package.parent)).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "tree" / p.relative_to(package.parent)).write_bytes(p.read_bytes())
    env = {**os.environ, "PYTHONPATH": str(tmp_path / "tree")}
    newcomer: list[subprocess.Popen] = []

    def join(state: object, row: dict | None) -> None:
        if row is not None and not newcomer:
            newcomer.append(
                subprocess.Popen(
                    [sys.executable, "-m", "dask", "worker", address, "--nthreads", "1", "--host", "127.0.0.1",
                     "--no-dashboard", "--death-timeout", "60"],
                    env=env, cwd=tmp_path,  # (-m puts the current folder, this checkout, first)
                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                )
            )  # fmt: skip
            with Client(address) as client:
                first = list(client.nthreads())
                client.wait_for_workers(2, timeout=60)
                client.retire_workers(first)  # what is left to run goes to the newcomer

    try:
        with pytest.raises(LfctlError, match=r"a worker runs other lfctl code .* from .*tree/lfctl\).* --resume"):
            run_sweep(folder / "s.toml", tmp_path / "out", scheduler=address, progress=join)
    finally:
        for proc in newcomer:
            proc.terminate()
            proc.wait(timeout=30)
    _some_of(read_rows(tmp_path / "out"), rows)  # the first worker's rows; none from the newcomer


def test_a_scheduler_that_stops_answering_ends_the_sweep_keeping_its_rows(
    reference: tuple[Path, list[dict]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, address: str
) -> None:
    # a frozen scheduler (SIGSTOP here; a hung or swapping one, a link that drops packets):
    # the loop waited on its answer for ever, deaf to the first two Ctrl-C
    folder, rows = reference
    monkeypatch.setattr(engine, "SCHEDULER_SILENT_S", 3.0)
    with Client(address) as client:
        pid = client.run_on_scheduler(os.getpid)
    frozen: list[int] = []

    def freeze(state: object, row: dict | None) -> None:
        if row is not None and not frozen:
            os.kill(pid, signal.SIGSTOP)
            frozen.append(row["run"])

    try:
        with pytest.raises(LfctlError, match=r"the Dask scheduler has not answered for 3 s: the sweep stopped"):
            run_sweep(folder / "s.toml", tmp_path / "out", scheduler=address, progress=freeze)
    finally:
        os.kill(pid, signal.SIGCONT)
    assert frozen
    _some_of(read_rows(tmp_path / "out"), rows)


def test_waiting_for_workers_hears_a_stop_and_ends_naming_how_many_came(
    reference: tuple[Path, list[dict]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, address: str
) -> None:
    # --workers 3 on a scheduler with one: a Ctrl-C went unheard until the 60 s wait ended
    folder, _rows = reference
    monkeypatch.setattr(engine, "WORKERS_WAIT_S", 2.0)
    result = run_sweep(folder / "s.toml", tmp_path / "out", scheduler=address, workers=3, stop=lambda: True)
    assert result.stopped and result.rows == []
    with pytest.raises(LfctlError, match=r"has 1 worker after 2 s, waiting for 3"):
        run_sweep(folder / "s.toml", tmp_path / "out2", scheduler=address, workers=3)


def test_a_scheduler_file_is_waited_for_and_its_address_used(
    reference: tuple[Path, list[dict]], tmp_path: Path
) -> None:
    # dask-jobqueue and dask-mpi give a scheduler file, not an address; the sweep may start
    # before the scheduler has written it
    folder, _rows = reference
    file = tmp_path / "shared" / "scheduler.json"
    file.parent.mkdir()
    up = threading.Event()  # the scheduler and its worker are up: the sweep stops before any run

    def start(stack: contextlib.ExitStack) -> None:
        stack.enter_context(scheduler_processes(1, scheduler_file=file))
        up.set()

    with contextlib.ExitStack() as later:
        timer = threading.Timer(1.0, start, (later,))
        timer.start()
        try:
            result = run_sweep(folder / "s.toml", tmp_path / "out", scheduler_file=file, stop=up.is_set)
        finally:
            timer.join()
        address = json.loads(file.read_text())["address"]
        assert f"Dask scheduler {address} (from {file}), 1 worker, 1 thread" in result.engine
    assert result.stopped and result.rows == []
    assert not file.exists()  # (the scheduler removes it when it stops)


def test_a_scheduler_file_that_is_missing_wrong_or_unreadable_is_named(
    reference: tuple[Path, list[dict]], tmp_path: Path
) -> None:
    file = tmp_path / "scheduler.json"
    with pytest.raises(LfctlError, match=r"--scheduler-file .*scheduler.json: no such file after 0.3 s"):
        engine.scheduler_address(file, wait_s=0.3)
    file.write_text('{"type": "Scheduler", "addr')  # half written, and never finished
    with pytest.raises(ConfigError, match=r"scheduler.json: not JSON \(.*\), still after 0.3 s"):
        engine.scheduler_address(file, wait_s=0.3)
    file.write_text('{"type": "Scheduler"}')
    with pytest.raises(ConfigError, match=r'scheduler.json: no "address" in it'):
        engine.scheduler_address(file, wait_s=0.0)
    with pytest.raises(ConfigError, match=r"--scheduler-file .*: cannot read it \(Is a directory\)"):
        engine.scheduler_address(tmp_path, wait_s=0.0)
    assert engine.scheduler_address(tmp_path / "none.json", stop=lambda: True) is None  # a Ctrl-C ends the wait

    # finished while it is waited for: read as soon as it is whole
    def finish() -> None:
        file.write_text('{"type": "Scheduler", "address": "tcp://127.0.0.1:8786"}')

    file.write_text('{"type": "Sched')
    timer = threading.Timer(0.3, finish)
    timer.start()
    try:
        assert engine.scheduler_address(file, wait_s=30.0) == "tcp://127.0.0.1:8786"
    finally:
        timer.join()

    folder, _rows = reference
    file.write_text('{"address": "ucx://127.0.0.1:8786"}')  # a transport the sweep does not take
    with pytest.raises(ConfigError, match=r"the address in --scheduler-file .* must be an address such as tcp://"):
        run_sweep(folder / "s.toml", tmp_path / "new", scheduler_file=file)
    with pytest.raises(ConfigError, match="give --scheduler or --scheduler-file"):
        run_sweep(folder / "s.toml", tmp_path / "new", scheduler="tcp://127.0.0.1:8786", scheduler_file=file)
    assert not (tmp_path / "new").exists()
    # a killed scheduler's file, left behind: the error says where the address came from
    file.write_text('{"address": "tcp://127.0.0.1:9"}')
    with pytest.raises(LfctlError, match=r"cannot reach .* \(its address came from --scheduler-file .*scheduler.json"):
        run_sweep(folder / "s.toml", tmp_path / "new", scheduler_file=file)
    # a stop while the file is awaited stops the sweep as a stop while workers are awaited does
    stopped = run_sweep(folder / "s.toml", tmp_path / "new", scheduler_file=tmp_path / "later.json", stop=lambda: True)
    assert stopped.stopped and stopped.rows == [] and "stopped while waiting for" in stopped.engine


def _end_the_workers_task(run: Run, out_dir: str, logs: str) -> dict:
    """Close the worker and its nanny, as a nanny that gives up does: nothing restarts it."""
    from distributed import get_worker

    worker = get_worker()
    worker.loop.add_callback(worker.close, nanny=True, reason="the test ends its worker")
    time.sleep(60)
    return {}


def test_a_cluster_left_without_workers_ends_the_sweep_keeping_its_rows(
    reference: tuple[Path, list[dict]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a LocalCluster whose nanny closed after its worker had died again and again (seen under
    # load in the test suite) left the sweep waiting for ever for runs no worker would take
    folder, _rows = reference
    monkeypatch.setattr(engine, "WORKERS_WAIT_S", 3.0)
    with pytest.raises(LfctlError, match=r"has had no worker for 3 s .*: the sweep stopped, 1 running run lost"):
        run_sweep(folder / "s.toml", tmp_path / "out", workers=1, task=_end_the_workers_task)
    assert read_rows(tmp_path / "out") == []


def test_a_process_says_the_code_it_imported_not_what_its_files_became(tmp_path: Path) -> None:
    # a worker that imported other code, its files put back since: it passed the check
    package = Path(lfctl_file).parent
    for p in [*package.rglob("*.py"), *models_dir().rglob("*")]:
        rel = p.relative_to(package.parent) if p.suffix == ".py" else Path("fmu_models") / p.relative_to(models_dir())
        if p.is_file():
            (tmp_path / "tree" / rel).parent.mkdir(parents=True, exist_ok=True)
            (tmp_path / "tree" / rel).write_bytes(p.read_bytes())
    script = (
        "import lfctl.data, lfctl.sweep.engine as e\n"
        "before = e._worker_identity()[1]\n"
        "f = e.Path(lfctl.data.__file__).with_name('frames.py')\n"
        "f.write_text(f.read_text() + '# edited\\n')\n"
        "print(before == e._worker_identity()[1], before != lfctl.data.code_digest())\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", script], env={**os.environ, "PYTHONPATH": str(tmp_path / "tree")}, cwd=tmp_path,
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert out.stdout.split() == ["True", "True"], out.stderr


def test_workers_lfctl_starts_leave_out_what_feeds_only_the_dashboard() -> None:
    assert worker_environment() == {
        "DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED": "False",
        "DASK_DISTRIBUTED__ADMIN__TICK__INTERVAL": "1s",
        "DASK_DISTRIBUTED__ADMIN__SYSTEM_MONITOR__INTERVAL": "2s",
    }

    def settings(dask_worker: object) -> tuple:
        import dask

        callbacks = dask_worker.periodic_callbacks  # type: ignore[attr-defined]
        return dask.config.get("distributed.admin.tick.interval"), "profile" in callbacks

    client, cluster, _ = _connect(None, 1)
    try:
        assert list(client.run(settings).values()) == [("1s", False)]  # no statistical profiler
    finally:
        client.close()
        cluster.close()
    with scheduler_processes(1) as address, Client(address) as client:
        assert list(client.run(settings).values()) == [("1s", False)]
    # the sweep's LocalCluster on its own (to keep up across sweeps): the same workers, closed on leaving
    with local_cluster(1) as address, Client(address) as client:
        assert list(client.run(settings).values()) == [("1s", False)]
        assert list(client.nthreads().values()) == [1]
        assert list(client.run(lambda: signal.getsignal(signal.SIGINT) is signal.SIG_IGN).values()) == [True]
    with pytest.raises(OSError):
        Client(address, timeout="1s")


class _Cluster:
    """What _check_workers asks of a client, answering as a scheduler and workers would."""

    def __init__(self, scheduler: object, workers: dict[str, object]) -> None:
        self.scheduler, self.workers = scheduler, workers

    def run_on_scheduler(self, fn: object) -> object:
        if isinstance(self.scheduler, Exception):
            raise self.scheduler
        return self.scheduler

    def run(self, fn: object) -> dict[str, object]:
        return self.workers


def test_a_scheduler_or_worker_with_other_lfctl_code_is_named() -> None:
    me = (__version__, "c0de" * 16, "/site/lfctl")
    _check_workers(_Cluster(me, {"tcp://w1": me}), me[1])  # the same code everywhere: fine
    with pytest.raises(LfctlError, match=r"the Dask scheduler runs other lfctl code \(lfctl 0.0.1, code 0ther"):
        _check_workers(_Cluster(("0.0.1", "0ther" * 8, "/old/lfctl"), {"tcp://w1": me}), me[1])
    with pytest.raises(LfctlError, match=r"the Dask scheduler cannot import lfctl .*ModuleNotFoundError"):
        _check_workers(_Cluster(ModuleNotFoundError("No module named 'lfctl'"), {}), me[1])
    with pytest.raises(
        LfctlError, match=r"workers run other lfctl code .*: tcp://w2 \(lfctl 0.0.1, code 0ther.*, from /old"
    ):
        _check_workers(_Cluster(me, {"tcp://w1": me, "tcp://w2": ("0.0.1", "0ther" * 8, "/old/lfctl")}), me[1])


def test_a_folder_is_checked_where_the_path_leads_and_a_failed_start_leaves_nothing(
    reference: tuple[Path, list[dict]], tmp_path: Path
) -> None:
    folder, _rows = reference
    (tmp_path / "runs.csv").write_text("precious\n")
    # "nosuch/.." is tmp_path itself, which holds a file: refused, nothing written
    with pytest.raises(ConfigError, match="exists and is not a sweep's folder"):
        run_sweep(folder / "s.toml", tmp_path / "nosuch" / "..", workers=1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runs.csv"]
    assert (tmp_path / "runs.csv").read_text() == "precious\n"
    # a scheduler that is not there: the folder it would have made is not left half-made
    with pytest.raises(LfctlError, match="cannot reach the Dask scheduler"):
        run_sweep(folder / "s.toml", tmp_path / "new", scheduler="tcp://127.0.0.1:9")
    assert not (tmp_path / "new").exists()
    for address, why in (
        ("tcp://", "missing port"),
        ("tcp://127.0.0.1:99999", "the port within 1..65535"),
        ("udp://127.0.0.1:8786", "an address such as tcp://HOST:8786"),
    ):
        with pytest.raises(ConfigError, match=why):
            run_sweep(folder / "s.toml", tmp_path / "new", scheduler=address)


@pytest.mark.parametrize(
    ("line", "why"),
    [
        (b"[1, 2]", r"line 9: not a run's row"),
        (b'{"x": 1}', r"line 9: not a run's row .* got run None"),
        (b'{"run": 99999, "variant": 0, "status": "ok"}', r"a row of run 99999, variant 0, which is not one of"),
        (
            b'{"run": 0, "variant": 0, "status": "ok", "follower1.lost_s": "abc"}',
            r"line 9: follower1\.lost_s must be a number",
        ),
        (b"[" * 100_000 + b"]" * 100_000, r"line 9: nested too deeply"),
    ],
)
def test_a_damaged_journal_is_named_on_resume(
    reference: tuple[Path, list[dict]], tmp_path: Path, line: bytes, why: str
) -> None:
    import shutil

    folder, _rows = reference
    out = tmp_path / "out"
    shutil.copytree(folder / "out", out)
    first = (out / "runs.jsonl").read_bytes().splitlines()[0]
    with open(out / "runs.jsonl", "ab") as f:  # (a bad last line is one cut short: not this)
        f.write(line + b"\n" + first + b"\n")
    table = (out / "runs.parquet").read_bytes()
    with pytest.raises(ConfigError, match=why):
        run_sweep(folder / "s.toml", out, resume=True)
    assert (out / "runs.parquet").read_bytes() == table  # nothing of it written


@pytest.mark.parametrize(
    ("asked", "left", "cores", "n", "said"),
    [
        (None, 8, 2, 2, ""),
        (None, 1, 2, 1, ""),
        (3, 100, 2, 3, ""),
        (40, 2, 2, 2, " (--workers 40: capped at 2, the 2 runs left)"),
        (40, 100, 2, 8, " (--workers 40: capped at 8, 4 a core on 2 cores)"),
        (10**6, 100_000, 2, 8, " (--workers 1000000: capped at 8, 4 a core on 2 cores)"),
    ],
)
def test_a_local_cluster_starts_at_most_the_runs_left_and_four_workers_a_core(
    asked: int | None, left: int, cores: int, n: int, said: str
) -> None:
    # --workers 40 for a 2-run sweep on 2 cores started 40 processes (1.4 GB to 5.5 GB used,
    # 7x slower); --workers 1000000 was taken
    assert engine.local_workers(asked, left, cores) == (n, said)


def test_the_cluster_a_sweep_starts_is_capped_and_says_so(
    reference: tuple[Path, list[dict]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    started: list[int] = []

    def cluster(n_workers: int) -> None:
        started.append(n_workers)
        raise LfctlError("no cluster in this test")

    monkeypatch.setattr(engine, "_local_cluster", cluster)
    monkeypatch.setattr(engine, "usable_cores", lambda: 2)
    folder, _rows = reference
    with pytest.raises(LfctlError, match="no cluster in this test"):
        run_sweep(folder / "s.toml", tmp_path / "new", workers=1000)
    assert started == [8]


def test_a_peer_that_says_nothing_is_not_taken_for_a_scheduler(
    reference: tuple[Path, list[dict]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import socket

    import lfctl.sweep.engine as engine

    monkeypatch.setattr(engine, "PROBE_S", 0.5)
    folder, _rows = reference
    with socket.create_server(("127.0.0.1", 0)) as silent:  # takes connections, never speaks
        address = f"tcp://127.0.0.1:{silent.getsockname()[1]}"
        with pytest.raises(LfctlError, match=r"said nothing within 0.5 s: not a Dask scheduler"):
            run_sweep(folder / "s.toml", tmp_path / "new", scheduler=address)
    assert not (tmp_path / "new").exists()
