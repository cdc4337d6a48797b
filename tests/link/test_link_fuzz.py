"""The fuzz benchmark's claim, in CI: hostile datagrams at a recording `lfctl sim --realtime`
crash nothing, and the vehicle still takes a mission, a mode and arming afterwards."""

from __future__ import annotations

import json

import pytest

from lfctl.bench import link_fuzz

pytestmark = [pytest.mark.integration, pytest.mark.slow, pytest.mark.fmu]


def test_a_recording_realtime_run_survives_the_fuzz(capsys: pytest.CaptureFixture[str]) -> None:
    link_fuzz.main(quick=True, soak_s=6.0)
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])["results"]
    assert result["crashes"] == []
    assert result["after_flood"] == {"upload": True, "mode": True, "arm": True}
    assert result["datagrams_handled"] > 0.5 * result["datagrams_sent"]
    assert all(s["handler_errors"] == s["send_errors"] == 0 for s in result["link_stats"].values())
    assert result["parts_guided_and_armed"][0] >= 1  # the first, before any fuzz, at least
