"""Hostile local input, seeded and bounded: scenario files, mission and parameter files,
command-line options. Each case must end in the right exit code (2 for bad input), one line
of error naming what was wrong, and nothing written anywhere; what is accepted must work."""

from __future__ import annotations

import copy
import functools
import math
import os
import random
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.cli import build_parser, main
from lfctl.config import MAX_SCENARIO_BYTES, parse_config
from lfctl.errors import ConfigError
from lfctl.link.mission import MissionItem, load_mission
from lfctl.link.params import load_param_file, save_param_file

EXAMPLES = Path(__file__).parents[1] / "examples"

#: values a red team puts in any key: non-finite, huge, tiny, negative, wrong types, paths
HOSTILE: list[Any] = [
    math.nan, math.inf, -math.inf, 1e308, -1e308, 1e-320, 0, -1, 0.5, 2**63, -(2**63), True, "",
    "x/../../../escaped", "a\x00b", "x" * 5000, "\u202e", [], [[1.0, 2.0]], {}, {"a": 1},
]  # fmt: skip


def leaves(node: Any, path: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    """Every key path in a parsed TOML document (array entries by index)."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield (*path, k)
            yield from leaves(v, (*path, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            if isinstance(v, (dict, list)):
                yield (*path, i)
                yield from leaves(v, (*path, i))


def mutated(doc: dict[str, Any], path: tuple[Any, ...], value: Any) -> dict[str, Any]:
    out = copy.deepcopy(doc)
    node = out
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return out


def documents() -> dict[str, dict[str, Any]]:
    docs = {p.stem: tomllib.loads(p.read_text()) for p in sorted(EXAMPLES.glob("*.toml"))}
    # keys the examples leave at their defaults get hostile values too
    extra = {
        "camera": {"k1": 0.0, "width_px": 640, "height_px": 480, "mount_forward_m": 0.1, "hfov_deg": 60.0},
        "banner": {"marker_saturation": 0.8, "panel_bgr": [200, 200, 200]},
        "link": {"home_alt_m": 900.0, "gcs_udpout": "127.0.0.1:14550", "udp_base_port": 14561, "udp_host": "127.0.0.1"},
        "recording": {"dir": "logs", "chunk_size_bytes": 4096, "jpeg_quality": 80},
        "scene": {
            "props": [{"kind": "box", "north_m": 2.0, "east_m": 1.0, "base_m": 0.0}],
            "occluders": [{"t_s": 3.0, "width_m": 0.5}],
            "lighting": [{"t_s": 1.0, "gain": 0.8, "tint_bgr": [1.0, 0.9, 0.8]}],
        },
    }
    convoy = docs["convoy"]
    for section, keys in extra.items():
        for k, v in keys.items():
            convoy.setdefault(section, {}).setdefault(k, v)
    convoy["vehicles"][1]["parameters"] = {"tau": 0.2}
    # a user FMU's map and units (a built-in model takes none), in a scenario of their own
    user = copy.deepcopy(convoy["vehicles"][:2])
    user[1] |= {"fmu": "rover.fmu", "map": {"north": "north"}, "units": {"yaw": "deg"}}
    docs["user_fmu"] = {"vehicles": user}
    return docs


@functools.cache
def scenario_cases() -> list[tuple[str, str, tuple[Any, ...], Any]]:
    cases = []
    for name, doc in documents().items():
        for path in leaves(doc):
            for value in HOSTILE:
                cases.append((name, tomli_w.dumps(mutated(doc, path, value)), path, value))
    return cases


def test_every_scenario_mutation_is_accepted_or_refused_with_one_line_naming_the_key() -> None:
    outcomes = {"accepted": 0, "refused": 0}
    unnamed = []
    for name, text, path, value in scenario_cases():
        try:
            parse_config(text, name)
        except ConfigError as exc:
            msg = str(exc)
            assert "\n" not in msg, msg
            leaf = next((k for k in reversed(path) if isinstance(k, str)), None)
            if leaf is not None and leaf.removesuffix("_deg").removesuffix("_degps") not in msg:
                unnamed.append(f"{'.'.join(map(str, path))} = {value!r}: {msg}")
            outcomes["refused"] += 1
        else:
            outcomes["accepted"] += 1
    print(f"\n{len(scenario_cases())} scenario mutations: {outcomes}")
    assert len(scenario_cases()) > 2000
    # a few refusals name the rule a key broke through another key (a rate faster than 1/dt_s)
    assert len(unnamed) <= len(scenario_cases()) // 100, "\n".join(unnamed[:20])


@pytest.mark.slow
def test_accepted_mutations_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    rng = random.Random(15)
    accepted = []
    for name, text, path, value in scenario_cases():
        try:
            cfg = parse_config(text, name)
        except ConfigError:
            continue
        runs = ("sim", "vehicles", "mission", "guidance", "sensing", "link", "script")  # sections a run uses
        if len(cfg.vehicles) <= 2 and name != "user_fmu" and path[0] in runs:
            accepted.append((text, path, value))
    for text, path, value in rng.sample(accepted, 12):
        scen = tmp_path / "s.toml"
        scen.write_text(text)
        rc = main(["sim", str(scen), "--duration", "0.5", "--no-record", "-q", "--sensing", "truth"])
        err = capsys.readouterr().err
        # what the scenario's checks accept, a run accepts too: no refusal found only later
        assert rc == 0, f"{'.'.join(map(str, path))} = {value!r}: exit {rc}: {err}"
        assert "Traceback" not in err and "internal error" not in err, err


def test_refused_scenarios_exit_2_with_one_line_and_write_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    scen = tmp_path / "s.toml"
    rng = random.Random(16)
    tried = 0
    for name, text, path, value in rng.sample(scenario_cases(), 400):
        try:
            parse_config(text, name)
            continue
        except ConfigError:
            pass
        scen.write_text(text)
        assert main(["sim", str(scen), "--duration", "0.5", "-q"]) == 2, (path, value)
        err = capsys.readouterr().err.strip()
        assert err.startswith("lfctl: error: ") and "\n" not in err, err
        assert not list(work.iterdir()), f"{path} = {value!r} wrote {list(work.iterdir())}"
        tried += 1
    assert tried > 100


LEADER = '[[vehicles]]\nname = "leader"\nrole = "leader"\n'


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[sim]\ndt_s = 1e-320\n" + LEADER, r"sim\.dt_s must be within \[0\.0001, 1\], got 1e-320"),
        ("[sim]\ndt_s = 1e-300\n" + LEADER, r"sim\.dt_s must be within"),
        (LEADER + "north_m = 1e308\n", r"vehicles\[leader\]\.north_m must be within \[-100000, 100000\]"),
        ("[mission]\nwaypoints = [[1e308, 0.0]]\n" + LEADER, r"mission\.waypoints\[0\] north_m must be within"),
        ("[camera]\nmount_forward_m = nan\n" + LEADER, r"camera\.mount_forward_m must be within \[-10, 10\], got nan"),
        ("[banner]\nmarker_saturation = 5\n" + LEADER, r"banner\.marker_saturation must be within \[0, 1\], got 5"),
        ("[link]\nhome_alt_m = nan\n" + LEADER, r"link\.home_alt_m must be within"),
        (
            "[link]\ngcs_udpout = '127.0.0.1:99999'\n" + LEADER,
            r"link\.gcs_udpout must be HOST:PORT with a port within 1\.\.65535, got '127\.0\.0\.1:99999'",
        ),
        (
            "[link]\nudp_base_port = 65535\n"
            + LEADER
            + LEADER.replace('"leader"\nrole = "leader"', '"f"\nrole = "follower"'),
            r"port 65536, past 65535",
        ),
        ("[script]\nleader = [[1.0, nan, 0.0]]\n" + LEADER, r"script\.leader\[0\] speed_mps must be within"),
        ('name = "x/../../../escaped"\n' + LEADER, r"name must be 1-64 letters"),
        ('name = "a\\u0000b"\n' + LEADER, r"name must be 1-64 letters"),
        (LEADER + 'model = "../fmu_models/SkidSteerRover"\n', r"vehicles\[leader\]\.model must be 1-64 letters"),
        (LEADER + "[vehicles.map]\nfly = 'x'\n", r"vehicles\[leader\]\.map: unknown role 'fly'"),
        (
            LEADER + "[vehicles.units]\nyaw = 'deg'\n",
            r"vehicles\[leader\]\.units: map and units apply only to a user FMU .* got \{yaw = 'deg'\}",
        ),
        ("[camera]\nk1 = nan\n" + LEADER, r"camera\.k1 must be within"),
        ("[camera]\nwidth_px = 8192\nheight_px = 8192\n" + LEADER, r"camera\.width_px must be within 16\.\.4096"),
        ("[camera]\nwidth_px = 4096\nheight_px = 4096\n" + LEADER, r"at most 8847360 pixels"),
        ("[[scene.props]]\nkind = 'box'\nnorth_m = nan\neast_m = 0\n" + LEADER, r"scene\.props\[0\]\.north_m must be"),
        (
            "[[scene.props]]\nkind = 'box'\nnorth_m = 0\neast_m = 0\nbase_m = inf\n" + LEADER,
            r"scene\.props\[0\]\.base_m",
        ),
        ("[[scene.props]]\nkind = 'box'\nnorth_m = 0\neast_m = 0\nwidth_m = 1e308\n" + LEADER, r"props\[0\]\.width_m"),
        ("[mission]\nwaypoints = [" + "[0.0, 0.0]," * 2000 + "]\n" + LEADER, r"at most 1999 entries, got 2000"),
        ("x = " + "[" * 5000 + "]" * 5000 + "\n" + LEADER, r"nested too deeply|unknown key"),
        ("[sim]\nseed = 18446744073709551616\n" + LEADER, r"sim\.seed must be within"),
    ],
    ids=lambda v: str(v)[:30],
)
def test_the_red_team_scenarios_are_refused_by_name(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_config(text)


FOLLOWER = '[[vehicles]]\nname = "f1"\nrole = "follower"\n'


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (LEADER + FOLLOWER + "range_m = 1e-9\n", r"vehicles\[f1\]\.range_m must be within \[0\.1, 1000\], got 1e-09"),
        (
            "[formation]\nshape = 'column'\nspacing_m = 0.05\n" + LEADER + FOLLOWER,
            r"formation\.spacing_m must be within \[0\.1, 1000\]",
        ),
        (
            "[formation]\nshape = 'column'\ntargets = 'leader'\nspacing_m = 600\n"
            + LEADER
            + FOLLOWER
            + FOLLOWER.replace("f1", "f2"),
            r"formation\.spacing_m = 600 puts vehicles\[f2\] 1200 m from its target .* must be within \[0\.1, 1000\] m",
        ),
        (
            "[guidance]\ntrail_lookahead_m = 0.001\n" + LEADER,
            r"guidance\.trail_lookahead_m must be within \[0\.01, 100\]",
        ),
        (
            "[camera]\ncx_px = 640\n" + LEADER,
            r"camera\.cx_px must lie on the picture \(below camera\.width_px = 640; 0: its centre\), got 640",
        ),
        ("[camera]\ncy_px = 480\n" + LEADER, r"camera\.cy_px must lie on the picture \(below camera\.height_px = 480"),
    ],
    ids=lambda v: str(v)[-40:],
)
def test_values_a_run_would_refuse_at_its_start_are_refused_when_the_scenario_is_read(text: str, message: str) -> None:
    """A slot or guidance value outside its LFC_* parameter's range (the run refused it at t = 0,
    after a sweep had started its cluster), and a principal point on the picture's far edge (a
    field of view of 0: "view_half_fov_rad must be within (0, pi]", naming no key)."""
    with pytest.raises(ConfigError, match=message):
        parse_config(text)


def test_the_slot_keys_take_the_parameters_ranges_from_the_parameters() -> None:
    import dataclasses

    from lfctl.config import FormationConfig, GuidanceConfig, VehicleConfig
    from lfctl.link.params import formation_params

    bound = {
        f.name: f.metadata.get("bound")
        for cls in (VehicleConfig, GuidanceConfig, FormationConfig)
        for f in dataclasses.fields(cls)
    }
    for key, name in (("range_m", "LFC_RANGE"), ("spacing_m", "LFC_RANGE"), ("trail_lookahead_m", "LFC_LOOKAHEAD"),
                      ("coast_s", "LFC_COAST"), ("search_yaw_rate_radps", "LFC_SEARCH"), ("bearing_rad", "LFC_BEARING")):  # fmt: skip
        p = formation_params()[name]
        assert (bound[key].lo, bound[key].hi) == (p.lo, p.hi), key


def test_scenario_files_that_are_not_files_or_too_big(tmp_path: Path) -> None:
    from lfctl.config import load_config

    fifo = tmp_path / "x.toml"
    os.mkfifo(fifo)
    with pytest.raises(ConfigError, match="not a regular file"):
        load_config(fifo)  # a FIFO would block a plain open() for ever
    with pytest.raises(ConfigError, match="it is a folder"):
        load_config(tmp_path)
    big = tmp_path / "big.toml"
    big.write_text(LEADER + "#" * MAX_SCENARIO_BYTES)
    with pytest.raises(ConfigError, match=f"the limit is {MAX_SCENARIO_BYTES}"):
        load_config(big)
    latin = tmp_path / "latin.toml"
    latin.write_bytes(b'name = "caf\xe9"\n')
    with pytest.raises(ConfigError, match="not UTF-8"):
        load_config(latin)
    escape = tmp_path / "sub" / "s.toml"
    escape.parent.mkdir()
    escape.write_text(LEADER + 'fmu = "../../outside.fmu"\n')
    with pytest.raises(ConfigError, match=r"vehicles\[leader\]\.fmu must stay inside"):
        load_config(escape)


# -- mission files -----------------------------------------------------------------------------

WPL_ROW = ["1", "0", "3", "16", "0", "0", "0", "0", "12.9605", "77.6690", "0", "1"]
HOSTILE_FIELDS = ["nan", "inf", "-inf", "1e300", "-1", "70000", "300", "2", "x", "", "1e-320", "0x10", "9" * 400]


def _packs(item: MissionItem) -> None:
    """The item as MISSION_ITEM_INT: what upload would send."""
    msg = mav.MAVLink_mission_item_int_message(
        1, 1, item.seq, item.frame, item.command, 0, item.autocontinue, item.param1, item.param2, item.param3,
        item.param4, item.x, item.y, item.z, 0,
    )  # fmt: skip
    msg.pack(mav.MAVLink(None, 255, 190))


def mission_cases(tmp_path: Path) -> Iterator[tuple[str, Path]]:
    head = "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t12.96\t77.669\t900\t1\n"
    k = 0
    for field in range(12):
        for bad in HOSTILE_FIELDS:
            row = list(WPL_ROW)
            row[field] = bad
            p = tmp_path / f"m{k}.waypoints"
            k += 1
            p.write_text(head + "\t".join(row) + "\n")
            yield f"WPL field {field} = {bad[:12]!r}", p
    for n in (11, 13):
        p = tmp_path / f"m{k}.waypoints"
        k += 1
        p.write_text(head + "\t".join(WPL_ROW[:n] + ["0"] * max(0, n - 12)) + "\n")
        yield f"WPL row of {n} fields", p
    plan = {
        "fileType": "Plan",
        "mission": {
            "plannedHomePosition": [12.96, 77.669, 900],
            "items": [{"type": "SimpleItem", "command": 16, "frame": 3, "autoContinue": True,
                       "params": [0, 0, 0, 0, 12.9605, 77.669, 0]}],
        },
    }  # fmt: skip
    import json

    item_paths = [("type",), ("command",), ("frame",), ("autoContinue",), ("params",)]
    item_paths += [("params", i) for i in range(7)]
    for sub in item_paths:
        for value in [None, "x", 1e300, -1, 70000, [], {}, True, [1, 2], 2**70]:
            doc = copy.deepcopy(plan)
            node = doc["mission"]["items"][0]
            for key in sub[:-1]:
                node = node[key]
            node[sub[-1]] = value
            p = tmp_path / f"m{k}.plan"
            k += 1
            p.write_text(json.dumps(doc))
            yield f".plan item {'.'.join(map(str, sub))} = {value!r}", p
    for top in [
        [],
        "x",
        {"mission": []},
        {"mission": {"items": {}}},
        {"mission": {"plannedHomePosition": [1], "items": []}},
    ]:
        p = tmp_path / f"m{k}.plan"
        k += 1
        p.write_text(json.dumps(top))
        yield f".plan {json.dumps(top)[:40]}", p
    p = tmp_path / "deep.plan"
    p.write_text("[" * 100_000 + "]" * 100_000)
    yield ".plan nested 100000 deep", p
    p = tmp_path / "many.waypoints"
    p.write_text(head + "".join("\t".join([str(i), *WPL_ROW[1:]]) + "\n" for i in range(1, 65536)))
    yield "WPL of 65,536 items", p
    p = tmp_path / "huge.waypoints"
    with p.open("w") as f:
        f.write(head)
        f.truncate(200 * 1024 * 1024)  # sparse: 200 MB of NULs, cheap to make
    yield "200 MB mission file", p
    fifo = tmp_path / "fifo.waypoints"
    os.mkfifo(fifo)
    yield "a FIFO", fifo


def test_mission_files_are_refused_by_line_or_give_items_that_pack(tmp_path: Path) -> None:
    refused = accepted = 0
    for what, path in mission_cases(tmp_path):
        try:
            items = load_mission(path)
        except ConfigError as exc:
            assert "\n" not in str(exc), (what, str(exc))
            refused += 1
            continue
        for it in items:
            _packs(it)  # would raise struct.error / OverflowError on a value MAVLink cannot carry
        accepted += 1
    print(f"\nmission files: {accepted} accepted (and packed), {refused} refused")
    assert refused > 150 and accepted > 10


def test_a_bad_mission_file_is_named_before_any_connection(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # nothing listens on this port: the file must be judged first, not reported as "no HEARTBEAT"
    assert (
        main(["gcs", "--connect", "udpout:127.0.0.1:9", "--timeout", "0.2", "upload", str(tmp_path / "no.plan")]) == 2
    )
    err = capsys.readouterr().err
    assert "cannot read mission" in err and "HEARTBEAT" not in err


def test_parameter_files(tmp_path: Path) -> None:
    cases = {
        "nan": "WP_SPEED nan\n", "inf": "WP_SPEED inf\n", "name": "WP SPEED X 1\n", "long": "A" * 17 + " 1\n",
        "text": "WP_SPEED fast\n", "bytes": None,
    }  # fmt: skip
    for what, text in cases.items():
        p = tmp_path / f"{what}.parm"
        if text is None:
            p.write_bytes(b"\xff\xfe\x00")
        else:
            p.write_text(text)
        with pytest.raises(ConfigError) as exc:
            load_param_file(p)
        assert "\n" not in str(exc.value)
    fifo = tmp_path / "fifo.parm"
    os.mkfifo(fifo)
    with pytest.raises(ConfigError, match="not a regular file"):
        load_param_file(fifo)
    # a value no MAVLink float carries is named with its line, before anything is sent (it was an
    # internal OverflowError in `lfctl gcs param load`, after the lines before it were set)
    for huge in ("LFC_LAW 1e308", "1\t1\tLFC_SEARCH\t-1e39\t9"):
        (tmp_path / "huge.parm").write_text("LFC_SEARCH 30\n" + huge + "\n")
        with pytest.raises(
            ConfigError, match=r"huge\.parm:2: LFC_\w+: value '-?1e3\d+' is beyond what MAVLink's float"
        ):
            load_param_file(tmp_path / "huge.parm")


# -- options -----------------------------------------------------------------------------------

NUMBERS = ["0", "-5", "nan", "inf", "-inf", "1e308", "1e-9", "99999", "x", "", "1.5.2", "0x10", "9" * 400]
#: refused by every numeric option
ALWAYS_BAD = {"nan", "inf", "-inf", "1e308", "x", "", "1.5.2", "0x10", "9" * 400}
NAMES = ["", "../../x", "a b", "a\x00b", "x" * 65]
CONNECTIONS = ["", "x", "udpout:127.0.0.1:99999", "udpout::14550", "udp:host", "/etc/passwd", "udpout:a b:1"]
OPTION_CASES = [
    (["follow", "--mavlink", "{v}"], CONNECTIONS),
    (["follow", "--mavlink", "udpout:127.0.0.1:14550", "--rate", "{v}"], NUMBERS),
    (["follow", "--mavlink", "udpout:127.0.0.1:14550", "--range", "{v}"], NUMBERS),
    (["follow", "--mavlink", "udpout:127.0.0.1:14550", "--bearing", "{v}"], NUMBERS),
    (["follow", "--mavlink", "udpout:127.0.0.1:14550", "--steps", "{v}"], NUMBERS),
    (["follow", "--mavlink", "udpout:127.0.0.1:14550", "--max-frames", "{v}"], NUMBERS),
    (["follow", "--mavlink", "udpout:127.0.0.1:14550", "--timeout", "{v}"], NUMBERS),
    (["follow", "--mavlink", "udpout:127.0.0.1:14550", "--target", "{v}"], NUMBERS),
    (["gcs", "--connect", "{v}", "arm"], CONNECTIONS),
    (["gcs", "--target", "{v}", "arm"], NUMBERS),
    (["gcs", "--timeout", "{v}", "arm"], NUMBERS),
    (["gcs", "param", "set", "WP_SPEED", "{v}"], NUMBERS),
    (["gcs", "param", "get", "{v}"], NAMES),
    (["gcs", "watch", "--count", "{v}"], NUMBERS),
    (["sim", "convoy", "--duration", "{v}"], NUMBERS),
    (["sim", "convoy", "--seed", "{v}"], NUMBERS),
    (["track", "x.mp4", "--max-frames", "{v}"], NUMBERS),
    (["track", "x.mp4", "--marker-hue-deg", "{v}"], NUMBERS),
    (["replay", "x.mcap", "--follower", "{v}"], NAMES),
    (["bench", "link", "--fuzz", "--soak-s", "{v}"], NUMBERS),
]


@pytest.mark.parametrize(
    ("argv", "values"),
    OPTION_CASES,
    ids=lambda a: (
        " ".join(a[:4])
        if isinstance(a, list) and a and a[0] in ("follow", "gcs", "sim", "track", "replay", "bench")
        else ""
    ),
)
def test_bad_options_are_one_line_and_exit_2(
    argv: list[str], values: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    parser = build_parser()
    for bad in values:
        args = [a.replace("{v}", bad) for a in argv]
        try:
            parser.parse_args(args)
        except SystemExit as stop:
            assert stop.code == 2, args
            err = capsys.readouterr().err.strip()
            assert err.count("\n") == 0 and ": error: " in err, (args, err)
        else:
            assert values is NUMBERS and bad not in ALWAYS_BAD, f"accepted {args}"


@pytest.mark.parametrize(
    "connect", ["/dev/ttyAMA0,", "/dev/ttyAMA0,0", "/dev/ttyAMA0,fast", "/dev/ttyAMA0,99999999999"]
)
def test_a_serial_device_s_bad_baud_is_named(connect: str, capsys: pytest.CaptureFixture[str]) -> None:
    # "/dev/ttyAMA0," got past the check to pymavlink, which failed on int(''): "invalid literal
    # for int() with base 10: ''", exit 1; the others read as no serial device at all
    with pytest.raises(SystemExit) as stop:
        build_parser().parse_args(["follow", "--mavlink", connect])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and f"must have a baud within 50..20000000 after the comma, got {connect!r}" in err


@pytest.mark.parametrize("name", ["", "../../x", "WP SPEED", "A" * 17, "a\x00b"])
def test_bad_parameter_names_are_refused_by_their_rule(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        build_parser().parse_args(["gcs", "param", "get", name])
    assert stop.value.code == 2 and "must be 1-16 letters" in capsys.readouterr().err


def test_a_shipped_mission_is_found_by_name_outside_a_checkout(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # from a folder without the file, the shipped square.waypoints is read (so the only
    # failure is that nothing listens), and an unknown name lists the shipped missions
    monkeypatch.chdir(tmp_path)
    args = ["gcs", "--connect", "udpout:127.0.0.1:9", "--timeout", "0.2", "upload"]
    assert main([*args, "square.waypoints"]) != 0
    err = capsys.readouterr().err
    assert "HEARTBEAT" in err and "cannot read mission" not in err
    assert main([*args, "square"]) != 0
    assert "HEARTBEAT" in capsys.readouterr().err
    assert main([*args, "circle.waypoints"]) == 2
    err = capsys.readouterr().err
    assert "cannot read mission 'circle.waypoints'" in err and "square.waypoints" in err


@given(
    st.dictionaries(
        st.sampled_from(["ARMING_CHECK", "WP_SPEED", "FENCE_RADIUS", "CRUISE_THROTTLE", "LFC_BEARING"]),
        st.one_of(st.integers(-(2**24), 2**24), st.floats(-1e6, 1e6, width=32)),
        min_size=1,
    )
)
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_a_saved_parameter_file_loads_back_the_values_a_vehicle_sent(tmp_path: Path, values: dict) -> None:
    # PARAM_VALUE carries 32-bit floats: each comes back as that float (a bitmask such as
    # 1048574 whole, not 1.04857e+06)
    sent = {name: float(np.float32(v)) for name, v in values.items()}
    for fmt in ("mavproxy", "qgc"):
        path = tmp_path / f"p.{fmt}"
        save_param_file(sent, path, fmt)
        assert {k: float(np.float32(v)) for k, v in load_param_file(path).items()} == sent
