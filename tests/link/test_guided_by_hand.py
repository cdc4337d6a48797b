"""GUIDED setpoints as ArduPilot Rover takes them (Rover/GCS_MAVLink_Rover.cpp:
handle_set_position_target_local_ned / _global_int, handle_set_attitude_target), worked by
hand: which target each combination of type_mask bits makes, where a position lands in each
frame, the speed and heading a velocity gives."""

from __future__ import annotations

import math

import pytest

from lfctl.link.guided import (
    MASK_ACC_IGNORE,
    MASK_POS_IGNORE,
    MASK_VEL_IGNORE,
    MASK_YAW_IGNORE,
    MASK_YAW_RATE_IGNORE,
    GuidedTarget,
    Pose,
    attitude_target,
    global_to_local,
    position_target,
)

ATT_YAW_RATE_IGNORE, ATT_THROTTLE_IGNORE = 0b0000_0100, 0b0100_0000
#: a setpoint that gives only what its name says (every other field ignored)
POSITION_ONLY = MASK_VEL_IGNORE | MASK_ACC_IGNORE | MASK_YAW_IGNORE | MASK_YAW_RATE_IGNORE
VELOCITY_ONLY = MASK_POS_IGNORE | MASK_ACC_IGNORE | MASK_YAW_IGNORE | MASK_YAW_RATE_IGNORE
VELOCITY_AND_RATE = MASK_POS_IGNORE | MASK_ACC_IGNORE | MASK_YAW_IGNORE
VELOCITY_AND_YAW = MASK_POS_IGNORE | MASK_ACC_IGNORE | MASK_YAW_RATE_IGNORE
YAW_ONLY = MASK_POS_IGNORE | MASK_VEL_IGNORE | MASK_ACC_IGNORE | MASK_YAW_RATE_IGNORE
RATE_ONLY = MASK_POS_IGNORE | MASK_VEL_IGNORE | MASK_ACC_IGNORE | MASK_YAW_IGNORE
#: the vehicle at (100 N, 50 E) heading east
EAST = Pose(100.0, 50.0, math.pi / 2)


def setpoint(
    frame: str,
    mask: int,
    x: float = 0.0,
    y: float = 0.0,
    vx: float = 0.0,
    vy: float = 0.0,
    yaw: float = 0.0,
    yaw_rate: float = 0.0,
    pose: Pose = EAST,
    origin: tuple[float, float] = (0.0, 0.0),
) -> GuidedTarget | str:
    return position_target(7.0, frame, mask, x, y, vx, vy, yaw, yaw_rate, pose, 2.0, origin)


# --- where a position setpoint lands --------------------------------------------------------------


def test_a_local_position_is_from_the_local_origin() -> None:
    # MAV_FRAME_LOCAL_NED: the EKF origin plus (x, y); the origin at (1, 2): (11, -3)
    got = setpoint("local", POSITION_ONLY, 10.0, -5.0, origin=(1.0, 2.0))
    assert got == GuidedTarget("location", 7.0, north_m=11.0, east_m=-3.0)


def test_a_local_offset_position_is_from_the_vehicle() -> None:
    # MAV_FRAME_LOCAL_OFFSET_NED: the vehicle (100, 50) plus (10, -5): (110, 45)
    assert setpoint("local_offset", POSITION_ONLY, 10.0, -5.0) == GuidedTarget(
        "location", 7.0, north_m=110.0, east_m=45.0
    )


def test_a_body_position_is_turned_by_the_heading() -> None:
    # MAV_FRAME_BODY_NED, heading east (cos 0, sin 1): 10 ahead and 2 right is
    # north x cos - y sin = -2, east x sin + y cos = 10: (98, 60)
    got = setpoint("body", POSITION_ONLY, 10.0, 2.0)
    assert isinstance(got, GuidedTarget)
    assert (got.kind, got.north_m, got.east_m) == ("location", pytest.approx(98.0), pytest.approx(60.0))


def test_a_body_position_at_a_slant_heading() -> None:
    # heading with cos 0.8, sin 0.6 (36.87 deg): 10 ahead and 5 right is north
    # 10 x 0.8 - 5 x 0.6 = 5, east 10 x 0.6 + 5 x 0.8 = 10: from (100, 50), (105, 60)
    got = setpoint("body", POSITION_ONLY, 10.0, 5.0, pose=Pose(100.0, 50.0, math.atan2(0.6, 0.8)))
    assert (got.north_m, got.east_m) == (pytest.approx(105.0), pytest.approx(60.0))


