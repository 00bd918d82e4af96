"""SLAM over several logs and a parameter grid, fanned out to local worker processes or a Dask cluster.

Every ``--log`` (a CARMEN log, converted once with its real odometry, or a bag with ``/scan`` and ``/odom``) is
replayed with every combination of the ``--grid`` values (the Cartesian product; ``--param`` values apply to
all), each combination one job of :func:`mrs_nav.replay.batch.run_jobs`: ``--workers`` local processes by
default, the Dask distributed scheduler at ``--cluster`` when given. One row per log and combination: scans,
loops closed, ATE against the log's corrected poses (agreement with the SLAM that corrected the log, not ground
truth), the map-consistency figures (end points on free cells, and on doubled walls with the broken-map line),
CPU ms per scan and the real-time factor by CPU time. The metrics do not depend on where a job ran; the timings do.
"""

from __future__ import annotations

import argparse
import itertools
import os
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from mrs_nav.bag.from_carmen import carmen_to_bag
from mrs_nav.bench.slam import DEFAULT_LOG
from mrs_nav.errors import InvalidInputError
from mrs_nav.limits import MAX_RUNS
from mrs_nav.options import runs_option
from mrs_nav.replay.batch import BagJob, BagOutcome, run_jobs
from mrs_nav.slam.config import SlamConfig
from mrs_nav.slam.eval.consistency import BROKEN_FRACTION, DUPLICATED_LINE, is_broken
from mrs_nav.slam.eval.cost import GROWTH_LINE, MEMORY_LINE_MB, TAIL_LINE, CostAlongLog, bytes_per_m2, cost_failures
from mrs_nav.tables import markdown_table

# Corrected logs hold only the scans their SLAM selected: process every one (as `bench slam` does).
DEFAULT_PARAMS = ("linearUpdate=0", "angularUpdate=0")
DEFAULT_GRID = ("loop_closure=true,false",)


def grid_option(text: str) -> tuple[str, tuple[str, ...]]:
    """``NAME=V1,V2,...`` -> (NAME, values), each ``NAME=Vi`` checked as a SLAM parameter."""
    name, sep, values = text.partition("=")
    choices = tuple(v.strip() for v in values.split(","))
    if not sep or not name.strip() or not all(choices):
        raise argparse.ArgumentTypeError(f"expected NAME=V1,V2,..., got {text[:80]!r}")
    if len(choices) > MAX_RUNS:
        raise argparse.ArgumentTypeError(f"at most {MAX_RUNS} values per parameter, got {len(choices)}")
    try:
        for value in choices:
            SlamConfig.from_assignments([f"{name.strip()}={value}"])
    except InvalidInputError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    return name.strip(), choices


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--log",
        type=Path,
        action="append",
        default=None,
        help=f"CARMEN log or bag, repeatable (default: {DEFAULT_LOG})",
    )
    parser.add_argument(
        "--grid",
        type=grid_option,
        action="append",
        default=None,
        metavar="NAME=V1,V2",
        help=f"SLAM parameter values to sweep, repeatable: every combination runs (default: {DEFAULT_GRID[0]})",
    )
    parser.add_argument(
        "--param",
        action="append",
        default=None,
        metavar="NAME=VALUE",
        help=f"SLAM parameter for every run, repeatable (default: {' '.join(DEFAULT_PARAMS)}: every scan processed)",
    )
    parser.add_argument(
        "--workers", type=runs_option, default=os.cpu_count() or 1, help="local worker processes (default: CPUs)"
    )
    parser.add_argument(
        "--cluster", metavar="ADDRESS", help="run the jobs on this Dask distributed scheduler (tcp://HOST:PORT)"
    )


def combinations(grid: Sequence[tuple[str, tuple[str, ...]]]) -> list[tuple[str, ...]]:
    """Every combination of the grid's values, as ``NAME=VALUE`` assignments in the grid's order."""
    axes = [[f"{name}={value}" for value in values] for name, values in grid]
    return [tuple(combo) for combo in itertools.product(*axes)]


def _as_bag(log: Path, folder: Path) -> Path:
    """``log`` itself if it is a bag, else its conversion (the log's real odometry) into ``folder``."""
    if not log.is_file():
        raise InvalidInputError(f"log {log}: not a readable file")
    if log.suffix == ".bag":
        return log
    bag = folder / (log.name.removesuffix(".gz").removesuffix(".log") + ".bag")
    if bag.exists():
        raise InvalidInputError(f"log {log}: another --log has the same name")
    carmen_to_bag(log, bag)
    return bag


