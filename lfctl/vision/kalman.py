"""The tracker's three Kalman filters (paper section 1), with filterpy.

1. :class:`CentreFilter`: constant velocity on the window centre (pixels, per frame); its
   prediction is where CAMShift searches next frame.
2. :class:`OcclusionCoaster`: takes the centre filter's position and velocity when the
   target disappears and keeps coasting them, with a larger process noise, so the search
   region follows the hidden target and widens with the uncertainty until it reappears. The
   tracker first gives the centre filter the motion the target kept over its last confident
   frames (:func:`steady_motion`): an occluder or a neighbour coming in drags the last few
   frames' windows, and so the filter's velocity, off the target before it is called hidden.
3. :class:`AreaFilter`: the window's size (square root of its area), constant velocity mixed
   with a holding model (an IMM); a normalised innovation beyond a gate flags an occlusion
   early (the window collapsing as an occluder slides over the target, or jumping onto
   something else).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence

import numpy as np
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import IMMEstimator, KalmanFilter

__all__ = ["AreaFilter", "CentreFilter", "OcclusionCoaster", "steady_motion"]


def _cv_filter(dim: int, accel_var: float, meas_var: float, cls: type[KalmanFilter] = KalmanFilter) -> KalmanFilter:
    """A constant-velocity filter on ``dim`` coordinates, one step per frame: state
    x = [p_1 .. p_dim, v_1 .. v_dim] (px, px/frame), measurement z = [p_1 .. p_dim]."""
    kf = cls(dim_x=2 * dim, dim_z=dim)
    # F = [[I, dt I], [0, I]], dt = 1 frame: p' = p + v, v' = v
    F = np.eye(2 * dim)
    for i in range(dim):
        F[i, dim + i] = 1.0
    kf.F = F
    # H = [I, 0]: the window gives the position only
    kf.H = np.hstack([np.eye(dim), np.zeros((dim, dim))])
    # R = meas_var I
    kf.R = np.eye(dim) * meas_var
    # Q = accel_var [[dt^4/4, dt^3/2], [dt^3/2, dt^2]] per coordinate (white acceleration noise)
    kf.Q = Q_discrete_white_noise(dim=2, dt=1.0, var=accel_var, block_size=dim, order_by_dim=False)
    return kf


def _innovation_sq(kf: KalmanFilter, u: float, v: float) -> float:
    # S = H P H' + R, y = z - H x, d^2 = y' S^-1 y
    S = kf.H @ kf.P @ kf.H.T + kf.R
    y = np.array([u, v]) - kf.H @ kf.x.reshape(-1)
    return float(y @ np.linalg.solve(S, y))


def _predict(kf: KalmanFilter) -> None:
    # x = F x
    # P = F P F' + Q
    kf.predict()


def _update(kf: KalmanFilter, z: np.ndarray, R: np.ndarray | None = None) -> None:
    # y = z - H x
    # S = H P H' + R  (R: the filter's, or this measurement's)
    # K = P H' S^-1
    # x = x + K y
    # P = (I - K H) P (I - K H)' + K R K'  (Joseph form)
    # H given: filterpy then takes z as it is (a 1-D vector, as the state is) instead of
    # reshaping it through np.atleast_2d each call; the same arithmetic
    kf.update(z, R, kf.H)


def steady_motion(frames: Sequence[int], us: Sequence[float], vs: Sequence[float], at_frame: int) -> np.ndarray:
    """The constant-velocity motion that best fits a few centres (least squares), as a centre
    filter's state at ``at_frame``: x = [u, v, du, dv] (px, px/frame).

    A walker keeps his pace over a second or two; the centre filter, which follows its
    measurements within a few frames, takes on the pace of a window that an occluder or a
    neighbour drags off him before he is called hidden, and coasting on that velocity carries
    the search the wrong way (a charcoal jacket going behind a sign: the window slid left onto
    another dark jacket for four frames, the coasted search went left while he walked right).

    Parameters
    ----------
    frames : sequence of int
        Frame numbers of the centres (at least two distinct ones).
    us, vs : sequence of float
        The centres, px.
    at_frame : int
        The frame the state is for (usually after the last centre: it is extrapolated).

    Raises
    ------
    ValueError
        Fewer than two distinct frames, or sequences of different lengths.
    """
    t = np.asarray(frames, dtype=np.float64) - at_frame
    if not len(t) == len(us) == len(vs):
        raise ValueError(f"frames, us and vs must have the same length, got {len(t)}, {len(us)}, {len(vs)}")
    if np.unique(t).size < 2:
        raise ValueError(f"a velocity needs centres in at least two frames, got frames {list(frames)!r}")
    # per coordinate c(t) = c0 + c1 t (t in frames from at_frame): coef = [[u0, v0], [du, dv]]
    coef = np.polynomial.polynomial.polyfit(t, np.column_stack([us, vs]), 1)
    return np.array([coef[0, 0], coef[0, 1], coef[1, 0], coef[1, 1]])


class CentreFilter:
    """Constant-velocity filter on the window centre (u, v), px and px/frame.

    Parameters
    ----------
    u, v : float
        The first centre, px (the velocity starts at 0, with a 5 px/frame sigma).
    accel_var : float
        Process noise: variance of the centre's acceleration, (px/frame^2)^2.
    meas_var : float
        Variance of a measured centre, px^2.
    """

    def __init__(self, u: float, v: float, accel_var: float = 2.0, meas_var: float = 4.0) -> None:
        self.kf = _cv_filter(2, accel_var, meas_var)
        self.kf.x = np.array([u, v, 0.0, 0.0])
        # P0 = diag(R, 5^2): the centre as measured, the velocity unknown
        self.kf.P = np.diag([meas_var, meas_var, 25.0, 25.0])

    def predict(self) -> tuple[float, float]:
        """Advance one frame; the predicted centre (where CAMShift searches), px."""
        _predict(self.kf)
        return float(self.kf.x[0]), float(self.kf.x[1])

    def update(self, u: float, v: float) -> None:
        """Fuse a measured centre.

        Parameters
        ----------
        u, v : float
            The window centre measured this frame, px.
        """
        _update(self.kf, np.array([u, v]))

    def innovation_sq(self, u: float, v: float) -> float:
        """Squared Mahalanobis distance of a measured centre from the predicted one (chi-square
        with 2 degrees of freedom for a centre the filter describes).

        Parameters
        ----------
        u, v : float
            A measured centre, px.
        """
        return _innovation_sq(self.kf, u, v)

    @property
    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the state x = [u, v, du, dv] and its covariance P."""
        return self.kf.x.copy(), self.kf.P.copy()

    def set_motion(self, x: np.ndarray) -> None:
        """Take the centre and velocity ``x`` = [u, v, du, dv] (px, px/frame) as the state; the
        covariance stays (as in :func:`steady_motion`'s use: the motion refitted, not better
        known).

        Parameters
        ----------
        x : np.ndarray
            The new state, 4 finite values.

        Raises
        ------
        ValueError
            Not 4 finite values.
        """
        x = np.asarray(x, dtype=np.float64).reshape(-1)
        if x.shape != (4,) or not np.isfinite(x).all():
            raise ValueError(f"a centre state is 4 finite values [u, v, du, dv], got {x!r}")
        self.kf.x = x.copy()


