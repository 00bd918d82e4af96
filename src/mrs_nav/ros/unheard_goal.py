"""One warning when an rviz 2D Nav Goal arrives and no navigation node listens for it.

``simulation.launch`` or ``slam.launch`` alone run no navigation: rviz's 2D Nav Goal then published to nobody,
and nothing moved or said why. The simulator (there whenever these run) subscribes to ``move_base_simple/goal``
itself; when a goal arrives and the master knows no other subscriber of it, it warns once, naming what to start.
"""

from __future__ import annotations

import rosgraph
import rospy
from geometry_msgs.msg import PoseStamped

ADVICE = (
    "start one: roslaunch mrs_nav rrt_navigation.launch sim:=false (on top of simulation.launch; on top of "
    "slam.launch add slam:=false), or navigation.launch sim:=false map_file:=MAP"
)


class UnheardGoalWarning:
    """Subscribes ``topic`` and warns once, as ``who``, when a goal on it reaches no other node."""

    def __init__(self, who: str, topic: str = "move_base_simple/goal") -> None:
        self._who = who
        self._topic = rospy.resolve_name(topic)
        self._warned = False
        self._sub = rospy.Subscriber(topic, PoseStamped, self._on_goal, queue_size=1)

    def _listeners(self) -> list[str]:
        """The nodes other than this one that subscribe to the topic, as the master knows them."""
        _pubs, subs, _srvs = rosgraph.Master(rospy.get_name()).getSystemState()
        nodes: list[str] = next((names for topic, names in subs if topic == self._topic), [])
        return [node for node in nodes if node != rospy.get_name()]

    def _on_goal(self, _msg: PoseStamped) -> None:
        if self._warned:
            return
        try:
            listeners = self._listeners()
        except (OSError, rosgraph.MasterException) as err:
            rospy.logdebug(f"{self._who}: cannot ask the master who listens on {self._topic}: {err}")
            return
        if not listeners:
            self._warned = True
            rospy.logwarn(
                f"{self._who}: a goal arrived on {self._topic} (rviz's 2D Nav Goal) but no navigation node "
                f"runs; {ADVICE}"
            )
