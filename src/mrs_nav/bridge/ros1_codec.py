"""ROS 1 wire bytes <-> field values, driven by ROS 2's description of a message type.

The ROS 2 bridge (:mod:`mrs_nav.ros.ros2_bridge_node`, :mod:`mrs_nav.ros2.bridge_half`) carries the ROS 1
serialised bytes between its two processes, and its ROS 2 half turns them into ROS 2 messages with this codec.
A type is described as ROS 2 describes it (``Msg.get_fields_and_field_types()``: field name -> ``"double"``,
``"sequence<float>"``, ``"double[36]"``, ``"std_msgs/Header"``, ...), so the codec knows no message itself.

The two wire layouts agree for every type the bridge carries except ``std_msgs/Header``, which lost its
``seq`` in ROS 2: :data:`ROS1_ONLY_FIELDS` names such fields (skipped when decoding, written as zero when
encoding). ROS 1's ``time``/``duration`` have the layout of ``builtin_interfaces/Time``/``Duration``.

Numeric arrays decode to :class:`array.array` straight from the buffer (one copy, no per-element work), so a
map or a scan costs about what copying its bytes costs.
"""

from __future__ import annotations

import array
import re
import struct
import sys
from collections.abc import Callable, Mapping
from typing import Any

from mrs_nav.errors import InvalidInputError

#: ROS 2 primitive type -> struct format (little-endian), the array typecode of the same layout.
PRIMITIVES: dict[str, tuple[str, str]] = {
    "boolean": ("?", "B"),
    "octet": ("B", "B"),
    "char": ("B", "B"),
    "byte": ("B", "B"),
    "int8": ("b", "b"),
    "uint8": ("B", "B"),
    "int16": ("h", "h"),
    "uint16": ("H", "H"),
    "int32": ("i", "i"),
    "uint32": ("I", "I"),
    "int64": ("q", "q"),
    "uint64": ("Q", "Q"),
    "float": ("f", "f"),
    "double": ("d", "d"),
}
#: Fields a type has in front on the ROS 1 wire but not in ROS 2.
ROS1_ONLY_FIELDS: dict[str, tuple[tuple[str, str], ...]] = {"std_msgs/Header": (("seq", "uint32"),)}

_SEQUENCE = re.compile(r"^sequence<(?P<item>[^,>]+)(?:,\s*\d+)?>$")
_FIXED = re.compile(r"^(?P<item>[^\[]+)\[(?P<size>\d+)\]$")
_BOUNDED_STRING = re.compile(r"^w?string<\d+>$")
_LENGTH = struct.Struct("<I")
_LITTLE = sys.byteorder == "little"

#: A type name -> its fields in wire order, as ROS 2 describes them.
FieldsOf = Callable[[str], Mapping[str, str]]
#: A type name and its decoded field values -> the message object.
Build = Callable[[str, dict[str, Any]], Any]


def _item_and_size(field_type: str) -> tuple[str, int | None] | None:
    """``sequence<T>`` -> (T, None); ``T[n]`` -> (T, n); anything else None."""
    match = _SEQUENCE.match(field_type)
    if match:
        return match["item"].strip(), None
    match = _FIXED.match(field_type)
    if match:
        return match["item"], int(match["size"])
    return None


class _Reader:
    """A cursor over one message's bytes; every read checks that the bytes are there."""

    def __init__(self, data: bytes | memoryview) -> None:
        self.view = memoryview(data)
        self.pos = 0

    def take(self, size: int) -> memoryview:
        end = self.pos + size
        if size < 0 or end > len(self.view):
            raise InvalidInputError(f"message truncated: needs {end} bytes, has {len(self.view)}")
        chunk = self.view[self.pos : end]
        self.pos = end
        return chunk

    def length(self) -> int:
        return int(_LENGTH.unpack(self.take(4))[0])