class OcclusionCoaster:
    """Coasts the hidden target's centre; its uncertainty widens the search region.

    Parameters
    ----------
    x, P : np.ndarray
        The centre filter's state [u, v, du, dv] and covariance when the target was hidden.
    accel_var : float
        Process noise while coasting, (px/frame^2)^2: larger than the centre filter's, as a
        hidden target may do anything.
    """

    def __init__(self, x: np.ndarray, P: np.ndarray, accel_var: float = 6.0) -> None:
        self.kf = _cv_filter(2, accel_var, 4.0)
        self.kf.x = x.copy()
        self.kf.P = P.copy()
        #: whether :meth:`keep_within` has put the centre back on the picture since the target
        #: was hidden: its coasted window reached the edge (it left past it, or stood at it
        #: and the coasting's noise took the centre a little past the margin)
        self.held_at_edge = False

    def predict(self) -> tuple[float, float]:
        """Advance one frame with no measurement; the coasted centre, px."""
        _predict(self.kf)
        return float(self.kf.x[0]), float(self.kf.x[1])

    def keep_within(self, width: float, height: float, margin_x: float = 0.0, margin_y: float = 0.0) -> bool:
        """Keep the coasted centre on the picture, at least ``margin_x`` / ``margin_y`` from
        its edges (the middle, for a picture narrower than twice the margin): a coordinate
        past that is put back on it and its speed along that axis stopped (a target that
        left past an edge is just past it, not still travelling away). Whether it was put
        back (and :attr:`held_at_edge` from then on); :attr:`centre` is where it is now.

        Parameters
        ----------
        width, height : float
            The picture's size, px.
        margin_x, margin_y : float
            How far from the edges the centre stays, px (half the window's width and height:
            the window stays whole on the picture).

        Raises
        ------
        ValueError
            A size that is not finite and positive, or a margin that is NaN (it would leave the
            centre where it is yet stop its speed and say it was put back); an infinite margin
            is one over half the picture: the middle.
        """
        if not (0 < width < math.inf and 0 < height < math.inf) or math.isnan(margin_x) or math.isnan(margin_y):
            raise ValueError(
                f"a picture of finite positive size and margins that are numbers, got {width!r} x {height!r}, "
                f"margins {margin_x!r}, {margin_y!r}"
            )
        x = self.kf.x
        put_back = False
        for i, size, margin in ((0, width, margin_x), (1, height, margin_y)):
            lo, hi = min(margin, size / 2.0), max(size - margin, size / 2.0)
            if not lo <= x[i] <= hi:
                x[i] = min(max(float(x[i]), lo), hi)
                x[i + 2] = 0.0
                put_back = True
        self.held_at_edge |= put_back
        return put_back

    @property
    def centre(self) -> tuple[float, float]:
        """The coasted centre, px."""
        return float(self.kf.x[0]), float(self.kf.x[1])

    @property
    def sigma_px(self) -> float:
        """1-sigma position uncertainty (the larger axis), px."""
        return float(math.sqrt(max(self.kf.P[0, 0], self.kf.P[1, 1])))


