"""The target model (paper section 3.3): a 32 x 16 x 36 hue x saturation x LBP histogram,
weighted down where the background shares its bins, normalised to a 0..255 look-up table
and back-projected into an 8-bit probability image."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import cv2
import numpy as np

from lfctl.vision.exposure import scale_value
from lfctl.vision.lbp import N_CODES, lbp_ri36

__all__ = ["FeatureSpace", "back_project", "bhattacharyya", "histogram", "ratio_lut"]

HUE_BINS, SAT_BINS, LBP_BINS = 32, 16, N_CODES


@dataclass(frozen=True)
class FeatureSpace:
    """Which channels the model uses: the paper's hue + saturation + LBP, or hue alone (the
    baseline CAMShift).

    Parameters
    ----------
    use_saturation : bool
        Add saturation (16 bins) to hue (32 bins); without it the model is hue alone.
    use_lbp : bool
        Add the 36 rotation-invariant LBP codes (needs ``use_saturation``).
    lbp_threshold : int
        The LBP noise threshold, grey levels (see :func:`~lfctl.vision.lbp.lbp_ri36`).
    achromatic_s : int
        Pixels with a saturation (0..255) at or below this count as grey: their hue goes to 0
        (or, with ``grey_levels``, to a brightness bin).
    grey_levels : int
        0: grey pixels share hue bin 0 (the paper's features). N > 0: grey pixels, and pixels
        too dark for their hue to mean anything (value below ``dark_v``), go to N extra
        brightness bins after the hue bins instead, as in Perez et al.'s colour-based tracker
        (ECCV 2002): a black jersey and a light grey van differ only there. Needs
        ``use_saturation``.
    dark_v : int
        With ``grey_levels``: pixels darker than this (value 0..255) count as grey whatever
        their saturation (OpenCV's saturation of a near-black pixel is noise).
    """

    use_saturation: bool = True
    use_lbp: bool = True
    lbp_threshold: int = 3
    achromatic_s: int = 40
    grey_levels: int = 0
    dark_v: int = 40

    @property
    def bins(self) -> list[int]:
        """Bins per channel, in plane order (as cv2.calcHist takes them)."""
        first = HUE_BINS + (self.grey_levels if self.use_saturation else 0)
        return [first] + ([SAT_BINS] if self.use_saturation else []) + ([LBP_BINS] if self.use_lbp else [])

    @property
    def ranges(self) -> list[float]:
        """Value range of each channel, flattened ``[lo, hi, lo, hi, ...]`` (hi exclusive)."""
        first = 180.0 + (self.grey_levels * 180.0 / HUE_BINS if self.use_saturation else 0.0)
        return [0, first] + ([0, 256] if self.use_saturation else []) + ([0, N_CODES] if self.use_lbp else [])

    @property
    def channels(self) -> list[int]:
        """Indices of the planes the histogram reads: all of them, 0..n-1."""
        return list(range(len(self.bins)))

    def features(self, frame_bgr: np.ndarray, value_gain: float = 1.0) -> tuple[list[np.ndarray], np.ndarray]:
        """The single-channel feature planes of a frame (or region) and its HSV image.

        Planes: hue, then saturation and the LBP codes when used. With saturation in the
        model, the hue of nearly grey pixels (below ``achromatic_s``) is set to 0: their hue
        is noise, and scattered over 32 bins a white panel would vanish from the model;
        saturation keeps them apart from real red.

        Parameters
        ----------
        frame_bgr : np.ndarray
            BGR image or region, uint8, H x W x 3.
        value_gain : float
            Exposure compensation: the value channel (the brightness bins, the dark test
            and the HSV image returned) is multiplied by it, as a camera's gain would (see
            :class:`~lfctl.vision.exposure.Exposure`). Hue, saturation and the LBP codes
            (thresholded contrasts) are read as the camera gave them.
        """
        hsv = scale_value(cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2HSV), value_gain)
        h, sat, val = cv2.split(hsv)
        if not self.use_saturation:
            return [h], hsv
        chromatic = cv2.compare(sat, self.achromatic_s, cv2.CMP_GT)
        if self.grey_levels:
            chromatic = cv2.bitwise_and(chromatic, cv2.compare(val, self.dark_v, cv2.CMP_GE))
            first = cv2.LUT(val, _grey_lut(self.grey_levels))  # the brightness bins...
            cv2.copyTo(h, chromatic, first)  # ...where the hue means nothing
            planes = [first, sat]
        else:
            planes = [cv2.bitwise_and(h, chromatic), sat]
        if self.use_lbp:
            planes.append(lbp_ri36(cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2GRAY), self.lbp_threshold))
        return planes, hsv


@functools.cache
def _grey_lut(levels: int) -> np.ndarray:
    """Value (0..255) -> the middle of its brightness bin on the extended hue axis: ``levels``
    equal value bands, each one hue-bin wide, after hue 180."""
    width = 180.0 / HUE_BINS
    band = np.minimum(np.arange(256) * levels // 256, levels - 1)
    return np.round(180.0 + (band + 0.5) * width).astype(np.uint8)


def histogram(space: FeatureSpace, planes: list[np.ndarray], mask: np.ndarray | None) -> np.ndarray:
    """Raw counts over the feature space inside ``mask``.

    Parameters
    ----------
    space : FeatureSpace
        The channels and bins.
    planes : list of np.ndarray
        The feature planes of one image (see :meth:`FeatureSpace.features`).
    mask : np.ndarray or None
        uint8, non-zero where pixels count; None counts every pixel.
    """
    return cv2.calcHist(planes, space.channels, mask, space.bins, space.ranges)


def ratio_lut(target: np.ndarray, background: np.ndarray | None) -> np.ndarray:
    """Look-up table 0..255: the target histogram weighted down where the background shares
    its bins (background-weighted histogram, Comaniciu et al. 2003, as used by Allen and
    Bradski's background-weighted CAMShift).

    Each bin ``u`` of the target histogram is multiplied by ``v_u = min(1, o* / o_u)`` where
    ``o_u`` is the background's share of bin ``u`` and ``o*`` its smallest non-zero share: a
    bin the background never shows keeps its weight, a bin common around the target all but
    disappears. Bins the target shows only a handful of times are dropped as noise. The table
    is scaled so its largest entry is 255 (all zeros for an empty target histogram).

    Parameters
    ----------
    target : np.ndarray
        Counts inside the target's window (see :func:`histogram`).
    background : np.ndarray or None
        Counts around it; None (or empty) weights nothing down.
    """
    t = target.astype(np.float32)
    t_sum = float(t.sum())
    if t_sum <= 0:
        return np.zeros_like(t)
    w = t / t_sum
    w[t < max(1.0, 0.002 * t_sum)] = 0.0
    if background is not None and float(background.sum()) > 0:
        o = background.astype(np.float32) / float(background.sum())
        nonzero = o[o > 0]
        o_star = float(nonzero.min()) if nonzero.size else 1.0
        v = np.minimum(1.0, o_star / np.maximum(o, 1e-12)).astype(np.float32)
        w = w * v
    peak = float(w.max())
    return (w * (255.0 / peak)).astype(np.float32) if peak > 0 else w


def back_project(space: FeatureSpace, planes: list[np.ndarray], lut: np.ndarray) -> np.ndarray:
    """The 8-bit probability image of ``planes`` under the look-up table.

    Parameters
    ----------
    space : FeatureSpace
        The channels and bins the table was made for.
    planes : list of np.ndarray
        The feature planes of the image to back-project.
    lut : np.ndarray
        0..255 per bin (see :func:`ratio_lut`).
    """
    return cv2.calcBackProject(planes, space.channels, lut, space.ranges, scale=1.0)


def bhattacharyya(a: np.ndarray, b: np.ndarray) -> float:
    """Bhattacharyya distance of two histograms: 0 identical, 1 disjoint (OpenCV's
    HISTCMP_BHATTACHARYYA, which normalises them itself); 1 when either is empty.

    Parameters
    ----------
    a, b : np.ndarray
        Histograms over the same bins (raw counts will do).
    """
    if float(a.sum()) <= 0 or float(b.sum()) <= 0:
        return 1.0
    return float(cv2.compareHist(a.astype(np.float32), b.astype(np.float32), cv2.HISTCMP_BHATTACHARYYA))
