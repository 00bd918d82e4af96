"""The ROS side of the ROS part of ``mrs-nav bench navigation``: one goal through the running ROS stack.

Run as ``python -m mrs_nav.ros.navigation_bench_peer --goal X Y --out FILE`` against a master on which
``rrt_navigation.launch`` runs. It waits for the first map and the navigation node, lets 3 s of sim time pass
(so the node has the map too), sends the goal on ``/move_base_simple/goal`` and waits for ``reached`` or
``failed`` on ``/rrt_navigation/status``. Writes JSON: ``reached``, ``sim_s`` and ``wall_s`` from the goal to
the outcome, ``final_error_m`` (true pose from ``/ground_truth/odom`` to the goal) and ``contacts``.
"""

from __future__ import annotations

import argparse
import json
import math
import threading
import time
from typing import Any

import rospy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from std_msgs.msg import String, UInt32


def _wait(pred: Any, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not pred():
        if time.monotonic() > deadline:
            raise SystemExit(f"navigation_bench_peer: no {what} within {timeout:.0f} s")
        time.sleep(0.01)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--goal", type=float, nargs=2, required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--timeout", type=float, default=300.0, help="wall s for the goal")
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("navigation_bench_peer", disable_signals=True)
    lock = threading.Lock()
    state: dict[str, Any] = {"map": False, "outcome": None, "truth": None, "contacts": 0}

    def on_status(msg: String) -> None:
        for word in ("reached", "failed"):
            if msg.data.startswith(f"{word}:") and state["outcome"] is None:
                with lock:
                    state["outcome"] = (word, rospy.get_time(), time.monotonic())

    def on_truth(msg: Odometry) -> None:
        with lock:
            state["truth"] = (msg.pose.pose.position.x, msg.pose.pose.position.y)

    subs = [
        rospy.Subscriber("/map", OccupancyGrid, lambda _m: state.update(map=True), queue_size=1),
        rospy.Subscriber("/rrt_navigation/status", String, on_status, queue_size=100),
        rospy.Subscriber("/ground_truth/odom", Odometry, on_truth, queue_size=1),
        rospy.Subscriber("/ground_truth/contacts", UInt32, lambda m: state.update(contacts=int(m.data)), queue_size=10),
    ]
    goal_pub = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=1, latch=True)
    _wait(lambda: state["map"] and goal_pub.get_num_connections() > 0, 120.0, "map and navigation node")
    first_map = rospy.get_time()
    _wait(lambda: rospy.get_time() > first_map + 3.0, 60.0, "3 s of sim time")
    goal = PoseStamped()
    goal.header.frame_id = "map"
    goal.pose.position.x, goal.pose.position.y = args.goal
    goal.pose.orientation.w = 1.0
    sim0, wall0 = rospy.get_time(), time.monotonic()
    goal_pub.publish(goal)
    _wait(lambda: state["outcome"] is not None, args.timeout, "outcome")
    with lock:
        word, sim1, wall1 = state["outcome"]
        x, y = state["truth"] or (math.nan, math.nan)
    result = {
        "reached": word == "reached",
        "sim_s": sim1 - sim0,
        "wall_s": wall1 - wall0,
        "final_error_m": math.hypot(x - args.goal[0], y - args.goal[1]),
        "contacts": state["contacts"],
    }
    with open(args.out, "w", encoding="utf-8") as out:
        json.dump(result, out)
    for sub in subs:
        sub.unregister()
    rospy.signal_shutdown("done")


if __name__ == "__main__":
    main()
