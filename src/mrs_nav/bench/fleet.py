"""Fleet over Zenoh: added latency and loss per robot, N robots' bridges behind one Zenoh router.

Starts its own roscore, ``mrs-nav router`` on a free loopback port, one zenoh_bridge per robot namespace
(``tb3_0`` ... as a client of the router, keys ``mrs_nav/tb3_i/...``), a ROS peer
(:mod:`mrs_nav.ros.bridge_bench_peer`) that publishes each robot's /odom 100 Hz, /scan 5 Hz and /map 1 Hz and
subscribes to them directly, and here one client session of the router subscribed to each robot's topics:
what ``mrs-nav monitor --fleet`` opens. Per message (matched by ``header.seq``) the added latency is the Zenoh receive
time minus the direct ROS subscriber's, both wall clock on this machine; a message is lost if it never arrives.
Plain TCP on loopback (the single-robot ``bench bridge`` measures TLS).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from mrs_nav.bench.bridge import TOPICS, Receiver, connect_when_up, cpu_seconds
from mrs_nav.options import duration_option, integer_option
from mrs_nav.resources import CHECKOUT
from mrs_nav.ros_processes import RosProcessError, free_port, process, roscore
from mrs_nav.tables import markdown_table

TARGET_P50_MS = 1.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--robots", type=integer_option(1, 20), default=3, help="robots, one bridge each (default 3)")
    parser.add_argument("--duration", type=duration_option, default=30.0, help="measured seconds (default 30)")


def run(args: argparse.Namespace) -> str:
    with tempfile.TemporaryDirectory(prefix="mrs_nav_bench_fleet_") as tmp:
        return _measure(Path(tmp), [f"tb3_{i}" for i in range(args.robots)], args.duration)


def _measure(tmp: Path, robots: list[str], duration: float) -> str:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    config = tmp / "bridge.yaml"
    config.write_text(json.dumps({"mode": "client", "listen": [], "connect": [endpoint], "discovery_period": 0.2}))
    receiver = Receiver(f"/{robot}{topic}" for robot in robots for topic in TOPICS)
    out = tmp / "peer.json"
    with contextlib.ExitStack() as stack:
        env = stack.enter_context(roscore(tmp))
        router = stack.enter_context(
            process([sys.executable, "-m", "mrs_nav", "router", "--listen", endpoint], env, tmp / "router.log")
        )
        bridge_cmd = [sys.executable, str(CHECKOUT / "scripts" / "zenoh_bridge"), f"_config_file:={config}"]
        bridges = [
            stack.enter_context(process([*bridge_cmd, f"__ns:={robot}"], env, tmp / f"bridge_{robot}.log"))
            for robot in robots
        ]
        session = connect_when_up(endpoint, "", router)
        stack.callback(session.close)
        receiver.subscribe(session)  # per topic, under each robot's prefix (a bridge's ACL admits only its own)
        peer_cmd = [sys.executable, "-m", "mrs_nav.ros.bridge_bench_peer", "--out", str(out),
                    "--namespaces", ",".join(robots), "--duration", str(duration)]  # fmt: skip
        with process(peer_cmd, env, tmp / "peer.log") as peer:
            cpu0 = sum(cpu_seconds(b.pid) for b in (router, *bridges))
            wall0 = time.monotonic()
            while peer.poll() is None:
                if time.monotonic() - wall0 > duration + 120:
                    raise RosProcessError("bench fleet: the ROS peer did not finish in time")
                time.sleep(0.5)
            cpu = (sum(cpu_seconds(b.pid) for b in (router, *bridges)) - cpu0) / (time.monotonic() - wall0) * 100
        if peer.returncode != 0 or not out.exists():
            log = (tmp / "peer.log").read_text(errors="replace")[-2000:]
            raise RosProcessError(f"bench fleet: the ROS peer failed ({peer.returncode}):\n{log}")
    return _report(json.loads(out.read_text()), receiver.times, robots, cpu, duration)


def _report(
    report: dict[str, Any], times: dict[str, dict[int, float]], robots: list[str], cpu: float, duration: float
) -> str:
    rows: list[list[object]] = []
    worst_p50, lost_total = 0.0, 0
    for robot in robots:
        added: list[float] = []
        sent_total = lost = 0
        for topic in TOPICS:
            name = f"/{robot}{topic}"
            sent = report[name]["sent"]
            direct = {int(k): v for k, v in report[name]["direct"].items()}
            got = times[name]
            sent_total += len(sent)
            lost += sum(seq not in got for seq in sent)
            added += [(got[s] - direct[s]) * 1e3 for s in sent if s in got and s in direct]
        p50, p99 = np.percentile(added, [50, 99]) if added else (np.nan, np.nan)
        worst_p50 = max(worst_p50, float(p50)) if added else math.inf
        lost_total += lost
        rows.append([robot, sent_total, lost, p50, p99])
    table = markdown_table(["robot", "sent", "lost", "added p50 ms", "added p99 ms"], rows)
    load, cores = os.getloadavg()[0], os.cpu_count() or 1
    verdict = "meets" if worst_p50 <= TARGET_P50_MS and lost_total == 0 else "MISSES"
    return (
        f"{len(robots)} robots, each /odom 100 Hz + /scan 5 Hz + /map 1 Hz through its own bridge (a client of one "
        f"`mrs-nav router`, plain TCP on loopback) to one client session of the router (what `monitor --fleet` "
        f"opens); {duration:g} s measured after a 1 s warm-up; added latency = Zenoh receive time minus a direct "
        f"rospy subscriber's receive time for the same message.\n\n{table}\n\n"
        f"Bridges + router CPU {cpu:.1f} % of one core in all (load average {load:.1f} on {cores} cores). "
        f"Target per robot p50 <= {TARGET_P50_MS:g} ms, zero loss: **{verdict}** (worst robot p50 {worst_p50:.3f} ms, "
        f"{lost_total} lost).\n"
        + (
            f"\nThe machine was shared (load average {load:.1f} on {cores} cores, other jobs running): latencies and "
            "loss measured under that contention.\n"
            if load > cores
            else ""
        )
    )
