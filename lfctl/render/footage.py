"""Photographed textures for the rendered scene, cut from the real footage that ships with
lfctl (``footage/``, see its README for where each video comes from and its licence).

``vtest.avi`` (OpenCV's sample: a campus yard filmed from a first floor) gives the ground
(asphalt, grass) and the walls (a brick facade): its median over the whole video is a clean
plate without the walking people. ``bikes.mp4`` (a street at dusk) and the top of the yard
give the distant background. Each photograph is cut, made to tile without seams and kept in
a pool; the renderer picks from the pool with its seed, so seeds vary the domain.

Decoding takes about half a second, once: the plates are kept in memory and in the user
cache directory (``~/.cache/lfctl/textures`` on Linux, as the FMU cache), keyed by the
videos' sizes and :data:`VERSION`. Without the footage (a trimmed install) :func:`plates`
returns None and the renderer draws procedural textures instead.
"""

from __future__ import annotations

import functools
import os
import tempfile
from pathlib import Path

import cv2
import numpy as np

from lfctl.data import footage_dir, user_cache

__all__ = ["VERSION", "Plates", "cache_dir", "close_loop", "make_periodic", "plates"]

#: bump when the crops or their processing change, to invalidate cached plates
VERSION = 2

# crops of the vtest median plate (768 x 576): x0, y0, x1, y1
_ASPHALT = ((480, 245, 690, 340), (300, 255, 420, 330), (540, 345, 700, 420))
_GRASS = ((180, 470, 470, 576), (100, 340, 330, 440))
_FACADE = ((440, 0, 600, 106), (0, 0, 105, 50))
_YARD_TOP = (0, 0, 768, 140)
_BIKES_FRAMES = (30, 150, 240)  # frames of bikes.mp4 for the background, rows 0..200


class Plates:
    """The photographs, cut: each attribute a list of BGR uint8 images to choose from.

    Parameters
    ----------
    asphalt, grass, facade : list of np.ndarray
        Ground and wall photographs, each tileable (periodic).
    background : np.ndarray
        A 360-degree panorama of the distant scene, tileable along x.
    """

    def __init__(
        self, asphalt: list[np.ndarray], grass: list[np.ndarray], facade: list[np.ndarray], background: np.ndarray
    ) -> None:
        self.asphalt = asphalt
        self.grass = grass
        self.facade = facade
        self.background = background


def cache_dir() -> Path:
    """Where cut plates are kept: the user cache directory (``~/.cache/lfctl/textures``)."""
    return user_cache("textures")


