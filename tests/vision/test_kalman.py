"""The tracker's three Kalman filters, with numbers worked by hand from
x = F x, P = F P F' + Q (predict) and y = z - H x, S = H P H' + R, K = P H' S^-1 (update)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lfctl.vision.kalman import AreaFilter, CentreFilter, OcclusionCoaster


def test_centre_filter_one_predict_and_update_by_hand() -> None:
    f = CentreFilter(100.0, 50.0, accel_var=2.0, meas_var=4.0)
    # P0 = diag(4, 4, 25, 25); Q per axis = 2 [[1/4, 1/2], [1/2, 1]] = [[0.5, 1], [1, 2]]
    assert f.predict() == (100.0, 50.0)
    x, P = f.state
    # P_pp = 4 + 25 + 0.5, P_pv = 25 + 1, P_vv = 25 + 2
    assert (P[0, 0], P[0, 2], P[2, 2]) == pytest.approx((29.5, 26.0, 27.0))
    f.update(104.0, 50.0)
    x, P = f.state
    # S = 29.5 + 4; K = (29.5, 26) / 33.5; x = x + K (104 - 100)
    assert x[0] == pytest.approx(100 + 4 * 29.5 / 33.5)
    assert x[2] == pytest.approx(4 * 26 / 33.5)
    assert (x[1], x[3]) == pytest.approx((50.0, 0.0))
    assert P[0, 0] == pytest.approx(29.5 * 4 / 33.5)  # (1 - K_p) P_pp


def test_area_filter_gate_by_hand() -> None:
    f = AreaFilter(20.0, accel_var=0.3, meas_var=4.0, gate_sigma=3.5)
    # S = P_pp + R = 4 + 4
    assert f.innovation_sigma(26.0) == pytest.approx(6 / math.sqrt(8))
    assert f.predict() == 20.0
    # P_pp = 4 + 4 + 0.3 / 4 = 8.075; S = 12.075
    assert f.innovation_sigma(33.0) == pytest.approx(13 / math.sqrt(12.075))
    assert f.consistent(20.0 + 3.4 * math.sqrt(12.075)) and not f.consistent(33.0)


def test_occlusion_coaster_moves_on_and_grows_by_hand() -> None:
    c = OcclusionCoaster(np.array([10.0, 20.0, 1.0, -2.0]), np.diag([4.0, 4.0, 1.0, 1.0]), accel_var=6.0)
    # Q per axis = 6 [[1/4, 1/2], [1/2, 1]] = [[1.5, 3], [3, 6]]
    assert c.predict() == (11.0, 18.0)
    assert c.sigma_px == pytest.approx(math.sqrt(4 + 1 + 1.5))
    assert c.predict() == (12.0, 16.0)
    # P_pv = 0 + 1 + 3 = 4, P_vv = 1 + 6 = 7: P_pp = 6.5 + 2 * 4 + 7 + 1.5
    assert c.sigma_px == pytest.approx(math.sqrt(23.0))


@settings(max_examples=50, deadline=None)
@given(st.floats(0, 640), st.floats(0, 480), st.lists(st.tuples(st.floats(-20, 20), st.floats(-20, 20)), max_size=30))
def test_centre_filter_covariance_stays_symmetric_positive_definite(u: float, v: float, moves: list) -> None:
    f = CentreFilter(u, v)
    for du, dv in moves:
        pu, pv = f.predict()
        f.update(pu + du, pv + dv)
        _x, P = f.state
        assert np.allclose(P, P.T)
        assert np.all(np.linalg.eigvalsh(P) > 0)


@settings(max_examples=30, deadline=None)
@given(st.floats(-5, 5), st.floats(-5, 5))
def test_centre_filter_learns_a_constant_velocity(vu: float, vv: float) -> None:
    f = CentreFilter(320.0, 240.0)
    for k in range(1, 40):
        f.predict()
        f.update(320.0 + vu * k, 240.0 + vv * k)
    x, _P = f.state
    assert x[2] == pytest.approx(vu, abs=0.05) and x[3] == pytest.approx(vv, abs=0.05)


def test_a_measurement_at_the_prediction_leaves_the_centre_where_it_is() -> None:
    f = CentreFilter(100.0, 50.0)
    f.predict()
    f.update(103.0, 52.0)
    before, _ = f.state
    pu, pv = f.predict()
    f.update(pu, pv)
    after, _ = f.state
    assert after == pytest.approx(before + np.array([before[2], before[3], 0.0, 0.0]))
