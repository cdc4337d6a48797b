"""The target estimator's F and Q, made once per step length, against filterpy's model made
afresh every step (what predict() did before)."""

from __future__ import annotations

import numpy as np
from filterpy.common import Q_discrete_white_noise

from lfctl.guidance.formation import TargetEstimator


def test_predictions_match_a_model_made_every_step_bit_for_bit() -> None:
    rng = np.random.default_rng(2)
    fast, plain = TargetEstimator(0.3, 0.5), TargetEstimator(0.3, 0.5)
    for est in (fast, plain):
        est.init(4.0, -1.0)
    ticks = np.cumsum(rng.choice([5, 5, 5, 4, 6], 400))
    times = ticks * 0.01  # t - t_prev takes several floating-point values for one period
    for k in range(1, len(times)):
        dt = float(times[k] - times[k - 1])
        if k == 200:
            fast.accel_var = plain.accel_var = 0.9  # a new noise: a new Q
        fast.predict(dt)
        F = np.array([[1.0, 0.0, dt, 0.0], [0.0, 1.0, 0.0, dt], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
        plain.kf.F = F
        plain.kf.Q = Q_discrete_white_noise(dim=2, dt=dt, var=plain.accel_var, block_size=2, order_by_dim=False)
        plain.kf.predict()
        z = rng.normal(0, 5, 2)
        fast.update(*z)
        plain.update(*z)
        assert fast.kf.x.tobytes() == plain.kf.x.tobytes()
        assert fast.kf.P.tobytes() == plain.kf.P.tobytes()
        assert fast.kf.Q.tobytes() == plain.kf.Q.tobytes() and fast.kf.F.tobytes() == plain.kf.F.tobytes()
    assert 1 < len(fast._models) <= 64
