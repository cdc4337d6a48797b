"""A user's FMU as fmpy and the FMI standard would have it: the flags and types its model
description declares, the status and flags its calls return (FaultyRover, its model
description edited where a test needs a declaration it lacks)."""

from __future__ import annotations

import dataclasses
import math
import os
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest

from lfctl.config import parse_config
from lfctl.errors import ConfigError, FmuError
from lfctl.fmu.build import BuiltModel
from lfctl.fmu.load import INPUT_ROLES, OUTPUT_ROLES, POSE_ROLES, FmuLibrary, RoleMap, _typed_value

pytestmark = pytest.mark.fmu

ROLES = {r: r for r in (*INPUT_ROLES, *OUTPUT_ROLES, *POSE_ROLES)}


def edited(src: Path, dst: Path, edit) -> Path:
    """``src`` with its modelDescription.xml passed through ``edit`` (text -> text)."""
    with zipfile.ZipFile(src) as a, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as b:
        for info in a.infolist():
            data = a.read(info)
            if info.filename == "modelDescription.xml":
                data = edit(data.decode()).encode()
            b.writestr(info.filename, data)
    return dst


def with_parameter_on_faults_reference(faulty: BuiltModel, dst: Path, name: str, typed: str) -> Path:
    """FaultyRover (FMI 2) with one more parameter, ``name`` of type ``typed`` (``<Integer
    start="0"/>``), on the value reference of its Real `fault`: FMI 2 value references are
    unique per type only."""
    with zipfile.ZipFile(faulty.fmi2) as z:
        vr = re.search(r'name="fault"\s+valueReference="(\d+)"', z.read("modelDescription.xml").decode())
    assert vr is not None
    variable = (
        f'<ScalarVariable name="{name}" valueReference="{vr.group(1)}" causality="parameter" '
        f'variability="fixed">{typed}</ScalarVariable>'
    )
    return edited(faulty.fmi2, dst, lambda md: md.replace("</ModelVariables>", variable + "</ModelVariables>"))


def rows() -> tuple[np.ndarray, np.ndarray]:
    return np.zeros(len(INPUT_ROLES)), np.zeros(len(OUTPUT_ROLES))


def test_an_fmu_that_can_be_instantiated_once_per_process_serves_one_vehicle(
    faulty: BuiltModel, tmp_path: Path
) -> None:
    once = edited(
        faulty.fmi2,
        tmp_path / "once.fmu",
        lambda md: md.replace("<CoSimulation", '<CoSimulation canBeInstantiatedOnlyOncePerProcess="true"', 1),
    )
    with FmuLibrary(once) as lib:
        lib.instantiate("f1", {}, (0.0, 0.0, 0.0), *rows())
        with pytest.raises(ConfigError, match="canBeInstantiatedOnlyOncePerProcess, and 'f1' has its one instance"):
            lib.instantiate("f2", {}, (0.0, 0.0, 0.0), *rows())


def test_an_integer_parameter_goes_through_its_own_setter_and_must_be_whole(faulty: BuiltModel, tmp_path: Path) -> None:
    """FMI 2 value references are unique per type only: an Integer parameter may share the
    value reference of a Real one (here `fault`'s), and must not be set through fmi2SetReal."""
    fmu = with_parameter_on_faults_reference(faulty, tmp_path / "int.fmu", "mode", '<Integer start="0"/>')
    with FmuLibrary(fmu) as lib:
        with pytest.raises(ConfigError, match=r"parameter 'mode' is an Integer: give a whole number .* got 0\.5"):
            lib.instantiate("f1", {"mode": 0.5}, (0.0, 0.0, 0.0), *rows())
        # FaultyRover has no Integer variables: it says so for fmi2SetInteger (fmi2SetReal
        # would have set `fault` to 3)
        with pytest.raises(FmuError, match="fmi2SetInteger returned Error") as err:
            lib.instantiate("f1", {"mode": 3}, (0.0, 0.0, 0.0), *rows())
        assert "no variables of this type" in str(err.value)


def test_a_boolean_parameter_from_a_scenario_goes_through_the_boolean_setter(
    faulty: BuiltModel, tmp_path: Path
) -> None:
    """A scenario's `flag = true` stays a Boolean on its way to the FMU (the config reader
    turned it down as not a number before)."""
    fmu = with_parameter_on_faults_reference(faulty, tmp_path / "bool.fmu", "flag", '<Boolean start="false"/>')
    cfg = parse_config('[[vehicles]]\nname = "leader"\nrole = "leader"\n[vehicles.parameters]\nflag = true\n')
    assert cfg.leader.parameters == {"flag": True} and type(cfg.leader.parameters["flag"]) is bool
    # FaultyRover has no Boolean variables: it says so for fmi2SetBoolean, the setter reached
    with FmuLibrary(fmu) as lib, pytest.raises(FmuError, match="fmi2SetBoolean returned Error"):
        lib.instantiate("f1", dict(cfg.leader.parameters), (0.0, 0.0, 0.0), *rows())


