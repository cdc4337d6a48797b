"""Rotation-invariant local binary patterns, 8 neighbours at radius 1 (paper section 3.3).

Bit k of a pixel's code is set when neighbour k is at least the centre plus a small noise
threshold; the rotation-invariant code is the minimum over the 8 circular rotations. There
are exactly 36 such codes: the paper's "36 (LBP)" histogram bins, numbered 0..35 here in
increasing order of the minimal byte. Border pixels use replicated neighbours.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["N_CODES", "RI_CODES", "RI_LUT", "lbp_ri36", "lbp_ri36_reference"]

# neighbour offsets (dy, dx), in circular order starting east, going round
NEIGHBOURS = ((0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1), (-1, 0), (-1, 1))


def _rotations(byte: int) -> list[int]:
    return [((byte >> k) | (byte << (8 - k))) & 0xFF for k in range(8)]


RI_MIN = np.array([min(_rotations(b)) for b in range(256)], np.uint8)
RI_CODES = np.unique(RI_MIN)  # the 36 rotation-invariant patterns
#: 256 -> 0..35 look-up table
RI_LUT = np.searchsorted(RI_CODES, RI_MIN).astype(np.uint8)
#: number of rotation-invariant codes: the LBP axis of the histogram
N_CODES = len(RI_CODES)
assert N_CODES == 36


def lbp_ri36(gray: np.ndarray, threshold: int = 0) -> np.ndarray:
    """The 0..35 rotation-invariant LBP code of every pixel (OpenCV element-wise ops + LUT).

    Parameters
    ----------
    gray : np.ndarray
        Grey image, uint8, H x W (else ValueError).
    threshold : int
        Noise threshold: a neighbour's bit is set when it is at least the centre plus this,
        grey levels.
    """
    if gray.dtype != np.uint8 or gray.ndim != 2:
        raise ValueError(f"lbp_ri36 needs a 2-D uint8 image, got {gray.dtype} {gray.shape}")
    # in 8 bits throughout (half the memory traffic of 16-bit differences): a saturating
    # difference and a threshold that writes the bit's value
    g = cv2.copyMakeBorder(gray, 1, 1, 1, 1, cv2.BORDER_REPLICATE)
    h, w = gray.shape
    centre = g[1 : h + 1, 1 : w + 1]
    code = np.zeros((h, w), np.uint8)
    for k, (dy, dx) in enumerate(NEIGHBOURS):
        nb = g[1 + dy : h + 1 + dy, 1 + dx : w + 1 + dx]
        if threshold > 0:  # nb - centre >= threshold: the rise (0 for a fall) over threshold - 1
            bit = cv2.threshold(cv2.subtract(nb, centre), threshold - 1, 1 << k, cv2.THRESH_BINARY)[1]
        else:  # centre - nb <= -threshold: the fall (0 for a rise) at most -threshold
            bit = cv2.threshold(cv2.subtract(centre, nb), -threshold, 1 << k, cv2.THRESH_BINARY_INV)[1]
        code = cv2.bitwise_or(code, bit)
    return cv2.LUT(code, RI_LUT)


def lbp_ri36_reference(gray: np.ndarray, threshold: int = 0) -> np.ndarray:
    """Plain numpy version of :func:`lbp_ri36`: the test oracle.

    Parameters
    ----------
    gray : np.ndarray
        Grey image, H x W.
    threshold : int
        Noise threshold, grey levels (as in :func:`lbp_ri36`).
    """
    g = np.pad(gray.astype(np.int32), 1, mode="edge")
    h, w = gray.shape
    centre = g[1 : h + 1, 1 : w + 1] + threshold
    code = np.zeros((h, w), np.int32)
    for k, (dy, dx) in enumerate(NEIGHBOURS):
        code |= (g[1 + dy : h + 1 + dy, 1 + dx : w + 1 + dx] >= centre).astype(np.int32) << k
    return RI_LUT[code]
