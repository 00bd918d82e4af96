"""Planar poses and angle helpers (SE(2)), in metres and radians."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mrs_nav.errors import InvalidInputError

FloatArray = npt.NDArray[np.float64]


def format_point(x: float, y: float) -> str:
    """``(x, y)`` in metres to the centimetre for log lines; in three significant digits past 1000 km, where a goal
    sent as ``1e300`` would otherwise print three hundred digits."""

    def one(v: float) -> str:
        return f"{v:.2f}" if abs(v) < 1e6 else f"{v:.3g}"

    return f"({one(x)}, {one(y)})"


def wrap_angle(angle: float) -> float:
    """Return ``angle`` wrapped to [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def poses_agree(a: Pose2D, b: Pose2D, tolerance: tuple[float, float]) -> bool:
    """Whether two poses' positions are within ``tolerance[0]`` (m) and their headings within ``tolerance[1]``
    (rad) of each other."""
    linear, angular = tolerance
    return math.hypot(a.x - b.x, a.y - b.y) <= linear and abs(wrap_angle(a.yaw - b.yaw)) <= angular


def wrap_angles(angles: FloatArray) -> FloatArray:
    """Vectorised :func:`wrap_angle`."""
    return np.asarray((angles + np.pi) % (2.0 * np.pi) - np.pi, dtype=np.float64)


def cos_sin(angles: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``cos`` and ``sin`` of ``angles``, the same to the last bit wherever the array lies in memory.

    Why: numpy (1.24 on AVX-512 machines) takes the cosine and sine of a strided array, such as a column of
    poses, by one of two routines that differ in the last bit, chosen by the array's address. A pose graph solved
    to different poses from run to run, and a replay of the MIT Infinite Corridor log ended 7 m, 34 m or 106 m
    off by chance. A contiguous copy always takes the same routine.
    """
    contiguous = np.ascontiguousarray(angles, dtype=np.float64)
    return np.cos(contiguous), np.sin(contiguous)


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    """Yaw (rotation about z) of a unit quaternion, in radians."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def quaternion_from_yaw(yaw: float) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of a rotation by ``yaw`` about z."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


@dataclass(frozen=True)
class Pose2D:
    """A planar pose: position (x, y) in metres and heading ``yaw`` in radians."""

    x: float
    y: float
    yaw: float = 0.0

    def __post_init__(self) -> None:
        if not all(math.isfinite(v) for v in (self.x, self.y, self.yaw)):
            raise InvalidInputError(f"pose has a non-finite value: ({self.x}, {self.y}, {self.yaw})")

    @property
    def position(self) -> FloatArray:
        return np.array([self.x, self.y], dtype=np.float64)

    def compose(self, other: Pose2D) -> Pose2D:
        """``self * other``: ``other`` expressed in the frame of ``self``, returned in the parent frame."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(
            self.x + c * other.x - s * other.y,
            self.y + s * other.x + c * other.y,
            wrap_angle(self.yaw + other.yaw),
        )

    def apply(self, points: FloatArray) -> FloatArray:
        """``points`` (N x 2) given in the frame of this pose, returned in the parent frame (N x 2)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        x, y = points[:, 0], points[:, 1]
        return np.stack([self.x + c * x - s * y, self.y + s * x + c * y], axis=1)

    def inverse(self) -> Pose2D:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(-c * self.x - s * self.y, s * self.x - c * self.y, wrap_angle(-self.yaw))

    def relative_to(self, base: Pose2D) -> Pose2D:
        """This pose expressed in the frame of ``base``."""
        return base.inverse().compose(self)
