"""TCPROS framing (mrs_nav.bridge.tcpros): connection headers and length-prefixed blocks, against the ROS wiki's
encoding of a header and against broken input; the node's slave API reached over IPv4 and IPv6 loopback."""

from __future__ import annotations

import io
import os
import struct
import xmlrpc.client

import pytest

from mrs_nav.bridge.tcpros import (
    MAX_MESSAGE_BYTES,
    RawSubscriberNode,
    decode_header,
    encode_header,
    read_block,
)
from mrs_nav.errors import InvalidInputError


def test_a_header_reads_back_as_written() -> None:
    fields = {"callerid": "/ros2_bridge_ros2_side", "topic": "/odom", "md5sum": "*", "type": "*", "x": "a=b"}
    block = read_block(io.BytesIO(encode_header(fields)))
    assert block is not None
    assert decode_header(block) == fields


def test_a_header_is_encoded_as_the_ros_wiki_example_says() -> None:
    # ROS wiki "ROS/Connection Header": the total length, then each field's length and "key=value"
    assert encode_header({"topic": "/chatter"}) == struct.pack("<I", 18) + struct.pack("<I", 14) + b"topic=/chatter"


@pytest.mark.parametrize(
    ("body", "what"),
    [
        (struct.pack("<I", 50) + b"topic=/x", "runs past the header"),
        (b"\x01\x00", "cut short"),
        (struct.pack("<I", 5) + b"topic", "has no '='"),
    ],
)
def test_a_broken_header_is_refused_with_what_is_wrong(body: bytes, what: str) -> None:
    with pytest.raises(InvalidInputError, match=what):
        decode_header(body)


def test_blocks_are_read_one_after_another_until_a_clean_end() -> None:
    stream = io.BytesIO(struct.pack("<I", 3) + b"abc" + struct.pack("<I", 0) + struct.pack("<I", 2) + b"de")
    assert [read_block(stream), read_block(stream), read_block(stream), read_block(stream)] == [
        b"abc",
        b"",
        b"de",
        None,
    ]


@pytest.mark.parametrize(
    ("data", "what"),
    [
        (b"\x05\x00", "inside a length"),
        (struct.pack("<I", 10) + b"short", "inside a block"),
        (struct.pack("<I", MAX_MESSAGE_BYTES + 1), "exceeds"),
    ],
)
def test_a_connection_cut_inside_a_block_or_an_oversized_one_is_refused(data: bytes, what: str) -> None:
    with pytest.raises(InvalidInputError, match=what):
        read_block(io.BytesIO(data))


@pytest.mark.parametrize("loopback", ["127.0.0.1", "::1"])
def test_the_slave_api_answers_on_ipv4_and_ipv6(loopback: str) -> None:
    # no master needed until something is subscribed
    node = RawSubscriberNode("http://127.0.0.1:1/", "/tcpros_api", loopback, loopback, print)
    try:
        proxy = xmlrpc.client.ServerProxy(node.uri)
        assert proxy.getPid("/pytest") == [1, "", os.getpid()]
        assert proxy.getSubscriptions("/pytest") == [1, "", []]
        assert proxy.requestTopic("/pytest", "/odom", [["TCPROS"]])[0] == -1
    finally:
        node.close()
