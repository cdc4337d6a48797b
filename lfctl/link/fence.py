"""Geofence and rally points as ArduPilot Rover keeps them (AC_Fence, AP_Rally), from the items
of the FENCE and RALLY mission types.

Fence items: NAV_FENCE_POLYGON_VERTEX_INCLUSION / _EXCLUSION (param1: the polygon's vertex
count, one item per vertex), NAV_FENCE_CIRCLE_INCLUSION / _EXCLUSION (param1: radius, m) and
NAV_FENCE_RETURN_POINT. With ``FENCE_TYPE`` bit 2 the vehicle must also stay within
``FENCE_RADIUS`` of home. Rally items: NAV_RALLY_POINT. Everything is turned into local NED
metres from home once, when a list is stored. Pure: positions in, breaches out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.frames import FLT_EPSILON, geodetic_to_ned, on_earth
from lfctl.link.mission import (
    CIRCLE_EXCLUSION,
    CIRCLE_INCLUSION,
    MAX_VERTICES,
    POLYGON_EXCLUSION,
    POLYGON_INCLUSION,
    RALLY_POINT,
    RETURN_POINT,
    MissionItem,
)

__all__ = [
    "FENCE_COMMANDS",
    "FENCE_TYPE_CIRCLE",
    "FENCE_TYPE_POLYGON",
    "RALLY_COMMANDS",
    "Fence",
    "breach_name",
    "fence_names",
    "rally_points",
    "validate_fence",
]

FENCE_COMMANDS = {POLYGON_INCLUSION, POLYGON_EXCLUSION, CIRCLE_INCLUSION, CIRCLE_EXCLUSION, RETURN_POINT}
RALLY_COMMANDS = {RALLY_POINT}
#: FENCE_TYPE bits a rover uses
FENCE_TYPE_CIRCLE = 2
FENCE_TYPE_POLYGON = 4
#: FENCE_TYPE's floor (Min Alt), which FENCE_ENABLE does not turn on, and all four fences
FENCE_TYPE_ALT_MIN = 8
FENCE_ALL = 0x0F
#: every FENCE_TYPE bit, in AC_Fence's order (max altitude, circle, polygon, min altitude), with
#: the name Rover gives each in its texts (``AC_Fence::get_fence_names``)
FENCE_NAMES = ((1, "Max Alt"), (FENCE_TYPE_CIRCLE, "Circle"), (FENCE_TYPE_POLYGON, "Polygon"), (8, "Min Alt"))


def fence_names(fences: int) -> str:
    """The fences of a FENCE_TYPE bitmask as Rover names them: "Polygon fence", "Circle and
    Polygon fences", "Max Alt, Circle and Polygon fences" (``AC_Fence::get_fence_names``);
    empty for none.

    Parameters
    ----------
    fences : int
        A bitmask of FENCE_TYPE bits.
    """
    names = [name for bit, name in FENCE_NAMES if fences & bit]
    if not names:
        return ""
    listed = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
    return f"{listed} fence{'s' if len(names) > 1 else ''}"


def breach_name(breached: int) -> str | None:
    """The breach a FENCE_TYPE bitmask of breached fences is reported as: "circle" before
    "polygon", None for none.

    Parameters
    ----------
    breached : int
        What :meth:`Fence.breaches` gives.
    """
    if breached & FENCE_TYPE_CIRCLE:
        return "circle"
    return "polygon" if breached & FENCE_TYPE_POLYGON else None


def _local(it: MissionItem, home: tuple[float, float, float]) -> tuple[float, float]:
    n, e, _ = geodetic_to_ned(it.lat_deg, it.lon_deg, home[2], *home)
    return n, e


def validate_fence(items: list[MissionItem]) -> tuple[int, int, str] | None:
    """The first problem of a whole fence list as (item index, MAV_MISSION_RESULT, Rover's
    words for it), or None: as ArduPilot's ``AC_PolyFence_loader::validate_fence``, which a
    fence upload meets when its last item has come, and which answers MAV_MISSION_ERROR.

    Polygon vertices come in runs of exactly the count their param1 gives (3 to
    :data:`MAX_VERTICES`), all of one kind; a circle has a positive radius and comes between
    polygons; there is at most one return point; every place is on the Earth.

    Parameters
    ----------
    items : list of MissionItem
        The whole fence, item 0 first (a fence has no home item).
    """
    error = mav.MAV_MISSION_ERROR
    left, want, kind = 0, 0, 0  # vertices still to come in the polygon begun, its count and command
    seen_return = False
    for i, it in enumerate(items):
        if it.command not in FENCE_COMMANDS:
            return i, mav.MAV_MISSION_UNSUPPORTED, "not a fence item"
        if it.command in (POLYGON_INCLUSION, POLYGON_EXCLUSION):
            count = int(it.param1) if math.isfinite(it.param1) else 0
            if not 3 <= count <= MAX_VERTICES:
                return i, error, f"Invalid vertex count ({count})"
            if left == 0:
                left, want, kind = count, count, it.command
            elif it.command != kind:
                return i, error, f"Received incorrect vertex type (want={kind} got={it.command})"
            elif count != want:
                return i, error, f"Unexpected vertex count want={want} got={count}"
            left -= 1
        elif left:
            return i, error, f"Received incorrect type (want={kind} got={it.command})"
        elif it.command in (CIRCLE_INCLUSION, CIRCLE_EXCLUSION):
            if not (math.isfinite(it.param1) and it.param1 >= FLT_EPSILON):  # Rover's is_positive
                return i, error, "Non-positive circle radius"
        elif it.command == RETURN_POINT:
            if seen_return:
                return i, error, "Multiple return points"  # (the spec allows one)
            seen_return = True
        if not on_earth(it.lat_deg, it.lon_deg):
            return i, error, "Bad lat or lon"
    if left:
        return len(items) - 1, error, "Incorrect item count"
    return None


def _inside_polygon(n: float, e: float, poly: list[tuple[float, float]]) -> bool:
    """Even-odd rule on a polygon of (north, east) vertices."""
    inside = False
    j = len(poly) - 1
    for i in range(len(poly)):
        ni, ei = poly[i]
        nj, ej = poly[j]
        if (ei > e) != (ej > e) and n < (nj - ni) * (e - ei) / (ej - ei) + ni:
            inside = not inside
        j = i
    return inside


@dataclass
class Fence:
    """A stored fence, in local NED metres.

    Parameters
    ----------
    inclusion_polygons, exclusion_polygons : list of list of (north, east)
        The vehicle must be inside every inclusion polygon and outside every exclusion one.
    inclusion_circles, exclusion_circles : list of (north, east, radius)
        Likewise for circles, m.
    return_point : (north, east) or None
        The list's return point (NAV_FENCE_RETURN_POINT), if it has one. A Rover's breach
        action does not go there (RTL goes home or to a rally point; on ArduPilot only Plane
        flies to the return point): it is kept as the list holds it, and nothing reads it.
    """

    inclusion_polygons: list[list[tuple[float, float]]] = field(default_factory=list)
    exclusion_polygons: list[list[tuple[float, float]]] = field(default_factory=list)
    inclusion_circles: list[tuple[float, float, float]] = field(default_factory=list)
    exclusion_circles: list[tuple[float, float, float]] = field(default_factory=list)
    return_point: tuple[float, float] | None = None

    @staticmethod
    def from_items(items: list[MissionItem], home: tuple[float, float, float]) -> Fence:
        """The fence a validated FENCE list describes (see :func:`validate_fence`).

        Parameters
        ----------
        items : list of MissionItem
            The fence items.
        home : (lat_deg, lon_deg, alt_m)
            The local origin.
        """
        f = Fence()
        i = 0
        while i < len(items):
            it = items[i]
            if it.command in (POLYGON_INCLUSION, POLYGON_EXCLUSION):
                count = int(it.param1)
                poly = [_local(r, home) for r in items[i : i + count]]
                (f.inclusion_polygons if it.command == POLYGON_INCLUSION else f.exclusion_polygons).append(poly)
                i += count
                continue
            if it.command in (CIRCLE_INCLUSION, CIRCLE_EXCLUSION):
                n, e = _local(it, home)
                (f.inclusion_circles if it.command == CIRCLE_INCLUSION else f.exclusion_circles).append(
                    (n, e, float(it.param1))
                )
            elif it.command == RETURN_POINT:
                f.return_point = _local(it, home)
            i += 1
        return f

    @property
    def empty(self) -> bool:
        """No polygon and no circle."""
        return not (
            self.inclusion_polygons or self.exclusion_polygons or self.inclusion_circles or self.exclusion_circles
        )

    def breaches(
        self,
        north_m: float,
        east_m: float,
        fence_type: int,
        radius_m: float,
        home_ned: tuple[float, float] = (0.0, 0.0),
        destination: bool = False,
    ) -> int:
        """Every fence the vehicle at (north, east) breaches, as FENCE_TYPE bits (0: none), as
        AC_Fence keeps its breached fences: the circle of ``radius_m`` around home, and the
        stored shapes together as the polygon fence.

        Parameters
        ----------
        north_m, east_m : float
            The vehicle, local NED, m.
        fence_type : int
            FENCE_TYPE: bit 2 the circle of ``radius_m`` around home, bit 4 the stored shapes.
        radius_m : float
            FENCE_RADIUS, m.
        home_ned : (north_m, east_m)
            Home, local NED, m: the circle's centre (as ArduPilot's AC_Fence measures it).
        destination : bool
            (north, east) is a place asked for (a GUIDED target, a rally point), not where the
            vehicle is: on the home circle is then inside it.
        """
        breached = 0
        # a vehicle on the circle is out (AC_Fence::check_fence_circle: distance >= radius), a
        # destination on it in (check_destination_within_fence: refused past the radius); on a
        # stored inclusion circle's edge is in, on an exclusion circle's out (AC_PolyFence_loader)
        out = math.hypot(north_m - home_ned[0], east_m - home_ned[1])
        if fence_type & FENCE_TYPE_CIRCLE and (out > radius_m if destination else out >= radius_m):
            breached |= FENCE_TYPE_CIRCLE
        if fence_type & FENCE_TYPE_POLYGON and (
            any(not _inside_polygon(north_m, east_m, p) for p in self.inclusion_polygons)
            or any(_inside_polygon(north_m, east_m, p) for p in self.exclusion_polygons)
            or any(math.hypot(north_m - n, east_m - e) > r for n, e, r in self.inclusion_circles)
            or any(math.hypot(north_m - n, east_m - e) < r for n, e, r in self.exclusion_circles)
        ):
            breached |= FENCE_TYPE_POLYGON
        return breached


def rally_points(items: list[MissionItem], home: tuple[float, float, float]) -> list[tuple[float, float]]:
    """The rally points of a RALLY list, local NED metres from home; one at latitude and
    longitude 0 is none (Rover's ``get_rally_point_with_index`` skips it as unset).

    Parameters
    ----------
    items : list of MissionItem
        The rally items.
    home : (lat_deg, lon_deg, alt_m)
        The local origin.
    """
    return [_local(it, home) for it in items if it.command in RALLY_COMMANDS and (it.x, it.y) != (0, 0)]
