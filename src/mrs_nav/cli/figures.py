"""``mrs-nav figures``: the assignment's figures as PNGs, seeded and deterministic."""

from __future__ import annotations

import argparse
import importlib
from pathlib import Path
from typing import Any

from mrs_nav.limits import MAX_SEED
from mrs_nav.options import seed_option
from mrs_nav.textfiles import check_writable

# Figure-set modules under mrs_nav.figures, each exposing make_figures(out_dir, seed) -> list[Path].
FIGURE_SETS = ("mrs_nav.figures.potential_field", "mrs_nav.figures.rrt")


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "figures",
        help="the assignment's figures as PNGs, seeded and deterministic",
        description="Write the assignment's figures as PNG files into --out.",
    )
    parser.add_argument("--out", type=Path, required=True, help="output folder (created if missing)")
    parser.add_argument(
        "--seed", type=seed_option, default=0, help=f"seed of the randomised figures, 0..{MAX_SEED} (default 0)"
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    check_writable(args.out, "--out", folder=True)
    for name in FIGURE_SETS:
        written: list[Path] = importlib.import_module(name).make_figures(args.out, args.seed)
        for path in written:
            print(path)
    return 0
