"""An FMU in a process of its own (sim.fmu_process; the default for a user FMU): one that
crashes, calls exit() or hangs ends the run with an FmuError naming the FMU, the vehicle, the
FMI call and the time, and a log that is whole and says why; the run is the same wherever
the FMUs run; what the FMU refuses comes back as it would in one process."""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from fmu_faults import ABORT, EXIT, HANG, SEGV, alive, faulty_scenario

from lfctl.cli import main
from lfctl.config import load_config, parse_config
from lfctl.errors import ConfigError, FmuError
from lfctl.fmu.build import BuiltModel
from lfctl.fmu.host import FmuHost, HostedInstance
from lfctl.fmu.load import FmuLibrary, calls_in_progress
from lfctl.record.audit import audit
from lfctl.sim.cosim import Simulation
from lfctl.sim.runner import run_scenario

pytestmark = pytest.mark.fmu

EXAMPLES = Path(__file__).parents[2] / "examples"


def _scenario(fmu: Path, fault: int, fault_at: float, logs: Path, sim: str = "") -> str:
    return faulty_scenario(fmu, fault, fault_at, logs).replace("[sim]", f"[sim]\n{sim}")


@pytest.mark.parametrize(
    ("fault", "fmi", "how"),
    [
        (SEGV, 2, "killed by SIGSEGV"),
        (SEGV, 3, "killed by SIGSEGV"),
        (EXIT, 2, "exit code 0"),
        (ABORT, 3, "killed by SIGABRT"),
    ],
)
def test_a_crashing_fmu_ends_the_run_with_an_error_and_a_whole_log(
    faulty: BuiltModel, tmp_path: Path, capsys: pytest.CaptureFixture[str], fault: int, fmi: int, how: str
) -> None:
    scen, logs = tmp_path / "s.toml", tmp_path / "logs"
    scen.write_text(_scenario(faulty.path(fmi), fault, 1.234, logs))
    assert main(["sim", str(scen), "-q"]) == 1
    call = f"fmi{fmi}DoStep"
    expected = f"FMU FaultyRover (f1) ended its process in {call} at t = 1.24 s ({how})"  # the step from 1.24 s
    assert capsys.readouterr().err == f"lfctl: error: {expected}\n"
    (log,) = logs.glob("*.mcap")
    report = audit(log)
    assert [f.kind for f in report.findings if f.level == "error"] == ["run"], report.findings
    assert report.figures["end"]["reason"] == f"error: FmuError: {expected}"
    assert float(report.figures["end"]["t_s"]) == pytest.approx(1.24)


def test_an_fmu_that_never_returns_is_ended_after_the_step_timeout(faulty: BuiltModel) -> None:
    text = _scenario(faulty.fmi2, HANG, 0.3, Path("unused"), "fmu_step_timeout_s = 0.5")
    text = text.replace("[recording]", "[recording]\nenabled = false")
    with Simulation(parse_config(text)) as sim:
        with pytest.raises(FmuError) as err:
            sim.run(1.0)
        pid = sim._host.pid if sim._host is not None else -1
        assert sim.tick == 30  # the step from 0.3 s never ended
        assert np.isfinite(sim.state().pos_ned_m).all()
    assert str(err.value) == (
        "FMU FaultyRover (f1) did not return from fmi2DoStep within 0.5 s at t = 0.3 s "
        "(sim.fmu_step_timeout_s); its process was ended"
    )
    assert err.value.call == "fmi2DoStep"
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)  # gone (and reaped)


