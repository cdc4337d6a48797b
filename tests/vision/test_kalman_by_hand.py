"""The centre gate and the defaults the tracker and ArUco use (they pass none of these), by
hand from x = F x, P = F P F' + Q and S = H P H' + R, d^2 = y' S^-1 y."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lfctl.vision.kalman import AreaFilter, CentreFilter, OcclusionCoaster


def test_the_centre_gate_is_the_squared_mahalanobis_distance_from_the_prediction() -> None:
    # Wrong, a banner-with-markers track would reject every plain-colour fix as "window jumped
    # off the track", or accept any jump.
    # By hand: P0 = diag(4, 4, 25, 25); after one predict P_pp = 4 + 25 + 2/4 = 29.5 per axis
    # and the axes are independent: S = diag(33.5, 33.5); y = (104 - 100, 53 - 50) = (4, 3):
    # d^2 = (16 + 9) / 33.5 = 0.746269.
    f = CentreFilter(100.0, 50.0)
    f.predict()
    assert f.innovation_sq(104.0, 53.0) == pytest.approx(25.0 / 33.5, rel=1e-12)
    assert f.innovation_sq(104.0, 53.0) == pytest.approx(0.746269, abs=1e-6)
    assert f.innovation_sq(100.0, 50.0) == 0.0  # on the prediction


def test_the_centre_filters_default_noise_by_hand() -> None:
    # Wrong, a re-tune of the tracker's search window (it builds the filter with the defaults)
    # would go unnoticed.
    # By hand: accel_var 2: Q per axis = 2 [[1/4, 1/2], [1/2, 1]] = [[0.5, 1], [1, 2]];
    # P0 = diag(4, 4, 25, 25): P_pp = 4 + 25 + 0.5 = 29.5, P_vv = 25 + 2 = 27.
    f = CentreFilter(0.0, 0.0)
    f.predict()
    _x, P = f.state
    assert np.diag(P) == pytest.approx([29.5, 29.5, 27.0, 27.0], rel=1e-12)
    # the default measurement variance, 4: after a fix on the prediction P_pp = 29.5 * 4 / 33.5
    f.update(0.0, 0.0)
    _x, P = f.state
    assert P[0, 0] == pytest.approx(29.5 * 4.0 / 33.5, rel=1e-12)


def test_the_occlusion_coasters_default_process_noise_by_hand() -> None:
    # Wrong, the search region round a hidden target would widen at another rate.
    # By hand: from P = 0, accel_var 6: P_pp = 6 / 4 = 1.5, sigma = sqrt(1.5) = 1.22474.
    c = OcclusionCoaster(np.zeros(4), np.zeros((4, 4)))
    c.predict()
    assert c.sigma_px == pytest.approx(math.sqrt(1.5), rel=1e-12)


def test_the_coaster_keeps_a_centre_that_left_the_picture_at_its_edge_by_hand() -> None:
    # Wrong, a target that left past an edge would be coasted on out of the picture, where no
    # search region reaches, and never looked for again.
    # By hand: from (630, 200) at (+12, -3) px a frame, P = 0: the predict gives (642, 197);
    # in a 640 x 480 picture with margins 20 x 30 the centre may be at u 20..620, v 30..450:
    # u is put back to 620 and its speed stopped; v, inside, keeps its place and speed.
    c = OcclusionCoaster(np.array([630.0, 200.0, 12.0, -3.0]), np.zeros((4, 4)))
    c.predict()
    assert c.held_at_edge is False
    assert c.keep_within(640, 480, 20.0, 30.0) is True
    assert c.held_at_edge is True  # it left past an edge
    assert c.centre == (620.0, 197.0)
    assert c.kf.x.tolist() == [620.0, 197.0, 0.0, -3.0]
    # the next frame it stays at the edge (no speed out) while v goes on
    c.predict()
    assert c.keep_within(640, 480, 20.0, 30.0) is False  # already there: nothing put back
    assert c.held_at_edge is True  # and it still left past an edge
    assert c.centre == (620.0, 194.0)
    # past the top-left corner, both axes are put back; a margin over half the picture: the middle
    c = OcclusionCoaster(np.array([-5.0, -8.0, -1.0, -2.0]), np.zeros((4, 4)))
    assert c.keep_within(640, 480, 400.0, 30.0) is True
    assert c.centre == (320.0, 30.0)
    assert c.kf.x.tolist() == [320.0, 30.0, 0.0, 0.0]
    # inside: nothing changes, exactly on the margin included
    c = OcclusionCoaster(np.array([20.0, 450.0, 5.0, 5.0]), np.zeros((4, 4)))
    assert c.keep_within(640, 480, 20.0, 30.0) is False
    assert c.held_at_edge is False
    assert c.centre == (20.0, 450.0)
    assert c.kf.x.tolist() == [20.0, 450.0, 5.0, 5.0]


def test_the_area_filters_default_gate_is_three_and_a_half_sigma() -> None:
    # Wrong, the tracker (which passes no gate_sigma) would flag occlusions at another size.
    # By hand: P0_pp = meas_var = 4, S = 4 + 4 = 8: 3.4 sigma is inside, 3.6 outside.
    f = AreaFilter(20.0)
    assert f.gate_sigma == 3.5
    assert f.consistent(20.0 + 3.4 * math.sqrt(8.0))
    assert not f.consistent(20.0 + 3.6 * math.sqrt(8.0))
    # after a predict, with accel_var 0.3 and rate_var 4: P_pp = 4 + 4 + 0.3 / 4 = 8.075,
    # S = 12.075
    f.predict()
    assert f.innovation_sigma(26.0) == pytest.approx(6.0 / math.sqrt(12.075), rel=1e-12)


def test_a_centre_state_given_as_a_row_or_a_column_is_taken() -> None:
    # Wrong, steady_motion's state handed as a (1, 4) or (4, 1) array would be refused.
    for x in (np.array([[1.0, 2.0, 3.0, 4.0]]), np.array([[1.0], [2.0], [3.0], [4.0]])):
        f = CentreFilter(0.0, 0.0)
        f.set_motion(x)
        assert f.state[0].tolist() == [1.0, 2.0, 3.0, 4.0]
