"""The tracker's smaller fast paths against the plain computations they replace: the
Kalman updates with H given to filterpy, and the choice among several constellations."""

from __future__ import annotations

import copy
import dataclasses
import math
import warnings

import cv2
import numpy as np
import pytest

import lfctl.vision.markers as markers_mod
import lfctl.vision.tracker as tracker_mod
from lfctl.render.sequences import make_sequence
from lfctl.vision.boxes import point_bounds
from lfctl.vision.kalman import AreaFilter, CentreFilter
from lfctl.vision.markers import (
    TINY_MARKER_PX,
    BannerLook,
    Constellation,
    _hue_off_table,
    check_constellation,
)
from lfctl.vision.pose import pnp_pose
from lfctl.vision.tracker import Tracker, _mismatch


def test_filter_updates_match_filterpys_plain_update_bit_for_bit() -> None:
    rng = np.random.default_rng(7)
    centre, area = CentreFilter(320.0, 240.0), AreaFilter(3.2, accel_var=1e-6, meas_var=0.04, size_var=4e-4)
    for k in range(200):
        plain_c, plain_a = copy.deepcopy(centre.kf), copy.deepcopy(area.kf)
        u, v, s = rng.normal(320, 40), rng.normal(240, 30), rng.normal(3.2, 0.3)
        var = 4e-4 if k % 3 else None
        centre.predict()
        area.predict()
        plain_c.predict()
        plain_a.predict()
        centre.update(u, v)
        area.update(s, var)
        plain_c.update(np.array([u, v]))
        plain_a.update(np.array([s]), None if var is None else np.array([[var]]))
        for fast, plain in ((centre.kf, plain_c), (area.kf, plain_a)):
            assert fast.x.shape == plain.x.shape and fast.x.tobytes() == plain.x.tobytes()
            assert fast.P.tobytes() == plain.P.tobytes()


def _constellation(cx: float, cy: float, side: float) -> Constellation:
    h = side / 2
    centres = np.array([[cx - h, cy - h], [cx + h, cy - h], [cx + h, cy + h], [cx - h, cy + h]])
    return Constellation(centres, (), 1.0)


