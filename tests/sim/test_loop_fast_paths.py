"""The main loop's faster paths against the plain computations they replace: the world
state made once per tick, and the endpoints fed from its arrays."""

from __future__ import annotations

import numpy as np
import pytest

from lfctl.config import parse_config
from lfctl.sim.cosim import Simulation
from lfctl.sim.links import Links
from lfctl.sim.world import WorldState

pytestmark = pytest.mark.fmu

TWO = """
[sim]
dt_s = 0.01
duration_s = 1.0
[[vehicles]]
name = "leader"
role = "leader"
north_m = 2.0
east_m = 1.0
yaw_deg = 90
[[vehicles]]
name = "f1"
role = "follower"
"""


def _plain_state(sim: Simulation) -> WorldState:
    """What state() computed before it was cached: a fresh WorldState from the outputs."""
    sim._state = None
    return sim.state()


def test_state_is_made_once_per_tick_and_follows_every_step() -> None:
    with Simulation(parse_config(TWO)) as sim:
        sim.set_command(0, 1.0, 0.2)
        for _ in range(30):
            first = sim.state()
            assert sim.state() is first  # shared by the tasks of one tick
            for a in (first.pos_ned_m, first.yaw_rad, first.speed_mps, first.yaw_rate_radps):
                assert not a.flags.writeable  # no reader can change what another sees
            sim.step()
            now = sim.state()
            assert now is not first and now.t_s == sim.t_s
            fresh = _plain_state(sim)
            for a, b in zip(
                (now.pos_ned_m, now.yaw_rad, now.speed_mps, now.yaw_rate_radps),
                (fresh.pos_ned_m, fresh.yaw_rad, fresh.speed_mps, fresh.yaw_rate_radps),
                strict=True,
            ):
                assert a.tobytes() == b.tobytes()
        assert sim.state().pos_ned_m[0, 1] > 1.0  # the leader moved east: the steps were seen


def test_links_feed_each_endpoint_what_world_vehicle_says() -> None:
    cfg = parse_config(TWO)
    links = Links(cfg, realtime=False)
    try:
        rng = np.random.default_rng(3)
        world = WorldState(
            1.25,
            cfg_names := tuple(v.name for v in cfg.vehicles),
            rng.normal(size=(len(cfg_names), 2)) * 100,
            rng.uniform(-3, 3, len(cfg_names)),
            rng.normal(size=len(cfg_names)),
            rng.normal(size=len(cfg_names)),
        )
        seen: list[dict[str, float]] = []
        for ep in links.endpoints:
            ep.tick = lambda t_s, state, _seen=seen: _seen.append(state)  # type: ignore[method-assign]
        links.tick(1.25, world)
        assert len(seen) == len(cfg_names)
        for i, state in enumerate(seen):
            v = world.vehicle(i)
            want = {
                "north_m": v.north_m,
                "east_m": v.east_m,
                "yaw_rad": v.yaw_rad,
                "speed_mps": v.speed_mps,
                "yaw_rate_radps": v.yaw_rate_radps,
            }
            assert state == want
            assert all(type(x) is float for x in state.values())
    finally:
        links.close()
