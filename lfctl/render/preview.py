"""Before / after pictures of the simulated camera: ``python -m lfctl.render.preview OUTDIR``.

For a few views of the vision benchmark's rendered tiers (:mod:`lfctl.render.sequences`) it
writes ``<view>-before.png`` (``scene.realism = "off"``: the flat look lfctl drew before),
``<view>-after.png`` (``scene.realism = "on"``, the realistic look the tiers use) and ``<view>-compare.png`` (both, side by
side). Deterministic for a seed.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import cv2
import numpy as np

from lfctl.render.renderer import Renderer, VehiclePose
from lfctl.render.sequences import make_sequence

__all__ = ["VIEWS", "main", "render_view"]

#: view name -> (tier, frame index): the leader ahead; very near and turned; a panel passing
#: in front; after the light dropped and turned warm; a same-hue distractor beside the banner
VIEWS = {
    "clear": ("clear", 45),
    "near": ("range", 14),
    "occlusion": ("occlusion", 135),
    "lighting": ("lighting", 200),
    "distractor": ("distractor", 150),
}


def render_view(tier: str, frame: int, seed: int, realism: str) -> np.ndarray:
    """Frame ``frame`` of a tier's sequence, rendered with ``scene.realism = realism``
    (every earlier frame is rendered too: auto-exposure and occluders have state).

    Parameters
    ----------
    tier : str
        A tier of :data:`lfctl.render.sequences.TIERS`.
    frame : int
        The frame's index (30 per second).
    seed : int
        The sequence's seed.
    realism : str
        ``"on"`` or ``"off"``.
    """
    seq = make_sequence(tier, seed, frame + 1)
    scene = dataclasses.replace(seq.scene, realism=realism)
    renderer = Renderer(seq.camera, seq.banner, scene, seed)
    follower = VehiclePose(0.0, 0.0, 0.0, banner=False)
    img = None
    for k in range(frame + 1):
        t = k / 30.0
        img, _truth = renderer.render(t, follower, [seq.leader(t)], 0, "follower")
    assert img is not None
    return img


def main(argv: list[str] | None = None) -> int:
    """Write the before / after PNGs; returns the exit code.

    Parameters
    ----------
    argv : list of str, optional
        ``OUTDIR [--seed N] [--view NAME ...]`` (default: the command line).
    """
    ap = argparse.ArgumentParser(prog="python -m lfctl.render.preview", description=__doc__.splitlines()[0])
    ap.add_argument("outdir", type=Path, help="folder to write the PNGs to (made if missing)")
    ap.add_argument("--seed", type=int, default=0, help="sequence seed (default 0)")
    ap.add_argument("--view", action="append", choices=sorted(VIEWS), help="one view (repeatable; default all)")
    args = ap.parse_args(argv)
    if not 0 <= args.seed <= 2**31:
        ap.error("--seed must be within 0..2147483648")
    args.outdir.mkdir(parents=True, exist_ok=True)
    for name in args.view or list(VIEWS):
        tier, frame = VIEWS[name]
        before = render_view(tier, frame, args.seed, "off")
        after = render_view(tier, frame, args.seed, "on")
        cv2.imwrite(str(args.outdir / f"{name}-before.png"), before)
        cv2.imwrite(str(args.outdir / f"{name}-after.png"), after)
        gap = np.full((before.shape[0], 8, 3), 255, np.uint8)
        cv2.imwrite(str(args.outdir / f"{name}-compare.png"), np.hstack([before, gap, after]))
        print(f"{name}: {args.outdir / name}-before.png, -after.png, -compare.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
