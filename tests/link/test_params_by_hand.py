"""Parameters as ArduPilot keeps them (AP_Param::set_float's 0.01 nudge before an integer
parameter truncates, the defaults and ranges of the fence, SmartRTL and RC override
parameters), and parameter files as MAVProxy and QGroundControl write them, worked by hand."""

from __future__ import annotations

import math

import pytest

from lfctl.errors import ConfigError
from lfctl.link.params import (
    INT8,
    INT16,
    REAL32,
    Param,
    ParamFileError,
    default_params,
    load_param_file,
    save_param_file,
    set_values,
)

# --- Param.stored, Param.accepts: AP_Param::set_float ------------------------------------------


@pytest.mark.parametrize(
    ("value", "stored"),
    [
        (0.5, 0.0),  # 0.51, truncated
        (0.999, 1.0),  # 1.009
        (2.994, 3.0),  # 3.004
        (2.98, 2.0),  # 2.99
        (-0.999, -1.0),  # below 0 the nudge is -0.01: -1.009
        (-0.5, 0.0),  # -0.51, truncated toward zero
        (7.0, 7.0),
    ],
)
def test_an_integer_parameter_is_nudged_by_a_hundredth_then_truncated(value: float, stored: float) -> None:
    assert Param(0, -100, 100, "", "", kind=INT8).stored(value) == stored


def test_a_float_parameter_is_stored_as_given() -> None:
    assert Param(0.0, -100.0, 100.0, "", "", kind=REAL32).stored(0.7) == 0.7


def test_a_value_is_accepted_if_what_is_stored_is_in_range() -> None:
    # 0..100 INT8: 100.004 is stored 100 (in); 100.995 is stored 101 (out); -0.004 is
    # -0.014 truncated to 0 (in); -1 is out
    p = Param(50, 0, 100, "%", "", kind=INT8)
    assert p.accepts(100.004)
    assert not p.accepts(100.995)
    assert p.accepts(-0.004)
    assert not p.accepts(-1.0)
    assert p.accepts(0.0) and p.accepts(100.0)  # the ends are in


def test_a_read_only_or_not_finite_value_is_refused() -> None:
    assert not Param(1, 1, 255, "", "", readonly=True, kind=INT16).accepts(1.0)
    p = Param(0.0, -1e9, 1e9, "", "")
    assert not p.accepts(math.nan)
    assert not p.accepts(math.inf)


# --- default_params: ArduPilot Rover's defaults and ranges --------------------------------------


def test_the_fence_parameters_start_at_rovers_defaults() -> None:
    # AC_Fence.cpp for Rover: TYPE circle | polygon = 6, ACTION 1 (RTL or hold), RADIUS 300 m
    # (30..10000), MARGIN 2 m; ENABLE 0
    p = default_params(1)
    assert [p[n].value for n in ("FENCE_ENABLE", "FENCE_TYPE", "FENCE_ACTION", "FENCE_RADIUS", "FENCE_MARGIN")] == [
        0,
        6,
        1,
        300.0,
        2.0,
    ]
    assert (p["FENCE_RADIUS"].lo, p["FENCE_RADIUS"].hi) == (30.0, 10000.0)


def test_the_smartrtl_and_override_parameters_start_at_rovers_defaults() -> None:
    # AP_SmartRTL: SRTL_ACCURACY 2 m, SRTL_POINTS 300 (at most 500); RC_OVERRIDE_TIME 3 s
    p = default_params(1)
    assert (p["SRTL_ACCURACY"].value, p["SRTL_POINTS"].value, p["SRTL_POINTS"].hi) == (2.0, 300, 500)
    assert p["RC_OVERRIDE_TIME"].value == 3.0
    assert p["SYSID_MYGCS"].value == 255


def test_sysid_thismav_is_the_vehicles_own_and_read_only() -> None:
    p = default_params(7)["SYSID_THISMAV"]
    assert (p.value, p.readonly, p.kind) == (7, True, INT16)


# --- set_values ----------------------------------------------------------------------------------


def test_set_values_stores_as_the_parameter_keeps_it_and_refuses_out_of_range() -> None:
    # LFC_LAW is 0..2 INT8: 0.999 is stored 1
    params = default_params(1)
    set_values(params, {"LFC_LAW": 0.999, "WP_SPEED": 3.5}, "test")
    assert (params["LFC_LAW"].value, params["WP_SPEED"].value) == (1.0, 3.5)
    with pytest.raises(ConfigError, match=r"scenario: LFC_LAW would be 3, outside its 0\.\.2"):
        set_values(params, {"LFC_LAW": 3}, "scenario")
    assert params["LFC_LAW"].value == 1.0  # unchanged


# --- parameter files -------------------------------------------------------------------------------


def test_mavproxy_and_qgroundcontrol_lines_are_read(tmp_path) -> None:
    f = tmp_path / "p.parm"
    f.write_text(
        "# a comment\n\nWP_SPEED 3.5\nFENCE_RADIUS,120  # comma separated, comment after\n1\t1\tSRTL_POINTS\t250\t4\n"
    )
    assert load_param_file(f) == {"WP_SPEED": 3.5, "FENCE_RADIUS": 120.0, "SRTL_POINTS": 250.0}


