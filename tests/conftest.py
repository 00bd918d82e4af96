"""Shared fixtures: a real ROS master for tests marked ``ros``, and repository paths."""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, settings

from mrs_nav.jit import warm
from tests.rosharness import REPO, RosMaster

# Kernel caches fresh for the sources under test before any test imports a kernel (see mrs_nav.jit).
warm()

WORLDS = REPO / "worlds"
# what rospy itself keeps registered for the test node: its log and, on sim time, the clock
_NODE_TOPICS = {"/rosout", "/clock"}

# Property tests are derandomised (the same examples every run, so CI never flakes) and carry no deadline or
# speed health check: the 2-core machines run ROS processes beside them and timing is not what they test.
settings.register_profile(
    "mrs_nav", derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow], print_blob=True
)
settings.load_profile("mrs_nav")


def _interrupt(signum: int, _frame: object) -> None:
    raise KeyboardInterrupt(f"signal {signum}")


@pytest.fixture(scope="session")
def ros_master(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RosMaster]:
    """One roscore on a free port for the session, shut down at the end.

    A SIGTERM to pytest becomes an interrupt, so that the session's teardown still ends every process the tests
    launched: killed outright, pytest left its launches' simulators running at maximum rate."""
    previous = signal.signal(signal.SIGTERM, _interrupt)
    master = RosMaster(tmp_path_factory.mktemp("ros"))
    try:
        yield master
    finally:
        master.close()
        signal.signal(signal.SIGTERM, previous)


@pytest.fixture(scope="session")
def rospy_node(ros_master: RosMaster) -> Any:
    """The test process joined to the session's master as an anonymous node on sim time."""
    import rospy

    os.environ["ROS_MASTER_URI"] = ros_master.uri
    os.environ["ROS_IP"] = "127.0.0.1"
    rospy.set_param("/use_sim_time", True)
    rospy.init_node("pytest", anonymous=True, disable_signals=True)
    return rospy


def _registered_topics() -> set[str]:
    """Topics the test node has publishers or subscribers on (none if this process never joined ROS)."""
    rospy = sys.modules.get("rospy")  # not imported here: modules without ROS must not load it
    if rospy is None or not rospy.core.is_initialized():
        return set()
    from rospy.impl.registration import get_topic_manager

    manager = get_topic_manager()
    return {name for name, _ in manager.get_publications() + manager.get_subscriptions()} - _NODE_TOPICS


@pytest.fixture(scope="module", autouse=True)
def no_leaked_topics() -> Iterator[None]:
    """Fail a test module that leaves topics registered in the shared test node.

    Every ROS test module shares one master and one test node, so a publisher a module forgets outlives it: a
    latched one hands its last message to every node later modules launch (a NaN scan reached a later SLAM node
    this way), and any handle left open keeps the latch of the whole topic alive in this process."""
    before = _registered_topics()
    yield
    leaked = sorted(_registered_topics() - before)
    assert not leaked, f"topics left registered by this module: {leaked}"


@pytest.fixture
def simple_world() -> Path:
    return WORLDS / "simple.world"
