"""Shared fixtures: a real ROS master for tests marked ``ros``, and repository paths."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, settings

from tests.rosharness import REPO, RosMaster

WORLDS = REPO / "worlds"

# Property tests are derandomised (the same examples every run, so CI never flakes) and carry no deadline or
# speed health check: the 2-core machines run ROS processes beside them and timing is not what they test.
settings.register_profile(
    "mrs_nav", derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow], print_blob=True
)
settings.load_profile("mrs_nav")


@pytest.fixture(scope="session")
def ros_master(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RosMaster]:
    """One roscore on a free port for the session, shut down at the end."""
    master = RosMaster(tmp_path_factory.mktemp("ros"))
    yield master
    master.close()


@pytest.fixture(scope="session")
def rospy_node(ros_master: RosMaster) -> Any:
    """The test process joined to the session's master as an anonymous node on sim time."""
    import rospy

    os.environ["ROS_MASTER_URI"] = ros_master.uri
    os.environ["ROS_IP"] = "127.0.0.1"
    rospy.set_param("/use_sim_time", True)
    rospy.init_node("pytest", anonymous=True, disable_signals=True)
    return rospy


@pytest.fixture
def simple_world() -> Path:
    return WORLDS / "simple.world"
