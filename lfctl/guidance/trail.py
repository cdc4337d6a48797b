"""The target's trail: the path a follower estimated its target drove, for a follower that
drives that path instead of cutting across to the target (``guidance.controller = "trail"``).

The follower knows its target only from its own sensor and odometry, so the trail is the
formation filter's estimate of the target's position, a point each ``spacing_m`` it moves, in
the follower's local frame. The follower finds where it is along the trail (its arc length
and its signed cross-track distance, positive right of the path) and steers for the point a
lookahead distance further along it (pure pursuit: it turns before a corner by about that
much, where steering by the segment it is on turns only once past it and swings wide), while
a sliding-mode law on the gap along the trail (the paper's range law, eq. 17-23, written
along the path) holds its distance behind the target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from lfctl.guidance.smc import RangeGains, clamp, sat

__all__ = ["Trail", "TrailFix", "trail_speed_mps"]


@dataclass(frozen=True)
class TrailFix:
    """Where a point is along a trail."""

    s_m: float  # arc length from the trail's first point to the point's projection, m
    cross_m: float  # signed distance from the trail, positive right of it, m
    heading_rad: float  # the trail's heading there, NED from north, clockwise positive


class Trail:
    """A polyline grown at its end and located on from its start.

    Parameters
    ----------
    spacing_m : float
        A new point is kept once the target is this far from the last one, m (> 0).
    max_points : int
        At most this many points are kept; the oldest go first (a follower that far behind
        has lost the trail's start anyway).
    """

    def __init__(self, spacing_m: float = 0.05, max_points: int = 4000) -> None:
        if not spacing_m > 0:
            raise ValueError(f"spacing_m must be > 0, got {spacing_m!r}")
        if max_points < 2:
            raise ValueError(f"max_points must be at least 2, got {max_points!r}")
        self.spacing_m = spacing_m
        self.max_points = max_points
        self.points: list[tuple[float, float]] = []
        self.s: list[float] = []  # arc length at each point, m
        self.cursor = 0  # the segment the follower was last found on

    def reset(self, start: tuple[float, float], target: tuple[float, float], heading_rad: float) -> None:
        """Start again: a straight trail from ``start`` (the follower) to ``target``; when
        the target is on the start, ``spacing_m`` along ``heading_rad`` (the follower's)."""
        self.points, self.s, self.cursor = [start], [0.0], 0
        step = math.hypot(target[0] - start[0], target[1] - start[1])
        if step < 1e-6:
            d = self.spacing_m
            target, step = (start[0] + d * math.cos(heading_rad), start[1] + d * math.sin(heading_rad)), d
        self.points.append(target)
        self.s.append(step)

    def extend(self, north_m: float, east_m: float) -> None:
        """The target is here now: kept as a new point once ``spacing_m`` from the last.
        A target that has backed up takes the trail back with it: the points it has backed
        past are dropped (never the first segment), so the trail's length is still how far
        along it the target is.

        Parameters
        ----------
        north_m, east_m : float
            The target's estimated position, m.
        """
        while len(self.points) > 2 and self._past_end(north_m, east_m) < 0.0:
            self.points.pop()  # backed up past the last point, along the last segment
            self.s.pop()
        self.cursor = min(self.cursor, len(self.points) - 2)
        ln, le = self.points[-1]
        step = math.hypot(north_m - ln, east_m - le)
        if step < self.spacing_m or self._past_end(north_m, east_m) < 0.0:
            return  # too near, or behind the end of the first segment (see end_s)
        self.points.append((north_m, east_m))
        self.s.append(self.s[-1] + step)
        if len(self.points) > self.max_points:
            drop = len(self.points) - self.max_points
            del self.points[:drop], self.s[:drop]
            self.cursor = max(0, self.cursor - drop)

    def end_s(self, north_m: float, east_m: float) -> float:
        """Arc length of the target at (north, east): the trail's length plus its distance
        from the last point, m; less how far it is behind the last point, along the last
        segment, when it is (a target backed up past the first segment's end).

        Parameters
        ----------
        north_m, east_m : float
            The target's estimated position, m.
        """
        ln, le = self.points[-1]
        along = self._past_end(north_m, east_m)
        return self.s[-1] + (along if along < 0.0 else math.hypot(north_m - ln, east_m - le))

    def _past_end(self, north_m: float, east_m: float) -> float:
        """How far (north, east) is past the last point along the last segment, m (negative
        behind it)."""
        (an, ae), (ln, le) = self.points[-2], self.points[-1]
        seg = self.s[-1] - self.s[-2]
        return ((north_m - ln) * (ln - an) + (east_m - le) * (le - ae)) / seg if seg > 0 else 0.0

    def aim(self, north_m: float, east_m: float, lookahead_m: float, offset_m: float = 0.0) -> tuple[float, float]:
        """Pure pursuit's aim: the first point of the trail, shifted ``offset_m`` to its right
        (left when negative), from the segment last located on towards the end, that is at
        least ``lookahead_m`` from (north, east) and ahead of it along its own segment; the
        shifted end when none is. The points just past a corner shifted to its inside lie
        behind a follower on that side, and are passed over, so it turns where the shifted
        legs cross rather than turning back.

        Parameters
        ----------
        north_m, east_m : float
            The follower, m.
        lookahead_m : float
            How far ahead it aims, m.
        offset_m : float
            Its sideways offset from the trail, m (positive right).
        """
        pts = self.points
        qn, qe = pts[-1]
        for k in range(self.cursor + 1, len(pts)):  # at least the last segment: cursor <= len - 2
            (an, ae), (bn, be) = pts[k - 1], pts[k]
            h = math.atan2(be - ae, bn - an)
            qn, qe = bn - offset_m * math.sin(h), be + offset_m * math.cos(h)
            dn, de = qn - north_m, qe - east_m
            if dn * dn + de * de >= lookahead_m * lookahead_m and dn * math.cos(h) + de * math.sin(h) > 0:
                break
        return qn, qe

    def locate(self, north_m: float, east_m: float, window: int = 200) -> TrailFix:
        """Where (north, east) is along the trail: the nearest segment from a few before the
        last one found to ``window`` after it (a follower moves on along its trail). Behind
        the first point the first segment runs on backwards: the arc length is negative there.

        Parameters
        ----------
        north_m, east_m : float
            The point (the follower), m.
        window : int
            Segments searched past the last one found.
        """
        if len(self.points) < 2:
            raise ValueError("a trail needs two points before it is located on: reset it first")
        best: tuple[float, int, float] | None = None
        first = max(0, self.cursor - 5)
        last = min(len(self.points) - 2, self.cursor + window)
        for k in range(first, last + 1):
            (an, ae), (bn, be) = self.points[k], self.points[k + 1]
            dn, de = bn - an, be - ae
            length2 = dn * dn + de * de
            lo = -math.inf if k == 0 else 0.0  # the first segment runs on backwards
            u = clamp(((north_m - an) * dn + (east_m - ae) * de) / length2, lo, 1.0) if length2 > 0 else 0.0
            d2 = (an + u * dn - north_m) ** 2 + (ae + u * de - east_m) ** 2
            if best is None or d2 < best[0]:
                best = (d2, k, u)
        assert best is not None
        _, k, u = best
        self.cursor = k
        (an, ae), (bn, be) = self.points[k], self.points[k + 1]
        heading = math.atan2(be - ae, bn - an)
        cross = -(north_m - an) * math.sin(heading) + (east_m - ae) * math.cos(heading)
        return TrailFix(self.s[k] + u * (self.s[k + 1] - self.s[k]), cross, heading)


def trail_speed_mps(
    gap_m: float, gap_cmd_m: float, target_speed_mps: float, turn_rad: float, gains: RangeGains
) -> float:
    """The range law (eq. 17-23) along the trail: with ``s = gap - gap_cmd`` and the reaching
    law ``ds/dt = -eta sat(s / Phi)``, the follower's speed along the trail must be the
    target's plus ``eta sat(s / Phi)``. That speed is scaled by ``max(0, cos(turn))``: a
    follower with a corner still to turn slows for it (the paper's range law divides by the
    cosine instead, and would speed it into the corner) and turns in place past 90 degrees;
    the gap law then takes back what was lost. Saturated to the speed limits.

    Parameters
    ----------
    gap_m, gap_cmd_m : float
        Arc length from the follower to the target along the trail, and the slot's, m.
    target_speed_mps : float
        The target's speed along its trail, m/s.
    turn_rad : float
        The heading the follower wants less its heading, rad.
    gains : RangeGains
        Reaching rate, boundary layer and speed limits.
    """
    along = target_speed_mps + gains.eta_mps * sat((gap_m - gap_cmd_m) / gains.phi_m)
    return clamp(along * max(0.0, math.cos(turn_rad)), gains.min_speed_mps, gains.max_speed_mps)
