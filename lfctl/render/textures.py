"""Procedural textures for the rendered scene, seeded: the banner, the floor, props and
occluders. Periodic where they tile (the floor), so no seams show.
"""

from __future__ import annotations

import colorsys
import math
from collections.abc import Sequence

import cv2
import numpy as np

from lfctl.config import BannerConfig, PropConfig

__all__ = [
    "GROUND_PERIOD_PX",
    "GROUND_PX_PER_M",
    "REAL_BANNER_PX_PER_M",
    "TEX_PX_PER_M",
    "banner_texture",
    "ground_texture",
    "hue_bgr",
    "noise_texture",
    "panel_sizes",
    "periodic_noise",
    "periodic_pyramid",
    "prop_texture",
    "real_banner_texture",
    "real_ground_texture",
    "real_wall_texture",
]

TEX_PX_PER_M = 800.0  # banner texture resolution, px per m
#: how much deeper than its Gaussian reaches (4 sigma) :func:`noise_texture` wraps the noise
#: around itself before blurring, px: more than OpenCV's widest vector, so no kept pixel is
#: left to the filter's scalar loop at a row's end
_BLUR_MARGIN_PX = 64


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
    n = rng.standard_normal((h, w))  # rng.normal(0, amplitude)'s draws, scaled at numpy's speed
    n = np.multiply(n, amplitude, out=n).astype(np.float32)
    if blur > 1:
        # blur the noise with its own wrap around it and keep the middle: the texture stays
        # periodic (no seams when tiled). The wrap is the middle of a 3 x 3 tiling, cut to
        # the kernel's reach plus _BLUR_MARGIN_PX, so the middle gets exactly the values the
        # whole tiling gave it, at a fraction of the pixels (a 300 x 2000 wall at sigma 4:
        # 6.5 x fewer)
        reach = 4 * blur + _BLUR_MARGIN_PX
        my, mx = min(h, reach), min(w, reach)
        n = cv2.GaussianBlur(np.pad(n, ((my, my), (mx, mx)), mode="wrap"), (0, 0), blur)[
            my : my + h, mx : mx + w
        ].copy()
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


#: a panel's texture resolution, px per m, and the most pixels one panel's longer side or all
#: the scene's panels together get (a large panel, or many, at full resolution would take
#: gigabytes: a 100 m wall 20000 px square)
PANEL_PX_PER_M = 200
PANEL_MAX_SIDE_PX = 4096
PANELS_MAX_PX = 48_000_000


def panel_sizes(dims_m: Sequence[tuple[float, float]]) -> list[tuple[int, int]]:
    """Texture sizes (width, height) px for panels of ``(width_m, height_m)``: at
    :data:`PANEL_PX_PER_M`, a panel's longer side at most :data:`PANEL_MAX_SIDE_PX`, and all of
    them together within :data:`PANELS_MAX_PX` (each scaled down alike), 8 px at least.

    Parameters
    ----------
    dims_m : sequence of (width_m, height_m)
        The panels' sizes, m.
    """
    sizes = []
    for w_m, h_m in dims_m:
        w, h = max(1.0, w_m * PANEL_PX_PER_M), max(1.0, h_m * PANEL_PX_PER_M)
        k = min(1.0, PANEL_MAX_SIDE_PX / max(w, h))
        sizes.append((w * k, h * k))
    total = sum(w * h for w, h in sizes)
    k = min(1.0, math.sqrt(PANELS_MAX_PX / total)) if total > 0 else 1.0
    return [(max(8, int(w * k)), max(8, int(h * k))) for w, h in sizes]


def prop_texture(
    prop: PropConfig, banner: BannerConfig, rng: np.random.Generator, size_px: tuple[int, int] | None = None
) -> np.ndarray:
    """Texture of a prop panel by kind (see :class:`~lfctl.config.PropConfig`), 200 px per m
    (or ``size_px``, width and height, from :func:`panel_sizes`).

    Parameters
    ----------
    prop : PropConfig
        The prop: its kind and size.
    banner : BannerConfig
        The banner, whose marker hue and panel colour distractors copy.
    rng : np.random.Generator
        The texture's random stream.
    size_px : (int, int), optional
        The texture's width and height, px.
    """
    w, h = size_px or panel_sizes([(prop.width_m, prop.height_m)])[0]
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


# ---------------------------------------------------------------------------------------
# The realistic renderer's textures (scene.realism = "on")

