"""A 2D Nav Goal where no navigation runs says so once: ``simulation.launch`` alone, a goal on
/move_base_simple/goal went to nobody and nothing said why. The simulator warns once (on /rosout) when a goal
arrives that no other node listens for, and not while one does."""

from __future__ import annotations

import time
from typing import Any

import pytest

from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros


def test_a_goal_nobody_listens_for_is_warned_of_once(ros_master: RosMaster, rospy_node: Any) -> None:
    rospy = rospy_node
    from geometry_msgs.msg import PoseStamped
    from rosgraph_msgs.msg import Log

    warnings: list[str] = []

    def on_log(msg: Log) -> None:
        if msg.level == Log.WARN and "no navigation node runs" in msg.msg:
            warnings.append(msg.msg)

    rosout = rospy.Subscriber("/rosout", Log, on_log, queue_size=100)
    goals = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=10)
    goal = PoseStamped()
    goal.header.frame_id = "map"
    goal.pose.orientation.w = 1.0
    try:
        with ros_master.launch("simulation.launch", "real_time_factor:=0"):
            wait_for(lambda: goals.get_num_connections() > 0, 60.0, "the simulator on /move_base_simple/goal")
            # a navigation stand-in listening: the goal is heard, no warning
            listener = rospy.Subscriber("/move_base_simple/goal", PoseStamped, lambda _m: None, queue_size=1)
            wait_for(lambda: goals.get_num_connections() > 1, 30.0, "the second subscriber")
            goals.publish(goal)
            time.sleep(2.0)  # wall time: the warning would come at once (the simulator asks the master, no sim time)
            assert warnings == []
            listener.unregister()
            wait_for(lambda: goals.get_num_connections() == 1, 30.0, "the listener gone")
            for _ in range(3):
                goals.publish(goal)
                time.sleep(0.3)
            wait_for(lambda: bool(warnings), 30.0, "the simulator's warning")
            time.sleep(1.0)
    finally:
        rosout.unregister()
        goals.unregister()
    assert len(warnings) == 1, warnings
    assert "/move_base_simple/goal" in warnings[0]
    assert "rrt_navigation.launch sim:=false" in warnings[0]
