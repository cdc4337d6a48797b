"""Missions flattened into the leader's legs: DO_JUMP unrolled, DO commands queued with the
leg they begin with, starting from the current item; jump loops with no waypoint in them end.
QGroundControl plans with a survey read as the items QGroundControl saved with it."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.link.mission import (
    DO_CHANGE_SPEED,
    DO_JUMP,
    DO_JUMP_TAG,
    JUMP_TAG,
    MAX_EXPANDED,
    MissionItem,
    local_mission,
    to_legs,
)

HOME = (12.96, 77.67, 900.0)


def renumbered(items: list[MissionItem]) -> list[MissionItem]:
    from dataclasses import replace

    return [replace(it, seq=k) for k, it in enumerate(items)]


def test_plain_waypoints_become_legs_in_local_metres() -> None:
    legs = to_legs(local_mission([(1.0, 0.0), (1.0, 1.0, 3.0)], HOME), HOME)
    assert [(leg.seq, leg.hold_s, leg.before) for leg in legs] == [(1, 0.0, ()), (2, 3.0, ())]
    # positions travel as degE7: 1e-7 deg is 1.1 cm of latitude
    assert [(leg.north_m, leg.east_m) for leg in legs] == [
        pytest.approx((1.0, 0.0), abs=0.012),
        pytest.approx((1.0, 1.0), abs=0.012),
    ]


def test_do_commands_begin_with_the_leg_after_them() -> None:
    # as ArduPilot's mission library: the DO commands between two waypoints start once the
    # first is done, so they act on the leg to the second
    items = local_mission([(1.0, 0.0), (1.0, 1.0), (2.0, 0.0)], HOME)
    items.insert(2, MissionItem(2, 0, DO_CHANGE_SPEED, 1.0, 0.5))
    items.insert(4, MissionItem(4, 0, DO_CHANGE_SPEED, 1.0, -1.0))  # -1: no change
    legs = to_legs(renumbered(items), HOME)
    assert [[(it.seq, it.param2) for it in leg.before] for leg in legs] == [[], [(2, 0.5)], [(4, -1.0)]]


def test_do_jump_repeats_its_loop_the_given_number_of_times() -> None:
    # 1 WP, 2 WP, 3 DO_JUMP to 1 twice, 4 WP: 1 2 (1 2) (1 2) 4
    items = local_mission([(1.0, 0.0), (1.0, 1.0)], HOME)
    items.append(MissionItem(3, 0, DO_JUMP, 1.0, 2.0))
    items += local_mission([(2.0, 0.0)], HOME)[1:]
    legs = to_legs(renumbered(items), HOME)
    assert [leg.seq for leg in legs] == [1, 2, 1, 2, 1, 2, 4]


def test_a_jump_to_a_tag_goes_to_the_first_jump_tag_of_it_and_a_missing_tag_ends_the_mission() -> None:
    # 1 WP, 2 JUMP_TAG 7, 3 WP, 4 DO_JUMP_TAG 7 once, 5 JUMP_TAG 7 (a second of the tag: not
    # the one jumped to), 6 WP: 1 3 (3) 6, as AP_Mission::get_index_of_jump_tag finds it
    items = local_mission([(1.0, 0.0)], HOME)
    items.append(MissionItem(2, 0, JUMP_TAG, 7.0))
    items += local_mission([(1.0, 1.0)], HOME)[1:]
    items.append(MissionItem(4, 0, DO_JUMP_TAG, 7.0, 1.0))
    items.append(MissionItem(5, 0, JUMP_TAG, 7.0))
    items += local_mission([(2.0, 0.0)], HOME)[1:]
    legs = to_legs(renumbered(items), HOME)
    assert [leg.seq for leg in legs] == [1, 3, 3, 6]
    assert [[it.seq for it in leg.before] for leg in legs] == [[], [2], [2], [5]]
    # said as a DO_JUMP's ("Mission: 4 Jump 1/1"), before the tag it leads to
    assert (legs[2].jumped, legs[2].jumps_first) == (((4, 1, 1),), 1)
    # a tag no JUMP_TAG has: the mission ends at the jump (MAVLink: "should complete the mission")
    for count in (1.0, 0.0):  # whatever the count: Rover's get_next_cmd checks the target first
        missing = [*items[:4], MissionItem(4, 0, DO_JUMP_TAG, 8.0, count), *items[5:]]
        assert [leg.seq for leg in to_legs(renumbered(missing), HOME)] == [1, 3]


def test_legs_start_from_the_current_item() -> None:
    items = local_mission([(1.0, 0.0), (1.0, 1.0), (2.0, 0.0)], HOME)
    assert [leg.seq for leg in to_legs(items, HOME, start_seq=2)] == [2, 3]


def test_a_jump_repeated_for_ever_is_unrolled_to_the_limit() -> None:
    items = local_mission([(1.0, 0.0), (1.0, 1.0)], HOME)
    items.append(MissionItem(3, 0, DO_JUMP, 1.0, -1.0))
    legs = to_legs(renumbered(items), HOME)
    assert len(legs) == MAX_EXPANDED


@pytest.mark.parametrize(
    "jumps",
    [
        [(2, 2.0, -1.0)],  # a DO_JUMP to itself, for ever
        [(2, 3.0, -1.0), (3, 2.0, -1.0)],  # two that point at each other
    ],
)
def test_jump_loops_without_a_waypoint_end(jumps: list[tuple[int, float, float]]) -> None:
    items = local_mission([(1.0, 0.0)], HOME)
    for seq, target, repeat in jumps:
        items.append(MissionItem(seq, 0, DO_JUMP, target, repeat))
    items += local_mission([(2.0, 0.0)], HOME)[1:]
    legs = to_legs(renumbered(items), HOME)  # returns: it used to spin for ever
    assert [leg.seq for leg in legs] == [1]


def qgc_item(command: int, params: list[float | None], frame: int = 3) -> dict:
    """One item as QGroundControl's MissionItem::save writes it."""
    return {
        "autoContinue": True,
        "command": command,
        "doJumpId": 0,
        "frame": frame,
        "params": params,
        "type": "SimpleItem",
    }


