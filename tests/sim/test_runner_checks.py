"""What a run says before it starts about a scenario whose followers cannot see their targets,
or whose vehicles start on top of each other, or whose timed events come after its end."""

from __future__ import annotations

from support import LEADER_AND_FOLLOWER

from lfctl.config import parse_config
from lfctl.sim.runner import events_after_the_end, slots_out_of_view

SCENARIO = (
    """[sim]
sensing = "camera"
[camera]
hfov_deg = 62
"""
    + LEADER_AND_FOLLOWER
    + """bearing_deg = 30
range_m = 1.5
"""
)


def test_a_slot_whose_banner_leaves_the_picture_is_named() -> None:
    # the default vee's slot (30 deg at 1.5 m) with the default 62 deg lens: the camera sits
    # ahead of the follower's point and the banner behind the leader's, so the banner is out
    # of the picture (such a follower tracked 0.8 s of 12 and ended stopped)
    (said,) = slots_out_of_view(parse_config(SCENARIO, "t"))
    assert said.startswith("f1's slot (1.5 m, 30 deg from leader) leaves leader's banner out of the 640x480 picture")
    assert slots_out_of_view(parse_config(SCENARIO.replace("hfov_deg = 62", "hfov_deg = 100"), "t")) == []
    assert slots_out_of_view(parse_config(SCENARIO.replace("bearing_deg = 30", "bearing_deg = 10"), "t")) == []
    # the focal length set directly: a 116 deg lens in fact, whatever hfov_deg says
    wide = SCENARIO.replace("hfov_deg = 62", "hfov_deg = 62\nfx_px = 200").replace(
        "bearing_deg = 30", "bearing_deg = 40"
    )
    assert slots_out_of_view(parse_config(wide, "t")) == []


def test_a_slot_outside_the_truth_sensors_view_or_range_is_named() -> None:
    truth = (
        SCENARIO.replace('"camera"', '"truth"').replace("range_m = 1.5", "range_m = 12") + "[sensing]\nfov_deg = 40\n"
    )
    said = slots_out_of_view(parse_config(truth, "t"))
    assert said == [
        "f1's slot (12 m, 30 deg from leader) is outside the truth sensor's field of view (+-20 deg): once in "
        "its slot it will not see its target",
        "f1's slot (12 m, 30 deg from leader) is past the truth sensor's sensing.max_range_m (10 m): once in "
        "its slot it will not see its target",
    ]
    assert slots_out_of_view(parse_config(SCENARIO.replace('"camera"', '"truth"'), "t")) == []


def test_vehicles_that_start_on_top_of_each_other_are_named() -> None:
    # a slip in a scenario (a follower's north_m left at the leader's 0): the run went on with
    # a minimum separation of 0.00 m and no word
    from lfctl.sim.runner import vehicles_on_each_other

    on_top = LEADER_AND_FOLLOWER.replace("north_m = -1.5", "north_m = -0.1")
    (said,) = vehicles_on_each_other(parse_config(on_top, "t"))
    assert said.startswith("vehicles leader and f1 start 0.10 m apart, closer than a rover's 0.3 m length")
    assert vehicles_on_each_other(parse_config(LEADER_AND_FOLLOWER, "t")) == []


def test_an_occluder_or_a_dropout_the_run_ends_before_is_named() -> None:
    # a 70 s run with an occluder at 300 s and a dropout from 70 s (the end itself): neither
    # ever happens; one at 69.9 s and a dropout from 10 s do, and are not named
    events = (
        """[sim]
duration_s = 70
[[scene.occluders]]
t_s = 300
[[scene.occluders]]
t_s = 69.9
[sensing]
dropouts = [[10.0, 20.0], [70.0, 80.0]]
"""
        + LEADER_AND_FOLLOWER
    )
    assert events_after_the_end(parse_config(events, "t")) == [
        "scene.occluders[0].t_s = 300 s is at or after the run's end (70 s): it never crosses",
        "sensing.dropouts[1] starts at 70 s, at or after the run's end (70 s): it never happens",
    ]
    assert events_after_the_end(parse_config(events.replace("duration_s = 70", "duration_s = 400"), "t")) == []
