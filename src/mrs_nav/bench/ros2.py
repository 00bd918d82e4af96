"""ROS 2 bridge: latency ROS 1 publisher -> ROS 2 subscriber through ros2_bridge beside an rclpy-to-rclpy floor,
loss, the bridge's CPU per message and RSS, at /odom 50 Hz + /scan 5 Hz + /map 1 Hz.

Starts its own roscore, a ros2_bridge (both its halves) on one ROS 2 domain, a ROS 1 publisher
(:mod:`mrs_nav.ros.bridge_bench_peer`) and a ROS 2 subscriber (:mod:`mrs_nav.ros2.bench_peer`) on the bridge's
domain; at the same time, on a second domain, an rclpy publisher and subscriber with the same messages, rates
and QoS (the floor: what ROS 2 itself costs on this machine under the same load), sent half an /odom period
after the bridged chain's messages (:data:`FLOOR_PHASE_S`) so that neither chain's latency depends on where the
other's instants happened to fall. Latency is the subscriber's
receive time minus the message's stamp, the publisher's wall-clock send time (one machine, one clock). CPU is
the user + system time of both halves of the bridge over the run; RSS their sum, sampled every second.

Then ``--goal-runs`` seeds of the same goal (the course arena, as ``bench navigation``'s ROS runs: same seed,
same start, rrt_navigation.launch at max rate in lockstep, a ros2_bridge running beside it both times, RRT* capped
at a fixed number of iterations as in the soak), once sent
over ROS 1 and once as a NavigateToPose goal from an rclpy client through the bridge; both timed in sim time on
ROS 1 from the goal's arrival to the navigation's outcome, ``--goal-repeats`` times each, the medians compared.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from mrs_nav.bench.bridge import cpu_seconds, rss_mb
from mrs_nav.bench.navigation import SCENARIOS
from mrs_nav.bench.soak import PLAN_ITERATIONS
from mrs_nav.bench.soak_ros import planner_overrides
from mrs_nav.bridge.ros2_link import Ros2BridgeConfig, child_environment, package_root, ros2_python
from mrs_nav.errors import MrsNavError
from mrs_nav.options import duration_option, optional_runs_option, runs_option
from mrs_nav.resources import CHECKOUT, WORLDS_DIR
from mrs_nav.ros_processes import RosProcessError, free_port, process, roscore, roslaunch_command, run_peer, stop
from mrs_nav.tables import markdown_table

RATES = {"/odom": 50.0, "/scan": 5.0, "/map": 1.0}
RELIABLE = ("/odom", "/map")
TARGET_RATIO = 1.5  # bridged p50 within this many times the floor's
# The floor's publisher starts this long after a whole second, the bridged chain's on it (bench.pacing): half an
# /odom period keeps each chain's messages (1-3 ms from send to receipt) from meeting the other's on the cores.
FLOOR_PHASE_S = 0.5 / RATES["/odom"]
MIN_CHAIN_GAP_S = 0.004  # closer than this, the two chains disturb each other and the ratio is not reported
GOAL_TOLERANCE = 0.05  # a ROS 2 goal's sim time within this fraction of the same goal's over ROS 1
GOAL_SCENARIO = "arena"
# Runs of one seed on each side, medians compared: the plans are fixed by the seed (a fixed number of iterations, not
# a wall-clock budget), but when a plan lands, and what the scans show then, still follow the machine's load.
GOAL_REPEATS = 3


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--duration", type=duration_option, default=60.0, help="measured seconds (default 60)")
    parser.add_argument(
        "--goal-runs",
        type=optional_runs_option,
        default=3,
        help="seeds of the same goal over ROS 1 and over ROS 2 (NavigateToPose), 0 = none (default 3)",
    )
    parser.add_argument(
        "--goal-repeats",
        type=runs_option,
        default=GOAL_REPEATS,
        help=f"runs of each seed on each side; the medians are compared (default {GOAL_REPEATS})",
    )


def descendants(pid: int) -> list[int]:
    """``pid`` and every process under it (the bridge's ROS 2 half is its child)."""
    parents: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError, ValueError, IndexError):
            parent = int(stat.read_text().rsplit(")", 1)[1].split()[1])
            parents.setdefault(parent, []).append(int(stat.parent.name))
    found, todo = [], [pid]
    while todo:
        current = todo.pop()
        found.append(current)
        todo.extend(parents.get(current, []))
    return found