class _ScalarKalmanFilter(KalmanFilter):
    """filterpy's KalmanFilter for one measured coordinate, with the measurement's likelihood
    in closed form: filterpy's own goes through scipy's multivariate normal (0.07-0.15 ms a
    call on the machine this was written on), which the IMM asks of each model each frame.
    The same value (to rounding), and the same floor for a likelihood that underflows to 0."""

    @property
    def likelihood(self) -> float:
        # N(y; 0, S) = exp(-(y^2 / S + log(2 pi S)) / 2), y and S of the last update
        S = float(self.S.item())
        y = float(self.y.item())
        return math.exp(-0.5 * (y * y / S + math.log(2.0 * math.pi * S))) or sys.float_info.min

    def update(self, z: np.ndarray, R: np.ndarray | None = None, H: np.ndarray | None = None) -> None:
        # H given: filterpy takes z as it is instead of reshaping it each call (as _update)
        super().update(z, R, self.H if H is None else H)


class AreaFilter:
    """The window's size, filtered; the gate flags collapses and jumps.

    The size may be sqrt(w h) in px, or its logarithm (as the tracker runs it: a scale
    changes by factors, so its noise is a fraction of the size, whatever the size).

    With ``hold_var`` None this is one constant-velocity filter (the size grows or shrinks at
    a steady rate). With a ``hold_var`` it is an interacting multiple model (IMM, Blom and
    Bar-Shalom 1988; filterpy's :class:`~filterpy.kalman.IMMEstimator`) of that filter and a
    second one in which the size holds, jittering by ``hold_var`` a frame, its rate zero. Each
    frame the two are mixed by how well each predicted the measured sizes, so a target that
    stops approaching is held at its size instead of extrapolated along the rate it had,
    and one that keeps approaching is followed at its rate (when the sizes are precise
    enough to tell the two apart; with noisy ones the mixture stays near even). The gate
    reads the mixture; filterpy weighs the predicted models by the last frame's mode
    probabilities (not yet moved by the chance of a switch, less than ``switch_prob``).

    Under the IMM, :attr:`kf` is the steady-rate model; :attr:`x`, :attr:`P` and
    :attr:`size` are the mixture's.

    Parameters
    ----------
    size_px : float
        The first window's size (sqrt(w h), px, or its logarithm).
    accel_var : float
        Process noise of the steady-rate model: variance of the size's acceleration, (size
        unit / frame^2)^2.
    meas_var : float
        Variance of a measured size, (size unit)^2.
    gate_sigma : float
        A size further than this many innovation sigmas from the prediction is flagged.
    rate_var : float
        Variance of the size's rate of change at the start, (size unit / frame)^2.
    size_var : float, optional
        Variance of the first size (default ``meas_var``: as uncertain as a measurement).
    hold_var : float, optional
        The holding model's variance of the size's change a frame, (size unit)^2; None
        (the default) for the steady-rate filter alone.
    switch_prob : float
        With ``hold_var``: the chance a frame that the target switches from one model to the
        other (0.03: it keeps one for about 33 frames, a second at 30 frames a second).

    Raises
    ------
    ValueError
        ``hold_var`` negative or not finite, or ``switch_prob`` outside (0, 1).
    """

    def __init__(
        self,
        size_px: float,
        accel_var: float = 0.3,
        meas_var: float = 4.0,
        gate_sigma: float = 3.5,
        rate_var: float = 4.0,
        size_var: float | None = None,
        hold_var: float | None = None,
        switch_prob: float = 0.03,
    ) -> None:
        self.kf = _cv_filter(1, accel_var, meas_var, _ScalarKalmanFilter)
        self.kf.x = np.array([size_px, 0.0])
        # P0 = diag(size_var, rate_var): the first size, its rate unknown
        self.kf.P = np.diag([meas_var if size_var is None else size_var, rate_var])
        self.gate_sigma = gate_sigma
        self.meas_var = meas_var
        self._imm: IMMEstimator | None = None
        if hold_var is not None:
            if not (hold_var >= 0.0 and math.isfinite(hold_var)):
                raise ValueError(f"hold_var must be >= 0, got {hold_var!r}")
            if not 0.0 < switch_prob < 1.0:
                raise ValueError(f"switch_prob must be in (0, 1), got {switch_prob!r}")
            hold = _ScalarKalmanFilter(dim_x=2, dim_z=1)
            # F = [[1, 0], [0, 0]]: the size stays, its rate is zero
            hold.F = np.array([[1.0, 0.0], [0.0, 0.0]])
            hold.H = self.kf.H.copy()
            hold.R = self.kf.R.copy()
            # Q = diag(hold_var, 0): the size jitters, the rate stays zero
            hold.Q = np.diag([hold_var, 0.0])
            hold.x = self.kf.x.copy()
            hold.P = self.kf.P.copy()
            # M[i, j]: chance of going from model i to model j in a frame; mu: both equally likely
            M = np.array([[1.0 - switch_prob, switch_prob], [switch_prob, 1.0 - switch_prob]])
            self._imm = IMMEstimator([self.kf, hold], np.array([0.5, 0.5]), M)

    @property
    def _estimate(self) -> KalmanFilter | IMMEstimator:
        # what holds the estimate: the one filter, or the IMM's mixture
        return self.kf if self._imm is None else self._imm

    @property
    def x(self) -> np.ndarray:
        """A copy of the state [size, rate] (the models' mixture with ``hold_var``)."""
        return self._estimate.x.copy()

    @property
    def P(self) -> np.ndarray:
        """A copy of the state's covariance (the mixture's, the models' spread included)."""
        return self._estimate.P.copy()

    @property
    def size(self) -> float:
        """The filtered size (size unit)."""
        return float(self._estimate.x[0])

    @property
    def hold_probability(self) -> float | None:
        """How likely the size is holding rather than changing steadily (None without ``hold_var``)."""
        return None if self._imm is None else float(self._imm.mu[1])

    def hold(self) -> None:
        """Set the size's rate to zero in every model: the size holds from here (a target not
        measured, as when hidden, is not extrapolated). The mixture's :attr:`P` keeps the
        models' spread of rates until the next :meth:`predict`."""
        self.kf.x[1] = 0.0  # the steady-rate model (the holding model's rate is zero by its F)
        if self._imm is not None:
            self._imm.x[1] = 0.0

    def predict(self) -> float:
        """Advance one frame; the predicted size."""
        if self._imm is None:
            _predict(self.kf)
        else:
            # each model starts from the mixture of both, weighted by the chance of a switch,
            # then predicts by its own F and Q; the estimate is their mixture by mu
            self._imm.predict()
        return self.size

    def innovation_sigma(self, size_px: float) -> float:
        """|measurement - prediction| in standard deviations of the innovation.

        Parameters
        ----------
        size_px : float
            A measured size.
        """
        # S = H P H' + R, with the mixture's P: P[0, 0] + R
        S = float(self._estimate.P[0, 0]) + self.meas_var
        # |y| / sqrt(S), y = z - H x
        return abs(size_px - self.size) / math.sqrt(S)

    def consistent(self, size_px: float) -> bool:
        """Within the gate (no occlusion or jump flagged).

        Parameters
        ----------
        size_px : float
            A measured size.
        """
        return self.innovation_sigma(size_px) <= self.gate_sigma

    def update(self, size_px: float, meas_var: float | None = None) -> None:
        """Fuse a measured size.

        Parameters
        ----------
        size_px : float
            The window's size measured this frame (sqrt(w h), px, or its logarithm).
        meas_var : float, optional
            This measurement's variance, when it is not the filter's ``meas_var`` (a more
            precise sensor).
        """
        z = np.array([size_px])
        R = None if meas_var is None else np.array([[meas_var]])
        if self._imm is None:
            _update(self.kf, z, R)
            return
        # each model updates on the measurement; mu_j ~ (chance of j before) x (likelihood of
        # the measurement under j), and the estimate is their mixture by mu
        if R is None:
            self._imm.update(z)
            return
        saved = [f.R for f in self._imm.filters]
        for f in self._imm.filters:
            f.R = R
        try:
            self._imm.update(z)
        finally:
            for f, r in zip(self._imm.filters, saved, strict=True):
                f.R = r
