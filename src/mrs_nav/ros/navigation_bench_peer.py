"""The ROS side of the ROS parts of ``mrs-nav bench navigation`` and ``bench multi-robot``: goals through the
running ROS stack.

Run as ``python -m mrs_nav.ros.navigation_bench_peer --goal X Y --out FILE`` against a master on which
``rrt_navigation.launch`` runs. It waits for the first map and the navigation node, lets 3 s of sim time pass
(so the node has the map too), sends the goal on ``/move_base_simple/goal`` and waits for ``reached`` or
``failed`` on ``/rrt_navigation/status``. Writes JSON: ``reached``, ``sim_s`` and ``wall_s`` from the goal to the
outcome, ``sim_start`` (sim time of the goal), ``wall_start`` (``time.monotonic()``, system-wide, when the goal
went out), ``final_error_m`` (true pose from ``/ground_truth/odom`` to the goal) and ``contacts``.

With ``--navigator potential_field_navigation`` (``potential_field_navigation.launch``, no SLAM) it waits for
the node instead of a map and sends the goal in ``odom``. With ``--world FILE`` the JSON also holds
``min_clearance_m``: the smallest distance from the true footprint (a disc of the Burger's radius around
``base_footprint``) to the world's obstacles over the ground-truth poses received (the latest at each moment the
peer looks, not every one), negative when overlapping.

With ``--from-action`` it sends no goal: once ready (and after writing the file ``--ready``, if given) it waits
for the goal someone else sends to the ``move_base`` action (``mrs-nav bench ros2``: a ROS 2 client through
ros2_bridge), and times from that goal's arrival.

With ``--robot NS X Y`` (repeated, instead of ``--goal``; ``multi_robot.launch``) the same for every robot at
once under its namespace (``/NS/map``, ``/NS/move_base_simple/goal``, ...): all goals go out together and the
JSON holds ``robots`` (NS -> the fields above) and ``sim_s``/``wall_s`` from the goals to the last outcome.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import threading
import time
from pathlib import Path
from typing import Any

import rospy
from geometry_msgs.msg import PoseStamped
from move_base_msgs.msg import MoveBaseActionGoal
from nav_msgs.msg import OccupancyGrid, Odometry
from std_msgs.msg import String, UInt32

from mrs_nav.atomic_write import write_text
from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.world import load_world
from mrs_nav.robot import BURGER_RADIUS

# --navigator -> (its status topic under the robot's prefix, the goal's frame, whether to wait for a map first)
NAVIGATORS = {
    "rrt_navigation": ("rrt_navigation/status", "map", True),
    "potential_field_navigation": ("potential_field_navigation/status", "odom", False),
}


def wait_until(pred: Any, timeout: float, what: str) -> None:
    """Poll ``pred`` until true; after ``timeout`` wall s, exit naming the peer (this module or another that runs
    as ``python -m``) and ``what`` did not come."""
    deadline = time.monotonic() + timeout
    while not pred():
        if time.monotonic() > deadline:
            raise SystemExit(f"{Path(sys.argv[0]).stem}: no {what} within {timeout:.0f} s")
        time.sleep(0.01)


class _Robot:
    """One robot's map, status, ground truth and contacts; ``prefix`` is ``""`` or ``"/NS"``."""

    def __init__(
        self, prefix: str, goal: tuple[float, float], navigator: str, obstacles: Obstacles | None = None
    ) -> None:
        status, self.frame, needs_map = NAVIGATORS[navigator]
        self.goal = goal
        self.lock = threading.Lock()
        self.has_map = not needs_map
        self.outcome: tuple[str, float, float] | None = None
        self.truth: tuple[float, float] | None = None
        self.truth_time = -math.inf  # sim s of the last ground-truth pose taken
        self.contacts = 0
        self._obstacles = obstacles
        self.min_clearance = math.inf
        self.subs = [
            rospy.Subscriber(f"{prefix}/{status}", String, self._on_status, queue_size=100),
            # the latest pose only: every one (50 Hz at tens of times real time) would load the stack measured
            rospy.Subscriber(f"{prefix}/ground_truth/odom", Odometry, self._on_truth, queue_size=1),
            rospy.Subscriber(f"{prefix}/ground_truth/contacts", UInt32, self._on_contacts, queue_size=10),
        ]
        self.goal_pub = rospy.Publisher(f"{prefix}/move_base_simple/goal", PoseStamped, queue_size=1, latch=True)
        if needs_map:
            # the first map is all the peer needs: deserialising every later one would take CPU from the stack
            self._map_sub = rospy.Subscriber(f"{prefix}/map", OccupancyGrid, self._on_map, queue_size=1)

    def _on_map(self, _msg: OccupancyGrid) -> None:
        self.has_map = True
        self._map_sub.unregister()

    def _on_status(self, msg: String) -> None:
        for word in ("reached", "failed"):
            if msg.data.startswith(f"{word}:") and self.outcome is None:
                with self.lock:
                    self.outcome = (word, rospy.get_time(), time.monotonic())

    def _on_truth(self, msg: Odometry) -> None:
        x, y = msg.pose.pose.position.x, msg.pose.pose.position.y
        clearance = math.inf
        if self._obstacles is not None:
            clearance = float(self._obstacles.signed_distance([[x, y]])[0]) - BURGER_RADIUS
        with self.lock:
            self.truth, self.truth_time = (x, y), msg.header.stamp.to_sec()
            self.min_clearance = min(self.min_clearance, clearance)

    def _on_contacts(self, msg: UInt32) -> None:
        self.contacts = int(msg.data)

    def caught_up(self) -> bool:
        """Whether the ground truth taken reaches the outcome's sim time (the final error is of the robot then)."""
        with self.lock:
            return self.outcome is not None and self.truth_time >= self.outcome[1]

    def ready(self) -> bool:
        return self.has_map and self.goal_pub.get_num_connections() > 0

    def send_goal(self) -> None:
        goal = PoseStamped()
        goal.header.frame_id = self.frame
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
            "sim_start": sim0,
            "wall_s": wall1 - wall0,
            "final_error_m": math.hypot(x - self.goal[0], y - self.goal[1]),
            "contacts": self.contacts,
            "min_clearance_m": self.min_clearance if math.isfinite(self.min_clearance) else None,
        }

    def close(self) -> None:
        for sub in self.subs:
            sub.unregister()


