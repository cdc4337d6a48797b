"""The co-simulation master: scheduling, determinism, world state, user FMUs through a map."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from lfctl.config import parse_config
from lfctl.errors import ConfigError
from lfctl.sim.cosim import Simulation
from lfctl.sim.links import Links
from lfctl.sim.scripted import scripted_command
from lfctl.sim.world import WorldState

pytestmark = pytest.mark.fmu

TWO = """
[sim]
dt_s = 0.01
duration_s = 10.0
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


def scripted_run(text: str, duration_s: float | None = None, loaded: list[Path] | None = None):
    """The scenario's run with its scripted commands; the FMU files it loaded are added to
    ``loaded`` when given."""
    cfg = parse_config(text)
    with Simulation(cfg) as sim:

        def script(t_s: float) -> None:
            v, r = scripted_command(cfg.script, t_s)
            for i in range(len(sim.names)):
                sim.set_command(i, v, r)

        sim.add_task("script", 20.0, script)
        if loaded is not None:
            loaded.extend(sim.fmu_paths)
        return sim.run(duration_s)


def test_initial_pose_comes_from_the_scenario() -> None:
    with Simulation(parse_config(TWO)) as sim:
        st = sim.state()
    assert st.pos_ned_m[0] == pytest.approx([2.0, 1.0]) and st.yaw_rad[0] == pytest.approx(math.pi / 2)
    assert st.pos_ned_m[1] == pytest.approx([0.0, 0.0])


def test_tasks_run_at_their_rates() -> None:
    calls: dict[str, list[float]] = {"physics": [], "guidance": [], "camera": [], "slow": []}
    with Simulation(parse_config(TWO)) as sim:
        sim.add_task("physics", 100.0, calls["physics"].append)
        sim.add_task("guidance", 20.0, calls["guidance"].append)
        sim.add_task("camera", 30.0, calls["camera"].append)
        sim.add_task("slow", 0.7, calls["slow"].append)
        sim.run(10.0)
    assert len(calls["physics"]) == 1000
    assert len(calls["guidance"]) == 200 and calls["guidance"][1] == pytest.approx(0.05)
    assert len(calls["camera"]) == 300  # 30 Hz on a 100 Hz grid: gaps of 3 or 4 ticks, no drift
    gaps = np.diff(calls["camera"])
    assert set(np.round(gaps, 6)) <= {0.03, 0.04} and calls["camera"][-1] == pytest.approx(9.97)
    assert len(calls["slow"]) == 7


def test_task_faster_than_physics_is_refused() -> None:
    with Simulation(parse_config(TWO)) as sim, pytest.raises(ConfigError, match=r"faster than the physics rate"):
        sim.add_task("x", 200.0, lambda t: None)


def test_same_scenario_twice_is_bit_identical() -> None:
    a = scripted_run(TWO)
    b = scripted_run(TWO)
    assert np.array_equal(a.pos_ned_m, b.pos_ned_m) and np.array_equal(a.yaw_rad, b.yaw_rad)
    assert a.pos_ned_m.shape == (100 + 1, 2, 2)  # 10 Hz samples at 0.0 .. 9.9 s, plus the final state


def test_run_advances_time_and_moves_the_leader() -> None:
    r = scripted_run(TWO, 5.0)
    assert r.sim_time_s == pytest.approx(5.0) and r.final.t_s == pytest.approx(5.0)
    # the default script drives 0.3 m/s straight for 4 s along yaw 90 deg (east)
    assert r.final.pos_ned_m[0, 1] > 1.0 + 1.0


def test_progress_is_told_about_once_a_second_and_at_the_end() -> None:
    told: list[float] = []
    with Simulation(parse_config(TWO)) as sim:
        sim.run(3.0, progress=lambda t_s, _wall_s: told.append(t_s))
    assert len(told) == 4 and told[-1] == pytest.approx(3.0)  # a bar drawn to its end


def test_set_command_rejects_non_finite() -> None:
    with Simulation(parse_config(TWO)) as sim, pytest.raises(ValueError, match=r"leader: commands must be finite"):
        sim.set_command("leader", math.nan, 0.0)


def test_fmi3_vehicle_runs_like_fmi2() -> None:
    from fmpy import read_model_description

    loaded_2: list[Path] = []
    loaded_3: list[Path] = []
    a = scripted_run(TWO, loaded=loaded_2)
    b = scripted_run(
        TWO.replace('name = "f1"', 'name = "f1"\nfmi_version = 3').replace(
            "yaw_deg = 90", "yaw_deg = 90\nfmi_version = 3"
        ),
        loaded=loaded_3,
    )
    # the key reaches the loader: each run loaded one file, of the version asked for
    assert [read_model_description(str(p)).fmiVersion for p in loaded_2] == ["2.0"]
    assert [read_model_description(str(p)).fmiVersion for p in loaded_3] == ["3.0"]
    np.testing.assert_allclose(a.pos_ned_m, b.pos_ned_m, atol=1e-9)


# -- a vehicle from another exporter, mapped by name with yaw in degrees ---------------------

