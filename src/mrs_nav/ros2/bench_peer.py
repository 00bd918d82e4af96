"""The ROS 2 side of ``mrs-nav bench ros2``: a subscriber that records receive times, and the floor's publisher.

``python -m mrs_nav.ros2.bench_peer sub --out FILE --ready FILE`` subscribes to /odom (reliable), /scan (sensor
data) and /map (transient local), as ros2_bridge publishes them, and at the end of its stdin writes JSON: per
topic ``[[stamp_ns, receive_time_s], ...]`` (stamps are the publishers' wall-clock send times, unique per
message). ``python -m mrs_nav.ros2.bench_peer pub --duration S --warmup S`` publishes the same messages at the
same rates from rclpy (the floor) and writes the measured stamps, per topic, to ``--out``.
``python -m mrs_nav.ros2.bench_peer navigate --goal X Y --after FILE --out FILE`` waits for the file ``--after``,
then sends one NavigateToPose goal (frame map) and writes JSON: the end ``status`` (action_msgs/GoalStatus),
``error_code``, ``feedbacks`` received and ``wall_s`` from sending to the result.
"""

from __future__ import annotations

import argparse
import array
import json
import sys
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from nav2_msgs.action import NavigateToPose
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.action import ActionClient
from rclpy.node import Node
from sensor_msgs.msg import LaserScan

from mrs_nav.bench.pacing import phase_option, start_on_grid
from mrs_nav.bridge.ros2_link import OUTBOUND
from mrs_nav.ros2.bridge_half import QOS
from mrs_nav.ros2.runtime import spinning_node

#: topic -> rate (Hz) of the bench's load
RATES = {"/odom": 50.0, "/scan": 5.0, "/map": 1.0}
_TYPES = {"/odom": Odometry, "/scan": LaserScan, "/map": OccupancyGrid}
_QOS = {r.ros2: QOS[r.qos] for r in OUTBOUND if r.ros2 in RATES}


def messages() -> dict[str, Any]:
    """The messages of mrs_nav.ros.bridge_bench_peer's sizes: a 360-beam scan, a 384 x 384 map."""
    scan = LaserScan(ranges=array.array("f", [1.0] * 360), intensities=array.array("f", [0.0] * 360))
    scan.header.frame_id = "base_scan"
    grid = OccupancyGrid(data=array.array("b", [-1] * (384 * 384)))
    grid.header.frame_id = "map"
    grid.info.width = grid.info.height = 384
    odom = Odometry()
    odom.header.frame_id, odom.child_frame_id = "odom", "base_footprint"
    return {"/odom": odom, "/scan": scan, "/map": grid}


def subscribe(node: Node, out: Path, ready: Path, wait_publishers: bool) -> None:
    received: dict[str, list[tuple[int, float]]] = {t: [] for t in RATES}

    def on_msg(msg: Any, topic: str) -> None:
        now = time.time()
        received[topic].append((msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec, now))

    for topic in RATES:
        node.create_subscription(_TYPES[topic], topic, lambda m, t=topic: on_msg(m, t), _QOS[topic])
    if wait_publishers:  # ready once the (bridge's) publishers are discovered: measured messages do not wait for it
        deadline = time.monotonic() + 60.0
        while any(node.count_publishers(t) < 1 for t in RATES) and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(1.0)  # discovery seen here is the first half of matching; the publisher's side follows
    ready.write_text("ready")
    sys.stdin.read()  # until the bench closes it
    out.write_text(json.dumps(received))