def run(args: argparse.Namespace) -> str:
    logs = args.log or [DEFAULT_LOG]
    params = tuple(args.param if args.param is not None else DEFAULT_PARAMS)
    SlamConfig.from_assignments(list(params))  # a bad --param: one error before any work
    grid = args.grid or [grid_option(g) for g in DEFAULT_GRID]
    combos = combinations(grid)
    with tempfile.TemporaryDirectory(prefix="mrs_nav_bench_sweep_") as tmp:
        root = Path(tmp)
        (root / "bags").mkdir()
        bags = [_as_bag(log, root / "bags") for log in logs]
        jobs = [
            BagJob(bag, root / "out" / bag.stem / str(i), params + combo, reference=True)
            for bag in bags
            for i, combo in enumerate(combos)
        ]
        start = time.perf_counter()
        outcomes = {o.out_dir: o for o in run_jobs(jobs, args.workers, args.cluster, fresh=True)}
        wall = time.perf_counter() - start
        rows = [_row(job, outcomes[job.out_dir], len(params)) for job in jobs]
    how = f"the Dask scheduler at {args.cluster}" if args.cluster else f"{args.workers} local worker process(es)"
    header = [
        "log",
        "swept parameters",
        "scans",
        "loops closed",
        "ATE vs corrected log [m]",
        "end points on free cells",
        "on doubled walls",
        "same, at the corrected poses",
        "places mapped twice",
        "map",
        "CPU ms/scan median",
        "x real time (CPU)",
        "peak RSS [MB]",
        "CPU ms/scan median, first / last 10 %",
        "last / first",
        "p95 / median",
        "area mapped [m^2]",
        "above the imports [kB/m^2]",
        "map + kept beams [kB/m^2]",
        "cost lines",
    ]
    return (
        f"### {len(jobs)} SLAM runs: {len(logs)} log(s) x {len(combos)} parameter combination(s)\n\n"
        f"Every run with {' '.join(params) or 'the shipped defaults'}; {len(jobs)} jobs on {how}, "
        f"{wall:.1f} s wall in all, each job in a process of its own (peak RSS: that process's during the replay, "
        "before the reference figure below; on a Dask cluster, the worker's). ATE compares with the log's "
        "corrected poses (another SLAM's output); "
        f"'broken' = more than {BROKEN_FRACTION} of the scan end points on doubled walls: pieces of a metre or more "
        "on free cells away from the map's walls (moving people leave shorter ones); the same figure for the map "
        "the scans make at the log's corrected poses says how much of it the scene draws (things that stood on "
        "one pass and were gone on the next, such as a parked car); or more than "
        f"{DUPLICATED_LINE} of the nodes checked found by place elsewhere in the map, twice in a row (places "
        "mapped twice, the second copy where the first never reached); '-' where a bag has no ground truth. "
        f"Cost lines (issue 40): the last 10 % of the scans' median CPU at most {GROWTH_LINE} x the first 10 %'s, "
        f"p95 at most {TAIL_LINE} x the median, peak RSS at most {MEMORY_LINE_MB:.0f} MB; memory above the imports "
        "is the peak at the replay's end less the RSS when it began, per square metre of cells seen free or "
        "occupied (an upper bound: it also holds the bag reader's buffers, and the peak may be from before the "
        "replay); of it, the SLAM's map arrays and the beams kept to rebuild it.\n\n"
        + markdown_table(header, rows)
        + "\n"
    )


def _row(job: BagJob, outcome: BagOutcome, fixed: int) -> list[object]:
    swept = " ".join(job.params[fixed:])
    if outcome.error is not None:
        return [job.name, swept, *["-"] * 7, f"error: {outcome.error}", *["-"] * 10]
    summary = outcome.summary
    doubled, at_truth = summary["doubled_wall_fraction"], summary["doubled_wall_fraction_at_truth"]
    duplicated = summary["duplicated_place_fraction"]
    return [
        job.name,
        swept,
        summary["scans"],
        summary["loops_closed"],
        summary["ate_rmse_m"] if summary["ate_rmse_m"] is not None else "-",
        summary["free_endpoint_fraction"],
        doubled,
        at_truth if at_truth is not None else "-",
        duplicated,
        "broken" if is_broken(doubled, duplicated) else "ok",
        summary["ms_per_scan_median"],
        summary["realtime_factor"],
        outcome.peak_rss_mb if outcome.peak_rss_mb is not None else "-",
        *_cost_cells(outcome),
    ]


def _cost_cells(outcome: BagOutcome) -> list[object]:
    """The cost columns of a replayed job's row (issue 40): the first and last tenth's medians, their ratio, p95
    over the median, the area mapped, the memory above the imports and the map's and kept beams' bytes per square
    metre, and the verdict."""
    summary, peak, start = outcome.summary, outcome.peak_rss_mb, outcome.start_rss_mb
    replay_peak = outcome.replay_peak_rss_mb
    area = summary["mapped_area_m2"]
    held = bytes_per_m2(summary["slam_held_bytes"], area) / 1000.0
    if summary["ms_per_scan_growth"] is None:
        return ["-", "-", "-", area, "-", held, "-"]
    cost = CostAlongLog(
        summary["scans"],
        summary["ms_per_scan_first_tenth_median"],
        summary["ms_per_scan_last_tenth_median"],
        summary["ms_per_scan_median"],
        summary["ms_per_scan_p95"],
    )
    above: object = "-"
    if replay_peak is not None and start is not None:
        above = bytes_per_m2(max(replay_peak - start, 0.0) * 2**20, area) / 1000.0
    failures = cost_failures(cost, peak)
    return [
        f"{cost.first_median_ms:.2f} / {cost.last_median_ms:.2f}",
        cost.growth,
        cost.tail,
        area,
        above,
        held,
        "FAIL: " + "; ".join(failures) if failures else "PASS",
    ]
