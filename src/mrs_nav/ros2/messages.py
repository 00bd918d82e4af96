"""ROS 2 message classes by ROS 1-style name, and the ROS 1 wire codec over them."""

from __future__ import annotations

import functools
import importlib
from collections.abc import Mapping
from typing import Any

from mrs_nav.bridge.ros1_codec import Ros1Codec


@functools.cache
def message_class(type_name: str) -> Any:
    """``"nav_msgs/Odometry"`` -> ``nav_msgs.msg.Odometry`` (``builtin_interfaces/Time`` likewise)."""
    package, _, name = type_name.partition("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


@functools.cache
def fields_of(type_name: str) -> Mapping[str, str]:
    fields: Mapping[str, str] = message_class(type_name).get_fields_and_field_types()
    return fields


def build(type_name: str, values: dict[str, Any]) -> Any:
    """The message with ``values``, which the codec decoded with the field types rclpy keeps: the setters'
    per-element checks (``ROS_PYTHON_CHECK_FIELDS``) would only repeat that, at most of a message's cost."""
    return message_class(type_name)(check_fields=False, **values)


def codec() -> Ros1Codec:
    return Ros1Codec(fields_of, build)
