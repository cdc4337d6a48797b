"""What a run says before it starts about a scenario whose followers cannot see their targets,
or whose vehicles start on top of each other."""

from __future__ import annotations

from support import LEADER_AND_FOLLOWER

from lfctl.config import parse_config
from lfctl.sim.runner import slots_out_of_view

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
