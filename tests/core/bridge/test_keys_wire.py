"""Key layout, attachment and definition wire formats."""

from __future__ import annotations

import pytest
import zenoh
from hypothesis import given
from hypothesis import strategies as st

from mrs_nav.bridge.config import BridgeConfig
from mrs_nav.bridge.keys import (
    KeyLayout,
    discovery_key,
    publish_key,
    robot_prefix,
    status_key,
    topic_key,
    topic_of_key,
    topic_of_publish_key,
    types_key,
)
from mrs_nav.bridge.wire import (
    decode_attachment,
    decode_definition,
    encode_attachment,
    encode_definition,
    encoding_text,
    ros_type,
    rosbags_type,
    schema_of,
)
from mrs_nav.errors import InvalidInputError

MD5 = "cd5e73d190d741a2f92e81eda573aca7"  # nav_msgs/Odometry


def test_topic_keys_follow_the_prefix_and_namespace() -> None:
    prefix = robot_prefix("mrs_nav", "/robot1/")
    assert prefix == "mrs_nav/robot1"
    assert topic_key(prefix, "/move_base_simple/goal") == "mrs_nav/robot1/move_base_simple/goal"
    assert topic_of_key(prefix, "mrs_nav/robot1/scan") == "/scan"
    assert types_key(prefix, "nav_msgs/msg/Odometry") == "mrs_nav/robot1/@types/nav_msgs/Odometry"
    key = publish_key(prefix, "/move_base_simple/goal")
    assert key == "mrs_nav/robot1/@bridge/publish/move_base_simple/goal"
    assert topic_of_publish_key(prefix, key) == "/move_base_simple/goal"


def test_zenoh_bridge_ros1_layout_is_hex_type_md5_topic() -> None:
    key = topic_key("", "/odom", KeyLayout.ZENOH_BRIDGE_ROS1, "nav_msgs/Odometry", MD5)
    assert key == f"{b'nav_msgs/Odometry'.hex()}/{MD5}/odom"
    assert topic_key("ns", "/odom", KeyLayout.ZENOH_BRIDGE_ROS1, "nav_msgs/Odometry", MD5).endswith(f"{MD5}/ns/odom")
    # zenoh-plugin-ros1 1.0.0-rc.1: ros1_discovery_info/<discovery ns>/<pub|sub|srv|cl>/<hex type>/<md5>/<bridge ns>/...
    beacon = discovery_key("/a/odom", "nav_msgs/Odometry", MD5)
    assert beacon == f"ros1_discovery_info/*/pub/{b'nav_msgs/Odometry'.hex()}/{MD5}/*/a/odom"
    assert zenoh.KeyExpr(beacon).intersects(zenoh.KeyExpr("ros1_discovery_info/*/*/*/*/*/*/**"))
    # An empty prefix is only possible with this layout, whose services then live under mrs_nav.
    assert BridgeConfig.from_mapping({"prefix": "", "layout": "zenoh-bridge-ros1"}).key_prefix == ""
    with pytest.raises(InvalidInputError, match="prefix is empty"):
        BridgeConfig.from_mapping({"prefix": ""})
    assert status_key("") == "mrs_nav/@bridge/status"


@pytest.mark.parametrize("topic", ["odom", "/a/*", "/a//b", "/", "/a/$x", "/a b"])
def test_bad_topic_names_are_refused(topic: str) -> None:
    with pytest.raises(InvalidInputError, match="topic"):
        topic_key("mrs_nav", topic)


def test_keys_outside_the_prefix_are_refused() -> None:
    with pytest.raises(InvalidInputError, match="not under prefix"):
        topic_of_key("mrs_nav/robot1", "mrs_nav/robot2/odom")


@given(st.integers(min_value=-(2**63), max_value=2**63 - 1), st.binary(min_size=16, max_size=16))
def test_attachment_round_trips(stamp: int, raw: bytes) -> None:
    att = decode_attachment(encode_attachment(raw.hex(), stamp))
    assert (att.md5, att.receive_time_ns) == (raw.hex(), stamp)


@pytest.mark.parametrize("data", [b"", b"\x01" * 24, b"\x02" + b"\x00" * 24])
def test_malformed_attachments_are_refused(data: bytes) -> None:
    with pytest.raises(InvalidInputError, match="attachment"):
        decode_attachment(data)


def test_md5_must_be_32_hex_digits() -> None:
    with pytest.raises(InvalidInputError, match="md5"):
        encode_attachment("abc", 0)


def test_encoding_schema_names_the_ros_type() -> None:
    assert encoding_text("nav_msgs/msg/Odometry") == "zenoh/bytes;nav_msgs/Odometry"
    assert schema_of("zenoh/bytes;nav_msgs/Odometry") == "nav_msgs/Odometry"
    assert schema_of("zenoh/bytes") == ""
    assert ros_type("a/msg/B") == ros_type("a/B") == "a/B"
    assert rosbags_type("a/B") == "a/msg/B"


def test_definition_reply_round_trips_and_rejects_garbage() -> None:
    assert decode_definition(encode_definition("std_msgs/msg/String", MD5, "string data")) == (
        "std_msgs/String",
        MD5,
        "string data",
    )
    with pytest.raises(InvalidInputError, match="malformed"):
        decode_definition(b"{not json")
