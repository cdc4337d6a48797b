"""SmartRTL's way back, thinned as a Rover thins it.

A Rover keeps breadcrumbs (a point each time it has moved ``SRTL_ACCURACY`` from the last)
and, before it drives them back and whenever its ``SRTL_POINTS`` are nearly used up, cleans
them in two steps (ArduPilot's AP_SmartRTL):

- **simplification**: points that lie within half the accuracy of the line between the
  points kept either side of them are dropped (Ramer-Douglas-Peucker);
- **loop pruning**: where the way comes back within 0.99 of the accuracy of a part of itself
  that is not its neighbour, everything driven in between is cut out and the two pieces are
  joined at the point midway between where they came closest: the way back does not drive
  a loop the vehicle drove. (A straight run out and back along itself simplifies to its two
  ends and the turn, which leaves no loop to cut: it is driven back out to the turn, as a
  Rover does.)

The pruning is Rover's own, decision for decision: each leg from the newest back is measured
against the older legs from the oldest on and the first it meets makes a loop (the legs
measured as ``AP_SmartRTL::segment_segment_dist`` measures them: the two lines' closest
points, each clamped to its own leg, so two legs may be taken as further apart than they
are, and parallel legs never meet); a loop inside, or overlapping, loops already found is
kept only if its squared leg lengths add up to more than theirs, and replaces them; the
newest of at most a quarter of ``SRTL_POINTS`` loops are cut first.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lfctl.frames import FLT_EPSILON

__all__ = ["clean", "leg_distances", "prune_loops", "simplify"]

Point = tuple[float, float]

#: the share of the accuracy within which a point is on the line and can be dropped
SIMPLIFY_SHARE = 0.5
#: the share of the accuracy within which two legs are taken to meet (no obstacle between)
PRUNE_SHARE = 0.99
#: |a c - b^2| under this: the legs are parallel (Rover's ``is_zero``, a float's epsilon)
PARALLEL = FLT_EPSILON
#: the most loops kept, as a share of ``SRTL_POINTS`` (Rover's loop buffer)
LOOPS_SHARE = 0.25


def simplify(points: list[Point], epsilon_m: float) -> list[Point]:
    """Drop the points that lie within ``epsilon_m`` of the line between the points kept
    either side of them (Ramer-Douglas-Peucker); the first and last are always kept.

    Parameters
    ----------
    points : list of (north, east)
        The way, oldest first, m.
    epsilon_m : float
        How far off the line a point may be and still be dropped, m.
    """
    n = len(points)
    if n < 3:
        return list(points)
    p = np.asarray(points, float)
    keep = np.zeros(n, bool)
    keep[0] = keep[-1] = True
    todo = [(0, n - 1)]
    while todo:
        a, b = todo.pop()
        if b - a < 2:
            continue
        d = _point_segment_distance(p[a + 1 : b], p[a], p[b])
        k = int(np.argmax(d))
        if d[k] > epsilon_m:
            keep[a + 1 + k] = True
            todo += [(a, a + 1 + k), (a + 1 + k, b)]
    return [points[i] for i in np.flatnonzero(keep)]


def prune_loops(points: list[Point], delta_m: float, max_loops: int | None = None) -> list[Point]:
    """Cut out the loops, as ``AP_SmartRTL`` (``detect_loops``, ``add_loop``,
    ``remove_points_by_loops``) does: see the module's description.

    Parameters
    ----------
    points : list of (north, east)
        The way, oldest first, m.
    delta_m : float
        How close two legs must come to be taken to meet, m.
    max_loops : int, optional
        The most loops kept (Rover's: a quarter of ``SRTL_POINTS``); once found, the search
        stops. None: no limit.
    """
    n = len(points)
    if n < 4:
        return list(points)
    p = np.asarray(points, np.float32)  # (Rover's positions are single precision)
    # every leg against every older leg that is not its neighbour, at once (leg k: point
    # k - 1 to point k); the search below reads them in Rover's order
    newer, older = np.nonzero(np.tri(n, n, -2, dtype=bool))
    newer, older = newer[older >= 1], older[older >= 1]
    dist, mid = leg_distances(p[newer], p[newer - 1], p[older - 1], p[older])
    meets = np.zeros((n, n), bool)
    meets[newer, older] = dist < delta_m
    joint = np.zeros((n, n, 2))
    joint[newer, older] = mid
    loops: list[_Loop] = []
    # the newest leg first, then back to leg 4 (Rover's search stops below 4, except that
    # its first leg is measured whatever its number)
    for i in range(n - 1, 3, -1) if n > 4 else (3,):
        hits = np.flatnonzero(meets[i, 1 : i - 1])
        if not hits.size:
            continue
        j = int(hits[0]) + 1  # the oldest leg it meets
        if max_loops is not None and len(loops) >= max_loops:
            break  # (Rover's loop buffer full: it stops looking)
        _add_loop(loops, _Loop(j, i - 1, (float(joint[i, j, 0]), float(joint[i, j, 1])), p))
    way = list(points)
    while loops:  # the last found first, the indices of those before it moved on
        loop = loops.pop()
        cut = loop.end - loop.start
        way[loop.start : loop.end + 1] = [loop.joint]
        for other in loops:
            if other.start >= loop.end:
                other.start -= cut
            if other.end >= loop.end:
                other.end -= cut
    return way


class _Loop:
    """A loop found: its first and last point, where its legs are joined, its size (the
    squared lengths of its legs and of the two half-legs to the joint, summed: Rover's)."""

    def __init__(self, start: int, end: int, joint: Point, p: np.ndarray) -> None:
        self.start, self.end, self.joint = start, end, joint
        # summed in Rover's order (ties between loops are decided by the last bit)
        size = _squared(joint, p[start]) + _squared(joint, p[end])
        for k in range(start, end):
            size += _squared(p[k], p[k + 1])
        self.size = size

    def overlaps(self, other: _Loop) -> bool:
        """One within the other, or one's ends on either side of the other's (Rover's
        ``loops_overlap``)."""
        if other.start <= self.start and self.end <= other.end:
            return True
        if self.start <= other.start and other.end <= self.end:
            return True
        start_in = other.start <= self.start <= other.end
        end_in = other.start <= self.end <= other.end
        return start_in != end_in


def _squared(a: Sequence[float], b: Sequence[float]) -> np.float32:
    """The squared distance between two points, in single precision (Rover's)."""
    dn, de = np.float32(a[0]) - np.float32(b[0]), np.float32(a[1]) - np.float32(b[1])
    return np.float32(dn * dn + de * de)


def _add_loop(loops: list[_Loop], new: _Loop) -> None:
    """Keep ``new`` unless the loops it overlaps are larger together; then it replaces them."""
    overlapped = [loop for loop in loops if loop.overlaps(new)]
    if overlapped and sum(loop.size for loop in overlapped) > new.size:
        return
    loops[:] = [loop for loop in loops if loop not in overlapped]
    loops.append(new)


def clean(points: list[Point], accuracy_m: float, points_max: int | None = None) -> list[Point]:
    """The way back as a Rover drives it: simplified at half the accuracy, then its loops
    pruned at 0.99 of it (:func:`simplify`, :func:`prune_loops`).

    Parameters
    ----------
    points : list of (north, east)
        The breadcrumbs, oldest first, m.
    accuracy_m : float
        ``SRTL_ACCURACY``, m (> 0).
    points_max : int, optional
        ``SRTL_POINTS``: a quarter of it is the most loops cut. None: no limit.
    """
    max_loops = None if points_max is None else int(LOOPS_SHARE * points_max)
    return prune_loops(simplify(points, SIMPLIFY_SHARE * accuracy_m), PRUNE_SHARE * accuracy_m, max_loops)


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances of the points ``p`` (n, 2) from the segment a-b."""
    ab = b - a
    den = float(ab @ ab)
    t = np.zeros(len(p)) if den == 0.0 else np.clip((p - a) @ ab / den, 0.0, 1.0)
    return np.hypot(*(p - a - t[:, None] * ab).T)


def leg_distances(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How far apart legs a0-a1 and b0-b1 are (arrays of (n, 2) points, or one point to pair
    with every row of the others), and the point midway between their closest points, as
    Rover's ``AP_SmartRTL::segment_segment_dist`` measures them: the closest points of the two
    lines, each clamped to its own leg on its own (so the distance may be more than the
    legs' true closest distance); parallel legs are infinitely far apart."""
    # in single precision, as Rover's Vector3f: which nearly parallel legs count as parallel,
    # and ties, are decided by the float's last bits
    a0, a1, b0, b1 = np.broadcast_arrays(*(np.asarray(x, np.float32).reshape(-1, 2) for x in (a0, a1, b0, b1)))
    u, v, w = a1 - a0, b1 - b0, a0 - b0
    a, b, c = (u * u).sum(1), (u * v).sum(1), (v * v).sum(1)
    d, e = (u * w).sum(1), (v * w).sum(1)
    den = a * c - b * b
    parallel = np.abs(den) < PARALLEL
    safe = np.where(parallel, 1.0, den)
    t = np.clip((b * e - c * d) / safe, 0.0, 1.0)[:, None]
    s = np.clip((a * e - b * d) / safe, 0.0, 1.0)[:, None]
    on_a, on_b = a0 + u * t, b0 + v * s
    dist = np.where(parallel, np.inf, np.hypot(*(on_a - on_b).T))
    return dist, (on_a + on_b) / 2
