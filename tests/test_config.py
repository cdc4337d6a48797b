"""Scenario loading: every error names the key, the value and the expectation."""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import pytest

from lfctl.config import config_from_table, load_config, parse_config
from lfctl.errors import ConfigError

EXAMPLES = Path(__file__).parents[1] / "examples"

LEADER = '[[vehicles]]\nname = "leader"\nrole = "leader"\n'
FOLLOWER = '[[vehicles]]\nname = "f{n}"\nrole = "follower"\n'


def test_examples_load() -> None:
    root = Path(__file__).parents[1] / "examples"
    convoy = load_config(root / "convoy.toml")
    assert convoy.name == "convoy" and [v.name for v in convoy.vehicles] == ["leader", "follower1"]
    column = load_config(root / "column5.toml")
    assert len(column.followers) == 4


def test_degrees_become_radians_once() -> None:
    cfg = parse_config(LEADER + "yaw_deg = 90.0\n" + FOLLOWER.format(n=1) + "bearing_deg = -30\n")
    assert cfg.leader.yaw_rad == pytest.approx(math.pi / 2)
    assert cfg.followers[0].bearing_rad == pytest.approx(-math.pi / 6)


def test_fmu_parameters_take_numbers_and_booleans_as_written() -> None:
    cfg = parse_config(LEADER + "[vehicles.parameters]\ntau = 2\nflag = true\noff = false\n")
    assert cfg.leader.parameters == {"tau": 2.0, "flag": True, "off": False}
    assert [type(v) for v in cfg.leader.parameters.values()] == [float, bool, bool]
    with pytest.raises(
        ConfigError, match=r"vehicles\[leader\]\.parameters\.tau must be a number, true or false, got \[1\]"
    ):
        parse_config(LEADER + "[vehicles.parameters]\ntau = [1]\n")


@pytest.mark.parametrize(("name", "key"), [("north_0", "north_m"), ("east_0", "east_m"), ("yaw_0", "yaw_deg")])
def test_a_start_pose_parameter_is_refused_naming_the_key_that_sets_it(name: str, key: str) -> None:
    # the run sets north_0, east_0 and yaw_0 from the vehicle's own keys: a value given as an
    # FMU parameter was silently overwritten (north_0 = 1e308 started the vehicle at 0)
    with pytest.raises(ConfigError, match=rf"vehicles\[leader\]\.parameters\.{name}: .* {key} key"):
        parse_config(LEADER + f"[vehicles.parameters]\n{name} = 1e308\n")


