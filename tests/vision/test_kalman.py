"""The tracker's three Kalman filters, with numbers worked by hand from
x = F x, P = F P F' + Q (predict) and y = z - H x, S = H P H' + R, K = P H' S^-1 (update)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lfctl.vision.kalman import AreaFilter, CentreFilter, OcclusionCoaster, steady_motion


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


def test_size_imm_one_predict_and_update_by_hand() -> None:
    # both models start at x = [0, 0], P = diag(1, 1); R = 1; steady-rate Q = 0, holding Q = 0
    f = AreaFilter(0.0, accel_var=0.0, meas_var=1.0, rate_var=1.0, size_var=1.0, hold_var=0.0, switch_prob=0.1)
    assert f.hold_probability == 0.5
    assert f.predict() == 0.0
    # steady rate: F = [[1, 1], [0, 1]]: P = [[2, 1], [1, 1]]; holding: F = [[1, 0], [0, 0]]: P = diag(1, 0)
    # the mixture (same means): P = (P_cv + P_hold) / 2
    assert np.allclose(f.P, [[1.5, 0.5], [0.5, 0.5]])
    assert f.innovation_sigma(2.0) == pytest.approx(2.0 / math.sqrt(1.5 + 1.0))
    f.update(2.0)
    # S_cv = 3, S_hold = 2; likelihoods N(2; 0, S); mu ~ 0.5 L (both models equally likely before)
    l_cv = math.exp(-4 / 6) / math.sqrt(2 * math.pi * 3)
    l_hold = math.exp(-4 / 4) / math.sqrt(2 * math.pi * 2)
    mu_hold = l_hold / (l_cv + l_hold)
    assert f.hold_probability == pytest.approx(mu_hold)
    # steady rate: K = (2, 1) / 3, x = (4/3, 2/3); holding: K = (1/2, 0), x = (1, 0)
    x = (1 - mu_hold) * np.array([4 / 3, 2 / 3]) + mu_hold * np.array([1.0, 0.0])
    assert np.allclose(f.x, x)
    assert f.size == pytest.approx(x[0])
    # second predict: the models mix. M = [[0.9, 0.1], [0.1, 0.9]]; cbar_j = sum_i M_ij mu_i;
    # model j starts from sum_i omega_ij x_i, omega_ij = M_ij mu_i / cbar_j
    mu = np.array([1 - mu_hold, mu_hold])
    cbar = np.array([0.9 * mu[0] + 0.1 * mu[1], 0.1 * mu[0] + 0.9 * mu[1]])
    assert cbar == pytest.approx([0.52608, 0.47392], abs=1e-5)
    x_cv, x_hold = np.array([4 / 3, 2 / 3]), np.array([1.0, 0.0])
    start_cv = (0.9 * mu[0] * x_cv + 0.1 * mu[1] * x_hold) / cbar[0]
    start_hold = (0.1 * mu[0] * x_cv + 0.9 * mu[1] * x_hold) / cbar[1]
    # steady rate: size + rate, rate; holding: size, 0; the estimate: their mixture by mu
    pred = mu[0] * np.array([start_cv[0] + start_cv[1], start_cv[1]]) + mu[1] * np.array([start_hold[0], 0.0])
    assert f.predict() == pytest.approx(pred[0])
    assert np.allclose(f.x, pred) and pred == pytest.approx([1.50279, 0.32352], abs=1e-5)


def test_size_imm_survives_a_measurement_neither_model_explains() -> None:
    f = AreaFilter(0.0, accel_var=1e-6, meas_var=1e-4, rate_var=1e-4, size_var=1e-4, hold_var=1e-5)
    for i in range(1, 21):
        f.predict()
        f.update(0.02 * i)
    f.predict()
    # both likelihoods underflow to 0: their floor keeps the mode probabilities (no 0 / 0)
    f.update(4.0, meas_var=4e-4)
    assert np.all(np.isfinite(f.x)) and np.all(np.isfinite(f.P)) and 0.0 <= f.hold_probability <= 1.0


def test_size_imm_a_precise_measurement_leaves_the_filters_own_noise() -> None:
    f = AreaFilter(0.0, accel_var=0.0, meas_var=1.0, rate_var=1.0, size_var=1.0, hold_var=0.0)
    f.predict()
    f.update(0.5, meas_var=0.01)
    # steady rate: K_p = 2 / 2.01; holding: K_p = 1 / 1.01; both pull the size nearly to 0.5
    assert f.size == pytest.approx(0.5, abs=0.01)
    assert all(m.R[0, 0] == 1.0 for m in f._imm.filters)  # the next size is a plain one again


def _imm_error_after(sizes: list[float], hold_var: float | None) -> list[float]:
    f = AreaFilter(sizes[0], accel_var=1e-6, meas_var=1e-4, rate_var=1e-4, size_var=1e-4, hold_var=hold_var)
    rng = np.random.default_rng(3)
    errs = []
    for s in sizes[1:]:
        f.predict()
        f.update(s + float(rng.normal(0.0, 0.01)))
        errs.append(abs(f.size - s))
    return errs


def test_size_imm_holds_a_target_that_stops_and_follows_one_that_keeps_growing() -> None:
    # log size grows 2 % a frame for 30 frames, then holds for 30 (a walker who stops)
    grow = [0.02 * i for i in range(31)]
    stop = grow + [grow[-1]] * 30
    cv_alone = _imm_error_after(stop, None)
    imm = _imm_error_after(stop, 1e-5)
    # after the stop the steady-rate filter alone runs on along the old rate for a while;
    # the mixture switches to holding and errs less
    assert max(imm[32:45]) < 0.5 * max(cv_alone[32:45])
    # while the target keeps growing, the mixture follows it as closely as the steady-rate
    # filter alone (the holding model would lag one rate's worth of frames behind)
    assert np.mean(imm[10:30]) < 2.0 * np.mean(cv_alone[10:30]) + 0.002
    g = AreaFilter(0.0, accel_var=1e-6, meas_var=1e-4, rate_var=1e-4, size_var=1e-4, hold_var=1e-5)
    for i in range(1, 31):
        g.predict()
        g.update(0.02 * i)
    assert g.hold_probability is not None and g.hold_probability < 0.1 and g.x[1] == pytest.approx(0.02, rel=0.1)


def test_size_imm_hold_stops_every_model() -> None:
    f = AreaFilter(0.0, accel_var=1e-6, meas_var=1e-4, rate_var=1e-4, size_var=1e-4, hold_var=1e-5)
    for i in range(1, 20):
        f.predict()
        f.update(0.03 * i)
    assert f.x[1] > 0.02
    f.hold()
    size = f.size
    assert f.x[1] == 0.0
    # no model extrapolates a rate (0.03 a frame before); the mixture moves only as the
    # models' weights do, their sizes being a little apart
    assert f.predict() == pytest.approx(size, abs=1e-3)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-0.5, 0.5), min_size=1, max_size=40), st.floats(1e-6, 1e-2), st.floats(0.001, 0.5))
def test_size_imm_stays_a_probability_and_a_covariance(steps: list, hold_var: float, p: float) -> None:
    f = AreaFilter(3.0, accel_var=1e-6, meas_var=0.04, rate_var=1e-4, size_var=4e-4, hold_var=hold_var, switch_prob=p)
    s = 3.0
    for d in steps:
        f.predict()
        s += d
        f.update(s, meas_var=4e-4 if d > 0.4 else None)
        assert 0.0 <= f.hold_probability <= 1.0
        assert np.allclose(f.P, f.P.T) and np.all(np.linalg.eigvalsh(f.P) >= -1e-12)
        assert math.isfinite(f.size)


@pytest.mark.parametrize(("hold_var", "p"), [(-1.0, 0.03), (math.nan, 0.03), (1e-4, 0.0), (1e-4, 1.0)])
def test_size_imm_refuses_bad_settings(hold_var: float, p: float) -> None:
    with pytest.raises(ValueError, match=r"hold_var|switch_prob"):
        AreaFilter(0.0, hold_var=hold_var, switch_prob=p)


def test_steady_motion_by_hand() -> None:
    """Centres (10, 5) at frame 2, (14, 5) at 3, (16, 6) at 4: least squares per coordinate,
    t = frame - 5 = -3, -2, -1 (mean -2). u: slope = sum((t + 2)(u - 40/3)) / sum((t + 2)^2)
    = ((-1)(-10/3) + 0 + (1)(8/3)) / 2 = 3; intercept at t = 0: 40/3 + 3 * 2 = 58/3.
    v: slope = ((-1)(-1/3) + 0 + (1)(2/3)) / 2 = 0.5; at t = 0: 16/3 + 0.5 * 2 = 19/3."""
    x = steady_motion([2, 3, 4], [10.0, 14.0, 16.0], [5.0, 5.0, 6.0], at_frame=5)
    np.testing.assert_allclose(x, [58 / 3, 19 / 3, 3.0, 0.5], atol=1e-12)


@given(
    st.floats(-500, 500),
    st.floats(-500, 500),
    st.floats(-20, 20),
    st.floats(-20, 20),
    st.lists(st.integers(0, 200), min_size=2, max_size=30, unique=True),
)
def test_steady_motion_recovers_a_constant_velocity(u0: float, v0: float, du: float, dv: float, frames: list) -> None:
    at = max(frames) + 3
    us = [u0 + du * (f - at) for f in frames]
    vs = [v0 + dv * (f - at) for f in frames]
    np.testing.assert_allclose(steady_motion(frames, us, vs, at), [u0, v0, du, dv], atol=1e-6)


@pytest.mark.parametrize(
    ("frames", "us", "vs", "message"),
    [
        ([3], [1.0], [1.0], "two frames"),
        ([3, 3], [1.0, 2.0], [1.0, 2.0], "two frames"),
        ([1, 2], [1.0], [1.0, 2.0], "same length"),
    ],
)
def test_steady_motion_refuses_what_has_no_velocity(frames: list, us: list, vs: list, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        steady_motion(frames, us, vs, 5)


def test_centre_filter_takes_a_motion_and_keeps_its_covariance() -> None:
    f = CentreFilter(10.0, 20.0)
    _, P = f.state
    f.set_motion(np.array([1.0, 2.0, 3.0, 4.0]))
    x, P2 = f.state
    np.testing.assert_array_equal(x, [1.0, 2.0, 3.0, 4.0])
    np.testing.assert_array_equal(P2, P)
    assert f.predict() == (4.0, 6.0)
    for bad in ([1.0, 2.0, 3.0], [1.0, 2.0, float("nan"), 4.0]):
        with pytest.raises(ValueError, match="4 finite values"):
            f.set_motion(np.array(bad))


@pytest.mark.parametrize(
    ("size", "margins"),
    [
        ((640.0, 480.0), (float("nan"), 30.0)),
        ((640.0, 480.0), (20.0, float("nan"))),
        ((float("nan"), 480.0), (20.0, 30.0)),
        ((640.0, float("inf")), (20.0, 30.0)),
        ((0.0, 480.0), (20.0, 30.0)),
        ((640.0, -1.0), (20.0, 30.0)),
    ],
)
def test_the_coaster_refuses_a_picture_or_margin_it_cannot_keep_a_centre_within(size: tuple, margins: tuple) -> None:
    # Wrong, a NaN margin passed every comparison: the centre stayed where it was, its speed
    # was stopped, and keep_within said it had put it back.
    c = OcclusionCoaster(np.array([100.0, 100.0, 3.0, 3.0]), np.eye(4))
    with pytest.raises(ValueError, match="finite positive size and margins that are numbers"):
        c.keep_within(*size, *margins)
    assert c.kf.x.tolist() == [100.0, 100.0, 3.0, 3.0]
    # an infinite margin is one over half the picture: the middle, as the docstring says
    assert c.keep_within(640.0, 480.0, float("inf"), 30.0) is True
    assert c.centre == (320.0, 100.0)
