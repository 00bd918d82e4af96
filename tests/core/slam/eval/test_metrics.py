import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.slam.eval.metrics import affine_fit, trajectory_errors, windowed_ate

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


def test_windowed_ate_sees_local_agreement_that_a_bend_hides_from_the_global_ate():
    # A straight 40-pose track whose second half the estimate bends by 10 degrees at pose 20.
    truth = [Pose2D(0.5 * i, 0.0, 0.0) for i in range(40)]
    bend = Pose2D(10.0, 0.0, math.radians(10.0))
    estimate = [*truth[:20], *(bend.compose(Pose2D(p.x - 10.0, 0.0, 0.0)) for p in truth[20:])]
    assert trajectory_errors(estimate, truth).ate_rmse_m > 0.2
    # Windows of 10 every 5 poses: 7 windows, 6 of them on one side of the bend (exact), so the median is 0.
    assert windowed_ate(estimate, truth, window=10) == pytest.approx(0.0, abs=1e-9)
    with pytest.raises(InvalidInputError, match="windowed ATE"):
        windowed_ate(estimate[:5], truth[:5], window=10)


def test_affine_fit_takes_a_stretched_building_as_one_deformation():
    # A 20 m x 10 m loop the estimate stretches by 1 % along x and moves rigidly: an ATE of centimetres that an
    # affine map removes entirely, with the stretches read back.
    truth = [Pose2D(x, y, 0.0) for x in range(21) for y in (0.0, 10.0)]
    moved = Pose2D(3.0, -2.0, 0.4)
    estimate = [moved.compose(Pose2D(1.01 * p.x, p.y, 0.0)) for p in truth]
    fit = affine_fit(estimate, truth)
    assert trajectory_errors(estimate, truth).ate_rmse_m > 0.02
    assert fit.residual_rms_m == pytest.approx(0.0, abs=1e-9)
    # The fit maps the estimate onto the truth: it undoes the stretch along x and keeps y.
    assert fit.stretch_min == pytest.approx(1 / 1.01, rel=1e-9)
    assert fit.stretch_max == pytest.approx(1.0, rel=1e-9)


def test_affine_fit_leaves_a_local_error_in_place():
    truth = [Pose2D(0.5 * i, 0.1 * (i % 7), 0.0) for i in range(40)]
    estimate = [Pose2D(p.x, p.y + (0.3 if i == 20 else 0.0), 0.0) for i, p in enumerate(truth)]
    assert affine_fit(estimate, truth).residual_rms_m > 0.03
    with pytest.raises(InvalidInputError, match="affine fit"):
        affine_fit(truth[:2], truth[:2])
