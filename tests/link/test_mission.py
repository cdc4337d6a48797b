"""Missions flattened into the leader's legs: DO_JUMP unrolled, DO commands queued with the
leg they begin with, starting from the current item; jump loops with no waypoint in them end."""

from __future__ import annotations

import pytest

from lfctl.link.mission import DO_CHANGE_SPEED, DO_JUMP, MAX_EXPANDED, MissionItem, local_mission, to_legs

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
