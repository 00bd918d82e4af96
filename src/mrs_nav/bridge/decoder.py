"""Decoding ROS 1 messages without ROS: rosbags typestores fed with fetched definitions."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from rosbags.typesys import Stores, TypesysError, get_types_from_msg, get_typestore

from mrs_nav.bridge.wire import ros_type, rosbags_type
from mrs_nav.errors import InvalidInputError


class MessageDecoder:
    """Deserialises ROS 1 bytes of types registered from their definitions (``message_definition`` text).

    Starts empty, so every type it decodes was described by the sender: a decoder on a machine without ROS
    decodes exactly what the bridge serves. :meth:`register` checks that the definition hashes to the md5
    the publisher announced, so a mismatched definition is refused rather than silently misdecoding.
    """

    def __init__(self) -> None:
        self._store = get_typestore(Stores.EMPTY)
        self._md5: dict[str, str] = {}

    def known(self, type_name: str) -> bool:
        return ros_type(type_name) in self._md5

    def md5(self, type_name: str) -> str:
        return self._md5[ros_type(type_name)]

    def register(self, type_name: str, definition: str, md5: str = "") -> str:
        """Register ``type_name`` from its full definition; return its md5 (checked against ``md5`` if given)."""
        name = ros_type(type_name)
        if name in self._md5:
            return self._md5[name]
        try:
            self._store.register(get_types_from_msg(definition, rosbags_type(name)))
            _, computed = self._store.generate_msgdef(rosbags_type(name), ros_version=1)
        except (TypesysError, ValueError, KeyError) as err:
            raise InvalidInputError(f"definition of {name} cannot be parsed: {err}") from None
        if md5 and computed != md5:
            raise InvalidInputError(f"definition of {name} hashes to {computed}, the publisher announced {md5}")
        self._md5[name] = computed
        return computed

    def decode(self, type_name: str, payload: bytes) -> Any:
        """The message object of ``payload``; raise InvalidInputError when it does not deserialise."""
        return deserialize_exactly(self._store, type_name, payload)


_NOETIC = get_typestore(Stores.ROS1_NOETIC)


def noetic_store() -> Any:
    """rosbags' built-in ROS 1 Noetic typestore (shared, read-only use)."""
    return _NOETIC


def deserialize_exactly(store: Any, type_name: str, payload: bytes) -> Any:
    """Deserialise ``payload`` as ``type_name`` and insist it is exactly one message: truncated data or
    trailing bytes raise InvalidInputError."""
    name = rosbags_type(type_name)
    try:
        msg = store.deserialize_ros1(payload, name)
        size = len(store.serialize_ros1(msg, name))
    except Exception as err:  # rosbags raises assorted errors on garbage (struct, index, unicode...)
        raise InvalidInputError(f"payload is not a valid {ros_type(name)}: {type(err).__name__}: {err}") from None
    if size != len(payload):
        raise InvalidInputError(
            f"payload is not a valid {ros_type(name)}: {len(payload)} bytes, the message uses {size}"
        )
    return msg


def first_non_finite(msg: Any, path: str = "") -> str | None:
    """The field path of the first NaN or infinite number in a rosbags message, or None when all are finite."""
    if isinstance(msg, float):
        return None if math.isfinite(msg) else path or "value"
    if isinstance(msg, np.ndarray):
        if msg.dtype.kind == "f" and not np.all(np.isfinite(msg)):
            return f"{path}[{int(np.argmin(np.isfinite(msg)))}]"
        return None
    if isinstance(msg, list | tuple):
        for i, item in enumerate(msg):
            found = first_non_finite(item, f"{path}[{i}]")
            if found:
                return found
        return None
    fields = getattr(msg, "__dataclass_fields__", None)
    if fields:
        for name in fields:
            if name.startswith("__"):
                continue
            found = first_non_finite(getattr(msg, name), f"{path}.{name}" if path else name)
            if found:
                return found
    return None
