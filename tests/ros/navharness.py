"""Shared by the navigation integration tests: what the robot truly did, and what the nodes reported."""

from __future__ import annotations

import math
import threading
import time
from typing import Any

import numpy as np

from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.rasterize import rasterize_world
from mrs_nav.maps.world import load_world
from tests.rosharness import REPO

FOOTPRINT_RADIUS = 0.105  # m, the simulated Burger's chassis


class TruthTrack:
    """Ground-truth positions (``/ground_truth/odom``) with their sim times, the simulator's contact count
    (``/ground_truth/contacts``) and the clearance to the world."""

    def __init__(self, rospy: Any, world: str, namespace: str = "") -> None:
        """``namespace``: a robot of several (``tb3_0``), whose topics are under ``/tb3_0/``."""
        from nav_msgs.msg import Odometry
        from std_msgs.msg import UInt32

        self.obstacles = Obstacles.from_world(load_world(REPO / "worlds" / world))
        self._lock = threading.Lock()
        self.samples: list[tuple[float, float, float]] = []
        self.yaws: list[float] = []
        self.contacts = 0
        prefix = f"/{namespace}" if namespace else ""
        self.sub = rospy.Subscriber(
            f"{prefix}/ground_truth/odom", Odometry, self._on_msg, queue_size=1000, tcp_nodelay=True
        )
        self.contacts_sub = rospy.Subscriber(
            f"{prefix}/ground_truth/contacts", UInt32, self._on_contacts, queue_size=10
        )

    def _on_contacts(self, msg: Any) -> None:
        self.contacts = int(msg.data)

    def _on_msg(self, msg: Any) -> None:
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
        with self._lock:
            self.samples.append((msg.header.stamp.to_sec(), p.x, p.y))
            self.yaws.append(yaw)

    def array(self) -> np.ndarray:
        with self._lock:
            return np.array(self.samples).reshape(-1, 3)

    def last(self) -> tuple[float, float, float] | None:
        with self._lock:
            return self.samples[-1] if self.samples else None

    def last_yaw(self) -> float:
        with self._lock:
            return self.yaws[-1]

    def since(self, t: float) -> np.ndarray:
        """The ``(t, x, y)`` samples stamped at or after sim time ``t``."""
        samples = self.array()
        return samples[samples[:, 0] >= t]

    def moved(self, start: float, end: float, timeout: float = 30.0) -> float:
        """How far (m) the robot got between sim times ``start`` and ``end``, once samples stamped past ``end``
        have arrived (this process's callbacks can lag the clock on a loaded machine)."""
        deadline = time.monotonic() + timeout
        while (last := self.last()) is None or last[0] < end:
            if time.monotonic() > deadline:
                raise AssertionError(f"no ground truth stamped after {end:.2f} s")
            time.sleep(0.05)
        samples = self.since(start)
        samples = samples[samples[:, 0] <= end]
        return float(math.hypot(*(samples[-1, 1:] - samples[0, 1:])))

    def min_clearance(self) -> float:
        """Smallest distance (m) from the robot's centre to an obstacle surface; below the footprint radius the
        chassis touched something."""
        xy = self.array()[:, 1:]
        return float(np.min(self.obstacles.signed_distance(xy))) if xy.size else float("inf")

    def close(self) -> None:
        self.sub.unregister()
        self.contacts_sub.unregister()


class StatusLog:
    """Every ``std_msgs/String`` status a node published, in order."""

    def __init__(self, rospy: Any, topic: str) -> None:
        from std_msgs.msg import String

        self._lock = threading.Lock()
        self.messages: list[str] = []
        self.sub = rospy.Subscriber(topic, String, self._on_msg, queue_size=100)

    def _on_msg(self, msg: Any) -> None:
        with self._lock:
            self.messages.append(msg.data)

    def has(self, state: str) -> bool:
        with self._lock:
            return any(m.startswith(f"{state}:") for m in self.messages)

    def close(self) -> None:
        self.sub.unregister()


def wait_for_move_base(rospy: Any, namespace: str = "", timeout: float = 120.0) -> None:
    """Until rrt_navigation's move_base action in ``namespace`` is up: it starts on the node's first map, so a goal
    sent after this is planned, not refused for want of a map (its status is published only once started)."""
    from actionlib_msgs.msg import GoalStatusArray

    rospy.wait_for_message(f"{namespace}/move_base/status", GoalStatusArray, timeout)  # wall seconds


def world_map_msg(rospy: Any, world: str, margin: float = 0.2) -> Any:
    """The map of a world file (0.05 m cells, free for ``margin`` m outside the walls) as a
    nav_msgs/OccupancyGrid."""
    from nav_msgs.msg import OccupancyGrid

    grid = rasterize_world(load_world(REPO / "worlds" / world), 0.05, margin=margin)
    msg = OccupancyGrid()
    msg.header.frame_id = "map"
    msg.header.stamp = rospy.Time.now()
    msg.info.resolution = grid.resolution
    msg.info.width, msg.info.height = grid.width, grid.height
    msg.info.origin.position.x, msg.info.origin.position.y = grid.origin[0], grid.origin[1]
    msg.info.origin.orientation.w = 1.0
    msg.data = grid.values.ravel().tolist()
    return msg


class IdentityCorrection:
    """map -> odom as SLAM would send it (identity: odometry starts at the true start pose), every 10 ms of wall
    time from a plain thread (a rospy.Timer dies when sim time jumps back between test modules; a static
    transform would outlive the module in the test process), dated ``ahead`` s of sim time in the future as SLAM
    does: at maximum rate 10 ms of wall time can be more sim time than the navigation's freshness limit.
    :meth:`stop` ends it, as a SLAM node that died."""

    ahead = 0.5

    def __init__(self, rospy: Any) -> None:
        import tf2_ros

        self.rospy = rospy
        self.broadcaster = tf2_ros.TransformBroadcaster()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        from geometry_msgs.msg import TransformStamped

        while not self._stop.wait(0.01):
            identity = TransformStamped()
            identity.header.stamp = self.rospy.Time.now() + self.rospy.Duration(self.ahead)
            identity.header.frame_id, identity.child_frame_id = "map", "odom"
            identity.transform.rotation.w = 1.0
            self.broadcaster.sendTransform(identity)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()

    def close(self) -> None:
        self.stop()
        self.broadcaster.pub_tf.unregister()


def close_action_client(client: Any) -> None:
    """Unregister a SimpleActionClient's topics, which actionlib leaves to the process's end."""
    inner = client.action_client
    for topic in (inner.pub_goal, inner.pub_cancel, inner.status_sub, inner.result_sub, inner.feedback_sub):
        topic.unregister()
