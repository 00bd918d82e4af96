"""Making sim time go back under running nodes, on purpose, and watching that they go on publishing.

:class:`ClockJumper` pauses the simulator (SIGSTOP) around one /clock message published from this process, as
``rostopic pub -1 /clock`` does: the clock then stays where that message put it for :data:`HOLD_S` wall seconds,
long enough for every node to see it, instead of racing the simulator's next tick; the simulator then goes on from
its own time. A message 1 s behind the simulator is a jump back by 1 s (and then forward again); a message 10 s or
185 s ahead is, when the simulator resumes, a jump back by 10 s or 185 s (185 s: what a simulator restarted under
the nodes does). The simulator's own time never jumps, so the scans it simulates are counted as before.

:class:`Activity` records when what the nodes publish arrives: map -> odom on /tf, /map, /amcl_pose and a moving
/cmd_vel. Used by the clock-jump tests and by ``mrs-nav bench soak``.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable
from typing import Any

import rosgraph
import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from nav_msgs.msg import OccupancyGrid
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage

from mrs_nav.ros_processes import node_pid

#: Wall s the paused clock stands at the published time: every node's timers and callbacks see it.
HOLD_S = 1.5
#: Wall s the simulator's last messages get to arrive once it is paused.
SETTLE_S = 0.2


class ClockJumper:
    """Publishes one /clock message while the simulator is paused (see the module's docstring)."""

    def __init__(self, simulator: str = "/simulator", subscribers: int = 3) -> None:
        """``simulator``: the node to pause; ``subscribers``: how many nodes must hear this /clock first."""
        self.simulator, self.subscribers = simulator, subscribers
        self.pub = rospy.Publisher("/clock", Clock, queue_size=1)

    def jump(self, offset_s: float, timeout: float = 10.0) -> float:
        """Pause the simulator, publish its time plus ``offset_s``, hold it, resume; the monotonic wall time of the
        resumption."""
        pid = node_pid(rosgraph.get_master_uri(), self.simulator)
        deadline = time.monotonic() + timeout
        while self.pub.get_num_connections() < self.subscribers:
            if time.monotonic() > deadline:
                raise TimeoutError(f"fewer than {self.subscribers} nodes subscribed this /clock in {timeout:.0f} s")
            time.sleep(0.05)
        os.kill(pid, signal.SIGSTOP)
        try:
            time.sleep(SETTLE_S)
            at = rospy.get_time() + offset_s
            self.pub.publish(Clock(clock=rospy.Time.from_sec(at)))
            time.sleep(HOLD_S)
        finally:
            os.kill(pid, signal.SIGCONT)
        return time.monotonic()

    def close(self) -> None:
        self.pub.unregister()


class Activity:
    """Wall arrival times of what the nodes publish: map -> odom on /tf, /map, /amcl_pose, a moving /cmd_vel."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.arrivals: dict[str, list[float]] = {"map->odom": [], "/map": [], "/amcl_pose": [], "/cmd_vel": []}
        self.subs = [
            rospy.Subscriber("/tf", TFMessage, self._on_tf, queue_size=1000),
            rospy.Subscriber("/map", OccupancyGrid, self._note("/map"), queue_size=1),
            rospy.Subscriber("/amcl_pose", PoseWithCovarianceStamped, self._note("/amcl_pose"), queue_size=10),
            rospy.Subscriber("/cmd_vel", Twist, self._on_cmd_vel, queue_size=100),
        ]

    def _add(self, what: str) -> None:
        with self._lock:
            self.arrivals[what].append(time.monotonic())

    def _note(self, what: str) -> Callable[[Any], None]:
        return lambda _msg: self._add(what)

    def _on_tf(self, msg: TFMessage) -> None:
        if any(t.header.frame_id.lstrip("/") == "map" and t.child_frame_id == "odom" for t in msg.transforms):
            self._add("map->odom")

    def _on_cmd_vel(self, msg: Twist) -> None:
        if msg.linear.x != 0.0 or msg.angular.z != 0.0:
            self._add("/cmd_vel")

    def since(self, wall: float) -> dict[str, int]:
        """How many of each arrived after the monotonic wall time ``wall``."""
        with self._lock:
            return {what: sum(t > wall for t in times) for what, times in self.arrivals.items()}

    def close(self) -> None:
        for sub in self.subs:
            sub.unregister()
