"""Small drawing helpers shared by the figure sets: headless axes, obstacles, vector fields, saving."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # headless: figures are files, never windows

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Circle, Polygon

from mrs_nav.atomic_write import atomic_path
from mrs_nav.geometry import FloatArray
from mrs_nav.maps.obstacles import Obstacles

OBSTACLE_COLOUR = "#7f7f7f"


Limits = tuple[float, float, float, float]


def new_axes(title: str, limits: Limits) -> tuple[Any, Any]:
    """A square figure with equal axes over ``limits`` = (xmin, ymin, xmax, ymax) metres."""
    fig, (ax,) = new_panels([title], [limits])
    return fig, ax


def new_panels(titles: list[str], limits: list[Limits]) -> tuple[Any, list[Any]]:
    """A row of equal-axis panels, one per title, each over its ``limits`` (metres)."""
    fig, axes = plt.subplots(1, len(titles), figsize=(6.0 * len(titles), 6.0), dpi=100, squeeze=False)
    for ax, title, lim in zip(axes[0], titles, limits, strict=True):
        ax.set_title(title, fontsize=10)
        ax.set_xlim(lim[0], lim[2])
        ax.set_ylim(lim[1], lim[3])
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
    return fig, list(axes[0])


def draw_obstacles(ax: Any, obstacles: Obstacles) -> None:
    for x, y, r in obstacles.circles:
        ax.add_patch(Circle((x, y), r, color=OBSTACLE_COLOUR, alpha=0.8, zorder=2))
    for corners in obstacles.box_corners():
        ax.add_patch(Polygon(corners, closed=True, color=OBSTACLE_COLOUR, alpha=0.8, zorder=2))


def draw_field(ax: Any, points: FloatArray, velocities: FloatArray) -> None:
    """Arrows of the velocity field at ``points`` ``(P, 2)`` (m/s, drawn to a common scale)."""
    ax.quiver(points[:, 0], points[:, 1], velocities[:, 0], velocities[:, 1], color="#1f77b4", alpha=0.6, zorder=1)


def grid(limits: Limits, count: int = 25) -> FloatArray:
    xs = np.linspace(limits[0], limits[2], count)
    ys = np.linspace(limits[1], limits[3], count)
    gx, gy = np.meshgrid(xs, ys)
    return np.column_stack([gx.ravel(), gy.ravel()])


def save(fig: Any, path: Path) -> Path:
    """Write ``fig`` as a PNG without the time-stamped metadata, so equal seeds give equal files."""
    try:
        with atomic_path(path, "figure") as temp:
            fig.savefig(temp, format="png", metadata={"Software": None})
    finally:
        plt.close(fig)
    return path
