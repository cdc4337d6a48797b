"""The benchmarks' own arithmetic and how `lfctl bench` ends, on made-up figures and runs."""

from __future__ import annotations

import contextlib
import json
import math
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from lfctl.bench.common import print_json
from lfctl.bench.formation import compare


def _run(law: str, range_rms_m: float, path_rms_m: float, chattering_per_s: float = 1.0) -> dict:
    return {
        "scenario": "vee",
        "sensing": "camera",
        "controller": law,
        "range_rms_m": range_rms_m,
        "chattering_per_s": chattering_per_s,
        "path_rms_m": path_rms_m,
        "lost_s": 0.0,
    }


def test_formation_compares_the_figures_as_measured_not_as_printed() -> None:
    # a --quick run's vee on camera: 0.003569 and 0.003621 m, both 0.0036 as printed (4
    # digits); the sliding mode is 1.4 % below the P baseline, and meets its target
    runs = [_run("smc", 0.003569, 0.000908), _run("p", 0.003621, 0.016379), _run("trail", 0.007, 0.003304)]
    (got,) = compare(runs)
    assert got["range_rms_ratio_smc_over_p"] == 0.986  # 0.003569 / 0.003621 = 0.98564
    assert got["smc_beats_p_on_range_without_more_chattering"] is True
    # 0.003304 / 0.000908 = 3.639 (from the printed 0.0033 / 0.0009: 3.667)
    assert got["path_rms_ratio_trail_over_smc"] == 3.639
    assert got["trail_on_path_lost_no_longer"] is False


