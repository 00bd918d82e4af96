"""The rrt_navigation node under a real roslaunch with the simulator.

Without SLAM: the test publishes the arena's map (rasterised from the world file, latched) and an identity
map -> odom transform, so the node's own behaviour is tested (goal refusal, preemption, reaching a goal)."""

from __future__ import annotations

import math
import threading
from collections.abc import Iterator
from typing import Any

import pytest

from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from tests.ros.navharness import FOOTPRINT_RADIUS, StatusLog, TruthTrack
from tests.rosharness import REPO, RosMaster, wait_for

pytestmark = pytest.mark.ros

# Sim time at max rate, in lockstep: the simulator never runs more than one control period past the last
# /cmd_vel, so the 10 Hz controller (and its 0.5 s command watchdog) keeps up however fast the machine is.
MAX_RATE = ("real_time_factor:=0", "lockstep:=true")


def arena_map_msg(rospy: Any) -> Any:
    from nav_msgs.msg import OccupancyGrid

    grid = rasterize_world(load_world(REPO / "worlds" / "simple.world"), 0.05, margin=0.2)
    msg = OccupancyGrid()
    msg.header.frame_id = "map"
    msg.header.stamp = rospy.Time.now()
    msg.info.resolution = grid.resolution
    msg.info.width, msg.info.height = grid.width, grid.height
    msg.info.origin.position.x, msg.info.origin.position.y = grid.origin[0], grid.origin[1]
    msg.info.origin.orientation.w = 1.0
    msg.data = grid.values.ravel().tolist()
    return msg


@pytest.fixture(scope="module")
def navigation(ros_master: RosMaster, rospy_node: Any) -> Iterator[dict[str, Any]]:
    """Simulator + rrt_navigation (slam:=false) + a known map and map -> odom from this process."""
    rospy = rospy_node
    import tf2_ros
    from geometry_msgs.msg import PoseStamped, TransformStamped
    from nav_msgs.msg import OccupancyGrid

    with (
        ros_master.launch("simulation.launch", *MAX_RATE, "x:=-1.5", "y:=-1.5", "yaw:=0") as sim,
        ros_master.launch("rrt_navigation.launch", "slam:=false", "seed:=3") as nav,
    ):
        truth = TruthTrack(rospy, "simple.world")
        wait_for(lambda: truth.last() is not None, 60.0, "ground truth from the simulator")
        # map -> odom as SLAM would send it (identity: odometry starts at the true start pose), every 20 ms of
        # wall time from a plain thread (a rospy.Timer dies when sim time jumps back between test modules; a
        # static transform would outlive this module in the test process)
        tf_pub = tf2_ros.TransformBroadcaster()
        stop = threading.Event()

        def send_identity() -> None:
            while not stop.wait(0.02):
                identity = TransformStamped()
                identity.header.stamp = rospy.Time.now()
                identity.header.frame_id, identity.child_frame_id = "map", "odom"
                identity.transform.rotation.w = 1.0
                tf_pub.sendTransform(identity)

        sender = threading.Thread(target=send_identity, daemon=True)
        sender.start()
        map_pub = rospy.Publisher("/map", OccupancyGrid, queue_size=1, latch=True)
        map_pub.publish(arena_map_msg(rospy))
        status = StatusLog(rospy, "/rrt_navigation/status")
        goal_pub = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=1, latch=True)
        wait_for(lambda: goal_pub.get_num_connections() > 0 and truth.last() is not None, 30.0, "the navigation node")
        yield {"rospy": rospy, "status": status, "truth": truth, "goal": goal_pub, "procs": (sim, nav)}
        stop.set()
        sender.join()
        for pub in (map_pub, goal_pub, tf_pub.pub_tf):
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
    send_goal(navigation, 0.3, 0.2)
    wait_for(lambda: status.has("refused"), 20.0, "the goal to be refused")
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
