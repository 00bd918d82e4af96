"""Replaying many recorded sessions at once: one job per bag, fanned out to local processes or a Dask cluster.

A :class:`BagJob` names a bag, its output folder, its SLAM parameters and planning options and, optionally, the
golden file it is held to. :func:`replay_bag` runs one job exactly as ``mrs-nav replay BAG`` does (the same
functions, in the same order), so a bag's output files are byte-identical whichever process, machine or order
ran it. :func:`run_jobs` runs them in this process, in a pool of local worker processes, or on an existing
Dask distributed scheduler (``tcp://host:port``) and returns the outcomes sorted by bag name; the aggregate
(:func:`aggregate`, :func:`markdown_report`) holds no timing, so it is byte-identical too.

Local worker processes are forked from a single-threaded parent, so they start with mrs_nav, numpy and rosbags
already imported (about 1.2 s of CPU each otherwise). A parent that holds threads (Dask's event loop, a progress
bar's monitor) starts them through ``forkserver`` instead, since ``fork`` would copy a lock another thread holds.
"""

from __future__ import annotations

import multiprocessing
import resource
import tempfile
import threading
from collections.abc import Callable, Iterable, Sequence
from concurrent import futures as local
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mrs_nav.bag.salvage import readable_bag
from mrs_nav.errors import InvalidInputError, MrsNavError
from mrs_nav.replay.bag_frames import BagNames
from mrs_nav.replay.golden import load_golden, regressions
from mrs_nav.replay.session_replay import (
    PlanOptions,
    SessionReplay,
    replay_session,
    session_output_paths,
    write_session_outputs,
)
from mrs_nav.replay.slam_replay import SlamReplay, output_paths, truth_scans, write_outputs
from mrs_nav.ros_processes import resident_bytes
from mrs_nav.slam.config import MAX_COORDINATE_M, SlamConfig
from mrs_nav.slam.eval.consistency import doubled_wall_fraction_at
from mrs_nav.tables import markdown_table

GOLDEN_SUFFIX = ".golden.json"


@dataclass(frozen=True)
class BagJob:
    """One bag to replay into ``out_dir`` with SLAM ``params`` (``NAME=VALUE``), re-planning when ``plan``."""

    bag: Path
    out_dir: Path
    params: tuple[str, ...] = ()
    plan: PlanOptions | None = None
    golden: Path | None = None
    names: BagNames = field(default_factory=BagNames)  # the bag's topics and frames
    # Also the doubled-wall figure of the map the scans make at the bag's ground-truth poses (summary key
    # doubled_wall_fraction_at_truth; None without truth): what the scene itself puts on the broken-map line.
    reference: bool = False

    @property
    def name(self) -> str:
        return self.bag.name.removesuffix(".active").removesuffix(".bag")


