"""`lfctl sweep` as a user runs it: bad input is one line naming the variant and the key
(exit 2), a pipe gets one JSON line per run, `report` rebuilds the summary, and Ctrl-C in a
terminal stops submitting and lets running runs finish (a second one cancels them)."""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from lfctl.cli import main

TRUTH = 'scenario = "convoy"\n{top}[set]\n"sim.duration_s" = {duration}\n"sim.sensing" = "truth"\n'


def test_bad_variants_and_arguments_are_one_line_naming_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)  # where sweeps/<name> would go
    bad = tmp_path / "bad.toml"
    bad.write_text(TRUTH.format(top="", duration=2.0) + '[grid]\n"sensing.range_noise_m" = [0.1, -0.5]\n')
    assert main(["sweep", str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.strip().splitlines() == [
        f"lfctl: error: {bad}: variant 1 (sensing.range_noise_m = -0.5): sensing.range_noise_m must be within [0, 100], got -0.5"
    ]
    assert not (tmp_path / "out").exists()  # nothing ran, nothing was made
    assert main(["sweep", "no-such-sweep"]) == 2
    assert "is neither a file nor a shipped sweep (shipped: " in capsys.readouterr().err
    assert main(["sweep", "report"]) == 2
    assert "lfctl sweep report needs the sweep's folder" in capsys.readouterr().err
    assert main(["sweep", "report", str(tmp_path)]) == 2
    assert "holds no sweep" in capsys.readouterr().err
    ok = tmp_path / "ok.toml"
    ok.write_text(TRUTH.format(top="", duration=2.0))
    with pytest.raises(SystemExit, match="2"):
        main(["sweep", str(ok), "--logs", "some"])
    assert "invalid choice: 'some'" in capsys.readouterr().err  # argparse names the choices
    assert main(["sweep", str(ok), "--scheduler", "udp://127.0.0.1:8786"]) == 2
    assert "--scheduler must be an address such as tcp://HOST:8786" in capsys.readouterr().err
    # HOST:PORT is a TCP address, as Dask takes it (nothing listens on port 9 here)
    assert main(["sweep", str(ok), "--scheduler", "127.0.0.1:9", "--out", str(tmp_path / "x")]) == 1
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in capsys.readouterr().err
    with pytest.raises(SystemExit, match="2"):
        main(["sweep", str(ok), "--scheduler", "127.0.0.1:9", "--scheduler-file", "s.json"])
    assert "argument --scheduler-file: not allowed with argument --scheduler" in capsys.readouterr().err
    monkeypatch.setattr("lfctl.sweep.engine.WORKERS_WAIT_S", 0.2)
    assert main(["sweep", str(ok), "--scheduler-file", "nosuch.json", "--out", str(tmp_path / "x")]) == 1
    err = capsys.readouterr().err  # (the human lines go to stderr when stdout is a pipe)
    assert "scheduler    waiting for nosuch.json to be written (up to 0.2 s)\n" in err
    assert err.endswith(
        "lfctl: error: --scheduler-file nosuch.json: no such file after 0.2 s (the scheduler writes it once it "
        "listens: `dask scheduler --scheduler-file PATH`)\n"
    )
    assert not (tmp_path / "x").exists()
    with pytest.raises(SystemExit, match="2"):  # when the command line is read: before the plan is printed
        main(["sweep", str(ok), "--workers", "0"])
    assert capsys.readouterr() == (
        "",
        "lfctl sweep: error: argument --workers: must be within 1..1000000, got 0 (see lfctl sweep --help)\n",
    )
    assert not (tmp_path / "sweeps").exists()  # options are checked before the folder is made


def test_an_out_that_cannot_be_made_is_named_before_a_cluster_starts(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # "/proc/x" gave a bare "[Errno 2] No such file or directory: '/proc/x'", once the cluster was up
    def no_cluster(n_workers: int) -> None:
        raise AssertionError("a cluster was started")

    monkeypatch.setattr("lfctl.sweep.engine._local_cluster", no_cluster)
    ok = tmp_path / "ok.toml"
    ok.write_text(TRUTH.format(top="", duration=2.0))
    (tmp_path / "afile").write_text("")
    for out, why in (
        ("/proc/lfctl-sweep", "--out /proc/lfctl-sweep: cannot make a folder in /proc: "),
        (
            str(tmp_path / "afile" / "x"),
            f"--out {tmp_path / 'afile' / 'x'}: cannot make it: {tmp_path / 'afile'} is not a folder",
        ),
    ):
        assert main(["sweep", str(ok), "--out", out, "-q"]) == 2
        err = capsys.readouterr().err
        assert f"lfctl: error: {why}" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "ok.toml"]  # (no probe left)


def test_a_pipe_gets_a_json_line_per_run_and_report_rebuilds_the_summary(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sweep = tmp_path / "s.toml"
    sweep.write_text(
        TRUTH.format(top="seeds = [5, 6]\n", duration=6.0) + '[grid]\n"guidance.controller" = ["smc", "p"]\n'
    )
    assert main(["sweep", str(sweep), "--out", str(tmp_path / "out"), "--workers", "1"]) == 0
    captured = capsys.readouterr()
    rows = [json.loads(line) for line in captured.out.splitlines()]  # stdout is not a terminal here
    assert sorted(r["run"] for r in rows) == [0, 1, 2, 3] and {r["seed"] for r in rows} == {5, 6}
    assert "engine       Dask LocalCluster, 1 worker process x 1 thread" in captured.err
    assert "| variant | guidance.controller | ok/runs | range_err_rms_m |" in captured.err
    assert main(["sweep", "report", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "| 1 | p | 2/2 |" in out and "plots        " in out
    # resuming a finished sweep waits for no scheduler, and does not say it does
    resume = ["sweep", str(sweep), "--out", str(tmp_path / "out"), "--resume", "--scheduler-file", "nosuch.json"]
    assert main(resume) == 0
    assert "waiting for" not in capsys.readouterr().err


#: a sweep still running this long after it started is killed, so that a test reading its
#: pipes sees them end and fails with its own message (before pytest-timeout's 300 s)
HUNG_S = 240.0
_watchdogs: dict[int, threading.Timer] = {}


def _start(sweep: Path, out: Path, workers: int = 2) -> subprocess.Popen[str]:
    """`lfctl sweep` in its own process group, as a terminal's foreground job is, killed
    after ``HUNG_S`` if nothing ends it before (`_end` does)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "lfctl", "sweep", str(sweep), "--out", str(out), "--workers", str(workers)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    _watchdogs[proc.pid] = threading.Timer(HUNG_S, _kill_group, (proc,))
    _watchdogs[proc.pid].daemon = True
    _watchdogs[proc.pid].start()
    return proc


def _kill_group(proc: subprocess.Popen[str]) -> None:
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)


def _line_where(proc: subprocess.Popen[str], wanted: Callable[[str], bool]) -> str:
    """The first line of the sweep's stderr that is ``wanted`` (it must not end before)."""
    assert proc.stderr is not None
    while True:
        said = proc.stderr.readline()
        assert said, "lfctl sweep ended before saying what the test waits for"
        if wanted(said):
            return said


def _end(proc: subprocess.Popen[str]) -> None:
    """Kill the sweep's process group if it is still running; its watchdog goes."""
    _watchdogs.pop(proc.pid).cancel()
    _kill_group(proc)
    proc.wait()


@pytest.mark.integration
@pytest.mark.parametrize("presses", [1, 2])
def test_ctrl_c_stops_submitting_and_lets_running_runs_finish_twice_cancels(tmp_path: Path, presses: int) -> None:
    sweep = tmp_path / "s.toml"
    # short and long runs take turns (15 and 400 s simulated, about 0.1 and 3 s): when the
    # first short one has finished, a long one is surely running for seconds
    sweep.write_text(
        'scenario = "convoy"\nseeds = 1\n[set]\n"sim.sensing" = "truth"\n[grid]\n'
        '"sensing.range_noise_m" = [0.0, 0.01, 0.02, 0.03, 0.04, 0.05]\n"sim.duration_s" = [15.0, 400.0]\n'
    )
    proc = _start(sweep, tmp_path / "out")
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        assert line, f"the sweep ended before a row (exit {proc.wait()}): {proc.communicate()[1]}"
        first = json.loads(line)  # a run has finished: others are running
        os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C reaches the whole process group, workers too
        said = _line_where(proc, lambda line: "stopping" in line)  # the sweep took the first Ctrl-C
        assert re.search(r"; [12] running finish", said), said  # the long run at least
        if presses == 2:
            os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=120)
    finally:
        _end(proc)
    assert proc.returncode == 130, err  # 128 + SIGINT, as a shell says after Ctrl-C
    lines = [first] + [json.loads(line) for line in out.splitlines()]
    table = (tmp_path / "out" / "runs.csv").read_text().splitlines()
    if presses == 1:
        # the runs in flight finished (their workers ignored the Ctrl-C): every row is ok
        assert all(r["status"] == "ok" for r in lines) and 2 <= len(lines) < 12
        assert len(table) == 1 + len(lines)
        assert f"--out {tmp_path / 'out'} --resume` finishes the sweep" in err
    else:
        assert "cancelled the running runs" in err and "lfctl: interrupted" in err
        assert len(table) == 1 + len(lines) and len(lines) < 12


@pytest.mark.integration
@pytest.mark.parametrize(("presses", "sig"), [(1, signal.SIGINT), (3, signal.SIGINT), (1, signal.SIGTERM)])
def test_ctrl_c_while_the_cluster_starts_stops_the_sweep_before_any_run(
    tmp_path: Path, presses: int, sig: signal.Signals
) -> None:
    sweep = tmp_path / "s.toml"
    sweep.write_text(TRUTH.format(top="seeds = 3\n", duration=15.0))
    proc = _start(sweep, tmp_path / "out")
    try:
        _line_where(proc, lambda line: line.startswith("folder"))  # printed before the cluster starts
        time.sleep(1.0)  # the workers are importing (about 2 s here): a Ctrl-C in the terminal reaches them
        for _ in range(presses):
            if sig == signal.SIGINT:
                os.killpg(proc.pid, signal.SIGINT)
            else:
                proc.send_signal(signal.SIGTERM)  # `kill`: lfctl stops as on Ctrl-C
            time.sleep(0.2)
        out, err = proc.communicate(timeout=120)
    finally:
        _end(proc)
    # the workers never see it (they start with SIGINT blocked): no Dask traceback, no run
    assert proc.returncode == 128 + sig, err  # 130 after Ctrl-C, 143 after SIGTERM, as a shell says
    assert "Traceback" not in err and out == "", err
    if presses == 1:  # a stop, taken once the cluster is up; the folder says how to go on
        assert "stopping     no more runs start; 0 running finish" in err, err
        assert "stopped      0 of 3 runs have rows" in err
    else:  # the third press interrupts the start itself
        assert "interrupted before the sweep began: nothing was written" in err, err
        assert not (tmp_path / "out").exists()


@pytest.mark.integration
@pytest.mark.parametrize("seeds", [8, 2])
def test_a_reader_that_leaves_stops_the_sweep_as_ctrl_c_does(tmp_path: Path, seeds: int) -> None:
    # `lfctl sweep ... | head -1`: the closed pipe stops the sweep with its folder whole (it
    # ended with exit 0 and half a folder: rows, no tables); at the last row too (2 runs, one
    # worker: nothing left to stop, the reader still did not get every row)
    sweep = tmp_path / "s.toml"
    # (the second of two runs takes a second or more: the reader has left before its row comes)
    sweep.write_text(TRUTH.format(top=f"seeds = {seeds}\n", duration=15.0 if seeds > 2 else 100.0))
    proc = _start(sweep, tmp_path / "out", workers=2 if seeds > 2 else 1)
    try:
        assert proc.stdout is not None and proc.stderr is not None
        line = proc.stdout.readline()
        assert line, f"the sweep ended before a row (exit {proc.wait()}): {proc.stderr.read()}"
        proc.stdout.close()  # the reader leaves
        rc = proc.wait(timeout=120)
        err = proc.stderr.read()
    finally:
        _end(proc)
    assert rc == 141, err  # 128 + SIGPIPE, as a shell reports a writer whose reader left
    assert "stdout       its reader left (a closed pipe): the sweep stops" in err and "Traceback" not in err
    rows = (tmp_path / "out" / "runs.csv").read_text().splitlines()
    assert (tmp_path / "out" / "summary.md").exists()
    if seeds > 2:
        assert f"--out {tmp_path / 'out'} --resume` finishes the sweep" in err and 2 <= len(rows) < 9
    else:
        assert len(rows) == 3  # both ran


def test_only_a_dask_comms_unread_error_is_kept_from_asyncios_log() -> None:
    import logging

    from distributed.comm.core import CommClosedError

    from lfctl.cli.sweep import _DaskCommUnread

    def record(exc: BaseException, msg: str = "Future exception was never retrieved") -> logging.LogRecord:
        return logging.LogRecord("asyncio", logging.ERROR, __file__, 1, msg, None, (type(exc), exc, None))

    keep = _DaskCommUnread().filter
    assert not keep(record(CommClosedError("in <TCP (closed) Scheduler Broadcast>: Stream is closed")))
    assert keep(record(ValueError("a bug of ours")))  # another error stays in the log
    assert keep(record(CommClosedError("x"), "Task was destroyed but it is pending!"))  # another message too
