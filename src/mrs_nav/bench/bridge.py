"""Zenoh bridge: latency added over a direct ROS subscriber, loss and CPU at /odom 100 Hz + /scan 5 Hz + /map 1 Hz.

Starts its own roscore and zenoh_bridge on free loopback ports (multicast scouting off), a ROS peer
(:mod:`mrs_nav.ros.bridge_bench_peer`) that publishes the load and subscribes to it directly, and a Zenoh
subscriber here. For every message (matched by ``header.seq``, the first 4 bytes of the payload) the added
latency is the Zenoh receive time minus the direct ROS subscriber's receive time, both wall clock on this
machine. The bridge's CPU use is its process's user + system time over the run, in % of one core.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from mrs_nav.bridge.session import open_client_session
from mrs_nav.errors import MrsNavError
from mrs_nav.resources import CHECKOUT
from mrs_nav.ros_processes import RosProcessError, free_port, process, roscore
from mrs_nav.tables import markdown_table

TOPICS = {"/odom": 100.0, "/scan": 5.0, "/map": 1.0}
TARGET_P50_MS, TARGET_P99_MS = 1.0, 5.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--duration", type=float, default=60.0, help="measured seconds (default 60)")


def _cpu_seconds(pid: int) -> float:
    """User + system CPU time (s) of process ``pid`` from /proc."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class _Receiver:
    """Zenoh receive times (wall clock, s) per topic and header.seq."""

    def __init__(self) -> None:
        self.times: dict[str, dict[int, float]] = {t: {} for t in TOPICS}
        self.lock = threading.Lock()

    def __call__(self, sample: Any) -> None:
        now = time.time()
        topic = "/" + str(sample.key_expr).split("/", 1)[1]
        seq = int.from_bytes(sample.payload.to_bytes()[:4], "little")
        with self.lock:
            if topic in self.times:
                self.times[topic][seq] = now


def run(args: argparse.Namespace) -> str:
    if args.duration <= 0:
        raise MrsNavError(f"--duration {args.duration}: expected seconds > 0")
    with tempfile.TemporaryDirectory(prefix="mrs_nav_bench_bridge_") as tmp:
        return _measure(Path(tmp), args.duration)


def _measure(tmp: Path, duration: float) -> str:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    config = tmp / "bridge.yaml"
    config.write_text(json.dumps({"listen": [endpoint], "discovery_period": 0.2}))
    receiver = _Receiver()
    with roscore(tmp) as env:
        bridge_cmd = [sys.executable, str(CHECKOUT / "scripts" / "zenoh_bridge"), f"_config_file:={config}"]
        with process(bridge_cmd, env, tmp / "zenoh_bridge.log") as bridge:
            session = open_client_session([endpoint])
            try:
                session.declare_subscriber("mrs_nav/**", receiver)
                out = tmp / "peer.json"
                peer_cmd = [sys.executable, "-m", "mrs_nav.ros.bridge_bench_peer", "--out", str(out)]
                with process([*peer_cmd, "--duration", str(duration)], env, tmp / "peer.log") as peer:
                    cpu0, wall0 = _cpu_seconds(bridge.pid), time.monotonic()
                    try:
                        peer.wait(timeout=duration + 120)
                    except subprocess.TimeoutExpired:
                        raise RosProcessError("bench bridge: the ROS peer did not finish in time") from None
                    cpu = (_cpu_seconds(bridge.pid) - cpu0) / (time.monotonic() - wall0) * 100
            finally:
                session.close()  # type: ignore[no-untyped-call]
            if peer.returncode != 0 or not out.exists():
                log = (tmp / "peer.log").read_text(errors="replace")[-2000:]
                raise RosProcessError(f"bench bridge: the ROS peer failed ({peer.returncode}):\n{log}")
    return _report(json.loads(out.read_text()), receiver.times, cpu, duration)


def _report(report: dict[str, Any], zenoh_times: dict[str, dict[int, float]], cpu: float, duration: float) -> str:
    rows: list[list[object]] = []
    all_added: list[float] = []
    lost_total = 0
    for topic, rate in TOPICS.items():
        sent = report[topic]["sent"]
        direct = {int(k): v for k, v in report[topic]["direct"].items()}
        via_zenoh = zenoh_times[topic]
        lost = sum(seq not in via_zenoh for seq in sent)
        lost_total += lost
        added = np.array([(via_zenoh[s] - direct[s]) * 1e3 for s in sent if s in via_zenoh and s in direct])
        all_added.extend(added.tolist())
        p50, p99, worst = np.percentile(added, [50, 99, 100]) if added.size else (np.nan,) * 3
        rows.append(
            [topic, f"{rate:g}", len(sent), sum(s in direct for s in sent), len(sent) - lost, lost, p50, p99, worst]
        )
    overall = np.array(all_added)
    p50, p99 = np.percentile(overall, [50, 99]) if overall.size else (np.nan, np.nan)
    table = markdown_table(
        ["topic", "Hz", "sent", "direct ROS got", "Zenoh got", "lost", "added p50 ms", "added p99 ms", "added max ms"],
        rows,
    )
    verdict = "meets" if p50 <= TARGET_P50_MS and p99 <= TARGET_P99_MS and lost_total == 0 else "MISSES"
    return (
        f"{duration:g} s measured after a 1 s warm-up; added latency = Zenoh receive time minus a direct rospy "
        f"subscriber's receive time for the same message (loopback, one machine, peer mode).\n\n{table}\n\n"
        f"All topics: added latency p50 {p50:.3f} ms, p99 {p99:.3f} ms; {lost_total} lost; bridge CPU "
        f"{cpu:.1f} % of one core (load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores).\n"
        f"Target p50 <= {TARGET_P50_MS:g} ms, p99 <= {TARGET_P99_MS:g} ms, zero loss: "
        f"**{verdict}**.\n"
    )