def survey_plan(tmp_path: Path, complex_item: dict) -> Path:
    import json

    wp = qgc_item(16, [0, 0, 0, None, 12.9603, 77.6691, 0])
    plan = {
        "fileType": "Plan",
        "groundStation": "QGroundControl",
        "version": 1,
        "mission": {
            "version": 2,
            "firmwareType": 3,
            "vehicleType": 10,
            "plannedHomePosition": [12.9602, 77.669, 900],
            "items": [wp, complex_item, qgc_item(20, [0, 0, 0, 0, 0, 0, 0], frame=2)],
        },
    }
    path = tmp_path / "survey.plan"
    path.write_text(json.dumps(plan))
    return path


def test_a_qgroundcontrol_survey_is_loaded_as_the_items_it_carries(tmp_path: Path) -> None:
    # QGroundControl saves a transect-style complex item (survey, corridor scan) with the
    # mission items it made of it: they follow the item before, numbered on
    from lfctl.link.mission import load_mission

    made = [
        qgc_item(16, [0, 0, 0, None, 12.9604, 77.6692, 0]),
        qgc_item(206, [2.5, 0, 1, 0, 0, 0, 0], frame=2),  # the camera, every 2.5 m
        qgc_item(16, [0, 0, 0, None, 12.9606, 77.6692, 0]),
        qgc_item(16, [0, 0, 0, None, 12.9606, 77.6694, 0]),
        qgc_item(206, [0, 0, 1, 0, 0, 0, 0], frame=2),
    ]
    survey = {
        "type": "ComplexItem",
        "complexItemType": "survey",
        "version": 5,
        "TransectStyleComplexItem": {"version": 1, "Items": made, "CameraCalc": {}, "VisualTransectPoints": []},
    }
    items = load_mission(survey_plan(tmp_path, survey))
    assert [(it.seq, it.command) for it in items] == [
        (0, 16), (1, 16), (2, 16), (3, 206), (4, 16), (5, 16), (6, 206), (7, 20),
    ]  # fmt: skip
    assert items[3].param1 == 2.5 and items[4].lat_deg == pytest.approx(12.9606)


