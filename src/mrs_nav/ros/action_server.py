"""An actionlib ``ActionServer`` that takes a goal whose id repeats a finished goal's as a new goal.

actionlib ignores, without a word, any goal whose id is still in its status list (finished goals stay there for
``status_list_timeout``, 5 s of ROS time). Its clients make ids from the node's name, a per-process count and the
ROS time: a script run twice under the same node name (the ROS wiki's SendingSimpleGoals), whose ``send_goal``
comes before the first ``/clock`` message has reached it (``wait_for_server`` returns on the latched status, which
can come first), sends ``<name>-1-0.000`` both times. The second goal was then dropped, and its client, seeing
that id finished in the status list, waited for a result that never came. An actionlib client publishes each
goal once, so a repeat of a finished goal's id is such a new goal: the old entry is dropped and the goal is taken.
A repeat of a goal still pending or active is left to actionlib (it stays ignored, as before).
"""

from __future__ import annotations

from typing import Any

import actionlib
import rospy
from actionlib_msgs.msg import GoalStatus

FINISHED = frozenset(
    {GoalStatus.PREEMPTED, GoalStatus.SUCCEEDED, GoalStatus.ABORTED, GoalStatus.REJECTED, GoalStatus.RECALLED}
)


class RepeatedIdActionServer(actionlib.ActionServer):  # type: ignore[misc]
    """``actionlib.ActionServer`` taking a goal whose id repeats a finished goal's (module docstring)."""

    def internal_goal_callback(self, goal: Any) -> None:
        with self.lock:  # actionlib's re-entrant lock: the base class takes it again
            repeats = [
                st
                for st in self.status_list
                if st.status.goal_id.id == goal.goal_id.id and st.status.status in FINISHED
            ]
            for st in repeats:
                self.status_list.remove(st)
        if repeats:
            rospy.logwarn(
                f"{rospy.get_name()}: goal id {goal.goal_id.id!r} repeats a finished goal's (a client that sent it "
                "before its first /clock message?): taken as a new goal"
            )
        super().internal_goal_callback(goal)
