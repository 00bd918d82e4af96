"""The ROS 2 bridge's core: ROS 1 wire codec (checked against rosbags' serialiser), pipe frames, configuration."""

from __future__ import annotations

import io
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from mrs_nav.bridge.ros1_codec import Ros1Codec
from mrs_nav.bridge.ros2_link import (
    MAX_FRAME_BYTES,
    Ros2BridgeConfig,
    child_environment,
    encode_frame,
    package_root,
    read_frame,
    ros2_python,
)
from mrs_nav.errors import InvalidInputError

# The ROS 2 descriptions (Msg.get_fields_and_field_types()) of the types used here, as rclpy gives them.
FIELDS: dict[str, dict[str, str]] = {
    "std_msgs/Header": {"stamp": "builtin_interfaces/Time", "frame_id": "string"},
    "builtin_interfaces/Time": {"sec": "int32", "nanosec": "uint32"},
    "geometry_msgs/Point": {"x": "double", "y": "double", "z": "double"},
    "geometry_msgs/Vector3": {"x": "double", "y": "double", "z": "double"},
    "geometry_msgs/Quaternion": {"x": "double", "y": "double", "z": "double", "w": "double"},
    "geometry_msgs/Pose": {"position": "geometry_msgs/Point", "orientation": "geometry_msgs/Quaternion"},
    "geometry_msgs/Transform": {"translation": "geometry_msgs/Vector3", "rotation": "geometry_msgs/Quaternion"},
    "geometry_msgs/TransformStamped": {
        "header": "std_msgs/Header",
        "child_frame_id": "string",
        "transform": "geometry_msgs/Transform",
    },
    "tf2_msgs/TFMessage": {"transforms": "sequence<geometry_msgs/TransformStamped>"},
    "geometry_msgs/PoseWithCovariance": {"pose": "geometry_msgs/Pose", "covariance": "double[36]"},
    "geometry_msgs/PoseWithCovarianceStamped": {
        "header": "std_msgs/Header",
        "pose": "geometry_msgs/PoseWithCovariance",
    },
    "sensor_msgs/LaserScan": {
        "header": "std_msgs/Header",
        "angle_min": "float",
        "angle_max": "float",
        "angle_increment": "float",
        "time_increment": "float",
        "scan_time": "float",
        "range_min": "float",
        "range_max": "float",
        "ranges": "sequence<float>",
        "intensities": "sequence<float>",
    },
    "nav_msgs/MapMetaData": {
        "map_load_time": "builtin_interfaces/Time",
        "resolution": "float",
        "width": "uint32",
        "height": "uint32",
        "origin": "geometry_msgs/Pose",
    },
    "nav_msgs/OccupancyGrid": {"header": "std_msgs/Header", "info": "nav_msgs/MapMetaData", "data": "sequence<int8>"},
}


def codec() -> Ros1Codec:
    return Ros1Codec(FIELDS.__getitem__, lambda _type, values: SimpleNamespace(**values))


def make(store: Any, type_name: str, *args: Any, **kwargs: Any) -> Any:
    """A rosbags message of ``type_name`` (``nav_msgs/Odometry`` style)."""
    return store.types[type_name.replace("/", "/msg/")](*args, **kwargs)


def serialized(store: Any, type_name: str, msg: Any) -> bytes:
    return bytes(store.serialize_ros1(msg, type_name.replace("/", "/msg/")))


def header(store: Any, frame: str, seq: int = 0) -> Any:
    return make(
        store, "std_msgs/Header", seq=seq, stamp=make(store, "builtin_interfaces/Time", 12, 345), frame_id=frame
    )


def pose(store: Any, x: float, y: float) -> Any:
    point = make(store, "geometry_msgs/Point", x, y, 0.0)
    return make(store, "geometry_msgs/Pose", point, make(store, "geometry_msgs/Quaternion", 0, 0, 0, 1))


def grid_msg(store: Any, width: int, height: int, data: list[int]) -> Any:
    stamp = make(store, "builtin_interfaces/Time", 1, 2)
    info = make(store, "nav_msgs/MapMetaData", stamp, 0.05, width, height, pose(store, -1.0, -2.0))
    return make(store, "nav_msgs/OccupancyGrid", header(store, "map"), info, np.array(data, np.int8))


