"""Cameras across worker processes: the same run with any number of workers, and a worker's
failure reported by name."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from lfctl.config import load_config
from lfctl.sim.camera_pool import CameraJob, CameraPool, CameraWorkerError, default_workers
from lfctl.sim.runner import run_scenario
from lfctl.sim.world import WorldState

pytestmark = pytest.mark.fmu

EXAMPLES = Path(__file__).parents[2] / "examples"


def column5(workers: int):
    cfg = load_config(EXAMPLES / "column5.toml")
    return dataclasses.replace(cfg, sim=dataclasses.replace(cfg.sim, sensing="camera", camera_workers=workers))


def world(n: int) -> WorldState:
    pos = np.array([[-1.5 * k, 0.0] for k in range(n)])
    return WorldState(0.0, tuple(f"v{k}" for k in range(n)), pos, np.zeros(n), np.zeros(n), np.zeros(n))


def test_a_run_is_the_same_with_any_number_of_camera_workers() -> None:
    # each follower's camera (renderer, tracker, their random streams) lives in one process
    # and sees the same world states in order: where it runs must not matter
    alone = run_scenario(column5(0), duration_s=3.0)
    spread = run_scenario(column5(2), duration_s=3.0)
    assert alone.result.extra["camera_workers"] == 0 and spread.result.extra["camera_workers"] == 2
    assert np.array_equal(alone.result.pos_ned_m, spread.result.pos_ned_m)
    for a, b in zip(alone.traces, spread.traces, strict=True):
        assert a.status == b.status and a.range_m == b.range_m


def test_workers_default_to_spare_cores_and_never_exceed_the_followers() -> None:
    cfg = column5(-1)
    assert 0 <= default_workers(cfg) <= 3
    assert default_workers(column5(9)) == 3  # four followers: this process runs one of them
    one = load_config(EXAMPLES / "convoy.toml")
    assert default_workers(one) == 0


def test_a_failing_worker_is_reported_with_its_followers_and_traceback() -> None:
    cfg = column5(1)
    with CameraPool(cfg, [("f1", 1), ("f2", 2)], workers=1) as pool:
        assert pool.where == {"f1": 0, "f2": 1}
        with pytest.raises(CameraWorkerError, match=r"for f2 failed:(.|\n)*IndexError"):
            pool.capture(0.0, world(3), [CameraJob("f2", 7, 0, None)])  # vehicle 7 does not exist


def test_a_killed_worker_is_reported_not_waited_for() -> None:
    cfg = column5(1)
    with CameraPool(cfg, [("f1", 1), ("f2", 2)], workers=1) as pool:
        proc, _conn = pool._procs[0]
        proc.kill()
        proc.wait()
        with pytest.raises(CameraWorkerError, match=r"camera worker for f2 died \(exit code -9\)"):
            pool.capture(0.0, world(3), [CameraJob("f1", 1, 0, None), CameraJob("f2", 2, 1, None)])