def test_defaults_fill_the_sim_section() -> None:
    cfg = parse_config(LEADER)
    assert cfg.sim.dt_s == 0.01 and cfg.sim.clock == "lockstep" and cfg.name == "scenario"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[sim]\ndt_s = -0.01\n" + LEADER, r"sim\.dt_s must be within \[0\.0001, 1\], got -0\.01"),
        ("[sim]\ndt_s = 0\n" + LEADER, r"sim\.dt_s must be within \[0\.0001, 1\], got 0\.0"),
        ("[sim]\nduration_s = 'long'\n" + LEADER, r"sim\.duration_s must be a number, got 'long'"),
        ("[sim]\nclock = 'fast'\n" + LEADER, r"sim\.clock must be one of 'lockstep', 'realtime', got 'fast'"),
        (
            "[sim]\nguidance_rate_hz = 500\n" + LEADER,
            r"guidance_rate_hz = 500.0 Hz is faster than the physics rate 1/dt = 100 Hz",
        ),
        ("[sim]\nspeed = 3\n" + LEADER, r"unknown key 'sim\.speed' \(allowed here: .*dt_s"),
        ("", r"need at least one \[\[vehicles\]\] entry, got none"),
        ("vehicles = 3", r"vehicles must be an array of tables"),
        (FOLLOWER.format(n=1), r"need exactly one role = \"leader\", got 0"),
        (
            LEADER + LEADER.replace('"leader"\nrole', '"l2"\nrole'),
            r"need exactly one role = \"leader\", got 2 \(leader, l2\)",
        ),
        (LEADER + LEADER, r"vehicles\.name must be unique, got \['leader'\]"),
        (FOLLOWER.format(n=1) + LEADER, r"the leader must come first, got 'f1' first"),
        (LEADER + 'role2 = "x"\n', r"unknown key 'vehicles\[leader\]\.role2'"),
        (LEADER + "yaw_rad = 1.0\n", r"unknown key 'vehicles\[leader\]\.yaw_rad'.*yaw_deg"),
        (LEADER + "north_m = true\n", r"vehicles\[leader\]\.north_m must be a number, got true"),
        (LEADER + "fmi_version = 1\n", r"vehicles\[leader\]\.fmi_version must be within 2\.\.3, got 1"),
        ('[[vehicles]]\nrole = "leader"\n', r"vehicles\[0\]: missing required key\(s\) 'name'"),
        ('[[vehicles]]\nname = "a b"\nrole = "leader"\n', r"vehicles\.name must be 1-64 letters, digits"),
        (
            LEADER + FOLLOWER.format(n=1) + "range_m = -1.5\n",
            r"vehicles\[f1\]\.range_m must be within \[0\.1, 1000\], got -1\.5",
        ),
        (
            LEADER + FOLLOWER.format(n=1) + "bearing_deg = 200\n",
            r"vehicles\[f1\]\.bearing_deg must be within \[-180, 180\], got 200",
        ),
        (
            LEADER + FOLLOWER.format(n=1) + 'target = "ghost"\n',
            r"vehicles\[f1\]\.target names an unknown vehicle 'ghost'",
        ),
        (
            LEADER + FOLLOWER.format(n=1) + 'target = "f2"\n' + FOLLOWER.format(n=2) + 'target = "f1"\n',
            r"follower targets form a cycle: f1 -> f2 -> f1",
        ),
        (LEADER + "[vehicles.parameters]\ntau = 'slow'\n", r"vehicles\[leader\]\.parameters\.tau must be a number"),
        (
            LEADER + "[script]\nleader = [[1.0, 0.3]]\n",
            r"script\.leader\[0\] must be \[duration_s, speed_mps, yaw_rate_deg_s\]",
        ),
        (
            LEADER + "[script]\nleader = [[-1.0, 0.3, 0]]\n",
            r"script\.leader\[0\] duration_s must be within \(0, 1e6\], got -1\.0",
        ),
        ("[sim\n", r"not valid TOML"),
        (LEADER + "[camera]\ntracker = 'kcf'\n", r"camera\.tracker must be one of 'full', 'hs-lbp', 'hue', got 'kcf'"),
        (
            LEADER + "model = 'Tank'\n",
            r"vehicles\[leader\]\.model must be one of KinematicUnicycle, SkidSteerRover, got 'Tank'",
        ),
        # keys that would be taken and ignored (a scenario author's audit found them run silently)
        (LEADER + "aruco_id = 5\n", r"vehicles\[leader\]\.aruco_id: a tag id applies only to an ArUco banner"),
        (LEADER + "[scene]\ntextures = 'footage'\n", r"photographed textures apply only with scene\.realism = \"on\""),
    ],
)
def test_bad_scenarios_name_the_key(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_config(text)


def test_unreadable_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"cannot read scenario .*missing\.toml"):
        load_config(tmp_path / "missing.toml")


def test_file_errors_carry_the_path(tmp_path: Path) -> None:
    p = tmp_path / "bad.toml"
    p.write_text("[sim]\ndt_s = -1\n" + LEADER)
    with pytest.raises(ConfigError, match=r"bad\.toml: sim\.dt_s must be within \[0\.0001, 1\]"):
        load_config(p)


def test_config_error_is_a_value_error() -> None:
    with pytest.raises(ValueError):
        parse_config("")


def test_the_reference_page_lists_every_key_with_its_range() -> None:
    from lfctl.config import reference

    page = (Path(__file__).parents[1] / "docs" / "scenario-reference.md").read_text()
    table = reference().splitlines()
    assert table[0] == "| key | type | default | accepted |" and len(table) > 100  # a row a key
    assert "| `sim.dt_s` | number | 0.01 | within [0.0001, 1] |" in table
    assert page.endswith(reference()), (
        "docs/scenario-reference.md is stale: regenerate it from lfctl.config.reference()"
    )


def test_every_number_in_a_scenario_has_a_declared_range() -> None:
    import dataclasses
    import typing

    import lfctl.config as c

    missing = []
    for name in c.__all__:
        cls = getattr(c, name)
        if not (isinstance(cls, type) and dataclasses.is_dataclass(cls) and issubclass(cls, c._Section)):
            continue
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            tp = hints[f.name]
            numeric = tp in (int, float, int | None, float | None)
            listed = typing.get_origin(tp) is tuple and not dataclasses.is_dataclass(typing.get_args(tp)[0])
            if numeric and f.metadata.get("bound") is None:
                missing.append(f"{name}.{f.name}")
            if listed and not (f.metadata.get("items") or f.metadata.get("each")):
                missing.append(f"{name}.{f.name} (entries)")
    assert not missing


