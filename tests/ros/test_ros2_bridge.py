"""ros2_bridge with a real ROS 2 node: a plain rclpy process (no mrs_nav) sees the simulated robot and drives it.

The simulation runs at maximum rate with rrt_navigation on a known map (published once, latched, by this process
before the ROS 2 peer exists: the peer's copy arrives by transient_local, a late join); one bridge accepts
/goal_pose, a second one on another domain accepts nothing, a third on a domain of its own serves Nav2's
NavigateToPose action (and takes nothing else)."""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from typing import Any

import pytest

from tests.ros.navharness import IdentityCorrection, TruthTrack, world_map_msg
from tests.ros.ros2_harness import Ros2Peer, free_domain, high_domain, needs_ros2
from tests.rosharness import RosMaster, wait_for

pytestmark = [pytest.mark.ros, needs_ros2]

MAX_RATE = ("real_time_factor:=0", "lockstep:=true")


@pytest.fixture(scope="module")
def bridged(
    ros_master: RosMaster, rospy_node: Any, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[dict[str, Any]]:
    rospy = rospy_node
    from nav_msgs.msg import OccupancyGrid

    logs = tmp_path_factory.mktemp("ros2")
    open_domain, closed_domain = free_domain(), free_domain()
    while closed_domain == open_domain:
        closed_domain = free_domain()
    action_domain = high_domain()
    with (
        ros_master.launch("simulation.launch", *MAX_RATE, "x:=-1.5", "y:=-1.5", "yaw:=0") as sim,
        ros_master.launch("rrt_navigation.launch", "slam:=false", "seed:=3", "rviz:=false") as nav,
        ros_master.launch("ros2_bridge.launch", f"domain_id:={open_domain}", "allow_inbound:=[/goal_pose]") as b1,
        ros_master.launch(
            "ros2_bridge.launch", f"domain_id:={closed_domain}", "node_name:=ros2_bridge_closed", name="closed"
        ) as b2,
        ros_master.launch(
            "ros2_bridge.launch",
            f"domain_id:={action_domain}",
            "allow_inbound:=[/navigate_to_pose]",
            "node_name:=ros2_bridge_action",
            name="action",
        ) as b3,
    ):
        truth = TruthTrack(rospy, "simple.world")
        correction = IdentityCorrection(rospy)
        map_pub = rospy.Publisher("/map", OccupancyGrid, queue_size=1, latch=True)
        peers: list[Ros2Peer] = []
        try:
            grid = world_map_msg(rospy, "simple.world")
            map_pub.publish(grid)
            wait_for(lambda: truth.last() is not None, 60.0, "ground truth from the simulator")
            # the bridges have the map before the peers exist: the peers get it by joining late
            wait_for(lambda: map_pub.get_num_connections() >= 4, 60.0, "navigation and the bridges on /map")
            time.sleep(1.0)
            peers += [Ros2Peer(open_domain, logs / "peer.log"), Ros2Peer(closed_domain, logs / "closed_peer.log"),
                      Ros2Peer(action_domain, logs / "action_peer.log")]  # fmt: skip
            yield {"rospy": rospy, "truth": truth, "peer": peers[0], "closed": peers[1], "action": peers[2],
                   "grid": grid, "procs": (sim, nav, b1, b2, b3)}  # fmt: skip
        finally:
            for peer in peers:
                peer.close()
            correction.close()
            map_pub.unregister()
            truth.close()


def test_a_ros2_node_receives_odom_scan_map_and_tf(bridged: dict[str, Any]) -> None:
    peer = bridged["peer"]
    wanted = ("odom", "scan", "map", "/tf", "/tf_static")
    wait_for(lambda: all(t in peer.last for t in wanted), 60.0, f"the ROS 2 peer on {wanted} (has {list(peer.last)})")
    odom, scan, grid = peer.last["odom"], peer.last["scan"], peer.last["map"]
    assert (odom["frame"], odom["child"]) == ("odom", "base_footprint")
    assert scan["beams"] == 360
    assert scan["frame"]
    sent = bridged["grid"]
    assert (grid["width"], grid["height"], grid["cells"]) == (sent.info.width, sent.info.height, len(sent.data))
    assert grid["occupied"] == sum(1 for v in sent.data if v > 50)
    assert grid["resolution"] == pytest.approx(sent.info.resolution)
    wait_for(lambda: peer.last["odom"]["count"] > 50, 30.0, "a stream of odometry")

    def frames(topic: str) -> set[tuple[str, str]]:
        lines = [line for line in list(peer.lines) if line.get("topic") == topic]
        return {(parent, child) for line in lines for parent, child in line["pairs"]}

    # tf2_msgs/TFMessage as rviz2 reads it: the simulator's odometry, this test's map -> odom, and the static
    # laser mount from robot_state_publisher
    wait_for(lambda: {("odom", "base_footprint"), ("map", "odom")} <= frames("/tf"), 30.0, "tf pairs")
    assert ("base_link", "base_scan") in frames("/tf_static"), frames("/tf_static")


def test_a_ros2_node_receives_the_particle_cloud_as_nav2_and_as_ros1_amcl_publish_it(
    bridged: dict[str, Any],
) -> None:
    rospy, peer = bridged["rospy"], bridged["peer"]
    from geometry_msgs.msg import Pose, PoseArray

    cloud_pub = rospy.Publisher("/particlecloud", PoseArray, queue_size=2)
    cloud = PoseArray()
    cloud.header.frame_id = "map"
    cloud.poses = [Pose() for _ in range(4)]
    for i, pose in enumerate(cloud.poses):
        pose.position.x, pose.orientation.w = 0.5 * i, 1.0
    try:

        def heard() -> bool:
            cloud.header.stamp = rospy.Time.now()
            cloud_pub.publish(cloud)  # best effort on ROS 2: sent until both arrive
            return "particle_cloud" in peer.last and "particlecloud" in peer.last

        wait_for(heard, 30.0, "the cloud on /particle_cloud and /particlecloud", period=0.2)
    finally:
        cloud_pub.unregister()
    nav2, poses = peer.last["particle_cloud"], peer.last["particlecloud"]
    assert nav2["frame"] == poses["frame"] == "map"
    assert nav2["xs"] == poses["xs"] == [0.0, 0.5, 1.0, 1.5]
    assert nav2["weights"] == pytest.approx([0.25] * 4)


def test_a_goal_is_refused_when_not_allowed(bridged: dict[str, Any]) -> None:
    rospy, closed, truth = bridged["rospy"], bridged["closed"], bridged["truth"]
    from geometry_msgs.msg import PoseStamped

    heard: list[Any] = []
    sub = rospy.Subscriber("/move_base_simple/goal", PoseStamped, heard.append)
    try:
        wait_for(lambda: "odom" in closed.last, 60.0, "the closed bridge's peer on odom")
        start = truth.last()
        for _ in range(5):
            closed.send("goal 1.5 1.5")
            time.sleep(0.3)

        def sent() -> list[int]:
            return [line["subscribers"] for line in list(closed.lines) if "sent" in line]

        wait_for(lambda: len(sent()) == 5, 10.0, "the peer's report of its 5 goals")
        assert sent() == [0] * 5  # nobody on the closed bridge's domain listens to /goal_pose
        assert heard == []
        end = truth.last()
        assert math.hypot(end[1] - start[1], end[2] - start[2]) < 0.05
    finally:
        sub.unregister()


def test_a_goal_with_nan_is_dropped_and_the_bridge_goes_on(bridged: dict[str, Any]) -> None:
    rospy, peer = bridged["rospy"], bridged["peer"]
    from geometry_msgs.msg import PoseStamped

    heard: list[Any] = []
    sub = rospy.Subscriber("/move_base_simple/goal", PoseStamped, heard.append)
    try:
        wait_for(lambda: sub.get_num_connections() > 0, 30.0, "the bridge's publisher of /move_base_simple/goal")

        def delivered() -> bool:  # until DDS has matched the peer with the bridge, goals reach nobody
            peer.send("goal nan 1.0")
            time.sleep(0.2)
            return any(line.get("subscribers", 0) > 0 for line in list(peer.lines) if "sent" in line)

        wait_for(delivered, 30.0, "the bridge subscribed to /goal_pose")
        for _ in range(3):
            peer.send("goal nan 1.0")
        time.sleep(1.0)
        assert heard == []
        assert all(proc.poll() is None for proc in bridged["procs"])
    finally:
        sub.unregister()


def test_a_ros2_goal_pose_drives_the_robot_there(bridged: dict[str, Any]) -> None:
    peer, truth = bridged["peer"], bridged["truth"]
    wait_for(lambda: "odom" in peer.last, 60.0, "the peer on odom")

    def subscribed() -> bool:
        peer.send("goal 1.5 1.5")
        time.sleep(0.2)
        return any(line.get("subscribers", 0) > 0 for line in peer.lines if "sent" in line)

    wait_for(subscribed, 30.0, "the bridge subscribed to /goal_pose")

    def there() -> bool:
        last = truth.last()
        return last is not None and math.hypot(last[1] - 1.5, last[2] - 1.5) < 0.25

    wait_for(there, 120.0, "the robot at (1.5, 1.5) in ground truth")


# action_msgs/GoalStatus
STATUS_SUCCEEDED, STATUS_CANCELED = 4, 5


def _action_lines(peer: Ros2Peer, name: str, key: str) -> list[dict[str, Any]]:
    return [line for line in list(peer.lines) if line.get("action") == name and key in line]


def _server_ready(peer: Ros2Peer) -> bool:
    peer.send("server")
    time.sleep(0.2)
    return any(line.get("server") for line in list(peer.lines))


def test_a_navigate_to_pose_goal_is_reached_with_feedback(bridged: dict[str, Any]) -> None:
    nav, truth = bridged["action"], bridged["truth"]
    wait_for(lambda: _server_ready(nav), 60.0, "the bridge's navigate_to_pose action server")
    goal = (-1.0, 1.5)
    nav.send(f"navigate first {goal[0]} {goal[1]}")
    wait_for(lambda: _action_lines(nav, "first", "status"), 180.0, "the NavigateToPose result")
    end = truth.last()
    (result,) = _action_lines(nav, "first", "status")
    assert (result["status"], result["error_code"], result["error_msg"]) == (STATUS_SUCCEEDED, 0, "")
    assert math.hypot(end[1] - goal[0], end[2] - goal[1]) < 0.25  # ground truth, not the robot's belief
    feedback = _action_lines(nav, "first", "feedback")
    assert result["feedbacks"] > 10
    assert len(feedback) >= 2
    assert {line["frame"] for line in feedback} == {"map"}
    assert feedback[-1]["distance"] < feedback[0]["distance"]
    assert feedback[-1]["navigation_time"] > feedback[0]["navigation_time"] > 0.0
    assert any(line["eta"] > 0.0 for line in feedback)  # the robot was seen moving


def test_a_navigate_to_pose_goal_is_cancelled_on_both_sides(bridged: dict[str, Any]) -> None:
    rospy, nav, truth = bridged["rospy"], bridged["action"], bridged["truth"]
    from move_base_msgs.msg import MoveBaseActionResult

    ros1_results: list[Any] = []
    sub = rospy.Subscriber("/move_base/result", MoveBaseActionResult, ros1_results.append)
    try:
        wait_for(lambda: _server_ready(nav), 60.0, "the bridge's navigate_to_pose action server")
        goal = (1.5, -1.5)
        nav.send(f"navigate second {goal[0]} {goal[1]}")

        def moving() -> bool:
            lines = _action_lines(nav, "second", "feedback")
            return len(lines) >= 2 and lines[-1]["distance"] < lines[0]["distance"] - 0.3

        wait_for(moving, 120.0, "feedback of the robot on its way")
        nav.send("cancel second")
        wait_for(lambda: _action_lines(nav, "second", "status"), 60.0, "the cancelled goal's result")
        (result,) = _action_lines(nav, "second", "status")
        assert result["status"] == STATUS_CANCELED
        assert [line["cancel_goals"] for line in _action_lines(nav, "second", "cancel_goals")] == [1]
        # move_base on ROS 1 was told: its goal ended PREEMPTED (actionlib_msgs/GoalStatus 2)
        wait_for(lambda: any(r.status.status == 2 for r in ros1_results), 10.0, "move_base's PREEMPTED result")
        stopped = truth.last()
        time.sleep(2.0)  # at maximum rate: many seconds of sim time
        end = truth.last()
        assert math.hypot(end[1] - stopped[1], end[2] - stopped[2]) < 0.05  # it stopped
        assert math.hypot(end[1] - goal[0], end[2] - goal[1]) > 0.5  # short of the goal
    finally:
        sub.unregister()
