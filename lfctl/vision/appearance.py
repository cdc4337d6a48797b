"""A cue beside colour for a target coming back into view: its grey-level pattern, compared
by normalised correlation.

The colour model says what a window's pixels are made of, not how they are arranged. A target
that comes back into view a little different in colour is refused by the strict re-entry gate
although its shape and shading are plainly its own: a coin flicked across a desk by a pen
lands lit from another side, 0.37-0.52 from its colour model against a re-entry gate of 0.29
(the tracking gate 0.53), and stays LOST in plain view for the rest of the clip. The tracker
lets such a window back (``TrackerSettings.appearance_reentry``) when its colours pass the
tracking gate and its pattern passes this one.

The pattern is the window's grey levels resampled to a fixed grid (:data:`GRID`), less their
mean and over their norm; a window's score is its normalised cross-correlation with the
target's pattern (-1..1), unchanged by the camera's gain and offset. The gate is learnt per
target, from two measurements:

- ``background``: in the first frame, the highest score of any window with a pattern, at
  any of :data:`SCALES` times the target's size, within :data:`SURROUNDINGS` of it and clear
  of it: the surroundings' best look-alike, given the same tries at size as a returning
  target (the colour gate takes the median of eight neighbours; a window let back on a
  second cue must beat the best impostor, not the typical one);
- ``typical``: the median score of the first accepted windows.

A window passes when its score is nearer the typical than the background one, and never for
a target whose pattern does not stand out from its surroundings (typical <= background). A
hidden target's size is known only roughly: its window is scored at :data:`SCALES` times the
predicted size and the best counts (the coin lands smaller, 58 x 40 px on its label, against
the 70 x 51 its track held: 0.27-0.60 at the held size, 0.69 at the best, frames 23-37).

Measured on the labelled real footage (``footage/``; target windows scored against the first
frame's pattern, impostors at random places of the same size): rigid targets keep their
pattern (coin, faces, tennis ball, box: median 0.74-0.97) above the impostors' 99th
percentile (0.23-0.60); a walking person does not (median 0.18-0.71 against 0.22-0.64), which
is why the pattern only lets a window back that the colours already nearly accept. What each
choice gave on the footage is in ``TrackerSettings.appearance_reentry``.
"""

from __future__ import annotations

import cv2
import numpy as np

from lfctl.vision.boxes import Box, clip_box

__all__ = ["GRID", "SCALES", "SURROUNDINGS", "AppearanceGate", "pattern"]

#: how far the first frame's impostors are looked for: windows of the target's size within a
#: region this many times its size, on its centre (the search region of a hidden target grows
#: to 4x the window and more)
SURROUNDINGS = 5.0
#: the sizes a hidden target's window is scored at, times the predicted one: a ladder of
#: quarter octaves (2 ** (k / 4), k = -2..2)
SCALES = tuple(float(2.0 ** (k / 4.0)) for k in range(-2, 3))
#: the pattern's grid (width, height), cells: fine enough for a face's or a coin's shading,
#: coarse enough that a window a few pixels off still correlates
GRID = (16, 16)


def pattern(grey: np.ndarray, box: Box) -> np.ndarray | None:
    """The zero-mean, unit-norm grey-level pattern of ``box`` in a grey image, resampled to
    :data:`GRID`; None when less than half the box is inside the image, or it is flat (its
    cells' rms under one grey level).

    Parameters
    ----------
    grey : np.ndarray
        Grey image, uint8, H x W.
    box : Box
        (x, y, w, h), pixels.
    """
    inside = clip_box(box, grey.shape)
    if inside is None or inside[2] * inside[3] < 0.5 * box[2] * box[3]:
        return None
    x, y, w, h = inside
    cells = cv2.resize(grey[y : y + h, x : x + w], GRID, interpolation=cv2.INTER_AREA).astype(np.float32)
    cells -= cells.mean()
    norm = float(np.linalg.norm(cells))
    if norm < np.sqrt(cells.size):  # flat (rms under one grey level): no pattern, only noise
        return None
    return cells / norm


