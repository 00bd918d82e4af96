"""``--snapshot``: the occupancy grid, the robot, its path and goal drawn into a PNG (matplotlib Agg)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mrs_nav.bridge.dashboard import path_xy, pose_of


def draw_snapshot(out: Path, grid: Any = None, odom: Any = None, path: Any = None, goal: Any = None) -> Path:
    """Write ``out`` (PNG) from rosbags messages (any may be None): OccupancyGrid, Odometry, Path, PoseStamped.

    Grid cells: unknown (-1) grey, free white, occupied black, shaded by occupancy probability; the image is
    placed at the grid's origin with its resolution (m/cell), so everything is in the map frame, metres.
    """
    # A bare Figure (no pyplot) renders with Agg and leaves the global backend alone.
    fig = Figure(figsize=(6, 6), dpi=100)
    ax = fig.subplots()
    ax.set_facecolor("#cfd8e3")  # outside the map, so that free (white) cells stand out
    if grid is not None:
        info = grid.info
        cells = np.asarray(grid.data, dtype=float).reshape(info.height, info.width)
        image = np.where(cells < 0, 0.5, 1.0 - np.clip(cells, 0, 100) / 100.0)
        x0, y0 = info.origin.position.x, info.origin.position.y
        extent = (x0, x0 + info.width * info.resolution, y0, y0 + info.height * info.resolution)
        ax.imshow(image, cmap="gray", vmin=0, vmax=1, origin="lower", extent=extent, interpolation="nearest")
    if path is not None and len(path.poses):
        xy = path_xy(path)
        ax.plot(xy[:, 0], xy[:, 1], "-", color="tab:blue", lw=1.5, label="path")
    if goal is not None:
        g = pose_of(goal.pose)
        ax.plot(g["x"], g["y"], "*", color="tab:green", ms=14, label="goal")
    if odom is not None:
        p = pose_of(odom.pose.pose)
        ax.plot(p["x"], p["y"], "o", color="tab:red", ms=8, label="robot")
        ax.arrow(p["x"], p["y"], 0.25 * math.cos(p["yaw"]), 0.25 * math.sin(p["yaw"]), color="tab:red", width=0.02)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    return out
