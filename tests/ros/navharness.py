"""Shared by the navigation integration tests: what the robot truly did, and what the nodes reported."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import numpy as np

from mrs_nav.maps.obstacles import Obstacles
from mrs_nav.maps.world import load_world
from tests.rosharness import REPO

FOOTPRINT_RADIUS = 0.105  # m, the simulated Burger's chassis


class TruthTrack:
    """Ground-truth positions (``/ground_truth/odom``) with their sim times, the simulator's contact count
    (``/ground_truth/contacts``) and the clearance to the world."""

    def __init__(self, rospy: Any, world: str) -> None:
        from nav_msgs.msg import Odometry
        from std_msgs.msg import UInt32

        self.obstacles = Obstacles.from_world(load_world(REPO / "worlds" / world))
        self._lock = threading.Lock()
        self.samples: list[tuple[float, float, float]] = []
        self.contacts = 0
        self.sub = rospy.Subscriber("/ground_truth/odom", Odometry, self._on_msg, queue_size=1000, tcp_nodelay=True)
        self.contacts_sub = rospy.Subscriber("/ground_truth/contacts", UInt32, self._on_contacts, queue_size=10)

    def _on_contacts(self, msg: Any) -> None:
        self.contacts = int(msg.data)

    def _on_msg(self, msg: Any) -> None:
        p = msg.pose.pose.position
        with self._lock:
            self.samples.append((msg.header.stamp.to_sec(), p.x, p.y))

    def array(self) -> np.ndarray:
        with self._lock:
            return np.array(self.samples).reshape(-1, 3)

    def last(self) -> tuple[float, float, float] | None:
        with self._lock:
            return self.samples[-1] if self.samples else None

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


def trajectory_lines(path: Path) -> list[list[float]]:
    return [[float(v) for v in line.split()] for line in path.read_text().splitlines() if not line.startswith("#")]
