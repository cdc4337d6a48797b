"""One sweep run on a worker: its row, and the log it names."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from lfctl.record.mcap_read import read_contents
from lfctl.sweep.engine import _say_scenario_warnings
from lfctl.sweep.spec import parse_sweep, plan
from lfctl.sweep.task import execute, log_name

pytestmark = pytest.mark.fmu

SWEEP = 'scenario = "convoy"\nseeds = 1\n[set]\n"sim.duration_s" = 1.0\n"sim.sensing" = "truth"\n'


def test_a_runs_log_is_its_own_not_an_earlier_attempts(tmp_path: Path) -> None:
    # an earlier attempt's torn log at the run's name (its worker killed under it): the
    # recorder, which never writes over a file, took run-00000-2.mcap and the row named the
    # torn one; with --logs failed, the good log of a run that succeeded stayed behind
    (run,) = plan(parse_sweep(SWEEP)).runs
    for logs in ("all", "failed"):
        out = tmp_path / logs
        (out / "logs").mkdir(parents=True)
        torn = out / log_name(run.run)
        torn.write_bytes(b"\x89MCAP0\r\n torn")
        row = execute(run, str(out), logs)
        assert row["status"] == "ok"
        if logs == "all":
            assert row["log_path"] == log_name(run.run)
            _, findings = read_contents(out / row["log_path"])
            assert not [f for f in findings if f.level == "error"], findings
        else:
            assert row["log_path"] == ""
        assert sorted(p.name for p in (out / "logs").iterdir()) == (["run-00000.mcap"] if logs == "all" else [])


def test_the_scenarios_warnings_are_said_once_by_the_sweep_not_by_each_run(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # the convoy's occluder (30 s) and dropout come after a 1 s run's end: each run said both
    # on its worker, two lines a run past the terminal's guard
    p = plan(parse_sweep(SWEEP.replace("seeds = 1", "seeds = 2") + "[grid]\n'guidance.controller' = ['smc', 'p']\n"))
    with caplog.at_level(logging.WARNING):
        _say_scenario_warnings(p)
        said = [r.getMessage() for r in caplog.records]
        caplog.clear()
        rows = [execute(run, str(tmp_path)) for run in p.runs[:2]]
    assert [r["status"] for r in rows] == ["ok", "ok"]
    assert len(said) == 2 and all(m.startswith("every run: ") for m in said), said
    assert "it never crosses" in said[0] and "it never happens" in said[1]
    assert not [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert not logging.getLogger("lfctl.sim.runner").filters  # (taken off after the run)
