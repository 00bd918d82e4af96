"""ROS 1 wire bytes -> the CDR bytes a ROS 2 publisher sends, without making a message object.

rclpy publishes serialised bytes as they are (``Publisher.publish(bytes)``), so the ROS 2 bridge's hot topics
skip rclpy's message objects and their conversion to C: the ROS 1 bytes are rewritten into XCDR1 little-endian
(what rmw_fastrtps serialises), which differs from ROS 1's layout in four ways only:

- a 4-byte encapsulation header (``00 01 00 00``: CDR, little-endian) in front;
- every primitive aligned to its size (at most 8) from the end of that header, with zero padding;
- a string's length counts its terminating NUL, which follows its bytes;
- ``std_msgs/Header`` has no ``seq`` (:data:`~mrs_nav.bridge.ros1_codec.ROS1_ONLY_FIELDS`).

As :class:`~mrs_nav.bridge.ros1_codec.Ros1Codec`, a type is described by ROS 2's field descriptions and rewritten
by a plan made once per type: nested messages and fixed arrays are flattened into runs of primitives, and a run is
copied in as few slices as its padding allows (an Odometry's 85 doubles are one slice).
"""

from __future__ import annotations

import enum
import struct
from dataclasses import dataclass

from mrs_nav.bridge.ros1_codec import LENGTH, PRIMITIVES, ROS1_ONLY_FIELDS, FieldsOf, is_string, item_and_size
from mrs_nav.errors import InvalidInputError

#: CDR (not PL_CDR), little-endian, no options.
ENCAPSULATION = b"\x00\x01\x00\x00"
_HEADER = len(ENCAPSULATION)
_ZEROS = bytes(8)


class _Step(enum.Enum):
    RUN = 1  # primitives in a row (nested messages and fixed arrays flattened)
    STRING = 2
    NUMBERS = 3  # a sequence of primitives
    ITEMS = 4  # a sequence of strings or messages


@dataclass(frozen=True)
class _Op:
    step: _Step
    # RUN: per output offset modulo 8, the (source offset, length, padding before) slices; and the source size
    slices: tuple[tuple[tuple[int, int, int], ...], ...] = ()
    size: int = 0  # RUN: bytes in ROS 1; NUMBERS: one item's bytes
    items: tuple[_Op, ...] = ()  # ITEMS: the plan of one item


def _slices(items: list[tuple[int, int, bool]], start: int) -> tuple[tuple[int, int, int], ...]:
    """The copy of a run of ``items`` (item size, count, kept) written at an output offset of ``start`` mod 8."""
    out: list[list[int]] = []
    src, dst = 0, start
    for size, count, kept in items:
        length = size * count
        if kept:
            pad = -dst % min(size, 8)
            if out and pad == 0 and out[-1][0] + out[-1][1] == src:
                out[-1][1] += length
            else:
                out.append([src, length, pad])
            dst += pad + length
        src += length
    return tuple((s, n, p) for s, n, p in out)


def _run(items: list[tuple[int, int, bool]]) -> _Op:
    size = sum(s * c for s, c, _ in items)
    return _Op(_Step.RUN, tuple(_slices(items, start) for start in range(8)), size)


