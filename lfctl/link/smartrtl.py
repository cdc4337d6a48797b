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
    pts = list(points)
    i = len(pts) - 1  # the leg from point i - 1 to point i
    while i >= 3:
        earlier = np.asarray(pts[: i - 1], float)  # legs (j - 1, j) for j = 1 .. i - 2: none touches leg i
        dist, mid = _segment_distances(np.asarray(pts[i - 1], float), np.asarray(pts[i], float), earlier)
        hits = np.flatnonzero(dist < delta_m)
        if hits.size:
            j = int(hits[0]) + 1  # the oldest leg it meets: the largest loop
            pts = [*pts[:j], (float(mid[hits[0], 0]), float(mid[hits[0], 1])), *pts[i:]]
            i = j  # the joined leg (j - 1 to the midpoint) is checked next
        else:
            i -= 1
    return pts


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


def _segment_distances(a: np.ndarray, b: np.ndarray, way: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The closest distance between segment a-b and each segment of ``way`` (its points
    k and k + 1), and the point midway between the two closest points (2-D: the closest pair
    is an end of one segment and the other segment, unless they cross)."""
    c, d = way[:-1], way[1:]
    candidates = []  # (distance, the point on a-b, the point on c-d) for each end's nearest

    def nearest(p: np.ndarray, s0: np.ndarray, s1: np.ndarray) -> np.ndarray:
        s = s1 - s0
        den = np.einsum("ij,ij->i", s, s)
        t = np.where(den > 0, np.einsum("ij,ij->i", p - s0, s) / np.where(den > 0, den, 1.0), 0.0)
        return s0 + np.clip(t, 0.0, 1.0)[:, None] * s

    n = len(c)
    ab0, ab1 = np.broadcast_to(a, (n, 2)), np.broadcast_to(b, (n, 2))
    for end, other in ((ab0, nearest(ab0, c, d)), (ab1, nearest(ab1, c, d))):
        candidates.append((np.hypot(*(end - other).T), end, other))
    for end in (c, d):
        on_ab = nearest(end, ab0, ab1)
        candidates.append((np.hypot(*(end - on_ab).T), on_ab, end))
    dist = np.stack([x[0] for x in candidates])
    best = np.argmin(dist, axis=0)
    rows = np.arange(n)
    p_ab = np.stack([x[1] for x in candidates])[best, rows]
    p_cd = np.stack([x[2] for x in candidates])[best, rows]
    out_d = dist[best, rows]
    mid = (p_ab + p_cd) / 2
    # segments that cross meet at their crossing
    r, s = ab1 - ab0, d - c
    den = r[:, 0] * s[:, 1] - r[:, 1] * s[:, 0]
    q = c - ab0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (q[:, 0] * s[:, 1] - q[:, 1] * s[:, 0]) / den
        u = (q[:, 0] * r[:, 1] - q[:, 1] * r[:, 0]) / den
    cross = (den != 0) & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)
    out_d = np.where(cross, 0.0, out_d)
    mid = np.where(cross[:, None], ab0 + np.where(cross, t, 0.0)[:, None] * r, mid)
    return out_d, mid
