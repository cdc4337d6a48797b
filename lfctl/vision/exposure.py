"""The full tracker's exposure compensation: when the whole picture darkens or brightens
(the light drops, a cloud passes, a camera without auto-exposure), the brightness of the
target's pixels moves with it, out of the brightness bins its model was learnt in and under
the value a marker pixel must have. A camera's auto-exposure undoes that by scaling its
gain; this does the same in software, on the value channel the tracker reads.

The picture's level is the mean of a sparse grid of its pixels (about every 4th row and
column); the compensation is the level the tracker started on over the level now. It engages only
past a change real cameras do not show on their own: on lfctl's labelled real footage, with
the cameras' own auto-exposure, the level stays within 0.74-1.37 of the first frame's
(panning, a bright window coming into view), so it engages past 1.6x either way and lets go
under 1.25x (hysteresis: no flicker at the edge). Between those the tracker sees the camera's
own pixels.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

__all__ = ["Exposure", "frame_level", "scale_value"]


def frame_level(frame: np.ndarray) -> float:
    """The picture's brightness: the mean over the three channels (0..255) of a
    nearest-neighbour quarter-size sample (every 4th row and column when the size is a
    multiple of 4; at least one pixel), at least 1.

    Parameters
    ----------
    frame : np.ndarray
        BGR image, uint8, H x W x 3.
    """
    h, w = frame.shape[:2]
    # nearest-neighbour shrink: at 640 x 480 the same grid as frame[::4, ::4], read in 27 us
    # where cv2.mean of the strided view took 90 us
    sample = cv2.resize(frame, (max(1, w // 4), max(1, h // 4)), interpolation=cv2.INTER_NEAREST)
    b, g, r, _ = cv2.mean(sample)
    return max(1.0, (b + g + r) / 3.0)


class Exposure:
    """The value gain that brings a frame back to the brightness the tracker started on.

    Parameters
    ----------
    engage : float
        A change of the picture's level by this factor (either way) switches the
        compensation on.
    release : float
        Back within this factor of the start, it switches off.
    limit : float
        The largest gain (and smallest, as 1 / limit): 8-bit pixels at a tenth of the light
        hold 25 levels, past that there is too little to scale.
    """

    def __init__(self, engage: float = 1.6, release: float = 1.25, limit: float = 10.0) -> None:
        if not 1.0 < release <= engage <= limit:
            raise ValueError(f"need 1 < release <= engage <= limit, got {release}, {engage}, {limit}")
        self.engage, self.release, self.limit = engage, release, limit
        self.reference: float | None = None
        self.gain = 1.0

    def start(self, frame: np.ndarray) -> None:
        """Take the frame the tracker starts on as the reference (gain 1).

        Parameters
        ----------
        frame : np.ndarray
            BGR image, uint8.
        """
        self.reference = frame_level(frame)
        self.gain = 1.0

    def rebase(self, frame: np.ndarray) -> None:
        """The tracker learnt its model afresh on this frame, as seen at the current gain:
        from now on the gain brings frames back to this frame's scaled level.

        Parameters
        ----------
        frame : np.ndarray
            BGR image, uint8, the frame the model was learnt on.
        """
        self.reference = frame_level(frame) * self.gain

    def update(self, frame: np.ndarray) -> float:
        """The gain for this frame (1 while the level is near the reference's).

        Parameters
        ----------
        frame : np.ndarray
            BGR image, uint8, the same camera as the reference.
        """
        if self.reference is None:
            self.start(frame)
            return self.gain
        wanted = float(np.clip(self.reference / frame_level(frame), 1.0 / self.limit, self.limit))
        change = abs(math.log(wanted))
        engaged = self.gain != 1.0
        if change > math.log(self.engage) or (engaged and change > math.log(self.release)):
            self.gain = wanted
        else:
            self.gain = 1.0
        return self.gain


def scale_value(hsv: np.ndarray, gain: float) -> np.ndarray:
    """``hsv`` with its value channel multiplied by ``gain`` (saturated at 255), in place.

    Parameters
    ----------
    hsv : np.ndarray
        HSV image (OpenCV's 8-bit scale), H x W x 3.
    gain : float
        The value gain.
    """
    if gain != 1.0:
        lut = np.clip(np.round(np.arange(256) * gain), 0, 255).astype(np.uint8)
        hsv[:, :, 2] = cv2.LUT(hsv[:, :, 2], lut)
    return hsv
