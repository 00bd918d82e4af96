"""What the monitor shows: a summary of decoded messages (pose, speed, goal, path, map) and per-topic
rates and latencies, as a dict (for ``--json``) and as text for a terminal."""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from mrs_nav.bridge.monitor import TopicStats
from mrs_nav.geometry import yaw_from_quaternion

# Which topic feeds each line of the dashboard (DESIGN.md's interface).
ODOM_TOPIC = "/odom"
GOAL_TOPIC = "/move_base_simple/goal"
PATH_TOPIC = "/path"
MAP_TOPIC = "/map"


def pose_of(pose: Any) -> dict[str, float]:
    """``{x, y, yaw}`` (m, m, rad) of a rosbags geometry_msgs/Pose."""
    q = pose.orientation
    return {"x": float(pose.position.x), "y": float(pose.position.y), "yaw": yaw_from_quaternion(q.x, q.y, q.z, q.w)}


def path_xy(path: Any) -> npt.NDArray[np.float64]:
    """(N, 2) positions of a nav_msgs/Path, metres."""
    return np.array([[p.pose.position.x, p.pose.position.y] for p in path.poses], dtype=float).reshape(-1, 2)


def path_length(points: npt.NDArray[np.float64]) -> float:
    """Sum of the segment lengths of a polyline, metres."""
    return float(np.sum(np.hypot(*np.diff(points, axis=0).T))) if len(points) > 1 else 0.0


def summarise(
    messages: Mapping[str, Any], stats: Mapping[str, TopicStats], now: float, now_ns: int | None = None
) -> dict[str, Any]:
    """The dashboard as plain data; ``messages`` maps topics to their last decoded message, ``now`` is the
    monotonic time (s) and ``now_ns`` the wall clock (ns since the epoch, default: now)."""
    wall_ns = time.time_ns() if now_ns is None else now_ns
    out: dict[str, Any] = {"pose": None, "speed": None, "goal": None, "path_length": None, "map": None}
    odom = messages.get(ODOM_TOPIC)
    if odom is not None:
        out["pose"] = pose_of(odom.pose.pose)
        twist = odom.twist.twist
        out["speed"] = {"linear": float(twist.linear.x), "angular": float(twist.angular.z)}
    goal = messages.get(GOAL_TOPIC)
    if goal is not None:
        out["goal"] = pose_of(goal.pose)
    path = messages.get(PATH_TOPIC)
    if path is not None:
        out["path_length"] = path_length(path_xy(path))
    grid = messages.get(MAP_TOPIC)
    if grid is not None:
        info = grid.info
        out["map"] = {
            "width": int(info.width),
            "height": int(info.height),
            "resolution": float(info.resolution),
            "size_m": [info.width * info.resolution, info.height * info.resolution],
        }
    out["topics"] = {
        topic: {
            "type": s.type,
            "count": s.count,
            "rate_hz": s.rate_hz(now),
            "latency_ms_p50": s.latency_ms(50),
            "latency_ms_p99": s.latency_ms(99),
            "age_s": None if math.isnan(s.age_s(wall_ns)) else s.age_s(wall_ns),
            "stale": s.stale(now, wall_ns),
        }
        for topic, s in stats.items()
    }
    return out


def _fmt(value: float | None, unit: str = "", digits: int = 2) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{value:.{digits}f}{unit}"


def render(summary: Mapping[str, Any], title: str = "") -> str:
    """Plain-text dashboard (no colours, so it also reads well in logs)."""
    lines = [title] if title else []
    pose, speed, goal, grid = summary["pose"], summary["speed"], summary["goal"], summary["map"]
    lines.append(
        "pose   "
        + (f"x {pose['x']:.2f} m  y {pose['y']:.2f} m  yaw {math.degrees(pose['yaw']):.1f} deg" if pose else "-")
    )
    lines.append("speed  " + (f"{speed['linear']:.3f} m/s  {speed['angular']:.3f} rad/s" if speed else "-"))
    lines.append(
        "goal   "
        + (f"x {goal['x']:.2f} m  y {goal['y']:.2f} m  yaw {math.degrees(goal['yaw']):.1f} deg" if goal else "-")
    )
    lines.append(f"path   {_fmt(summary['path_length'], ' m')}")
    lines.append(
        "map    "
        + (
            f"{grid['width']} x {grid['height']} cells @ {grid['resolution']:.3f} m "
            f"({grid['size_m'][0]:.1f} x {grid['size_m'][1]:.1f} m)"
            if grid
            else "-"
        )
    )
    lines.append("")
    lines.append(
        f"{'topic':<28} {'type':<28} {'count':>7} {'rate Hz':>8} {'lat p50 ms':>11} {'p99 ms':>8} {'age s':>8}  state"
    )
    for topic, t in summary["topics"].items():
        lines.append(
            f"{topic:<28} {t['type']:<28} {t['count']:>7} {_fmt(t['rate_hz'], '', 1):>8} "
            f"{_fmt(t['latency_ms_p50'], '', 2):>11} {_fmt(t['latency_ms_p99'], '', 2):>8} "
            f"{_fmt(t['age_s'], '', 1):>8}  {'STALE' if t['stale'] else 'live'}"
        )
    return "\n".join(lines)
