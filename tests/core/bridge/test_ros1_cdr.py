"""ROS 1 bytes rewritten to CDR (the ROS 2 bridge's hot path) against rosbags' own CDR serialiser, which zeroes
its padding as the rewrite does (tests/ros/test_ros2_cdr.py checks against rclpy's)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from mrs_nav.bridge.ros1_cdr import Ros1ToCdr
from mrs_nav.errors import InvalidInputError
from tests.core.bridge.test_ros2_link import FIELDS, grid_msg, header, make, pose, serialized


def as_ros2(store2: Any, value: Any) -> Any:
    """The rosbags ROS 2 message of a ROS 1 one (Header without seq)."""
    if not hasattr(value, "__msgtype__"):
        return [as_ros2(store2, v) for v in value] if isinstance(value, list) else value
    fields = {k: as_ros2(store2, getattr(value, k)) for k in value.__dataclass_fields__ if k not in ("__msgtype__",)}
    if value.__msgtype__ == "std_msgs/msg/Header":
        fields.pop("seq")
    return store2.types[value.__msgtype__](**fields)


def rewritten_is_cdr(store: Any, store2: Any, type_name: str, msg: Any) -> None:
    cdr = Ros1ToCdr(FIELDS.__getitem__).transcode(type_name, serialized(store, type_name, msg))
    expected = bytes(store2.serialize_cdr(as_ros2(store2, msg), type_name.replace("/", "/msg/")))
    assert cdr == expected


@pytest.mark.parametrize(("frame", "ranges", "intensities"), [("base_scan", 360, 360), ("", 0, 0), ("ab", 3, 0),
                                                              ("abc", 0, 1), ("l", 5, 2)])  # fmt: skip
def test_a_scan_is_rewritten_as_cdr(store: Any, store2: Any, frame: str, ranges: int, intensities: int) -> None:
    scan = make(store, "sensor_msgs/LaserScan", header(store, frame, 41), -3.1, 3.1, 0.0175, 0.0, 0.2, 0.12, 3.5,
                np.linspace(0.1, 3.5, ranges, dtype=np.float32), np.ones(intensities, np.float32))  # fmt: skip
    rewritten_is_cdr(store, store2, "sensor_msgs/LaserScan", scan)


@pytest.mark.parametrize(("width", "height"), [(0, 0), (3, 1), (7, 3), (384, 384)])
def test_a_map_is_rewritten_as_cdr(store: Any, store2: Any, width: int, height: int) -> None:
    data = [(i % 102) - 1 for i in range(width * height)]
    rewritten_is_cdr(store, store2, "nav_msgs/OccupancyGrid", grid_msg(store, width, height, data))


@pytest.mark.parametrize("children", [(), ("base_footprint",), ("a", "", "odd_name")])
def test_transforms_are_rewritten_as_cdr(store: Any, store2: Any, children: tuple[str, ...]) -> None:
    def transform(index: int, child: str) -> Any:
        vector = make(store, "geometry_msgs/Vector3", 0.1 * index, 0.0, 0.0)
        value = make(store, "geometry_msgs/Transform", vector, make(store, "geometry_msgs/Quaternion", 0, 0, 0, 1))
        return make(store, "geometry_msgs/TransformStamped", header(store, "odom" * index), child, value)

    tf = make(store, "tf2_msgs/TFMessage", [transform(i, c) for i, c in enumerate(children)])
    rewritten_is_cdr(store, store2, "tf2_msgs/TFMessage", tf)


def test_a_pose_with_covariance_is_rewritten_as_cdr(store: Any, store2: Any) -> None:
    covariance = make(store, "geometry_msgs/PoseWithCovariance", pose(store, 0.5, 1.5), np.arange(36, dtype=np.float64))
    stamped = make(store, "geometry_msgs/PoseWithCovarianceStamped", header(store, "map"), covariance)
    rewritten_is_cdr(store, store2, "geometry_msgs/PoseWithCovarianceStamped", stamped)


@pytest.mark.parametrize("cut", [1, 10, 40])
def test_truncated_or_padded_bytes_are_refused_with_the_type(store: Any, cut: int) -> None:
    data = serialized(store, "nav_msgs/OccupancyGrid", grid_msg(store, 2, 2, [0, 0, 0, 0]))
    cdr = Ros1ToCdr(FIELDS.__getitem__)
    with pytest.raises(InvalidInputError, match="nav_msgs/OccupancyGrid"):
        cdr.transcode("nav_msgs/OccupancyGrid", data[:-cut])
    with pytest.raises(InvalidInputError, match="left after"):
        cdr.transcode("nav_msgs/OccupancyGrid", data + b"\0" * cut)


def test_an_absurd_sequence_length_or_a_bad_string_is_refused() -> None:
    cdr = Ros1ToCdr(FIELDS.__getitem__)
    with pytest.raises(InvalidInputError, match="items announced"):
        cdr.transcode("tf2_msgs/TFMessage", b"\xff\xff\xff\x7f")
    bad_frame = b"\0" * 12 + b"\x02\0\0\0\xff\xfe"  # a header whose frame_id is not UTF-8
    with pytest.raises(InvalidInputError, match="std_msgs/Header"):
        cdr.transcode("std_msgs/Header", bad_frame)
