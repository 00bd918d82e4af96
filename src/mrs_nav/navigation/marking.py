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
  (the localisation's first reports after a 2D Pose Estimate carry its covariance, wide for rviz's).

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

__all__ = ["MarkingConfig", "MarkingGate"]


@dataclass(frozen=True)
class MarkingConfig:
    """How confident the localisation must be for scans to mark (1-sigma bounds)."""

    max_xy_stddev_m: float = 0.3
    max_yaw_stddev_rad: float = 0.3
    settle_s: float = 1.0

    def __post_init__(self) -> None:
        for name in ("max_xy_stddev_m", "max_yaw_stddev_rad"):
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
            return "the localisation has not reported a confident pose since the last initial pose"
        return self._doubt

    def report(self, stamp: float, covariance: npt.ArrayLike) -> None:
        """The localisation's estimate at ``stamp`` has ``covariance`` (``(3, 3)``: x, y, yaw)."""
        if stamp < self._reset_at:  # computed before the reset, from the belief it replaced
            return
        self._reported = True
        self._doubt = self._why_unsure(covariance)
        if self._doubt is not None:
            self._confident_since = None
        elif self._confident_since is None:
            self._confident_since = stamp

    def reset(self, now: float) -> None:
        """The localisation was told a new pose at ``now``: no marking until it is confident of it."""
        self._reported = True
        self._confident_since = None
        self._doubt = None
        self._reset_at = now

    def may_mark(self, stamp: float) -> bool:
        """Whether a scan stamped ``stamp`` may mark obstacles."""
        if not self._reported:
            return True
        return self._confident_since is not None and stamp >= self._confident_since + self.config.settle_s
