"""A trajectory known at some stamps, bridged between them by odometry, sampled at many times at once.

``P(t) = C(t) O(t)``: ``O(t)`` the odometry interpolated at ``t`` and ``C(t)`` the correction ``P_k inv(O_k)``
(map -> odom) interpolated linearly (x, y, yaw) between the trajectory poses before and after ``t``, held beyond
the first and last, as a SLAM system's correction moves between its updates. With the odometry itself as the
trajectory the correction is the identity and ``P(t)`` is the odometry. Poses are arrays of rows ``x, y, yaw``
(m, rad).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mrs_nav.geometry import FloatArray, Pose2D, cos_sin, wrap_angles

BoolArray = npt.NDArray[np.bool_]


def as_rows(poses: Sequence[Pose2D]) -> FloatArray:
    """Poses as an ``(n, 3)`` array of ``x, y, yaw``."""
    return np.array([(p.x, p.y, p.yaw) for p in poses], dtype=np.float64).reshape(-1, 3)


def compose(a: FloatArray, b: FloatArray) -> FloatArray:
    """Row-wise ``a * b`` (:meth:`Pose2D.compose`), yaw wrapped."""
    c, s = cos_sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    return np.stack([x, y, wrap_angles(a[..., 2] + b[..., 2])], axis=-1)


def inverse(a: FloatArray) -> FloatArray:
    """Row-wise :meth:`Pose2D.inverse`."""
    c, s = cos_sin(a[..., 2])
    return np.stack([-(c * a[..., 0] + s * a[..., 1]), s * a[..., 0] - c * a[..., 1], -a[..., 2]], axis=-1)


def relation_residuals(start: FloatArray, end: FloatArray, reference: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Translational (m) and absolute rotational (rad) parts of ``inv(reference) inv(start) end``, row-wise."""
    error = compose(inverse(reference), compose(inverse(start), end))
    return np.hypot(error[..., 0], error[..., 1]), np.abs(wrap_angles(error[..., 2]))


@dataclass(frozen=True)
class BridgedTrajectory:
    """Poses at ``stamps`` (s, increasing) bridged by an odometry track (see the module doc)."""

    stamps: FloatArray
    corrections: FloatArray  # yaw unwrapped, so that interpolation takes the shorter arc
    odom_stamps: FloatArray
    odom: FloatArray  # yaw unwrapped
    odom_tolerance: float  # s: odometry is held this long past its ends (as PoseTrack.at), None beyond

    @classmethod
    def of(
        cls,
        stamps: Sequence[float],
        poses: FloatArray,
        odom_at_poses: FloatArray,
        *,
        odom_stamps: Sequence[float],
        odom_poses: FloatArray,
        odom_tolerance: float,
    ) -> BridgedTrajectory:
        corrections = compose(poses, inverse(odom_at_poses))
        corrections[:, 2] = np.unwrap(corrections[:, 2])
        odom = np.array(odom_poses, dtype=np.float64)
        odom[:, 2] = np.unwrap(odom[:, 2])
        return cls(
            np.asarray(stamps, dtype=np.float64),
            corrections,
            np.asarray(odom_stamps, dtype=np.float64),
            odom,
            odom_tolerance,
        )

    @property
    def span(self) -> tuple[float, float]:
        """The times (s) at which a pose exists: those of the odometry, held by its tolerance."""
        return float(self.odom_stamps[0]) - self.odom_tolerance, float(self.odom_stamps[-1]) + self.odom_tolerance

    def poses_at(self, times: FloatArray) -> tuple[FloatArray, BoolArray]:
        """Poses at ``times`` (any shape, s) as ``times.shape + (3,)``, and where they exist (boolean mask)."""
        first, last = self.span
        valid = (times >= first) & (times <= last)
        odom = np.stack([np.interp(times, self.odom_stamps, self.odom[:, k]) for k in range(3)], axis=-1)
        correction = np.stack([np.interp(times, self.stamps, self.corrections[:, k]) for k in range(3)], axis=-1)
        return compose(correction, odom), valid
