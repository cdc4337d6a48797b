"""Frame conventions and angle wrapping."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from lfctl.frames import body_to_ned, geodetic_to_ned, ned_to_body, ned_to_geodetic, range_bearing, wrap_pi


@given(st.floats(-1e6, 1e6, allow_nan=False))
def test_wrap_pi_lands_in_half_open_interval(angle: float) -> None:
    w = wrap_pi(angle)
    assert -math.pi < w <= math.pi
    assert math.isclose(math.sin(w), math.sin(angle), abs_tol=1e-6) and math.isclose(
        math.cos(w), math.cos(angle), abs_tol=1e-6
    )


def test_wrap_pi_edges() -> None:
    assert wrap_pi(math.pi) == pytest.approx(math.pi)
    assert wrap_pi(-math.pi) == pytest.approx(math.pi)
    assert wrap_pi(3 * math.pi / 2) == pytest.approx(-math.pi / 2)


def test_bearing_is_clockwise_positive() -> None:
    # facing north, a target to the east is 90 deg to the right
    rng, brg = range_bearing(0.0, 0.0, 0.0, 0.0, 2.0)
    assert rng == pytest.approx(2.0) and brg == pytest.approx(math.pi / 2)


@given(st.floats(-100, 100), st.floats(-100, 100), st.floats(-math.pi, math.pi))
def test_body_ned_round_trip(n: float, e: float, yaw: float) -> None:
    f, r = ned_to_body(n, e, yaw)
    n2, e2 = body_to_ned(f, r, yaw)
    assert n2 == pytest.approx(n, abs=1e-9) and e2 == pytest.approx(e, abs=1e-9)


def test_geodetic_round_trip_and_scale() -> None:
    home = (12.9716, 77.5946, 900.0)  # Bengaluru
    lat, lon, alt = ned_to_geodetic(100.0, -50.0, -2.0, *home)
    n, e, d = geodetic_to_ned(lat, lon, alt, *home)
    assert (n, e, d) == pytest.approx((100.0, -50.0, -2.0), abs=1e-6)
    assert lat - home[0] == pytest.approx(100.0 / 111319.49, rel=1e-4)


def test_the_180th_meridian_is_crossed_the_short_way_and_a_pole_still_has_an_east() -> None:
    from lfctl.frames import on_earth

    home = (-16.8, 179.9995, 10.0)  # Taveuni, Fiji
    lat, lon, _ = ned_to_geodetic(0.0, 100.0, 0.0, *home)
    # 100 m east is 0.000938 deg of longitude there (100 / (6378137 cos 16.8 deg) rad): past 180
    assert lat == pytest.approx(-16.8) and lon == pytest.approx(-180.0 + 0.000439, abs=2e-6)
    assert geodetic_to_ned(lat, lon, 10.0, *home)[:2] == pytest.approx((0.0, 100.0), abs=1e-6)
    # at the pole cos(lat) = 0: the scale is held at 0.01 (5 km east: 4.49 deg of longitude)
    assert ned_to_geodetic(0.0, 5000.0, 0.0, 90.0, 10.0, 0.0)[1] == pytest.approx(
        10.0 + math.degrees(5000.0 / 63781.37)
    )
    assert on_earth(90.0, -180.0) and not on_earth(90.0001, 0.0) and not on_earth(0.0, 180.0001)
    assert not on_earth(math.nan, 0.0) and not on_earth(0.0, math.inf)


def test_rot_z_takes_a_body_vector_into_ned() -> None:
    from lfctl.frames import rot_z

    # heading east (90 deg): forward is east, right is south, down stays down
    r = rot_z(math.pi / 2)
    assert r @ [1.0, 0.0, 0.0] == pytest.approx([0.0, 1.0, 0.0], abs=1e-12)
    assert r @ [0.0, 1.0, 0.0] == pytest.approx([-1.0, 0.0, 0.0], abs=1e-12)
    assert r @ [0.0, 0.0, 1.0] == pytest.approx([0.0, 0.0, 1.0], abs=1e-12)
    # the same turn as body_to_ned at any heading: 30 deg, (2, 1) m forward and right
    assert (rot_z(math.radians(30)) @ [2.0, 1.0, 0.0])[:2] == pytest.approx(body_to_ned(2.0, 1.0, math.radians(30)))
