"""A ground station's sticks as ArduPilot Rover reads them (RC_Channel::pwm_to_angle_dz_trim,
GCS_MAVLINK::handle_rc_channels_override and manual_override, RC_Channel::has_override),
worked by hand at Rover's defaults: 1100..1900 us, trim 1500, dead zone 30 (so 1470..1530
reads 0 and 370 us either side is the full range)."""

from __future__ import annotations

import math

import pytest

from lfctl.link.rc import STEER_RANGE, THROTTLE_RANGE, RcOverrides, manual_to_pwm, stick


@pytest.mark.parametrize(
    ("pwm", "percent"),
    [
        (1531, 0),  # 100 x 1 / 370 = 0.27: whole percent 0
        (1534, 1),  # 100 x 4 / 370 = 1.08
        (1466, -1),  # 100 x -4 / 370 = -1.08, toward zero -1
        (1899, 99),  # 100 x 369 / 370 = 99.7
        (1101, -99),
    ],
)
def test_the_throttle_reads_in_whole_percent_just_outside_the_dead_zone(pwm: int, percent: int) -> None:
    assert stick(pwm) == percent / 100
    assert stick(pwm, THROTTLE_RANGE) == percent / 100


def test_steering_left_of_the_dead_zone_reads_in_whole_centidegrees() -> None:
    # 4500 x (1300 - 1470) / 370 = -2067.6, toward zero -2067
    assert stick(1300, STEER_RANGE) == -2067 / 4500


@pytest.mark.parametrize(
    ("axis", "pwm"),
    [
        (1, 1500),  # 1100 + 800 x 1001 / 2000 = 1500.4, truncated
        (-1, 1499),  # 1499.6
        (3, 1501),  # 1501.2
        (1500, 2100),  # beyond the axis: 1100 + 800 x 2500 / 2000, beyond the end point too
    ],
)
def test_a_manual_control_axis_is_truncated_to_a_whole_microsecond(axis: int, pwm: int) -> None:
    assert manual_to_pwm(axis) == pwm


def test_rc_channels_override_is_read_to_channel_16_as_a_rover_has_16() -> None:
    # Rover's handle_rc_channels_override reads chan1..chan16 (NUM_RC_CHANNELS): channels 17 and
    # 18 are not taken, and values() reports them as 0, as Rover's RC_CHANNELS does
    rc = RcOverrides()
    rc.from_rc_override([1500] * 16 + [1700, 1800, 1600], t_s=0.0)
    assert rc.values(0.0, 3.0) == [1500] * 16 + [0, 0]
    assert rc.value(17, 0.0, 3.0) is None and rc.value(19, 0.0, 3.0) is None


def test_values_report_each_live_override_and_0_for_the_rest() -> None:
    # channel 2 1700 us and channel 12 1200 us; the others 0 (no override)
    rc = RcOverrides()
    rc.from_rc_override([65535, 1700, 65535, 65535, 65535, 65535, 65535, 65535, 0, 0, 0, 1200], t_s=5.0)
    expected = [0] * 18
    expected[1], expected[11] = 1700, 1200
    assert rc.values(5.0, 3.0) == expected
    assert rc.values(8.0, 3.0) == [0] * 18  # 3 s later: timed out


def test_an_override_is_live_until_rc_override_time_has_passed() -> None:
    # has_override: now - last_override_time < timeout: live at 2.999 s, gone at 3 s
    rc = RcOverrides()
    rc.set(3, 1800, 10.0)
    assert rc.value(3, 12.999, 3.0) == 1800
    assert rc.value(3, 13.0, 3.0) is None
    assert rc.value(3, 1e6, -1.0) == 1800  # negative: never times out
    assert rc.value(3, 10.0, 0.0) is None  # 0: overrides off
    assert rc.value(3, 10.0, math.nan) is None


def test_a_later_override_restarts_its_time() -> None:
    rc = RcOverrides()
    rc.set(1, 1600, 0.0)
    rc.set(1, 1650, 2.0)
    assert rc.value(1, 4.5, 3.0) == 1650  # 2.5 s after the second


def test_only_a_live_throttle_makes_the_pilot_active_with_steering_centred() -> None:
    # throttle 1715 us: (1715 - 1530) / 370 = 0.5; no steering override: centred
    rc = RcOverrides()
    rc.set(3, 1715, 0.0)
    pilot = rc.pilot(1.0, 3.0)
    assert (pilot.active, pilot.steering, pilot.throttle) == (True, 0.0, 0.5)


def test_only_a_live_steering_makes_the_pilot_active_with_throttle_centred() -> None:
    # steering 1285 us: (1285 - 1470) / 370 = -0.5, 2250 centidegrees exactly
    rc = RcOverrides()
    rc.set(1, 1285, 0.0)
    pilot = rc.pilot(1.0, 3.0)
    assert (pilot.active, pilot.steering, pilot.throttle) == (True, -0.5, 0.0)
    assert not rc.pilot(3.0, 3.0).active


def test_a_pulse_width_of_32768_is_int16_minus_32768_full_reverse() -> None:
    # radio_in read as an int16_t: 32768 is -32768, constrained to 1100: -1 (not 32768 -> 1900)
    assert stick(32768) == -1.0
    assert stick(32767) == 1.0  # the largest positive int16: constrained to 1900


def test_an_override_time_under_a_second_still_times_out() -> None:
    # RC_OVERRIDE_TIME 0.5 s: 500 ms; an override 0.6 s old is gone, 0.4 s old is live
    rc = RcOverrides()
    rc.set(1, 1600, 0.0)
    assert rc.value(1, 0.4, 0.5) == 1600
    assert rc.value(1, 0.6, 0.5) is None
