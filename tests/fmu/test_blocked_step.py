"""SIGTERM or Ctrl-C while an FMU is stuck in doStep (an endless loop in C) ends `lfctl sim`
within about a second, with a finished log that says why, one line on stderr, and no
extracted folder left; a run whose FMU returns still stops between steps, as before."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from fmu_faults import HANG, INIT_HANG, alive, faulty_scenario

from lfctl.fmu.build import BuiltModel
from lfctl.record.audit import audit

pytestmark = [pytest.mark.fmu, pytest.mark.integration]


def start_sim(
    scenario: Path, tmp: Path, mark: Path, stdout: int = subprocess.DEVNULL, group: bool = False, **env_vars: str
) -> subprocess.Popen[str]:
    """``lfctl sim`` (with ``group``, in a process group of its own, as a service manager starts it)."""
    env = dict(os.environ, TMPDIR=str(tmp), LFCTL_TEST_FMU_MARK=str(mark), **env_vars)
    return subprocess.Popen(
        [sys.executable, "-m", "lfctl", "sim", str(scenario), "-q"],
        stdout=stdout,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=group,
    )


def wait_stuck(proc: subprocess.Popen[str], mark: Path) -> int:
    """Wait until the FMU marks itself stuck (at most 60 s); the process it is stuck in."""
    deadline = time.monotonic() + 60
    while not mark.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert mark.exists(), "the FMU never got stuck"
    time.sleep(0.3)
    assert proc.poll() is None  # stuck, lfctl still running
    return int(mark.read_text())


@pytest.mark.parametrize("where", ["main", "separate"])  # the FMUs in lfctl's process, or in one of their own
@pytest.mark.parametrize(
    ("fmi", "sig", "code", "signals", "phase"),
    [
        (2, signal.SIGTERM, 143, 1, "step"),
        (3, signal.SIGINT, 130, 1, "step"),
        (2, signal.SIGINT, 130, 3, "step"),  # (three Ctrl-C in a row are one stop)
        (2, signal.SIGTERM, 143, 1, "setup"),  # stuck as it is set up, before the first step
    ],
)
def test_a_signal_ends_a_run_stuck_in_an_fmu_call(
    faulty: BuiltModel, tmp_path: Path, fmi: int, sig: signal.Signals, code: int, signals: int, phase: str, where: str
) -> None:
    scen, tmp, mark, logs = tmp_path / "s.toml", tmp_path / "tmp", tmp_path / "stuck", tmp_path / "logs"
    tmp.mkdir()
    # (FaultyRover initialises its state as its parameters are set: stuck in setup, it spins in fmi2SetReal)
    fault, call, t = (HANG, f"fmi{fmi}DoStep", "0.5") if phase == "step" else (INIT_HANG, f"fmi{fmi}SetReal", "0")
    text = faulty_scenario(faulty.path(fmi), fault, 0.5, logs, duration_s=5.0)
    scen.write_text(text.replace("[sim]", f"[sim]\nfmu_process = '{where}'"))
    proc = start_sim(scen, tmp, mark)
    try:
        stuck = wait_stuck(proc, mark)  # the process the FMU runs in
        for _ in range(signals):
            proc.send_signal(sig)
            time.sleep(0.05)
        rc = proc.wait(timeout=10)  # the FMU call never returns: a run still going fails the test
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.stderr is not None
    err = proc.stderr.read()
    assert rc == code, (rc, err)
    assert err == f"lfctl: error: FMU FaultyRover (f1) blocked in {call} at t = {t} s; terminated by {sig.name}\n"
    assert list(tmp.iterdir()) == []  # the extracted FMU went too
    assert (stuck == proc.pid) == (where == "main")
    assert not alive(stuck)  # the FMU's own process ended with the run
    if phase == "setup":
        return
    (log,) = logs.glob("*.mcap")
    report = audit(log)
    # a whole, finished file: its one error is the run's abnormal end
    assert [f.kind for f in report.findings if f.level == "error"] == ["run"], report.findings
    assert report.figures["end"]["reason"] == f"error: FMU FaultyRover (f1) blocked in {call} at t = 0.5 s; terminated"
    assert float(report.figures["end"]["t_s"]) == pytest.approx(0.5)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_an_fmu_stuck_as_its_library_loads_is_stopped_and_dies_with_lfctl(
    faulty: BuiltModel, tmp_path: Path, sig: signal.Signals
) -> None:
    # a library constructor that never returns holds the worker's interpreter lock (dlopen):
    # lfctl's watchdog sees the load as a call, and the kernel ends the worker with lfctl
    scen, tmp, mark, logs = tmp_path / "s.toml", tmp_path / "tmp", tmp_path / "stuck", tmp_path / "logs"
    tmp.mkdir()
    scen.write_text(faulty_scenario(faulty.fmi2, 0, 0.0, logs).replace("[sim]", "[sim]\nfmu_process = 'separate'"))
    proc = start_sim(scen, tmp, mark, LFCTL_TEST_FMU_LOAD_HANG="1")
    try:
        stuck = wait_stuck(proc, mark)
        assert stuck != proc.pid  # in the worker
        proc.send_signal(sig)
        rc = proc.wait(timeout=10)
        deadline = time.monotonic() + 5
        while alive(stuck) and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert not alive(stuck)  # no worker left behind, however lfctl ended
    assert proc.stderr is not None
    err = proc.stderr.read()
    if sig == signal.SIGTERM:
        assert rc == 143
        assert err == "lfctl: error: FMU FaultyRover (leader) blocked in dlopen at t = 0 s; terminated by SIGTERM\n"
    else:
        assert rc == -signal.SIGKILL


@pytest.mark.parametrize("group", [False, True])
def test_a_signal_still_stops_a_healthy_run_between_steps(faulty: BuiltModel, tmp_path: Path, group: bool) -> None:
    # SIGTERM to lfctl, or to its whole process group as `timeout` and service managers send
    # it: the FMU's process is in a group of its own, so lfctl alone gets it either way
    scen, tmp, logs = tmp_path / "s.toml", tmp_path / "tmp", tmp_path / "logs"
    tmp.mkdir()
    scen.write_text(
        faulty_scenario(faulty.fmi2, 0, 0.0, logs, duration_s=600.0).replace("[sim]", "[sim]\nclock = 'realtime'")
    )
    proc = start_sim(scen, tmp, tmp_path / "unused", stdout=subprocess.PIPE, group=group)
    try:
        deadline = time.monotonic() + 60
        while not list(logs.glob("*.mcap")) and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(1.0)
        workers = [
            int(p) for t in Path(f"/proc/{proc.pid}/task").iterdir() for p in (t / "children").read_text().split()
        ]
        assert workers and all(os.getpgid(w) != os.getpgid(proc.pid) for w in workers)
        if group:
            os.killpg(proc.pid, signal.SIGTERM)
        else:
            proc.send_signal(signal.SIGTERM)
        rc = proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.stderr is not None
    assert (rc, proc.stderr.read()) == (143, "lfctl: terminated\n")  # 128 + SIGTERM, as the watchdog's
    (log,) = logs.glob("*.mcap")
    assert audit(log).figures["end"]["reason"] == "interrupted"
    assert proc.stdout is not None and f"log          {log}  (interrupted;" in proc.stdout.read()  # where it went
    assert list(tmp.iterdir()) == []