@pytest.mark.parametrize(
    ("line", "reason"),
    [
        ("WP_SPEED 1 2", "expected 'NAME VALUE'"),  # three columns
        ("ABCDEFGHIJKLMNOPQ 1", "bad parameter name"),  # 17 characters
        ("WP_SPEÉD 1", "bad parameter name"),  # not ASCII
        ("WP_SPEED fast", "is not a number"),
        ("WP_SPEED inf", "is not finite"),
        ("WP_SPEED 3.5e38", "beyond what MAVLink's float carries"),
    ],
)
def test_a_bad_line_is_named_by_its_number(tmp_path, line: str, reason: str) -> None:
    f = tmp_path / "p.parm"
    f.write_text(f"WP_RADIUS 2\n{line}\n", encoding="utf-8")
    with pytest.raises(ParamFileError) as err:
        load_param_file(f)
    assert err.value.line == 2
    assert reason in err.value.reason


def test_a_name_of_16_characters_and_a_value_of_3_4e38_are_read(tmp_path) -> None:
    f = tmp_path / "p.parm"
    f.write_text("ABCDEFGHIJKLMNOP -3.4e38\n")
    assert load_param_file(f) == {"ABCDEFGHIJKLMNOP": -3.4e38}


def test_mavproxy_files_have_whole_numbers_in_full_and_floats_as_short_as_a_float32(tmp_path) -> None:
    # 1048574 would be 1.04857e+06 in %g; 0.7 as a float32 is 0.699999988, written 0.7;
    # sorted by name, the name padded to 16
    f = tmp_path / "p.parm"
    save_param_file({"WP_SPEED": 0.7, "ARMING_CHECK": 1048574.0}, f)
    assert f.read_text() == "ARMING_CHECK     1048574\nWP_SPEED         0.7\n"


def test_qgroundcontrol_files_have_the_vehicle_and_type_9(tmp_path) -> None:
    f = tmp_path / "p.params"
    save_param_file({"WP_SPEED": 0.5}, f, fmt="qgc", sysid=3)
    assert f.read_text() == (
        "# Onboard parameters for Vehicle 3\n#\n# Vehicle-Id Component-Id Name Value Type\n3\t1\tWP_SPEED\t0.5\t9\n"
    )
    assert load_param_file(f) == {"WP_SPEED": 0.5}


def test_nothing_is_saved_that_could_not_be_read_back(tmp_path) -> None:
    f = tmp_path / "p.parm"
    with pytest.raises(ConfigError, match="1 parameters could not be loaded back"):
        save_param_file({"WP_SPEED": math.nan, "WP_RADIUS": 2.0}, f)
    with pytest.raises(ConfigError, match="format must be"):
        save_param_file({"WP_RADIUS": 2.0}, f, fmt="csv")
    assert not f.exists()


def test_set_values_takes_the_ends_of_the_range() -> None:
    # LFC_LAW 0..2: both ends are in
    params = default_params(1)
    set_values(params, {"LFC_LAW": 0}, "test")
    assert params["LFC_LAW"].value == 0
    set_values(params, {"LFC_LAW": 2}, "test")
    assert params["LFC_LAW"].value == 2


def test_a_one_letter_name_is_saved_and_an_empty_one_is_not(tmp_path) -> None:
    f = tmp_path / "p.parm"
    save_param_file({"A": 1.0}, f)
    assert load_param_file(f) == {"A": 1.0}
    with pytest.raises(ConfigError, match="1 parameters could not be loaded back"):
        save_param_file({"": 1.0}, f)


def test_everything_after_the_first_hash_is_a_comment(tmp_path) -> None:
    f = tmp_path / "p.parm"
    f.write_text("WP_SPEED 2.5 # fast # really\n")
    assert load_param_file(f) == {"WP_SPEED": 2.5}


def test_a_file_of_20000_lines_is_read_and_its_errors_name_the_file(tmp_path) -> None:
    f = tmp_path / "p.parm"
    f.write_text("# x\n" * 19_999 + "WP_SPEED 1\n")  # the 20 000th line is still read
    assert load_param_file(f) == {"WP_SPEED": 1.0}
    missing = tmp_path / "none.parm"
    with pytest.raises(ParamFileError) as err:
        load_param_file(missing)
    assert (err.value.path, err.value.line) == (missing, 0)
    assert str(err.value).startswith(f"{missing}: ")  # the whole file: no line number


def test_a_qgroundcontrol_file_names_vehicle_1_by_default(tmp_path) -> None:
    f = tmp_path / "p.params"
    save_param_file({"WP_SPEED": 0.5}, f, fmt="qgc")
    assert f.read_text().splitlines()[0] == "# Onboard parameters for Vehicle 1"
    assert f.read_text().splitlines()[3].startswith("1\t1\t")