def test_vehicle_roles_are_the_fmu_roles() -> None:
    from lfctl.config import VEHICLE_ROLES
    from lfctl.fmu.load import INPUT_ROLES, OUTPUT_ROLES, POSE_ROLES

    assert set(VEHICLE_ROLES) == {*INPUT_ROLES, *OUTPUT_ROLES, *POSE_ROLES}


def test_config_from_table_builds_what_parse_config_builds_and_leaves_the_table_alone() -> None:
    text = (EXAMPLES / "convoy.toml").read_text()
    table = tomllib.loads(text)
    before = copy.deepcopy(table)
    assert config_from_table(table, "convoy", text) == parse_config(text, "convoy")
    assert table == before
    table["sensing"]["range_noise_m"] = -1.0
    with pytest.raises(ConfigError, match=r"sensing\.range_noise_m must be within \[0, 100\], got -1\.0"):
        config_from_table(table)


def test_a_byte_order_mark_before_the_scenario_is_read_past(tmp_path: Path) -> None:
    text = (Path(__file__).parent.parent / "examples" / "convoy.toml").read_text()
    p = tmp_path / "bom.toml"
    p.write_bytes(b"\xef\xbb\xbf" + text.encode())  # as some Windows editors save it
    plain = load_config(Path(__file__).parent.parent / "examples" / "convoy.toml")
    assert load_config(p).vehicles == plain.vehicles and load_config(p).mission == plain.mission


def test_an_odd_camera_size_with_h264_recording_names_the_keys(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from lfctl.cli import main

    text = (Path(__file__).parent.parent / "examples" / "convoy.toml").read_text()
    assert "[camera]\n" in text
    p = tmp_path / "odd.toml"
    p.write_text(
        text.replace("[camera]\n", "[camera]\nwidth_px = 641\nheight_px = 479\n", 1)
        + f'\n[recording]\ndir = "{tmp_path}"\n'
    )
    assert main(["sim", str(p), "--duration", "0.2", "-q"]) != 0
    err = capsys.readouterr().err
    assert "camera.width_px x height_px is 641x479" in err and 'image_format = "jpeg"' in err and "Traceback" not in err


@pytest.mark.parametrize(
    ("value", "written"),
    [
        (True, "true"),
        ([1, "a", False], "[1, 'a', false]"),
        ({"x": 1.5, "on": True}, "{x = 1.5, on = true}"),
        ("long", "'long'"),
        (list(range(100)), "[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21..."),  # 80
    ],
)
def test_a_bad_value_is_named_as_the_scenario_file_writes_it(value: object, written: str) -> None:
    # "got True" named a TOML true in Python's words
    from lfctl.config import toml_value

    assert toml_value(value) == written


def test_a_key_of_too_many_dotted_parts_is_refused_before_it_is_parsed() -> None:
    # Python's TOML reader takes time with the square of a key's parts (80 kB of one key: 24 s;
    # without the check this test would run for hours)
    from lfctl.config import MAX_KEY_PARTS, read_toml

    with pytest.raises(ConfigError, match=r"line 2: a key of 400001 dotted parts \(at most 16 are read\)"):
        parse_config('name = "x"\n' + "a." * 400_000 + "b = 1\n")
    with pytest.raises(ConfigError, match=r"line 1: a key of 17 dotted parts"):
        read_toml("[" + ".".join(["t"] * 17) + "]\nx = 1\n")  # a table header too
    # ... wherever the key stands: after a quoted part holding '=', in an inline table, in a
    # header whose quoted part holds ']' (each took a minute per 120 kB past a line-based check)
    for hidden in (
        '"k=v".' + "a." * 60_000 + "b = 1\n",
        "t = { " + "a." * 60_000 + "b = 1 }\n",
        '["]".' + "a." * 60_000 + "b]\n",
    ):
        with pytest.raises(ConfigError, match=r"line 1: a key of 6000[12] dotted parts"):
            read_toml(hidden)
    deep = ".".join(["t"] * MAX_KEY_PARTS)
    assert read_toml(f"{deep} = 1\n")["t"]["t"]  # 16 parts are read
    fine = (
        '"'
        + "." * 40
        + '" = 1\n'  # dots in quotes are no parts
        + "# "
        + "." * 1000
        + "\n"  # nor in a comment of dots
        + "w = [\n"
        + ",\n".join(f"{i}.5" for i in range(100))
        + "]\n"  # nor a list of numbers
        + 'x = "'
        + "a" * 200_000
        + '"\n'  # a long run of letters is read once (quadratic at first)
    )
    assert read_toml(fine)["." * 40] == 1
