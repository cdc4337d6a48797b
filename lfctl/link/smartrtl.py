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

The pruning here cuts, from the newest leg back, the largest loop each leg closes (Rover
searches in the same order and keeps the longer of two overlapping loops).
"""

from __future__ import annotations

import numpy as np

__all__ = ["clean", "prune_loops", "segment_distances", "simplify"]

Point = tuple[float, float]

#: the share of the accuracy within which a point is on the line and can be dropped
SIMPLIFY_SHARE = 0.5
#: the share of the accuracy within which two legs are taken to meet (no obstacle between)
PRUNE_SHARE = 0.99


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


def prune_loops(points: list[Point], delta_m: float) -> list[Point]:
    """Cut out the loops: where a leg comes within ``delta_m`` of an earlier leg that is not
    its neighbour, the points between are dropped and the two legs joined at the point
    midway between where they came closest. From the newest leg back, each leg cuts the
    largest loop it closes.

    Parameters
    ----------
    points : list of (north, east)
        The way, oldest first, m.
    delta_m : float
        How close two legs must come to be taken to meet, m.
    """
    n = len(points)
    if n < 4:
        return list(points)
    p = np.asarray(points, float)
    # every pair of legs (leg k: point k - 1 to point k) that are not neighbours, at once
    newer, older = np.nonzero(np.tri(n, n, -2, dtype=bool))
    newer, older = newer[older >= 1], older[older >= 1]
    lo, hi = np.minimum(p[:-1], p[1:]), np.maximum(p[:-1], p[1:])  # each leg's box (leg k: row k - 1)
    gap = np.maximum(lo[older - 1] - hi[newer - 1], lo[newer - 1] - hi[older - 1]).max(axis=1)
    newer, older = newer[gap < delta_m], older[gap < delta_m]  # boxes further apart: legs too
    dist, mid = segment_distances(p[newer - 1], p[newer], p[older - 1], p[older])
    near = np.full((n, n), np.inf)
    near[newer, older] = dist
    meet = np.zeros((n, n, 2))
    meet[newer, older] = mid
    way = [points[-1]]  # what is kept, newest first
    i, end = n - 1, None  # the leg from point i - 1 to point i, or to ``end`` where legs were joined
    while i >= 1:
        if i >= 3:
            if end is None:
                hits = np.flatnonzero(near[i, 1 : i - 1] < delta_m) + 1
                joints = meet[i]
            else:  # a joined leg: not one of the legs measured above
                d, m = segment_distances(p[i - 1], np.asarray(end), p[: i - 2], p[1 : i - 1])
                hits = np.flatnonzero(d < delta_m) + 1
                joints = np.vstack([np.zeros((1, 2)), m])
            if hits.size:
                j = int(hits[0])  # the oldest leg it meets: the largest loop
                end = (float(joints[j, 0]), float(joints[j, 1]))
                way.append(end)
                i = j  # the leg from point j - 1 to the joint is checked next
                continue
        way.append(points[i - 1])
        i, end = i - 1, None
    return way[::-1]


def clean(points: list[Point], accuracy_m: float) -> list[Point]:
    """The way back as a Rover drives it: simplified at half the accuracy, then its loops
    pruned at 0.99 of it (:func:`simplify`, :func:`prune_loops`).

    Parameters
    ----------
    points : list of (north, east)
        The breadcrumbs, oldest first, m.
    accuracy_m : float
        ``SRTL_ACCURACY``, m (> 0).
    """
    return prune_loops(simplify(points, SIMPLIFY_SHARE * accuracy_m), PRUNE_SHARE * accuracy_m)


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances of the points ``p`` (n, 2) from the segment a-b."""
    ab = b - a
    den = float(ab @ ab)
    t = np.zeros(len(p)) if den == 0.0 else np.clip((p - a) @ ab / den, 0.0, 1.0)
    return np.hypot(*(p - a - t[:, None] * ab).T)


def segment_distances(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The closest distance between segments a-b and c-d (arrays of (n, 2) points, or one
    point to pair with every row of the others), and the point midway between the two
    closest points. In 2-D the closest pair is an end of one segment and the nearest point
    of the other, unless they cross, when they meet at the crossing."""
    a, b, c, d = np.broadcast_arrays(*(np.asarray(x, float).reshape(-1, 2) for x in (a, b, c, d)))

    def nearest(q: np.ndarray, s0: np.ndarray, s1: np.ndarray) -> np.ndarray:
        s = s1 - s0
        den = np.einsum("ij,ij->i", s, s)
        t = np.einsum("ij,ij->i", q - s0, s) / np.where(den > 0, den, 1.0)
        return s0 + np.clip(np.where(den > 0, t, 0.0), 0.0, 1.0)[:, None] * s

    pairs = [(a, nearest(a, c, d)), (b, nearest(b, c, d)), (nearest(c, a, b), c), (nearest(d, a, b), d)]
    dist = np.stack([np.hypot(*(x - y).T) for x, y in pairs])
    best = np.argmin(dist, axis=0)
    rows = np.arange(len(a))
    on_ab = np.stack([x for x, _y in pairs])[best, rows]
    on_cd = np.stack([y for _x, y in pairs])[best, rows]
    out_d, mid = dist[best, rows], (on_ab + on_cd) / 2
    r, s = b - a, d - c
    den = r[:, 0] * s[:, 1] - r[:, 1] * s[:, 0]
    q = c - a
    safe = np.where(den != 0, den, 1.0)
    t = (q[:, 0] * s[:, 1] - q[:, 1] * s[:, 0]) / safe
    u = (q[:, 0] * r[:, 1] - q[:, 1] * r[:, 0]) / safe
    cross = (den != 0) & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)
    return np.where(cross, 0.0, out_d), np.where(cross[:, None], a + np.where(cross, t, 0.0)[:, None] * r, mid)
