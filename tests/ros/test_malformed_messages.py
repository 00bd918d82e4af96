"""Malformed messages into the running stack (simulator + SLAM + RRT* navigation, one real roslaunch): for each
class of bad message (NaN / inf fields, empty arrays, wrong frame ids, huge arrays, wrong lengths) every node
stays alive, SLAM's map keeps what it knew, and the node that dropped the message said so on /rosout."""

from __future__ import annotations

import contextlib
import math
import threading
import time
import xmlrpc.client
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import pytest

from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

MAX_RATE = ("real_time_factor:=0", "lockstep:=true")
NODES = ("/simulator", "/slam", "/rrt_navigation")
WARN = 4  # rosgraph_msgs/Log level


@dataclass
class Stack:
    """The running launch and what the test process hears from it."""

    rospy: Any
    master: RosMaster
    proc: Any
    logs: list[tuple[float, str, int, str]]  # (wall time, node, level, text)
    maps: list[Any]  # SLAM's own /map messages
    lock: threading.Lock
    publishers: dict[str, Any]

    def known_cells(self) -> int:
        with self.lock:
            return sum(1 for v in self.maps[-1].data if v >= 0) if self.maps else 0

    def warned_since(self, node: str, since: float) -> list[str]:
        with self.lock:
            return [text for t, name, level, text in self.logs if name == node and level >= WARN and t >= since]

    def alive(self, node: str) -> bool:
        code, _, uri = xmlrpc.client.ServerProxy(self.master.uri).lookupNode("/pytest", node)
        if code != 1:
            return False
        try:
            return bool(xmlrpc.client.ServerProxy(uri).getPid("/pytest")[0] == 1)
        except OSError:
            return False


@contextlib.contextmanager
def launch_stack(
    master: RosMaster,
    rospy: Any,
    launch: str,
    args: tuple[str, ...],
    topics: dict[str, Any],
    *,
    ready: Callable[[Stack], bool],
) -> Iterator[Stack]:
    """``launch`` running with ``args``, a publisher per entry of ``topics`` (topic -> message class) connected to
    it, /rosout_agg and SLAM's /map heard, once ``ready(stack)``."""
    from nav_msgs.msg import OccupancyGrid
    from rosgraph_msgs.msg import Log

    lock = threading.Lock()
    logs: list[tuple[float, str, int, str]] = []
    maps: list[Any] = []

    def on_log(msg: Any) -> None:
        with lock:
            logs.append((time.monotonic(), msg.name, msg.level, msg.msg))

    def on_map(msg: Any) -> None:
        if msg._connection_header.get("callerid") == "/slam":  # not the test's own malformed maps
            with lock:
                maps.append(msg)

    subs = [
        rospy.Subscriber("/rosout_agg", Log, on_log, queue_size=1000),
        rospy.Subscriber("/map", OccupancyGrid, on_map, queue_size=5),
    ]
    publishers = {topic: rospy.Publisher(topic, kind, queue_size=10) for topic, kind in topics.items()}
    try:
        with master.launch(launch, *args) as proc:
            stack = Stack(rospy, master, proc, logs, maps, lock, publishers)
            wait_for(lambda: proc.poll() is not None or ready(stack), 90.0, f"{launch} to be ready")
            assert proc.poll() is None, "roslaunch exited"
            for topic, pub in publishers.items():
                wait_for(lambda pub=pub: pub.get_num_connections() > 0, 30.0, f"a subscriber of {topic}")
            yield stack
    finally:
        for sub in subs:
            sub.unregister()
        for pub in publishers.values():
            pub.unregister()


@pytest.fixture(scope="module")
def stack(ros_master: RosMaster, rospy_node: Any) -> Iterator[Stack]:
    from geometry_msgs.msg import PoseStamped, Twist
    from nav_msgs.msg import OccupancyGrid
    from sensor_msgs.msg import LaserScan

    topics = {"/scan": LaserScan, "/move_base_simple/goal": PoseStamped, "/map": OccupancyGrid, "/cmd_vel": Twist}
    args = (*MAX_RATE, "rviz:=false", "seed:=5")
    with launch_stack(
        ros_master, rospy_node, "rrt_navigation.launch", args, topics, ready=lambda s: len(s.maps) >= 2
    ) as running:
        yield running


# ---- the malformed messages ------------------------------------------------------------------------------------


def _scan(rospy: Any, **fields: Any) -> Any:
    from sensor_msgs.msg import LaserScan

    msg = LaserScan()
    msg.header.stamp = rospy.Time.now()
    msg.header.frame_id = "base_scan"
    msg.angle_min, msg.angle_max = 0.0, 2.0 * math.pi * 359 / 360
    msg.angle_increment = 2.0 * math.pi / 360
    msg.range_min, msg.range_max = 0.12, 3.5
    msg.ranges = [1.0] * 360
    for name, value in fields.items():
        if name == "frame_id":
            msg.header.frame_id = value
        else:
            setattr(msg, name, value)
    return msg


