"""A vehicle FMU whose outputs go NaN, infinite or absurd ends the run with an FmuError that
names the FMU, the variable, the value and the time, not a traceback further on."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from fmu_faults import FAR, HUGE, INF, NAN, faulty_scenario

from lfctl.cli import main
from lfctl.config import parse_config
from lfctl.errors import FmuError
from lfctl.fmu.build import BuiltModel
from lfctl.fmu.host import HostedInstance
from lfctl.fmu.load import KEPT_MESSAGES, OUTPUT_BOUNDS, FmuInstance, FmuLibrary, RoleMap
from lfctl.record.audit import audit
from lfctl.sim.cosim import Simulation

pytestmark = pytest.mark.fmu


def _instance(lib: FmuLibrary, fault: int, fault_at: float):
    cmd, out = np.zeros(2), np.zeros(5)
    inst = lib.instantiate("f1", {"fault": fault, "fault_at": fault_at}, (0.0, 0.0, 0.0), cmd, out)
    return inst, cmd, out


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize(
    ("fault", "variable", "value", "why"),
    [
        (NAN, "north", "nan m", "is not a finite number"),
        (INF, "speed", "inf m/s", "is not a finite number"),
        (HUGE, "east", "1e+308 m", r"is beyond the bound \|east\| <= 1e\+06 m"),
    ],
)
def test_a_bad_output_names_fmu_variable_value_and_time(
    faulty: BuiltModel, fmi: int, fault: int, variable: str, value: str, why: str
) -> None:
    path = faulty.path(fmi)
    with FmuLibrary(path) as lib:
        inst, _cmd, _out = _instance(lib, fault, 0.25)
        for _ in range(24):  # up to t = 0.24 s: fine
            inst.step(0.01)
            inst.check_outputs()
        inst.step(0.01)
        with pytest.raises(FmuError) as err:
            inst.check_outputs()
    msg = str(err.value)
    assert (
        f"FMU FaultyRover ({path}), instance 'f1': output '{variable}' (role {variable}) = {value} at t = 0.25 s" in msg
    )
    assert re.search(why, msg)
    assert err.value.model == "FaultyRover"


def test_bad_initial_outputs_fail_at_instantiation(faulty: BuiltModel) -> None:
    with FmuLibrary(faulty.fmi2) as lib, pytest.raises(FmuError, match=r"output 'north' .* = nan m at t = 0 s"):
        _instance(lib, NAN, 0.0)


def test_the_bound_is_in_si_units_whatever_the_fmu_declares(faulty: BuiltModel) -> None:
    # speed read as km/h: 1000 km/h (278 m/s) passes, 1100 km/h (306 m/s) is beyond 300 m/s
    assert OUTPUT_BOUNDS["speed"] == 300.0
    with FmuLibrary(faulty.fmi2, RoleMap(units={"speed": "km/h", "speed_cmd": "km/h"})) as lib:
        inst, cmd, _out = _instance(lib, 0, 0.0)
        cmd[0] = 1000.0  # FaultyRover's speed is its command
        inst.step(0.01)
        inst.check_outputs()
        cmd[0] = 1100.0
        inst.step(0.01)
        with pytest.raises(FmuError, match=r"output 'speed' \(role speed\) = 1100.0 km/h at t = 0.02 s is beyond"):
            inst.check_outputs()


def _two_vehicles(fmu: Path, fault: int, fault_at: float) -> str:
    return faulty_scenario(fmu, fault, fault_at, Path("unused")).replace("[recording]", "[recording]\nenabled = false")


def test_the_master_checks_every_step(faulty: BuiltModel) -> None:
    with Simulation(parse_config(_two_vehicles(faulty.fmi3, NAN, 0.5))) as sim:
        with pytest.raises(FmuError, match=r"FMU FaultyRover \(.*\.fmi3\.fmu\), instance 'f1': output 'north'"):
            sim.run(1.0)
        assert sim.tick == 49  # the step to 0.5 s failed: no task saw its outputs
        assert np.isfinite(sim.state().pos_ned_m[0]).all()


@pytest.mark.parametrize("where", ["main", "separate"])
def test_far_but_within_bounds_is_not_an_error(faulty: BuiltModel, monkeypatch: pytest.MonkeyPatch, where: str) -> None:
    # 9e5 m north and east: the one-vector check says "look closer", the closer look is fine
    looks = []
    for cls in (FmuInstance, HostedInstance):
        check = cls.check_outputs
        monkeypatch.setattr(cls, "check_outputs", lambda self, check=check: looks.append(self.t_s) or check(self))
    text = _two_vehicles(faulty.fmi2, FAR, 0.1).replace("[sim]", f"[sim]\nfmu_process = '{where}'")
    with Simulation(parse_config(text)) as sim:
        sim.run(0.3)
        assert tuple(sim.state().pos_ned_m[1]) == (9e5, 9e5)
    # after t = 0.1 s, both, every step; in this process, two at instantiation too
    assert len(looks) == 2 * 20 + (2 if where == "main" else 0)


def test_sim_exits_1_with_one_line_and_the_log_says_why(
    faulty: BuiltModel, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scen = tmp_path / "s.toml"
    scen.write_text(faulty_scenario(faulty.fmi2, INF, 1.234, tmp_path / "logs"))
    assert main(["sim", str(scen), "-q"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    expected = f"FMU FaultyRover ({faulty.fmi2}), instance 'f1': output 'speed' (role speed) = inf m/s at t = 1.24 s"
    assert err.startswith(f"lfctl: error: {expected} is not a finite number")
    (log,) = (tmp_path / "logs").glob("*.mcap")
    report = audit(log)
    assert report.figures["end"]["reason"] == f"error: FmuError: {expected} is not a finite number"
    assert float(report.figures["end"]["t_s"]) == pytest.approx(1.23)


def test_an_fmu_that_logs_without_end_keeps_only_the_newest_messages(faulty: BuiltModel) -> None:
    with FmuLibrary(faulty.fmi3) as lib:
        inst, _cmd, _out = _instance(lib, 0, 0.0)
        for _ in range(KEPT_MESSAGES + 50):  # a fixed parameter after initialisation: refused, logged
            with pytest.raises(FmuError):
                inst.set_real({"fault_at": 1.0})
        assert len(inst.messages) == KEPT_MESSAGES


@pytest.mark.parametrize("version", [2, 3])
def test_a_freed_instance_refuses_every_call_without_reaching_the_fmu(faulty: BuiltModel, version: int) -> None:
    # a call into a freed FMU reads freed memory: the second step after free() ended the process
    with FmuLibrary(faulty.path(version)) as lib:
        inst, _cmd, _out = _instance(lib, 0, 0.0)
        inst.step(0.01)
        inst.free()
        for _ in range(3):
            with pytest.raises(FmuError, match=r"\(f1\): fmi[23]Set\w+ after the instance was freed"):
                inst.step(0.01)
        with pytest.raises(FmuError, match=r"fmi[23]Get\w+ after the instance was freed"):
            inst.read()
        with pytest.raises(FmuError, match="Reset after the instance was freed"):
            inst.reset({}, (0.0, 0.0, 0.0))
        inst.free()  # still safe twice
