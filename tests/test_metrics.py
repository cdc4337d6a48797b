"""Formation figures by hand."""

from __future__ import annotations

import numpy as np
import pytest

from lfctl.metrics import sign_changes, variation_per_s


def test_variation_per_s_sums_the_command_s_moves_over_the_run() -> None:
    # |1-0| + |0-1| + |1-0| = 3 over 4 samples of 0.5 s = 2 s
    assert variation_per_s([0.0, 1.0, 0.0, 1.0], 0.5) == pytest.approx(1.5)
    assert variation_per_s([0.3] * 10, 0.05) == 0.0
    assert variation_per_s([0.3], 0.05) == 0.0


def test_sign_changes_ignore_swings_inside_the_deadband() -> None:
    assert sign_changes(np.array([0.1, -0.1, 0.01, -0.01, 0.1]), 0.05) == 2