class Ros1Codec:
    """Decodes ROS 1 bytes into messages made by ``build`` and encodes objects' fields into ROS 1 bytes.

    ``fields_of`` describes each type (see the module docstring); plans are made once per type and cached.
    """

    def __init__(self, fields_of: FieldsOf, build: Build) -> None:
        self._fields_of = fields_of
        self._build = build

    # --- decoding ---------------------------------------------------------------------------------------
    def decode(self, type_name: str, data: bytes | memoryview) -> Any:
        """The message of ``type_name`` in ``data``; InvalidInputError if the bytes do not hold exactly one."""
        reader = _Reader(data)
        try:
            msg = self._read(reader, type_name)
        except (struct.error, UnicodeDecodeError, ValueError) as err:
            raise InvalidInputError(f"{type_name}: malformed ROS 1 message: {err}") from None
        if reader.pos != len(reader.view):
            raise InvalidInputError(f"{type_name}: {len(reader.view) - reader.pos} bytes left after the message")
        return msg

    def _read(self, reader: _Reader, field_type: str) -> Any:
        primitive = PRIMITIVES.get(field_type)
        if primitive is not None:
            fmt = "<" + primitive[0]
            return struct.unpack(fmt, reader.take(struct.calcsize(fmt)))[0]
        if field_type == "string" or _BOUNDED_STRING.match(field_type):
            return bytes(reader.take(reader.length())).decode()
        array_of = _item_and_size(field_type)
        if array_of is not None:
            item, size = array_of
            count = reader.length() if size is None else size
            if item in PRIMITIVES:
                return self._read_numbers(reader, item, count)
            if count > len(reader.view):  # every item takes at least a byte: refuse absurd counts at once
                raise InvalidInputError(f"{field_type}: {count} items announced in {len(reader.view)} bytes")
            return [self._read(reader, item) for _ in range(count)]
        for _, extra_type in ROS1_ONLY_FIELDS.get(field_type, ()):
            self._read(reader, extra_type)
        values = {name: self._read(reader, sub) for name, sub in self._fields_of(field_type).items()}
        return self._build(field_type, values)

    @staticmethod
    def _read_numbers(reader: _Reader, item: str, count: int) -> Any:
        code = PRIMITIVES[item][1]
        numbers = array.array(code)
        chunk = reader.take(count * numbers.itemsize)
        numbers.frombytes(chunk)
        if not _LITTLE:
            numbers.byteswap()
        return [bool(v) for v in numbers] if item == "boolean" else numbers

    # --- encoding ---------------------------------------------------------------------------------------
    def encode(self, type_name: str, msg: Any) -> bytes:
        """``msg``'s fields (read with getattr) as the ROS 1 bytes of ``type_name``."""
        out = bytearray()
        try:
            self._write(out, type_name, msg)
        except (struct.error, TypeError, ValueError, AttributeError) as err:
            raise InvalidInputError(f"{type_name}: cannot encode: {err}") from None
        return bytes(out)

    def _write(self, out: bytearray, field_type: str, value: Any) -> None:
        primitive = PRIMITIVES.get(field_type)
        if primitive is not None:
            out += struct.pack("<" + primitive[0], value)
            return
        if field_type == "string" or _BOUNDED_STRING.match(field_type):
            encoded = str(value).encode()
            out += _LENGTH.pack(len(encoded)) + encoded
            return
        array_of = _item_and_size(field_type)
        if array_of is not None:
            item, size = array_of
            items = list(value)
            if size is None:
                out += _LENGTH.pack(len(items))
            elif len(items) != size:
                raise ValueError(f"{field_type} needs {size} items, got {len(items)}")
            if item in PRIMITIVES:
                out += struct.pack(f"<{len(items)}{PRIMITIVES[item][0]}", *items)
            else:
                for element in items:
                    self._write(out, item, element)
            return
        for _, extra_type in ROS1_ONLY_FIELDS.get(field_type, ()):
            self._write(out, extra_type, 0)
        for name, sub in self._fields_of(field_type).items():
            self._write(out, sub, getattr(value, name))
