"""Decoding from fetched definitions and the inbound checks."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mrs_nav.bridge.config import BridgeConfig
from mrs_nav.bridge.decoder import MessageDecoder, first_non_finite, noetic_store
from mrs_nav.bridge.inbound import InboundValidator
from mrs_nav.bridge.monitor import serialize_goal
from mrs_nav.bridge.wire import encode_attachment
from mrs_nav.errors import InvalidInputError

GOAL = "/move_base_simple/goal"
POSE_STAMPED = "geometry_msgs/PoseStamped"


def definition(type_name: str) -> tuple[str, str]:
    """The ROS 1 full definition text and md5, as a ROS publisher's connection header carries them."""
    text, md5 = noetic_store().generate_msgdef(type_name, ros_version=1)
    return text, md5


def test_decoder_registers_fetched_definitions_and_decodes() -> None:
    text, md5 = definition("geometry_msgs/msg/PoseStamped")
    decoder = MessageDecoder()
    assert not decoder.known(POSE_STAMPED)
    assert decoder.register(POSE_STAMPED, text, md5) == md5
    msg = decoder.decode(POSE_STAMPED, serialize_goal(1.5, -2.0, math.pi / 2))
    assert (msg.pose.position.x, msg.pose.position.y, msg.header.frame_id) == (1.5, -2.0, "map")
    assert msg.pose.orientation.z == pytest.approx(math.sqrt(0.5))


def test_decoder_refuses_a_definition_that_does_not_match_the_md5() -> None:
    text, _ = definition("geometry_msgs/msg/PoseStamped")
    with pytest.raises(InvalidInputError, match="hashes to"):
        MessageDecoder().register(POSE_STAMPED, text, "0" * 32)


def test_decoder_refuses_truncated_and_padded_payloads() -> None:
    text, md5 = definition("geometry_msgs/msg/PoseStamped")
    decoder = MessageDecoder()
    decoder.register(POSE_STAMPED, text, md5)
    payload = serialize_goal(1.0, 2.0, 0.0)
    for bad in (payload[:-3], payload + b"\x00", b""):
        with pytest.raises(InvalidInputError, match="not a valid"):
            decoder.decode(POSE_STAMPED, bad)


def test_first_non_finite_names_the_field() -> None:
    msg = noetic_store().deserialize_ros1(serialize_goal(float("inf"), 0.0, 0.0), "geometry_msgs/msg/PoseStamped")
    assert first_non_finite(msg) == "pose.position.x"


@pytest.fixture
def validator() -> InboundValidator:
    return InboundValidator(BridgeConfig.from_mapping({"inbound": [GOAL]}))


def test_a_good_goal_passes(validator: InboundValidator) -> None:
    payload = serialize_goal(1.0, 2.0, 0.5)
    attachment = encode_attachment(validator.md5(GOAL), 0)
    msg = validator.validate(GOAL, POSE_STAMPED, payload, attachment)
    assert msg.pose.position.y == 2.0


@pytest.mark.parametrize(
    ("topic", "schema", "payload", "match"),
    [
        ("/cmd_vel", "geometry_msgs/Twist", b"", "not in the bridge's inbound allow-list"),
        (GOAL, "geometry_msgs/PoseWithCovarianceStamped", serialize_goal(0, 0, 0), "accepts geometry_msgs/PoseStamped"),
        (GOAL, "", serialize_goal(0, 0, 0), "no type"),
        (GOAL, POSE_STAMPED, b"\x01\x02", "not a valid"),
        (GOAL, POSE_STAMPED, serialize_goal(float("nan"), 0, 0), "not a finite number"),
        (GOAL, POSE_STAMPED, serialize_goal(0, 0, 0, frame="odom"), "frame 'odom'"),
    ],
)
def test_bad_inbound_messages_are_refused_with_the_reason(
    validator: InboundValidator, topic: str, schema: str, payload: bytes, match: str
) -> None:
    with pytest.raises(InvalidInputError, match=match):
        validator.validate(topic, schema, payload)


NOW = 1_800_000_000.0  # s since the epoch, the bridge's clock in the tests below
S = 1_000_000_000  # ns


