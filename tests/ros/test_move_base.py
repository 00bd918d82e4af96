"""The move_base interface of rrt_navigation under a real roslaunch (simulator in lockstep, sim time at max
rate), on the course arena's known map with map -> odom from this process: action goals with headings,
cancel, refusal, an unreachable goal, make_plan, the costmap, and a box put in the way at run time."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.world import Box, load_world
from tests.ros.navharness import (
    FOOTPRINT_RADIUS,
    IdentityCorrection,
    TruthTrack,
    close_action_client,
    world_map_msg,
)
from tests.rosharness import REPO, RosMaster, wait_for

pytestmark = pytest.mark.ros

MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
XY_TOLERANCE, YAW_TOLERANCE = 0.05, 0.17  # m, rad: the node's defaults (move_base's names)
MARGIN = 1.0  # m of free map outside the arena's walls, where no path leads
SLACK = 0.01  # m the robot may still move after the goal is reached (settling)
# How far the truth may be from the node's estimate (odometry, map -> odom being the identity here: no SLAM).
# Odometry drifts with the distance driven (the simulator's 1 % wheel noise and the wheels' slip), and the module's
# goals add up: CI runs saw 0.087 m after two 3 m trips and 0.106 m after all of them. So a fixed part plus a part
# per metre the robot has driven since the module started.
DRIFT_BASE, DRIFT_PER_METRE = 0.05, 0.01  # m, m/m


def target(rospy: Any, x: float, y: float, yaw: float) -> Any:
    from move_base_msgs.msg import MoveBaseGoal

    goal = MoveBaseGoal()
    goal.target_pose.header.frame_id = "map"
    goal.target_pose.header.stamp = rospy.Time.now()
    goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = x, y
    goal.target_pose.pose.orientation.z, goal.target_pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return goal


@pytest.fixture(scope="module")
def arena(ros_master: RosMaster, rospy_node: Any) -> Iterator[dict[str, Any]]:
    rospy = rospy_node
    import actionlib
    from move_base_msgs.msg import MoveBaseAction
    from nav_msgs.msg import OccupancyGrid

    with (
        ros_master.launch("simulation.launch", *MAX_RATE, "x:=-1.5", "y:=-1.5", "yaw:=0") as sim,
        ros_master.launch("rrt_navigation.launch", "slam:=false", "seed:=4", "lockstep:=true") as nav,
    ):
        truth = TruthTrack(rospy, "simple.world")
        wait_for(lambda: truth.last() is not None, 60.0, "ground truth from the simulator")
        correction = IdentityCorrection(rospy)
        map_pub = rospy.Publisher("/map", OccupancyGrid, queue_size=1, latch=True)
        map_pub.publish(world_map_msg(rospy, "simple.world", margin=MARGIN))
        client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
        assert client.wait_for_server(rospy.Duration(60.0)), "no move_base action server"
        rospy.wait_for_message("/move_base/global_costmap/costmap", OccupancyGrid, 60.0)  # it has the map
        state = {"rospy": rospy, "truth": truth, "client": client, "procs": (sim, nav), "correction": correction}
        yield state
        state["correction"].close()
        close_action_client(client)
        map_pub.unregister()
        truth.close()


def assert_reached(rospy: Any, truth: TruthTrack, x: float, y: float) -> None:
    """The tolerance holds for the node's estimate (odometry), and the truth is within the odometry's drift."""
    from nav_msgs.msg import Odometry

    odom = rospy.wait_for_message("/odom", Odometry, 10.0).pose.pose.position
    assert math.hypot(odom.x - x, odom.y - y) <= XY_TOLERANCE + SLACK, (x, y, odom.x, odom.y)
    track = truth.array()[:, 1:]
    driven = float(np.hypot(*np.diff(track, axis=0).T).sum())
    _, tx, ty = truth.last()
    drift = math.hypot(tx - odom.x, ty - odom.y)
    assert drift <= DRIFT_BASE + DRIFT_PER_METRE * driven, (odom.x, odom.y, tx, ty, driven)


def wait_result(arena: dict[str, Any], timeout: float = 150.0) -> int:
    client = arena["client"]
    wait_for(lambda: client.get_state() not in (0, 1), timeout, "the goal to end")  # PENDING, ACTIVE
    return int(client.get_state())


def test_goals_with_headings_succeed_within_the_tolerances(arena: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    rospy, truth, client = arena["rospy"], arena["truth"], arena["client"]
    feedback: list[Any] = []
    for x, y, yaw in [(1.2, -1.5, math.pi / 2), (1.3, 1.3, math.pi), (-1.4, 0.9, -math.pi / 2)]:
        feedback.clear()
        client.send_goal(target(rospy, x, y, yaw), feedback_cb=feedback.append)
        assert wait_result(arena) == GoalStatus.SUCCEEDED, client.get_goal_status_text()
        t0 = rospy.get_time()
        wait_for(lambda t0=t0: rospy.get_time() > t0 + 0.5, 20.0, "the robot to settle")
        assert_reached(rospy, truth, x, y)
        assert abs(math.remainder(truth.last_yaw() - yaw, 2 * math.pi)) <= YAW_TOLERANCE + 0.02
        assert len(feedback) > 10  # base_position every control period
        assert feedback[-1].base_position.header.frame_id == "map"
    assert truth.min_clearance() > FOOTPRINT_RADIUS
    assert truth.contacts == 0


def test_a_goal_with_the_all_zero_quaternion_asks_for_no_heading(arena: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    rospy, truth, client = arena["rospy"], arena["truth"], arena["client"]
    goal = target(rospy, -1.3, -1.2, 0.0)
    goal.target_pose.pose.orientation.w = 0.0  # x = y = z = w = 0: a goal sent without a heading
    client.send_goal(goal)
    assert wait_result(arena) == GoalStatus.SUCCEEDED, client.get_goal_status_text()
    assert_reached(rospy, truth, -1.3, -1.2)


def test_cancel_stops_the_robot_within_half_a_second(arena: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    rospy, truth, client = arena["rospy"], arena["truth"], arena["client"]
    _, x0, y0 = truth.last()
    client.send_goal(target(rospy, -x0, -y0 + 0.1, 0.0))
    wait_for(lambda: client.get_state() == GoalStatus.ACTIVE, 20.0, "the goal to be active")
    # Moving, not merely 4 s of sim time after the goal: the plan's budget is wall-clock time, so on a loaded
    # machine at max rate the robot may still be planning or turning on the spot then (a CI run saw 9 mm).
    wait_for(lambda: truth.moved(rospy.get_time() - 0.5, rospy.get_time()) > 0.03, 60.0, "the robot to be on its way")
    client.cancel_goal()
    cancelled_at = rospy.get_time()
    assert wait_result(arena) == GoalStatus.PREEMPTED
    wait_for(lambda: rospy.get_time() > cancelled_at + 2.0, 30.0, "2 s after the cancel")
    assert truth.moved(cancelled_at + 0.5, cancelled_at + 2.0) < 0.01  # stopped within 0.5 s of sim time


def test_a_goal_inside_the_cylinder_is_rejected_with_a_reason(arena: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    arena["client"].send_goal(target(arena["rospy"], 0.3, 0.2, 0.0))
    assert wait_result(arena, 30.0) == GoalStatus.REJECTED
    assert "inside an obstacle" in arena["client"].get_goal_status_text()


def test_a_goal_whose_id_repeats_a_finished_goals_is_taken_as_a_new_goal(arena: dict[str, Any]) -> None:
    """The ROS wiki's goal script run twice under its one node name, each time sending before its first /clock
    message, sends the id ``<name>-1-0.000`` twice: the second goal must be taken, not ignored by actionlib (its
    client then waited for a result for ever)."""
    from actionlib_msgs.msg import GoalStatus
    from move_base_msgs.msg import MoveBaseActionGoal, MoveBaseActionResult

    rospy, truth = arena["rospy"], arena["truth"]
    results: list[tuple[str, int, str]] = []
    sub = rospy.Subscriber(
        "/move_base/result",
        MoveBaseActionResult,
        lambda m: results.append((m.status.goal_id.id, m.status.status, m.status.text)),
        queue_size=10,
    )
    pub = rospy.Publisher("/move_base/goal", MoveBaseActionGoal, queue_size=1)
    goal_id = "/simple_navigation_goals-1-0.000"
    try:
        wait_for(lambda: pub.get_num_connections() > 0, 30.0, "the server on /move_base/goal")
        _, x, y = truth.last()
        for n, where in enumerate([target(rospy, 0.3, 0.2, 0.0), target(rospy, x, y, 0.0)]):
            where.target_pose.pose.orientation.w = 0.0  # the second: where the robot stands, no heading
            msg = MoveBaseActionGoal(goal=where)
            msg.goal_id.id = goal_id  # stamp 0, as a client without a clock yet sends it
            pub.publish(msg)
            wait_for(lambda n=n: len([r for r in list(results) if r[0] == goal_id]) > n, 60.0, f"result {n + 1}")
        first, second = [r for r in results if r[0] == goal_id]
        assert first[1] == GoalStatus.REJECTED, first
        assert second[1] == GoalStatus.SUCCEEDED, second
    finally:
        sub.unregister()
        pub.unregister()


def test_an_unreachable_goal_is_aborted_with_a_reason(arena: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    # free space of the map outside the arena's wall: no path leads there
    arena["client"].send_goal(target(arena["rospy"], 2.7, 0.0, 0.0))
    assert wait_result(arena, 120.0) == GoalStatus.ABORTED
    assert "plans failed" in arena["client"].get_goal_status_text()


def test_make_plan_plans_without_moving_and_the_costmap_is_published(arena: dict[str, Any]) -> None:
    rospy, truth = arena["rospy"], arena["truth"]
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import OccupancyGrid
    from nav_msgs.srv import GetPlan

    rospy.wait_for_service("/move_base/make_plan", 30.0)
    start, goal = PoseStamped(), PoseStamped()
    start.header.frame_id = goal.header.frame_id = "map"
    start.pose.position.x, start.pose.position.y, start.pose.orientation.w = -1.5, 1.5, 1.0
    goal.pose.position.x, goal.pose.position.y, goal.pose.orientation.w = 1.5, -1.5, 1.0
    _, x0, y0 = truth.last()
    plan = rospy.ServiceProxy("/move_base/make_plan", GetPlan)(start=start, goal=goal, tolerance=0.0).plan
    assert plan.header.frame_id == "map"
    assert len(plan.poses) >= 2
    first, last = plan.poses[0].pose.position, plan.poses[-1].pose.position
    assert math.hypot(first.x + 1.5, first.y - 1.5) < 0.01
    assert math.hypot(last.x - 1.5, last.y + 1.5) < 0.25
    _, x1, y1 = truth.last()
    assert math.hypot(x1 - x0, y1 - y0) < 0.01
    costmap = rospy.wait_for_message("/move_base/global_costmap/costmap", OccupancyGrid, 30.0)
    assert costmap.header.frame_id == "map"
    assert sum(1 for v in costmap.data if v == 100) > sum(
        1 for v in world_map_msg(rospy, "simple.world").data if v == 100
    )


def test_a_box_put_in_the_way_is_driven_around_without_contact(arena: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus
    from visualization_msgs.msg import Marker

    rospy, truth, client = arena["rospy"], arena["truth"], arena["client"]
    client.send_goal(target(rospy, -1.5, -1.5, 0.0))  # back to the start corner
    assert wait_result(arena) == GoalStatus.SUCCEEDED, client.get_goal_status_text()
    box = Marker(type=Marker.CUBE, ns="wall_in_the_way")
    # across the south side of the arena, from the wall to the cylinder: the map does not have it
    box.pose.position.x, box.pose.position.y, box.pose.position.z = 0.0, -1.0, 0.25
    box.pose.orientation.w = 1.0
    box.scale.x, box.scale.y, box.scale.z = 0.2, 2.0, 0.5
    add = rospy.Publisher("/simulator/add_box", Marker, queue_size=1, latch=True)
    wait_for(lambda: add.get_num_connections() > 0, 20.0, "the simulator's add_box")
    add.publish(box)
    added_at = rospy.get_time()
    client.send_goal(target(rospy, 1.5, -1.5, 0.0))
    assert wait_result(arena) == GoalStatus.SUCCEEDED, client.get_goal_status_text()
    add.unregister()
    assert_reached(rospy, truth, 1.5, -1.5)
    world = load_world(REPO / "worlds" / "simple.world")
    with_box = replace(world, boxes=(*world.boxes, Box("box", 0.0, -1.0, 0.25, 0.0, 0.2, 2.0, 0.5)))
    trip = truth.since(added_at)
    assert Obstacles.from_world(with_box).signed_distance(trip[:, 1:]).min() > FOOTPRINT_RADIUS
    assert truth.contacts == 0
    assert trip[:, 2].max() > 0.5  # north of the cylinder: the other way round


def test_a_scan_with_nan_angles_is_dropped_with_a_warning(arena: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus
    from rosgraph_msgs.msg import Log
    from sensor_msgs.msg import LaserScan

    rospy, client = arena["rospy"], arena["client"]
    warnings: list[str] = []
    log_sub = rospy.Subscriber(
        "/rosout_agg", Log, lambda m: warnings.append(m.msg) if m.name == "/rrt_navigation" else None, queue_size=100
    )
    scan_pub = rospy.Publisher("/scan", LaserScan, queue_size=1, latch=True)
    bad = LaserScan(angle_min=math.nan, angle_increment=math.nan, range_min=0.12, range_max=3.5, ranges=[1.0] * 360)
    bad.header.frame_id = "base_scan"
    wait_for(lambda: scan_pub.get_num_connections() > 0, 20.0, "the navigation node's /scan")
    # the warning is logged once: be listening to /rosout_agg before it can be
    wait_for(lambda: log_sub.get_num_connections() > 0, 20.0, "/rosout_agg")
    scan_pub.publish(bad)
    wait_for(lambda: any("dropping scan" in w for w in warnings), 30.0, "the warning about the bad scan")
    scan_pub.unregister()
    log_sub.unregister()
    client.send_goal(target(rospy, -1.0, -1.5, 0.0))  # still alive and navigating
    assert wait_result(arena) == GoalStatus.SUCCEEDED, client.get_goal_status_text()


def test_a_robot_that_loses_its_localisation_stops_and_resumes_when_it_returns(arena: dict[str, Any]) -> None:
    from actionlib_msgs.msg import GoalStatus

    rospy, truth, client = arena["rospy"], arena["truth"], arena["client"]
    client.send_goal(target(rospy, -1.2, 1.0, 0.0))  # from (-1, -1.5), the previous goal
    t0 = rospy.get_time()
    wait_for(lambda: rospy.get_time() > t0 + 4.0, 30.0, "the robot to be on its way")
    arena["correction"].stop()  # map -> odom stops, as when the SLAM node dies
    # the last correction was dated IdentityCorrection.ahead into the future: it went stale from then on
    stale_from = rospy.get_time() + IdentityCorrection.ahead
    wait_for(lambda: rospy.get_time() > stale_from + 3.0, 30.0, "3 s of sim time without localisation")
    assert truth.moved(stale_from + 0.5, stale_from + 3.0) < 0.01  # stopped within 0.5 s of sim time
    assert client.get_state() == GoalStatus.ACTIVE
    arena["correction"].close()
    arena["correction"] = IdentityCorrection(rospy)  # localisation is back
    assert wait_result(arena) == GoalStatus.SUCCEEDED, client.get_goal_status_text()
