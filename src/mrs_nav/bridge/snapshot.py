"""``--snapshot``: each robot's occupancy grid, pose, path and goal drawn into one PNG (matplotlib Agg)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mrs_nav.atomic_write import atomic_path
from mrs_nav.bridge.dashboard import path_xy, pose_of


@dataclass(frozen=True)
class RobotView:
    """What one robot's panel shows (rosbags messages, any may be None)."""

    grid: Any = None  # nav_msgs/OccupancyGrid
    odom: Any = None  # nav_msgs/Odometry
    path: Any = None  # nav_msgs/Path
    goal: Any = None  # geometry_msgs/PoseStamped


def draw_snapshot(out: Path, views: Mapping[str, RobotView]) -> Path:
    """Write ``out`` as PNG whatever its suffix (matplotlib would otherwise add ``.png`` to a name without one,
    or refuse another suffix after the whole run): one panel per robot, side by side, titled with its name when
    there are several.

    Grid cells: unknown (-1) grey, free white, occupied black, shaded by occupancy probability; the image is
    placed at the grid's origin with its resolution (m/cell), so everything is in that robot's map frame, metres
    (robots of a fleet each map in their own frame, hence a panel each rather than one shared plot).
    """
    columns = min(3, max(1, len(views)))
    rows = math.ceil(max(1, len(views)) / columns)
    # A bare Figure (no pyplot) renders with Agg and leaves the global backend alone.
    fig = Figure(figsize=(6 * columns, 6 * rows), dpi=100)
    axes = fig.subplots(rows, columns, squeeze=False).ravel()
    for ax, (name, view) in zip(axes, views.items(), strict=False):
        _draw_robot(ax, view)
        if len(views) > 1:
            ax.set_title(name)
    for ax in axes[len(views) :]:
        ax.set_axis_off()
    with atomic_path(out, "snapshot") as temp:
        fig.savefig(temp, format="png")
    return out


def _draw_robot(ax: Any, view: RobotView) -> None:
    ax.set_facecolor("#cfd8e3")  # outside the map, so that free (white) cells stand out
    if view.grid is not None:
        info = view.grid.info
        cells = np.asarray(view.grid.data, dtype=float).reshape(info.height, info.width)
        image = np.where(cells < 0, 0.5, 1.0 - np.clip(cells, 0, 100) / 100.0)
        x0, y0 = info.origin.position.x, info.origin.position.y
        extent = (x0, x0 + info.width * info.resolution, y0, y0 + info.height * info.resolution)
        ax.imshow(image, cmap="gray", vmin=0, vmax=1, origin="lower", extent=extent, interpolation="nearest")
    if view.path is not None and len(view.path.poses):
        xy = path_xy(view.path)
        ax.plot(xy[:, 0], xy[:, 1], "-", color="tab:blue", lw=1.5, label="path")
    if view.goal is not None:
        g = pose_of(view.goal.pose)
        ax.plot(g["x"], g["y"], "*", color="tab:green", ms=14, label="goal")
    if view.odom is not None:
        p = pose_of(view.odom.pose.pose)
        ax.plot(p["x"], p["y"], "o", color="tab:red", ms=8, label="robot")
        ax.arrow(p["x"], p["y"], 0.25 * math.cos(p["yaw"]), 0.25 * math.sin(p["yaw"]), color="tab:red", width=0.02)
        if view.grid is None:  # nothing else to frame the view: 2 m around the robot
            ax.set_xlim(p["x"] - 1.0, p["x"] + 1.0)
            ax.set_ylim(p["y"] - 1.0, p["y"] + 1.0)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right")