@pytest.mark.parametrize(
    ("complex_item", "named"),
    [
        (
            {"type": "ComplexItem", "complexItemType": "StructureScan", "version": 3},
            "'StructureScan' carries no mission",
        ),
        (
            {"type": "ComplexItem", "complexItemType": "survey", "TransectStyleComplexItem": {"Items": [3]}},
            "TransectStyleComplexItem.Items[0] must be an object",
        ),
        ({"type": "Waypoint"}, "'Waypoint' is not SimpleItem or ComplexItem"),
    ],
)
def test_a_complex_item_lfctl_cannot_read_is_named(tmp_path: Path, complex_item: dict, named: str) -> None:
    from lfctl.errors import ConfigError
    from lfctl.link.mission import load_mission

    with pytest.raises(ConfigError, match=re.escape(named)):
        load_mission(survey_plan(tmp_path, complex_item))


@pytest.mark.parametrize(
    ("section", "value", "named"),
    [
        ("geoFence", {"polygons": [{"inclusion": True}]}, "geoFence.polygons[0] must be"),
        ("geoFence", {"polygons": [{"inclusion": 1, "polygon": []}]}, "geoFence.polygons[0] must be"),
        (
            "geoFence",
            {"polygons": [{"inclusion": True, "polygon": [[12.9, 77.6], [12.9, "77"], [13, 77]]}]},
            "polygon[1] must be [latitude",
        ),
        ("geoFence", {"polygons": [{"inclusion": True, "polygon": [[12.9, 77.6], [12.91, 77.6]]}]}, "this one 2"),
        ("geoFence", {"circles": [{"inclusion": True, "circle": {"center": [12.9, 77.6], "radius": 0}}]}, "got 0"),
        # under a float's epsilon: not positive to Rover's validate_fence either
        (
            "geoFence",
            {"circles": [{"inclusion": True, "circle": {"center": [12.9, 77.6], "radius": 1e-8}}]},
            "got 1e-08",
        ),
        ("geoFence", {"polygons": [{"inclusion": True, "polygon": [[10**400, 77.6]] * 3}]}, "polygon[0] must be [lat"),
        ("geoFence", {"breachReturn": [12.9, 77.6]}, "geoFence.breachReturn must be [latitude, longitude, altitude]"),
        ("geoFence", {"circles": [{"circle": {"center": [12.9, 77.6], "radius": "5"}}]}, "geoFence.circles[0] must be"),
        ("geoFence", {"circles": [{"inclusion": True, "circle": {"center": [12.9], "radius": 5}}]}, "center must be"),
        ("geoFence", [], "geoFence must be an object"),
        ("rallyPoints", {"points": [[12.9, 77.6]]}, "rallyPoints.points[0] must be [latitude, longitude, altitude]"),
        ("rallyPoints", {"points": {}}, "rallyPoints must be"),
        ("rallyPoints", {"points": [[95.0, 77.6, 0]]}, "latitude must be within"),
        # what QGroundControl refuses: a fence or rally list of another version, a polygon or
        # circle that does not say whether it is an inclusion, a fence without its lists
        ("geoFence", {"version": 3}, "geoFence version 3: QGroundControl reads version 2"),
        ("geoFence", {"version": None}, "geoFence version None"),
        ("geoFence", {"polygons": [{"polygon": [[12.9, 77.6], [12.91, 77.6], [12.91, 77.61]]}]}, "'inclusion': true"),
        ("geoFence", {"circles": [{"circle": {"center": [12.9, 77.6], "radius": 5}}]}, "'inclusion': true"),
        ("geoFence", {"circles": None}, "(both are required)"),
        ("rallyPoints", {"version": 3, "points": []}, "rallyPoints version 3: QGroundControl reads version 2"),
    ],
)
def test_a_plans_fence_or_rally_point_lfctl_cannot_read_is_named(
    tmp_path: Path, section: str, value: object, named: str
) -> None:
    import json

    from lfctl.errors import ConfigError
    from lfctl.link.mission import load_mission_file

    path = survey_plan(tmp_path, qgc_item(16, [0, 0, 0, 0, 12.9603, 77.6691, 0]))
    plan = json.loads(path.read_text())
    required = {"geoFence": {"version": 2, "polygons": [], "circles": []}, "rallyPoints": {"version": 2}}
    plan[section] = {**required[section], **value} if isinstance(value, dict) else value
    path.write_text(json.dumps(plan))
    with pytest.raises(ConfigError, match=re.escape(named)):
        load_mission_file(path)


