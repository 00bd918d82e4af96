"""The ROS side of ``mrs-nav bench soak``: laps of the arena's corners through the running stack, clock jumps.

Run as ``python -m mrs_nav.ros.soak_peer --out FILE --minutes M --jump-every J --node /simulator ...`` against a
master on which ``rrt_navigation.launch`` runs. It waits for the ``move_base`` action server and the first map,
lets 3 s of sim time pass, then sends the corners (:data:`mrs_nav.bench.soak_rules.CORNERS`) in turn as
``move_base`` action goals, as a user's program would, lap after lap, until ``M`` wall minutes have passed and at
least :data:`~mrs_nav.bench.soak_rules.MIN_LAPS` laps are done. At each lap's end it reads every ``--node``'s RSS
and CPU time from /proc and the sim time (scans = sim seconds x the simulator's ``~scan_rate``).

When a clock jump is due (:func:`mrs_nav.bench.soak_rules.jumps_due`), the goal just sent is driven for 2 s of sim
time, then :class:`mrs_nav.ros.clock_jumper.ClockJumper` makes sim time go back under the nodes; once that goal
has ended (aborted, as the nodes do on a jump back), the same goal is sent again. Recorded per jump: the first
goal's outcome, the resent goal's outcome and the true distance to it then (``/ground_truth/odom``), and what the
nodes published from the resumption to that outcome (:class:`mrs_nav.ros.clock_jumper.Activity`).

Writes JSON: ``laps`` (``usage`` node -> [RSS bytes, CPU s], ``scans``, ``reached``, ``wall_s``), ``jumps`` and
``sim_s``. A line per lap and per jump goes to stderr.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import threading
import time
from dataclasses import asdict, dataclass, field
from typing import Any

import actionlib
import rosgraph
import rospy
from actionlib_msgs.msg import GoalStatus
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid, Odometry

from mrs_nav.atomic_write import write_text
from mrs_nav.bench.soak_rules import CORNERS, MIN_LAPS, jump_offset, jumps_due
from mrs_nav.ros.clock_jumper import Activity, ClockJumper
from mrs_nav.ros.navigation_bench_peer import wait_until
from mrs_nav.ros_processes import node_pid, process_usage

GOAL_TIMEOUT_S = 600.0  # wall s for one goal on a loaded machine
SET_OFF_S = 2.0  # sim s a goal is driven before the clock jumps under it


@dataclass
class JumpRecord:
    """One clock jump and the goal after it."""

    at_min: float
    offset_s: float
    goal: tuple[float, float]
    first: str = ""
    after: str = ""
    error_m: float | None = None
    published: dict[str, int] = field(default_factory=dict)


class Driver:
    """Goals through the ``move_base`` action, one at a time, with a wall-clock bound."""

    def __init__(self) -> None:
        self.client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
        self._done = threading.Event()
        self._state = GoalStatus.LOST

    def send(self, goal: tuple[float, float]) -> None:
        msg = MoveBaseGoal()
        msg.target_pose.header.frame_id = "map"
        msg.target_pose.pose.position.x, msg.target_pose.pose.position.y = goal
        msg.target_pose.pose.orientation.w = 1.0
        self._done.clear()
        self.client.send_goal(msg, done_cb=self._on_done)

    def _on_done(self, state: int, _result: Any) -> None:
        self._state = state
        self._done.set()

    def outcome(self) -> str:
        """Wait for the goal sent last to end; its final state (``SUCCEEDED``, ``ABORTED``, ...)."""
        if not self._done.wait(GOAL_TIMEOUT_S):
            self.client.cancel_all_goals()
            return "TIMED OUT"
        return str(GoalStatus.to_string(self._state))

    def drive(self, goal: tuple[float, float]) -> str:
        self.send(goal)
        return self.outcome()


class Truth:
    """The latest true position (``/ground_truth/odom``) while open; only the latest, to load the stack little."""

    def __init__(self) -> None:
        self.position: tuple[float, float] | None = None
        self.sub = rospy.Subscriber("/ground_truth/odom", Odometry, self._on_odom, queue_size=1)

    def _on_odom(self, msg: Odometry) -> None:
        self.position = (msg.pose.pose.position.x, msg.pose.pose.position.y)

    def distance(self, goal: tuple[float, float]) -> float | None:
        time.sleep(0.5)  # the pose of the stopped robot arrives
        if self.position is None:
            return None
        return math.hypot(self.position[0] - goal[0], self.position[1] - goal[1])

    def close(self) -> None:
        self.sub.unregister()


def jump_during(driver: Driver, jumper: ClockJumper, record: JumpRecord) -> bool:
    """Send ``record.goal``, jump the clock under it by ``record.offset_s``, then send it again; fills in
    ``record``; whether the resent goal was reached."""
    activity, truth = Activity(), Truth()
    try:
        driver.send(record.goal)
        sent = rospy.get_time()
        wait_until(lambda: rospy.get_time() > sent + SET_OFF_S, 120.0, f"{SET_OFF_S} s of sim time after the goal")
        resumed = jumper.jump(record.offset_s)
        record.first = driver.outcome()
        record.after = driver.drive(record.goal)
        record.error_m = truth.distance(record.goal)
        record.published = activity.since(resumed)
    finally:
        activity.close()
        truth.close()
    print(f"soak_peer: jump {record}", file=sys.stderr, flush=True)
    return record.after == "SUCCEEDED"


def _usage(pids: dict[str, int]) -> dict[str, tuple[int, float]]:
    return {node: process_usage(pid) for node, pid in pids.items()}


def soak(args: argparse.Namespace, driver: Driver, pids: dict[str, int], scan_rate: float) -> dict[str, Any]:
    """Laps until the requested minutes have passed (see the module's docstring); the JSON result."""
    jumper = ClockJumper()
    wall0 = time.monotonic()
    deadline = wall0 + 60.0 * args.minutes
    sim_total = 0.0
    laps: list[dict[str, Any]] = []
    jumps: list[JumpRecord] = []
    while len(laps) < MIN_LAPS or time.monotonic() < deadline:
        before, sim0, lap_wall0, reached = _usage(pids), rospy.get_time(), time.monotonic(), 0
        for goal in CORNERS:
            elapsed = time.monotonic() - wall0
            if len(jumps) < jumps_due(elapsed, args.jump_every, args.minutes):
                record = JumpRecord(elapsed / 60.0, jump_offset(len(jumps)), goal)
                jumps.append(record)
                reached += jump_during(driver, jumper, record)
            else:
                reached += driver.drive(goal) == "SUCCEEDED"
        after, sim_s = _usage(pids), rospy.get_time() - sim0
        sim_total += sim_s
        usage = {node: [after[node][0], after[node][1] - before[node][1]] for node in pids}
        laps.append(
            {"usage": usage, "scans": sim_s * scan_rate, "reached": reached, "wall_s": time.monotonic() - lap_wall0}
        )
        cpu = ", ".join(f"{node} {1000.0 * u[1] / max(sim_s * scan_rate, 1.0):.1f}" for node, u in usage.items())
        print(
            f"soak_peer: lap {len(laps)} {reached}/4 reached, {sim_s:.0f} sim s, CPU ms/scan {cpu}",
            file=sys.stderr,
            flush=True,
        )
    jumper.close()
    return {"laps": laps, "jumps": [asdict(j) for j in jumps], "sim_s": sim_total}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", required=True)
    parser.add_argument("--minutes", type=float, required=True, help="wall minutes of laps")
    parser.add_argument("--jump-every", type=float, default=0.0, help="wall minutes between clock jumps; 0 = none")
    parser.add_argument("--node", action="append", required=True, help="a node to measure (repeat)")
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("soak_peer", disable_signals=True)
    has_map = threading.Event()
    map_sub = rospy.Subscriber("/map", OccupancyGrid, lambda _m: has_map.set(), queue_size=1)
    driver = Driver()
    wait_until(
        lambda: has_map.is_set() and driver.client.wait_for_server(rospy.Duration(0.1)), 120.0, "map and move_base"
    )
    map_sub.unregister()
    ready = rospy.get_time()
    wait_until(lambda: rospy.get_time() > ready + 3.0, 60.0, "3 s of sim time")
    pids = {node: node_pid(rosgraph.get_master_uri(), node) for node in args.node}
    result = soak(args, driver, pids, float(rospy.get_param("/simulator/scan_rate")))
    write_text(args.out, json.dumps(result), "soak results")
    rospy.signal_shutdown("done")


if __name__ == "__main__":
    main()
