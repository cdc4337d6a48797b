"""The ArUco section of `lfctl bench vision`: the leader's pose from an ArUco banner against
the paper's banner (CAMShift on H x S x LBP + the four red markers, lfctl's ``full``
tracker), against range and viewing angle, under the rendered tiers' lighting and
occlusion.

For each tier (``clear``, ``lighting``, ``occlusion``: the scenes of
:mod:`lfctl.render.sequences`), range (0.5 to 8 m, between the vehicles' reference points)
and angle (the leader turned 0, 30, 60 deg from the line of sight), the leader stands still
straight ahead and the tier's ten seconds play (light drop, flicker and shadow band; the
occluder crossing). Both banners are rendered from the same scene, seed and noise, and differ
only in what the panel carries; each frame goes to its banner's perception (the full
pipeline of `lfctl sim`: search, track, pose, the banner's offset to the vehicle).

Per cell: detection rate (frames with a pose, of those whose banner is at least half in
view), median range error (% of range) and bearing error (deg) of the poses, median ms per
frame of perception (both measured in the same worker, frame by frame, so they share the
machine's load).
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from lfctl.bench.common import print_json, print_table, run_as_script
from lfctl.render.renderer import Renderer, VehiclePose
from lfctl.render.sequences import FPS, make_sequence
from lfctl.vision.perception import BannerPerception

__all__ = ["ANGLES_DEG", "METHODS", "RANGES_M", "TIERS", "compare", "main", "run_cell"]

RANGES_M = (0.5, 1.0, 2.0, 4.0, 8.0)
ANGLES_DEG = (0.0, 30.0, 60.0)
TIERS = ("clear", "lighting", "occlusion")
METHODS = ("markers", "aruco")
SCENE_S = 10.0  # each tier's scene time: the frames are spread evenly over it


def run_cell(job: tuple[str, float, float, int]) -> dict:
    """One tier at one range and angle: per-frame records of both banners' perception.

    Parameters
    ----------
    job : (tier, range_m, angle_deg, n_frames)
        The cell and how many frames to spread over the tier's scene.
    """
    tier, range_m, angle_deg, n_frames = job
    seq = make_sequence(tier, 0, int(SCENE_S * FPS))
    # the tiers' back wall stands 7 m out and a box may stand on the line of sight 4 m out:
    # the wall goes behind the farthest leader, the boxes at least 1 m to the side
    props = tuple(
        dataclasses.replace(p, north_m=max(p.north_m, range_m + 3.0))
        if p.kind == "wall"
        else dataclasses.replace(p, east_m=math.copysign(max(abs(p.east_m), 1.0), p.east_m))
        if p.kind == "box"
        else p
        for p in seq.scene.props
    )
    scene = dataclasses.replace(seq.scene, props=props)
    banners = {"markers": seq.banner, "aruco": dataclasses.replace(seq.banner, kind="aruco")}
    renderers = {k: Renderer(seq.camera, b, scene, seq.seed) for k, b in banners.items()}
    perceptions = {k: BannerPerception.from_config(seq.camera, b, kind="full") for k, b in banners.items()}
    me = VehiclePose(0.0, 0.0, 0.0, banner=False)
    leader = VehiclePose(range_m, 0.0, math.radians(angle_deg))
    rec: dict[str, dict[str, list]] = {k: {"range_m": [], "bearing_rad": [], "ms": []} for k in METHODS}
    vis, truth_range, truth_bearing = [], 0.0, 0.0
    for i in range(n_frames):
        t = i * SCENE_S / n_frames
        for k in METHODS:
            frame, truth = renderers[k].render(t, me, [leader], 0, "follower")
            t0 = time.perf_counter()
            m = perceptions[k].step(t, frame).measurement
            rec[k]["ms"].append((time.perf_counter() - t0) * 1000)
            rec[k]["range_m"].append(m.range_m if m.range_m is not None else math.nan)
            rec[k]["bearing_rad"].append(m.bearing_rad if m.range_m is not None else math.nan)
        vis.append(truth.visible_fraction)  # the same panel, place and occluders for both
        truth_range, truth_bearing = truth.range_m, truth.bearing_rad
    return {
        "tier": tier,
        "range_m": range_m,
        "angle_deg": angle_deg,
        "vis": vis,
        "truth_range_m": truth_range,
        "truth_bearing_rad": truth_bearing,
        "rec": rec,
    }


def _stats(cells: list[dict], method: str) -> dict[str, float | int | None]:
    """Detection rate, median range error (%), median bearing error (deg), median ms/frame."""
    det, rng_err, brg_err, ms, hidden_poses = [], [], [], [], 0
    for c in cells:
        vis = np.array(c["vis"])
        r = np.array(c["rec"][method]["range_m"])
        b = np.array(c["rec"][method]["bearing_rad"])
        seen = np.isfinite(r)
        det.extend(seen[vis >= 0.5])
        hidden_poses += int(np.sum(seen & (vis < 0.05)))
        rng_err.extend(np.abs(r[seen] - c["truth_range_m"]) / c["truth_range_m"] * 100)
        brg_err.extend(np.degrees(np.abs(b[seen] - c["truth_bearing_rad"])))
        ms.extend(c["rec"][method]["ms"])

    def med(x: list) -> float | None:
        return round(float(np.median(x)), 3) if x else None

    return {
        "detection": round(float(np.mean(det)), 3) if det else None,
        "scored_frames": len(det),
        "range_err_median_pct": med(rng_err),
        "bearing_err_median_deg": med(brg_err),
        "ms_median": med(ms),
        "poses_while_hidden": hidden_poses,
    }


def compare(quick: bool = False) -> dict:
    """Run every cell, print the two tables, return the figures (for the JSON line).

    Parameters
    ----------
    quick : bool
        24 frames per cell instead of 90.
    """
    n_frames = 24 if quick else 90
    jobs = [(t, r, a, n_frames) for t in TIERS for r in RANGES_M for a in ANGLES_DEG]
    workers = max(1, min(len(jobs), os.cpu_count() or 1))
    with ProcessPoolExecutor(workers) as pool:
        cells = list(pool.map(run_cell, jobs))
    by_pose, rows = {}, []
    for r in RANGES_M:
        for a in ANGLES_DEG:
            sel = [c for c in cells if c["range_m"] == r and c["angle_deg"] == a]
            s = {k: _stats(sel, k) for k in METHODS}
            by_pose[f"{r:g}m_{a:g}deg"] = s
            rows.append((r, a, *_side_by_side(s, _ACCURACY)))
    print("ArUco banner vs CAMShift + markers (tiers clear, lighting, occlusion pooled; the leader still)")
    print_table(("range m", "angle deg", *_side_by_side_names(_ACCURACY)), rows)
    print()
    by_tier, rows = {}, []
    for t in TIERS:
        sel = [c for c in cells if c["tier"] == t]
        s = {k: _stats(sel, k) for k in METHODS}
        by_tier[t] = s
        rows.append((t, *_side_by_side(s, _PER_TIER)))
    print_table(("tier", *_side_by_side_names(_PER_TIER)), rows)
    print(
        f"detect: frames with a pose of those whose banner is >= 50 % in view; errors: medians over those "
        f"poses; {n_frames} frames per cell over the tier's {SCENE_S:g} s; ms/frame: perception only, "
        f"median, {workers} workers sharing the machine"
    )
    return {
        "frames_per_cell": n_frames,
        "ranges_m": list(RANGES_M),
        "angles_deg": list(ANGLES_DEG),
        "tiers": list(TIERS),
        "by_pose": by_pose,
        "by_tier": by_tier,
    }


#: the figures shown for both methods side by side: (key in _stats, column name)
_ACCURACY = (
    ("detection", "detect"),
    ("range_err_median_pct", "range err %"),
    ("bearing_err_median_deg", "bearing err deg"),
)
_PER_TIER = (*_ACCURACY, ("ms_median", "ms/frame"))


def _side_by_side(stats: dict[str, dict[str, Any]], figures: tuple[tuple[str, str], ...]) -> list[Any]:
    return [stats[m][key] for key, _ in figures for m in METHODS]


def _side_by_side_names(figures: tuple[tuple[str, str], ...]) -> list[str]:
    return [f"{name} {m}" for _, name in figures for m in METHODS]


def main(quick: bool = False) -> None:
    """Run the ArUco section alone, print its tables and JSON line (``quick``: shorter runs)."""
    print_json("vision-aruco", compare(quick))


if __name__ == "__main__":
    run_as_script(main, __doc__)
