"""lfctl bench vision: the paper's tracker and its baselines against OpenCV's trackers on
rendered sequences with ground truth, and the renderer's own cost.

Tiers (lfctl/render/sequences.py) x seeds x 300 frames; every frame is rendered once and fed to
every tracker: hue-only CAMShift (the paper's baseline), H+S+LBP CAMShift without filters,
the full lfctl tracker, and OpenCV's TrackerMIL, TrackerKCF and TrackerCSRT (KCF and CSRT
need opencv-contrib-python-headless; see the README for the environment that has them).
All start from the true banner box in frame 0.

Per tier and tracker: success rate (IoU >= 0.5 over frames whose banner is at least half
visible), median centre error, frames to recover after a full occlusion, frames reported as
tracking while fully hidden, median ms per frame; for the full tracker also the pose error
of both estimators (range %, bearing deg; within 3 m).

Then the ArUco section (:mod:`lfctl.bench.vision_aruco`): an ArUco banner against the
paper's, detection and pose error against range and angle under the same tiers.
"""

from __future__ import annotations

import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import cv2
import numpy as np

from lfctl.bench.common import print_json, print_table
from lfctl.bench.vision_aruco import compare as aruco_compare
from lfctl.render.sequences import TIERS, make_sequence
from lfctl.vision.banner import BannerGeometry
from lfctl.vision.boxes import iou
from lfctl.vision.camera_model import CameraModel
from lfctl.vision.pose import paper_pose, pnp_pose, to_vehicle_frame
from lfctl.vision.track_state import TrackStatus
from lfctl.vision.tracker import Tracker, TrackerSettings

__all__ = ["main"]

OURS = ("hue", "hs-lbp", "full")


def peer_names() -> list[str]:
    names = ["MIL"]
    if hasattr(cv2, "TrackerKCF"):
        names.append("KCF")
    if hasattr(cv2, "TrackerCSRT"):
        names.append("CSRT")
    return names


def make_peer(name: str):
    return {
        "MIL": cv2.TrackerMIL.create,
        "KCF": lambda: cv2.TrackerKCF.create(),
        "CSRT": lambda: cv2.TrackerCSRT.create(),
    }[name]()


def run_job(job: tuple[str, int, int, tuple[str, ...]]) -> dict:
    """One tier at one seed: per-tracker frame records and the renderer's cost."""
    tier, seed, n_frames, peers = job
    seq = make_sequence(tier, seed, n_frames, realism="on")  # the realistic camera, photographed textures
    cam = CameraModel.from_config(seq.camera)
    trackers: dict[str, object] = {k: Tracker(TrackerSettings(kind=k)) for k in OURS}
    for p in peers:
        trackers[p] = make_peer(p)
    rec: dict[str, dict[str, list]] = {k: {"iou": [], "err": [], "tracking": [], "ms": []} for k in trackers}
    truth_vis, truth_valid = [], []
    pose_err: dict[str, list] = {"paper": [], "pnp": []}
    render_ms = []
    init_failed: list[str] = []
    frames = seq.frames()
    for i in range(n_frames):
        t0 = time.perf_counter()
        _t, frame, truth = next(frames)
        render_ms.append((time.perf_counter() - t0) * 1000)
        if i == 0:
            for k, tr in list(trackers.items()):
                try:
                    tr.init(frame, truth.bbox)  # type: ignore[attr-defined]
                except cv2.error as exc:  # a peer that refuses to start fails the whole sequence
                    trackers[k] = None  # type: ignore[assignment]
                    init_failed.append(f"{k}@{tier}/{seed}: {str(exc).splitlines()[-1][:80]}")
            continue
        truth_vis.append(truth.visible_fraction)
        truth_valid.append(truth.bbox is not None and truth.visible_fraction >= 0.5)
        for k, tr in trackers.items():
            if tr is None:
                rec[k]["ms"].append(math.nan)
                rec[k]["tracking"].append(False)
                rec[k]["iou"].append(0.0)
                rec[k]["err"].append(math.nan)
                continue
            t0 = time.perf_counter()
            if k in OURS:
                st = tr.update(frame)  # type: ignore[attr-defined]
                box, tracking = st.bbox, st.status is TrackStatus.TRACKING
            else:
                ok, b = tr.update(frame)  # type: ignore[attr-defined]
                box, tracking = (tuple(int(v) for v in b) if ok else None), bool(ok)
            rec[k]["ms"].append((time.perf_counter() - t0) * 1000)
            rec[k]["tracking"].append(tracking)
            if box is not None and truth.bbox is not None and box[2] > 0 and box[3] > 0:
                rec[k]["iou"].append(iou(box, truth.bbox))
                tc = (truth.bbox[0] + truth.bbox[2] / 2, truth.bbox[1] + truth.bbox[3] / 2)
                rec[k]["err"].append(math.hypot(box[0] + box[2] / 2 - tc[0], box[1] + box[3] / 2 - tc[1]))
            else:
                rec[k]["iou"].append(0.0)
                rec[k]["err"].append(math.nan)
            if k == "full" and st.markers is not None and truth.range_m <= 3.0:
                for est in (
                    paper_pose(st.markers, cam.K, seq.banner.side_m),
                    pnp_pose(st.markers, cam.K, None, seq.banner.side_m),
                ):
                    if est is None:
                        continue
                    r, b_, _ = to_vehicle_frame(
                        est, cam.mount_body_m, cam.R_body_from_cam, BannerGeometry.from_config(seq.banner).back_m
                    )
                    pose_err[est.method].append(
                        ((r - truth.range_m) / truth.range_m, math.degrees(b_ - truth.bearing_rad))
                    )
    return {
        "tier": tier,
        "seed": seed,
        "rec": rec,
        "vis": truth_vis,
        "valid": truth_valid,
        "pose": pose_err,
        "render_ms": render_ms,
        "init_failed": init_failed,
    }


