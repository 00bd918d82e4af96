"""ROS 1 wire bytes <-> field values, driven by ROS 2's description of a message type.

The ROS 2 bridge (:mod:`mrs_nav.ros.ros2_bridge_node`, :mod:`mrs_nav.ros2.bridge_half`) carries the ROS 1
serialised bytes between its two processes, and its ROS 2 half turns them into ROS 2 messages with this codec.
A type is described as ROS 2 describes it (``Msg.get_fields_and_field_types()``: field name -> ``"double"``,
``"sequence<float>"``, ``"double[36]"``, ``"std_msgs/Header"``, ...), so the codec knows no message itself.

The two wire layouts agree for every type the bridge carries except ``std_msgs/Header``, which lost its
``seq`` in ROS 2: :data:`ROS1_ONLY_FIELDS` names such fields (skipped when decoding, written as zero when
encoding). ROS 1's ``time``/``duration`` have the layout of ``builtin_interfaces/Time``/``Duration``.

Numeric sequences decode to :class:`array.array` and fixed arrays to numpy arrays straight from the buffer (one
copy, no per-element work), so a map or a scan costs about what copying its bytes costs.
"""

from __future__ import annotations

import array
import enum
import re
import struct
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

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
LENGTH = struct.Struct("<I")
_LITTLE = sys.byteorder == "little"

#: A type name -> its fields in wire order, as ROS 2 describes them.
FieldsOf = Callable[[str], Mapping[str, str]]
#: A type name and its decoded field values -> the message object.
Build = Callable[[str, dict[str, Any]], Any]


def is_string(field_type: str) -> bool:
    """``string`` or a bounded string (``string<n>``, ``wstring<n>``)."""
    return field_type == "string" or _BOUNDED_STRING.match(field_type) is not None


def item_and_size(field_type: str) -> tuple[str, int | None] | None:
    """``sequence<T>`` -> (T, None); ``T[n]`` -> (T, n); anything else None."""
    match = _SEQUENCE.match(field_type)
    if match:
        return match["item"].strip(), None
    match = _FIXED.match(field_type)
    if match:
        return match["item"], int(match["size"])
    return None


def _take(view: memoryview, pos: int, size: int) -> memoryview:
    end = pos + size
    if size < 0 or end > len(view):
        raise InvalidInputError(f"message truncated: needs {end} bytes, has {len(view)}")
    return view[pos:end]


def _read_numbers(view: memoryview, pos: int, item: str, count: int, fixed: bool) -> tuple[Any, int]:
    code = PRIMITIVES[item][1]
    numbers = array.array(code)
    chunk = _take(view, pos, count * numbers.itemsize)
    pos += len(chunk)
    if item == "boolean":
        return [bool(v) for v in chunk], pos
    if fixed:  # rclpy keeps fixed arrays as numpy arrays (and checks others element by element)
        return np.frombuffer(chunk, dtype=np.dtype(code).newbyteorder("<")).copy(), pos
    numbers.frombytes(chunk)
    if not _LITTLE:
        numbers.byteswap()
    return numbers, pos


def _make_plan(fields: tuple[tuple[str, str], ...], ros1_only: int) -> tuple[_Op, ...]:
    """The decoding steps of a type with ``fields`` (name, ROS 2 type) in wire order, the first ``ros1_only``
    of them ROS 1's only (primitives: decoded and dropped)."""
    plan: list[_Op] = []
    run: list[tuple[str | None, str]] = []  # primitive fields in a row: (name, struct code)

    def close_run() -> None:
        if run:
            fmt = struct.Struct("<" + "".join(code for _, code in run))
            plan.append(_Op(_Step.PRIMITIVES, tuple(name for name, _ in run), fmt))
            run.clear()

    for index, (name, field_type) in enumerate(fields):
        kept = None if index < ros1_only else name
        if field_type in PRIMITIVES:
            run.append((kept, PRIMITIVES[field_type][0]))
            continue
        close_run()
        array_of = item_and_size(field_type)
        if is_string(field_type):
            plan.append(_Op(_Step.STRING, (name,)))
        elif array_of is not None:
            item, size = array_of
            step = _Step.NUMBERS if item in PRIMITIVES else _Step.MESSAGES
            plan.append(_Op(step, (name,), item=item, size=size))
        else:
            plan.append(_Op(_Step.MESSAGE, (name,), item=field_type))
    close_run()
    return tuple(plan)


