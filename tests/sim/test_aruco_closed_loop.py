"""Closed loop on camera sensing with an ArUco banner (examples/convoy-aruco.toml): the
follower sees only its rendered camera, finds the leader's tag and holds its slot."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from lfctl.config import load_config
from lfctl.sim.runner import run_scenario

pytestmark = pytest.mark.fmu

EXAMPLES = Path(__file__).parents[2] / "examples"


@pytest.mark.slow
def test_camera_sensing_on_an_aruco_banner_holds_the_formation() -> None:
    cfg = load_config(EXAMPLES / "convoy-aruco.toml")
    assert cfg.banner.kind == "aruco" and cfg.sim.sensing == "camera"
    rep = run_scenario(cfg, duration_s=20.0)  # the first leg and the first corner
    m = rep.metrics[0]
    assert m.range_err_rms_m <= 0.10 * m.range_cmd_m, m
    assert math.degrees(m.bearing_err_rms_rad) <= 5.0, m
    assert m.min_separation_m >= 0.3
    assert m.time_in_state_s["lost"] < 1.0  # only before the first frame
    assert m.time_in_state_s["tracking"] > 18.0  # of the 20 s run
    assert len(rep.waypoints_reached) >= 1