class AppearanceGate:
    """The target's grey-level pattern and the scores that tell it from its surroundings; see
    the module docstring.

    Parameters
    ----------
    grey : np.ndarray
        The first frame, grey, uint8.
    box : Box
        The target's window in it.
    learn_frames : int
        Accepted windows whose median score is :attr:`typical`.
    """

    def __init__(self, grey: np.ndarray, box: Box, learn_frames: int = 5) -> None:
        p = pattern(grey, box)
        self.template = p
        self.learn_frames = learn_frames
        self.typical: float | None = None
        self._first: list[float] = []
        self.background = 1.0 if p is None else _best_impostor(grey, box, p)

    def score(self, grey: np.ndarray, box: Box) -> float | None:
        """Normalised correlation of ``box``'s pattern with the target's (-1..1); None when
        either has no pattern (see :func:`pattern`).

        Parameters
        ----------
        grey : np.ndarray
            Grey image, uint8.
        box : Box
            (x, y, w, h), pixels of ``grey``.
        """
        if self.template is None:
            return None
        return self._correlate(pattern(grey, box))

    def _correlate(self, p: np.ndarray | None) -> float | None:
        """A pattern's normalised correlation with the target's; None without either."""
        if p is None or self.template is None:
            return None
        return float(np.dot(p.ravel(), self.template.ravel()))

    def turned_scores(
        self, frame: np.ndarray, centre: tuple[float, float], size: tuple[float, float], angles: tuple[float, ...]
    ) -> list[float | None]:
        """Normalised correlation with the target's pattern of the window of ``size`` on
        ``centre`` with its axes turned by each of ``angles``; None for an angle whose window
        has no pattern or reaches past the image's edge.

        Parameters
        ----------
        frame : np.ndarray
            BGR image, uint8 (only the pixels around ``centre`` are made grey).
        centre : tuple of float
            The window's centre (x, y), pixels.
        size : tuple of float
            The window's width and height along its own axes, pixels.
        angles : tuple of float
            How far the window is turned, degrees, in OpenCV's sense: the picture turned by
            the angle about the centre puts the target back as it was at the start.
        """
        if self.template is None:
            return [None] * len(angles)
        cx, cy = centre
        w, h = max(2, int(round(size[0]))), max(2, int(round(size[1])))
        r = int(np.ceil(np.hypot(w, h) / 2.0)) + 1  # every turned window lies within r of the centre
        x0, y0 = max(0, int(round(cx)) - r), max(0, int(round(cy)) - r)
        x1, y1 = min(frame.shape[1], int(round(cx)) + r), min(frame.shape[0], int(round(cy)) + r)
        if x1 <= x0 or y1 <= y0:
            return [None] * len(angles)
        grey = cv2.cvtColor(frame[y0:y1, x0:x1], cv2.COLOR_BGR2GRAY)
        corners = np.array([[0, 0, 1], [w, 0, 1], [0, h, 1], [w, h, 1]], np.float64)
        scores: list[float | None] = []
        for angle in angles:
            # the window's pixels from the frame's: turned by -angle about the centre
            back = cv2.getRotationMatrix2D((w / 2.0, h / 2.0), -angle, 1.0)
            back[:, 2] += (cx - w / 2.0, cy - h / 2.0)
            reach = corners @ back.T  # its corners in the frame
            if reach.min() < 0 or reach[:, 0].max() > frame.shape[1] or reach[:, 1].max() > frame.shape[0]:
                scores.append(None)
                continue
            back[:, 2] -= (x0, y0)
            upright = cv2.warpAffine(
                grey, back, (w, h), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_REPLICATE
            )
            scores.append(self._correlate(pattern(upright, (0, 0, w, h))))
        return scores

    def best_score(self, grey: np.ndarray, box: Box) -> float | None:
        """The highest :meth:`score` of windows on ``box``'s centre at :data:`SCALES` times its
        size (a hidden target's size is known only roughly); None when none has a pattern.

        Parameters
        ----------
        grey : np.ndarray
            The frame in grey levels, uint8 (as :meth:`score` takes it).
        box : Box
            The predicted window (x, y, w, h), pixels; the sizes tried are about its centre.
        """
        x, y, w, h = box
        cx, cy = x + w / 2.0, y + h / 2.0
        scored = []
        for k in SCALES:
            kw, kh = max(2, int(round(w * k))), max(2, int(round(h * k)))
            s = self.score(grey, (int(round(cx - kw / 2.0)), int(round(cy - kh / 2.0)), kw, kh))
            if s is not None:
                scored.append(s)
        return max(scored) if scored else None

    @property
    def can_pass(self) -> bool:
        """Whether any window can pass yet: the typical score learnt, and above the best
        impostor's around the start (else :meth:`passes` refuses every window)."""
        return self.typical is not None and self.typical > self.background

    @property
    def threshold(self) -> float | None:
        """The lowest score that passes (exclusive); None while still learning."""
        if self.typical is None:
            return None
        return 0.5 * (self.typical + self.background)

    def passes(self, s: float | None) -> bool:
        """Whether a window scoring ``s`` looks like the target (never while still learning,
        or without a score).

        Parameters
        ----------
        s : float or None
            The window's :meth:`score`.
        """
        t = self.threshold
        return s is not None and t is not None and self.can_pass and s > t

    def observe(self, s: float | None) -> None:
        """Learn from the score of a window the track accepted.

        Parameters
        ----------
        s : float or None
            Its :meth:`score` (None is skipped).
        """
        if self.typical is None and s is not None:
            self._first.append(float(s))
            if len(self._first) >= self.learn_frames:
                self.typical = float(np.median(self._first))