def _fake_benchmark(tmp_path: Path, bench: str, pid_file: Path, driver_head: str = "") -> tuple[subprocess.Popen, int]:
    """``run_all`` of one benchmark whose process runs ``bench`` (as ``python -m
    lfctl.bench.NAME`` would), in a driver process; returns the driver and the pid ``bench``
    writes to ``pid_file`` once it runs."""
    fake_python = tmp_path / "python"  # what run_all starts as `python -m lfctl.bench.NAME`
    fake_python.write_text(f"#!/bin/sh\nexec {shlex.quote(sys.executable)} -c {shlex.quote(bench)}\n")
    fake_python.chmod(0o755)
    driver = (
        f"{driver_head}import sys; sys.executable = {str(fake_python)!r}; import lfctl.bench; "
        f"lfctl.bench.run_all(('cosim',), True, __import__('pathlib').Path({str(tmp_path)!r}))"
    )
    proc = subprocess.Popen([sys.executable, "-c", driver], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    for _ in range(200):
        if pid_file.exists() and pid_file.read_text():
            return proc, int(pid_file.read_text())
        time.sleep(0.05)
    proc.kill()
    raise AssertionError("the benchmark did not start")


def _end(proc: subprocess.Popen, pid: int) -> None:
    if proc.poll() is None:
        proc.kill()
    if _alive(pid):
        os.kill(pid, signal.SIGKILL)


def test_ctrl_c_of_every_benchmark_leaves_nothing_a_benchmark_started(tmp_path: Path) -> None:
    # a benchmark (run by run_all in a process of its own) that started a process which
    # outlives a Ctrl-C, as vision's pool workers do (they catch it as a job's error and wait
    # for the next job): subprocess.run killed the benchmark alone and left them for ever
    pid_file = tmp_path / "worker.pid"
    worker = (
        "import os, signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); "
        f"open({str(pid_file)!r}, 'w').write(str(os.getpid())); time.sleep(120)"
    )
    bench = f"import subprocess, sys, time; subprocess.Popen([sys.executable, '-c', {worker!r}]); time.sleep(120)"
    head = "import signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
    proc, worker_pid = _fake_benchmark(tmp_path, bench, pid_file, head)
    try:
        proc.send_signal(signal.SIGINT)  # Ctrl-C
        assert proc.wait(timeout=60) != 0
        assert b"KeyboardInterrupt" in proc.stderr.read()  # (stopped, not ended by itself)
        time.sleep(0.5)
        assert not _alive(worker_pid), "the benchmark's worker outlived Ctrl-C"
        assert not (tmp_path / "bench-results.json").exists()  # nothing written after a Ctrl-C
    finally:
        _end(proc, worker_pid)


def test_a_benchmark_stopped_by_ctrl_c_is_read_while_it_ends(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # a benchmark that writes more than a pipe holds as it ends (its pool's workers' tracebacks,
    # a cluster's close): the wait for it read nothing, so it blocked on the full pipe and was
    # killed at STOP_S without finishing its cleanup
    import lfctl.bench

    monkeypatch.setattr(lfctl.bench, "STOP_S", 20.0)
    done = tmp_path / "cleaned"
    code = (
        "import sys, time\ntry:\n    time.sleep(60)\nexcept KeyboardInterrupt:\n"
        f"    sys.stderr.write('x' * 200_000)\n    sys.stderr.flush()\n    open({str(done)!r}, 'w').close()\n"
    )
    with subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    ) as child:
        time.sleep(1.0)  # (in its sleep)
        lfctl.bench._stop_child(child)
    assert child.returncode == 0 and done.exists()  # it finished its cleanup, not killed at STOP_S


def test_a_hangup_stops_the_benchmark_running(tmp_path: Path) -> None:
    # the terminal closed: the shell passes SIGHUP to its job, lfctl's process group; the
    # benchmark, in a session of its own, heard nothing and ran on with nobody to read it
    pid_file = tmp_path / "bench.pid"
    bench = f"import os, time; open({str(pid_file)!r}, 'w').write(str(os.getpid())); time.sleep(120)"
    proc, bench_pid = _fake_benchmark(tmp_path, bench, pid_file)
    try:
        proc.send_signal(signal.SIGHUP)
        proc.wait(timeout=60)
        time.sleep(0.5)
        assert not _alive(bench_pid), "the benchmark outlived the hangup"
    finally:
        _end(proc, bench_pid)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with contextlib.suppress(OSError):  # a zombie (its parent gone, init not yet reaped it) is not alive
        return Path(f"/proc/{pid}/stat").read_text().split(") ")[-1][0] != "Z"
    return True


def test_the_link_benchmarks_p99_is_the_nearest_rank() -> None:
    from lfctl.bench.link import pct

    # of 1..200, 99 % are at or below 198: the 198th; 1..1000: the 990th
    assert pct([float(v) for v in range(200, 0, -1)], 0.99) == 198.0
    assert pct([float(v) for v in range(1, 1001)], 0.99) == 990.0
    assert pct([3.0], 0.99) == 3.0
    assert pct([1.0, 2.0, 3.0, 4.0], 0.5) == 2.0  # (the lower middle: half of them at or below it)


def test_a_peer_that_refused_every_run_of_a_tier_has_no_figures_only_the_reason() -> None:
    from lfctl.bench.vision import refused_on_every_run

    # MIL on the range tier: its first box is the picture's whole height (init: no positive
    # samples), on every seed; the bench printed success 0 for it, as if it had tracked
    why = "init: !posSamples.empty() (-215)"
    runs = [{"init_failed": [f"MIL@range/{seed}: {why}"]} for seed in (0, 1, 2)]
    assert refused_on_every_run("MIL", runs) == why
    assert refused_on_every_run("full", runs) is None  # (it ran)
    # refused on one seed of three: it ran on the others, which it is scored on (the refused one as failing)
    assert refused_on_every_run("MIL", [runs[0], {"init_failed": []}, {"init_failed": []}]) is None


def test_the_closing_json_line_is_strict_json_with_null_for_what_was_not_measured(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # Wrong, a median of nothing (NaN) or an infinite ratio would print a bare NaN or
    # Infinity, which strict JSON readers (JavaScript's JSON.parse) refuse: the whole line
    # lost to the one figure.
    print_json("x", {"a": math.nan, "b": [1.5, math.inf, (2, -math.inf)], "c": {"d": {"e": math.nan}}, "f": "NaN"})
    line = capsys.readouterr().out.strip()

    def refuse(constant: str) -> None:
        raise AssertionError(f"non-standard JSON constant {constant} in {line}")

    doc = json.loads(line, parse_constant=refuse)
    assert doc["benchmark"] == "x"
    assert doc["results"] == {"a": None, "b": [1.5, None, [2, None]], "c": {"d": {"e": None}}, "f": "NaN"}


def test_the_e2e_benchmarks_cpu_seconds_take_in_the_processes_the_run_started() -> None:
    # camera workers and an FMU's own process spend CPU outside this one: the CPU-time factor
    # counts them once they have ended
    from lfctl.bench.e2e import cpu_seconds

    before = cpu_seconds()
    burn = "import time\nwhile time.process_time() < 0.3:\n    pass\n"
    subprocess.run([sys.executable, "-c", burn], check=True, timeout=120)
    assert cpu_seconds() - before >= 0.3