@pytest.mark.parametrize(
    ("stamp_ns", "max_age", "match"),
    [
        (int(NOW - 3600) * S, None, r"stamped 3600.0 s ago, older than its max_age 5 s"),  # captured an hour ago
        (0, None, "older than its max_age"),  # never stamped
        (int((NOW - 5.5) * S), None, "older than"),
        (int(NOW - 30) * S, 20.0, "older than its max_age 20 s"),
        (int(NOW + 2) * S, None, r"stamped 2.0 s in the future, beyond the 0.5 s clock tolerance"),
        (int((NOW - 4.5) * S), None, ""),
        (int((NOW + 0.4) * S), None, ""),
        (int(NOW - 10) * S, 20.0, ""),
    ],
)
def test_an_inbound_goal_too_old_or_from_the_future_is_refused(
    stamp_ns: int, max_age: float | None, match: str
) -> None:
    rule: dict[str, Any] = {"topic": GOAL} if max_age is None else {"topic": GOAL, "max_age": max_age}
    validator = InboundValidator(BridgeConfig.from_mapping({"inbound": [rule]}))
    payload = serialize_goal(1.0, 2.0, 0.0, stamp_ns=stamp_ns)
    if not match:
        assert validator.validate(GOAL, POSE_STAMPED, payload, now=NOW).pose.position.x == 1.0
        return
    with pytest.raises(InvalidInputError, match=match):
        validator.validate(GOAL, POSE_STAMPED, payload, now=NOW)


@pytest.mark.parametrize("max_age", [0, -1.0, float("nan"), float("inf")])
def test_a_max_age_that_is_not_a_positive_time_is_refused(max_age: float) -> None:
    with pytest.raises(InvalidInputError, match=r"inbound /move_base_simple/goal max_age .*expected an age > 0 s"):
        BridgeConfig.from_mapping({"inbound": [{"topic": GOAL, "max_age": max_age}]})


def test_a_wrong_md5_is_refused(validator: InboundValidator) -> None:
    with pytest.raises(InvalidInputError, match="md5"):
        validator.validate(GOAL, POSE_STAMPED, serialize_goal(0, 0, 0), encode_attachment("1" * 32, 0))


def test_nothing_is_allowed_in_by_default() -> None:
    with pytest.raises(InvalidInputError, match=r"allowed: nothing"):
        InboundValidator(BridgeConfig()).validate(GOAL, POSE_STAMPED, serialize_goal(0, 0, 0))


def accepted_or_refused(validator: InboundValidator, schema: str, payload: bytes, attachment: bytes | None) -> Any:
    """The accepted message, or None when refused with InvalidInputError; any other exception fails the test."""
    try:
        return validator.validate(GOAL, schema, payload, attachment)
    except InvalidInputError:
        return None


@given(
    st.binary(max_size=200),
    st.sampled_from([POSE_STAMPED, "geometry_msgs/Twist", "", "x"]),
    st.one_of(st.none(), st.binary(max_size=30)),
)
def test_arbitrary_network_input_is_refused_cleanly(payload: bytes, schema: str, attachment: bytes | None) -> None:
    msg = accepted_or_refused(
        InboundValidator(BridgeConfig.from_mapping({"inbound": [GOAL]})), schema, payload, attachment
    )
    if msg is not None:  # whatever passes is a well-formed, finite goal in the map frame
        assert msg.header.frame_id == "map"
        assert first_non_finite(msg) is None


@given(st.binary(min_size=1, max_size=300))
def test_a_corrupted_goal_is_accepted_only_if_it_is_still_valid(noise: bytes) -> None:
    payload = bytearray(serialize_goal(1.0, 2.0, 0.3))
    for i, b in enumerate(noise[: len(payload)]):
        payload[i] ^= b
    msg = accepted_or_refused(
        InboundValidator(BridgeConfig.from_mapping({"inbound": [GOAL]})), POSE_STAMPED, bytes(payload), None
    )
    if msg is not None:
        assert msg.header.frame_id == "map"
        assert first_non_finite(msg) is None