def _ros2_process(python: Path, domain: int, args: list[str], log: Path, **kwargs: Any) -> subprocess.Popen[bytes]:
    env = child_environment(Ros2BridgeConfig.from_mapping({"domain_id": domain}), os.environ, package_root())
    return subprocess.Popen(
        [str(python), "-m", "mrs_nav.ros2.bench_peer", *args], env=env, stdout=log.open("wb"), stderr=subprocess.STDOUT,
        start_new_session=True, **kwargs,
    )  # fmt: skip


def run(args: argparse.Namespace) -> str:
    python = ros2_python("", os.environ, sys.prefix)
    if not python.exists():
        raise MrsNavError(f"bench ros2: no ROS 2 venv at {python.parent.parent} (MRS_NAV_ROS2=1 make install)")
    with tempfile.TemporaryDirectory(prefix="mrs_nav_bench_ros2_") as name:
        latency = _measure(Path(name), python, args.duration)
    goals = goal_section(python, args.goal_runs, args.goal_repeats) if args.goal_runs else ""
    return latency + (f"\n{goals}" if goals else "")


def goal_run(python: Path, seed: int, over_ros2: bool) -> dict[str, Any]:
    """``bench navigation``'s ROS run with a ros2_bridge (allowing NavigateToPose) beside the stack; the goal sent
    over ROS 1 or, ``over_ros2``, by an rclpy NavigateToPose client through the bridge. The ROS 1 peer's JSON
    (timed from the goal's publication, or its arrival at move_base), with the client's under ``ros2``."""
    scenario = SCENARIOS[GOAL_SCENARIO]
    goal = [str(v) for v in scenario.goal]
    with tempfile.TemporaryDirectory(prefix="mrs_nav_bench_ros2_goal_") as name:
        tmp = Path(name)
        domain = 101 + free_port() % 100
        launch = roslaunch_command(
            "rrt_navigation.launch", WORLDS_DIR / scenario.world, scenario.start,
            str(planner_overrides(tmp / "plan.launch", PLAN_ITERATIONS)),
            "real_time_factor:=0", "lockstep:=true", "rviz:=false", f"seed:={seed}",
        )  # fmt: skip
        bridge_cmd = [sys.executable, str(CHECKOUT / "scripts" / "ros2_bridge"), f"_domain_id:={domain}",
                      "_allow_inbound:=[/navigate_to_pose]"]  # fmt: skip
        peer_args = ["--goal", *goal, *(["--from-action", "--ready", str(tmp / "go")] if over_ros2 else [])]
        with (
            roscore(tmp) as env,
            process(launch, env, tmp / "launch.log") as proc,
            process(bridge_cmd, env, tmp / "ros2_bridge.log"),
        ):
            client = None
            if over_ros2:
                client = _ros2_process(
                    python, domain, ["navigate", "--goal", *goal, "--after", str(tmp / "go"), "--out",
                                     str(tmp / "ros2.json")], tmp / "client.log",
                )  # fmt: skip
            try:
                result: dict[str, Any] = run_peer(proc, env, tmp, peer_args)
                if client is not None:
                    client.wait(timeout=60)
            finally:
                if client is not None:
                    stop(client)
        if over_ros2:
            if not (tmp / "ros2.json").is_file():
                raise RosProcessError(f"bench ros2: NavigateToPose client failed:\n{(tmp / 'client.log').read_text()}")
            result["ros2"] = json.loads((tmp / "ros2.json").read_text())
    return result


def _attempt(python: Path, seed: int, over_ros2: bool) -> dict[str, Any] | None:
    """:func:`goal_run`, or None (said on stderr) if the run failed: one stuck run does not lose the others."""
    try:
        return goal_run(python, seed, over_ros2)
    except RosProcessError as err:
        print(f"bench ros2: seed {seed} over ROS {2 if over_ros2 else 1} failed: {err}", file=sys.stderr)
        return None