def test_a_scan_decodes_as_rosbags_wrote_it(store: Any) -> None:
    ranges = np.linspace(0.1, 3.5, 360, dtype=np.float32)
    limits = (-3.1, 3.1, 0.0175, 0.0, 0.2, 0.12, 3.5)
    scan = make(
        store, "sensor_msgs/LaserScan", header(store, "base_scan", 41), *limits, ranges, np.zeros(0, np.float32)
    )
    msg = codec().decode("sensor_msgs/LaserScan", serialized(store, "sensor_msgs/LaserScan", scan))
    assert (msg.header.frame_id, msg.header.stamp.sec, msg.header.stamp.nanosec) == ("base_scan", 12, 345)
    assert msg.angle_min == pytest.approx(-3.1)
    assert msg.range_max == pytest.approx(3.5)
    assert np.array_equal(np.asarray(msg.ranges), ranges)
    assert len(msg.intensities) == 0


def test_a_map_decodes_and_encodes_back_to_the_same_bytes(store: Any) -> None:
    data = serialized(store, "nav_msgs/OccupancyGrid", grid_msg(store, 3, 2, [0, 100, -1, 50, 0, 100]))
    msg = codec().decode("nav_msgs/OccupancyGrid", data)
    assert (msg.info.width, msg.info.height, list(msg.data)) == (3, 2, [0, 100, -1, 50, 0, 100])
    assert msg.info.origin.position.y == -2.0
    assert codec().encode("nav_msgs/OccupancyGrid", msg) == data


def test_a_tf_message_decodes_and_encodes_back_to_the_same_bytes(store: Any) -> None:
    def transform(parent: str, child: str, x: float, z: float, w: float) -> Any:
        vector = make(store, "geometry_msgs/Vector3", x, 0.0, 0.0)
        rotation = make(store, "geometry_msgs/Quaternion", 0, 0, z, w)
        value = make(store, "geometry_msgs/Transform", vector, rotation)
        return make(store, "geometry_msgs/TransformStamped", header(store, parent), child, value)

    tf = make(
        store,
        "tf2_msgs/TFMessage",
        [transform("odom", "base_footprint", 1.0, 0.6, 0.8), transform("map", "odom", 0, 0, 1)],
    )
    data = serialized(store, "tf2_msgs/TFMessage", tf)
    msg = codec().decode("tf2_msgs/TFMessage", data)
    frames = [(t.header.frame_id, t.child_frame_id) for t in msg.transforms]
    assert frames == [("odom", "base_footprint"), ("map", "odom")]
    assert msg.transforms[0].transform.rotation.z == pytest.approx(0.6)
    assert codec().encode("tf2_msgs/TFMessage", msg) == data


def test_a_pose_with_covariance_round_trips_with_its_fixed_array(store: Any) -> None:
    covariance = make(store, "geometry_msgs/PoseWithCovariance", pose(store, 0.5, 1.5), np.arange(36, dtype=np.float64))
    stamped = make(store, "geometry_msgs/PoseWithCovarianceStamped", header(store, "map"), covariance)
    data = serialized(store, "geometry_msgs/PoseWithCovarianceStamped", stamped)
    msg = codec().decode("geometry_msgs/PoseWithCovarianceStamped", data)
    assert list(msg.pose.covariance) == list(range(36))
    assert codec().encode("geometry_msgs/PoseWithCovarianceStamped", msg) == data


@pytest.mark.parametrize("cut", [1, 10, 40])
def test_truncated_or_padded_bytes_are_refused_with_the_type(store: Any, cut: int) -> None:
    data = serialized(store, "nav_msgs/OccupancyGrid", grid_msg(store, 2, 2, [0, 0, 0, 0]))
    with pytest.raises(InvalidInputError, match="nav_msgs/OccupancyGrid"):
        codec().decode("nav_msgs/OccupancyGrid", data[:-cut])
    with pytest.raises(InvalidInputError, match="left after"):
        codec().decode("nav_msgs/OccupancyGrid", data + b"\0" * cut)


def test_an_absurd_sequence_length_is_refused_without_allocating() -> None:
    data = b"\xff\xff\xff\x7f"  # 2**31 - 1 transforms announced in 4 bytes
    with pytest.raises(InvalidInputError, match="items announced"):
        codec().decode("tf2_msgs/TFMessage", data)


