"""The full tracker's appearance gate, learnt from the target it was started on.

A fixed distance threshold cannot serve every target: on lfctl's rendered banner the
window's colour distance to the model stays below 0.2, on real video it sits at 0.15 (a
black jersey), 0.37 (a bow tie 45 x 18 px) or 0.53 (a shirt print in 176 x 144 video) while
the target is in plain view. So the gate is learnt per target, from two measurements:

- ``background``: in the first frame, the colour distance of the model to the eight windows
  of the target's size around it (the median: one neighbour may be more of the target);
  what "not the target" looks like here;
- ``typical``: the distance of the accepted windows over the first frames (their median).
  The reference histogram itself follows the target (the tracker blends confident windows
  into it, and for a target followed by its colours alone the other accepted ones too,
  weighted by :meth:`DistanceGate.teach_weight`), so the distance the target keeps from it
  stays near this.

A window is the target when its distance is nearer the typical than the background one:
``d < (typical + background) / 2``, the two-class threshold for classes of equal spread.
Until ``learn_frames`` distances are in, the gate is the background distance itself (the
window must at least look more like the target than its surroundings do).

The distance is taken on the colour marginal of the model (hue or grey level x saturation),
not on the full H x S x LBP histogram: with 36 LBP codes a window of a few hundred pixels
fills a few hundred of the 20,000 bins and its distance to the model is mostly sampling noise
(the bow tie's own frames: 0.64-0.70 on the full histogram, 0.35-0.49 on the colour
marginal). The LBP codes still shape the back-projection CAMShift follows.
"""

from __future__ import annotations

import numpy as np

from lfctl.vision.histogram import bhattacharyya

__all__ = ["DistanceGate", "colour_distance", "ring_boxes", "separating_level"]


def colour_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Bhattacharyya distance of two model histograms over their first two axes (hue or grey
    level x saturation), summed over any further axis (the LBP codes).

    Parameters
    ----------
    a, b : np.ndarray
        Histograms over the same bins (see :func:`~lfctl.vision.histogram.histogram`).
    """
    if a.ndim > 2:
        a = a.reshape(a.shape[0], a.shape[1], -1).sum(axis=2)
        b = b.reshape(b.shape[0], b.shape[1], -1).sum(axis=2)
    return bhattacharyya(a, b)


def separating_level(inside: np.ndarray, outside: np.ndarray) -> int:
    """The back-projection level that best tells the target's pixels from its surroundings'
    (Youden's J: the largest share of target pixels at or above it minus the share of
    surrounding pixels at or above it); 0 when no level separates them.

    The ratio histogram weights down the colours the surroundings share, but not to zero: on
    real video a dark jacket's neighbours (another dark coat, the trousers, shadow) keep a
    faint back-projection, which CAMShift's zeroth moment adds up over a large area, and its
    window swells onto them (the red jacket passing a same-red barrier tape: 0.33 success
    with the faint values kept, 0.95 without them). Below this level a pixel is more
    probably surroundings than target.

    Parameters
    ----------
    inside, outside : np.ndarray
        uint8 back-projection values of the target's pixels and of the surrounding ones.
    """
    if inside.size == 0 or outside.size == 0:
        return 0
    t = np.bincount(inside.ravel(), minlength=256)[:256].astype(np.float64) / inside.size
    b = np.bincount(outside.ravel(), minlength=256)[:256].astype(np.float64) / outside.size
    # share at or above each level k: 1 - cdf(k - 1)
    at_or_above_t = 1.0 - np.concatenate(([0.0], np.cumsum(t)[:-1]))
    at_or_above_b = 1.0 - np.concatenate(([0.0], np.cumsum(b)[:-1]))
    j = at_or_above_t - at_or_above_b
    j[0] = 0.0  # level 0 keeps everything: no threshold
    k = int(np.argmax(j))
    return k if j[k] > 0 else 0


def ring_boxes(box: tuple[int, int, int, int]) -> list[tuple[int, int, int, int]]:
    """The eight windows of ``box``'s size around it (left, right, above, below, diagonals).

    Parameters
    ----------
    box : Box
        (x, y, w, h), pixels.
    """
    x, y, w, h = box
    return [(x + dx * w, y + dy * h, w, h) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy]


class DistanceGate:
    """Accept or refuse a window by its colour distance to the model; see the module docstring.

    Parameters
    ----------
    background : float
        Median colour distance of the model to the windows around the target in the first
        frame (0..1).
    learn_frames : int
        Accepted distances from which :attr:`typical` is taken (their median).
    """

    def __init__(self, background: float, learn_frames: int = 5) -> None:
        self.background = float(background)
        self.learn_frames = learn_frames
        self.typical: float | None = None
        self._first: list[float] = []

    @property
    def threshold(self) -> float:
        """The largest distance still accepted (exclusive)."""
        if self.typical is None:
            return self.background
        return 0.5 * (self.typical + self.background)

    @property
    def reentry_threshold(self) -> float:
        """The largest distance accepted for a target coming back after it was lost from view
        (exclusive): a quarter of the way from the typical distance to the background one
        (hysteresis: a track is kept on weaker evidence than it is taken up on)."""
        if self.typical is None:
            return self.background
        return self.typical + 0.25 * (self.background - self.typical)

    def accepts(self, d: float, reentry: bool = False) -> bool:
        """Whether a window at colour distance ``d`` is the target.

        Parameters
        ----------
        d : float
            The window's colour distance to the model (0..1).
        reentry : bool
            The target is coming back into view: the stricter :attr:`reentry_threshold`.
        """
        return d < (self.reentry_threshold if reentry else self.threshold)

    def confident(self, d: float) -> bool:
        """Whether ``d`` is near enough the typical distance for the window to teach the model in
        full (nearer the typical than the threshold; never while still learning).

        Parameters
        ----------
        d : float
            The window's colour distance to the model (0..1).
        """
        return self.typical is not None and d <= 0.5 * (self.typical + self.threshold)

    def teach_weight(self, d: float) -> float:
        """How much an accepted window at colour distance ``d`` teaches the model, 0..1: all of
        it while :meth:`confident`, then less the nearer ``d`` is to :attr:`threshold`, nothing
        at or past it (and nothing while still learning). The tracker uses it for a target
        followed by its colours alone (a banner's markers relearn its look instead).

        Such a target has no other way to follow its own look as it changes (light, pose, a
        video coder's colour), and a window between the confident level and the threshold is
        still the target (the gate accepted it). Taught only by confident windows, the model
        keeps the first frames' look while the target drifts from it until the gate refuses
        it in plain view (a printed shirt under cyan light whose saturation fell from 145 to
        83-122). Taught less the nearer the threshold, a window that is partly something else
        (an occluder coming in, a window slid off the target) teaches little.

        Parameters
        ----------
        d : float
            The window's colour distance to the model (0..1).
        """
        if self.typical is None or d >= self.threshold:
            return 0.0
        sure = 0.5 * (self.typical + self.threshold)  # the confident level
        span = self.threshold - sure
        if d <= sure or span <= 0.0:
            return 1.0
        return (self.threshold - d) / span

    def observe(self, d: float) -> None:
        """Learn from the distance of a window the track accepted.

        Parameters
        ----------
        d : float
            Its colour distance to the model (0..1).
        """
        if self.typical is None:
            self._first.append(float(d))
            if len(self._first) >= self.learn_frames:
                self.typical = float(np.median(self._first))
