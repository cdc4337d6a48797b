"""Every example scenario, as a user runs it (20 simulated seconds), and its log audited."""

from __future__ import annotations

from pathlib import Path

import pytest

from lfctl.cli import main
from lfctl.record.audit import audit

EXAMPLES = sorted((Path(__file__).parents[1] / "examples").glob("*.toml"))


@pytest.mark.slow
@pytest.mark.fmu
@pytest.mark.parametrize("scenario", EXAMPLES, ids=lambda p: p.stem)
def test_example_runs_and_its_log_passes_the_audit(
    scenario: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)  # logs/ lands here
    assert main(["sim", str(scenario), "--duration", "20", "-q"]) == 0
    out = capsys.readouterr().out
    assert "sim time     20.00 s" in out and "log          logs/" in out
    (log,) = (tmp_path / "logs").glob("*.mcap")
    report = audit(log)
    assert report.ok, [f.line() for f in report.findings]
    assert main(["audit", str(log), "--strict"]) == 0