def test_a_global_position_is_taken_as_given() -> None:
    # SET_POSITION_TARGET_GLOBAL_INT: already local north, east from the caller
    assert setpoint("global", POSITION_ONLY, -30.0, 40.0) == GuidedTarget("location", 7.0, north_m=-30.0, east_m=40.0)


def test_a_position_wins_over_a_velocity_and_is_held_until_reached() -> None:
    # with position given the handler sets the location and returns: the velocity is unused
    got = setpoint("local", MASK_ACC_IGNORE | MASK_YAW_IGNORE | MASK_YAW_RATE_IGNORE, 5.0, 6.0, vx=1.0)
    assert got == GuidedTarget("location", 7.0, north_m=5.0, east_m=6.0)
    assert not got.times_out


def test_a_degree_e7_position_is_metres_from_home() -> None:
    # home 0 N 0 E: 1e7 degE7 = 1 deg = radians(1) x 6 378 137 = 111 319.491 m, north and
    # east alike (cos 0 = 1); -2e7 degE7 is twice that to the west
    n, e = global_to_local(10_000_000, -20_000_000, (0.0, 0.0, 0.0))
    assert (n, e) == (pytest.approx(111319.4908, abs=1e-3), pytest.approx(-222638.9816, abs=1e-3))


# --- what is refused --------------------------------------------------------------------------------


def test_acceleration_not_ignored_refuses_even_a_position() -> None:
    # send_acc_ignore_must_be_set_message, then return: no target at all
    got = setpoint("local", MASK_VEL_IGNORE | MASK_YAW_IGNORE | MASK_YAW_RATE_IGNORE, 5.0, 6.0)
    assert isinstance(got, str)


def test_a_not_a_number_in_an_ignored_field_is_no_matter() -> None:
    # vx NaN but velocity ignored: a plain location target; NaN in the position it uses: refused
    assert setpoint("local", POSITION_ONLY, 5.0, 6.0, vx=math.nan).kind == "location"
    assert isinstance(setpoint("local", POSITION_ONLY, math.nan, 6.0), str)
    assert isinstance(setpoint("local", VELOCITY_ONLY, vy=math.nan), str)


def test_both_yaw_and_yaw_rate_set_nothing() -> None:
    # no branch of the handler takes yaw and yaw rate together, with or without velocity
    assert isinstance(setpoint("local", MASK_POS_IGNORE | MASK_VEL_IGNORE | MASK_ACC_IGNORE, yaw=1.0), str)
    assert isinstance(setpoint("local", MASK_POS_IGNORE | MASK_ACC_IGNORE, vx=1.0, yaw=1.0), str)


def test_a_setpoint_with_every_field_ignored_sets_nothing() -> None:
    assert isinstance(setpoint("local", POSITION_ONLY | MASK_POS_IGNORE), str)


# --- velocity, heading, turn rate ----------------------------------------------------------------


def test_a_velocity_alone_is_a_heading_and_a_speed_capped_at_wp_speed() -> None:
    # (vx, vy) = (1, 1): speed sqrt 2 = 1.414 (under WP_SPEED 2), heading atan2(1, 1) = 45 deg
    got = setpoint("local", VELOCITY_ONLY, vx=1.0, vy=1.0)
    assert isinstance(got, GuidedTarget)
    assert (got.kind, got.speed_mps, got.heading_rad) == ("heading", pytest.approx(math.sqrt(2)), math.pi / 4)
    assert got.times_out
    # (3, 4): 5 m/s, capped at 2; heading atan2(4, 3) = 0.9273 rad
    got = setpoint("local", VELOCITY_ONLY, vx=3.0, vy=4.0)
    assert (got.speed_mps, got.heading_rad) == (2.0, pytest.approx(0.927295, abs=1e-6))


def test_a_velocity_alone_backwards_is_a_heading_the_other_way_at_a_forward_speed() -> None:
    # speed_dir stays 1 without a yaw or yaw rate: (-1, 0) is heading 180 deg at +1 m/s
    got = setpoint("local", VELOCITY_ONLY, vx=-1.0)
    assert isinstance(got, GuidedTarget)
    assert (got.kind, got.speed_mps, abs(got.heading_rad)) == ("heading", 1.0, pytest.approx(math.pi))