PYTHONFMU_ROVER = textwrap.dedent(
    '''
    import math
    from pythonfmu import Fmi2Causality, Fmi2Slave, Real

    class DegRover(Fmi2Slave):
        """Kinematic unicycle with other names and yaw in degrees (RK4, 1 ms sub-steps)."""

        description = "test vehicle from pythonfmu"

        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.v_ref = 0.0
            self.r_ref = 0.0
            self.x = self.y = self.psi_deg = self.u = self.r_deg = 0.0
            self.register_variable(Real("v_ref", causality=Fmi2Causality.input))
            self.register_variable(Real("r_ref", causality=Fmi2Causality.input))
            for name in ("x", "y", "psi_deg", "u", "r_deg"):
                self.register_variable(Real(name, causality=Fmi2Causality.output))

        def do_step(self, t, dt):
            n = max(1, math.ceil(dt / 0.001 - 1e-9))
            h = dt / n
            v = max(-0.6, min(0.6, self.v_ref))
            r = max(-3.0, min(3.0, self.r_ref))
            for _ in range(n):
                def f(psi):
                    return v * math.cos(psi), v * math.sin(psi), r
                psi = math.radians(self.psi_deg)
                k1 = f(psi)
                k2 = f(psi + 0.5 * h * k1[2])
                k3 = f(psi + 0.5 * h * k2[2])
                k4 = f(psi + h * k3[2])
                self.x += h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
                self.y += h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
                psi += h / 6 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2])
                psi = math.atan2(math.sin(psi), math.cos(psi))
                self.psi_deg = math.degrees(psi)
            self.u = v
            self.r_deg = math.degrees(r)
            return True
    '''
)


@pytest.fixture(scope="module")
def pythonfmu_rover(tmp_path_factory: pytest.TempPathFactory) -> Path:
    pytest.importorskip("pythonfmu")
    folder = tmp_path_factory.mktemp("pythonfmu")
    script = folder / "DegRover.py"
    script.write_text(PYTHONFMU_ROVER)
    subprocess.run(
        [sys.executable, "-m", "pythonfmu", "build", "-f", str(script), "-d", str(folder)],
        check=True,
        capture_output=True,
    )
    return folder / "DegRover.fmu"


def byo_scenario(fmu: Path, extra: str = "") -> str:
    return f"""
[sim]
duration_s = 8.0
[[vehicles]]
name = "leader"
role = "leader"
model = "KinematicUnicycle"
north_m = 1.0
east_m = -2.0
yaw_deg = 30
[[vehicles]]
name = "f1"
role = "follower"
fmu = "{fmu}"
north_m = 1.0
east_m = -2.0
yaw_deg = 30
[vehicles.map]
speed_cmd = "v_ref"
yaw_rate_cmd = "r_ref"
north = "x"
east = "y"
yaw = "psi_deg"
speed = "u"
yaw_rate = "r_deg"
[vehicles.units]
yaw = "deg"
yaw_rate = "deg/s"
{extra}
[script]
leader = [[2.0, 0.3, 0.0], [3.0, 0.25, 40.0], [3.0, 0.4, -25.0]]
followers = "copy"
"""


@pytest.mark.integration
def test_user_fmu_from_another_exporter_drives_the_same_trajectory(pythonfmu_rover: Path) -> None:
    r = scripted_run(byo_scenario(pythonfmu_rover))
    leader, follower = r.pos_ned_m[:, 0], r.pos_ned_m[:, 1]
    assert np.abs(leader - follower).max() < 1e-9
    yaw_err = np.abs(np.angle(np.exp(1j * (r.yaw_rad[:, 0] - r.yaw_rad[:, 1]))))
    assert yaw_err.max() < 1e-9
    assert np.linalg.norm(leader[-1] - leader[0]) > 1.0  # it did move


@pytest.mark.integration
def test_user_fmu_missing_mapped_variable_is_named(pythonfmu_rover: Path) -> None:
    text = byo_scenario(pythonfmu_rover).replace('yaw = "psi_deg"', 'yaw = "heading"')
    with pytest.raises(ConfigError, match=r"variable 'heading' \(mapped to role 'yaw'\) does not exist"):
        scripted_run(text)


@pytest.mark.integration
def test_user_fmu_wrong_causality_is_named(pythonfmu_rover: Path) -> None:
    text = byo_scenario(pythonfmu_rover).replace('north = "x"', 'north = "v_ref"')
    with pytest.raises(ConfigError, match=r"'v_ref' mapped to role 'north' has causality 'input', expected 'output'"):
        scripted_run(text)


@pytest.mark.integration
def test_user_fmu_with_unconvertible_unit_is_named(pythonfmu_rover: Path) -> None:
    text = byo_scenario(pythonfmu_rover).replace('yaw = "deg"', 'yaw = "furlong"')
    with pytest.raises(
        ConfigError,
        match=r"unit 'furlong' of role 'yaw' in \[vehicles\.units\] \(variable 'psi_deg' declares none\); expected one "
        r"convertible to rad",
    ):
        scripted_run(text)


# the main loop's faster paths against the plain computations they replace: the world
# state made once per tick, and the endpoints fed from its arrays


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
