"""The launch files compose as TurtleBot3's do: ``simulation.launch``, then ``slam.launch sim:=false`` on the same
master. A second robot_state_publisher used to replace the first ("new node registered with same name"), both
died, nothing published /tf_static and SLAM dropped every scan."""

from __future__ import annotations

import xmlrpc.client
from typing import Any

import pytest

from tests.ros.test_slam_node import Latest
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros


def _publishers(master_uri: str, topic: str) -> list[str]:
    _, _, (publishers, _, _) = xmlrpc.client.ServerProxy(master_uri).getSystemState("/pytest")
    return next((nodes for name, nodes in publishers if name == topic), [])


def test_slam_sim_false_on_top_of_simulation_gives_one_robot_state_publisher_tf_static_and_a_map(
    ros_master: RosMaster, rospy_node: Any
) -> None:
    rospy = rospy_node
    from nav_msgs.msg import OccupancyGrid
    from tf2_msgs.msg import TFMessage

    statics: list[str] = []
    tf_static = rospy.Subscriber(
        "/tf_static", TFMessage, lambda m: statics.extend(t.child_frame_id for t in m.transforms), queue_size=10
    )
    grid = Latest(rospy, "/map", OccupancyGrid)
    try:
        with ros_master.launch("simulation.launch", "real_time_factor:=2") as sim:
            wait_for(lambda: _publishers(ros_master.uri, "/tf_static") != [], 60.0, "the simulation's /tf_static")
            with ros_master.launch("slam.launch", "sim:=false", "open_rviz:=false") as slam:
                wait_for(lambda: grid.msg is not None, 90.0, "a /map from SLAM")
                wait_for(lambda: sum(v >= 0 for v in grid.msg.data) > 1000, 60.0, "a map of the scans")
                assert sim.poll() is None
                assert slam.poll() is None
                assert _publishers(ros_master.uri, "/tf_static") == ["/robot_state_publisher"]
                assert "base_scan" in statics
    finally:
        tf_static.unregister()
        grid.sub.unregister()