class _Step(enum.Enum):
    PRIMITIVES = 1  # a run of primitive fields: one struct
    STRING = 2
    NUMBERS = 3  # an array of primitives: one copy
    MESSAGES = 4  # an array of messages
    MESSAGE = 5


@dataclass(frozen=True)
class _Op:
    """One step of a type's decoding plan: ``names`` are its fields (None: a ROS 1-only field, skipped)."""

    step: _Step
    names: tuple[str | None, ...]
    fmt: struct.Struct | None = None  # PRIMITIVES
    item: str = ""  # the item type (NUMBERS, MESSAGES) or the message type (MESSAGE)
    size: int | None = None  # a fixed array's length; None: a sequence (its length is on the wire)


class Ros1Codec:
    """Decodes ROS 1 bytes into messages made by ``build`` and encodes objects' fields into ROS 1 bytes.

    ``fields_of`` describes each type (see the module docstring). Decoding follows a plan made once per type:
    a run of primitive fields is one ``struct`` unpack, a numeric array one copy (a sequence an
    :class:`array.array`, a fixed array a numpy array, as rclpy keeps them), so that a message costs a few steps
    per nested message rather than a step per field.
    """

    def __init__(self, fields_of: FieldsOf, build: Build) -> None:
        self._fields_of = fields_of
        self._build = build
        self._plans: dict[str, tuple[_Op, ...]] = {}

    # --- decoding ---------------------------------------------------------------------------------------
    def decode(self, type_name: str, data: bytes | memoryview) -> Any:
        """The message of ``type_name`` in ``data``; InvalidInputError if the bytes do not hold exactly one."""
        view = memoryview(data)
        try:
            msg, end = self._read_message(view, 0, type_name)
        except (struct.error, UnicodeDecodeError, ValueError) as err:
            raise InvalidInputError(f"{type_name}: malformed ROS 1 message: {err}") from None
        if end != len(view):
            raise InvalidInputError(f"{type_name}: {len(view) - end} bytes left after the message")
        return msg

    def _plan(self, type_name: str) -> tuple[_Op, ...]:
        plan = self._plans.get(type_name)
        if plan is None:
            ros1_only = ROS1_ONLY_FIELDS.get(type_name, ())
            fields = (*ros1_only, *self._fields_of(type_name).items())
            plan = self._plans[type_name] = _make_plan(fields, len(ros1_only))
        return plan

    def _read_message(self, view: memoryview, pos: int, type_name: str) -> tuple[Any, int]:
        values: dict[str, Any] = {}
        for op in self._plan(type_name):
            if op.step is _Step.PRIMITIVES:
                assert op.fmt is not None
                unpacked = zip(op.names, op.fmt.unpack_from(view, pos), strict=True)
                values.update({name: value for name, value in unpacked if name is not None})
                pos += op.fmt.size
                continue
            name = op.names[0]
            assert name is not None
            if op.step is _Step.MESSAGE:
                values[name], pos = self._read_message(view, pos, op.item)
                continue
            count = op.size
            if count is None or op.step is _Step.STRING:
                (count,) = LENGTH.unpack_from(view, pos)
                pos += 4
            if op.step is _Step.STRING:
                values[name] = bytes(_take(view, pos, count)).decode()
                pos += count
            elif op.step is _Step.NUMBERS:
                values[name], pos = _read_numbers(view, pos, op.item, count, fixed=op.size is not None)
            else:
                if count > len(view):  # every item takes at least a byte: refuse absurd counts at once
                    raise InvalidInputError(f"sequence<{op.item}>: {count} items announced in {len(view)} bytes")
                items = []
                for _ in range(count):
                    item, pos = self._read_message(view, pos, op.item)
                    items.append(item)
                values[name] = items
        return self._build(type_name, values), pos

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
        if is_string(field_type):
            encoded = str(value).encode()
            out += LENGTH.pack(len(encoded)) + encoded
            return
        array_of = item_and_size(field_type)
        if array_of is not None:
            item, size = array_of
            items = list(value)
            if size is None:
                out += LENGTH.pack(len(items))
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
