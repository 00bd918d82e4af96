"""A time series of planar poses, interpolated at arbitrary stamps (odometry or ground truth from a bag)."""

from __future__ import annotations

import bisect

from mrs_nav.geometry import Pose2D, wrap_angle


class PoseTrack:
    """Poses appended in time order; :meth:`at` interpolates linearly (heading along the shorter arc)."""

    def __init__(self, tolerance: float = 0.05) -> None:
        self.tolerance = tolerance
        self.stamps: list[float] = []
        self.poses: list[Pose2D] = []

    def add(self, stamp: float, pose: Pose2D) -> None:
        if self.stamps and stamp < self.stamps[-1]:
            # Time went backwards (a bag looping, or out-of-order stamps): keep the series monotonic.
            index = bisect.bisect_right(self.stamps, stamp)
            self.stamps.insert(index, stamp)
            self.poses.insert(index, pose)
            return
        self.stamps.append(stamp)
        self.poses.append(pose)

    @property
    def latest(self) -> float:
        return self.stamps[-1] if self.stamps else float("-inf")

    def at(self, stamp: float) -> Pose2D | None:
        """Pose at ``stamp``; the nearest one within ``tolerance`` s outside the series; else None."""
        if not self.stamps:
            return None
        i = bisect.bisect_left(self.stamps, stamp)
        if i == 0:
            return self.poses[0] if self.stamps[0] - stamp <= self.tolerance else None
        if i == len(self.stamps):
            return self.poses[-1] if stamp - self.stamps[-1] <= self.tolerance else None
        t0, t1 = self.stamps[i - 1], self.stamps[i]
        p0, p1 = self.poses[i - 1], self.poses[i]
        f = 0.0 if t1 <= t0 else (stamp - t0) / (t1 - t0)
        return Pose2D(
            p0.x + f * (p1.x - p0.x), p0.y + f * (p1.y - p0.y), wrap_angle(p0.yaw + f * wrap_angle(p1.yaw - p0.yaw))
        )
