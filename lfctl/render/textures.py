"""Procedural textures for the rendered scene, seeded: the banner, the floor, props and
occluders. Periodic where they tile (the floor), so no seams show.
"""

from __future__ import annotations

import colorsys
from collections.abc import Sequence

import cv2
import numpy as np

from lfctl.config import BannerConfig, PropConfig

__all__ = [
    "TEX_PX_PER_M",
    "banner_texture",
    "ground_texture",
    "hue_bgr",
    "noise_texture",
    "periodic_pyramid",
    "prop_texture",
]

TEX_PX_PER_M = 800.0  # banner texture resolution, px per m


def hue_bgr(hue_deg: float, saturation: float, value: float) -> tuple[int, int, int]:
    """BGR (0..255 each) of an HSV colour.

    Parameters
    ----------
    hue_deg : float
        Hue, degrees (wrapped to 0..360).
    saturation, value : float
        Saturation and value, 0..1.
    """
    r, g, b = colorsys.hsv_to_rgb((hue_deg % 360) / 360.0, saturation, value)
    return int(round(b * 255)), int(round(g * 255)), int(round(r * 255))


def noise_texture(
    rng: np.random.Generator, h: int, w: int, base: Sequence[int], amplitude: float, blur: int
) -> np.ndarray:
    """A BGR texture: a flat colour plus grey Gaussian noise, periodic (it tiles without seams).

    Parameters
    ----------
    rng : np.random.Generator
        The noise's random stream.
    h, w : int
        Size, px.
    base : sequence of 3 int
        The colour, BGR 0..255.
    amplitude : float
        Standard deviation of the noise, digital numbers (kept after blurring).
    blur : int
        Gaussian blur sigma of the noise, px: the grain size (1 or less: none).
    """
    n = rng.normal(0.0, amplitude, (h, w)).astype(np.float32)
    if blur > 1:
        # blur a 3x3 tiling and keep the middle: the texture stays periodic (no seams when tiled)
        n = cv2.GaussianBlur(np.tile(n, (3, 3)), (0, 0), blur)[h : 2 * h, w : 2 * w].copy()
        n *= amplitude / max(float(n.std()), 1e-6)
    tex = np.empty((h, w, 3), np.uint8)
    for c in range(3):
        tex[:, :, c] = np.clip(base[c] + n, 0, 255).astype(np.uint8)
    return tex


def banner_texture(cfg: BannerConfig, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The banner panel texture and its four marker centres in texture pixels (TL, TR, BR, BL).

    Parameters
    ----------
    cfg : BannerConfig
        Sizes and colours of the panel and markers.
    rng : np.random.Generator
        The panel noise's random stream.
    """
    size = int(round(cfg.panel_size_m * TEX_PX_PER_M))
    tex = noise_texture(rng, size, size, cfg.panel_bgr, 10.0, 1)
    # a printed pattern: fine diagonal hatching, the texture LBP keys on
    for k in range(-size, size, 9):
        cv2.line(tex, (k, 0), (k + size, size), tuple(int(c * 0.8) for c in cfg.panel_bgr), 2, cv2.LINE_AA)
    half = cfg.side_m / 2 * TEX_PX_PER_M
    m = cfg.marker_size_m / 2 * TEX_PX_PER_M
    c0 = size / 2
    centres = np.array([[c0 - half, c0 - half], [c0 + half, c0 - half], [c0 + half, c0 + half], [c0 - half, c0 + half]])
    colour = hue_bgr(cfg.marker_hue_deg, cfg.marker_saturation, 0.85)
    for cx, cy in centres:
        cv2.rectangle(
            tex, (int(round(cx - m)), int(round(cy - m))), (int(round(cx + m)), int(round(cy + m))), colour, -1
        )
    return tex, centres


def ground_texture(kind: str, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """A tileable ground texture and its resolution (px per m).

    Parameters
    ----------
    kind : str
        ``"checker"`` (0.5 m squares), ``"carpet"``, or anything else for concrete.
    rng : np.random.Generator
        The texture's random stream.
    """
    if kind == "checker":
        tile = np.kron((np.indices((8, 8)).sum(axis=0) % 2), np.ones((64, 64))).astype(np.uint8)
        tex = np.dstack([90 + 60 * tile] * 3).astype(np.uint8)
        return tex, 128.0  # 0.5 m squares
    if kind == "carpet":
        return noise_texture(rng, 512, 512, (70, 60, 110), 25.0, 2), 256.0
    return noise_texture(rng, 512, 512, (128, 130, 132), 18.0, 3), 128.0


def prop_texture(prop: PropConfig, banner: BannerConfig, rng: np.random.Generator) -> np.ndarray:
    """Texture of a prop panel by kind (see :class:`~lfctl.config.PropConfig`), 200 px per m.

    Parameters
    ----------
    prop : PropConfig
        The prop: its kind and size.
    banner : BannerConfig
        The banner, whose marker hue and panel colour distractors copy.
    rng : np.random.Generator
        The texture's random stream.
    """
    w = max(8, int(prop.width_m * 200))
    h = max(8, int(prop.height_m * 200))
    marker = hue_bgr(banner.marker_hue_deg, banner.marker_saturation, 0.85)
    if prop.kind == "distractor":
        # the markers' hue, flat, at a lower saturation (a red box is rarely the markers' red)
        return noise_texture(rng, h, w, hue_bgr(banner.marker_hue_deg, 0.6, 0.8), 3.0, 1)
    if prop.kind == "textured_distractor":
        # the markers' hue and saturation exactly; only its texture (hatching) differs
        tex = noise_texture(rng, h, w, marker, 6.0, 1)
        dark = tuple(int(c * 0.6) for c in marker)
        for k in range(0, w + h, 10):
            cv2.line(tex, (k, 0), (k - h, h), dark, 2, cv2.LINE_AA)
        return tex
    if prop.kind == "panel_clutter":
        return noise_texture(rng, h, w, banner.panel_bgr, 4.0, 1)
    if prop.kind == "wall":
        return noise_texture(rng, h, w, (150, 160, 170), 20.0, 4)
    return noise_texture(rng, h, w, (60, 110, 150), 15.0, 2)  # box: cardboard


def periodic_pyramid(tex: np.ndarray, levels: int) -> list[np.ndarray]:
    """Mip levels of a periodic texture that stay periodic (each pyrDown sees the wrap).

    Parameters
    ----------
    tex : np.ndarray
        The full-resolution texture, level 0.
    levels : int
        How many levels at most, level 0 included; fewer when a side becomes odd or smaller
        than 16 px.
    """
    out = [tex]
    while len(out) < levels:
        h, w = out[-1].shape[:2]
        if h % 2 or w % 2 or min(h, w) < 16:
            break
        # filter a 3 x 3 tiling and keep the middle tile: no reflected border at the seams
        down = cv2.pyrDown(np.tile(out[-1], (3, 3, 1)))
        out.append(down[h // 2 : h, w // 2 : w].copy())
    return out
