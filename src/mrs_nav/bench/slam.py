"""SLAM: Intel Research Lab log RPE and real-time factor (three seeds); simulated office ATE, map IoU, speed.

The Intel log goes through ``carmen2bag`` (default odometry noise) and ``replay --slam`` with every scan
processed (the corrected log already holds gmapping's selected scans, about 0.65 m / 22 degrees apart).
Targets: RPE mean translational error <= 0.07 m (gmapping's published figure), >= 15x faster than real time,
and a median <= 20 ms per processed scan. The simulated office: a scripted 20 m drive with the core simulator
(360-beam scans, 1 % wheel odometry noise), ATE <= 3 cm and <= 1 degree, map IoU against the world >= 0.9.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from mrs_nav.bag.from_carmen import carmen_to_bag
from mrs_nav.maps.world import load_world
from mrs_nav.motion_model import DEFAULT_ALPHAS, OdometryNoise
from mrs_nav.replay.slam_replay import replay_slam
from mrs_nav.resources import CHECKOUT, WORLDS_DIR
from mrs_nav.sim.simulator import SimulatorConfig
from mrs_nav.slam.config import SlamConfig
from mrs_nav.slam.metrics import trajectory_errors
from mrs_nav.slam.sim_drive import OFFICE_START, OFFICE_WAYPOINTS, drive_with_slam
from mrs_nav.tables import markdown_table

DEFAULT_LOG = CHECKOUT.parent / "shared" / "data" / "intel-corrected.log.gz"
OFFICE = WORLDS_DIR / "office.world"
# Every logged scan is processed; beams beyond 30 m (none in this log) would only clear free space.
INTEL_CONFIG = SlamConfig(maxUrange=30.0, linearUpdate=0.0, angularUpdate=0.0)
RPE_TARGET_M = 0.07
REALTIME_TARGET = 15.0
MS_TARGET = 20.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--log", type=Path, default=DEFAULT_LOG, help=f"Intel CARMEN log (default: {DEFAULT_LOG})")
    parser.add_argument("--seeds", type=int, default=3, help="odometry noise seeds 0..N-1 (default: 3)")


def run(args: argparse.Namespace) -> str:
    return _intel(args) + "\n" + _office()


def _office() -> str:
    rows: list[list[object]] = []
    for seed in (1, 2, 3):
        result = drive_with_slam(
            load_world(OFFICE), OFFICE_START, OFFICE_WAYPOINTS, sim_config=SimulatorConfig(odom_noise=0.01, seed=seed)
        )
        rows.append(
            [
                seed,
                result.scans,
                result.errors.ate_rmse_m,
                result.errors.ate_rmse_deg,
                result.iou,
                result.iou_one_cell,
                float(np.median(result.slam_ms)),
                result.scans_per_second,
            ]
        )
    header = ["seed", "scans", "ATE [m]", "ATE [deg]", "IoU", "IoU (1 cell tol.)", "ms/scan median", "scans/s"]
    worst_ate = max(float(r[2]) for r in rows)  # type: ignore[arg-type]
    worst_deg = max(float(r[3]) for r in rows)  # type: ignore[arg-type]
    worst_iou = min(float(r[4]) for r in rows)  # type: ignore[arg-type]
    ms = float(np.median([float(r[6]) for r in rows]))  # type: ignore[arg-type]
    return (
        "### Simulated office (20 m scripted drive, 360-beam scans, maxUrange 3 m)\n\n"
        + markdown_table(header, rows)
        + "\n\n"
        + f"- ATE (worst seed) {worst_ate:.4f} m / {worst_deg:.3f} deg, target <= 0.03 m and <= 1 deg: "
        + f"{'PASS' if worst_ate <= 0.03 and worst_deg <= 1.0 else 'FAIL'}\n"
        + f"- map IoU (worst seed) {worst_iou:.3f}, target >= 0.9: {'PASS' if worst_iou >= 0.9 else 'FAIL'}\n"
        + f"- median ms per processed 360-beam scan {ms:.1f} ms, target <= {MS_TARGET} ms: "
        + f"{'PASS' if ms <= MS_TARGET else 'FAIL'}\n"
    )


def _intel(args: argparse.Namespace) -> str:
    rows: list[list[object]] = []
    rpe, factors, medians = [], [], []
    noise = OdometryNoise.of(DEFAULT_ALPHAS)
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.seeds):
            bag = Path(tmp) / f"intel_{seed}.bag"
            carmen_to_bag(args.log, bag, noise, seed)
            result = replay_slam(bag, INTEL_CONFIG)
            summary = result.summary()
            odom_errors = trajectory_errors(result.odometry, result.truth)
            rpe.append(summary["rpe_trans_mean_m"])
            factors.append(summary["realtime_factor"])
            medians.append(summary["ms_per_scan_median"])
            rows.append(
                [
                    seed,
                    summary["scans"],
                    summary["rpe_trans_mean_m"],
                    summary["rpe_rot_mean_deg"],
                    odom_errors.rpe_trans_mean_m,
                    summary["ate_rmse_m"],
                    summary["ms_per_scan_median"],
                    summary["ms_per_scan_p95"],
                    summary["realtime_factor"],
                ]
            )
    header = [
        "seed",
        "scans",
        "RPE trans mean [m]",
        "RPE rot mean [deg]",
        "odometry alone RPE [m]",
        "ATE RMS [m]",
        "ms/scan median",
        "ms/scan p95",
        "x real time",
    ]
    verdict = (
        f"- RPE mean (worst seed) {max(rpe):.4f} m, target <= {RPE_TARGET_M} m: "
        f"{'PASS' if max(rpe) <= RPE_TARGET_M else 'FAIL'}\n"
        f"- real-time factor (slowest seed) {min(factors):.1f}x, target >= {REALTIME_TARGET}x: "
        f"{'PASS' if min(factors) >= REALTIME_TARGET else 'FAIL'}\n"
        f"- median ms per processed 180-beam scan {float(np.median(medians)):.1f} ms\n"
    )
    alphas = ",".join(f"{a:g}" for a in DEFAULT_ALPHAS)
    return (
        f"### Intel Research Lab log ({args.log.name}, odometry noise alphas {alphas}, seeds 0..{args.seeds - 1})\n\n"
        + markdown_table(header, rows)
        + "\n\n"
        + verdict
    )
