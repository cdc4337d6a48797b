"""A loiter's fractional turns as ArduPilot stores them (AP_Mission::mavlink_int_to_mission_cmd):
0 < turns < 1 in 256ths of a turn, truncated, and given back as that fraction."""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.link.mission import NAV_LOITER_TURNS, MissionItem, as_stored


def loiter(turns: float) -> MissionItem:
    return MissionItem(
        1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, NAV_LOITER_TURNS, turns, 0.0, 2.0, 0.0, 129600000, 776700000, 10.0
    )


@pytest.mark.parametrize(
    ("turns", "stored"),
    [
        (0.5, 0.5),  # 0.5 * 256 = 128 256ths: exactly half a turn
        (0.3, 76 / 256),  # 0.3 * 256 = 76.8, truncated to 76: 0.296875
    ],
)
def test_fractional_loiter_turns_are_stored_in_256ths_of_a_turn(turns: float, stored: float) -> None:
    # Wrong, a NAV_LOITER_TURNS of half a turn would be stored, given back and driven as 0 turns.
    it = as_stored(loiter(turns))
    assert it.param1 == pytest.approx(stored, abs=1e-12)
    assert it.param3 == 2.0  # the radius, whole metres, clockwise
    assert (it.x, it.y, it.z) == (129600000, 776700000, 10.0)