def _best_impostor(grey: np.ndarray, box: Box, template: np.ndarray) -> float:
    """The highest score of a window at any of :data:`SCALES` times ``box``'s size, placed
    anywhere within :data:`SURROUNDINGS` of it and not overlapping it, that has a pattern (its
    cells' rms at least one grey level, as :func:`pattern` asks: a flat window has no score and
    never passes); 0 when every such window is flat (a plain wall), 1 (nothing passes) when
    there is no room for one. The impostors get the same tries at size as a hidden target's
    window (:meth:`AppearanceGate.best_score`)."""
    x, y, w, h = box
    cx, cy = x + w / 2.0, y + h / 2.0
    reach = SURROUNDINGS / 2.0
    area = clip_box(
        (int(round(cx - reach * w)), int(round(cy - reach * h)), int(round(2 * reach * w)), int(round(2 * reach * h))),
        grey.shape,
    )
    if area is None:
        return 1.0
    ax, ay, aw, ah = area
    gw, gh = GRID
    best, room = -np.inf, False
    for k in SCALES:
        fx, fy = gw / (k * w), gh / (k * h)  # the area resampled so a window k times the box is GRID
        size = (max(gw, int(round(aw * fx))), max(gh, int(round(ah * fy))))
        cells = cv2.resize(grey[ay : ay + ah, ax : ax + aw], size, interpolation=cv2.INTER_AREA).astype(np.float32)
        scores = cv2.matchTemplate(cells, template.astype(np.float32), cv2.TM_CCOEFF_NORMED)
        # each window's variance over its cells, from integral images
        s1, s2 = cv2.integral2(cells.astype(np.float64), sdepth=cv2.CV_64F)
        n = gw * gh
        total = s1[gh:, gw:] - s1[:-gh, gw:] - s1[gh:, :-gw] + s1[:-gh, :-gw]
        squares = s2[gh:, gw:] - s2[:-gh, gw:] - s2[gh:, :-gw] + s2[:-gh, :-gw]
        var = squares / n - (total / n) ** 2
        # each window's top-left in cells; the box spans gw / k x gh / k cells from (tx, ty), and
        # resampling mixes it into the cell beyond its edge: a window must clear that too
        tx, ty = (x - ax) * fx, (y - ay) * fy
        rows, cols = np.ogrid[: scores.shape[0], : scores.shape[1]]
        off_x = (cols + gw <= tx - 1) | (cols >= tx + gw / k + 1)
        off_y = (rows + gh <= ty - 1) | (rows >= ty + gh / k + 1)
        away = off_x | off_y
        room = room or bool(away.any())
        keep = away & (var >= 1.0) & np.isfinite(scores)
        if keep.any():
            best = max(best, float(scores[keep].max()))
    if not room:
        return 1.0
    return best if np.isfinite(best) else 0.0