@pytest.mark.parametrize(
    ("kind", "value", "taken"),
    [("Real", 2, 2.0), ("Boolean", 1, True), ("Boolean", False, False), ("Int8", -128, -128), ("UInt16", 65535, 65535)],
)
def test_a_parameter_value_is_taken_as_its_type(kind: str, value: object, taken: object) -> None:
    got = _typed_value(Path("x.fmu"), "p", kind, value)
    assert got == taken and type(got) is type(taken)


@pytest.mark.parametrize(
    ("kind", "value", "says"),
    [("Boolean", 2, "give true, false, 1 or 0"), ("Int8", 128, r"\[-128, 127\]"), ("UInt8", -1, r"\[0, 255\]"),
     ("Integer", 1.5, "whole number"), ("Real", "1", "is a Real"), ("String", 1, "numbers and Booleans only")],
)  # fmt: skip
def test_a_parameter_value_its_type_cannot_hold_is_named(kind: str, value: object, says: str) -> None:
    with pytest.raises(ConfigError, match=f"parameter 'p'.*{says}"):
        _typed_value(Path("x.fmu"), "p", kind, value)


def test_a_value_outside_a_variables_declared_range_is_refused_by_name(faulty: BuiltModel, tmp_path: Path) -> None:
    # FMI: min <= start <= max, and a value set outside them is the caller's error; the
    # range is the variable's own, else its declared type's
    def ranged(md: str) -> str:
        md = md.replace(
            "<DefaultExperiment",
            '<TypeDefinitions><SimpleType name="Delay"><Real unit="s" min="0" max="30"/></SimpleType>'
            "</TypeDefinitions><DefaultExperiment",
            1,
        )
        md = md.replace('<Real unit="s" start="0.0" />', '<Real declaredType="Delay" unit="s" start="0.0" />', 1)
        return md.replace('<Real start="0.0" />', '<Real start="0.0" min="0" max="5" />', 1)  # fault

    fmu = edited(faulty.fmi2, tmp_path / "ranged.fmu", ranged)
    with FmuLibrary(fmu) as lib:
        with pytest.raises(ConfigError, match=r"parameter 'fault' = 7 is outside its declared range \[0, 5\]"):
            lib.instantiate("f1", {"fault": 7}, (0.0, 0.0, 0.0), *rows())
        with pytest.raises(ConfigError, match=r"parameter 'fault_at' = -1\.5 is outside its declared range \[0, 30\]"):
            lib.instantiate("f1", {"fault_at": -1.5}, (0.0, 0.0, 0.0), *rows())
        lib.instantiate("f1", {"fault": 5, "fault_at": 30}, (0.0, 0.0, 0.0), *rows())  # the bounds are inside
    bad_start = edited(
        faulty.fmi2,
        tmp_path / "bad-start.fmu",
        lambda md: md.replace('<Real unit="s" start="0.01" />', '<Real unit="s" start="0.01" min="0.02" />', 1),
    )
    with pytest.raises(
        FmuError, match=r"variable 'internal_step' has start value 0\.01 outside its declared range \[0\.02, inf\]"
    ):
        FmuLibrary(bad_start)


def test_roles_mapped_by_hand_must_exist_and_one_variable_plays_one_role(faulty: BuiltModel) -> None:
    typo = RoleMap(names=ROLES | {"north_0": "x0_typo"}, explicit=frozenset({"north_0"}))
    with pytest.raises(ConfigError, match=r"variable 'x0_typo' \(mapped to role 'north_0'\) does not exist"):
        FmuLibrary(faulty.fmi2, typo)
    twice = RoleMap(names=ROLES | {"north": "east"}, explicit=frozenset({"north"}))
    with pytest.raises(ConfigError, match="variable 'east' is mapped to two roles, 'north' and 'east'"):
        FmuLibrary(faulty.fmi2, twice)