def test_a_stop_while_the_fmu_is_stuck_ends_it_and_says_so(
    faulty: BuiltModel, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # no watchdog here (a library caller): the stop comes as KeyboardInterrupt mid-step
    mark = tmp_path / "stuck"
    monkeypatch.setenv("LFCTL_TEST_FMU_MARK", str(mark))
    text = _scenario(faulty.fmi3, HANG, 0.2, Path("unused")).replace("[recording]", "[recording]\nenabled = false")
    seen: list[list[tuple[str, str]]] = []

    def interrupt() -> None:
        deadline = time.monotonic() + 30
        while not mark.exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        seen.append([(inst.name, call) for inst, call, _key in calls_in_progress()])
        signal.pthread_kill(threading.main_thread().ident or 0, signal.SIGINT)

    with Simulation(parse_config(text)) as sim:
        thread = threading.Thread(target=interrupt)
        thread.start()
        try:
            with pytest.raises(
                FmuError, match=r"^FMU FaultyRover \(f1\) blocked in fmi3DoStep at t = 0.2 s; terminated$"
            ):
                sim.run(5.0)
        finally:
            thread.join()
    assert seen == [[("f1", "fmi3DoStep")]]  # a watchdog sees the worker's call


def test_a_run_is_the_same_wherever_the_fmus_run() -> None:
    cfg = load_config(EXAMPLES / "convoy.toml")
    runs = {}
    for where in ("main", "separate"):
        c = dataclasses.replace(cfg, sim=dataclasses.replace(cfg.sim, fmu_process=where))
        runs[where] = run_scenario(c, duration_s=8.0)
    a, b = runs["main"], runs["separate"]
    assert a.result.pos_ned_m.shape == b.result.pos_ned_m.shape
    assert np.array_equal(a.result.pos_ned_m, b.result.pos_ned_m)
    assert np.array_equal(a.result.yaw_rad, b.result.yaw_rad)
    assert np.ptp(a.result.pos_ned_m[:, 0]) > 1.0  # the leader drove


def test_where_each_fmu_runs(faulty: BuiltModel) -> None:
    text = _scenario(faulty.fmi2, 0, 0.0, Path("unused")).replace("[recording]", "[recording]\nenabled = false")
    # a built-in leader beside the user FMU's follower
    text = text.replace(f'fmu = "{faulty.fmi2}"\n', "", 1)
    for where, kinds in (
        ("auto", ["FmuInstance", "HostedInstance"]),
        ("main", ["FmuInstance", "FmuInstance"]),
        ("separate", ["HostedInstance", "HostedInstance"]),
    ):
        with Simulation(parse_config(text.replace("[sim]", f"[sim]\nfmu_process = '{where}'"))) as sim:
            assert [type(i).__name__ for i in sim._instances] == kinds, where
            sim.set_command("leader", 0.5, 0.0)
            sim.set_command("f1", 0.4, 0.0)
            sim.run(1.0)
            north = sim.state().pos_ned_m[:, 0]
            assert north[0] == pytest.approx(0.5, abs=0.1)  # each row its own vehicle's
            assert north[1] == pytest.approx(-1.5 + 0.4, abs=1e-9)


@pytest.mark.parametrize(
    ("parameters", "error", "match"),
    [
        (
            {"north": 1.0},
            ConfigError,
            r"vehicles\[f1\]\.parameters\.north: 'north' has causality 'output' in FaultyRover, not a",
        ),
        ({"nonesuch": 1.0}, ConfigError, r"parameter 'nonesuch' does not exist in FaultyRover"),
        # the FMU refuses it as it leaves initialization, naming it: the scenario's value
        (
            {"internal_step": 2.0},
            ConfigError,
            r"vehicles\[f1\]\.parameters\.internal_step = 2\.0: FaultyRover says: must be in \(0, 1\] s, got 2$",
        ),
    ],
)
def test_what_the_fmu_refuses_comes_back_as_in_one_process(
    faulty: BuiltModel, parameters: dict[str, float], error: type[Exception], match: str
) -> None:
    with FmuLibrary(faulty.fmi2) as lib:
        with pytest.raises(error, match=match) as here:
            lib.instantiate("f1", parameters, (0.0, 0.0, 0.0), np.zeros(2), np.zeros(5))
        with FmuHost(1) as host, pytest.raises(error, match=match) as there:
            host.add(0, lib, "f1", parameters, (0.0, 0.0, 0.0))
    assert str(there.value) == str(here.value)
    if isinstance(here.value, FmuError):
        assert isinstance(there.value, FmuError)
        assert (there.value.call, there.value.status) == (here.value.call, here.value.status)


def test_a_hosted_instance_reads_its_rows_and_checks_them(faulty: BuiltModel) -> None:
    with FmuLibrary(faulty.fmi2) as lib, FmuHost(2) as host:
        inst = host.add(1, lib, "f1", {"fault": 1.0, "fault_at": 0.055}, (2.0, 3.0, 0.0))
        assert isinstance(inst, HostedInstance)
        assert tuple(host.out[1, :2]) == (2.0, 3.0) and tuple(host.out[0]) == (0.0,) * 5
        host.cmd[1] = (1.0, 0.0)
        for _ in range(5):
            host.start_step(0.01)
            host.finish_step()
            inst.check_outputs()
        assert inst.t_s == pytest.approx(0.05)
        assert host.out[1, 0] == pytest.approx(2.05)
        host.start_step(0.01)
        host.finish_step()
        with pytest.raises(FmuError, match=r"instance 'f1': output 'north' \(role north\) = nan m at t = 0.06 s"):
            inst.check_outputs()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the parent-death signal is Linux's")
def test_the_fmu_process_ends_with_the_process_that_started_it(faulty: BuiltModel, tmp_path: Path) -> None:
    script = tmp_path / "parent.py"
    script.write_text(
        textwrap.dedent(f"""
        import sys, time
        import numpy as np
        from lfctl.fmu.host import FmuHost
        from lfctl.fmu.load import FmuLibrary
        lib = FmuLibrary({str(faulty.fmi2)!r})
        host = FmuHost(1)
        host.add(0, lib, "f1", {{}}, (0.0, 0.0, 0.0))
        print(host.pid, flush=True)
        time.sleep(600)
        """)
    )
    parent = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    try:
        assert parent.stdout is not None
        worker = int(parent.stdout.readline())
        os.kill(worker, 0)  # alive
        parent.kill()  # no chance to close anything
        parent.wait()
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and alive(worker):
            time.sleep(0.05)
        if alive(worker):
            pytest.fail(f"the FMU process {worker} outlived its parent")
    finally:
        if parent.poll() is None:
            parent.kill()
            parent.wait()


def test_the_fmu_process_outlives_the_thread_that_started_it(faulty: BuiltModel) -> None:
    # (Linux's parent-death signal would have killed it with that thread)
    text = _scenario(faulty.fmi2, 0, 0.0, Path("unused")).replace("[recording]", "[recording]\nenabled = false")
    sim = Simulation(parse_config(text))
    opener = threading.Thread(target=sim.open)
    opener.start()
    opener.join()
    try:
        time.sleep(1.0)  # the worker looks for its parent every 0.5 s
        sim.set_command("f1", 0.5, 0.0)
        sim.run(0.5)
        assert sim.state().pos_ned_m[1, 0] == pytest.approx(-1.5 + 0.25)
    finally:
        sim.close()


def test_fmu_processes_start_after_a_fork_and_while_the_interpreter_exits(tmp_path: Path) -> None:
    # workers are started by one thread of the process: a forked child (multiprocessing's
    # default) has not that thread and makes its own; at exit, a thread still running keeps
    # its worker (the starting thread is a daemon, never joined)
    script = tmp_path / "forks.py"
    script.write_text(
        textwrap.dedent("""
        import faulthandler, os, threading, time
        from lfctl.fmu.host import FmuHost
        FmuHost(1).close()
        pid = os.fork()
        if pid == 0:
            faulthandler.dump_traceback_later(20, exit=True)
            FmuHost(1).close()
            os._exit(0)
        print("child", os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]), flush=True)
        ready = threading.Event()
        def late():
            host = FmuHost(1)
            ready.set()
            time.sleep(1.0)  # the main thread has returned: the interpreter is exiting
            print("late worker", host._proc.poll(), flush=True)
            FmuHost(1).close()
            host.close()
            print("late start ok", flush=True)
        threading.Thread(target=late).start()
        ready.wait()
        """)
    )
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert out.stdout.splitlines() == ["child 0", "late worker None", "late start ok"], out.stderr


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_the_fmu_process_passes_on_no_descriptor_and_ignores_the_current_folder(
    faulty: BuiltModel, tmp_path: Path
) -> None:
    with FmuLibrary(faulty.fmi2) as lib, FmuHost(1) as host:
        host.add(0, lib, "f1", {}, (0.0, 0.0, 0.0))
        cmdline = Path(f"/proc/{host.pid}/cmdline").read_bytes().split(b"\0")[:-1]
        assert cmdline[1] == b"-P" and cmdline[5] == b"lfctl.fmu.host", cmdline
        for fd in cmdline[6:]:  # its connection and the shared rows: close-on-exec in it
            flags = next(x for x in Path(f"/proc/{host.pid}/fdinfo/{int(fd)}").read_text().splitlines() if "flags" in x)
            assert int(flags.split()[1], 8) & os.O_CLOEXEC, (fd, flags)
    # a numpy.py in the folder lfctl runs from is not the worker's numpy
    (tmp_path / "numpy.py").write_text("raise ImportError('the wrong numpy')\n")
    scen = tmp_path / "s.toml"
    scen.write_text(_scenario(faulty.fmi2, 0, 0.0, tmp_path / "logs"))
    run = subprocess.run(
        [sys.executable, "-P", "-m", "lfctl", "sim", str(scen), "-q"], cwd=tmp_path, capture_output=True, text=True
    )
    assert (run.returncode, run.stderr) == (0, "")
    # a run started with -E ignores PYTHONPATH, and so does its worker: another lfctl there
    # is neither's (the worker had the parent's package folder put first on PYTHONPATH once)
    (tmp_path / "other" / "lfctl").mkdir(parents=True)
    (tmp_path / "other" / "lfctl" / "__init__.py").write_text("raise ImportError('another lfctl')\n")
    run = subprocess.run(
        [sys.executable, "-E", "-P", "-m", "lfctl", "sim", str(scen), "-q"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(tmp_path / "other")},
    )
    assert (run.returncode, run.stderr) == (0, "")
