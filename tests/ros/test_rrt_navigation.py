"""The rrt_navigation node under a real roslaunch with the simulator.

Without SLAM: the test publishes the arena's map (rasterised from the world file, latched) and an identity
map -> odom transform, so the node's own behaviour is tested (goal refusal, preemption, reaching a goal)."""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from typing import Any

import pytest

from tests.ros.navharness import FOOTPRINT_RADIUS, IdentityCorrection, StatusLog, TruthTrack, world_map_msg
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

# Sim time at max rate, in lockstep: the simulator never runs more than one control period past the last
# /cmd_vel, so the 10 Hz controller (and the simulator's 0.3 s command watchdog) keeps up however fast the machine is.
MAX_RATE = ("real_time_factor:=0", "lockstep:=true")


@pytest.fixture(scope="module")
def navigation(ros_master: RosMaster, rospy_node: Any) -> Iterator[dict[str, Any]]:
    """Simulator + rrt_navigation (slam:=false) + a known map and map -> odom from this process."""
    rospy = rospy_node
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import OccupancyGrid

    with (
        ros_master.launch("simulation.launch", *MAX_RATE, "x:=-1.5", "y:=-1.5", "yaw:=0") as sim,
        ros_master.launch("rrt_navigation.launch", "slam:=false", "seed:=3") as nav,
    ):
        truth = TruthTrack(rospy, "simple.world")
        wait_for(lambda: truth.last() is not None, 60.0, "ground truth from the simulator")
        correction = IdentityCorrection(rospy)
        map_pub = rospy.Publisher("/map", OccupancyGrid, queue_size=1, latch=True)
        map_pub.publish(world_map_msg(rospy, "simple.world"))
        status = StatusLog(rospy, "/rrt_navigation/status")
        goal_pub = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=1, latch=True)
        wait_for(lambda: goal_pub.get_num_connections() > 0 and truth.last() is not None, 30.0, "the navigation node")
        # The latched map reaches the node when it connects; a goal sent before that is refused for want of a map.
        wait_for(lambda: map_pub.get_num_connections() > 0, 30.0, "the navigation node on /map")
        yield {"rospy": rospy, "status": status, "truth": truth, "goal": goal_pub, "procs": (sim, nav)}
        correction.close()
        for pub in (map_pub, goal_pub):
            pub.unregister()
        status.close()
        truth.close()


def send_goal(nav: dict[str, Any], x: float, y: float) -> None:
    from geometry_msgs.msg import PoseStamped

    msg = PoseStamped()
    msg.header.frame_id = "map"
    msg.header.stamp = nav["rospy"].Time.now()
    msg.pose.position.x, msg.pose.position.y = x, y
    msg.pose.orientation.w = 1.0
    nav["goal"].publish(msg)


def count(status: StatusLog, state: str) -> int:
    return sum(m.startswith(f"{state}:") for m in list(status.messages))


def test_a_goal_inside_the_cylinder_is_refused_and_the_robot_does_not_move(navigation: dict[str, Any]) -> None:
    rospy, status, truth = navigation["rospy"], navigation["status"], navigation["truth"]
    before = truth.last()

    def refused_for_the_goal() -> bool:
        # Until the node has taken in the map (its callback may still be running) it refuses for want of one.
        refusals = [m for m in status.messages if m.startswith("refused:")]
        if refusals and "no map received yet" not in refusals[-1]:
            return True
        send_goal(navigation, 0.3, 0.2)
        time.sleep(0.2)
        return False

    wait_for(refused_for_the_goal, 20.0, "the goal to be refused")
    assert "inside an obstacle" in [m for m in status.messages if m.startswith("refused:")][-1]
    t0 = rospy.get_time()
    wait_for(lambda: rospy.get_time() > t0 + 2.0, 20.0, "2 s of sim time")
    after = truth.last()
    assert math.hypot(after[1] - before[1], after[2] - before[2]) < 0.01
    assert not status.has("active")


def test_a_second_goal_preempts_the_first_and_is_reached(navigation: dict[str, Any]) -> None:
    rospy, status, truth = navigation["rospy"], navigation["status"], navigation["truth"]
    # timed from the first goal: the simulator ran freely (nobody commanding it) until the node started
    started = rospy.get_time()
    send_goal(navigation, 1.5, 1.5)
    wait_for(lambda: count(status, "active") >= 2, 30.0, "the first goal to be accepted and planned")
    t0 = rospy.get_time()
    wait_for(lambda: rospy.get_time() > t0 + 3.0, 20.0, "the robot to be on its way")
    send_goal(navigation, -1.5, 1.5)
    wait_for(lambda: status.has("preempted"), 20.0, "the first goal to be preempted")
    preempted = [m for m in status.messages if m.startswith("preempted:")][-1]
    assert "(1.50, 1.50)" in preempted
    wait_for(lambda: status.has("reached") or status.has("failed"), 120.0, "the second goal to end")
    reached = [m for m in status.messages if m.startswith("reached:")]
    assert reached
    assert "(-1.50, 1.50)" in reached[-1]
    _, x, y = truth.last()
    assert math.hypot(x + 1.5, y - 1.5) <= 0.2
    assert truth.min_clearance() > FOOTPRINT_RADIUS
    assert truth.contacts == 0
    assert rospy.get_time() - started < 60.0  # s of sim time: 3 s towards the first goal, ~20 s to the second