def timing_pass(tier: str, n_frames: int, peers: tuple[str, ...]) -> dict[str, float]:
    """Median ms per frame of the renderer and of each tracker alone on the same pre-rendered
    frames, in one process (the accuracy runs share the cores, which inflates their timings)."""
    seq = make_sequence(tier, 0, n_frames, realism="on")
    frames, render = [], []
    it = seq.frames()
    for _ in range(n_frames):
        t0 = time.perf_counter()
        _t, frame, truth = next(it)
        render.append((time.perf_counter() - t0) * 1000)
        frames.append((frame, truth))
    out = {"renderer": float(np.median(render))}
    for k in (*OURS, *peers):
        tr = Tracker(TrackerSettings(kind=k)) if k in OURS else make_peer(k)
        try:
            tr.init(frames[0][0], frames[0][1].bbox)
        except cv2.error:
            out[k] = math.nan
            continue
        ms = []
        for frame, _ in frames[1:]:
            t0 = time.perf_counter()
            tr.update(frame)
            ms.append((time.perf_counter() - t0) * 1000)
        out[k] = float(np.median(ms))
    return out


def recovery_frames(vis: list[float], ious: list[float]) -> list[int]:
    """For each full occlusion (visible < 5 %), frames from its end until IoU >= 0.5 again."""
    out = []
    i, n = 0, len(vis)
    while i < n:
        if vis[i] < 0.05:
            j = i
            while j < n and vis[j] < 0.05:
                j += 1
            if j - i >= 10 and j < n:  # a real full occlusion, not a flicker
                k = j
                while k < n and ious[k] < 0.5:
                    k += 1
                out.append(k - j if k < n else n - j)
            i = j
        else:
            i += 1
    return out


