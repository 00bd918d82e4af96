"""Malformed messages into the potential-field stack (simulator + potential_field_navigation taking its obstacles
from the laser, one real roslaunch): the node drops each with a warning on /rosout and lives on, and still
obeys the next good goal."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from tests.ros.test_malformed_messages import MAX_RATE, Stack, _goal, _scan, inject, launch_stack
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros

NODE = "/potential_field_navigation"
NODES = ("/simulator", NODE)

CASES: dict[str, tuple[str, Callable[[Any], Any]]] = {
    "scan NaN angle_max": ("/scan", lambda r: _scan(r, angle_max=math.nan)),
    "scan inf range_max": ("/scan", lambda r: _scan(r, range_max=math.inf)),
    "scan empty ranges": ("/scan", lambda r: _scan(r, ranges=[])),
    "scan all NaN ranges": ("/scan", lambda r: _scan(r, ranges=[math.nan] * 360)),
    "scan wrong length": ("/scan", lambda r: _scan(r, ranges=[1.0] * 17)),
    "scan unknown frame": ("/scan", lambda r: _scan(r, frame_id="nowhere")),
    "goal NaN": ("/move_base_simple/goal", lambda r: _goal(r, math.nan, 0.0)),
    "goal inf": ("/move_base_simple/goal", lambda r: _goal(r, math.inf, 1.0)),
    "goal unknown frame": ("/move_base_simple/goal", lambda r: _goal(r, 0.5, 0.5, "nowhere")),
}


@pytest.fixture(scope="module")
def pf_stack(ros_master: RosMaster, rospy_node: Any) -> Iterator[Stack]:
    from geometry_msgs.msg import PoseStamped
    from sensor_msgs.msg import LaserScan

    topics = {"/scan": LaserScan, "/move_base_simple/goal": PoseStamped}
    args = (*MAX_RATE, "obstacles:=scan", "seed:=5")

    def ready(stack: Stack) -> bool:
        return bool(stack.alive(NODE) and stack.rospy.get_time() > 1.0)

    with launch_stack(ros_master, rospy_node, "potential_field_navigation.launch", args, topics, ready=ready) as stack:
        yield stack


@pytest.mark.parametrize("case", list(CASES))
def test_a_malformed_message_is_dropped_with_a_warning(pf_stack: Stack, case: str) -> None:
    topic, make = CASES[case]
    inject(pf_stack, case, topic, NODE, make, nodes=NODES)


def test_a_good_goal_after_the_bad_ones_is_taken(pf_stack: Stack) -> None:
    from std_msgs.msg import String

    statuses: list[str] = []
    sub = pf_stack.rospy.Subscriber("/potential_field_navigation/status", String, lambda m: statuses.append(m.data))
    try:
        pf_stack.publishers["/move_base_simple/goal"].publish(_goal(pf_stack.rospy, -1.0, -1.5, "odom"))
        wait_for(lambda: any("accepted" in s for s in statuses), 30.0, "the good goal accepted")
    finally:
        sub.unregister()