def goal_section(python: Path, runs: int, repeats: int) -> str:
    """Markdown: the same goal over ROS 1 and as a ROS 2 NavigateToPose goal, ``runs`` seeds ``repeats`` times
    each side (alternating), in sim time; the medians of the runs that reached the goal compared per seed."""
    rows, ratios, spreads, missed = [], [], [], 0
    for seed in range(runs):
        sides: dict[bool, list[dict[str, Any]]] = {False: [], True: []}
        for _ in range(repeats):
            for over_ros2 in (False, True):
                if (result := _attempt(python, seed, over_ros2)) is not None:
                    sides[over_ros2].append(result)
        ros1 = [r["sim_s"] for r in sides[False] if r["reached"]]
        ros2 = [r["sim_s"] for r in sides[True] if r["reached"]]
        ratio = float(np.median(ros2) / np.median(ros1)) if ros1 and ros2 else math.nan
        ratios.append(ratio)
        missed += 2 * repeats - len(ros1) - len(ros2)
        spreads.append(max(ros1) / min(ros1) - 1.0 if ros1 else math.nan)
        statuses = sorted({r["ros2"]["status"] for r in sides[True]})
        feedbacks = np.median([r["ros2"]["feedbacks"] for r in sides[True]]) if sides[True] else math.nan
        rows.append([seed, f"{len(ros1)}/{repeats}", " ".join(f"{v:.2f}" for v in ros1),
                     f"{np.median(ros1) if ros1 else math.nan:.2f}", f"{spreads[-1]:.1%}", f"{len(ros2)}/{repeats}",
                     " ".join(map(str, statuses)), f"{feedbacks:.0f}", " ".join(f"{v:.2f}" for v in ros2),
                     f"{np.median(ros2) if ros2 else math.nan:.2f}", f"{ratio:.3f}"])  # fmt: skip
    table = markdown_table(
        ["seed", "ROS 1 reached", "ROS 1 sim s (each run)", "median", "ROS 1 max/min - 1", "ROS 2 reached",
         "action status", "feedbacks (median)", "ROS 2 sim s (each run)", "median", "ROS 2 / ROS 1 medians"],
        rows,
    )  # fmt: skip
    median = float(np.median(ratios))
    ok = missed == 0 and all(abs(r - 1.0) <= GOAL_TOLERANCE for r in ratios)
    scenario = SCENARIOS[GOAL_SCENARIO]
    return (
        f"The same goal ({GOAL_SCENARIO}: {scenario.start} to {scenario.goal}, rrt_navigation.launch at max rate in "
        "lockstep, the seed of simulator and planner as given, a ros2_bridge running beside the stack both times), "
        "over ROS 1 (/move_base_simple/goal, as `bench navigation`) and as a NavigateToPose goal from an rclpy "
        f"client through the bridge, {repeats} times each, alternating (`--goal-repeats`). Sim s: from the goal "
        "reaching the navigation (its publication on ROS 1; its arrival on move_base/goal from ROS 2) to `reached`; "
        f"action status 4 = SUCCEEDED. RRT* plans {PLAN_ITERATIONS} iterations (`max_iterations`, as in `bench "
        "soak`), not for a wall-clock budget, so a seed's plans do not change with the machine's load; when each plan "
        "lands in sim time still does: ROS 1 against ROS 1 on one seed differed by up to "
        f"{np.nanmax(spreads):.1%} here (max/min - 1); hence the medians.\n\n{table}\n\n"
        f"ROS 2 / ROS 1 median sim time, median over the seeds {median:.3f}; runs that did not reach the goal "
        f"(failed, or stuck; not in the medians): {missed}. Target every run reaching the goal and every seed's "
        f"medians within +-{GOAL_TOLERANCE:.0%}: **{'meets' if ok else 'MISSES'}**.\n"
    )