def _goal_from_action(ready: str | None, timeout: float) -> tuple[float, float]:
    """Sim and wall time when a goal reached the ``move_base`` action (sent by another client)."""
    arrived: list[tuple[float, float]] = []
    sub = rospy.Subscriber(
        "move_base/goal", MoveBaseActionGoal, lambda _m: arrived.append((rospy.get_time(), time.monotonic()))
    )
    if ready:
        write_text(ready, "ready", "bench peer ready file")
    wait_until(lambda: bool(arrived), timeout, "goal on move_base/goal")
    sub.unregister()
    return arrived[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--goal", type=float, nargs=2)
    where.add_argument("--robot", nargs=3, action="append", metavar=("NS", "X", "Y"), help="repeat per robot")
    parser.add_argument("--out", required=True)
    parser.add_argument("--timeout", type=float, default=300.0, help="wall s for the goal")
    parser.add_argument("--navigator", choices=sorted(NAVIGATORS), default="rrt_navigation")
    parser.add_argument("--world", help="world file: report the true footprint's smallest clearance to it")
    parser.add_argument("--from-action", action="store_true", help="wait for a move_base goal instead of sending")
    parser.add_argument("--ready", help="with --from-action: a file written once the goal may come")
    args = parser.parse_args(rospy.myargv()[1:])
    obstacles = Obstacles.from_world(load_world(args.world)) if args.world else None
    rospy.init_node("navigation_bench_peer", disable_signals=True)
    if args.goal is not None:
        robots = {"": _Robot("", (args.goal[0], args.goal[1]), args.navigator, obstacles)}
    else:
        robots = {ns: _Robot(f"/{ns}", (float(x), float(y)), args.navigator, obstacles) for ns, x, y in args.robot}
    wait_until(lambda: all(r.ready() for r in robots.values()), 120.0, "map and navigation node")
    first_map = rospy.get_time()
    wait_until(lambda: rospy.get_time() > first_map + 3.0, 60.0, "3 s of sim time")
    if args.from_action:
        sim0, wall0 = _goal_from_action(args.ready, args.timeout)
    else:
        sim0, wall0 = rospy.get_time(), time.monotonic()
        for robot in robots.values():
            robot.send_goal()
    wait_until(lambda: all(r.outcome is not None for r in robots.values()), args.timeout, "outcome")
    wait_until(lambda: all(r.caught_up() for r in robots.values()), 60.0, "ground truth up to the outcome")
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
