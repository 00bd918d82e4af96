"""Drawing a tree search on its map, in the style of the assignment's Figures 9 and 10 (PNG via matplotlib Agg).

The map is drawn grey where occupied or unknown (lighter where only the robot-radius inflation blocks it), the
tree's arcs thin, the returned path thick, the start as an arrow along its yaw and the goal as a star.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib as mpl

mpl.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection

from mrs_nav.atomic_write import atomic_path
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.planning import PlanResult
from mrs_nav.trees import arcs
from mrs_nav.trees.tree import ArcTree


def draw_search(
    tree: ArcTree,
    result: PlanResult | None,
    grid: OccupancyGrid,
    planning_grid: OccupancyGrid,
    *,
    start: Pose2D,
    goal: FloatArray,
    title: str,
    out: Path,
) -> Path:
    """Write a PNG of ``tree`` and the path of ``result`` (None: the search found none) over ``grid``
    (``planning_grid`` is the inflated one it ran on); returns ``out``."""
    x0, y0, x1, y1 = grid.extent
    fig, ax = plt.subplots(figsize=(6.0, 6.0 * (y1 - y0) / max(x1 - x0, 1e-9) + 0.4), dpi=120)
    shade = np.ones(grid.values.shape)
    shade[~planning_grid.free_mask] = 0.8
    shade[~grid.free_mask] = 0.35
    ax.imshow(shade, origin="lower", extent=(x0, x1, y0, y1), cmap="gray", vmin=0.0, vmax=1.0, interpolation="nearest")
    if len(tree) > 1:
        poses, first = arcs.sample(tree.edges(), max(grid.resolution, 0.02))
        segments = [poses[first[i] : first[i + 1], :2] for i in range(len(first) - 1)]
        ax.add_collection(LineCollection(segments, colors="tab:blue", linewidths=0.6, alpha=0.6, label="tree"))
        ax.plot(tree.position[1 : len(tree), 0], tree.position[1 : len(tree), 1], ".", color="tab:blue", markersize=2)
    if result is not None:
        path = result.path
        ax.plot(path[:, 0], path[:, 1], color="tab:red", linewidth=2.5, label=f"path {result.length_m:.2f} m")
    ax.quiver([start.x], [start.y], [np.cos(start.yaw)], [np.sin(start.yaw)], color="tab:green", scale=12, zorder=5)
    ax.plot(start.x, start.y, "o", color="tab:green", label="start", zorder=5)
    ax.plot(goal[0], goal[1], "*", color="tab:red", markersize=14, label="goal", zorder=5)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title, fontsize=10)
    ax.legend(loc="lower right", fontsize=8)
    try:
        with atomic_path(out, "--png") as temp:
            fig.savefig(temp, format="png", bbox_inches="tight")
    finally:
        plt.close(fig)
    return out