def make_periodic(img: np.ndarray, axes: tuple[int, ...] = (0, 1)) -> np.ndarray:
    """The image made to tile without seams: along each axis it is cross-faded with itself
    shifted by half a period, the weight going to the shifted copy at the edges.

    Parameters
    ----------
    img : np.ndarray
        A BGR image.
    axes : tuple of int
        0 for y (rows), 1 for x (columns).
    """
    out = img.astype(np.float32)
    for axis in axes:
        n = out.shape[axis]
        w = np.sin(np.pi * (np.arange(n) + 0.5) / n) ** 2
        shape = [1, 1, 1]
        shape[axis] = n
        w = w.reshape(shape).astype(np.float32)
        rolled = np.roll(out, n // 2, axis=axis)
        blend = out * w + rolled * (1 - w)
        # a cross-fade of two unrelated patches loses contrast mid-way: restore the spread
        mean = out.mean(axis=(0, 1), keepdims=True)
        gain = np.sqrt(w**2 + (1 - w) ** 2)
        out = mean + (blend - mean) / gain
    return np.clip(out, 0, 255).astype(np.uint8)


def _read_frames(path: Path, wanted: set[int] | None, every: int = 1) -> list[np.ndarray]:
    cap = cv2.VideoCapture(str(path))
    frames, i = [], 0
    try:
        while True:
            ok = cap.grab()
            if not ok:
                break
            if (wanted is None and i % every == 0) or (wanted is not None and i in wanted):
                ok, f = cap.retrieve()
                if ok:
                    frames.append(f)
            i += 1
            if wanted is not None and i > max(wanted):
                break
    finally:
        cap.release()
    return frames


def _cut(folder: Path) -> dict[str, np.ndarray]:
    """Decode the videos and cut every plate (about half a second)."""
    yard = _read_frames(folder / "vtest.avi", None, every=53)
    if not yard:
        raise OSError("vtest.avi gave no frames")
    stack = np.stack(yard)
    half = len(yard) // 2

    def median(x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
        # the per-pixel median over the video: the people walk away
        return np.partition(stack[:, y0:y1, x0:x1], half, axis=0)[half]

    out: dict[str, np.ndarray] = {}
    for name, boxes in (("asphalt", _ASPHALT), ("grass", _GRASS), ("facade", _FACADE)):
        for k, box in enumerate(boxes):
            crop = median(*box)
            if name != "facade":
                # the yard is filmed at a slant: a crop's far rows are squeezed; square it up
                side = max(crop.shape[:2])
                crop = cv2.resize(crop, (side, side), interpolation=cv2.INTER_CUBIC)
            out[f"{name}{k}"] = make_periodic(crop, (0, 1) if name != "facade" else (1,))
    # the background: the yard's far side, then the street, cross-faded into one loop
    strips = [median(*_YARD_TOP)]
    street = _read_frames(folder / "bikes.mp4", set(_BIKES_FRAMES))
    strips += [f[0:200] for f in street]
    strips.insert(2, cv2.flip(strips[0], 1))
    height = 200
    strips = [cv2.resize(s, (round(s.shape[1] * height / s.shape[0]), height), interpolation=cv2.INTER_AREA) for s in strips]  # fmt: skip
    pano = strips[0].astype(np.float32)
    fade = 48
    ramp = np.linspace(0, 1, fade, dtype=np.float32)[None, :, None]
    for s in strips[1:]:
        s = s.astype(np.float32)
        mixed = pano[:, -fade:] * (1 - ramp) + s[:, :fade] * ramp
        pano = np.concatenate([pano[:, :-fade], mixed, s[:, fade:]], axis=1)
    out["background"] = close_loop(np.clip(pano, 0, 255).astype(np.uint8), fade)
    return out


def close_loop(strip: np.ndarray, fade: int) -> np.ndarray:
    """A strip made to tile along x by cross-fading its last ``fade`` columns into its first
    ones (and dropping them): only the join is blended, the rest stays the photograph
    (:func:`make_periodic` would blend the whole strip with itself: ghosts everywhere).

    Parameters
    ----------
    strip : np.ndarray
        A BGR image wider than ``2 * fade``.
    fade : int
        Width of the cross-fade, px.
    """
    ramp = np.linspace(0, 1, fade, dtype=np.float32)[None, :, None]
    out = strip[:, :-fade].copy()
    mixed = strip[:, -fade:].astype(np.float32) * (1 - ramp) + strip[:, :fade].astype(np.float32) * ramp
    out[:, :fade] = np.clip(np.round(mixed), 0, 255).astype(np.uint8)
    return out


def _cache_key(folder: Path) -> str:
    sizes = "-".join(str((folder / n).stat().st_size) for n in ("vtest.avi", "bikes.mp4"))
    return f"v{VERSION}-{sizes}"


@functools.cache
def plates() -> Plates | None:
    """The photographed plates (cut once per process, and kept on disk), or None when the
    footage is not installed or cannot be decoded."""
    folder = footage_dir()
    try:
        key = _cache_key(folder)
    except OSError:
        return None
    cache = cache_dir() / key
    names = [f"asphalt{k}" for k in range(len(_ASPHALT))] + [f"grass{k}" for k in range(len(_GRASS))]
    names += [f"facade{k}" for k in range(len(_FACADE))] + ["background"]
    cut: dict[str, np.ndarray] = {}
    if all((cache / f"{n}.png").is_file() for n in names):
        for n in names:
            img = cv2.imread(str(cache / f"{n}.png"), cv2.IMREAD_COLOR)
            if img is None:
                cut = {}
                break
            cut[n] = img
    if not cut:
        try:
            cut = _cut(folder)
        except (OSError, cv2.error):
            return None
        try:  # best effort: another process may write the same files; each lands whole
            cache.mkdir(parents=True, exist_ok=True)
            for n, img in cut.items():
                fd, tmp = tempfile.mkstemp(suffix=".png", dir=cache)
                os.close(fd)
                cv2.imwrite(tmp, img)
                os.replace(tmp, cache / f"{n}.png")
        except OSError:
            pass
    return Plates(
        [cut[f"asphalt{k}"] for k in range(len(_ASPHALT))],
        [cut[f"grass{k}"] for k in range(len(_GRASS))],
        [cut[f"facade{k}"] for k in range(len(_FACADE))],
        cut["background"],
    )