@pytest.mark.parametrize("fmi", [2, 3])
def test_two_roles_on_one_value_reference_are_refused_naming_both(faulty: BuiltModel, tmp_path: Path, fmi: int) -> None:
    # a model description whose yaw-rate input has the speed input's value reference: every
    # turn command would be written onto the speed (the follower could never turn)
    import re

    def shared(md: str) -> str:
        def vr_of(name: str) -> str:
            m = re.search(rf'name="{name}"[^>]*?valueReference="(\d+)"', md)
            assert m is not None, name
            return m.group(1)

        speed, turn = vr_of("speed_cmd"), vr_of("yaw_rate_cmd")
        at = md.index('name="yaw_rate_cmd"')
        return md[:at] + md[at:].replace(f'valueReference="{turn}"', f'valueReference="{speed}"', 1)

    fmu = edited(faulty.path(fmi), tmp_path / "shared.fmu", shared)
    if fmi == 3:  # FMI 3 has no aliases: fmpy's validation refuses the model description
        with pytest.raises(FmuError, match=r'"yaw_rate_cmd" .* has the same value reference as variable "speed_cmd"'):
            FmuLibrary(fmu)
        return
    with pytest.raises(  # FMI 2's aliases share one: as roles, refused here
        ConfigError,
        match=r"variables 'speed_cmd' \(role 'speed_cmd'\) and 'yaw_rate_cmd' \(role 'yaw_rate_cmd'\) share value "
        r"reference \d+: one value",
    ):
        FmuLibrary(fmu)


def test_an_array_variable_cannot_play_a_role(faulty: BuiltModel, tmp_path: Path) -> None:
    def yaw_array(md: str) -> str:
        start = md.index('name="yaw"')
        end = md.index("/>", start)
        return md[:end] + '><Dimension start="2"/></Float64>' + md[end + 2 :]

    fmu = edited(faulty.fmi3, tmp_path / "array.fmu", yaw_array)
    with pytest.raises(ConfigError, match="variable 'yaw' mapped to role 'yaw' is an array, expected a scalar"):
        FmuLibrary(fmu)


def test_a_warning_from_dostep_is_a_step_done_and_terminate_simulation_ends_the_run(faulty: BuiltModel) -> None:
    """fmi2Warning: "the computation can continue" (FMI 2.0, 2.1.3): the outputs are read and
    the time moves on (lfctl's time fell a step behind the FMU's, and its next doStep was an
    Error). FMI 3's terminateSimulation from doStep: the FMU asks to stop, and the run ends."""
    with FmuLibrary(faulty.fmi2) as lib:
        cmd, out = rows()
        inst = lib.instantiate("f1", {}, (0.0, 0.0, 0.0), cmd, out)
        real_do = inst._do
        inst._do = lambda *args: real_do(*args) or 1  # each step done, with a warning
        cmd[:] = (1.0, 0.0)
        for _ in range(3):
            inst.step(0.1)
        assert inst.t_s == pytest.approx(0.3) and out[0] == pytest.approx(0.3)
    with FmuLibrary(faulty.fmi3) as lib:
        inst = lib.instantiate("f1", {}, (0.0, 0.0, 0.0), *rows())
        real_do = inst._do

        def asks_to_stop(*args: object) -> int:
            status = real_do(*args)
            inst._flags[1].value = True  # terminateSimulation
            return status

        inst.step(0.1)
        inst._do = asks_to_stop
        with pytest.raises(FmuError, match=r"fmi3DoStep at t=0\.1 s asked to end the simulation"):
            inst.step(0.1)


def test_two_vehicles_on_one_fmu_file_need_one_mapping(faulty: BuiltModel, tmp_path: Path) -> None:
    from lfctl.config import parse_config
    from lfctl.sim.cosim import Simulation

    text = f"""
name = "shared"
[[vehicles]]
name = "leader"
role = "leader"
fmu = "{faulty.fmi2}"
[[vehicles]]
name = "f1"
role = "follower"
fmu = "{faulty.fmi2}"
north_m = -1.5
[vehicles.units]
yaw = "deg"
"""
    cfg = parse_config(text)
    with pytest.raises(ConfigError, match=r"vehicles\[leader\] and vehicles\[f1\] use .* with different map/units"):
        Simulation(cfg).open()
    same = dataclasses.replace(cfg, vehicles=(cfg.vehicles[0], dataclasses.replace(cfg.vehicles[1], units={})))
    with Simulation(same):
        pass


