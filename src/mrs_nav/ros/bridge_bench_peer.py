"""The ROS side of ``mrs-nav bench bridge`` and ``bench fleet``: publishes /odom, /scan and /map (once per robot
namespace with ``--namespaces tb3_0,tb3_1``) and subscribes to them directly.

Run as ``python -m mrs_nav.ros.bridge_bench_peer --out FILE [--duration S]`` against a running master. It
waits until the bridge and its own subscribers are connected, publishes a one-second warm-up, then the
measured load, and writes JSON: per topic the first measured ``header.seq``, the sequence numbers sent, their
stamps (ns, the wall-clock send times) and
the wall-clock receive time (s) of each one at the direct subscriber.
"""

from __future__ import annotations

import argparse
import json
import threading
import time
from typing import Any

import numpy as np
import rospy
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan

from mrs_nav.atomic_write import write_text
from mrs_nav.bench.pacing import phase_option, start_on_grid
from mrs_nav.ros.map_messages import OccupancyGridArrayMsg

WARMUP = 1.0  # s published before measuring, so every connection is established


def make_messages(namespace: str = "") -> dict[str, tuple[Any, Any, float]]:
    """topic -> (type, message, rate Hz) with the sizes the real stack produces, under ``/namespace``."""
    scan = LaserScan()
    scan.header.frame_id = "base_scan"
    scan.angle_min, scan.angle_max, scan.angle_increment = 0.0, 6.2657, 0.01745
    scan.range_min, scan.range_max = 0.12, 3.5
    scan.ranges = [1.0] * 360
    scan.intensities = [0.0] * 360
    grid = OccupancyGridArrayMsg()  # published as SLAM and the map server publish theirs (map_messages)
    grid.header.frame_id = "map"
    grid.info.width = grid.info.height = 384
    grid.info.resolution = 0.05
    grid.info.origin.orientation.w = 1.0
    grid.data = np.full(384 * 384, -1, dtype=np.int8)
    odom = Odometry()
    odom.header.frame_id, odom.child_frame_id = "odom", "base_footprint"
    odom.pose.pose.orientation.w = 1.0
    ns = f"/{namespace}" if namespace else ""
    return {
        f"{ns}/odom": (Odometry, odom, 100.0),
        f"{ns}/scan": (LaserScan, scan, 5.0),
        f"{ns}/map": (OccupancyGridArrayMsg, grid, 1.0),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", required=True)
    parser.add_argument("--duration", type=float, default=60.0)
    parser.add_argument("--connections", type=int, default=2, help="subscribers to wait for per topic")
    parser.add_argument("--namespaces", default="", help="comma-separated robot namespaces (default: none)")
    parser.add_argument("--odom-rate", type=float, default=None, help="Hz of /odom (default: make_messages')")
    parser.add_argument(
        "--no-direct",
        action="store_true",
        help="publish only (no subscriber in this process, as a floor's publisher has none; 'direct' stays empty)",
    )
    parser.add_argument("--phase", type=phase_option, default=0.0, help="s past a whole second to start at")
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("bridge_bench_peer", disable_signals=True)
    messages = {t: m for ns in args.namespaces.split(",") for t, m in make_messages(ns.strip()).items()}
    if args.odom_rate:
        messages = {t: (typ, m, args.odom_rate if t.endswith("/odom") else r) for t, (typ, m, r) in messages.items()}
    received: dict[str, dict[int, float]] = {t: {} for t in messages}

    def on_msg(msg: Any, topic: str) -> None:
        received[topic][msg.header.seq] = time.time()

    subs = [
        rospy.Subscriber(t, typ, on_msg, callback_args=t, queue_size=1000, tcp_nodelay=True)
        for t, (typ, _, _) in messages.items()
        if not args.no_direct
    ]
    pubs = {
        t: rospy.Publisher(t, typ, queue_size=1000, latch=t.endswith("/map")) for t, (typ, _, _) in messages.items()
    }
    deadline = time.monotonic() + 60.0
    while any(p.get_num_connections() < args.connections for p in pubs.values()):
        if time.monotonic() > deadline:
            raise SystemExit("bridge_bench_peer: subscribers did not connect within 60 s")
        time.sleep(0.05)
    sent: dict[str, list[int]] = {t: [] for t in messages}
    stamps: dict[str, list[int]] = {t: [] for t in messages}  # ns, of the measured messages
    first: dict[str, int] = {}
    start = start_on_grid(args.phase)

    def publish(topic: str) -> None:
        _, msg, rate = messages[topic]
        k = 0
        while True:
            t = start + k / rate
            if t - start > WARMUP + args.duration:
                return
            time.sleep(max(0.0, t - time.monotonic()))
            msg.header.stamp = rospy.Time(nsecs=time.time_ns())
            pubs[topic].publish(msg)  # rospy numbers header.seq
            if t - start >= WARMUP:
                first.setdefault(topic, msg.header.seq)
                sent[topic].append(msg.header.seq)
                stamps[topic].append(msg.header.stamp.to_nsec())
            k += 1

    threads = [threading.Thread(target=publish, args=(t,)) for t in messages]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    time.sleep(1.0)  # let the last messages arrive
    for s in subs:
        s.unregister()
    out = {
        t: {
            "first": first.get(t, 0),
            "sent": sent[t],
            "stamps": stamps[t],
            "direct": {str(k): v for k, v in received[t].items()},
        }
        for t in messages
    }
    write_text(args.out, json.dumps(out), "bench peer results")
    rospy.signal_shutdown("done")


if __name__ == "__main__":
    main()
