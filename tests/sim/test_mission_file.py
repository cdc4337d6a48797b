"""A scenario's ``mission.file``: a ground station's .plan (with its fence and rally points)
or .waypoints flown in lockstep as the scenario's own waypoints are, checked before the run
starts, attached to the log and drawn by the audit's plot."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from support import LEADER_AND_FOLLOWER

from lfctl.cli import main
from lfctl.config import load_config, parse_config
from lfctl.errors import ConfigError
from lfctl.frames import ned_to_geodetic
from lfctl.link.mission_server import FENCE, MISSION, RALLY
from lfctl.sim.links import Links, scenario_mission
from lfctl.sim.runner import run_scenario

pytestmark = pytest.mark.fmu

ROUTE = ((3.0, 0.0), (3.0, 2.0), (0.0, 2.0))
SCENARIO = (
    """
[sim]
duration_s = 35.0
"""
    + LEADER_AND_FOLLOWER
    + """
[mission]
{mission}
"""
)


def geo(cfg, n: float, e: float) -> list[float]:
    lc = cfg.link
    lat, lon, _ = ned_to_geodetic(n, e, 0.0, lc.home_lat_deg, lc.home_lon_deg, lc.home_alt_m)
    return [lat, lon]


def write_plan(folder: Path, cfg, route=ROUTE, command: int = 16, fence: bool = True) -> Path:
    """A QGroundControl plan of ``route`` (local north, east), with an inclusion fence around
    it and one rally point, as QGroundControl saves one."""
    items = [
        {
            "type": "SimpleItem",
            "command": command,
            "frame": 3,
            "params": [0, 0, 0, None, *geo(cfg, n, e), 0],
            "autoContinue": True,
            "doJumpId": k,
        }
        for k, (n, e) in enumerate(route, start=1)
    ]
    box = [geo(cfg, n, e) for n, e in ((-20, -20), (-20, 20), (20, 20), (20, -20))]
    plan = {
        "fileType": "Plan",
        "version": 1,
        "groundStation": "QGroundControl",
        "mission": {"version": 2, "items": items, "plannedHomePosition": [*geo(cfg, 0, 0), 0], "firmwareType": 3},
        "geoFence": {"version": 2, "polygons": [{"inclusion": True, "polygon": box}] if fence else [], "circles": []},
        "rallyPoints": {"version": 2, "points": [[*geo(cfg, -1.0, -1.0), 0.0]] if fence else []},
    }
    path = folder / "route.plan"
    path.write_text(json.dumps(plan))
    return path


def scenario(folder: Path, mission: str) -> Path:
    path = folder / "run.toml"
    path.write_text(SCENARIO.format(mission=mission))
    return path


def test_a_plan_is_flown_as_the_same_waypoints_are_and_its_fence_and_rally_points_go_up_with_it(
    tmp_path: Path,
) -> None:
    base = parse_config(SCENARIO.format(mission=""))
    write_plan(tmp_path, base)
    from_file = load_config(scenario(tmp_path, 'file = "route.plan"'))
    assert from_file.mission.file == str((tmp_path / "route.plan").resolve())  # beside the scenario
    waypoints = dataclasses.replace(base, mission=dataclasses.replace(base.mission, waypoints=ROUTE))
    links = []
    a = run_scenario(from_file, on_links=links.append)
    b = run_scenario(waypoints)
    assert [i for i, _ in a.waypoints_reached] == [i for i, _ in b.waypoints_reached] == [0, 1, 2]
    assert np.allclose(a.result.pos_ned_m, b.result.pos_ned_m, atol=1e-6)
    leader = links[0].endpoints[0]
    assert [len(leader.missions.lists[k]) for k in (MISSION, FENCE, RALLY)] == [4, 4, 1]


def test_a_plan_in_a_realtime_run_is_stored_with_its_fence_and_rally_points_for_a_gcs_to_start(
    tmp_path: Path, free_udp_ports
) -> None:
    base = parse_config(SCENARIO.format(mission=""))
    write_plan(tmp_path, base)
    cfg = load_config(scenario(tmp_path, 'file = "route.plan"'))
    link = dataclasses.replace(cfg.link, udp_base_port=free_udp_ports(2), gcs_udpout="")
    cfg = dataclasses.replace(cfg, link=link)
    links = Links(cfg, realtime=True, mission=scenario_mission(cfg))
    try:
        leader = links.endpoints[0]
        assert [len(leader.missions.lists[k]) for k in (MISSION, FENCE, RALLY)] == [4, 4, 1]
        assert not leader.armed  # stored, as on a rover: a ground station starts it
    finally:
        links.close()


@pytest.mark.parametrize(
    ("mission", "says"),
    [
        ('file = "route.plan"\nwaypoints = [[1.0, 1.0]]', "mission.file and mission.waypoints are two missions"),
        ('file = "../route.plan"', "mission.file must stay inside"),
        ('file = "none.plan"', "cannot read mission.file"),
    ],
)
def test_a_mission_file_named_wrongly_is_one_line_naming_it(tmp_path: Path, mission: str, says: str) -> None:
    with pytest.raises(ConfigError, match=says):
        scenario_mission(load_config(scenario(tmp_path, mission)))


def test_a_plan_for_another_site_or_with_an_item_the_leader_refuses_stops_the_run_before_it_starts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    base = parse_config(SCENARIO.format(mission=""))
    far = dataclasses.replace(base, link=dataclasses.replace(base.link, home_lat_deg=48.0, home_lon_deg=11.0))
    write_plan(tmp_path, far)  # planned in Bavaria, flown from the default home
    monkeypatch.chdir(tmp_path)
    run = scenario(tmp_path, 'file = "route.plan"')
    assert main(["sim", str(run), "-q"]) == 2
    err = capsys.readouterr().err
    assert "mission item 1 (NAV_WAYPOINT)" in err and "km from the scenario's home" in err
    assert "link.home_lat_deg" in err
    assert not (tmp_path / "logs").exists()  # nothing recorded
    # a command no ArduPilot mission knows, its yaw left unset: Rover checks the parameters
    # first (AP_Mission::sanity_check_params), and only a waypoint's yaw may be NaN
    write_plan(tmp_path, base, command=31000)
    with pytest.raises(ConfigError, match="would refuse its mission at item 1: MAV_MISSION_INVALID_PARAM4"):
        scenario_mission(load_config(run))
    write_plan(tmp_path, base, route=())
    with pytest.raises(ConfigError, match="holds no mission items"):
        scenario_mission(load_config(run))


def test_the_mission_file_is_attached_to_the_log_and_drawn_by_the_plot(tmp_path: Path) -> None:
    from lfctl.record.audit import audit
    from lfctl.record.plots import _scene_mission

    base = parse_config(SCENARIO.format(mission=""))
    plan = write_plan(tmp_path, base, fence=False)
    cfg = load_config(scenario(tmp_path, 'file = "route.plan"'))
    log = tmp_path / "run.mcap"
    run_scenario(cfg, record_to=log, duration_s=3.0)
    report = audit(log)
    assert report.ok, [f.line() for f in report.findings]
    assert report.contents.attachments["mission/route.plan"] == plan.read_bytes()
    t0, places, radius = _scene_mission(report.contents)
    assert t0 == pytest.approx(0.0, abs=0.1) and radius == pytest.approx(cfg.mission.acceptance_radius_m)
    assert np.allclose(places, ROUTE, atol=0.02)  # degE7: about 1 cm


def write_lists(folder: Path, cfg, route, fence_box=None, rally=()) -> Path:
    """A plan of ``route`` with an inclusion polygon at ``fence_box`` (geodetic vertices) and
    ``rally`` (geodetic points), written as QGroundControl writes one."""
    path = write_plan(folder, cfg, route=route, fence=False)
    plan = json.loads(path.read_text())
    if fence_box is not None:
        plan["geoFence"]["polygons"] = [{"inclusion": True, "polygon": fence_box}]
    plan["rallyPoints"]["points"] = [[*p, 0.0] for p in rally]
    path.write_text(json.dumps(plan))
    return path


def test_every_list_is_checked_against_the_site_and_the_leaders_room(tmp_path: Path) -> None:
    base = parse_config(SCENARIO.format(mission=""))
    run = scenario(tmp_path, 'file = "route.plan"')
    near = [geo(base, -1.0, -1.0)]
    # a rally point 101 km north is another site; 99 km is this one
    write_lists(tmp_path, base, ROUTE, rally=[geo(base, 101_000.0, 0.0)])
    with pytest.raises(ConfigError, match=r"rally point 0 .* 101 km from the scenario's home"):
        scenario_mission(load_config(run))
    write_lists(tmp_path, base, ROUTE, rally=[geo(base, 99_000.0, 0.0)])
    assert scenario_mission(load_config(run)) is not None
    # a fence vertex at 0, 0 is at 0, 0 (only a mission item's 0, 0 means "here")
    box = [geo(base, n, e) for n, e in ((-20, -20), (-20, 20), (20, 20))] + [[0.0, 0.0]]
    write_lists(tmp_path, base, ROUTE, fence_box=box)
    with pytest.raises(ConfigError, match="fence item 3"):
        scenario_mission(load_config(run))
    # 51 rally points: a Rover has room for 50
    write_lists(tmp_path, base, ROUTE, rally=near * 51)
    with pytest.raises(ConfigError, match=r"rally at item 50: MAV_MISSION_NO_SPACE \(room for 50 items, it has 51\)"):
        scenario_mission(load_config(run))


def test_a_mission_file_under_home_is_found_and_an_unknown_user_is_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    base = parse_config(SCENARIO.format(mission=""))
    write_plan(tmp_path, base)
    monkeypatch.setenv("HOME", str(tmp_path))
    cfg = load_config(scenario(tmp_path, 'file = "~/route.plan"'))
    assert cfg.mission.file == str(tmp_path / "route.plan") and scenario_mission(cfg) is not None
    with pytest.raises(ConfigError, match=r"mission\.file: cannot expand"):
        load_config(scenario(tmp_path, 'file = "~no_such_user_lfctl/route.plan"'))
    with pytest.raises(ConfigError, match=r"mission\.file is empty"):
        load_config(scenario(tmp_path, 'file = " "'))


def test_the_plot_draws_a_mission_uploaded_after_the_start() -> None:
    """The log's first /scene mission is empty (no mission at the start); the one a ground
    station uploaded at 3 s is drawn."""
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

    from lfctl.record.mcap_read import Contents
    from lfctl.record.plots import _scene_mission

    def scene(places: list[tuple[float, float]]) -> bytes:
        update = SceneUpdate()
        ent = update.entities.add(id="mission")
        for n, e in places:
            sphere = ent.spheres.add()
            sphere.pose.position.x, sphere.pose.position.y = n, e
        return update.SerializeToString()

    c = Contents()
    c.messages["/scene"] = [(0, scene([])), (3_000_000_000, scene([(3.0, 0.0), (3.0, 2.0)]))]
    t0, places, _radius = _scene_mission(c)
    assert t0 == pytest.approx(3.0) and places == [(3.0, 0.0), (3.0, 2.0)]


def test_a_sweep_flies_a_mission_file_beside_its_scenario_from_any_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from lfctl.sweep.spec import parse_sweep, plan

    base = parse_config(SCENARIO.format(mission=""))
    folder = tmp_path / "scenarios"
    folder.mkdir()
    plan_file = write_plan(folder, base)
    scenario(folder, 'file = "route.plan"')
    monkeypatch.chdir(tmp_path)  # not the scenario's folder
    text = 'scenario = "scenarios/run.toml"\nseeds = 1\n[grid]\n"mission.cruise_speed_mps" = [0.2, 0.3]\n'
    first = plan(parse_sweep(text, base_dir=tmp_path))
    assert {r.config.mission.file for r in first.runs} == {str(plan_file.resolve())}
    plan_file.write_text(plan_file.read_text().replace('"version": 1', '"version": 1 '))
    assert plan(parse_sweep(text, base_dir=tmp_path)).digest != first.digest  # another mission, another sweep
    (folder / "route.plan").write_text("{")
    with pytest.raises(ConfigError, match=r"route\.plan"):
        plan(parse_sweep(text, base_dir=tmp_path))


def test_a_sweeps_folder_keeps_the_mission_file_so_each_variant_runs_again(tmp_path: Path) -> None:
    """The folder's scenario.toml and variants/*.toml name the plan as the scenario did
    ("plans/route.plan", beside it): a copy lies there for each."""
    from lfctl.sweep.engine import _make, _prepare
    from lfctl.sweep.spec import parse_sweep, plan

    base = parse_config(SCENARIO.format(mission=""))
    folder = tmp_path / "scenarios"
    (folder / "plans").mkdir(parents=True)
    original = write_plan(folder / "plans", base)
    scenario(folder, 'file = "plans/route.plan"')
    text = 'scenario = "scenarios/run.toml"\nseeds = 1\n[grid]\n"mission.cruise_speed_mps" = [0.2, 0.3]\n'
    out = tmp_path / "out"
    p = plan(parse_sweep(text, base_dir=tmp_path))
    assert _prepare(out, p, False, "code") is None  # a new folder, to make
    _make(out, p, "code")
    original.write_text("{")  # edited after the sweep: the folder keeps what it flew
    for toml in (out / "scenario.toml", *sorted((out / "variants").glob("*.toml"))):
        cfg = load_config(toml)
        assert Path(cfg.mission.file) == toml.parent / "plans" / "route.plan"
        assert [len(lst) for lst in scenario_mission(cfg).lists.values()] == [len(ROUTE) + 1, 4, 1]


def test_a_sweep_copies_only_what_its_scenario_names_beside_it_and_never_over_its_own_files(tmp_path: Path) -> None:
    from lfctl.sweep.engine import _make, _prepare
    from lfctl.sweep.spec import parse_sweep, plan

    def make(out: Path) -> None:
        p = plan(parse_sweep(text, base_dir=tmp_path))
        assert _prepare(out, p, False, "code") is None
        _make(out, p, "code")

    base = parse_config(SCENARIO.format(mission=""))
    folder = tmp_path / "scenarios"
    (folder / "plans").mkdir(parents=True)
    plan_file = write_plan(folder / "plans", base)
    text = 'scenario = "scenarios/run.toml"\nseeds = 1\n[grid]\n"mission.cruise_speed_mps" = [0.2, 0.3]\n'
    # a roundabout relative name lands where it points; an absolute one is used where it is
    scenario(folder, 'file = "plans/../plans/route.plan"')
    make(tmp_path / "a")
    assert (tmp_path / "a" / "plans" / "route.plan").is_file() and not (tmp_path / "plans").exists()
    scenario(folder, f"file = {json.dumps(str(plan_file))}")
    make(tmp_path / "b")
    assert not (tmp_path / "b" / "plans").exists()
    # a plan saved as sweep.json would take the sweep's own file's place
    (folder / "sweep.json").write_text(plan_file.read_text())
    scenario(folder, 'file = "sweep.json"')
    with pytest.raises(ConfigError, match=r"sweep\.json: a file the scenario names beside it would take"):
        _prepare(tmp_path / "c", plan(parse_sweep(text, base_dir=tmp_path)), False, "code")
    assert not (tmp_path / "c").exists()  # refused before anything was written