def _measure(tmp: Path, python: Path, duration: float) -> str:
    bridged, floor = 1 + free_port() % 100, 101 + free_port() % 100
    samples: list[tuple[float, float, float]] = []  # (cpu s, rss MB of both halves, cpu s of the ROS 1 half)
    with contextlib.ExitStack() as stack:
        env = stack.enter_context(roscore(tmp))
        bridge_cmd = [sys.executable, str(CHECKOUT / "scripts" / "ros2_bridge"), f"_domain_id:={bridged}"]
        bridge = stack.enter_context(process(bridge_cmd, env, tmp / "ros2_bridge.log"))
        subs = []
        for domain, tag in ((bridged, "bridged"), (floor, "floor")):
            wait = ["--wait-publishers"] if domain == bridged else []
            sub = _ros2_process(python, domain, ["sub", "--out", str(tmp / f"{tag}.json"), *wait],
                                tmp / f"{tag}.log", stdin=subprocess.PIPE)  # fmt: skip
            stack.callback(stop, sub)
            subs.append((sub, tag))
        _wait_files([tmp / f"{tag}.ready" for _, tag in subs], [bridge, *(s for s, _ in subs)])
        floor_pub = _ros2_process(
            python, floor, ["pub", "--out", str(tmp / "floor_sent.json"), "--duration", str(duration), "--phase",
                            str(FLOOR_PHASE_S)], tmp / "floor_pub.log",
        )  # fmt: skip
        stack.callback(stop, floor_pub)
        peer_cmd = [sys.executable, "-m", "mrs_nav.ros.bridge_bench_peer", "--out", str(tmp / "peer.json"),
                    "--duration", str(duration), "--odom-rate", str(RATES["/odom"]), "--no-direct",
                    "--connections", "1", "--phase", "0"]  # fmt: skip
        with process(peer_cmd, env, tmp / "peer.log") as peer:
            wall0 = time.monotonic()
            while peer.poll() is None or floor_pub.poll() is None:
                if time.monotonic() - wall0 > duration + 120:
                    raise RosProcessError("bench ros2: the publishers did not finish in time")
                pids = descendants(bridge.pid)
                samples.append((sum(map(cpu_seconds, pids)), sum(map(rss_mb, pids)), cpu_seconds(bridge.pid)))
                time.sleep(1.0)
        time.sleep(1.0)  # the last messages
        for sub, _ in subs:
            assert sub.stdin is not None
            sub.stdin.close()
            sub.wait(timeout=30)
        if peer.returncode != 0:
            raise RosProcessError(f"bench ros2: the ROS 1 publisher failed:\n{(tmp / 'peer.log').read_text()[-2000:]}")
    peer_sent = {t: v["stamps"] for t, v in json.loads((tmp / "peer.json").read_text()).items()}
    floor_sent = json.loads((tmp / "floor_sent.json").read_text())
    received = {tag: json.loads((tmp / f"{tag}.json").read_text()) for tag in ("bridged", "floor")}
    return _report(peer_sent, floor_sent, received, samples, duration)


def _wait_files(paths: list[Path], procs: list[subprocess.Popen[bytes]]) -> None:
    deadline = time.monotonic() + 60.0
    while not all(p.exists() for p in paths):
        if time.monotonic() > deadline or any(p.poll() is not None for p in procs):
            raise RosProcessError(f"bench ros2: processes did not start (waiting for {paths})")
        time.sleep(0.1)


def _latencies(sent: list[int], received: list[list[float]]) -> tuple[list[float], int]:
    """Latencies (ms) of the sent messages that arrived, and how many did not."""
    arrival = {int(stamp): at for stamp, at in received}
    got = [(arrival[s] - s * 1e-9) * 1e3 for s in sent if s in arrival]
    return got, len(sent) - len(got)


def chain_gap_s(bridged_odom: list[int], floor_odom: list[int]) -> float:
    """How far apart (s) the two chains' /odom send times fall on the /odom period: the circular mean of each
    chain's stamps (ns, wall clock) modulo the period, so one late message does not move it."""
    if not bridged_odom or not floor_odom:
        return math.nan
    period = round(1e9 / RATES["/odom"])

    def phase(stamps: list[int]) -> float:
        turns = (np.asarray(stamps, dtype=np.int64) % period) / period * 2 * math.pi
        return float(np.angle(np.mean(np.exp(1j * turns))))

    apart = abs(phase(floor_odom) - phase(bridged_odom)) % (2 * math.pi)
    return min(apart, 2 * math.pi - apart) / (2 * math.pi) * period * 1e-9


