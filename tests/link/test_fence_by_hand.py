"""The geofence as ArduPilot Rover keeps it (AC_Fence, AC_PolyFence_loader), worked by hand:
the names of the fences in Rover's texts, the checks a fence upload meets, the shapes a fence
list becomes and which of them a vehicle breaches.

Shapes are given in local metres (north, east) from home where the geometry is the point;
where the items themselves are the point, home is at 0 N 0 E, where 1e-4 degree is
radians(1e-4) * 6 378 137 m = 11.132 m both north and east (cos 0 = 1)."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.link.fence import FENCE_TYPE_CIRCLE, FENCE_TYPE_POLYGON, Fence, fence_names, validate_fence
from lfctl.link.mission import (
    CIRCLE_EXCLUSION,
    CIRCLE_INCLUSION,
    MAX_VERTICES,
    POLYGON_EXCLUSION,
    POLYGON_INCLUSION,
    RETURN_POINT,
    MissionItem,
)

ERROR = mav.MAV_MISSION_ERROR
HOME = (0.0, 0.0, 0.0)
M_PER_1E4_DEG = math.radians(1e-4) * 6378137.0  # 11.132 m
BOTH = FENCE_TYPE_CIRCLE | FENCE_TYPE_POLYGON


def item(command: int, param1: float = 0.0, lat_e7: int = 0, lon_e7: int = 0) -> MissionItem:
    return MissionItem(0, mav.MAV_FRAME_GLOBAL, command, param1, x=lat_e7, y=lon_e7)


def square(command: int, n0: int, e0: int, side: int) -> list[MissionItem]:
    """A square of 4 vertices, its south-west corner at (n0, e0), in 1e-4 degree steps."""
    corners = [(n0, e0), (n0 + side, e0), (n0 + side, e0 + side), (n0, e0 + side)]
    return [item(command, 4, n * 1000, e * 1000) for n, e in corners]


# --- fence_names: AC_Fence::get_fence_names ---------------------------------------------------


def test_no_fence_has_no_name() -> None:
    # get_fence_names returns at once for fences == 0: nothing is printed
    assert fence_names(0) == ""


def test_three_or_four_fences_are_named_with_commas_and_the_last_after_and() -> None:
    # Rover walks the bits from 1 up: ", " before each name but the last set bit, " and "
    # before that one, then " fences" (plural for more than one)
    assert fence_names(1 | 2 | 4) == "Max Alt, Circle and Polygon fences"
    assert fence_names(1 | 2 | 4 | 8) == "Max Alt, Circle, Polygon and Min Alt fences"


# --- validate_fence: AC_PolyFence_loader::validate_fence --------------------------------------


def test_one_return_point_is_allowed_and_a_second_is_not() -> None:
    # seen_return_point starts false: the first return point is fine, the second is item 1
    assert validate_fence([item(RETURN_POINT)]) is None
    assert validate_fence([item(RETURN_POINT), item(RETURN_POINT)]) == (1, ERROR, "Multiple return points")


def test_a_vertex_count_that_is_not_a_number_is_count_0() -> None:
    # lfctl reads a NaN param1 as a count of 0 (not a crash): "Invalid vertex count (0)"
    assert validate_fence([item(POLYGON_INCLUSION, math.nan)]) == (0, ERROR, "Invalid vertex count (0)")


def test_a_polygon_of_max_vertices_is_accepted_and_one_more_is_not() -> None:
    # lfctl's own limit (MAX_VERTICES = 100, about what ArduPilot's fence storage holds):
    # 3 <= 100 <= 100 passes; 101 is "Invalid vertex count (101)" at its first vertex
    full = [item(POLYGON_EXCLUSION, MAX_VERTICES, k, k * k) for k in range(MAX_VERTICES)]
    assert validate_fence(full) is None
    over = [item(POLYGON_EXCLUSION, MAX_VERTICES + 1)] * (MAX_VERTICES + 1)
    assert validate_fence(over) == (0, ERROR, f"Invalid vertex count ({MAX_VERTICES + 1})")


def test_a_circle_of_half_a_metre_is_allowed_and_one_of_0_m_is_not() -> None:
    # is_positive(0.5): 0.5 >= FLT_EPSILON; is_positive(0): no -> "Non-positive circle radius"
    assert validate_fence([item(CIRCLE_INCLUSION, 0.5)]) is None
    assert validate_fence([item(CIRCLE_EXCLUSION, 0.5), item(CIRCLE_EXCLUSION, 0.0)]) == (
        1,
        ERROR,
        "Non-positive circle radius",
    )


def test_a_circle_radius_below_a_floats_epsilon_is_not_positive() -> None:
    # ArduPilot's validate_fence asks is_positive(radius), which is radius >= FLT_EPSILON
    # (1.19e-7, AP_Math.h): 1e-8 m is not positive to it (lfctl took it until December 2026).
    assert validate_fence([item(CIRCLE_INCLUSION, 1e-8)]) == (0, ERROR, "Non-positive circle radius")


def test_a_circle_north_of_the_pole_is_a_bad_lat_or_lon() -> None:
    # 900000001 degE7 = 90.0000001 deg: check_latlng fails, "Bad lat or lon", at item 1
    ok = item(CIRCLE_INCLUSION, 10.0, 900000000, 0)
    bad = item(CIRCLE_INCLUSION, 10.0, 900000001, 0)
    assert validate_fence([ok]) is None
    assert validate_fence([ok, bad]) == (1, ERROR, "Bad lat or lon")


# --- Fence.from_items ---------------------------------------------------------------------------


def test_an_exclusion_polygon_and_circle_are_kept_as_exclusions() -> None:
    # a keep-out square 1e-4 deg on a side from (1e-4 N, 1e-4 E), and a keep-out circle of
    # 2 m around (0, 3e-4 deg E): none is a keep-in shape
    f = Fence.from_items([*square(POLYGON_EXCLUSION, 1, 1, 1), item(CIRCLE_EXCLUSION, 2.0, 0, 3000)], HOME)
    assert (len(f.inclusion_polygons), len(f.exclusion_polygons)) == (0, 1)
    assert (len(f.inclusion_circles), len(f.exclusion_circles)) == (0, 1)
    n, e, r = f.exclusion_circles[0]
    assert (n, e, r) == pytest.approx((0.0, 3 * M_PER_1E4_DEG, 2.0))  # 33.40 m east


def test_the_shapes_after_a_polygon_are_read_too() -> None:
    # square (4 items), then two circles: after the polygon the reading goes on at item 4,
    # and on one item at a time after each circle
    items = [*square(POLYGON_INCLUSION, 0, 0, 2), item(CIRCLE_INCLUSION, 5.0), item(CIRCLE_INCLUSION, 7.0)]
    f = Fence.from_items(items, HOME)
    assert len(f.inclusion_polygons) == 1
    assert [r for *_, r in f.inclusion_circles] == [5.0, 7.0]
    corners = [(0, 0), (2, 0), (2, 2), (0, 2)]
    got = [x for vertex in f.inclusion_polygons[0] for x in vertex]
    assert got == pytest.approx([x * M_PER_1E4_DEG for corner in corners for x in corner])


@pytest.mark.timeout(10)  # (reading a polygon's count as the next index loops for ever)
def test_a_polygon_after_a_circle_starts_at_its_own_item() -> None:
    # circle (item 0), then a square at items 1-4: the next item after the square is 5 (the
    # end), so one circle and one 4-vertex polygon
    f = Fence.from_items([item(CIRCLE_INCLUSION, 5.0), *square(POLYGON_INCLUSION, 0, 0, 2)], HOME)
    assert len(f.inclusion_circles) == 1
    assert [len(p) for p in f.inclusion_polygons] == [4]


def test_the_return_point_is_stored_in_local_metres() -> None:
    # 2e-4 deg N, 1e-4 deg E: (22.26, 11.13) m
    f = Fence.from_items([item(RETURN_POINT, 0.0, 2000, 1000)], HOME)
    assert f.return_point == pytest.approx((2 * M_PER_1E4_DEG, M_PER_1E4_DEG))
    assert f.empty  # a return point is no shape


# --- Fence.breaches: the circle around home (AC_Fence::check_fence_circle) ----------------------


def test_the_home_circle_is_measured_from_home_north_and_east() -> None:
    # home at (0, 10), FENCE_RADIUS 5: (0, 14) is 4 m from home (in); (0, 16) is 6 m (out);
    # (3, 10) and (6, 10) likewise along north
    f = Fence()
    assert f.breaches(0.0, 14.0, FENCE_TYPE_CIRCLE, 5.0, (0.0, 10.0)) == 0
    assert f.breaches(0.0, 16.0, FENCE_TYPE_CIRCLE, 5.0, (0.0, 10.0)) == FENCE_TYPE_CIRCLE
    assert f.breaches(3.0, 10.0, FENCE_TYPE_CIRCLE, 5.0, (0.0, 10.0)) == 0
    assert f.breaches(6.0, 10.0, FENCE_TYPE_CIRCLE, 5.0, (0.0, 10.0)) == FENCE_TYPE_CIRCLE


def test_the_home_circle_counts_only_when_its_bit_is_set() -> None:
    # 1000 m out with FENCE_RADIUS 300: a breach with FENCE_TYPE 2, none with FENCE_TYPE 4
    f = Fence()
    assert f.breaches(1000.0, 0.0, FENCE_TYPE_CIRCLE, 300.0) == FENCE_TYPE_CIRCLE
    assert f.breaches(1000.0, 0.0, FENCE_TYPE_POLYGON, 300.0) == 0


def test_on_the_home_circle_is_a_breach() -> None:
    # check_fence_circle breaches at _home_distance >= _circle_radius (AC_Fence.cpp); (3, 4) is
    # hypot = 5.0 m exactly from home, FENCE_RADIUS 5: a breach (lfctl's was > until December 2026).
    assert Fence().breaches(3.0, 4.0, FENCE_TYPE_CIRCLE, 5.0) == FENCE_TYPE_CIRCLE


def test_a_destination_on_the_home_circle_is_within_it() -> None:
    # check_destination_within_fence refuses a target only past the radius (distance > radius,
    # AC_Fence.cpp): a GUIDED target or a rally point at (3, 4), 5.0 m from home with
    # FENCE_RADIUS 5, is allowed, where a vehicle standing there breaches; at (3, 4.001), past it
    assert Fence().breaches(3.0, 4.0, FENCE_TYPE_CIRCLE, 5.0, destination=True) == 0
    assert Fence().breaches(3.0, 4.001, FENCE_TYPE_CIRCLE, 5.0, destination=True) == FENCE_TYPE_CIRCLE


# --- Fence.breaches: the stored shapes (AC_PolyFence_loader::breached) --------------------------


def test_a_stored_shape_counts_only_when_the_polygon_bit_is_set() -> None:
    # 1000 m north of a 10 m keep-in square: a polygon breach with FENCE_TYPE 4 only
    f = Fence(inclusion_polygons=[[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]])
    assert f.breaches(1000.0, 5.0, FENCE_TYPE_POLYGON, 1e6) == FENCE_TYPE_POLYGON
    assert f.breaches(1000.0, 5.0, FENCE_TYPE_CIRCLE, 1e6) == 0


def test_inside_an_exclusion_polygon_is_a_breach_and_outside_is_not() -> None:
    # keep-out square north 10..20, east -5..5: (15, 0) is inside it, home (0, 0) is not
    f = Fence(exclusion_polygons=[[(10.0, -5.0), (20.0, -5.0), (20.0, 5.0), (10.0, 5.0)]])
    assert f.breaches(15.0, 0.0, BOTH, 1e6) == FENCE_TYPE_POLYGON
    assert f.breaches(0.0, 0.0, BOTH, 1e6) == 0


def test_an_exclusion_circle_breaches_strictly_inside_it() -> None:
    # keep-out circle at (20, 10), radius 5 (breached: distance < radius):
    # (22, 12): sqrt(4 + 4) = 2.83 m in; (23, 14): hypot(3, 4) = 5.0 exactly, not in;
    # (0, 10): 20 m due south; (20, 30): 20 m due east
    f = Fence(exclusion_circles=[(20.0, 10.0, 5.0)])
    assert f.breaches(22.0, 12.0, BOTH, 1e6) == FENCE_TYPE_POLYGON
    assert f.breaches(23.0, 14.0, BOTH, 1e6) == 0
    assert f.breaches(0.0, 10.0, BOTH, 1e6) == 0
    assert f.breaches(20.0, 30.0, BOTH, 1e6) == 0


def test_an_inclusion_circle_breaches_strictly_outside_it() -> None:
    # keep-in circle at (20, 10), radius 5 (breached: distance > radius):
    # (22, 12): 2.83 m, in; (23, 14): 5.0 exactly, still in; (0, 10) and (20, 30): 20 m, out
    f = Fence(inclusion_circles=[(20.0, 10.0, 5.0)])
    assert f.breaches(22.0, 12.0, BOTH, 1e6) == 0
    assert f.breaches(23.0, 14.0, BOTH, 1e6) == 0
    assert f.breaches(0.0, 10.0, BOTH, 1e6) == FENCE_TYPE_POLYGON
    assert f.breaches(20.0, 30.0, BOTH, 1e6) == FENCE_TYPE_POLYGON


@pytest.mark.parametrize(
    ("north", "east", "inside"),
    [
        # the diamond |n - 20| + |e - 10| <= 10 (vertices (20, 0), (30, 10), (20, 20), (10, 10))
        (20.0, 10.0, True),  # its centre: 0
        (20.0, 1.0, True),  # 0 + 9 = 9
        (26.0, 13.0, True),  # 6 + 3 = 9
        (14.0, 12.0, True),  # 6 + 2 = 8
        (12.0, 4.0, False),  # 8 + 6 = 14
        (28.0, 17.0, False),  # 8 + 7 = 15
        (5.0, 10.0, False),  # 15 + 0: due south of it
        (35.0, 10.0, False),  # 15 + 0: due north of it
    ],
)
def test_a_keep_in_diamond_away_from_home(north: float, east: float, inside: bool) -> None:
    # ArduPilot's Polygon_outside: for each side whose ends lie either side of the point's
    # east, a crossing north of the point flips it (even-odd)
    f = Fence(inclusion_polygons=[[(20.0, 0.0), (30.0, 10.0), (20.0, 20.0), (10.0, 10.0)]])
    assert f.breaches(north, east, FENCE_TYPE_POLYGON, 0.0) == (0 if inside else FENCE_TYPE_POLYGON)


def test_on_a_keep_in_squares_south_side_is_in_and_on_its_north_side_is_out() -> None:
    # square north 0..10, east 0..10; Polygon_outside flips on a side only when the side's
    # crossing is strictly north of the point: (0, 5) has the north side's crossing (10) north
    # of it, one flip, in; (10, 5) has none strictly north (10 < 10 is false), out
    f = Fence(inclusion_polygons=[[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]])
    assert f.breaches(0.0, 5.0, FENCE_TYPE_POLYGON, 0.0) == 0
    assert f.breaches(10.0, 5.0, FENCE_TYPE_POLYGON, 0.0) == FENCE_TYPE_POLYGON


def test_in_line_with_a_north_south_side_beyond_it_is_outside() -> None:
    # square north 0..10, east 0..10; (20, 0) is due north of its west side (east 0 at both
    # ends): that side has no end east of 0 and is skipped, the others have no crossing north
    # of 20: out, a breach (and no division by the side's zero east extent)
    f = Fence(inclusion_polygons=[[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]])
    assert f.breaches(20.0, 0.0, FENCE_TYPE_POLYGON, 0.0) == FENCE_TYPE_POLYGON
    assert f.breaches(20.0, 10.0, FENCE_TYPE_POLYGON, 0.0) == FENCE_TYPE_POLYGON
