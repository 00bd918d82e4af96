"""Potential field: success rate, planning time and path-length ratio over seeds in both trap cases.

For each trap (cylinder at the origin in the course arena; two overlapping cylinders) and each seed, one
:func:`~mrs_nav.fields.randomized_potential_field.plan_potential_field` call is timed (descent, escapes and
simplification). The ratio compares the simplified path with the exact shortest path among the circles
(:mod:`mrs_nav.fields.shortest_path`; the arena walls are left out of that yardstick, which only makes it shorter,
so the ratio is if anything overstated). A baseline row runs the plain descent (no noise, no random walk).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from tqdm import tqdm

from mrs_nav.fields.randomized_potential_field import EscapeSettings, plan_potential_field
from mrs_nav.fields.scenarios import Scenario, symmetric_trap, two_cylinder_trap
from mrs_nav.fields.shortest_path import shortest_path
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.tables import markdown_table

HEADER = [
    "case",
    "method",
    "reached",
    "time median [ms]",
    "time p95 [ms]",
    "steps median",
    "length median [m]",
    "shortest [m]",
    "ratio median",
    "ratio max",
]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seeds", type=int, default=100, help="seeds per case (default 100)")


def _row(scenario: Scenario, method: str, settings: EscapeSettings, seeds: int) -> list[object]:
    field = scenario.field()
    best = shortest_path(scenario.start, scenario.goal, Obstacles(circles=scenario.obstacles.circles)).length_m
    times, steps, lengths = [], [], []
    reached = 0
    progress = tqdm(range(seeds), desc=f"{scenario.name}, {method}", disable=not sys.stderr.isatty(), leave=False)
    for seed in progress:
        result = plan_potential_field(field, (*scenario.start, 0.0), seed, settings)
        times.append(result.time_s * 1000.0)
        steps.append(result.iterations)
        if result.success:
            reached += 1
            lengths.append(result.length_m)
    ratios = np.array(lengths) / best
    return [
        scenario.name,
        method,
        f"{reached}/{seeds}",
        float(np.median(times)),
        float(np.percentile(times, 95)),
        int(np.median(steps)),
        float(np.median(lengths)) if lengths else "-",
        best,
        float(np.median(ratios)) if lengths else "-",
        float(ratios.max()) if lengths else "-",
    ]


def run(args: argparse.Namespace) -> str:
    escape = EscapeSettings()
    plain = EscapeSettings(noise_std=0.0, random_walk=False)
    rows = []
    for scenario in (symmetric_trap(), two_cylinder_trap()):
        rows.append(_row(scenario, "noise + random walk", escape, args.seeds))
        rows.append(_row(scenario, "plain descent", plain, min(args.seeds, 10)))
    return (
        f"{args.seeds} seeds per case (the plain-descent baseline is deterministic: 10 runs). Time is one "
        "`plan_potential_field` call (Euler descent at dt = 0.01 s with noise sigma = 0.05 m/s, random-walk "
        "escapes, shortcut simplification); ratio = simplified path length / exact shortest path among the "
        "circles. Targets: >= 99 of 100 seeds reach the goal, ratio <= 1.15.\n\n" + markdown_table(HEADER, rows)
    )
