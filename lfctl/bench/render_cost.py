"""What each of the renderer's realistic effects costs: CPU milliseconds per 640 x 480 frame
on one core (the rendering thread's CPU time, so time lost to other programs on a shared
machine is not counted), every variant in the same run against the same baseline.

The scene is the camera convoy's (examples/convoy.toml: the leader 1.5 m ahead, a wall and a
red box beyond it, a cloud's shadow), its view turning slowly while the renderer is told
of a 0.5 rad/s yaw rate, so motion blur and the rolling shutter have something to do. Variants render in interleaved blocks, so a change in the
machine's load falls on all of them alike; each figure is a median over every frame.

- ``off``: ``scene.realism = "off"``, the flat look (the baseline, and the default);
- ``on``: ``scene.realism = "on"`` with its default effects;
- ``on, bare``: ``"on"`` with every optional effect off (the geometry: shaded rover with
  wheels and contact patch, printed banner, full-resolution floor, procedural textures);
- one row per effect: its cost is ``on`` minus ``on`` without it (effects on by default)
  or ``on`` with it minus ``on`` (effects off by default).

Run alone with ``python -m lfctl.bench.render_cost [--quick]``; ``lfctl bench e2e`` runs it
as its last section.
"""

from __future__ import annotations

import dataclasses
import math
import os
import statistics
import time
from collections.abc import Callable

import cv2

from lfctl.bench.common import print_json, print_table, run_as_script
from lfctl.config import BannerConfig, CameraConfig, SceneConfig, load_config
from lfctl.data import examples_dir
from lfctl.render.renderer import Renderer, VehiclePose

__all__ = ["EFFECTS", "effect_costs", "main"]

Variant = tuple[CameraConfig, BannerConfig, SceneConfig]
Change = Callable[[CameraConfig, BannerConfig, SceneConfig], Variant]


def _cam(**kw: object) -> Change:
    return lambda c, b, s: (dataclasses.replace(c, **kw), b, s)


def _banner(**kw: object) -> Change:
    return lambda c, b, s: (c, dataclasses.replace(b, **kw), s)


def _scene(**kw: object) -> Change:
    return lambda c, b, s: (c, b, dataclasses.replace(s, **kw))


#: effect -> (on by default with realism "on", the change that toggles it away from the default)
EFFECTS: dict[str, tuple[bool, Change]] = {
    "cast shadows (sun)": (True, _scene(shadows=False)),
    "cloud shadow (shadow_gain 0.8)": (True, _scene(shadow_gain=1.0)),
    "banner glare (gloss)": (True, _banner(gloss=0.0)),
    "banner thickness": (True, _banner(thickness_m=0.0)),
    "auto-exposure": (True, _cam(auto_exposure=False)),
    "white-balance drift": (True, _cam(white_balance_drift=0.0)),
    "vignetting": (True, _cam(vignetting=0.0)),
    "shot noise": (True, _cam(shot_noise=0.0)),
    "read noise": (True, _cam(noise_sigma=0.0)),
    "vignetting + shot noise": (True, _cam(vignetting=0.0, shot_noise=0.0)),
    "photographed textures (footage)": (False, _scene(textures="footage")),
    "JPEG (quality 80)": (False, _cam(jpeg_quality=80)),
    "rolling shutter (30 ms)": (False, _cam(rolling_shutter_s=0.03)),
    "motion blur": (False, _cam(motion_blur=True)),
    # a webcam's calibration: the frame drawn on the lens's canvas and bent (lfctl.render.lens)
    "lens distortion (k1 -0.12, k2 0.03)": (False, _cam(k1=-0.12, k2=0.03)),
}


def _bare(c: CameraConfig, b: BannerConfig, s: SceneConfig) -> Variant:
    cam = dataclasses.replace(
        c, shot_noise=0.0, noise_sigma=0.0, auto_exposure=False, white_balance_drift=0.0, vignetting=0.0
    )
    return (
        cam,
        dataclasses.replace(b, gloss=0.0, thickness_m=0.0),
        dataclasses.replace(s, shadows=False, shadow_gain=1.0),
    )


