"""Sweep files: dotted keys, the checks with errors that name the key, and the expansion into
validated variants and runs (no Dask here)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from lfctl.config import load_config, parse_config
from lfctl.data import resolve_scenario
from lfctl.errors import ConfigError
from lfctl.sweep.spec import (
    load_sweep,
    parse_key,
    parse_sweep,
    plan,
    set_key,
    sweep_names,
    sweeps_dir,
    with_keys,
)

HEAD = 'scenario = "convoy"\n'


def test_keys_parse_into_table_and_array_steps() -> None:
    assert parse_key("sensing.range_noise_m") == [("table", "sensing"), ("table", "range_noise_m")]
    assert parse_key("scene.lighting[1].gain") == [
        ("table", "scene"),
        ("table", "lighting"),
        ("item", 1),
        ("table", "gain"),
    ]
    assert parse_key("vehicles[follower1].range_m")[1] == ("item", "follower1")
    with pytest.raises(ConfigError, match=r"key 'sensing\.\.x': '' is not a name"):
        parse_key("sensing..x")


def test_set_key_reaches_tables_array_entries_by_position_and_by_name() -> None:
    table = {"vehicles": [{"name": "leader"}, {"name": "f1", "range_m": 1.5}], "scene": {"lighting": [{"t_s": 0.0}]}}
    set_key(table, "vehicles[1].range_m", 2.0)
    set_key(table, "vehicles[leader].north_m", 3.0)
    set_key(table, "scene.lighting[0].gain", 0.5)
    set_key(table, "sensing.range_noise_m", 0.2)  # a missing table is made
    assert table["vehicles"][1]["range_m"] == 2.0 and table["vehicles"][0]["north_m"] == 3.0
    assert table["scene"]["lighting"][0] == {"t_s": 0.0, "gain": 0.5}
    assert table["sensing"] == {"range_noise_m": 0.2}


@pytest.mark.parametrize(
    ("key", "message"),
    [
        ("scene.lighting[3].gain", r"has 1 scene\.lighting entries \(indices 0\.\.0\), no \[3\]"),
        ("vehicles[ghost].range_m", r"no vehicles entry named 'ghost' \(named: \['leader', 'f1'\]\)"),
        ("scene.occluders[0].t_s", r"the scenario has no scene\.occluders entries to index"),
        ("vehicles.range_m", r"vehicles is not a table"),
    ],
)
def test_set_key_errors_name_the_key(key: str, message: str) -> None:
    table = {"vehicles": [{"name": "leader"}, {"name": "f1"}], "scene": {"lighting": [{"t_s": 0.0}]}}
    with pytest.raises(ConfigError, match=message):
        set_key(table, key, 1.0)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", r"scenario must name the base scenario"),
        (HEAD + "speed = 3\n", r"unknown key 'speed' \(allowed here: name, scenario, seeds"),
        ('scenario = "nowhere"\n', r"scenario 'nowhere' is neither a file nor a shipped example"),
        (HEAD + "[grid]\n'sensing.range_noise_m' = 0.1\n", r"grid\.'sensing\.range_noise_m' must be a non-empty array"),
        (HEAD + "[grid]\n'sensing.range_noise_m' = []\n", r"must be a non-empty array of values, got \[\]"),
        (
            HEAD + "[random]\nsamples = 3\n'sim.dt_s' = { gauss = [0, 1] }\n",
            r"random\.'sim\.dt_s' must be one distribution",
        ),
        (HEAD + "[random]\nsamples = 3\n'sim.dt_s' = { uniform = [1, 0] }\n", r"uniform needs lo <= hi, got \[1, 0\]"),
        (HEAD + "[random]\nsamples = 3\n'sim.dt_s' = { loguniform = [0, 1] }\n", r"loguniform needs lo > 0"),
        (
            HEAD + "[random]\n'sim.dt_s' = { uniform = [0, 1] }\n",
            r"random\.samples must be an integer within 1\.\.10000, got None",
        ),
        (HEAD + "[random]\nsamples = 2\n", r"random\.samples is given but \[random\] names no key"),
        (HEAD + "seeds = 0\n", r"seeds must be a count within 1\.\.100000"),
        (HEAD + "seeds = [1, 1]\n", r"seeds must not repeat \(use repetitions\)"),
        (
            HEAD + "[grid]\n'guidance.controller' = ['smc', 'p', 'smc']\n",
            r"grid\.'guidance\.controller' gives 'smc' twice \(places 1 and 3 of its array\): each variant once",
        ),
        # (places, not "values 0 and 1": the values are 0 and 0.0)
        (HEAD + "[grid]\n'sensing.range_noise_m' = [0, 0.0]\n", r"gives 0 twice \(places 1 and 2 of its array\)"),
        (HEAD + "repetitions = 0\n", r"repetitions must be an integer within 1\.\.100000, got 0"),
        (HEAD + "seeds = 1000000000\n", r"seeds must be a count within 1\.\.100000 .*, got 1000000000"),
        (HEAD + "seeds = [99999999999999999999]\n", r"list of integers within 0\.\.9223372036854775807"),
        (HEAD + "name = '..'\n", r"name must be .*\(not dots alone\), got '\.\.'"),
        (
            HEAD + "[random]\nsamples = 2\n'sim.dt_s' = { uniform = [-1.7e308, 1.7e308] }\n",
            r"uniform: hi - lo must be a finite number",
        ),
        (
            HEAD + "[random]\nsamples = 2\n'sim.seed' = { integers = [0, 99999999999999999999] }\n",
            r"integers bounds must be within \+-9223372036854775806",
        ),
        (
            HEAD + "[grid]\n" + "".join(f"'k{i}' = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]\n" for i in range(10)),
            r"the sweep has 10000000000 variants .* at most 10000 variants and 100000 runs",
        ),
        (
            HEAD + "seeds = 2\nrepetitions = 100000\n",
            r"^the sweep has 1 variant \(grid combinations x samples\) and 200000 runs",
        ),
        (HEAD + "[grid]\n'sim.seed' = [1, 2]\n", r"'sim\.seed' cannot be varied by a sweep: it is set by seeds"),
        (HEAD + "[grid]\n'sim. seed' = [1, 2]\n", r"'sim\. seed' cannot be varied by a sweep: it is set by seeds"),
        (
            HEAD + "[set]\n'sim.dt_s' = 0.01\n[grid]\n'sim.dt_s' = [0.01, 0.02]\n",
            r"key 'sim\.dt_s' appears more than once",
        ),
        (
            HEAD + "[grid]\n'vehicles[1].range_m' = [1.5, 2.0]\n'vehicles[follower1].range_m' = [1.6, 2.1]\n",
            r"key 'vehicles\[follower1\]\.range_m' appears more than once in \[set\], \[grid\] and \[random\] "
            r"\(as 'vehicles\[1\]\.range_m'\)$",
        ),
        (
            HEAD + "[set]\n'vehicles[-1].range_m' = 1.5\n[grid]\n'vehicles[ 1 ].range_m' = [1.6, 2.1]\n",
            r"key 'vehicles\[ 1 \]\.range_m' appears more than once",
        ),
        (HEAD + "[grid]\n'scene.lighting[x' = [1]\n", r"is not a name with optional \[index\] parts"),
    ],
)
def test_bad_sweep_files_name_the_key(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_sweep(text)


@pytest.mark.parametrize(("fmu", "why"), [("/dev/zero", "is not a regular file"), ("/nonesuch.fmu", "does not exist")])
def test_a_user_fmu_that_is_no_file_is_refused_before_anything_runs(fmu: str, why: str) -> None:
    spec = parse_sweep(HEAD + f"[set]\n'vehicles[0].fmu' = '{fmu}'\n")
    with pytest.raises(ConfigError, match=rf"variant 0: vehicles\[leader\]\.fmu {fmu} {why}"):
        plan(spec)


def test_every_variant_is_built_before_anything_runs_and_an_error_names_variant_and_key() -> None:
    spec = parse_sweep(HEAD + "[grid]\n'guidance.controller' = ['smc', 'p']\n'sensing.range_noise_m' = [0.01, -1.0]\n")
    with pytest.raises(
        ConfigError,
        match=r"variant 1 \(guidance\.controller = 'smc', sensing\.range_noise_m = -1\.0\): "
        r"sensing\.range_noise_m must be within \[0, 100\], got -1\.0",
    ):
        plan(spec)
    spec = parse_sweep(HEAD + "[grid]\n'scene.lighting[5].gain' = [0.5]\n")
    with pytest.raises(ConfigError, match=r"variant 0 .*has 3 scene\.lighting entries"):
        plan(spec)
    with pytest.raises(ConfigError, match=r"variant 0: sim\.clock must be 'lockstep' in a sweep"):
        plan(parse_sweep(HEAD + "[set]\n'sim.clock' = 'realtime'\n"))
    with pytest.raises(ConfigError, match=r"variant 0 \(camera\.trackr = 'hue'\): unknown key 'camera\.trackr'"):
        plan(parse_sweep(HEAD + "[grid]\n'camera.trackr' = ['hue']\n"))


def test_a_variant_whose_slot_its_run_would_refuse_is_refused_before_anything_runs() -> None:
    # it used to be planned, run, and written as an error row at t = 0 of each of its runs
    spec = parse_sweep(HEAD + "[grid]\n'vehicles[1].range_m' = [1.5, 0.05]\n")
    with pytest.raises(
        ConfigError,
        match=r"variant 1 \(vehicles\[1\]\.range_m = 0\.05\): vehicles\[follower1\]\.range_m must be within \[0\.1, 1000\], got 0\.05",
    ):
        plan(spec)


def test_grid_times_samples_times_seeds_and_repetitions_with_keys_as_in_a_scenario_file() -> None:
    text = (
        HEAD
        + "seeds = [4, 9]\nrepetitions = 2\n"
        + "[set]\n'sim.duration_s' = 3.0\n"
        + "[grid]\n'camera.tracker' = ['hue', 'full']\n'vehicles[follower1].bearing_deg' = [0, 10]\n"
        + "[grid.scene]\n'lighting[2].gain' = [0.5]\n"  # a nested table of the grid means the same dotted key
        + "[random]\nseed = 3\nsamples = 2\n'sensing.bearing_noise_deg' = { uniform = [0.0, 2.0] }\n"
        + "'guidance.range_eta_mps' = { loguniform = [0.1, 1.0] }\n"
    )
    p = plan(parse_sweep(text))
    spec = p.spec
    assert spec.keys == [
        "camera.tracker",
        "vehicles[follower1].bearing_deg",
        "scene.lighting[2].gain",
        "sensing.bearing_noise_deg",
        "guidance.range_eta_mps",
    ]
    assert len(p.variants) == 2 * 2 * 1 * 2 and len(p.runs) == len(p.variants) * 2 * 2
    v = p.variants[3]  # first key slowest: hue, bearing 10, sample 1
    assert v.values["camera.tracker"] == "hue" and v.values["vehicles[follower1].bearing_deg"] == 10
    cfg = v.config
    assert cfg.camera.tracker == "hue" and cfg.sim.duration_s == 3.0 and cfg.scene.lighting[2].gain == 0.5
    assert math.isclose(cfg.followers[0].bearing_rad, math.radians(10))  # _deg converted as in a file
    assert math.isclose(cfg.sensing.bearing_noise_rad, math.radians(v.values["sensing.bearing_noise_deg"]))
    assert not cfg.recording.images  # logs leave frames out unless the sweep says images = true
    assert parse_config(v.source, cfg.name) == cfg  # the variant's TOML is the scenario that runs
    assert [(r.seed, r.repetition) for r in p.runs[:4]] == [(4, 0), (4, 1), (9, 0), (9, 1)]
    assert p.runs[6].config.sim.seed == 9 and p.runs[6].variant == 1 and p.runs[6].repetition == 0
    # samples come from their own seed: the same file gives the same values and digest
    again = plan(parse_sweep(text))
    assert [v.values for v in again.variants] == [v.values for v in p.variants] and again.digest == p.digest
    other = plan(parse_sweep(text.replace("seed = 3", "seed = 4")))
    assert other.variants[0].values != p.variants[0].values and other.digest != p.digest
    sampled = [v.values["guidance.range_eta_mps"] for v in p.variants]
    assert all(0.1 <= x <= 1.0 for x in sampled) and sampled[0] != sampled[1]


def test_seeds_default_to_the_scenarios_and_a_count_means_one_to_n() -> None:
    assert parse_sweep(HEAD).seeds == (1,)  # convoy.toml: seed = 1
    assert parse_sweep(HEAD + "seeds = 3\n").seeds == (1, 2, 3)


def test_the_scenario_is_found_beside_the_sweep_file(tmp_path: Path) -> None:
    (tmp_path / "base.toml").write_text('[[vehicles]]\nname = "leader"\nrole = "leader"\n')
    (tmp_path / "s.toml").write_text('scenario = "base.toml"\n[grid]\n"sim.dt_s" = [0.01, 0.02]\n')
    spec = load_sweep(tmp_path / "s.toml")
    assert spec.name == "s" and spec.scenario == tmp_path / "base.toml"
    assert [v.config.sim.dt_s for v in plan(spec).variants] == [0.01, 0.02]
    (tmp_path / "bad.toml").write_text('scenario = "base.toml"\n[grid]\n"sim.dt_s" = [2.0]\n')
    with pytest.raises(
        ConfigError,
        match=r"bad\.toml: variant 0 \(sim\.dt_s = 2\.0\): sim\.dt_s must be within \[0\.0001, 1\], got 2\.0",
    ):
        plan(load_sweep(tmp_path / "bad.toml"))


@pytest.mark.parametrize("name", sweep_names())
def test_shipped_sweeps_plan(name: str) -> None:
    p = plan(load_sweep(name))  # by name, as `lfctl sweep NAME` finds them
    assert p.spec.scenario.is_file() and len(p.runs) >= 20
    assert load_sweep(sweeps_dir() / f"{name}.toml").name == p.spec.name


def test_with_keys_changes_a_loaded_scenario_as_a_sweep_would() -> None:
    cfg = load_config(resolve_scenario("convoy"))
    changed = with_keys(cfg, {"sensing.bearing_noise_deg": 2.0, "vehicles[follower1].range_m": 2.0})
    assert math.isclose(changed.sensing.bearing_noise_rad, math.radians(2.0))
    assert changed.slots()["follower1"].range_m == 2.0 and changed.mission == cfg.mission
    assert parse_config(changed.source, "convoy") == changed
    with pytest.raises(ConfigError, match=r"guidance\.controller must be one of 'smc', 'p', 'trail', got 'pid'"):
        with_keys(cfg, {"guidance.controller": "pid"})


def test_with_keys_takes_numpy_values_tuples_and_paths_and_names_a_value_toml_cannot_hold() -> None:
    # a sweep script built on np.arange gave numpy integers: a raw TypeError naming no key
    import numpy as np

    cfg = load_config(resolve_scenario("convoy"))
    changed = with_keys(
        cfg, {"sim.seed": np.int64(3), "sensing.dropouts": np.array([[1.0, 2.0]]), "recording.dir": Path("/tmp/x")}
    )
    assert changed.sim.seed == 3 and changed.sensing.dropouts == ((1.0, 2.0),) and changed.recording.dir == "/tmp/x"
    assert with_keys(cfg, {"sensing.dropouts": ((1.0, 2.0),)}).sensing.dropouts == ((1.0, 2.0),)
    with pytest.raises(ConfigError, match=r"sim\.duration_s: None is not a TOML value .*leave the key out"):
        with_keys(cfg, {"sim.duration_s": None})
    with pytest.raises(ConfigError, match=r"sim\.seed: a value of type object is not a TOML value"):
        with_keys(cfg, {"sim.seed": object()})


def test_run_scenario_checks_its_duration_and_its_scenario_as_a_file_would() -> None:
    from lfctl.sim.runner import run_scenario

    cfg = load_config(resolve_scenario("convoy"))
    for bad in (-1.0, 0.0, math.nan, 1e12):
        with pytest.raises(ConfigError, match=r"sim\.duration_s must be within \(0, 1e6\]"):
            run_scenario(cfg, duration_s=bad)
    with pytest.raises(ConfigError, match=r"run_scenario takes a Config .*got str 'convoy'"):
        run_scenario("convoy")  # type: ignore[arg-type]


def test_a_spec_changed_after_it_was_read_is_refused_and_one_read_from_changed_text_plans() -> None:
    # the folder's sweep.toml is the spec's source: a spec cut down with dataclasses.replace ran 4
    # runs and kept the 400-run file as its record
    import dataclasses

    spec = load_sweep("noise")
    cut = dataclasses.replace(spec, seeds=(1, 2))
    with pytest.raises(ConfigError, match=r"sweep .noise.: its seeds differs from its source TOML"):
        plan(cut)
    text = spec.source.replace("seeds = 10", "seeds = [1, 2]")
    assert text != spec.source
    small = parse_sweep(text, "noise", spec.path.parent)
    assert small.seeds == (1, 2) and len(plan(small).runs) == len(plan(spec).runs) // 5


def test_a_sweep_given_as_a_scenario_and_a_scenario_given_as_a_sweep_are_named_with_the_command() -> None:
    # a new user's likely slip: each file is said to be what it is, with the command to run it
    # (before, each was an unknown key of the other: 'description', 'banner')
    from lfctl.data import examples_dir

    sweep_file = examples_dir() / "sweeps" / "gains-bearing.toml"
    with pytest.raises(
        ConfigError, match=r"this is a sweep over the scenario 'convoy', not a scenario; run it with `lfctl sweep`"
    ):
        load_config(sweep_file)
    with pytest.raises(
        ConfigError, match=r"unknown key 'banner': this is a scenario, not a sweep; run it with `lfctl sim`"
    ):
        load_sweep(examples_dir() / "convoy.toml")
    # a scenario's own bad key is still only that
    with pytest.raises(ConfigError, match=r"unknown key 'scenario' \(allowed here:"):
        parse_config("scenario = 3\n")
