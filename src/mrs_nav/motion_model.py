"""The odometry motion model (Thrun, Burgard, Fox, *Probabilistic Robotics*, table 5.6) as a noise source.

A motion between two poses is split into a rotation ``rot1`` towards the direction of travel, a translation
``trans`` and a final rotation ``rot2``. Sampled odometry perturbs each with zero-mean Gaussian noise of
variance

    var(rot1)  = a1 * rot1^2 + a2 * trans^2        (rad^2; a1 in rad^2/rad^2, a2 in rad^2/m^2)
    var(trans) = a3 * trans^2 + a4 * (rot1^2 + rot2^2)   (m^2; a3 in m^2/m^2, a4 in m^2/rad^2)
    var(rot2)  = a1 * rot2^2 + a2 * trans^2

Backward motion is decomposed with a negative translation so that ``rot1`` stays small. A motion that translates
less than :data:`IN_PLACE_M` draws the noise of a turn on the spot (``rot1`` 0, all of the turn in ``rot2``), as
AMCL's ``diff`` model does (:meth:`OdometryNoise.std_devs`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D, wrap_angle

# Defaults of `mrs-nav carmen2bag --odom-noise`: 1 sigma about 10 % of the translation and 7 % of the
# rotation, plus 2.6 degrees of heading per metre: odometry alone then has an Intel-log RPE of ~0.06 m.
DEFAULT_ALPHAS = (0.005, 0.002, 0.01, 0.0005)


#: A translation shorter than this (m) is a turn on the spot for the noise (AMCL's 1 cm): a robot turning in place
#: drifts a few millimetres in an arbitrary direction, and a first rotation of up to 90 degrees towards it, undone
#: by the second, would be charged rotation and translation noise for turning that the robot never did (a 0.85 rad
#: turn with 2 mm of drift spread a filter's cloud 0.33 rad and 0.33 m instead of 0.12 rad and 0.12 m).
IN_PLACE_M = 0.01

# An alpha of 10 is a standard deviation over three times the motion itself (AMCL's default is 0.2): odometry that
# bad tells a filter nothing, and far larger ones throw poses past any map or overflow them to infinity.
MAX_ALPHA = 10.0


@dataclass(frozen=True)
class OdometryNoise:
    """Alphas ``a1..a4`` of the odometry motion model (variances per squared motion, see module doc)."""

    a1: float
    a2: float
    a3: float
    a4: float

    def __post_init__(self) -> None:
        values = (self.a1, self.a2, self.a3, self.a4)
        if not all(math.isfinite(a) and 0.0 <= a <= MAX_ALPHA for a in values):
            raise InvalidInputError(f"odometry noise alphas must be in 0..{MAX_ALPHA:g}, got {values}")

    def std_devs(self, rot1: float, trans: float, rot2: float) -> tuple[float, float, float]:
        """The standard deviations of ``rot1``, ``trans`` and ``rot2`` (:func:`decompose`) for that motion (module
        docstring), a turn on the spot when ``|trans|`` is under :data:`IN_PLACE_M`."""
        if abs(trans) < IN_PLACE_M:
            rot1, rot2 = 0.0, wrap_angle(rot1 + rot2)
        return (
            math.sqrt(self.a1 * rot1**2 + self.a2 * trans**2),
            math.sqrt(self.a3 * trans**2 + self.a4 * (rot1**2 + rot2**2)),
            math.sqrt(self.a1 * rot2**2 + self.a2 * trans**2),
        )

    @classmethod
    def of(cls, alphas: Sequence[float]) -> OdometryNoise:
        if len(alphas) != 4:
            raise InvalidInputError(f"odometry noise needs 4 alphas a1,a2,a3,a4, got {len(alphas)}")
        return cls(*(float(a) for a in alphas))


def decompose(start: Pose2D, end: Pose2D) -> tuple[float, float, float]:
    """``(rot1, trans, rot2)`` of the motion from ``start`` to ``end`` (rad, m, rad); trans < 0 if backwards."""
    dx, dy = end.x - start.x, end.y - start.y
    trans = math.hypot(dx, dy)
    if trans < 1e-9:
        return 0.0, 0.0, wrap_angle(end.yaw - start.yaw)
    rot1 = wrap_angle(math.atan2(dy, dx) - start.yaw)
    if abs(rot1) > math.pi / 2.0:
        rot1 = wrap_angle(rot1 + math.pi)
        trans = -trans
    return rot1, trans, wrap_angle(end.yaw - start.yaw - rot1)


def apply_motion(pose: Pose2D, rot1: float, trans: float, rot2: float) -> Pose2D:
    """The pose reached from ``pose`` by ``rot1``, ``trans``, ``rot2``."""
    heading = pose.yaw + rot1
    return Pose2D(pose.x + trans * math.cos(heading), pose.y + trans * math.sin(heading), wrap_angle(heading + rot2))


def noisy_odometry(truth: Sequence[Pose2D], noise: OdometryNoise, rng: np.random.Generator) -> list[Pose2D]:
    """Odometry poses integrated from the increments of ``truth`` with sampled noise; starts at ``truth[0]``."""
    if not truth:
        return []
    odom = [truth[0]]
    for prev, cur in itertools.pairwise(truth):
        rot1, trans, rot2 = decompose(prev, cur)
        sd_rot1, sd_trans, sd_rot2 = noise.std_devs(rot1, trans, rot2)
        e1, et, e2 = rng.normal(0.0, 1.0, 3)
        odom.append(apply_motion(odom[-1], rot1 + sd_rot1 * e1, trans + sd_trans * et, rot2 + sd_rot2 * e2))
    return odom