def _time_block(renderer: Renderer, start: int, n: int, out: list[float]) -> None:
    follower_yaw_rate = 0.5
    for k in range(start, start + n):
        t = k / 30.0
        yaw = follower_yaw_rate * t * 0.1  # a slow turn: the view changes, the scene stays in sight
        me = VehiclePose(0.0, 0.0, yaw, banner=False)
        lead = VehiclePose(1.5 * math.cos(yaw), 1.5 * math.sin(yaw) + 0.1 * math.sin(t), yaw + 0.2 * math.sin(0.7 * t))
        t0 = time.thread_time()
        renderer.render(t, me, [lead], 0, "follower1", follower_yaw_rate)
        out.append(time.thread_time() - t0)


def effect_costs(frames: int = 240, block: int = 4) -> dict[str, object]:
    """Render every variant ``frames`` times (in interleaved blocks of ``block``) on one core
    and return the medians, ms per frame, and each effect's cost against its reference.

    Parameters
    ----------
    frames : int
        Frames per variant.
    block : int
        Frames rendered per variant before moving to the next.
    """
    cfg = load_config(examples_dir() / "convoy.toml")
    base = (dataclasses.replace(cfg.camera, width_px=640, height_px=480), cfg.banner, cfg.scene)
    on = (base[0], base[1], dataclasses.replace(base[2], realism="on"))
    variants: dict[str, Variant] = {
        "off": (base[0], base[1], dataclasses.replace(base[2], realism="off")),
        "on": on,
        "on, bare": _bare(*on),
    }
    for name, (_default, change) in EFFECTS.items():
        variants[name] = change(*on)
    renderers = {name: Renderer(*v, seed=7) for name, v in variants.items()}
    times: dict[str, list[float]] = {name: [] for name in variants}
    cpus = os.sched_getaffinity(0)
    threads = cv2.getNumThreads()
    os.sched_setaffinity(0, {min(cpus)})
    cv2.setNumThreads(1)
    load_before = os.getloadavg()[0]
    try:
        for start in range(0, frames, block):
            for name, r in renderers.items():
                _time_block(r, start, min(block, frames - start), times[name])
    finally:
        os.sched_setaffinity(0, cpus)
        cv2.setNumThreads(threads)
    ms = {name: 1e3 * statistics.median(t) for name, t in times.items()}
    costs = {}
    for name, (default, _change) in EFFECTS.items():
        costs[name] = ms["on"] - ms[name] if default else ms[name] - ms["on"]
    return {
        "frames_per_variant": frames,
        "load_1min": [round(load_before, 2), round(os.getloadavg()[0], 2)],
        "median_ms": {k: round(v, 3) for k, v in ms.items()},
        "cost_ms": {k: round(v, 3) for k, v in costs.items()},
        "on_by_default": {k: d for k, (d, _c) in EFFECTS.items()},
    }


def print_costs(result: dict[str, object]) -> None:
    """The cost table of :func:`effect_costs`'s result."""
    ms = result["median_ms"]
    costs = result["cost_ms"]
    defaults = result["on_by_default"]
    assert isinstance(ms, dict) and isinstance(costs, dict) and isinstance(defaults, dict)
    off = ms["off"]
    rows: list[tuple[object, ...]] = [
        ('realism "off" (baseline)', "", round(off, 2), ""),
        ('realism "on", bare (geometry, full-res floor)', "", round(ms["on, bare"], 2), round(ms["on, bare"] - off, 2)),
        ('realism "on", its defaults', "", round(ms["on"], 2), round(ms["on"] - off, 2)),
    ]
    for name, cost in costs.items():
        rows.append((name, "on" if defaults[name] else "off", round(ms[name], 2), round(cost, 2)))
    print_table(("variant / effect", 'default with "on"', "ms/frame", "cost, ms/frame"), rows)
    lo, hi = result["load_1min"]
    print(f"\n640 x 480, one core, median of {result['frames_per_variant']} frames per row; load average {lo}-{hi}")
    print('an effect\'s cost: "on" minus "on" without it (on by default), or with it minus "on" (off by default)')


def main(quick: bool = False) -> None:
    """Run the measurement, print the table and the JSON line (``quick``: fewer frames)."""
    result = effect_costs(frames=60 if quick else 240)
    print_costs(result)
    print_json("render_cost", result)


if __name__ == "__main__":
    run_as_script(main, __doc__)
