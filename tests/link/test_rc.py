"""The ground station's sticks as Rover reads them: pulse widths through the dead zone to
-1..1, MANUAL_CONTROL's axes onto pulse widths, RC_CHANNELS_OVERRIDE's no-change and release
values, and the override timeout. Hand-worked numbers from Rover's defaults (1100-1900 us,
trim 1500, dead zone 30)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from lfctl.link.rc import STEER_RANGE, RcOverrides, manual_to_pwm, stick
from lfctl.sim.driver import speed_max


@pytest.mark.parametrize(
    ("pwm", "expected"),
    [
        (1500, 0.0),
        (1530, 0.0),  # the dead zone's edge
        (1470, 0.0),
        (1900, 1.0),
        (1100, -1.0),
        (1715, 0.5),  # (1715 - 1530) / (1900 - 1530) = 185 / 370
        (1285, -0.5),  # (1285 - 1470) / (1470 - 1100)
        (1700, 0.45),  # 100 x 170 / 370 = 45.9: Rover's control_in is a whole percent
        (1300, -0.45),  # truncated toward zero
        (2100, 1.0),  # beyond the end points: clipped, as Rover constrains radio_in
        (900, -1.0),
        (40000, -1.0),  # radio_in is an int16_t: 40000 is -25536
        (65535, -1.0),
    ],
)
def test_a_channel_reads_through_its_dead_zone_to_its_end_points(pwm: int, expected: float) -> None:
    assert stick(pwm) == pytest.approx(expected)


def test_steering_reads_in_whole_centidegrees() -> None:
    assert stick(1700, STEER_RANGE) == 2067 / 4500  # 4500 x 170 / 370 = 2067.6
    assert stick(1567, STEER_RANGE) == 0.1  # 4500 x 37 / 370 = 450


@pytest.mark.parametrize(
    ("cruise_speed", "cruise_throttle", "full"),
    [
        (2.0, 50, 4.0),  # Rover's defaults: 2 m/s at 50 %
        (0.4, 80, 0.5),
        (2.0, 4, 2.0),  # below 5 %: not sane, full throttle is the cruise speed
        (2.0, 0, 2.0),
        (20.0, 25, 30.0),  # at most 30 m/s
    ],
)
def test_full_throttle_speed_as_rover_projects_it(cruise_speed: float, cruise_throttle: float, full: float) -> None:
    assert speed_max(cruise_speed, cruise_throttle) == pytest.approx(full)


@given(st.integers(800, 2200), st.integers(800, 2200))
def test_a_stick_is_monotone_and_bounded(a: int, b: int) -> None:
    lo, hi = sorted((a, b))
    assert -1.0 <= stick(lo) <= stick(hi) <= 1.0


@pytest.mark.parametrize(("axis", "pwm"), [(-1000, 1100), (0, 1500), (1000, 1900), (250, 1600), (-500, 1300)])
def test_manual_control_axes_map_linearly_onto_the_channel(axis: int, pwm: int) -> None:
    assert manual_to_pwm(axis) == pwm


def test_rc_override_no_change_release_and_the_high_channels() -> None:
    rc = RcOverrides()
    rc.from_rc_override([1600, 65535, 1700, 0, 0, 0, 0, 0, 1234, 0, 65535], t_s=0.0)
    assert rc.value(1, 0.0, 3.0) == 1600 and rc.value(3, 0.0, 3.0) == 1700
    assert rc.value(9, 0.0, 3.0) == 1234
    assert rc.value(2, 0.0, 3.0) is None and rc.value(10, 0.0, 3.0) is None
    # 65535 leaves channel 1 as it was; 0 releases channel 3; on 9-16 0 changes nothing and 65534 releases
    rc.from_rc_override([65535, 0, 0, 0, 0, 0, 0, 0, 0], t_s=1.0)
    assert rc.value(1, 1.0, 3.0) == 1600 and rc.value(3, 1.0, 3.0) is None
    assert rc.value(9, 1.0, 3.0) == 1234
    rc.from_rc_override([65535] * 8 + [65534], t_s=1.0)
    assert rc.value(9, 1.0, 3.0) is None


def test_an_override_lasts_rc_override_time_and_manual_control_releases_with_int16_max() -> None:
    rc = RcOverrides()
    rc.from_manual_control(y=500, z=-1000, t_s=10.0)
    pilot = rc.pilot(12.9, timeout_s=3.0)
    assert pilot.active and pilot.throttle == -1.0
    assert pilot.steering == 2067 / 4500  # y 500 -> 1700 us
    assert not rc.pilot(13.0, timeout_s=3.0).active  # 3 s after it came
    assert rc.pilot(1000.0, timeout_s=-1.0).active  # negative: until released
    assert not rc.pilot(10.0, timeout_s=0.0).active  # 0: overrides off
    rc.from_manual_control(y=32767, z=32767, t_s=11.0)
    assert not rc.pilot(11.0, timeout_s=-1.0).active


def test_a_negative_pulse_width_wraps_as_rovers_uint16_override() -> None:
    rc = RcOverrides()
    rc.from_manual_control(y=-32768, z=-3750, t_s=0.0)  # 1100 + 800 x -31768 / 2000; z: exactly 0
    assert rc.value(1, 0.0, 3.0) == (1100 - 12707) & 0xFFFF
    assert rc.value(3, 0.0, 3.0) is None  # 0: released, as Rover's manual_override gives it
    assert rc.pilot(0.0, 3.0).steering == -1.0
    assert all(0 <= v <= 0xFFFF for v in rc.values(0.0, 3.0))
