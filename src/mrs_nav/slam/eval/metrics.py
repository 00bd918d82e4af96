"""Trajectory error metrics: absolute trajectory error after SE(2) alignment, and relative pose error.

ATE (Sturm et al., IROS 2012): the estimate is rotated and translated (no scale) onto the ground truth by the
least-squares rigid fit of the positions (Umeyama / Kabsch in 2-D); the RMS of the remaining position errors
(m) and of the heading errors (deg, after the same rotation) are reported.
RPE (Kuemmerle et al., Autonomous Robots 2009): for consecutive pose pairs, the error of the estimated relative
motion against the true one, ``inv(T_gt_i^-1 T_gt_j) (T_est_i^-1 T_est_j)``; mean translation (m) and
rotation (deg).
Windowed ATE (:func:`windowed_ate`): the ATE of stretches of a few dozen consecutive poses, each aligned on its
own, median over the stretches: how well the two trajectories agree locally, apart from the bends and shifts
between distant parts that the global ATE sums up.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, Pose2D, wrap_angles


@dataclass(frozen=True)
class TrajectoryErrors:
    """ATE RMS (m, deg) after alignment and mean RPE over consecutive poses (m, deg)."""

    ate_rmse_m: float
    ate_rmse_deg: float
    rpe_trans_mean_m: float
    rpe_rot_mean_deg: float


def align_se2(estimate: FloatArray, truth: FloatArray) -> Pose2D:
    """The rigid motion (rotation and translation) that best maps ``estimate`` positions onto ``truth`` (N x 2),
    in the least-squares sense: ``align_se2(e, t).apply(e)`` is the aligned estimate."""
    mu_e, mu_t = estimate.mean(axis=0), truth.mean(axis=0)
    e, t = estimate - mu_e, truth - mu_t
    angle = math.atan2(float(np.sum(e[:, 0] * t[:, 1] - e[:, 1] * t[:, 0])), float(np.sum(e * t)))
    rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    shift = mu_t - rot @ mu_e
    return Pose2D(float(shift[0]), float(shift[1]), angle)


def trajectory_errors(estimate: Sequence[Pose2D], truth: Sequence[Pose2D]) -> TrajectoryErrors:
    """ATE and RPE of ``estimate`` against ``truth`` (same length, corresponding poses)."""
    if len(estimate) != len(truth) or len(estimate) < 2:
        raise InvalidInputError(f"trajectory errors need >= 2 matched poses, got {len(estimate)} and {len(truth)}")
    est = np.array([[p.x, p.y, p.yaw] for p in estimate])
    gt = np.array([[p.x, p.y, p.yaw] for p in truth])
    alignment = align_se2(est[:, :2], gt[:, :2])
    pos_err = np.linalg.norm(alignment.apply(est[:, :2]) - gt[:, :2], axis=1)
    yaw_err = wrap_angles(est[:, 2] + alignment.yaw - gt[:, 2])
    trans, rot = [], []
    for i in range(1, len(estimate)):
        d_est = estimate[i].relative_to(estimate[i - 1])
        d_gt = truth[i].relative_to(truth[i - 1])
        err = d_est.relative_to(d_gt)
        trans.append(math.hypot(err.x, err.y))
        rot.append(abs(err.yaw))
    return TrajectoryErrors(
        ate_rmse_m=float(np.sqrt(np.mean(pos_err**2))),
        ate_rmse_deg=math.degrees(float(np.sqrt(np.mean(yaw_err**2)))),
        rpe_trans_mean_m=float(np.mean(trans)),
        rpe_rot_mean_deg=math.degrees(float(np.mean(rot))),
    )


def windowed_ate(estimate: Sequence[Pose2D], truth: Sequence[Pose2D], window: int = 20) -> float:
    """Median over windows of ``window`` consecutive poses (every ``window // 2``) of their ATE RMS (m), each
    window aligned on its own."""
    if len(estimate) != len(truth) or len(estimate) < window or window < 2:
        raise InvalidInputError(
            f"windowed ATE needs >= {max(window, 2)} matched poses, got {len(estimate)} and {len(truth)}"
        )
    est = np.array([[p.x, p.y] for p in estimate])
    gt = np.array([[p.x, p.y] for p in truth])
    errors = []
    for start in range(0, len(est) - window + 1, max(1, window // 2)):
        e, t = est[start : start + window], gt[start : start + window]
        aligned = align_se2(e, t).apply(e)
        errors.append(math.sqrt(float(np.mean(np.sum((aligned - t) ** 2, axis=1)))))
    return float(np.median(errors))


@dataclass(frozen=True)
class AffineFit:
    """How much of the difference between two trajectories is one linear deformation of the plane: the RMS
    position error (m) left after the least-squares affine map of the estimate onto the truth, and that map's
    principal stretches (its singular values: 1.0 and 1.0 for a rigid motion)."""

    residual_rms_m: float
    stretch_min: float
    stretch_max: float


def affine_fit(estimate: Sequence[Pose2D], truth: Sequence[Pose2D]) -> AffineFit:
    """The affine part of the ATE (:class:`AffineFit`). A global scale or shear between two maps of the same
    building (e.g. one built with a wheel-scale bias along its corridors) shows as stretches away from 1 and a
    residual well below the ATE; loop closure cannot see such a deformation, scans seen from afar can."""
    if len(estimate) != len(truth) or len(estimate) < 3:
        raise InvalidInputError(f"an affine fit needs >= 3 matched poses, got {len(estimate)} and {len(truth)}")
    est = np.array([[p.x, p.y, 1.0] for p in estimate])
    gt = np.array([[p.x, p.y] for p in truth])
    solution, *_ = np.linalg.lstsq(est, gt, rcond=None)
    residual = est @ solution - gt
    stretches = np.linalg.svd(solution[:2], compute_uv=False)
    return AffineFit(
        float(np.sqrt(np.mean(np.sum(residual**2, axis=1)))), float(stretches.min()), float(stretches.max())
    )
