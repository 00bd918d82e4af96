"""Figures 9 and 10 of the assignment: RRT and RRT* with circular-arc edges on the course arena.

Both run on ``maps/simple.yaml``'s grid (the arena rasterised at 0.05 m), inflated by the Burger's 0.105 m, from
(-1.5, -1.5, 0) to (1.5, 1.5). Budgets are iteration counts, never time, so a seed always draws the same tree.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mrs_nav.figures.tree_drawing import draw_search
from mrs_nav.robot import BURGER_RADIUS
from mrs_nav.trees.rrt import RRTConfig, grow_rrt
from mrs_nav.trees.rrt_star import RRTStarConfig, grow_rrt_star
from mrs_nav.trees.scenarios import COURSE_GOAL, COURSE_START, course_grid

#: RRT* iterations drawn in Figure 10.
STAR_ITERATIONS = 1500


def make_figures(out_dir: Path, seed: int) -> list[Path]:
    grid = course_grid()
    planning = grid.inflate(BURGER_RADIUS)
    plain = grow_rrt(COURSE_START, COURSE_GOAL, planning, RRTConfig(), np.random.default_rng(seed))
    star = grow_rrt_star(
        COURSE_START,
        COURSE_GOAL,
        planning,
        RRTStarConfig(iterations=STAR_ITERATIONS, time_budget=None),
        np.random.default_rng(seed),
    )
    return [
        draw_search(
            plain.tree,
            plain.result,
            grid,
            planning,
            start=COURSE_START,
            goal=COURSE_GOAL,
            title=f"Figure 9: RRT with arc edges (seed {seed}, {plain.result.iterations} samples)",
            out=out_dir / "figure9_rrt.png",
        ),
        draw_search(
            star.tree,
            star.result,
            grid,
            planning,
            start=COURSE_START,
            goal=COURSE_GOAL,
            title=f"Figure 10: RRT* with arc edges (seed {seed}, {STAR_ITERATIONS} iterations)",
            out=out_dir / "figure10_rrt_star.png",
        ),
    ]