def test_after_a_fatal_status_no_function_of_the_fmu_is_called(faulty: BuiltModel) -> None:
    """FMI 2.0, 2.1.3: after fmi2Fatal "it is not possible to call any other function" (a
    pythonfmu FMU crashed the process in the fmi2Terminate lfctl called while freeing)."""
    calls: list[str] = []
    with FmuLibrary(faulty.fmi2) as lib:
        inst = lib.instantiate("f1", {}, (0.0, 0.0, 0.0), *rows())
        inst._slave.terminate = lambda: calls.append("terminate")
        inst._do = lambda *args: 4  # fmi2Fatal
        with pytest.raises(FmuError, match="returned Fatal"):
            inst.step(0.1)
    assert calls == []


@pytest.mark.parametrize(
    ("unit", "base", "scale"),
    [("degree", 'rad="1" factor="0.017453292519943295"', math.pi / 180), ("mrad", 'rad="1" factor="0.001"', 1e-3),
     ("1/s", 's="-1"', None), ("furlong", 'm="1" factor="201.168"', None), ("degC", 'K="1" offset="273.15"', None)],
)  # fmt: skip
def test_a_unit_the_fmu_defines_is_converted_by_its_base_unit(
    faulty: BuiltModel, tmp_path: Path, unit: str, base: str, scale: float | None
) -> None:
    """A unit name lfctl's table lacks, defined in <UnitDefinitions> as the role's base units
    times a factor (FMI 2.0, 2.2.2), converts by that factor; other dimensions are refused.
    (The yaw role here; 1/s for yaw_rate, below.)"""

    def yaw_in(md: str) -> str:
        md = md.replace("<UnitDefinitions>", f'<UnitDefinitions><Unit name="{unit}"><BaseUnit {base}/></Unit>', 1)
        start = md.index('name="yaw"')
        return md[:start] + md[start:].replace('unit="rad"', f'unit="{unit}"', 1)

    fmu = edited(faulty.fmi2, tmp_path / "unit.fmu", yaw_in)
    if scale is None:
        with pytest.raises(ConfigError, match=f"has unit '{unit}'; expected one convertible to rad"):
            FmuLibrary(fmu)
        return
    with FmuLibrary(fmu) as lib:
        assert lib.scale["yaw"] == pytest.approx(scale)


def test_a_unit_override_that_does_not_fit_its_role_is_named_as_the_scenarios(faulty: BuiltModel) -> None:
    # it said "variable 'yaw' for role 'yaw' has unit 'm'": the FMU declares rad, the m is the scenario's
    with pytest.raises(
        ConfigError,
        match=r"unit 'm' of role 'yaw' in \[vehicles\.units\] \(variable 'yaw' declares 'rad'\); expected one "
        r"convertible to rad \(rad, deg\)$",
    ):
        FmuLibrary(faulty.fmi2, RoleMap(units={"yaw": "m"}))


@pytest.mark.parametrize("factor", ["0", "-1", "1e999", "NaN"])
def test_a_unit_factor_that_is_not_finite_and_positive_is_refused(
    faulty: BuiltModel, tmp_path: Path, factor: str
) -> None:
    # factor 0 froze the vehicle at 0, 0 and ran "successfully"; 1e999 (inf) failed later, unclearly
    def north_in(md: str) -> str:
        md = md.replace(
            "<UnitDefinitions>", f'<UnitDefinitions><Unit name="bad"><BaseUnit m="1" factor="{factor}"/></Unit>', 1
        )
        start = md.index('name="north"')
        return md[:start] + md[start:].replace('unit="m"', 'unit="bad"', 1)

    with pytest.raises(ConfigError, match=rf"unit 'bad' has factor {float(factor):g}; it must be finite and > 0"):
        FmuLibrary(edited(faulty.fmi2, tmp_path / "bad.fmu", north_in))


def test_an_fmu_path_that_is_no_regular_file_is_named_as_such(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "pipe.fmu")
    for path, why in ((tmp_path / "pipe.fmu", "is not a regular file"), (tmp_path / "none.fmu", "does not exist")):
        with pytest.raises(FmuError, match=f"FMU file {path} {why}"):
            FmuLibrary(path)


def test_a_yaw_rate_in_1_per_s_is_rad_per_s(faulty: BuiltModel, tmp_path: Path) -> None:
    def rate_in(md: str) -> str:
        md = md.replace("<UnitDefinitions>", '<UnitDefinitions><Unit name="1/s"><BaseUnit s="-1"/></Unit>', 1)
        start = md.index('name="yaw_rate"')
        return md[:start] + md[start:].replace('unit="rad/s"', 'unit="1/s"', 1)

    with FmuLibrary(edited(faulty.fmi2, tmp_path / "rate.fmu", rate_in)) as lib:
        assert lib.scale["yaw_rate"] == 1.0
