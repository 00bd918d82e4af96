"""The ROS side of the ROS parts of ``mrs-nav bench navigation`` and ``bench multi-robot``: goals through the
running ROS stack.

Run as ``python -m mrs_nav.ros.navigation_bench_peer --goal X Y --out FILE`` against a master on which
``rrt_navigation.launch`` runs. It waits for the first map and the navigation node, lets 3 s of sim time pass
(so the node has the map too), sends the goal on ``/move_base_simple/goal`` and waits for ``reached`` or
``failed`` on ``/rrt_navigation/status``. Writes JSON: ``reached``, ``sim_s`` and ``wall_s`` from the goal to
the outcome, ``wall_start`` (``time.monotonic()``, system-wide, when the goal went out), ``final_error_m`` (true
pose from ``/ground_truth/odom`` to the goal) and ``contacts``.

With ``--robot NS X Y`` (repeated, instead of ``--goal``; ``multi_robot.launch``) the same for every robot at
once under its namespace (``/NS/map``, ``/NS/move_base_simple/goal``, ...): all goals go out together and the
JSON holds ``robots`` (NS -> the fields above) and ``sim_s``/``wall_s`` from the goals to the last outcome.
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

from mrs_nav.atomic_write import write_text


def _wait(pred: Any, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not pred():
        if time.monotonic() > deadline:
            raise SystemExit(f"navigation_bench_peer: no {what} within {timeout:.0f} s")
        time.sleep(0.01)


class _Robot:
    """One robot's map, status, ground truth and contacts; ``prefix`` is ``""`` or ``"/NS"``."""

    def __init__(self, prefix: str, goal: tuple[float, float]) -> None:
        self.goal = goal
        self.lock = threading.Lock()
        self.has_map = False
        self.outcome: tuple[str, float, float] | None = None
        self.truth: tuple[float, float] | None = None
        self.contacts = 0
        # the first map is all the peer needs: deserialising every later one would take CPU from the stack measured
        self._map_sub = rospy.Subscriber(f"{prefix}/map", OccupancyGrid, self._on_map, queue_size=1)
        self.subs = [
            rospy.Subscriber(f"{prefix}/rrt_navigation/status", String, self._on_status, queue_size=100),
            rospy.Subscriber(f"{prefix}/ground_truth/odom", Odometry, self._on_truth, queue_size=1),
            rospy.Subscriber(f"{prefix}/ground_truth/contacts", UInt32, self._on_contacts, queue_size=10),
        ]
        self.goal_pub = rospy.Publisher(f"{prefix}/move_base_simple/goal", PoseStamped, queue_size=1, latch=True)

    def _on_map(self, _msg: OccupancyGrid) -> None:
        self.has_map = True
        self._map_sub.unregister()

    def _on_status(self, msg: String) -> None:
        for word in ("reached", "failed"):
            if msg.data.startswith(f"{word}:") and self.outcome is None:
                with self.lock:
                    self.outcome = (word, rospy.get_time(), time.monotonic())

    def _on_truth(self, msg: Odometry) -> None:
        with self.lock:
            self.truth = (msg.pose.pose.position.x, msg.pose.pose.position.y)

    def _on_contacts(self, msg: UInt32) -> None:
        self.contacts = int(msg.data)

    def ready(self) -> bool:
        return self.has_map and self.goal_pub.get_num_connections() > 0

    def send_goal(self) -> None:
        goal = PoseStamped()
        goal.header.frame_id = "map"
        goal.pose.position.x, goal.pose.position.y = self.goal
        goal.pose.orientation.w = 1.0
        self.goal_pub.publish(goal)

    def result(self, sim0: float, wall0: float) -> dict[str, Any]:
        with self.lock:
            assert self.outcome is not None
            word, sim1, wall1 = self.outcome
            x, y = self.truth or (math.nan, math.nan)
        return {
            "reached": word == "reached",
            "sim_s": sim1 - sim0,
            "wall_s": wall1 - wall0,
            "final_error_m": math.hypot(x - self.goal[0], y - self.goal[1]),
            "contacts": self.contacts,
        }

    def close(self) -> None:
        for sub in self.subs:
            sub.unregister()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--goal", type=float, nargs=2)
    where.add_argument("--robot", nargs=3, action="append", metavar=("NS", "X", "Y"), help="repeat per robot")
    parser.add_argument("--out", required=True)
    parser.add_argument("--timeout", type=float, default=300.0, help="wall s for the goal")
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("navigation_bench_peer", disable_signals=True)
    if args.goal is not None:
        robots = {"": _Robot("", (args.goal[0], args.goal[1]))}
    else:
        robots = {ns: _Robot(f"/{ns}", (float(x), float(y))) for ns, x, y in args.robot}
    _wait(lambda: all(r.ready() for r in robots.values()), 120.0, "map and navigation node")
    first_map = rospy.get_time()
    _wait(lambda: rospy.get_time() > first_map + 3.0, 60.0, "3 s of sim time")
    sim0, wall0 = rospy.get_time(), time.monotonic()
    for robot in robots.values():
        robot.send_goal()
    _wait(lambda: all(r.outcome is not None for r in robots.values()), args.timeout, "outcome")
    results = {ns: robot.result(sim0, wall0) for ns, robot in robots.items()}
    if args.goal is not None:
        summary: dict[str, Any] = results[""]
    else:
        summary = {
            "robots": results,
            "sim_s": max(r["sim_s"] for r in results.values()),
            "wall_s": max(r["wall_s"] for r in results.values()),
        }
    summary["wall_start"] = wall0  # time.monotonic() (system-wide) when the goals went out
    write_text(args.out, json.dumps(summary), "bench peer results")
    for robot in robots.values():
        robot.close()
    rospy.signal_shutdown("done")


if __name__ == "__main__":
    main()