def test_a_body_velocity_is_turned_by_the_heading() -> None:
    # body frame: atan2(0, 1) = 0 plus the vehicle's 90 deg: heading east
    got = setpoint("body", VELOCITY_ONLY, vx=1.5)
    assert (got.kind, got.speed_mps, got.heading_rad) == ("heading", 1.5, pytest.approx(math.pi / 2))
    # body frame: 90 deg + 135 deg (vy > 0, vx < 0) = 225 deg, wrapped to -135 deg
    got = setpoint("body", VELOCITY_ONLY, vx=-1.0, vy=1.0)
    assert got.heading_rad == pytest.approx(-3 * math.pi / 4)


def test_a_velocity_with_a_turn_rate_is_a_rate_target_reversed_by_a_negative_vx() -> None:
    # speed sqrt(0.36 + 0.64) = 1; vx < 0 with a yaw rate: speed_dir -1
    got = setpoint("local", VELOCITY_AND_RATE, vx=0.6, vy=0.8, yaw_rate=0.3)
    assert got == GuidedTarget("rate", 7.0, speed_mps=pytest.approx(1.0), yaw_rate_radps=0.3)
    got = setpoint("local", VELOCITY_AND_RATE, vx=-0.6, vy=0.8, yaw_rate=-0.3)
    assert got == GuidedTarget("rate", 7.0, speed_mps=pytest.approx(-1.0), yaw_rate_radps=-0.3)


def test_a_velocity_with_a_heading_takes_the_heading_and_is_reversed_by_a_negative_vx() -> None:
    # the yaw (1 rad) replaces the velocity's direction; speed 1, backwards for vx = -0.6
    got = setpoint("local", VELOCITY_AND_YAW, vx=-0.6, vy=0.8, yaw=1.0)
    assert got == GuidedTarget("heading", 7.0, speed_mps=pytest.approx(-1.0), heading_rad=pytest.approx(1.0))


def test_a_velocity_with_vx_0_and_a_turn_rate_is_forward() -> None:
    # is_negative(0) is false: (0, 1) with a yaw rate is +1 m/s
    got = setpoint("local", VELOCITY_AND_RATE, vx=0.0, vy=1.0, yaw_rate=0.2)
    assert got == GuidedTarget("rate", 7.0, speed_mps=1.0, yaw_rate_radps=0.2)


def test_a_velocity_a_hair_below_zero_is_still_forward() -> None:
    # Rover reverses only for is_negative(vx), vx <= -FLT_EPSILON (-1.19e-7, AP_Math.h);
    # vx = -1e-9 is not negative to it: forward at |(vx, 1)| = 1 m/s (lfctl reversed for any
    # vx < 0 until December 2026).
    got = setpoint("local", VELOCITY_AND_RATE, vx=-1e-9, vy=1.0, yaw_rate=0.2)
    assert got.speed_mps == pytest.approx(1.0)


def test_a_heading_alone_is_a_heading_at_rest_and_a_body_one_is_turned() -> None:
    # yaw 0.5 rad, no velocity: heading 0.5, speed 0; in the body frame 0.5 + pi/2
    assert setpoint("local", YAW_ONLY, yaw=0.5) == GuidedTarget("heading", 7.0, speed_mps=0.0, heading_rad=0.5)
    got = setpoint("body", YAW_ONLY, yaw=0.5)
    assert got.heading_rad == pytest.approx(0.5 + math.pi / 2)


def test_a_turn_rate_alone_turns_on_the_spot() -> None:
    assert setpoint("local", RATE_ONLY, yaw_rate=-0.4) == GuidedTarget("rate", 7.0, speed_mps=0.0, yaw_rate_radps=-0.4)


# --- SET_ATTITUDE_TARGET ---------------------------------------------------------------------------


def test_an_attitude_target_needs_its_thrust() -> None:
    assert isinstance(attitude_target(1.0, ATT_THROTTLE_IGNORE, (1.0, 0.0, 0.0, 0.0), 0.0, 0.5, 2.0), str)


