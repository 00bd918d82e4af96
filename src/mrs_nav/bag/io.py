"""Reading and writing ROS 1 bags with rosbags' Noetic type store (plus ``tf2_msgs/TFMessage``).

Errors become :class:`mrs_nav.errors.BagError` naming the bag (and the topic when one is missing).
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Iterable, Iterator
from pathlib import Path
from types import TracebackType
from typing import Any

from rosbags.rosbag1 import Reader, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from mrs_nav.atomic_write import atomic_path
from mrs_nav.bag.definitions import connection_store
from mrs_nav.errors import BagError

TF_MESSAGE = "tf2_msgs/msg/TFMessage"
_TF_MESSAGE_DEF = "geometry_msgs/TransformStamped[] transforms\n"


@functools.cache
def typestore() -> Any:
    """The ROS 1 Noetic type store with ``tf2_msgs/TFMessage`` registered (Noetic's store lacks it)."""
    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(get_types_from_msg(_TF_MESSAGE_DEF, TF_MESSAGE))
    return store


class BagWriter:
    """Write messages to a new ROS 1 bag (BZ2-compressed chunks unless ``compress=False``).

    BZ2, not LZ4: Debian's rosbag cannot decompress the LZ4 chunks rosbags writes ("malformed data to
    decompress"), and every bag mrs_nav writes must open in the user's own rosbag tools.
    """

    def __init__(self, path: Path, *, compress: bool = True) -> None:
        self.path = path
        self._compress = compress
        self._connections: dict[str, Any] = {}
        self._writer: Writer | None = None
        self._open = contextlib.ExitStack()

    def __enter__(self) -> BagWriter:
        """Open a temporary bag beside :attr:`path`; it replaces :attr:`path` only when the block succeeds
        (:func:`mrs_nav.atomic_write.atomic_path`), so an existing bag is replaced only by a whole new one.
        A recording stopped by Ctrl-C is the exception: what was recorded is closed into a whole bag and kept,
        as ``rosbag record`` keeps it, before the interrupt goes on."""
        with contextlib.ExitStack() as stack:
            temp = stack.enter_context(atomic_path(self.path, "bag"))
            writer = Writer(temp)
            if self._compress:
                writer.set_compression(Writer.CompressionFormat.BZ2)  # must precede open()
            try:
                writer.open()
            except OSError:
                raise  # atomic_path names the bag and the system's reason
            except Exception as err:
                raise BagError(f"cannot create bag {self.path}: {err}") from None
            stack.callback(writer.close)  # runs before the rename: the index is written first
            self._writer = writer
            self._open = stack.pop_all()
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if exc_type is not None and issubclass(exc_type, KeyboardInterrupt):
            self._open.__exit__(None, None, None)  # close and rename: the messages so far are a valid bag
            return
        self._open.__exit__(exc_type, exc, tb)

    def write(self, topic: str, msgtype: str, stamp_ns: int, message: Any, *, latching: bool = False) -> None:
        """Append ``message`` (a rosbags message object of ``msgtype``) on ``topic`` at ``stamp_ns``."""
        if self._writer is None:
            raise BagError(f"bag {self.path} is not open (use BagWriter as a context manager)")
        store = typestore()
        conn = self._connections.get(topic)
        if conn is None:
            conn = self._writer.add_connection(topic, msgtype, typestore=store, latching=int(latching))
            self._connections[topic] = conn
        self._writer.write(conn, stamp_ns, store.serialize_ros1(message, msgtype))


def bag_topics(path: Path) -> dict[str, str]:
    """``{topic: message type}`` of a bag."""
    try:
        with Reader(path) as reader:
            return {topic: info.msgtype for topic, info in reader.topics.items() if info.msgtype}
    except Exception as err:
        raise BagError(f"cannot read bag {path}: {err}") from None


def read_messages(path: Path, topics: Iterable[str], *, required: Iterable[str] = ()) -> Iterator[tuple[str, int, Any]]:
    """Yield ``(topic, bag time ns, message)`` for ``topics`` in time order.

    Each connection is decoded as it was written (:func:`mrs_nav.bag.definitions.connection_store`). Raises
    :class:`BagError` when the bag cannot be read, lacks one of the ``required`` topics or holds a connection
    whose definition mrs_nav cannot read.
    """
    wanted = set(topics)
    store = typestore()
    try:
        reader = Reader(path)
        reader.open()
    except Exception as err:
        raise BagError(f"cannot read bag {path}: {err}") from None
    try:
        missing = sorted(set(required) - set(reader.topics))
        if missing:
            present = ", ".join(sorted(reader.topics)) or "none"
            raise BagError(f"bag {path} has no {', '.join(missing)} topic (topics: {present})")
        connections = [c for c in reader.connections if c.topic in wanted]
        for conn in connections:
            if conn.msgtype not in store.types:
                raise BagError(f"bag {path}: topic {conn.topic} has type {conn.msgtype}, which mrs_nav cannot read")
        if not connections:  # rosbags reads every connection when given none
            return
        stores = {conn.id: connection_store(conn, store, path) for conn in connections}
        try:
            for conn, stamp, raw in reader.messages(connections=connections):
                yield conn.topic, stamp, stores[conn.id].deserialize_ros1(raw, conn.msgtype)
        except BagError:
            raise
        except Exception as err:
            raise BagError(f"bag {path} is damaged: {err}") from None
    finally:
        reader.close()
