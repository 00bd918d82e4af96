import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.slam.metrics import trajectory_errors

TRUTH = [Pose2D(0.1 * i, 0.05 * i * i, 0.1 * i) for i in range(20)]


@given(st.floats(-10, 10), st.floats(-10, 10), st.floats(-math.pi, math.pi))
def test_a_rigidly_moved_estimate_has_no_error(dx, dy, angle):
    offset = Pose2D(dx, dy, angle)
    moved = [offset.compose(p) for p in TRUTH]
    errors = trajectory_errors(moved, TRUTH)
    assert errors.ate_rmse_m == pytest.approx(0.0, abs=1e-6)
    assert errors.ate_rmse_deg == pytest.approx(0.0, abs=1e-6)
    assert errors.rpe_trans_mean_m == pytest.approx(0.0, abs=1e-6)
    assert errors.rpe_rot_mean_deg == pytest.approx(0.0, abs=1e-6)


def test_one_wrong_step_shows_in_rpe_once():
    est = [*TRUTH[:10], *(Pose2D(p.x + 0.2, p.y, p.yaw) for p in TRUTH[10:])]
    errors = trajectory_errors(est, TRUTH)
    # Only the step from pose 9 to 10 is wrong (by 0.2 m), so the mean over 19 steps is 0.2 / 19.
    assert errors.rpe_trans_mean_m == pytest.approx(0.2 / 19, rel=1e-6)
    assert errors.ate_rmse_m > 0.05


def test_lengths_must_match():
    with pytest.raises(InvalidInputError, match="matched poses"):
        trajectory_errors(TRUTH[:3], TRUTH[:4])