#: the realistic banner's texture resolution, px per m: sharp down to half a metre away
REAL_BANNER_PX_PER_M = 1600.0
#: the realistic ground: a 2 m period at 768 px per m (a pixel's footprint on the nearest rows
#: of a 640 x 480, 62 degree camera 0.2 m up is about 1.2 mm)
GROUND_PERIOD_PX, GROUND_PX_PER_M = 1536, 768.0


def periodic_noise(rng: np.random.Generator, h: int, w: int, sigma_px: float) -> np.ndarray:
    """Zero-mean, unit-spread Gaussian noise blurred by ``sigma_px`` that tiles without seams
    (float32, h x w).

    Parameters
    ----------
    rng : np.random.Generator
        The noise's random stream.
    h, w : int
        Size, px.
    sigma_px : float
        Grain size, px (below 0.5: white noise).
    """
    n = rng.standard_normal((h, w), dtype=np.float32)
    if sigma_px >= 0.5:
        pad = int(3 * sigma_px) + 1
        big = np.pad(n, pad, mode="wrap")
        n = cv2.GaussianBlur(big, (0, 0), sigma_px)[pad : pad + h, pad : pad + w]
    return (n - n.mean()) / max(float(n.std()), 1e-6)


def real_banner_texture(cfg: BannerConfig, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The printed banner: BGRA (alpha 255: the warp's border gives anti-aliased edges) and
    the marker centres in texture pixels (TL, TR, BR, BL).

    Board with paper grain and uneven ink, the hatched pattern, markers printed with soft
    edges and ink that varies (never one flat, fully saturated colour), slightly blurred as
    a print is. ``marker_saturation`` sets the ink's mean saturation.

    Parameters
    ----------
    cfg : BannerConfig
        Sizes and colours.
    rng : np.random.Generator
        The grain's random stream.
    """
    s = REAL_BANNER_PX_PER_M
    size = int(round(cfg.panel_size_m * s))
    up = 2  # drawn at twice the size, then area-averaged: anti-aliased print edges
    big = size * up
    base = np.array(cfg.panel_bgr, np.float32)
    grain = periodic_noise(rng, big, big, 0.8) * 4.0 + periodic_noise(rng, big, big, 14.0) * 3.0
    tex = np.clip(base[None, None, :] + grain[..., None], 0, 255).astype(np.uint8)
    hatch = tuple(int(c * 0.8) for c in cfg.panel_bgr)
    step = 9 * up * s / TEX_PX_PER_M / 2  # the same pattern as the flat banner, in metres
    k = -float(big)
    while k < big:
        cv2.line(tex, (int(k), 0), (int(k) + big, big), hatch, max(1, int(round(up * s / TEX_PX_PER_M))), cv2.LINE_AA)
        k += step
    half = cfg.side_m / 2 * s * up
    m = cfg.marker_size_m / 2 * s * up
    c0 = big / 2
    centres = np.array([[c0 - half, c0 - half], [c0 + half, c0 - half], [c0 + half, c0 + half], [c0 - half, c0 + half]])
    ink = np.array(hue_bgr(cfg.marker_hue_deg, cfg.marker_saturation, 0.82), np.float32)
    mask = np.zeros((big, big), np.uint8)
    for cx, cy in centres:
        pts = np.array([[cx - m, cy - m], [cx + m, cy - m], [cx + m, cy + m], [cx - m, cy + m]])
        cv2.fillPoly(mask, [np.round(pts * 16).astype(np.int32)], 255, cv2.LINE_AA, shift=4)
    # ink: thinner and thicker by a few per cent, and the paper shows through a little
    mottle = 1.0 + 0.05 * periodic_noise(rng, big, big, 3.0) + 0.03 * periodic_noise(rng, big, big, 0.6)
    ink_img = ink[None, None, :] * mottle[..., None] + 0.12 * (tex.astype(np.float32) - base)
    a = (mask.astype(np.float32) / 255.0)[..., None]
    out = tex.astype(np.float32) * (1 - a) + ink_img * a
    out = cv2.GaussianBlur(out, (0, 0), 0.7 * up)
    out = cv2.resize(np.clip(out, 0, 255).astype(np.uint8), (size, size), interpolation=cv2.INTER_AREA)
    bgra = np.dstack([out, np.full((size, size), 255, np.uint8)])
    return bgra, (centres + 0.5) / up - 0.5


def _tile_to(img: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """A periodic image scaled to a period that divides ``n``, flipped at random, tiled to n x n."""
    period = int(rng.choice([n // 4, n // 3, n // 2])) if n % 12 == 0 else n // 2
    t = cv2.resize(img, (period, period), interpolation=cv2.INTER_CUBIC)
    if rng.random() < 0.5:
        t = cv2.flip(t, 1)
    if rng.random() < 0.5:
        t = cv2.transpose(t)
    reps = n // period
    tiled = np.tile(t, (reps, reps, 1))
    return np.roll(tiled, (int(rng.integers(n)), int(rng.integers(n))), axis=(0, 1))


def real_ground_texture(
    kind: str, photos: Sequence[np.ndarray] | None, rng: np.random.Generator
) -> tuple[np.ndarray, float]:
    """The realistic ground: one period (:data:`GROUND_PERIOD_PX` square, tileable) at
    :data:`GROUND_PX_PER_M`, and that resolution.

    With ``photos`` (crops of real ground), several are laid over each other at random
    scales, flips and offsets and blended by smooth random weights, so the 2 m period does
    not show one photograph repeating; otherwise the procedural ``kind``. A fine grain is
    added either way: a photograph magnified to the nearest rows would look soft.

    Parameters
    ----------
    kind : str
        ``"checker"``, ``"carpet"``, ``"grass"`` or concrete (anything else).
    photos : sequence of np.ndarray or None
        Tileable photographs of this kind of ground, or None for procedural.
    rng : np.random.Generator
        Choices and grain.
    """
    n = GROUND_PERIOD_PX
    if photos:
        layers = [_tile_to(photos[int(rng.integers(len(photos)))], n, rng).astype(np.float32) for _ in range(3)]
        yy, xx = np.mgrid[0:n, 0:n].astype(np.float32) * (2 * np.pi / n)
        weights = []
        for _ in layers:
            f = np.zeros((n, n), np.float32)
            for _ in range(3):
                kx, ky = int(rng.integers(-3, 4)), int(rng.integers(1, 4))
                f += np.cos(kx * xx + ky * yy + float(rng.uniform(0, 2 * np.pi)))
            weights.append(f)
        w = np.exp(np.stack(weights) / 0.35)
        w /= w.sum(axis=0, keepdims=True)
        base = sum(layer * wk[..., None] for layer, wk in zip(layers, w, strict=True))
        grain_dn = 6.0
    else:
        if kind == "checker":
            sq = n // 4  # 0.5 m squares
            tile = (np.indices((4, 4)).sum(axis=0) % 2).astype(np.float32)
            base = np.dstack([np.kron(90 + 60 * tile, np.ones((sq, sq), np.float32))] * 3)
            grain_dn = 3.0
        else:
            colour = {"carpet": (70, 60, 110), "grass": (40, 110, 70)}.get(kind, (128, 130, 132))
            amp = {"carpet": 25.0, "grass": 22.0}.get(kind, 18.0)
            coarse = periodic_noise(rng, n, n, 18.0) * amp
            base = np.array(colour, np.float32)[None, None, :] + coarse[..., None]
            grain_dn = 8.0
    grain = periodic_noise(rng, n, n, 0.7) * grain_dn + periodic_noise(rng, n, n, 2.5) * grain_dn * 0.6
    tex = np.clip(np.asarray(base, np.float32) + grain[..., None], 0, 255).astype(np.uint8)
    return tex, GROUND_PX_PER_M


def real_wall_texture(
    prop: PropConfig,
    photos: Sequence[np.ndarray] | None,
    banner: BannerConfig,
    rng: np.random.Generator,
    size_px: tuple[int, int] | None = None,
) -> np.ndarray:
    """A prop's realistic texture: a wall faced with a photographed facade (tiled along its
    width at its height), anything else as :func:`prop_texture`.

    Parameters
    ----------
    prop : PropConfig
        The prop.
    photos : sequence of np.ndarray or None
        Facade photographs (tileable along x), or None.
    banner : BannerConfig
        For distractors, as :func:`prop_texture`.
    rng : np.random.Generator
        Choices.
    size_px : (int, int), optional
        The texture's width and height, px (:func:`panel_sizes`).
    """
    if prop.kind != "wall" or not photos:
        return prop_texture(prop, banner, rng, size_px)
    photo = photos[int(rng.integers(len(photos)))]
    w, h = size_px or panel_sizes([(prop.width_m, prop.height_m)])[0]
    tw = max(8, int(round(photo.shape[1] * h / photo.shape[0])))
    tile = cv2.resize(photo, (tw, h), interpolation=cv2.INTER_CUBIC)
    reps = w // tw + 2
    row = np.tile(tile, (1, reps, 1))  # the facade is periodic along x: no seams
    x0 = int(rng.integers(tw))
    return np.ascontiguousarray(row[:, x0 : x0 + w])