def main(quick: bool = False) -> None:
    """Run the benchmark, print its table and JSON line (``quick``: shorter runs)."""
    n_frames = 90 if quick else 300
    seeds = (0,) if quick else (0, 1, 2)
    peers = tuple(peer_names())
    jobs = [(tier, seed, n_frames, peers) for tier in TIERS for seed in seeds]
    workers = max(1, min(len(jobs), os.cpu_count() or 1))
    with ProcessPoolExecutor(workers) as pool:
        results = list(pool.map(run_job, jobs))
    timing = {tier: timing_pass(tier, 60 if quick else 150, peers) for tier in TIERS}
    names = [*OURS, *peers]
    rows, out = [], {}
    for tier in TIERS:
        rs = [r for r in results if r["tier"] == tier]
        out[tier] = {}
        for k in names:
            valid = np.concatenate([np.array(r["valid"]) for r in rs])
            ious = np.concatenate([np.array(r["rec"][k]["iou"]) for r in rs])
            errs = np.concatenate([np.array(r["rec"][k]["err"]) for r in rs])
            tracking = np.concatenate([np.array(r["rec"][k]["tracking"]) for r in rs])
            vis = np.concatenate([np.array(r["vis"]) for r in rs])
            ms = np.concatenate([np.array(r["rec"][k]["ms"]) for r in rs])
            rec = [f for r in rs for f in recovery_frames(r["vis"], r["rec"][k]["iou"])]
            success = float(np.mean(ious[valid] >= 0.5)) if valid.any() else math.nan
            ce = errs[valid]
            ce = ce[np.isfinite(ce)]
            hidden = vis < 0.05
            entry = {
                "success": round(success, 3),
                "median_centre_error_px": round(float(np.median(ce)), 2) if ce.size else None,
                "recovery_frames_max": int(max(rec)) if rec else None,
                "false_tracking_while_hidden": int(np.sum(tracking & hidden)),
                "hidden_frames": int(hidden.sum()),
                "median_ms": round(timing[tier][k], 3) if math.isfinite(timing[tier][k]) else None,
                "median_ms_under_load": round(float(np.nanmedian(ms)), 3) if np.isfinite(ms).any() else None,
            }
            if k == "full":
                for m in ("paper", "pnp"):
                    e = np.array([x for r in rs for x in r["pose"][m]])
                    entry[f"pose_{m}_range_rms_pct"] = (
                        round(float(np.sqrt(np.mean(e[:, 0] ** 2)) * 100), 3) if e.size else None
                    )
                    entry[f"pose_{m}_bearing_rms_deg"] = (
                        round(float(np.sqrt(np.mean(e[:, 1] ** 2))), 3) if e.size else None
                    )
            out[tier][k] = entry
            rows.append(
                (
                    tier,
                    k,
                    entry["success"],
                    entry["median_centre_error_px"],
                    entry["recovery_frames_max"],
                    f"{entry['false_tracking_while_hidden']}/{entry['hidden_frames']}",
                    entry["median_ms"],
                )
            )
    print_table(
        ("tier", "tracker", "success", "centre err px", "recover frames", "tracking while hidden", "ms/frame"), rows
    )
    print()
    pose_rows = [
        (
            t,
            out[t]["full"]["pose_paper_range_rms_pct"],
            out[t]["full"]["pose_paper_bearing_rms_deg"],
            out[t]["full"]["pose_pnp_range_rms_pct"],
            out[t]["full"]["pose_pnp_bearing_rms_deg"],
        )
        for t in TIERS
    ]
    print_table(
        ("tier", "paper range RMS %", "paper bearing RMS deg", "PnP range RMS %", "PnP bearing RMS deg"), pose_rows
    )
    failed = [f for r in results for f in r["init_failed"]]
    if failed:
        print("trackers that refused to initialise (scored as failing those sequences):", "; ".join(failed))
    render = np.array([timing[t]["renderer"] for t in TIERS])
    per_tier = ", ".join(f"{t} {timing[t]['renderer']:.2f}" for t in TIERS)
    print(f"\nrenderer: median over tiers {np.median(render):.2f} ms/frame (per tier: {per_tier}), 640x480")
    print("ms/frame: each tracker alone on the same pre-rendered frames, one process")
    full_ms = float(np.median([timing[t]["full"] for t in TIERS]))
    summary = {
        "full_min_success": min(out[t]["full"]["success"] for t in TIERS),
        "hue_only_distractor_success": out["distractor"]["hue"]["success"],
        "full_max_recovery_frames": out["occlusion"]["full"]["recovery_frames_max"],
        "full_median_ms": round(full_ms, 3),
        "renderer_median_ms": round(float(np.median(render)), 3),
    }
    if "CSRT" in peers:
        csrt_ms = float(np.nanmedian([timing[t]["CSRT"] for t in TIERS]))
        summary["csrt_over_full_speed_ratio"] = round(csrt_ms / full_ms, 1)
    else:
        print(
            "KCF/CSRT: not in this OpenCV build (opencv-python-headless); run in an environment with opencv-contrib-python-headless (README)"
        )
    print("summary:", summary)
    print()
    aruco = aruco_compare(quick)
    print_json(
        "vision",
        {
            "frames_per_sequence": n_frames,
            "seeds": list(seeds),
            "peers": list(peers),
            "tiers": out,
            "summary": summary,
            "aruco": aruco,
        },
    )


if __name__ == "__main__":
    main("--quick" in sys.argv)