def test_thrust_is_a_share_of_wp_speed_clipped_to_plus_minus_one() -> None:
    # thrust 0.25 of 2 m/s: 0.5 m/s; thrust -1.5 clipped to -1: -2 m/s; yaw rate as given
    assert attitude_target(1.0, 0, (1.0, 0.0, 0.0, 0.0), 0.3, 0.25, 2.0) == GuidedTarget(
        "rate", 1.0, speed_mps=0.5, yaw_rate_radps=0.3
    )
    assert attitude_target(1.0, 0, (1.0, 0.0, 0.0, 0.0), 0.0, -1.5, 2.0).speed_mps == -2.0
    assert attitude_target(1.0, 0, (1.0, 0.0, 0.0, 0.0), 0.0, 1.5, 2.0).speed_mps == 2.0


def test_with_the_yaw_rate_ignored_the_quaternions_yaw_is_the_heading() -> None:
    # q = (cos 45 deg, 0, 0, sin 45 deg): a 90 deg yaw; atan2(2 (w z + x y), 1 - 2 (y^2 + z^2))
    # = atan2(2 * 0.5, 1 - 2 * 0.5) = atan2(1, 0) = pi/2
    c = math.sqrt(0.5)
    got = attitude_target(1.0, ATT_YAW_RATE_IGNORE, (c, 0.0, 0.0, c), 9.0, 0.5, 2.0)
    assert isinstance(got, GuidedTarget)
    assert (got.kind, got.t_s, got.speed_mps, got.heading_rad) == ("heading", 1.0, 1.0, pytest.approx(math.pi / 2))
    # (cos 60, 0, 0, -sin 60): a -120 deg yaw: atan2(2 * -0.433, 1 - 1.5) = atan2(-0.866, -0.5)
    got = attitude_target(1.0, ATT_YAW_RATE_IGNORE, (0.5, 0.0, 0.0, -math.sqrt(0.75)), 0.0, 0.5, 2.0)
    assert got.heading_rad == pytest.approx(-2 * math.pi / 3)


def test_an_attitude_target_with_a_not_a_number_is_refused() -> None:
    assert isinstance(attitude_target(1.0, 0, (1.0, 0.0, 0.0, 0.0), math.nan, 0.5, 2.0), str)
    assert isinstance(attitude_target(1.0, 0, (1.0, 0.0, 0.0, 0.0), 0.0, math.nan, 2.0), str)


@pytest.mark.parametrize(
    ("q", "heading"),
    [
        ((1.0, 0.0, 0.0, 0.0), 0.0),  # no rotation: atan2(0, 1)
        ((0.0, 1.0, 0.0, 0.0), 0.0),  # rolled over: atan2(0, 1 - 0)
        ((0.0, 0.0, 1.0, 0.0), math.pi),  # pitched over: atan2(0, 1 - 2)
        ((0.0, 0.0, 0.0, 1.0), math.pi),  # turned 180 deg: atan2(0, 1 - 2)
        ((0.5, 0.5, 0.5, 0.5), math.pi / 2),  # atan2(2 (0.25 + 0.25), 1 - 2 (0.25 + 0.25)) = atan2(1, 0)
    ],
)
def test_the_heading_is_the_quaternions_euler_yaw(q: tuple, heading: float) -> None:
    # Quaternion::get_euler_yaw: atan2(2 (q1 q4 + q2 q3), 1 - 2 (q3^2 + q4^2))
    got = attitude_target(1.0, ATT_YAW_RATE_IGNORE, q, 0.0, 0.5, 2.0)
    assert isinstance(got, GuidedTarget)
    assert abs(got.heading_rad) == pytest.approx(heading)


def test_a_quaternion_with_a_not_a_number_is_refused() -> None:
    assert isinstance(attitude_target(1.0, ATT_YAW_RATE_IGNORE, (math.nan, 0.0, 0.0, 1.0), 0.0, 0.5, 2.0), str)


def test_a_zero_quaternion_is_heading_north() -> None:
    # Rover's handle_set_attitude_target takes Quaternion(0, 0, 0, 0).get_euler_yaw() =
    # atan2(0, 1 - 0) = 0 as it is: heading north at the thrust's speed, 0.5 x 2 m/s (lfctl
    # refused a quaternion of norm under 1e-6 until December 2026).
    got = attitude_target(1.0, ATT_YAW_RATE_IGNORE, (0.0, 0.0, 0.0, 0.0), 0.0, 0.5, 2.0)
    assert got == GuidedTarget("heading", 1.0, speed_mps=1.0, heading_rad=0.0)
