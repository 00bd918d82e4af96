"""Regression replays of many bags: serial, local worker processes, and a local two-worker Dask cluster.

``--bags`` copies of the regression bags (``tests/data/bags``, cycled, each with its golden file, so each copy is
replayed with SLAM and re-planning as the regression suite does) are replayed three ways through
:func:`mrs_nav.replay.batch.run_jobs`: in turn in this process, by ``--workers`` local processes, and on a Dask
``LocalCluster`` of ``--workers`` single-threaded worker processes on 127.0.0.1. Wall time covers the whole
batch; the cluster's start, in which its workers import mrs_nav (``preload``, as the README advises for any
cluster), is excluded, while the local workers' start is counted: they are forked, as ``mrs-nav replay`` forks
them, before this process has replayed anything. The per-bag outputs of each parallel run are checked
byte-identical to the serial run's.
"""

from __future__ import annotations

import argparse
import multiprocessing
import shutil
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from mrs_nav.bench.replay import DEFAULT_BAGS
from mrs_nav.errors import MrsNavError
from mrs_nav.options import runs_option
from mrs_nav.replay.batch import BagJob, find_bags, run_jobs
from mrs_nav.replay.golden import load_golden
from mrs_nav.replay.job_options import golden_job
from mrs_nav.tables import markdown_table

SPEEDUP_TARGET = 0.6  # issue: wall time with 2 workers <= 0.6x the serial time


def dask_worker_config() -> dict[str, object]:
    """The Dask worker settings the README gives for replay clusters (measured on the 20 regression bags)."""
    import dask  # noqa: PLC0415 - only the cluster run needs Dask
    import distributed  # noqa: F401, PLC0415 - registers the defaults read below

    environ = dask.config.get("distributed.nanny.pre-spawn-environ")
    return {
        # The worker's statistical profiler samples the task's stack every 10 ms: a few % of a replay's CPU.
        "distributed.worker.profile.enabled": False,
        # Dask's own 64 KiB trim threshold hands freed memory back to the OS at once, so a replay's per-scan
        # arrays cost page faults: 15 % of a worker's CPU went to system time. Without it glibc's adaptive
        # threshold applies, as in any Python process.
        "distributed.nanny.pre-spawn-environ": {k: v for k, v in environ.items() if k != "MALLOC_TRIM_THRESHOLD_"},
    }


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--bags", type=runs_option, default=20, help="how many bags to replay (default: 20)")
    parser.add_argument("--workers", type=runs_option, default=2, help="local worker processes (default: 2)")
    parser.add_argument("--source", type=Path, default=DEFAULT_BAGS, help=f"regression bags (default: {DEFAULT_BAGS})")


def _jobs(source: Path, count: int, folder: Path, out: Path) -> list[BagJob]:
    """``count`` copies of the source bags, each replayed with the options of its golden file."""
    originals = [b for b in find_bags([source]) if b.with_name(b.stem + ".golden.json").is_file()]
    if not originals:
        raise MrsNavError(f"no bags with golden files in {source}")
    jobs = []
    for i in range(count):
        original = originals[i % len(originals)]
        bag = folder / f"{original.stem}_{i:03d}.bag"
        shutil.copy(original, bag)
        golden = original.with_name(original.stem + ".golden.json")
        load_golden(golden)
        jobs.append(golden_job(bag, out / bag.stem, golden))
    return jobs


def _spin(_: int) -> float:
    """CPU-bound pure Python for a fixed amount of work; its wall time (s)."""
    start = time.perf_counter()
    total = 0
    for i in range(15_000_000):  # about 1 s: shorter runs mostly measure the host's noise
        total += i * i
    return time.perf_counter() - start


def parallel_capacity(workers: int) -> float:
    """How many times one process's throughput ``workers`` CPU-bound processes get together on this machine
    (``workers`` on dedicated cores; less where virtual CPUs share a core or the host is busy)."""
    context = multiprocessing.get_context("forkserver")
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        list(pool.map(_spin, range(workers)))  # warm the workers up
        alone = min(pool.submit(_spin, 0).result() for _ in range(3))
        together = max(pool.map(_spin, range(workers)))
    return workers * alone / together


def _files(out: Path) -> dict[str, bytes]:
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


def run(args: argparse.Namespace) -> str:
    import dask  # noqa: PLC0415 - only this benchmark starts a cluster
    from distributed import LocalCluster  # noqa: PLC0415

    runs: dict[str, tuple[float, int, int, Path]] = {}  # wall s, bags, bags passed, output folder
    with tempfile.TemporaryDirectory(prefix="mrs_nav_bench_batch_") as tmp:
        root = Path(tmp)
        (root / "bags").mkdir()

        def timed(label: str, workers: int, address: str | None) -> None:
            out = root / label.replace(" ", "_").replace(",", "")
            jobs = _jobs(args.source, args.bags, root / "bags", out)
            start = time.perf_counter()
            outcomes = run_jobs(jobs, workers, address)
            wall = time.perf_counter() - start
            runs[label] = (wall, len(outcomes), sum(o.verdict == "passed" for o in outcomes), out)

        local, cluster_label = f"{args.workers} local workers", f"Dask LocalCluster, {args.workers} workers"
        # The local workers run first, forked from this process while it holds only the imports that
        # `mrs-nav replay` holds when it forks them; after the serial run they would inherit its warmed-up state.
        timed(local, args.workers, None)
        timed("serial", 1, None)
        # The cluster is started only now: its idle scheduler and workers would otherwise share the CPU with the
        # two runs above.
        # preload and config: the workers start as the README tells users to start theirs.
        with (
            dask.config.set(dask_worker_config()),
            LocalCluster(  # type: ignore[no-untyped-call]
                n_workers=args.workers,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
                preload=["mrs_nav.replay.batch"],
            ) as cluster,
        ):
            timed(cluster_label, 1, cluster.scheduler_address)
        serial_wall, _, _, serial_out = runs["serial"]
        serial_files = _files(serial_out)
        rows: list[list[object]] = []
        verdicts = []
        for label in ["serial", local, cluster_label]:
            wall, bags, passed, out = runs[label]
            same = _files(out) == serial_files
            ratio = wall / serial_wall
            rows.append([label, wall, ratio, passed, "yes" if same else "NO"])
            if label != "serial":
                verdict = "PASS" if ratio <= SPEEDUP_TARGET and same and passed == bags else "FAIL"
                verdicts.append(f"- {label}: {ratio:.2f}x the serial time, target <= {SPEEDUP_TARGET}: {verdict}")
    capacity = parallel_capacity(args.workers)
    header = ["how", "wall [s]", "x serial time", "bags passed", "outputs identical to serial"]
    return (
        f"### Regression replays of {args.bags} bags (SLAM + re-planning, held to their goldens)\n\n"
        + markdown_table(header, rows)
        + "\n\n"
        + "\n".join(verdicts)
        + f"\n\nThis machine's parallel capacity just after the batches: {args.workers} CPU-bound Python processes "
        f"at once got {capacity:.2f}x the throughput of one (about {args.workers}x on {args.workers} dedicated cores, "
        "less while the host is busy). It varies from minute to minute with the host's load, and so do the ratios "
        "above.\n"
    )
