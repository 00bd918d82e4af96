"""Replaying a recorded session offline: SLAM again over its scans, the planner again on its goals, and the
replay compared with what the live system recorded.

Metrics (all deterministic: the same bag and options give the same numbers, so they can be held to a golden
file): ``scans_processed``; against ``/ground_truth/odom`` ``ate_rmse_m``/``ate_rmse_deg`` (after an SE(2)
fit) and ``rpe_trans_mean_m``/``rpe_rot_mean_deg``; against the recorded ``/map`` (its last message)
``map_iou`` and ``map_iou_1cell`` (:mod:`mrs_nav.replay.map_compare`); against the recorded live SLAM pose
(``/tf`` map->odom * ``/odom``) ``slam_vs_recorded_rms_m`` (RMS position difference at the processed scans); and
with planning, ``goals``, ``goals_reachable`` (on the replayed map), ``goals_reachable_recorded_map`` and
``plan_length_ratio_mean`` (length planned on the replayed map over that planned on the recorded map, same
start and seed, where both succeed).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mrs_nav.atomic_write import write_text
from mrs_nav.bag import topics
from mrs_nav.bag.io import bag_topics
from mrs_nav.errors import BagError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.occupancy_grid import OccupancyGrid
from mrs_nav.replay.bag_frames import BagNames
from mrs_nav.replay.golden import dump_json
from mrs_nav.replay.map_compare import compare_maps
from mrs_nav.replay.plan_replay import GoalPlan, replan_goals
from mrs_nav.replay.pose_track import PoseTrack
from mrs_nav.replay.recorded import RecordedSession, read_recorded
from mrs_nav.replay.slam_replay import SlamReplay, replay_slam
from mrs_nav.slam.config import SlamConfig

Metrics = dict[str, float | int | None]


@dataclass(frozen=True)
class PlanOptions:
    """Re-planning budget (RRT* iterations per query), seed, and whether to stop at the first path."""

    iterations: int = 1500
    seed: int = 0
    first_path: bool = False


@dataclass
class SessionReplay:
    """A replayed session: the SLAM replay, what was recorded, the plans and the metrics."""

    slam: SlamReplay
    recorded: RecordedSession
    plans: list[GoalPlan] = field(default_factory=list)
    plans_on_recorded_map: list[GoalPlan] = field(default_factory=list)
    metrics: Metrics = field(default_factory=dict)


def check_types(bag: Path) -> None:
    """Raise :class:`BagError` when a session topic of ``bag`` has another type than a recording's."""
    for topic, msgtype in sorted(bag_topics(bag).items()):
        expected = topics.SESSION_TYPES.get(topic)
        if expected is not None and msgtype != expected:
            raise BagError(f"bag {bag}: topic {topic} has type {msgtype}, expected {expected}")


def replayed_map(result: SlamReplay) -> OccupancyGrid:
    """The SLAM map of a replay as an :class:`OccupancyGrid` (map frame)."""
    grid = result.slam.grid
    return OccupancyGrid(grid.to_occupancy(), grid.resolution, (grid.origin_x, grid.origin_y, 0.0))


