"""Small CARMEN logs written at test time: a drive around the synthetic room in the corrected-log form.

Scans are exact (``tests.core.slam.synthetic.cast``) at CARMEN's 180-beam geometry (-90 degrees, 1 degree
steps; "no return" is the SICK's 81.83 m). ODOM lines follow the corrected logs' convention: after each scan one
line re-anchors the stream at the scan's pose (stamp 0), then the pose advanced by noisy wheel increments, the
last one stamped at the next scan.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mrs_nav.geometry import Pose2D
from tests.core.slam.synthetic import cast

NO_RETURN = 81.83


def drive() -> list[Pose2D]:
    """A lap of the room: straight legs 0.25 m per scan and turns of 0.3 rad per scan."""
    poses = [Pose2D(-3.6, -2.0, 0.0)]
    for heading, steps in ((0.0, 20), (math.pi / 2, 12), (math.pi, 20)):
        while abs(math.remainder(poses[-1].yaw - heading, 2 * math.pi)) > 1e-9:
            turn = math.remainder(heading - poses[-1].yaw, 2 * math.pi)
            step = math.copysign(min(0.3, abs(turn)), turn)
            poses.append(Pose2D(poses[-1].x, poses[-1].y, poses[-1].yaw + step))
        for _ in range(steps):
            poses.append(poses[-1].compose(Pose2D(0.25, 0.0, 0.0)))
    return poses


def front_ranges(pose: Pose2D) -> np.ndarray:
    full = cast(pose, beams=360, max_range=NO_RETURN)
    ranges = full.ranges[90:270].copy()  # -90 .. +89 degrees
    ranges[~np.isfinite(ranges)] = NO_RETURN
    return ranges


def log_lines(poses: list[Pose2D], *, seed: int = 0, stamps: list[float] | None = None) -> list[str]:
    """FLASER and ODOM lines of a corrected log of ``poses``; odometry increments with 5 % noise."""
    rng = np.random.default_rng(seed)
    stamps = stamps if stamps is not None else [10.0 + 0.5 * i for i in range(len(poses))]
    lines = ["# message formats defined: PARAM SYNC ODOM FLASER", "PARAM robot_frontlaser_offset 0.0 nohost 0"]
    for i, (pose, t) in enumerate(zip(poses, stamps, strict=True)):
        if i:
            step = pose.relative_to(poses[i - 1])
            noisy = Pose2D(step.x * (1 + 0.05 * rng.normal()), step.y, step.yaw * (1 + 0.05 * rng.normal()))
            half = poses[i - 1].compose(Pose2D(noisy.x / 2, noisy.y / 2, noisy.yaw / 2))
            full = poses[i - 1].compose(noisy)
            lines.append(f"ODOM {half.x:.6f} {half.y:.6f} {half.yaw:.6f} 0 0 0 {t - 0.2:.6f} host {t - 0.2:.6f}")
            lines.append(f"ODOM {full.x:.6f} {full.y:.6f} {full.yaw:.6f} 0 0 0 {t:.6f} host {t:.6f}")
        ranges = " ".join(f"{r:.3f}" for r in front_ranges(pose))
        triple = f"{pose.x:.6f} {pose.y:.6f} {pose.yaw:.6f}"
        lines.append(f"FLASER 180 {ranges} {triple} {triple} {t:.6f} host {t:.6f}")
        lines.append(f"ODOM {triple} 0 0 0 0 host 0")
    return lines


def write_log(path: Path, lines: list[str]) -> Path:
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
