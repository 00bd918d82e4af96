"""A move_base client of its own, as a user's script or a second terminal would be:
``python -m tests.ros.move_base_goal X Y`` waits for the ``move_base`` action server, sends a goal at (X, Y) in the
map frame (no heading), waits for the result and exits 0 when it is SUCCEEDED, 1 otherwise. It waits without
bounds: the test running it bounds it in wall time and reads its output (one line per step) when it fails."""

from __future__ import annotations

import sys

import actionlib
import rospy
from actionlib_msgs.msg import GoalStatus
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal


def main(x: float, y: float) -> int:
    rospy.init_node("move_base_goal", anonymous=True, disable_signals=True)
    client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
    client.wait_for_server()
    print("server found", flush=True)
    goal = MoveBaseGoal()
    goal.target_pose.header.frame_id = "map"
    goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = x, y
    goal.target_pose.pose.orientation.w = 1.0
    client.send_goal(goal)
    client.wait_for_result()
    state = client.get_state()
    print(f"result: {GoalStatus.to_string(state)}", flush=True)
    return 0 if state == GoalStatus.SUCCEEDED else 1


if __name__ == "__main__":
    sys.exit(main(float(sys.argv[1]), float(sys.argv[2])))
