"""Frame and unit conventions, stated once.

- World: local NED (x north, y east, z down), metres. Heading (yaw) from north, positive
  clockwise seen from above, in (-pi, pi].
- Body: FRD (x forward, y right, z down). A positive yaw rate turns right.
- Camera: OpenCV (x right, y down, z forward).
- Bearings: positive clockwise seen from above (target to the right is positive).
- Inside lfctl everything is SI (m, s, rad); degrees appear only in TOML keys ending in
  ``_deg`` and in MAVLink fields, converted at that edge.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "FLT_EPSILON",
    "body_to_ned",
    "geodetic_to_ned",
    "ned_to_body",
    "ned_to_geodetic",
    "on_earth",
    "range_bearing",
    "rot_z",
    "wrap_pi",
]

EARTH_RADIUS_M = 6378137.0  # WGS-84 equatorial radius
#: a float32's epsilon: ArduPilot's AP_Math compares against it (``is_positive(x)`` is
#: ``x >= FLT_EPSILON``, ``is_negative(x)`` is ``x <= -FLT_EPSILON``, ``is_zero`` within it)
FLT_EPSILON = 1.1920928955078125e-07
HALF_EARTH_M = math.pi * EARTH_RADIUS_M  # no place is farther along the ground, m


def wrap_pi(angle_rad: float) -> float:
    """Wrap an angle to (-pi, pi].

    Parameters
    ----------
    angle_rad : float
        Any finite angle in radians.
    """
    wrapped = math.fmod(angle_rad + math.pi, 2.0 * math.pi)
    if wrapped <= 0.0:
        wrapped += 2.0 * math.pi
    return wrapped - math.pi


def ned_to_body(north_m: float, east_m: float, yaw_rad: float) -> tuple[float, float]:
    """Rotate a horizontal NED vector into body FRD (forward, right).

    Parameters
    ----------
    north_m, east_m : float
        The vector in NED, m.
    yaw_rad : float
        The body's heading, rad.
    """
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return c * north_m + s * east_m, -s * north_m + c * east_m


def body_to_ned(forward_m: float, right_m: float, yaw_rad: float) -> tuple[float, float]:
    """Rotate a horizontal body FRD vector (forward, right) into NED (north, east).

    Parameters
    ----------
    forward_m, right_m : float
        The vector in the body frame, m.
    yaw_rad : float
        The body's heading, rad.
    """
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return c * forward_m - s * right_m, s * forward_m + c * right_m


def range_bearing(
    from_north_m: float, from_east_m: float, from_yaw_rad: float, to_north_m: float, to_east_m: float
) -> tuple[float, float]:
    """Range (m) and body-relative bearing (rad, clockwise positive) from one pose to a point.

    Parameters
    ----------
    from_north_m, from_east_m : float
        The observer's position, NED, m.
    from_yaw_rad : float
        The observer's heading, rad.
    to_north_m, to_east_m : float
        The point's position, NED, m.
    """
    dn, de = to_north_m - from_north_m, to_east_m - from_east_m
    return math.hypot(dn, de), wrap_pi(math.atan2(de, dn) - from_yaw_rad)


def geodetic_to_ned(
    lat_deg: float, lon_deg: float, alt_m: float, home_lat_deg: float, home_lon_deg: float, home_alt_m: float
) -> tuple[float, float, float]:
    """Local tangent-plane NED (m) of a geodetic point relative to home (equirectangular).

    Accurate to a few millimetres over the hundreds of metres a ground-robot mission spans.

    Parameters
    ----------
    lat_deg, lon_deg : float
        The point's latitude and longitude, degrees.
    alt_m : float
        The point's altitude, m (same datum as ``home_alt_m``).
    home_lat_deg, home_lon_deg : float
        Home (the local frame's origin) latitude and longitude, degrees.
    home_alt_m : float
        Home altitude, m (the local frame's z = 0).
    """
    dlat = math.radians(lat_deg - home_lat_deg)
    dlon = math.radians((lon_deg - home_lon_deg + 180.0) % 360.0 - 180.0)  # the short way round
    north = dlat * EARTH_RADIUS_M
    east = dlon * EARTH_RADIUS_M * _longitude_scale(home_lat_deg)
    return north, east, home_alt_m - alt_m


def ned_to_geodetic(
    north_m: float, east_m: float, down_m: float, home_lat_deg: float, home_lon_deg: float, home_alt_m: float
) -> tuple[float, float, float]:
    """Inverse of :func:`geodetic_to_ned`: (lat_deg, lon_deg, alt_m), the longitude wrapped
    into [-180, 180) (east of the 180th meridian is west of it). The latitude is not limited:
    past +-90 is no place (:func:`on_earth`).

    Parameters
    ----------
    north_m, east_m, down_m : float
        The point in the local NED frame, m.
    home_lat_deg, home_lon_deg : float
        Home (the local frame's origin) latitude and longitude, degrees.
    home_alt_m : float
        Home altitude, m (the local frame's z = 0).
    """
    lat = home_lat_deg + math.degrees(north_m / EARTH_RADIUS_M)
    lon = home_lon_deg + math.degrees(east_m / (EARTH_RADIUS_M * _longitude_scale(home_lat_deg)))
    return lat, (lon + 180.0) % 360.0 - 180.0, home_alt_m - down_m


def _longitude_scale(lat_deg: float) -> float:
    """Metres east per metre of the equator's arc at this latitude: cos(lat), at least 0.01
    (as ArduPilot keeps it, so a home at a pole still has an east)."""
    return max(math.cos(math.radians(lat_deg)), 0.01)


def on_earth(lat_deg: float, lon_deg: float) -> bool:
    """Whether a latitude and longitude name a place: both numbers, the latitude within +-90
    and the longitude within +-180.

    Parameters
    ----------
    lat_deg, lon_deg : float
        Latitude and longitude, degrees.
    """
    return -90.0 <= lat_deg <= 90.0 and -180.0 <= lon_deg <= 180.0


def rot_z(yaw_rad: float) -> np.ndarray:
    """3x3 rotation about z (NED down): body-to-NED for a vehicle with this yaw.

    Parameters
    ----------
    yaw_rad : float
        The heading, rad.
    """
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