def publish(node: Node, out: Path, duration: float, warmup: float, subscribers: int, *, phase: float) -> None:
    publishers = {t: node.create_publisher(_TYPES[t], t, _QOS[t]) for t in RATES}
    deadline = time.monotonic() + 60.0
    while any(p.get_subscription_count() < subscribers for p in publishers.values()):
        if time.monotonic() > deadline:
            raise SystemExit("bench_peer: the floor's subscriber did not match within 60 s")
        time.sleep(0.05)
    msgs = messages()
    sent: dict[str, list[int]] = {t: [] for t in RATES}
    start = start_on_grid(phase)

    def run(topic: str) -> None:
        msg, rate, k = msgs[topic], RATES[topic], 0
        while (at := start + k / rate) - start <= warmup + duration:
            time.sleep(max(0.0, at - time.monotonic()))
            now = time.time_ns()
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now, 1_000_000_000)
            publishers[topic].publish(msg)
            if at - start >= warmup:
                sent[topic].append(now)
            k += 1

    with ThreadPoolExecutor(len(RATES)) as pool:  # a thread per topic, each at its own rate
        list(pool.map(run, RATES))
    out.write_text(json.dumps(sent))


def _result(future: Any, deadline: float) -> Any:
    """The future's result; the node spins in its own thread."""
    while not future.done():
        if time.monotonic() > deadline:
            raise SystemExit("bench_peer: NavigateToPose did not end in time")
        time.sleep(0.01)
    return future.result()


def _request(node: Node, deadline: float, send: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """The response to an action client's request ``send(*args, **kwargs)``, sent from the executor's thread:
    rclpy (Jazzy) files a request's future only after sending it, and a response that the spinning thread takes
    in between is dropped ("Ignoring unexpected goal response"), its future never done."""
    if node.executor is None:
        raise SystemExit("bench_peer: the node spins in no executor")
    return _result(_result(node.executor.create_task(send, *args, **kwargs), deadline), deadline)


def navigate(node: Node, out: Path, goal_xy: tuple[float, float], after: Path, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    client = ActionClient(node, NavigateToPose, "navigate_to_pose")
    while not after.exists() or not client.server_is_ready():
        if time.monotonic() > deadline:
            raise SystemExit("bench_peer: no navigate_to_pose server (or no go-ahead) in time")
        time.sleep(0.05)
    goal = NavigateToPose.Goal()
    goal.pose.header.frame_id = "map"
    goal.pose.pose.position.x, goal.pose.pose.position.y = goal_xy
    goal.pose.pose.orientation.w = 1.0
    feedbacks = [0]
    wall0 = time.monotonic()

    def on_feedback(_msg: Any) -> None:
        feedbacks[0] += 1

    handle = _request(node, deadline, client.send_goal_async, goal, feedback_callback=on_feedback)
    response = _request(node, deadline, handle.get_result_async)
    out.write_text(
        json.dumps(
            {"status": response.status, "error_code": response.result.error_code, "feedbacks": feedbacks[0],
             "wall_s": time.monotonic() - wall0}
        )
    )  # fmt: skip


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("mode", choices=["sub", "pub", "navigate"])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--ready", type=Path, default=None)
    parser.add_argument("--duration", type=float, default=60.0)
    parser.add_argument("--warmup", type=float, default=1.0)
    parser.add_argument("--subscribers", type=int, default=1)
    parser.add_argument("--phase", type=phase_option, default=0.0, help="pub: s past a whole second to start at")
    parser.add_argument("--wait-publishers", action="store_true", help="sub: ready once every topic has one")
    parser.add_argument("--goal", type=float, nargs=2, default=(0.0, 0.0), help="navigate: x y in map (m)")
    parser.add_argument("--after", type=Path, help="navigate: send the goal once this file exists")
    parser.add_argument("--timeout", type=float, default=600.0, help="navigate: wall s for everything")
    args = parser.parse_args(argv[1:])
    with spinning_node(f"bench_{args.mode}") as node:
        if args.mode == "sub":
            subscribe(node, args.out, args.ready or args.out.with_suffix(".ready"), args.wait_publishers)
        elif args.mode == "pub":
            publish(node, args.out, args.duration, args.warmup, args.subscribers, phase=args.phase)
        else:
            navigate(node, args.out, tuple(args.goal), args.after, args.timeout)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
