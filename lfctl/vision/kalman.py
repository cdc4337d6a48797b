"""The tracker's three Kalman filters (paper section 1), with filterpy.

1. :class:`CentreFilter`: constant velocity on the window centre (pixels, per frame); its
   prediction is where CAMShift searches next frame.
2. :class:`OcclusionCoaster`: takes the centre filter's position and velocity when the
   target disappears and keeps coasting them, with a larger process noise, so the search
   region follows the hidden target and widens with the uncertainty until it reappears.
3. :class:`AreaFilter`: constant velocity on the window's size (square root of its area); a
   normalised innovation beyond a gate flags an occlusion early (the window collapsing as an
   occluder slides over the target, or jumping onto something else).
"""

from __future__ import annotations

import math

import numpy as np
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import KalmanFilter


def _cv_filter(dim: int, accel_var: float, meas_var: float) -> KalmanFilter:
    kf = KalmanFilter(dim_x=2 * dim, dim_z=dim)
    F = np.eye(2 * dim)
    for i in range(dim):
        F[i, dim + i] = 1.0  # one frame
    kf.F = F
    kf.H = np.hstack([np.eye(dim), np.zeros((dim, dim))])
    kf.R = np.eye(dim) * meas_var
    kf.Q = Q_discrete_white_noise(dim=2, dt=1.0, var=accel_var, block_size=dim, order_by_dim=False)
    return kf


class CentreFilter:
    """Constant-velocity filter on the window centre (u, v), px and px/frame."""

    def __init__(self, u: float, v: float, accel_var: float = 2.0, meas_var: float = 4.0) -> None:
        self.kf = _cv_filter(2, accel_var, meas_var)
        self.kf.x = np.array([u, v, 0.0, 0.0])
        self.kf.P = np.diag([meas_var, meas_var, 25.0, 25.0])

    def predict(self) -> tuple[float, float]:
        self.kf.predict()
        return float(self.kf.x[0]), float(self.kf.x[1])

    def update(self, u: float, v: float) -> None:
        self.kf.update(np.array([u, v]))

    @property
    def state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.kf.x.copy(), self.kf.P.copy()


class OcclusionCoaster:
    """Coasts the hidden target's centre; its uncertainty widens the search region."""

    def __init__(self, x: np.ndarray, P: np.ndarray, accel_var: float = 6.0) -> None:
        self.kf = _cv_filter(2, accel_var, 4.0)
        self.kf.x = x.copy()
        self.kf.P = P.copy()

    def predict(self) -> tuple[float, float]:
        self.kf.predict()
        return float(self.kf.x[0]), float(self.kf.x[1])

    @property
    def sigma_px(self) -> float:
        """1-sigma position uncertainty (the larger axis), px."""
        return float(math.sqrt(max(self.kf.P[0, 0], self.kf.P[1, 1])))


class AreaFilter:
    """Constant-velocity filter on sqrt(window area); the gate flags collapses and jumps."""

    def __init__(self, size_px: float, accel_var: float = 0.3, meas_var: float = 4.0, gate_sigma: float = 3.5) -> None:
        self.kf = _cv_filter(1, accel_var, meas_var)
        self.kf.x = np.array([size_px, 0.0])
        self.kf.P = np.diag([meas_var, 4.0])
        self.gate_sigma = gate_sigma

    def predict(self) -> float:
        self.kf.predict()
        return float(self.kf.x[0])

    def innovation_sigma(self, size_px: float) -> float:
        """|measurement - prediction| in standard deviations of the innovation."""
        S = float((self.kf.H @ self.kf.P @ self.kf.H.T + self.kf.R)[0, 0])
        return abs(size_px - float(self.kf.x[0])) / math.sqrt(S)

    def consistent(self, size_px: float) -> bool:
        """Within the gate (no occlusion or jump flagged)."""
        return self.innovation_sigma(size_px) <= self.gate_sigma

    def update(self, size_px: float) -> None:
        self.kf.update(np.array([size_px]))

    @property
    def size_px(self) -> float:
        return float(self.kf.x[0])