@dataclass(frozen=True)
class BagOutcome:
    """What one job gave: its metrics and regressions against the golden, or the one-line error that stopped it.

    ``summary`` (SLAM figures, including timings) and ``notes`` (how an unindexed bag was read, what was skipped)
    are for printing only; :func:`aggregate` leaves them out.
    """

    name: str
    out_dir: Path
    metrics: dict[str, float | int | None] = field(default_factory=dict)
    regressions: tuple[str, ...] = ()
    has_golden: bool = False
    error: str | None = None
    summary: dict[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    # Peak resident memory (MB) of the process that ran the job, up to the end of its replay (not the reference
    # map after it, BagJob.reference): the job's own with run_jobs(fresh=True)
    peak_rss_mb: float | None = None
    # Its resident memory (MB) when the replay began (the imports, the bag opened; in a reused process, earlier
    # jobs' leftovers) and its peak at the replay's end, before the outputs and figures (the SLAM's own memory)
    start_rss_mb: float | None = None
    replay_peak_rss_mb: float | None = None

    @property
    def verdict(self) -> str:
        """``error``, ``regressed``, ``passed`` (held to a golden file) or ``replayed`` (no golden file)."""
        if self.error is not None:
            return "error"
        if self.regressions:
            return "regressed"
        return "passed" if self.has_golden else "replayed"


def job_outputs(out_dir: Path) -> list[Path]:
    """Every file a replay may write into ``out_dir``."""
    return [*output_paths(out_dir).values(), *session_output_paths(out_dir).values()]


def golden_beside(bag: Path) -> Path | None:
    """``NAME.golden.json`` next to ``NAME.bag`` (or ``NAME.bag.active``), if there is one."""
    name = bag.name.removesuffix(".active").removesuffix(".bag")
    candidate = bag.with_name(name + GOLDEN_SUFFIX)
    return candidate if candidate.is_file() else None


def find_bags(paths: Iterable[Path]) -> list[Path]:
    """The bags named: files as given, folders as their ``*.bag`` and ``*.bag.active`` files, sorted by name."""
    bags: list[Path] = []
    for path in paths:
        if path.is_dir():
            bags += sorted(p for p in path.iterdir() if p.is_file() and p.name.endswith((".bag", ".bag.active")))
        elif path.is_file():
            bags.append(path)
        else:
            raise InvalidInputError(f"{path}: no such bag or folder")
    if not bags:
        raise InvalidInputError("no bags found in " + ", ".join(str(p) for p in paths))
    names = [b.name.removesuffix(".active") for b in bags]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise InvalidInputError(f"bag names must be unique (their output folders are named after them): {twice}")
    return sorted(bags, key=lambda b: b.name)


def replay_bag(job: BagJob, progress: Callable[[int], None] | None = None) -> tuple[BagOutcome, SessionReplay]:
    """Replay one bag and write its outputs to ``job.out_dir``; raises :class:`MrsNavError` on bad input."""
    config = SlamConfig.from_assignments(list(job.params))
    golden = load_golden(job.golden) if job.golden else None
    with tempfile.TemporaryDirectory(prefix="mrs_nav_replay_") as work:
        bag, note = readable_bag(job.bag, Path(work))
        start = resident_bytes() / 2**20
        session = replay_session(bag, config, job.plan, progress, job.names)
        replay_peak = _peak_rss_mb()
        result = session.slam
        if not result.estimate:
            skipped = _skipped(session)
            if skipped:  # every scan refused for its own values: say so, not that odometry was missing
                raise InvalidInputError(f"bag {job.bag}: no scan could be used: {'; '.join(skipped)}")
            read = result.scans_read
            raise InvalidInputError(f"bag {job.bag}: no scan could be paired with odometry ({read} scans read)")
        job.out_dir.mkdir(parents=True, exist_ok=True)
        write_outputs(result, job.out_dir)
        write_session_outputs(session, job.out_dir)
        summary = result.summary()
        # The replay's peak, taken before the reference map: that map is the bench's memory, not the SLAM's.
        peak = _peak_rss_mb()
        if job.reference:
            summary["doubled_wall_fraction_at_truth"] = _doubled_at_truth(bag, result, config)
    found = regressions(session.metrics, golden) if golden is not None else []
    outcome = BagOutcome(
        name=job.name,
        out_dir=job.out_dir,
        metrics=dict(session.metrics),
        regressions=tuple(r.describe() for r in found),
        has_golden=golden is not None,
        summary=summary,
        notes=tuple(n for n in (note, *_skipped(session)) if n),
        peak_rss_mb=peak,
        start_rss_mb=start,
        replay_peak_rss_mb=replay_peak,
    )
    return outcome, session


def _doubled_at_truth(bag: Path, result: SlamReplay, config: SlamConfig) -> float | None:
    """:func:`doubled_wall_fraction_at` the bag's ground-truth poses; None without truth or when those poses
    take the map past its cell limit."""
    scans = truth_scans(bag, result)
    if scans is None:
        return None
    try:
        return doubled_wall_fraction_at(config, scans)
    except InvalidInputError:
        return None


def _skipped(session: SessionReplay) -> list[str]:
    """What the SLAM replay left out of the bag, in words (nothing when it used every message)."""
    result = session.slam
    notes = [result.frames.note] if result.frames.note else []
    if result.scans_out_of_order or result.scans_rejected:
        first = f" (first: {result.first_rejection})" if result.first_rejection else ""
        notes.append(
            f"skipped {result.scans_out_of_order} scans stamped at or before the previous scan and "
            f"{result.scans_rejected} scans without odometry or with bad values, of {result.scans_read}{first}"
        )
    if result.slam.clipped_in_rebuild:
        notes.append(
            f"{result.slam.clipped_in_rebuild} scans reached past the map's cell limit when the map was rebuilt "
            "after loop closures and were mapped clipped to it"
        )
    if result.poses_invalid:
        notes.append(
            f"skipped {result.poses_invalid} odometry or ground-truth messages with non-finite values (first: "
            f"{result.first_invalid_pose})"
        )
    if result.odom_rejected:
        notes.append(
            f"skipped {result.odom_rejected} of {result.odom_read} odometry messages farther than "
            f"{MAX_COORDINATE_M:g} m from the origin"
        )
    return notes


def run_job(job: BagJob) -> BagOutcome:
    """:func:`replay_bag` for a worker: a domain error becomes the outcome's ``error`` instead of an exception."""
    try:
        return replay_bag(job)[0]
    except MrsNavError as err:
        return BagOutcome(
            name=job.name,
            out_dir=job.out_dir,
            has_golden=job.golden is not None,
            error=str(err),
            peak_rss_mb=_peak_rss_mb(),
        )


def _peak_rss_mb() -> float:
    """This process's peak resident memory so far (MB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def run_jobs(
    jobs: Sequence[BagJob],
    workers: int = 1,
    cluster: str | None = None,
    done: Callable[[BagOutcome], None] | None = None,
    *,
    fresh: bool = False,
) -> list[BagOutcome]:
    """Run every job (``workers`` local processes, or the Dask scheduler at ``cluster``); sorted by bag name.

    ``done`` is called in this process as each job finishes (a progress bar). ``fresh``: every local job in a
    process of its own, started anew, so that its ``peak_rss_mb`` is the job's alone (about a second more a job).
    """
    if workers < 1:
        raise InvalidInputError(f"--workers must be >= 1, got {workers}")
    outcomes: list[BagOutcome] = []

    def finished(outcome: BagOutcome) -> None:
        outcomes.append(outcome)
        if done is not None:
            done(outcome)

    if cluster is not None:
        _run_on_dask(jobs, cluster, finished)
    elif not fresh and (workers == 1 or len(jobs) == 1):
        for job in jobs:
            finished(run_job(job))
    else:
        method = "spawn" if fresh else "fork" if threading.active_count() == 1 else "forkserver"
        with local.ProcessPoolExecutor(
            max_workers=min(workers, len(jobs)),
            mp_context=multiprocessing.get_context(method),
            max_tasks_per_child=1 if fresh else None,
        ) as pool:
            for future in local.as_completed([pool.submit(run_job, job) for job in longest_first(jobs)]):
                finished(future.result())
    return sorted(outcomes, key=lambda o: o.name)


def longest_first(jobs: Sequence[BagJob]) -> list[BagJob]:
    """The jobs, largest bag first: a long replay started last would leave the other workers idle at the end.

    Bag size stands in for replay time (Graham's longest-processing-time rule, within 4/3 of the best schedule).
    """

    def size(job: BagJob) -> int:
        try:
            return job.bag.stat().st_size
        except OSError:
            return 0  # replaying it will say what is wrong with it

    return sorted(jobs, key=size, reverse=True)


def _run_on_dask(jobs: Sequence[BagJob], address: str, finished: Callable[[BagOutcome], None]) -> None:
    """The jobs on the Dask distributed scheduler at ``address``; its workers need mrs_nav installed."""
    try:
        from distributed import Client, as_completed  # noqa: PLC0415 - only --cluster needs it
    except ImportError:
        raise InvalidInputError("--cluster needs Dask distributed: pip install distributed") from None
    try:
        client = Client(address, timeout=10)  # type: ignore[no-untyped-call]
    except (OSError, TimeoutError) as err:
        raise InvalidInputError(f"--cluster {address}: no Dask scheduler answered ({err})") from None
    with client:
        # pure=False: two jobs with equal fields are still two replays (and never served from a cache).
        for future in as_completed(client.map(run_job, longest_first(jobs), pure=False)):  # type: ignore[no-untyped-call]
            finished(future.result())


def dask_setup(worker: object) -> None:
    """Dask's start-up hook for a preload module (``dask worker ... --preload mrs_nav.replay.batch``): a worker
    imports the plotting library every replay's figure needs (about 0.5 s of CPU) when it starts, not in its first
    job."""
    del worker
    import matplotlib.backends.backend_agg  # noqa: PLC0415
    import matplotlib.figure  # noqa: F401, PLC0415


def aggregate(outcomes: Sequence[BagOutcome]) -> dict[str, Any]:
    """The report of a batch as JSON-ready data: per bag its verdict, metrics and regressions, and the counts."""
    verdicts = [o.verdict for o in outcomes]
    return {
        "bags": [
            {
                "bag": o.name,
                "verdict": o.verdict,
                "error": o.error,
                "regressions": list(o.regressions),
                "metrics": o.metrics,
            }
            for o in outcomes
        ],
        "counts": {v: verdicts.count(v) for v in ("passed", "regressed", "replayed", "error")},
    }


def markdown_report(outcomes: Sequence[BagOutcome]) -> str:
    """The report as a markdown table: one row per bag, its verdict and the metrics every bag has."""
    columns = sorted(set.intersection(*(set(o.metrics) for o in outcomes))) if outcomes else []
    rows: list[list[object]] = [
        [
            o.name,
            o.verdict,
            *(o.metrics.get(c, "-") for c in columns),
            (o.error or "; ".join(o.regressions)).replace("|", "/"),
        ]
        for o in outcomes
    ]
    return markdown_table(["bag", "verdict", *columns, "why"], rows) + "\n"