def _report(
    peer_sent: dict[str, list[int]],
    floor_sent: dict[str, list[int]],
    received: dict[str, dict[str, list[list[float]]]],
    samples: list[tuple[float, float, float]],
    duration: float,
) -> str:
    rows: list[list[object]] = []
    ratios = []
    lost_reliable = 0
    for topic, rate in RATES.items():
        bridged, lost = _latencies(peer_sent[topic], received["bridged"][topic])
        floor, floor_lost = _latencies(floor_sent[topic], received["floor"][topic])
        lost_reliable += lost if topic in RELIABLE else 0
        b50, b99 = np.percentile(bridged, [50, 99]) if bridged else (np.nan, np.nan)
        f50, f99 = np.percentile(floor, [50, 99]) if floor else (np.nan, np.nan)
        ratios.append(b50 / f50)
        rows.append([topic, f"{rate:g}", len(peer_sent[topic]), lost, b50, b99, len(floor_sent[topic]), floor_lost,
                     f50, f99, f"{b50 / f50:.2f}"])  # fmt: skip
    table = markdown_table(
        ["topic", "Hz", "bridged sent", "lost", "p50 ms", "p99 ms", "floor sent", "lost", "floor p50 ms",
         "floor p99 ms", "p50 / floor"],
        rows,
    )  # fmt: skip
    cpu, rss, cpu_ros1 = np.array(samples).T if samples else (np.zeros(2), np.zeros(2), np.zeros(2))
    messages = sum(len(v) for v in peer_sent.values())
    cpu_per_msg = (cpu[-1] - cpu[0]) / messages * 1e6 if messages else float("nan")
    ros1_per_msg = (cpu_ros1[-1] - cpu_ros1[0]) / messages * 1e6 if messages else float("nan")
    span = len(samples) - 1
    settled = rss[len(rss) // 5 :]
    slope = float(np.polyfit(np.arange(len(settled)), settled, 1)[0]) * 60 if len(settled) > 2 else float("nan")
    load, cores = os.getloadavg()[0], os.cpu_count() or 1
    gap = chain_gap_s(peer_sent["/odom"], floor_sent["/odom"])
    if not gap >= MIN_CHAIN_GAP_S:
        verdict = f"NOT VALID (the two chains sent within {MIN_CHAIN_GAP_S * 1e3:g} ms of each other)"
    else:
        verdict = "meets" if max(ratios) <= TARGET_RATIO and lost_reliable == 0 else "MISSES"
    return (
        f"{duration:g} s measured after a 1 s warm-up (`--duration`; the issue asks for 10 minutes, this run is "
        f"{'that' if duration >= 600 else 'shorter'}). "
        "Latency = a ROS 2 subscriber's receive time minus the publisher's wall-clock send time (the stamp), one "
        "machine. Bridged: a rospy publisher (nothing else in its process) -> ros2_bridge (its ROS 2 half subscribes "
        "on ROS 1 itself) -> an rclpy subscriber; "
        "floor: an rclpy publisher -> an rclpy subscriber with the same messages, rates and QoS, on another domain "
        f"at the same time, its messages sent {gap * 1e3:.1f} ms (circular mean over the run) from the bridged "
        "chain's (half an /odom period: each publisher starts on a whole second of the machine's monotonic clock plus "
        "its phase, so the two chains do not share the cores at the same instants; before, their relative phase, and "
        "with it the ratio, changed from run to run). "
        f"Both on ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST with Fast DDS.\n\n{table}\n\n"
        f"Loss on the reliable topics (/odom, /map): {lost_reliable}. Bridge (both halves) CPU "
        f"{cpu_per_msg:.0f} us per message (ROS 1 half {ros1_per_msg:.0f}, ROS 2 half "
        f"{cpu_per_msg - ros1_per_msg:.0f}; {(cpu[-1] - cpu[0]) / max(span, 1) * 100:.1f} % of one core over "
        f"{span} s); RSS {rss[0]:.1f} MB at the start, {rss[-1]:.1f} MB at the end, {rss.max():.1f} MB at most, "
        f"drift {slope:+.3f} MB/min over the last 80 % of the run (load average {load:.1f} on {cores} cores).\n"
        f"Target p50 within {TARGET_RATIO:g}x the floor on every topic, zero loss on reliable topics: **{verdict}**.\n"
    )