def test_a_plan_is_read_as_qgroundcontrol_reads_it(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """DO_JUMP's param1 names its target's doJumpId, and goes up as the target's seq; a
    version-1 fence or rally list (QGroundControl 3.x) is ignored, as QGroundControl ignores
    it; a DO command's params 5-6 in MAV_FRAME_MISSION go up as they are, not scaled as a place;
    a file that is not a plan of version 1 is named."""
    import json

    from lfctl.errors import ConfigError
    from lfctl.link.mission import load_mission_file, save_mission

    plan = json.loads(survey_plan(tmp_path, qgc_item(16, [0, 0, 0, 0, 12.9603, 77.6691, 0])).read_text())
    items = [
        qgc_item(16, [0, 0, 0, 0, 12.9603, 77.6691, 0]) | {"doJumpId": 10},
        qgc_item(16, [0, 0, 0, 0, 12.9604, 77.6691, 0]) | {"doJumpId": 20},
        qgc_item(177, [10, 2, 0, 0, 0, 0, 0], frame=2) | {"doJumpId": 30},
        qgc_item(203, [0, 0, 0, 0, 1, 7, 0], frame=2) | {"doJumpId": 40},  # DO_DIGICAM_CONTROL: shoot, id 7
    ]
    plan["mission"]["items"] = items
    plan["geoFence"] = {"version": 1, "polygon": [[12.96, 77.66], [12.961, 77.66], [12.961, 77.661]],
                        "breachReturn": [12.96, 77.66]}  # fmt: skip
    plan["rallyPoints"] = {"version": 1, "points": [[12.96, 77.66]]}
    path = tmp_path / "q.plan"
    path.write_text(json.dumps(plan))
    loaded = load_mission_file(path)
    assert [(it.command, it.param1) for it in loaded.mission[1:4]] == [(16, 0.0), (16, 0.0), (177, 1.0)]
    assert (loaded.mission[4].x, loaded.mission[4].y) == (1, 7)  # not 10000000, 70000000
    assert (loaded.fence, loaded.rally) == ([], []) and "version 1 (QGroundControl 3.x) ignored" in caplog.text
    save_mission(loaded.mission, tmp_path / "again.plan")
    again = json.loads((tmp_path / "again.plan").read_text())["mission"]["items"]
    assert again[3]["params"][4:6] == [1.0, 7.0] and again[2]["params"][0] == 1.0 and again[0]["doJumpId"] == 1
    assert load_mission_file(tmp_path / "again.plan").mission == loaded.mission
    items[2]["params"][0] = 2  # no item has doJumpId 2: QGroundControl refuses the file
    path.write_text(json.dumps(plan))
    with pytest.raises(ConfigError, match="jumps to doJumpId 2, which no item has"):
        load_mission_file(path)
    for key, value, named in (
        ("fileType", "Mission", "fileType 'Mission', not 'Plan'"),
        ("version", 2, "plan version 2"),
    ):
        path.write_text(json.dumps(plan | {key: value}))
        with pytest.raises(ConfigError, match=re.escape(named)):
            load_mission_file(path)


def test_a_plans_fence_and_rally_points_round_trip_through_the_plan_writer(tmp_path: Path) -> None:
    import json

    from lfctl.link.mission import load_mission_file, save_mission

    first = tmp_path / "first.plan"
    geo = {
        "version": 2,
        "polygons": [{"inclusion": False, "polygon": [[12.96, 77.66], [12.961, 77.66], [12.961, 77.661]]}],
        "circles": [{"inclusion": True, "circle": {"center": [12.9605, 77.6605], "radius": 40.0}}],
        "breachReturn": [12.9602, 77.6602, 5.0],
    }
    # param4 (yaw) left unset, as QGroundControl writes it: null, read as NaN, written as null
    plan = json.loads(survey_plan(tmp_path, qgc_item(16, [0, 0, 0, None, 12.9603, 77.6691, 0])).read_text())
    plan["geoFence"], plan["rallyPoints"] = geo, {"version": 2, "points": [[12.9601, 77.6601, 3.0]]}
    first.write_text(json.dumps(plan))
    loaded = load_mission_file(first)
    assert [(it.seq, it.command, it.param1) for it in loaded.fence] == [
        (0, 5002, 3.0),
        (1, 5002, 3.0),
        (2, 5002, 3.0),
        (3, 5003, 40.0),
        (4, 5000, 0.0),
    ]
    save_mission(loaded.mission, tmp_path / "again.plan", loaded.fence, loaded.rally)
    strict = json.loads((tmp_path / "again.plan").read_text(), parse_constant=lambda c: pytest.fail(f"bare {c}"))
    assert strict["mission"]["items"][0]["params"][3] is None
    assert strict["geoFence"]["breachReturn"] == pytest.approx([12.9602, 77.6602, 5.0])
    again = load_mission_file(tmp_path / "again.plan")
    assert (again.fence, again.rally) == (loaded.fence, loaded.rally)
    assert [(it.command, it.x, it.y) for it in again.mission] == [(it.command, it.x, it.y) for it in loaded.mission]
    assert math.isnan(again.mission[1].param4) and again.plan and again.rally[0].z == 3.0


def test_fence_and_rally_items_are_places_and_mission_items_always_continue_as_on_rover() -> None:
    """ArduPilot's fence and rally converters: a vertex or rally point in MAV_FRAME_MISSION is
    no place (UNSUPPORTED_FRAME), a rally point's altitude is an int16; a mission item goes
    down with autocontinue 1 whatever came up (mission_cmd_to_mavlink_int)."""
    from lfctl.link.mission import MissionItem
    from lfctl.link.mission_server import FENCE, MISSION, RALLY, _item_message, item_result

    x, y = 129600000, 776700000
    vertex = MissionItem(0, mav.MAV_FRAME_GLOBAL, mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, 5.0, x=x, y=y)
    rally = MissionItem(0, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_NAV_RALLY_POINT, x=x, y=y, z=3.0)
    assert item_result(vertex, FENCE, 1) == item_result(rally, RALLY, 1) == mav.MAV_MISSION_ACCEPTED
    for it, kind in ((vertex, FENCE), (rally, RALLY)):
        moved = dataclasses.replace(it, frame=mav.MAV_FRAME_MISSION)
        assert item_result(moved, kind, 1) == mav.MAV_MISSION_UNSUPPORTED_FRAME
    assert item_result(dataclasses.replace(rally, z=40000.0), RALLY, 1) == mav.MAV_MISSION_INVALID_PARAM7
    wp = MissionItem(1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_NAV_WAYPOINT, x=x, y=y, autocontinue=0)
    assert _item_message(wp, 255, 190, 0, MISSION).autocontinue == 1
    assert _item_message(dataclasses.replace(vertex, autocontinue=0), 255, 190, 0, FENCE).autocontinue == 0


@pytest.mark.parametrize(
    ("command", "kept"),
    [
        (mav.MAV_CMD_SET_CAMERA_ZOOM, (1.0, 2.0, 0.0, 0.0)),
        (mav.MAV_CMD_SET_CAMERA_FOCUS, (1.0, 2.0, 0.0, 0.0)),
        (mav.MAV_CMD_SET_CAMERA_SOURCE, (1.0, 2.0, 3.0, 0.0)),
        (mav.MAV_CMD_DO_RETURN_PATH_START, (0.0, 0.0, 0.0, 0.0)),
        (JUMP_TAG, (1.0, 0.0, 0.0, 0.0)),
        (DO_JUMP_TAG, (1.0, 2.0, 0.0, 0.0)),
    ],
)
def test_the_newer_commands_keep_what_ap_mission_keeps(command: int, kept: tuple[float, ...]) -> None:
    # AP_Mission::mavlink_int_to_mission_cmd's fields: a download gives back these, the rest 0
    from lfctl.link.mission import as_stored

    it = as_stored(MissionItem(1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command, 1.0, 2.0, 3.0, 4.0))
    assert (it.param1, it.param2, it.param3, it.param4) == kept