@pytest.mark.parametrize("seed", range(20))
def test_markers_near_picks_the_constellation_min_picked(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(seed)
    found = [_constellation(*rng.uniform(50, 400, 2), rng.uniform(10, 60)) for _ in range(rng.integers(1, 6))]
    tr = Tracker()
    expect = (int(rng.integers(0, 400)), int(rng.integers(0, 300)), 60, 60)
    pos = tr.s.panel_over_side
    if seed % 2 == 0:  # a tie at the least mismatch: the first of them, as min() picks
        best = min(found, key=lambda k: _mismatch(k.banner_bbox(pos), expect))
        found.append(Constellation(best.centres.copy(), (), 0.5))
    monkeypatch.setattr(tracker_mod, "find_constellations", lambda *a, **k: list(found))
    monkeypatch.setattr(tracker_mod, "refine", lambda c, *a, **k: c)
    want = min(found, key=lambda k: _mismatch(k.banner_bbox(pos), expect))
    got = tr._markers_near(np.zeros((4, 4, 3), np.uint8), expect, must="nearest")
    assert got is want
    track = tr._markers_near(np.zeros((4, 4, 3), np.uint8), expect, must="track")
    assert track is (want if _mismatch(want.banner_bbox(pos), expect) <= 1.0 else None)


def test_pnp_pose_with_shared_object_points_per_side() -> None:
    K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
    corners = np.array([[300.0, 220], [340, 220], [340, 260], [300, 260]])
    near, far = pnp_pose(corners, K, None, 0.14), pnp_pose(corners, K, None, 0.28)
    again = pnp_pose(corners, K, None, 0.14)
    assert near is not None and far is not None and again is not None
    assert far.range_m == pytest.approx(2 * near.range_m)
    assert again.range_m == near.range_m


def _plain_banner_bbox(centres: np.ndarray, panel_over_side: float) -> tuple[int, int, int, int]:
    """Constellation.banner_bbox as it was, all in numpy."""
    c = centres.mean(axis=0)
    corners = c + (centres - c) * panel_over_side
    x0, y0 = np.floor(corners.min(axis=0)).astype(int)
    x1, y1 = np.ceil(corners.max(axis=0)).astype(int)
    return int(x0), int(y0), int(x1 - x0), int(y1 - y0)


def test_banner_bbox_is_numpys_to_the_bit() -> None:
    rng = np.random.default_rng(11)
    for _k in range(20000):
        scale = 10.0 ** rng.uniform(-2, 4)
        centres = rng.uniform(-1, 1, (4, 2)) * scale + rng.uniform(-500, 1500, 2)
        pos = float(rng.uniform(0.5, 3.0))
        c = Constellation(np.ascontiguousarray(centres), (), 1.0)
        assert c.banner_bbox(pos) == _plain_banner_bbox(centres, pos)
        # near-integer centres far out, where rounding decides which side of an integer a
        # corner lands on
        near = rng.integers(-(10**6), 10**6, (4, 2)) + rng.choice([0.0, 0.1, 0.3, 1e-9], (4, 2))
        pos = float(rng.choice([1.0, 3.0, 0.5, 0.22 / 0.14]))
        assert Constellation(near, (), 1.0).banner_bbox(pos) == _plain_banner_bbox(near, pos)


def test_banner_bbox_of_other_arrays_is_numpys() -> None:
    centres = np.array([[10.25, 20.5], [40.0, 20.0], [40.5, 50.0], [10.0, 50.75]])
    want = _plain_banner_bbox(centres, 1.5)
    assert Constellation(np.asfortranarray(centres), (), 1.0).banner_bbox(1.5) == want
    f32 = centres.astype(np.float32)
    assert Constellation(f32, (), 1.0).banner_bbox(1.5) == _plain_banner_bbox(f32, 1.5)
    for odd in (np.nan, np.inf):
        bad = centres.copy()
        bad[0, 0] = odd
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # numpy's cast of NaN and inf to int
            assert Constellation(bad, (), 1.0).banner_bbox(1.5) == _plain_banner_bbox(bad, 1.5)


def test_point_bounds_are_numpys_floor_and_ceil() -> None:
    rng = np.random.default_rng(0)
    odd = [np.nan, np.inf, -np.inf, 1e308, -1e19, 9.3e18, 4e18]
    for k in range(20000):
        poly = rng.normal(size=(int(rng.integers(3, 9)), 2)) * 10.0 ** int(rng.integers(-2, 5))
        if k % 7 == 0:
            poly = np.round(poly)  # whole coordinates: floor and ceil meet
        if k % 11 == 0:
            poly[rng.integers(len(poly)), rng.integers(2)] = odd[k % len(odd)]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # numpy's cast of NaN and inf to int
            lo = np.floor(poly.min(axis=0)).astype(int).tolist()
            hi = np.ceil(poly.max(axis=0)).astype(int).tolist()
        assert point_bounds(poly) == (*lo, *hi), poly


def _plain_marker_check(c: Constellation, hsv: np.ndarray, aspect: float, look: BannerLook) -> tuple[str, list, list]:
    """check_constellation's marker loop as it was, one blob at a time: the first failure,
    or "" with the markers' median saturations and values."""
    hue_off_of = _hue_off_table(0)
    sats, vals = [], []
    for b in c.blobs:
        x, y, w, h = b.bbox
        if abs(w - aspect * h) > 0.3 * aspect * h + 1.0:
            return "marker shape", sats, vals
        px = hsv[max(0, y) : y + h, max(0, x) : x + w].reshape(-1, 3).astype(np.int16)
        px[:, 0] = hue_off_of[px[:, 0]]
        on = px[(px[:, 0] <= 18.0) & (px[:, 1] >= 90) & (px[:, 2] >= 40)]
        if on.shape[0] == 0:
            return "marker colour", sats, vals
        k = on.shape[0] // 2
        hue_off, sat, val = np.partition(on, k, axis=0)[k].tolist()
        judged = int(on[:, 1].max()) if b.area_px < TINY_MARKER_PX else sat
        if hue_off > 9.0 or judged < 0.7 * look.marker_saturation * 255.0:
            return "marker colour", sats, vals
        sats.append(sat)
        vals.append(val)
    return "", sats, vals


def test_check_constellation_judges_markers_as_one_blob_at_a_time(monkeypatch: pytest.MonkeyPatch) -> None:
    """Rendered banners, and their blobs moved and resized at random (every kind of marker
    failure): the batched marker loop decides as the plain one, and hands the panel check
    the same medians."""
    look = BannerLook()
    real_ceil = markers_mod.math.ceil
    panel_inputs: list[float] = []

    class _Math:  # records what the panel check is given (sorted(sats)[2], sorted(vals)[2])
        def __getattr__(self, name: str):
            return getattr(math, name)

        @staticmethod
        def ceil(v: float) -> int:
            panel_inputs.append(v)
            return real_ceil(v)

    monkeypatch.setattr(markers_mod, "math", _Math())
    rng = np.random.default_rng(5)
    reasons = set()
    seq = make_sequence("range", 1, 90)
    for i, (_t, frame, _truth) in enumerate(seq.frames()):
        if i % 3:
            continue
        hsv = cv2.cvtColor(frame, cv2.COLOR_BGR2HSV)
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(markers_mod, "check_constellation", lambda *a, **k: "")
            cands = markers_mod.find_constellations(hsv, 0.0)
        for c in cands:
            variants = [c]
            for _ in range(6):
                blobs = tuple(
                    dataclasses.replace(
                        b,
                        bbox=(
                            b.bbox[0] + int(rng.integers(-3, 4)),
                            b.bbox[1] + int(rng.integers(-3, 4)),
                            max(1, b.bbox[2] + int(rng.integers(-2, 3))),
                            max(1, b.bbox[3] + int(rng.integers(-2, 3))),
                        ),
                        area_px=float(rng.choice([b.area_px, 9.0, 40.0])),
                    )
                    for b in c.blobs
                )
                variants.append(Constellation(c.centres, blobs, c.score))
            # one marker's box moved off it onto the panel: no marker pixels there
            k = int(rng.integers(0, 4))
            off = c.blobs[k].bbox
            moved = dataclasses.replace(c.blobs[k], bbox=(off[0] + 2 * off[2] + 2, off[1], off[2], off[3]))
            variants.append(Constellation(c.centres, (*c.blobs[:k], moved, *c.blobs[k + 1 :]), c.score))
            for v in variants:
                pts = np.asarray(v.centres, np.float64)
                (xa, ya), (xb, yb), (xc, yc), (xd, yd) = pts.tolist()
                across = math.hypot(xb - xa, yb - ya) + math.hypot(xc - xd, yc - yd)
                down = math.hypot(xd - xa, yd - ya) + math.hypot(xc - xb, yc - yb)
                plain, sats, vals = _plain_marker_check(v, hsv, across / max(1e-9, down), look)
                panel_inputs.clear()
                got = check_constellation(v, hsv, 0.0, look)
                if plain:
                    assert got == plain
                else:
                    assert got not in ("marker shape", "marker colour")
                    if panel_inputs:
                        assert panel_inputs[:2] == [0.5 * sorted(sats)[2], 0.5 * sorted(vals)[2]]
                reasons.add(got)
    assert {"", "marker shape", "marker colour"} <= reasons