def test_frames_round_trip_and_a_cut_or_oversized_frame_is_an_error() -> None:
    stream = io.BytesIO(encode_frame(3, b"abc") + encode_frame(0, b""))
    assert read_frame(stream) == (3, b"abc")
    assert read_frame(stream) == (0, b"")
    assert read_frame(stream) is None
    with pytest.raises(InvalidInputError, match="inside a frame"):
        read_frame(io.BytesIO(encode_frame(1, b"abcdef")[:-2]))
    with pytest.raises(InvalidInputError, match="exceeds"):
        read_frame(io.BytesIO((1).to_bytes(2, "little") + (MAX_FRAME_BYTES + 1).to_bytes(4, "little")))


def test_nothing_goes_from_ros2_into_ros1_unless_allowed() -> None:
    default = Ros2BridgeConfig.from_mapping({})
    assert (default.discovery_range, default.allow_inbound) == ("LOCALHOST", ())
    assert not any(route.inbound for route in default.routes)
    allowed = Ros2BridgeConfig.from_mapping({"allow_inbound": ["/goal_pose"], "namespace": "/tb3_0/"})
    inbound = [r for r in allowed.routes if r.inbound]
    assert [(allowed.ros2_topic(r), allowed.ros1_topic(r)) for r in inbound] == [
        ("/tb3_0/goal_pose", "/tb3_0/move_base_simple/goal")
    ]
    tf = next(r for r in allowed.routes if r.ros1 == "/tf")
    assert (allowed.ros1_topic(tf), allowed.ros2_topic(tf)) == ("/tf", "/tf")  # shared by the robots
    assert allowed.own_frame("tb3_0/base_footprint")
    assert not allowed.own_frame("tb3_1/base_footprint")
    assert default.own_frame("base_footprint")
    assert not default.allow_action
    assert not allowed.allow_action
    action = Ros2BridgeConfig.from_mapping({"allow_inbound": ["/navigate_to_pose"], "namespace": "tb3_1"})
    assert action.allow_action
    assert not any(r.inbound for r in action.routes)  # the action is no topic route
    assert action.action_names == ("/tb3_1/navigate_to_pose", "/tb3_1/move_base")
    with pytest.raises(InvalidInputError, match="allow_inbound"):
        Ros2BridgeConfig.from_mapping({"allow_inbound": ["/move_base_simple/goal"]})
    with pytest.raises(InvalidInputError, match="discovery_range"):
        Ros2BridgeConfig.from_mapping({"discovery_range": "lan"})
    with pytest.raises(InvalidInputError, match="namespace"):
        Ros2BridgeConfig.from_mapping({"namespace": "tb3 0"})
    assert Ros2BridgeConfig.from_json(allowed.to_json()) == allowed


def test_the_ros2_half_gets_no_ros1_python_path_and_stays_on_this_machine(tmp_path: Any) -> None:
    config = Ros2BridgeConfig.from_mapping({"domain_id": 17})
    parent = {"PYTHONPATH": "/usr/lib/python3/dist-packages", "_ROS_WHEELS_BOOTSTRAP_COMPLETE": "1",
              "ROS_LOCALHOST_ONLY": "0", "HOME": "/root"}  # fmt: skip
    env = child_environment(config, parent, package_root())
    assert env["PYTHONPATH"] == str(package_root())
    assert (package_root() / "mrs_nav").is_dir()
    assert "_ROS_WHEELS_BOOTSTRAP_COMPLETE" not in env
    assert "ROS_LOCALHOST_ONLY" not in env
    assert (env["ROS_DOMAIN_ID"], env["ROS_AUTOMATIC_DISCOVERY_RANGE"], env["HOME"]) == ("17", "LOCALHOST", "/root")
    assert ros2_python("", {"VENV_ROS2": str(tmp_path)}, "/x/.venv") == tmp_path / "bin" / "python"
    assert str(ros2_python("", {}, "/x/.venv")) == "/x/.venv-ros2/bin/python"
    assert str(ros2_python("/opt/py", {"VENV_ROS2": "/y"}, "/x/.venv")) == "/opt/py"
