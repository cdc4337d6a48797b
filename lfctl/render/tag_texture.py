"""The ArUco banner's texture (``banner.kind = "aruco"``): the banner's panel printed with
one tag at its centre, in a clean one-cell margin, instead of the four markers.

The tag's edges sit exactly where the banner geometry puts them (sub-pixel: each texel is
the fraction of it the print covers), so a pose measured from the rendered tag can be
checked against the truth to a fraction of a millimetre.
"""

from __future__ import annotations

import cv2
import numpy as np

from lfctl.config import BannerConfig
from lfctl.render.textures import TEX_PX_PER_M, noise_texture
from lfctl.vision.aruco import tag_bitmap

__all__ = ["INK_FRACTION", "tag_banner_texture"]

#: the tag's black, as a fraction of the panel's colour (printer ink on the panel's paper)
INK_FRACTION = 0.15
_SUPER = 8  # subsamples per texel along each axis


def _cells(n_px: int, lo: float, cell: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """For each subsample along one axis: the cell it falls in and whether it is on the tag.
    Texel ``i`` covers texture coordinates ``i - 0.5 .. i + 0.5`` (OpenCV's pixel centres)."""
    x = np.arange(n_px * _SUPER) / _SUPER - 0.5 + 0.5 / _SUPER
    k = np.floor((x - lo) / cell).astype(int)
    inside = (k >= 0) & (k < n)
    return np.clip(k, 0, n - 1), inside


def tag_banner_texture(cfg: BannerConfig, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The panel with the tag, and the tag's four corners in texture coordinates (TL, TR,
    BR, BL as seen from behind the vehicle).

    Parameters
    ----------
    cfg : BannerConfig
        The panel's size and colour; the tag's dictionary, id and side.
    rng : np.random.Generator
        The panel's noise.
    """
    size = int(round(cfg.panel_size_m * TEX_PX_PER_M))
    px_per_m = size / cfg.panel_size_m  # texture coordinate x is x / px_per_m m from the panel's edge
    bits = tag_bitmap(cfg.aruco_dictionary, cfg.aruco_id)
    n = bits.shape[0]
    half = cfg.tag_size_m / 2 * px_per_m
    c0 = size / 2.0
    cell = 2 * half / n
    idx, on_tag = _cells(size, c0 - half, cell, n)
    # coverage of each texel: by the tag's black cells, and by the tag with its margin
    black_ss = (bits[np.ix_(idx, idx)] == 0) & on_tag[:, None] & on_tag[None, :]
    _, in_margin = _cells(size, c0 - half - cell, cell, n + 2)
    clean_ss = in_margin[:, None] & in_margin[None, :]
    black = black_ss.reshape(size, _SUPER, size, _SUPER).mean(axis=(1, 3))[..., None]
    clean = clean_ss.reshape(size, _SUPER, size, _SUPER).mean(axis=(1, 3))[..., None]
    paper = noise_texture(rng, size, size, cfg.panel_bgr, 10.0, 1)
    # outside the margin the panel keeps the hatching the markers' banner is printed with
    hatched = paper.copy()
    for k in range(-size, size, 9):
        cv2.line(hatched, (k, 0), (k + size, size), tuple(int(c * 0.8) for c in cfg.panel_bgr), 2, cv2.LINE_AA)
    ink = np.array(cfg.panel_bgr, np.float32) * INK_FRACTION
    tex = hatched.astype(np.float32) * (1 - clean) + paper.astype(np.float32) * (clean - black) + ink * black
    corners = np.array([[c0 - half, c0 - half], [c0 + half, c0 - half], [c0 + half, c0 + half], [c0 - half, c0 + half]])
    return np.clip(np.round(tex), 0, 255).astype(np.uint8), corners