def replay_session(
    bag: Path,
    config: SlamConfig,
    plan: PlanOptions | None = None,
    progress: Callable[[int], None] | None = None,
    names: BagNames | None = None,
) -> SessionReplay:
    """Replay ``bag`` (see the module docstring) reading the topics and frames ``names`` gives (default:
    mrs_nav's); plan only when ``plan`` is given."""
    check_types(bag)
    names = names or BagNames()
    session = SessionReplay(replay_slam(bag, config, progress, names), read_recorded(bag, names))
    slam, recorded = session.slam, session.recorded
    poses = [p.pose for p in slam.slam.processed]  # after any correction since each scan was processed
    metrics: Metrics = {"scans_processed": len(poses)}
    errors = slam.errors()
    metrics["ate_rmse_m"] = errors.ate_rmse_m if errors else None
    metrics["ate_rmse_deg"] = errors.ate_rmse_deg if errors else None
    metrics["rpe_trans_mean_m"] = errors.rpe_trans_mean_m if errors else None
    metrics["rpe_rot_mean_deg"] = errors.rpe_rot_mean_deg if errors else None
    grid = replayed_map(slam)
    if recorded.final_map is not None:
        agreement = compare_maps(recorded.final_map, grid)
        metrics["map_iou"], metrics["map_iou_1cell"] = agreement.iou, agreement.iou_1cell
    else:
        metrics["map_iou"] = metrics["map_iou_1cell"] = None
    metrics["slam_vs_recorded_rms_m"] = _rms_difference(slam.stamps, poses, recorded)
    if plan is not None:
        track = PoseTrack(tolerance=math.inf)
        for stamp, pose in zip(slam.stamps, poses, strict=True):
            track.add(stamp, pose)

        def plan_on(map_: OccupancyGrid) -> list[GoalPlan]:
            return replan_goals(
                map_, recorded.goals, track.at, iterations=plan.iterations, seed=plan.seed, first_path=plan.first_path
            )

        session.plans = plan_on(grid)
        metrics["goals"] = len(recorded.goals)
        metrics["goals_reachable"] = sum(p.result is not None for p in session.plans)
        if recorded.final_map is not None:
            session.plans_on_recorded_map = plan_on(recorded.final_map)
            metrics["goals_reachable_recorded_map"] = sum(p.result is not None for p in session.plans_on_recorded_map)
        else:
            metrics["goals_reachable_recorded_map"] = None
        ratios = [
            mine.result.length_m / theirs.result.length_m
            for mine, theirs in zip(session.plans, session.plans_on_recorded_map, strict=False)
            if mine.result is not None and theirs.result is not None and theirs.result.length_m > 0.0
        ]
        metrics["plan_length_ratio_mean"] = float(np.mean(ratios)) if ratios else None
    session.metrics = {k: _rounded(v) for k, v in metrics.items()}
    return session


def _rms_difference(stamps: list[float], poses: list[Pose2D], recorded: RecordedSession) -> float | None:
    pairs = [(p, recorded.slam_pose(t)) for t, p in zip(stamps, poses, strict=True)]
    diffs = [math.hypot(p.x - q.x, p.y - q.y) for p, q in pairs if q is not None]
    return math.sqrt(sum(d * d for d in diffs) / len(diffs)) if diffs else None


def _rounded(value: float | int | None) -> float | int | None:
    """Floats to 6 decimals (micrometres for lengths): stable text, no false precision in golden files."""
    return round(value, 6) if isinstance(value, float) else value


def plans_json(session: SessionReplay) -> dict[str, Any]:
    """The re-planned goals (start, goal, success, length, path) without timings, so the text is reproducible.

    A goal with no path has ``success`` false, length 0 and an empty path."""

    def entry(plan: GoalPlan) -> dict[str, Any]:
        path = np.zeros((0, 3)) if plan.result is None else np.asarray(plan.result.path).reshape(-1, 3)
        return {
            "stamp": round(plan.goal.stamp, 6),
            "start": [round(v, 4) for v in (plan.start.x, plan.start.y, plan.start.yaw)],
            "goal": [round(plan.goal.pose.x, 4), round(plan.goal.pose.y, 4)],
            "success": plan.result is not None,
            "length_m": round(plan.result.length_m, 4) if plan.result is not None else 0.0,
            "iterations": plan.iterations,
            "path": [[round(float(v), 4) for v in row] for row in path],
        }

    return {
        "replayed_map": [entry(p) for p in session.plans],
        "recorded_map": [entry(p) for p in session.plans_on_recorded_map],
        "recorded_paths": [[round(t, 6), round(length, 4)] for t, length in session.recorded.paths],
    }


def session_output_paths(out_dir: Path) -> dict[str, Path]:
    """The files :func:`write_session_outputs` may write into ``out_dir``."""
    return {"metrics": out_dir / "metrics.json", "plans": out_dir / "plans.json"}


def write_session_outputs(session: SessionReplay, out_dir: Path) -> dict[str, Path]:
    """``metrics.json`` (and ``plans.json`` when planned) in ``out_dir``; byte-identical for the same replay."""
    every = session_output_paths(out_dir)
    paths = {"metrics": every["metrics"]}
    write_text(paths["metrics"], dump_json(session.metrics), "metrics")
    if session.plans or session.plans_on_recorded_map:
        paths["plans"] = every["plans"]
        write_text(paths["plans"], dump_json(plans_json(session)), "plans")
    return paths