def _goal(rospy: Any, x: float, y: float, frame: str = "map") -> Any:
    from geometry_msgs.msg import PoseStamped

    msg = PoseStamped()
    msg.header.stamp = rospy.Time(0)
    msg.header.frame_id = frame
    msg.pose.position.x, msg.pose.position.y = x, y
    msg.pose.orientation.w = 1.0
    return msg


def _map(rospy: Any, width: int, height: int, data: list[int], resolution: float = 0.05) -> Any:
    from nav_msgs.msg import OccupancyGrid

    msg = OccupancyGrid()
    msg.header.stamp = rospy.Time.now()
    msg.header.frame_id = "map"
    msg.info.width, msg.info.height, msg.info.resolution = width, height, resolution
    msg.info.origin.orientation.w = 1.0
    msg.data = data
    return msg


def _twist(x: float, z: float) -> Any:
    from geometry_msgs.msg import Twist

    msg = Twist()
    msg.linear.x, msg.angular.z = x, z
    return msg


Case = tuple[str, str | None, Callable[[Any], Any]]  # topic, node expected to warn (None: none), message factory
CASES: dict[str, Case] = {
    "scan NaN angle_max": ("/scan", "/slam", lambda r: _scan(r, angle_max=math.nan)),
    "scan inf angle_increment": ("/scan", "/slam", lambda r: _scan(r, angle_increment=math.inf)),
    "scan empty ranges": ("/scan", "/slam", lambda r: _scan(r, ranges=[])),
    "scan all NaN ranges": ("/scan", "/slam", lambda r: _scan(r, ranges=[math.nan] * 360)),
    "scan all negative ranges": ("/scan", "/slam", lambda r: _scan(r, ranges=[-1.0] * 360)),
    "scan wrong length": ("/scan", "/slam", lambda r: _scan(r, ranges=[1.0] * 17)),
    "scan huge array": ("/scan", "/slam", lambda r: _scan(r, ranges=[1.0] * 1_000_000)),
    "scan unknown frame": ("/scan", "/slam", lambda r: _scan(r, frame_id="nowhere")),
    # tf knows base_link: the scan may be transformed and used, but must not start a new map
    "scan in another known frame": ("/scan", None, lambda r: _scan(r, frame_id="base_link")),
    "goal NaN": ("/move_base_simple/goal", "/rrt_navigation", lambda r: _goal(r, math.nan, 0.0)),
    "goal inf": ("/move_base_simple/goal", "/rrt_navigation", lambda r: _goal(r, math.inf, 1.0)),
    "goal unknown frame": ("/move_base_simple/goal", "/rrt_navigation", lambda r: _goal(r, 0.5, 0.5, "nowhere")),
    "map wrong length": ("/map", "/rrt_navigation", lambda r: _map(r, 10, 10, [0] * 7)),
    "map empty": ("/map", "/rrt_navigation", lambda r: _map(r, 0, 0, [])),
    "map NaN resolution": ("/map", "/rrt_navigation", lambda r: _map(r, 2, 2, [0] * 4, math.nan)),
    "map huge dimensions": ("/map", "/rrt_navigation", lambda r: _map(r, 1_000_000, 1_000_000, [0] * 4)),
    "cmd_vel NaN": ("/cmd_vel", "/simulator", lambda r: _twist(math.nan, 0.0)),
    "cmd_vel inf": ("/cmd_vel", "/simulator", lambda r: _twist(0.0, math.inf)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_malformed_message_is_dropped_with_a_warning(stack: Stack, case: str) -> None:
    topic, node, make = CASES[case]
    before = stack.known_cells()
    assert before > 0
    inject(stack, case, topic, node, make, nodes=NODES)
    assert stack.known_cells() >= 0.95 * before, f"{case}: known cells {before} -> {stack.known_cells()}"


def inject(
    stack: Stack, case: str, topic: str, node: str | None, make: Callable[[Any], Any], *, nodes: tuple[str, ...]
) -> None:
    """Publish the malformed message until ``node`` warns about it (or 2 s when no warning is due), give the stack
    3 sim seconds to choke on it, then check that roslaunch and every one of ``nodes`` still run."""
    rospy = stack.rospy
    since = time.monotonic()
    # Warnings are throttled (one per 5 s of sim time per kind), so repeat the message until one is heard.
    deadline = since + (60.0 if node else 2.0)
    while not (node and stack.warned_since(node, since)) and time.monotonic() < deadline:
        stack.publishers[topic].publish(make(rospy))
        time.sleep(0.1)
    if node:
        assert stack.warned_since(node, since), f"{node} logged no warning for {case}"
    # Give SLAM a few sim seconds to process scans (and publish a map, were it to start a new one), then hold
    # its latest map to what it knew.
    resume = rospy.get_time() + 3.0
    wait_for(lambda: rospy.get_time() > resume, 60.0, "3 s of sim time after the malformed message")
    assert stack.proc.poll() is None, "roslaunch exited"
    for name in nodes:
        assert stack.alive(name), f"{name} died on {case}"
