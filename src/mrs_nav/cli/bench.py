"""``mrs-nav bench NAME``: run a benchmark and write its section of ``bench/RESULTS.md``.

Each benchmark is a module ``mrs_nav.bench.<module>`` exposing ``add_arguments(parser)`` and
``run(args) -> str`` (the markdown body of its section).
"""

from __future__ import annotations

import argparse
import importlib
from pathlib import Path
from typing import Any

from mrs_nav.bench.results import results_path, write_section

# benchmark name on the command line -> module under mrs_nav.bench
BENCHMARKS = {
    "potential-field": "potential_field",
    "planners": "planners",
    "simulator": "simulator",
    "slam": "slam",
    "slam-sweep": "slam_sweep",
    "navigation": "navigation",
    "replay": "replay",
    "replay-batch": "replay_batch",
    "bridge": "bridge",
    "ros2": "ros2",
    "fleet": "fleet",
    "soak": "soak",
    "localisation": "localisation",
    "multi-robot": "multi_robot",
    "contacts": "contacts",
}


def _available() -> dict[str, Any]:
    found = {}
    for name, module in BENCHMARKS.items():
        try:
            found[name] = importlib.import_module(f"mrs_nav.bench.{module}")
        except ModuleNotFoundError as err:
            if err.name != f"mrs_nav.bench.{module}":
                raise
    return found


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "bench",
        help="run a benchmark and record it in bench/RESULTS.md",
        description="Run a benchmark; its section of bench/RESULTS.md is replaced with the new figures.",
    )
    sub = parser.add_subparsers(dest="benchmark", metavar="NAME", required=True)
    for name, module in _available().items():
        bench_parser = sub.add_parser(name, help=(module.__doc__ or name).strip().splitlines()[0])
        bench_parser.add_argument(
            "--results",
            type=Path,
            default=None,
            help="markdown file to update (default: bench/RESULTS.md of the checkout)",
        )
        bench_parser.add_argument("--no-write", action="store_true", help="print the section only")
        module.add_arguments(bench_parser)
        bench_parser.set_defaults(handler=_runner(name, module))


def _runner(name: str, module: Any) -> Any:
    def run(args: argparse.Namespace) -> int:
        results = None if args.no_write else results_path(args.results)  # refused before, not after, the run
        body: str = module.run(args)
        print(body)
        if results is not None:
            path = write_section(name, body, results)
            print(f"written to {path}")
        return 0

    return run
