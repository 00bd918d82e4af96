"""The rosbags typestores the ROS 2 bridge's codec tests check against."""

from __future__ import annotations

from typing import Any

import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

TF_MESSAGE = "geometry_msgs/TransformStamped[] transforms"


def _with_tf(stores: Stores) -> Any:
    typestore = get_typestore(stores)
    if "tf2_msgs/msg/TFMessage" not in typestore.types:
        typestore.register(get_types_from_msg(TF_MESSAGE, "tf2_msgs/msg/TFMessage"))
    return typestore


@pytest.fixture(scope="module")
def store() -> Any:
    """ROS 1 Noetic's types (and tf2_msgs/TFMessage)."""
    return _with_tf(Stores.ROS1_NOETIC)


@pytest.fixture(scope="module")
def store2() -> Any:
    """ROS 2 Jazzy's types (and tf2_msgs/TFMessage)."""
    return _with_tf(Stores.ROS2_JAZZY)