class Ros1ToCdr:
    """Rewrites ROS 1 bytes of a type described by ``fields_of`` (see the module docstring) into CDR bytes."""

    def __init__(self, fields_of: FieldsOf) -> None:
        self._fields_of = fields_of
        self._plans: dict[str, tuple[_Op, ...]] = {}

    def transcode(self, type_name: str, data: bytes | memoryview) -> bytes:
        """The CDR bytes of the message of ``type_name`` in ``data``; InvalidInputError if ``data`` does not hold
        exactly one."""
        view = memoryview(data)
        out = bytearray(ENCAPSULATION)
        try:
            end = self._write(self.plan(type_name), view, 0, out)
        except (struct.error, UnicodeDecodeError, InvalidInputError) as err:
            raise InvalidInputError(f"{type_name}: malformed ROS 1 message: {err}") from None
        if end != len(view):
            raise InvalidInputError(f"{type_name}: {len(view) - end} bytes left after the message")
        return bytes(out)

    def plan(self, type_name: str) -> tuple[_Op, ...]:
        """The rewriting steps of ``type_name``; InvalidInputError for a type with a wide string."""
        plan = self._plans.get(type_name)
        if plan is None:
            ops: list[_Op] = []
            run: list[tuple[int, int, bool]] = []
            self._flatten(type_name, ops, run)
            if run:
                ops.append(_run(run))
            plan = self._plans[type_name] = tuple(ops)
        return plan

    def _flatten(self, type_name: str, ops: list[_Op], run: list[tuple[int, int, bool]]) -> None:
        """Appends ``type_name``'s steps to ``ops``, primitives to the open ``run`` (item size, count, kept)."""

        def close() -> None:
            if run:
                ops.append(_run(run))
                run.clear()

        fields = [(t, False) for _, t in ROS1_ONLY_FIELDS.get(type_name, ())]
        fields += [(t, True) for t in self._fields_of(type_name).values()]
        for field_type, kept in fields:
            array_of = item_and_size(field_type)
            item, count = array_of if array_of is not None else (field_type, 1)
            if field_type.startswith("wstring") or item.startswith("wstring"):
                raise InvalidInputError(f"{type_name}: wide strings are not rewritten to CDR")
            if item in PRIMITIVES and count is not None:
                run.append((struct.calcsize(PRIMITIVES[item][0]), count, kept))
                continue
            if count is None:  # a sequence
                close()
                if item in PRIMITIVES:
                    ops.append(_Op(_Step.NUMBERS, size=struct.calcsize(PRIMITIVES[item][0])))
                else:
                    ops.append(_Op(_Step.ITEMS, items=self.plan(item) if not is_string(item) else (_STRING,)))
                continue
            for _ in range(count):
                if is_string(item):
                    close()
                    ops.append(_STRING)
                else:
                    self._flatten(item, ops, run)

    def _write(self, plan: tuple[_Op, ...], view: memoryview, pos: int, out: bytearray) -> int:
        """Appends the CDR of the message at ``pos`` of ``view`` to ``out``; the position after it."""
        for op in plan:
            if op.step is _Step.RUN:
                end = pos + op.size
                if end > len(view):
                    raise InvalidInputError(f"message truncated: needs {end} bytes, has {len(view)}")
                for src, length, pad in op.slices[(len(out) - _HEADER) % 8]:
                    if pad:
                        out += _ZEROS[:pad]
                    out += view[pos + src : pos + src + length]
                pos = end
                continue
            (count,) = LENGTH.unpack_from(view, pos)
            pos += 4
            out += _ZEROS[: -(len(out) - _HEADER) % 4]
            if op.step is _Step.STRING:
                text = view[pos : pos + count]
                if len(text) != count:
                    raise InvalidInputError(f"string truncated: {count} bytes announced, {len(text)} left")
                str(text, "utf-8")  # refused as the object path refuses it
                out += LENGTH.pack(count + 1)
                out += text
                out += b"\x00"
                pos += count
            elif op.step is _Step.NUMBERS:
                length = count * op.size
                if pos + length > len(view):
                    raise InvalidInputError(f"sequence truncated: {count} items need {length} bytes")
                out += LENGTH.pack(count)
                if count:
                    out += _ZEROS[: -(len(out) - _HEADER) % min(op.size, 8)]
                    out += view[pos : pos + length]
                pos += length
            else:
                if count > len(view):  # every item takes at least a byte: refuse absurd counts at once
                    raise InvalidInputError(f"sequence: {count} items announced in {len(view)} bytes")
                out += LENGTH.pack(count)
                for _ in range(count):
                    pos = self._write(op.items, view, pos, out)
        return pos


_STRING = _Op(_Step.STRING)
