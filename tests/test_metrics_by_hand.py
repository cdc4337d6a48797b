"""formation_metrics's headline figures by hand: the errors after the settling time, the
closest approach, the control effort and the chattering rate."""

from __future__ import annotations

import pytest

from lfctl.metrics import formation_metrics


def test_the_headline_figures_of_three_samples_by_hand() -> None:
    # Wrong, the run summary and `lfctl audit` would print wrong or empty figures.
    # By hand: samples at 4, 5, 6 s, 0.5 s apart; the errors count from 5 s: range errors
    # (0.3, -0.4): RMS sqrt((0.09 + 0.16) / 2) = 0.353553, max 0.4; bearing errors (0.1, -0.2):
    # RMS sqrt(0.05 / 2) = 0.158114, max 0.2. Closest approach over the run: 1.2. Control
    # effort (0.5 + 0.5 + 0.25) * 0.5 = 0.625. The yaw rate swings + - +: 2 sign changes over
    # 3 * 0.5 = 1.5 s: 1.33333 per s.
    m = formation_metrics(
        "f1",
        "leader",
        1.5,
        0.0,
        [4.0, 5.0, 6.0],
        [9.0, 0.3, -0.4],
        [9.0, 0.1, -0.2],
        [2.0, 1.2, 1.7],
        ["tracking"] * 3,
        [0.5, -0.5, 0.25],
        0.5,
    )
    assert (m.name, m.target, m.range_cmd_m, m.bearing_cmd_rad) == ("f1", "leader", 1.5, 0.0)
    assert m.range_err_rms_m == pytest.approx(0.353553, abs=1e-6)
    assert m.range_err_max_m == pytest.approx(0.4, abs=1e-12)
    assert m.bearing_err_rms_rad == pytest.approx(0.158114, abs=1e-6)
    assert m.bearing_err_max_rad == pytest.approx(0.2, abs=1e-12)
    assert m.min_separation_m == pytest.approx(1.2, abs=1e-12)
    assert m.control_effort_rad == pytest.approx(0.625, abs=1e-12)
    assert m.chattering_per_s == pytest.approx(2.0 / 1.5, rel=1e-12)
    assert m.time_in_state_s == {"tracking": 1.5, "occluded": 0.0, "lost": 0.0}


def test_the_chattering_rate_of_a_run_under_a_second_and_of_an_empty_one() -> None:
    # Wrong, a short run's chattering would read 0, or an empty run's 1 (or a division by 0).
    # By hand: two samples 0.4 s apart swinging + -: 1 change over 0.8 s = 1.25 per s.
    # (The report's single sample cannot change sign, so it reads 0 whatever the duration test.)
    m = formation_metrics(
        "f1", "leader", 1.5, 0.0, [0.0, 0.4], [0.0] * 2, [0.0] * 2, [2.0] * 2, ["tracking"] * 2, [0.5, -0.5], 0.4
    )
    assert m.chattering_per_s == pytest.approx(1.25, rel=1e-12)
    # no samples: no duration, 0.0; nothing else to report
    m = formation_metrics("f1", "leader", 1.5, 0.0, [], [], [], [], [], [], 0.5)
    assert m.chattering_per_s == 0.0 and m.control_effort_rad == 0.0
    assert (m.range_err_rms_m, m.min_separation_m) == (None, None)
