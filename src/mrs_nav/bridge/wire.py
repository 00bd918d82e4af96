"""What travels next to the payload: the Encoding schema, the attachment and type-definition replies.

- Payload: the ROS 1 serialized message, byte for byte as the ROS publisher sent it.
- Encoding: ``zenoh/bytes`` with schema = the ROS type name, ``nav_msgs/Odometry``.
- Attachment (25 bytes, little endian, struct ``<B16sq``): format version (1), the md5 sum of the message
  definition as 16 raw bytes, and the bridge's receive time in integer nanoseconds since the UNIX epoch
  (wall clock), from which a subscriber on a synchronised clock derives the latency.
- Type definitions (``P/@types/pkg/Type`` replies): UTF-8 JSON ``{"type", "md5", "definition"}``, the
  definition being the full text of ROS 1's ``message_definition`` (dependencies after ``MSG:`` lines).
- Status (``P/@bridge/status`` replies): UTF-8 JSON ``{"topics": {topic: {"type", "forwarded", "limited",
  "age_s"}}, "inbound": {topic: {"accepted", "dropped"}}, "refused": n}``; ``age_s`` is the time since the last
  message of the topic reached the bridge (null before the first one).
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass
from typing import Any

from mrs_nav.errors import InvalidInputError

ATTACHMENT_VERSION = 1
_ATTACHMENT = struct.Struct("<B16sq")
_STAMP = struct.Struct("<q")  # the last field of _ATTACHMENT
ENCODING_PREFIX = "zenoh/bytes"


@dataclass(frozen=True)
class Attachment:
    """md5 sum (32 hex digits) of the message type and the bridge's receive time (ns since the epoch)."""

    md5: str
    receive_time_ns: int


def encode_attachment(md5: str, receive_time_ns: int) -> bytes:
    """Pack an attachment; ``md5`` is the 32-hex-digit sum ROS 1 puts in connection headers."""
    return stamp_attachment(attachment_prefix(md5), receive_time_ns)


def attachment_prefix(md5: str) -> bytes:
    """The part of every attachment of a topic that does not change (version and md5), made once per topic: the
    bridge then only appends each message's stamp (:func:`stamp_attachment`), little work on its hot path."""
    try:
        raw = bytes.fromhex(md5)
    except ValueError:
        raise InvalidInputError(f"md5 sum {md5!r}: expected 32 hex digits") from None
    if len(raw) != 16:
        raise InvalidInputError(f"md5 sum {md5!r}: expected 32 hex digits")
    return bytes((ATTACHMENT_VERSION,)) + raw


def stamp_attachment(prefix: bytes, receive_time_ns: int) -> bytes:
    """The attachment of one message: :func:`attachment_prefix` then the receive time."""
    return prefix + _STAMP.pack(receive_time_ns)


def decode_attachment(data: bytes) -> Attachment:
    """Unpack an attachment made by :func:`encode_attachment`; raise InvalidInputError otherwise."""
    if len(data) != _ATTACHMENT.size:
        raise InvalidInputError(f"attachment: expected {_ATTACHMENT.size} bytes, got {len(data)}")
    version, raw, stamp = _ATTACHMENT.unpack(data)
    if version != ATTACHMENT_VERSION:
        raise InvalidInputError(f"attachment: unknown format version {version}")
    return Attachment(raw.hex(), stamp)


def encoding_text(type_name: str) -> str:
    """The Encoding (as text) carried by samples of ``type_name``: ``zenoh/bytes;nav_msgs/Odometry``."""
    return f"{ENCODING_PREFIX};{ros_type(type_name)}"


def schema_of(encoding: str) -> str:
    """The schema part of an Encoding's text (``zenoh/bytes;nav_msgs/Odometry`` -> ``nav_msgs/Odometry``)."""
    _, sep, schema = encoding.partition(";")
    return schema if sep else ""


def ros_type(type_name: str) -> str:
    """ROS 1 spelling ``pkg/Type`` of a type given as ``pkg/Type`` or rosbags' ``pkg/msg/Type``."""
    pkg, _, rest = type_name.partition("/")
    return f"{pkg}/{rest.removeprefix('msg/')}"


def rosbags_type(type_name: str) -> str:
    """rosbags' spelling ``pkg/msg/Type`` of a type given as ``pkg/Type`` or ``pkg/msg/Type``."""
    pkg, _, rest = ros_type(type_name).partition("/")
    return f"{pkg}/msg/{rest}"


def encode_definition(type_name: str, md5: str, definition: str) -> bytes:
    """The JSON reply of a ``@types`` query."""
    return json.dumps({"type": ros_type(type_name), "md5": md5, "definition": definition}).encode()


def decode_definition(data: bytes) -> tuple[str, str, str]:
    """``(type, md5, definition)`` from a ``@types`` reply; raise InvalidInputError if malformed."""
    try:
        obj = json.loads(data)
        result = (str(obj["type"]), str(obj["md5"]), str(obj["definition"]))
    except (ValueError, TypeError, KeyError) as err:
        raise InvalidInputError(f"type definition reply is malformed: {err}") from None
    return result


def encode_status(status: dict[str, Any]) -> bytes:
    """The JSON reply of a status query."""
    return json.dumps(status).encode()


def decode_status(data: bytes) -> dict[str, Any]:
    """The bridge's status from a status reply; raise InvalidInputError if malformed."""
    try:
        status = json.loads(data)
    except ValueError as err:
        raise InvalidInputError(f"bridge status reply is malformed: {err}") from None
    if not isinstance(status, dict) or not isinstance(status.get("topics"), dict):
        raise InvalidInputError("bridge status reply is malformed: no topics")
    return status
