"""rrt_navigation starts its move_base action only on the first map, as move_base does: before it a client's
``wait_for_server`` does not return and an rviz goal (as a script at start-up sends it) is kept, not
driven to; once the map is there the server is up and the kept goal is reached. (Before, the server was up at
start and took goals it could only refuse: a ROS 2 NavigateToPose sent as soon as the bridge was ready came back
REJECTED.)"""

from __future__ import annotations

import math
import time
from typing import Any

import pytest

from tests.ros.navharness import IdentityCorrection, StatusLog, TruthTrack, close_action_client, world_map_msg
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
NO_SERVER_FOR = 5.0  # wall s the server must stay down with the node running and no map


def test_the_action_server_waits_for_the_first_map(ros_master: RosMaster, rospy_node: Any) -> None:
    rospy = rospy_node
    import actionlib
    from geometry_msgs.msg import PoseStamped
    from move_base_msgs.msg import MoveBaseAction
    from nav_msgs.msg import OccupancyGrid

    with (
        ros_master.launch("simulation.launch", *MAX_RATE, "x:=-1.5", "y:=-1.5", "yaw:=0"),
        ros_master.launch("rrt_navigation.launch", "slam:=false", "seed:=4", "lockstep:=true"),
    ):
        truth = TruthTrack(rospy, "simple.world")
        status = StatusLog(rospy, "/rrt_navigation/status")
        correction = IdentityCorrection(rospy)
        client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
        goals = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=1)
        map_pub = rospy.Publisher("/map", OccupancyGrid, queue_size=1, latch=True)
        try:
            wait_for(lambda: status.has("idle"), 60.0, "the navigation node's idle status")
            wait_for(lambda: truth.last() is not None, 60.0, "ground truth from the simulator")
            wait_for(lambda: goals.get_num_connections() > 0, 60.0, "the navigation node on the rviz goal topic")
            rviz_goal = PoseStamped()  # sent before any map
            rviz_goal.header.frame_id = "map"
            rviz_goal.pose.position.x, rviz_goal.pose.position.y, rviz_goal.pose.orientation.w = -1.0, -1.5, 1.0
            goals.publish(rviz_goal)
            start = truth.last()
            # bounded in wall time: actionlib's own timeout counts sim time, which runs free here
            deadline = time.monotonic() + NO_SERVER_FOR
            while time.monotonic() < deadline:
                assert not client.wait_for_server(rospy.Duration(0.001)), "the action server is up without a map"
                time.sleep(0.05)
            now = truth.last()
            assert start is not None
            assert now is not None
            assert math.hypot(now[1] - start[1], now[2] - start[2]) < 0.01  # no map, no driving
            assert not any(m.startswith("refused:") for m in list(status.messages))

            map_pub.publish(world_map_msg(rospy, "simple.world", margin=1.0))
            wait_for(lambda: client.wait_for_server(rospy.Duration(0.001)), 60.0, "the action server after the map")
            # the rviz goal sent before the map is taken now
            wait_for(lambda: any(status.has(s) for s in ("reached", "failed", "refused")), 120.0, "the kept goal")
            assert status.has("reached"), status.messages
            end = truth.last()
            assert end is not None
            assert math.hypot(end[1] + 1.0, end[2] + 1.5) < 0.1, end  # the truth, within the odometry's drift
        finally:
            map_pub.unregister()
            close_action_client(client)
            goals.unregister()
            correction.close()
            status.close()
            truth.close()
