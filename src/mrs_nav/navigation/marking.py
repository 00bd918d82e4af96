"""How far the localisation is trusted: laser scans mark obstacles only while it is confident of the pose that
places them, and a goal counts as reached only when it is confident of the pose that reached it.

A scan placed at a wrong pose marks the walls it sees where they are not: diagonal walls across rooms and
corridors, many of them in cells no later beam crosses (behind a wall as seen from where the robot truly is), so
ray tracing never clears them (:mod:`.obstacles`). The rule, fed by the localisation's reports (amcl's
``amcl_pose``: a stamp and the covariance of x, y, yaw) and its resets (``initialpose``, rviz's 2D Pose
Estimate):

* With no report ever received (SLAM, or a localisation that publishes no covariance) every scan marks.
* Otherwise a scan marks only when the latest report is confident and the scan is stamped at least ``settle_s``
  after the first confident report of the current confident spell (the localisation's new ``map -> odom`` must
  have replaced the old one in tf for the scan's stamp: transforms are dated ahead and interpolated between, so
  a scan stamped just after a correction is still placed partly by the old one). Confident: the standard
  deviation of the position
  along its worst axis (the square root of the larger eigenvalue of the x-y covariance) is at most
  ``max_xy_stddev_m`` and that of the heading at most ``max_yaw_stddev_rad``. A report that is not confident ends
  the spell at once.
* A reset (:meth:`MarkingGate.reset`) says that the pose believed so far was wrong: the caller drops every mark
  (all were placed by that belief), and no scan marks until a confident report stamped after the reset arrives
  (the localisation's first reports after a 2D Pose Estimate carry its covariance, wide for rviz's). The reset
  is dated when the caller hears of it: a report stamped earlier may have been computed from the old belief.
  One stamped between the given pose's own stamp and then may also be the localisation's first from the new
  belief (it takes scans from the given pose's stamp on, and a robot standing still sends no other): it counts
  when it lies within the confident bounds (``max_xy_stddev_m``, ``max_yaw_stddev_rad``) of the pose given,
  where the old belief, if it was that close, would mark no worse.

* The scan must also be placed by the localisation's estimate: the ``map -> odom`` correction that tf gave the
  scan, applied to the odometry at the scan's stamp, puts the robot within ``max_tf_gap_m`` and
  ``max_tf_gap_rad`` of where the latest confident report's own correction (its pose composed with the inverse
  of the odometry at its stamp) puts it. The settle time alone does not ensure this: the localisation sends the
  new ``map -> odom`` only once its update has finished, and on a loaded machine at maximum sim rate that can be
  seconds of sim time after the scan the report is stamped with; until then tf still places the scans by the old
  belief, and a robot standing still would mark its phantom walls again from there (the old correction 1 m and
  30 deg off re-marked 300-820 phantom cells of the office under load). A report whose correction the caller
  could not work out (no odometry at its stamp) is held to the settle time alone.

Clearing is never held back: a beam placed at a wrong pose can only unmark a cell, which the next confident
scan marks again if the obstacle is there. The same test, applied to the latest report (:meth:`MarkingGate.doubt`),
keeps a goal from being reported reached on a pose the localisation is not sure of. Times are in seconds of the
caller's clock (sim time in ROS).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D, wrap_angle

__all__ = ["MarkingConfig", "MarkingGate"]


@dataclass(frozen=True)
class MarkingConfig:
    """How confident the localisation must be for scans to mark (1-sigma bounds), and how closely tf must place a
    scan where its estimate puts the robot."""

    max_xy_stddev_m: float = 0.3
    max_yaw_stddev_rad: float = 0.3
    settle_s: float = 1.0
    max_tf_gap_m: float = 0.05
    max_tf_gap_rad: float = 0.05

    def __post_init__(self) -> None:
        for name in ("max_xy_stddev_m", "max_yaw_stddev_rad", "max_tf_gap_m", "max_tf_gap_rad"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"marking {name} must be a positive number, got {value}")
        if not (math.isfinite(self.settle_s) and self.settle_s >= 0.0):
            raise InvalidInputError(f"marking settle_s must be a number >= 0, got {self.settle_s}")


class MarkingGate:
    """Whether a scan may mark (the module docstring's rule)."""

    def __init__(self, config: MarkingConfig | None = None) -> None:
        self.config = config or MarkingConfig()
        self._reported = False
        self._confident_since: float | None = None  # stamp of the first confident report of this spell
        self._reset_at = -math.inf
        self._doubt: str | None = None  # why the latest report is not confident
        self._correction: Pose2D | None = None  # map -> odom of the latest report (None: not known)
        self._given: tuple[float, Pose2D] | None = None  # the last pose given, from when the localisation takes it

    def confident(self, covariance: npt.ArrayLike) -> bool:
        """Whether a pose with ``covariance`` (``(3, 3)``: x, y in m, yaw in rad) is confident enough to mark."""
        return self._why_unsure(covariance) is None

    def _why_unsure(self, covariance: npt.ArrayLike) -> str | None:
        cov = np.asarray(covariance, dtype=np.float64).reshape(3, 3)
        if not np.all(np.isfinite(cov)):
            return "the localisation's covariance is not finite"
        xy = math.sqrt(max(float(np.linalg.eigvalsh((cov[:2, :2] + cov[:2, :2].T) / 2.0)[-1]), 0.0))
        yaw = math.sqrt(max(float(cov[2, 2]), 0.0))
        cfg = self.config
        if xy <= cfg.max_xy_stddev_m and yaw <= cfg.max_yaw_stddev_rad:
            return None
        return (
            f"the localisation is not confident (1 sigma {xy:.2f} m, {yaw:.2f} rad; at most"
            f" {cfg.max_xy_stddev_m:.2f} m, {cfg.max_yaw_stddev_rad:.2f} rad)"
        )

    def doubt(self) -> str | None:
        """Why the pose is not to be trusted now (None: it is, or no localisation reports at all)."""
        if not self._reported:
            return None
        if self._confident_since is None and self._doubt is None:
            return "the localisation has not reported a confident pose since the last initial pose or time jump"
        return self._doubt

    def report(
        self, stamp: float, covariance: npt.ArrayLike, correction: Pose2D | None = None, pose: Pose2D | None = None
    ) -> None:
        """The localisation's estimate ``pose`` at ``stamp`` has ``covariance`` (``(3, 3)``: x, y, yaw) and implies
        the ``map -> odom`` ``correction`` (None: not known, the settle time alone applies)."""
        if stamp < self._reset_at and not self._near_given(stamp, pose):  # maybe from the belief it replaced
            return
        self._reported = True
        self._correction = correction
        self._doubt = self._why_unsure(covariance)
        if self._doubt is not None:
            self._confident_since = None
        elif self._confident_since is None:
            self._confident_since = stamp

    def reset(self, now: float, pose: Pose2D | None = None, stamp: float | None = None) -> None:
        """The localisation was told a new ``pose`` stamped ``stamp`` (None: not known), heard of at ``now``: no
        marking until it is confident of it."""
        self._reported = True
        self._confident_since = None
        self._doubt = None
        self._correction = None
        self._reset_at = now
        self._given = None if pose is None else (now if stamp is None else min(stamp, now), pose)

    def forget_time(self) -> None:
        """Sim time went back (a bag played again, the simulator restarted): the stamps held are of the old time
        line, where every new report would lie before the last reset and be ignored for good. Marking waits for the
        next confident report, as after a reset, when there is a localisation at all."""
        if self._reported:
            self._confident_since = None
            self._doubt = None
        self._correction = None
        self._reset_at = -math.inf
        self._given = None

    def _near_given(self, stamp: float, pose: Pose2D | None) -> bool:
        """Whether a report at ``pose`` stamped ``stamp`` before the reset was heard of is the localisation's first
        from the pose given (the module docstring)."""
        if self._given is None or pose is None or stamp < self._given[0]:
            return False
        given, cfg = self._given[1], self.config
        return (
            math.hypot(pose.x - given.x, pose.y - given.y) <= cfg.max_xy_stddev_m
            and abs(wrap_angle(pose.yaw - given.yaw)) <= cfg.max_yaw_stddev_rad
        )

    def may_mark(self, stamp: float, correction: Pose2D | None = None, odom: Pose2D | None = None) -> bool:
        """Whether a scan stamped ``stamp`` may mark obstacles, tf having placed it with the ``map -> odom``
        ``correction`` and the odometry pose ``odom`` of its stamp (both None: not checked against the report)."""
        if not self._reported:
            return True
        if self._confident_since is None or stamp < self._confident_since + self.config.settle_s:
            return False
        return self.tf_gap(correction, odom) is None

    @property
    def checks_placement(self) -> bool:
        """Whether :meth:`may_mark` has a report's correction to check a scan's placement against (otherwise the
        caller need not look the placement up)."""
        return self._correction is not None

    def tf_gap(self, correction: Pose2D | None, odom: Pose2D | None) -> str | None:
        """How far tf's ``correction`` places the robot at ``odom`` from where the latest report's puts it, when
        that is more than the bounds (None: within them, or not known)."""
        if self._correction is None or correction is None or odom is None:
            return None
        placed, expected = correction.compose(odom), self._correction.compose(odom)
        gap_m = math.hypot(placed.x - expected.x, placed.y - expected.y)
        gap_rad = abs(wrap_angle(placed.yaw - expected.yaw))
        if gap_m <= self.config.max_tf_gap_m and gap_rad <= self.config.max_tf_gap_rad:
            return None
        return f"tf's map->odom places the robot {gap_m:.2f} m and {gap_rad:.2f} rad from the localisation's estimate"
