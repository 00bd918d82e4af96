"""Reading a bag whose recording was cut short: unindexed (``.bag.active``) or truncated mid-chunk.

A ROS 1 bag (format 2.0) is the line ``#ROSBAG V2.0`` followed by records, each
``<header length u32><header fields><data length u32><data>`` with header fields ``<len u32>name=value``.
``rosbag record`` writes a bag header (op 0x03) whose ``index_pos`` stays 0 until the recording is closed, then
chunk records (op 0x05, ``compression`` none/bz2/lz4) holding connection (0x07) and message (0x02) records, and
finally the index. A recording killed with SIGKILL leaves no index (and may end inside a chunk), so rosbags'
reader refuses it.

:func:`salvage_bag` walks the records in file order, keeps every connection and message of each chunk that is
whole and decompresses, stops at the first incomplete record, and writes them to a new, indexed bag. The input
is only ever read: rebuilding into a separate file is what Debian's ``rosbag reindex`` does in place after a
backup, without the risk to the original.
"""

from __future__ import annotations

import bz2
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

from lz4.frame import decompress as lz4_decompress  # type: ignore[import-untyped]
from rosbags.rosbag1 import Writer, WriterError

from mrs_nav.atomic_write import atomic_path
from mrs_nav.errors import BagError

MAGIC = b"#ROSBAG V2.0\n"
OP_MESSAGE = 0x02
OP_BAG_HEADER = 0x03
OP_CHUNK = 0x05
OP_CONNECTION = 0x07


@dataclass(frozen=True)
class SalvageReport:
    """What :func:`salvage_bag` kept: whole chunks, messages, connections, and the bytes read of the input."""

    source: Path
    output: Path
    chunks: int
    messages: int
    connections: int
    bytes_used: int
    bytes_total: int

    def describe(self) -> str:
        """One line for the user: what was read and what was lost."""
        lost = self.bytes_total - self.bytes_used
        return (
            f"bag {self.source} has no index (recording cut short): read {self.messages} messages in "
            f"{self.chunks} whole chunks up to byte {self.bytes_used} of {self.bytes_total}"
            + (f" ({lost} trailing bytes of an incomplete chunk or index skipped)" if lost else "")
            + f"; rebuilt copy at {self.output}"
        )


@dataclass(frozen=True)
class _Connection:
    topic: str
    msgtype: str
    md5sum: str
    msgdef: str
    callerid: str | None
    latching: int | None


def is_unindexed(path: Path) -> bool:
    """Whether ``path`` is a format-2.0 bag whose header has no index position (a recording never closed)."""
    try:
        with path.open("rb") as f:
            if f.readline() != MAGIC:
                return False
            record = _read_record(f)
    except OSError:
        return False
    if record is None:
        return True  # the bag header itself is incomplete: nothing indexed
    fields, _ = record
    return fields.get("op") == bytes([OP_BAG_HEADER]) and _u64(fields.get("index_pos")) == 0


def salvage_bag(source: Path, output: Path) -> SalvageReport:
    """Rebuild ``source`` (read only) into the new indexed bag ``output`` from its whole chunks.

    Raises :class:`BagError` when ``source`` is not a ROS 1 format-2.0 bag or holds no whole chunk.
    """
    total = source.stat().st_size
    connections: dict[int, _Connection] = {}
    messages: list[tuple[int, int, bytes]] = []
    chunks = 0
    try:
        with source.open("rb") as f:
            if f.readline() != MAGIC:
                raise BagError(f"bag {source} is not a ROS 1 bag (format 2.0): its first line is not {MAGIC!r}")
            used = f.tell()
            for fields, data in _records(f):
                # A record or chunk that does not decompress or parse ends what can be trusted: everything
                # before it is kept, nothing after it is guessed at.
                found_connections: dict[int, _Connection] = {}
                found_messages: list[tuple[int, int, bytes]] = []
                try:
                    if fields.get("op", b"\xff")[:1] == bytes([OP_CHUNK]):
                        for inner_fields, inner_data in _records_in(_decompress(fields, data)):
                            _collect(inner_fields, inner_data, found_connections, found_messages)
                        chunks += 1
                    else:
                        _collect(fields, data, found_connections, found_messages)
                except _DAMAGE:
                    break
                for conn_id, conn in found_connections.items():
                    connections.setdefault(conn_id, conn)
                messages += found_messages
                used = f.tell()
    except OSError as err:
        raise BagError(f"cannot read bag {source}: {err.strerror}") from None
    if not messages:
        raise BagError(f"bag {source} has no index and no whole chunk of messages ({total} bytes): nothing to read")
    _write(output, connections, messages)
    return SalvageReport(source, output, chunks, len(messages), len(connections), used, total)


# What a damaged (bit-flipped, cut) record or chunk raises while it is decoded.
_DAMAGE = (ValueError, KeyError, IndexError, OSError, RuntimeError, EOFError, struct.error)


def _collect(
    fields: dict[str, bytes], data: bytes, connections: dict[int, _Connection], messages: list[tuple[int, int, bytes]]
) -> None:
    """Add a connection or message record; raises one of :data:`_DAMAGE` when the record is malformed."""
    op = fields.get("op", b"\xff")[0]
    if op == OP_CONNECTION:
        conn_id = struct.unpack("<I", fields["conn"])[0]
        info = _fields(data)
        latching = info.get("latching")
        connections.setdefault(
            conn_id,
            _Connection(
                topic=info.get("topic", fields.get("topic", b"")).decode(),
                msgtype=_normalize(info["type"].decode()),
                md5sum=info["md5sum"].decode(),
                msgdef=info.get("message_definition", b"").decode(),
                callerid=info["callerid"].decode() if "callerid" in info else None,
                latching=int(latching.decode()) if latching else None,
            ),
        )
    elif op == OP_MESSAGE:
        conn_id = struct.unpack("<I", fields["conn"])[0]
        sec, nsec = struct.unpack("<II", fields["time"])
        messages.append((conn_id, sec * 1_000_000_000 + nsec, data))


def _write(output: Path, connections: dict[int, _Connection], messages: list[tuple[int, int, bytes]]) -> None:
    """Write the rebuilt bag whole or not at all (:func:`mrs_nav.atomic_write.atomic_path`)."""
    with atomic_path(output, "rebuilt bag") as temp:
        writer = Writer(temp)
        writer.open()
        try:
            _write_records(writer, connections, messages)
        except (WriterError, ValueError, KeyError) as err:
            # connection records that parsed but that rosbags cannot write (a damaged type name or md5)
            raise BagError(f"cannot rebuild bag into {output}: a connection record is damaged ({err})") from None
        finally:
            writer.close()


def _write_records(writer: Writer, connections: dict[int, _Connection], messages: list[tuple[int, int, bytes]]) -> None:
    """Add each distinct connection once and the messages whose connection is known."""
    added: dict[int, Any] = {}
    by_args: dict[_Connection, Any] = {}
    for conn_id, conn in sorted(connections.items()):
        if conn not in by_args:  # rosbags refuses two connections with identical arguments
            by_args[conn] = writer.add_connection(
                conn.topic,
                conn.msgtype,
                msgdef=conn.msgdef,
                md5sum=conn.md5sum,
                callerid=conn.callerid,
                latching=conn.latching,
            )
        added[conn_id] = by_args[conn]
    for conn_id, stamp, data in messages:
        if conn_id in added:  # a message whose connection record was lost cannot be typed
            writer.write(added[conn_id], stamp, data)


def _normalize(msgtype: str) -> str:
    """``pkg/Name`` (ROS 1) -> ``pkg/msg/Name`` (rosbags' names)."""
    package, _, name = msgtype.rpartition("/")
    return msgtype if "/msg/" in msgtype else f"{package}/msg/{name}"


def _decompress(fields: dict[str, bytes], data: bytes) -> bytes:
    compression = fields.get("compression", b"none").decode()
    if compression == "none":
        return data
    if compression == "bz2":
        return bz2.decompress(data)
    if compression == "lz4":
        return bytes(lz4_decompress(data))
    raise ValueError(f"unknown chunk compression {compression!r}")


def _fields(blob: bytes) -> dict[str, bytes]:
    """``<len u32>name=value`` fields of a record header (or of a connection record's data)."""
    fields: dict[str, bytes] = {}
    pos = 0
    while pos + 4 <= len(blob):
        (size,) = struct.unpack_from("<I", blob, pos)
        pos += 4
        if pos + size > len(blob):
            raise ValueError("header field runs past its header")
        name, sep, value = blob[pos : pos + size].partition(b"=")
        if not sep:
            raise ValueError("header field without '='")
        fields[name.decode()] = value
        pos += size
    return fields


def _read_record(f: BinaryIO) -> tuple[dict[str, bytes], bytes] | None:
    """The next whole record of ``f``, or None at the end of the file or at an incomplete record."""
    head = f.read(4)
    if len(head) < 4:
        return None
    (header_len,) = struct.unpack("<I", head)
    header = f.read(header_len)
    size = f.read(4)
    if len(header) < header_len or len(size) < 4:
        return None
    (data_len,) = struct.unpack("<I", size)
    data = f.read(data_len)
    if len(data) < data_len:
        return None
    try:
        return _fields(header), data
    except (ValueError, UnicodeDecodeError):
        return None


def _records(f: BinaryIO) -> Iterator[tuple[dict[str, bytes], bytes]]:
    while (record := _read_record(f)) is not None:
        yield record


def _records_in(payload: bytes) -> Iterator[tuple[dict[str, bytes], bytes]]:
    pos = 0
    while pos < len(payload):
        header_len = struct.unpack_from("<I", payload, pos)[0]
        header = payload[pos + 4 : pos + 4 + header_len]
        data_len = struct.unpack_from("<I", payload, pos + 4 + header_len)[0]
        start = pos + 8 + header_len
        if start + data_len > len(payload):
            raise ValueError("record runs past its chunk")
        yield _fields(header), payload[start : start + data_len]
        pos = start + data_len


def _u64(value: bytes | None) -> int:
    """A little-endian unsigned header field (4 or 8 bytes); 0 when absent or of another length."""
    if value is None or len(value) not in (4, 8):
        return 0
    return int.from_bytes(value, "little")


def readable_bag(path: Path, workdir: Path) -> tuple[Path, str | None]:
    """A path rosbags can read for ``path``, and a note for the user when it had to be rebuilt.

    An unindexed bag (a recording cut short) is salvaged into ``workdir``; a closed bag cut short (its index
    lies past its end) or anything that is not a bag raises :class:`BagError` naming what is missing.
    """
    if not path.exists():
        raise BagError(f"bag {path} does not exist")
    if path.is_dir():
        raise BagError(f"bag {path} is a folder, not a bag file")
    if not path.is_file():
        raise BagError(f"bag {path} is not a regular file (a device, FIFO or socket cannot be a bag)")
    if is_unindexed(path):
        report = salvage_bag(path, workdir / f"{path.name.removesuffix('.active')}.salvaged.bag")
        return report.output, report.describe()
    size = path.stat().st_size
    with path.open("rb") as f:
        if f.readline() != MAGIC:
            raise BagError(f"bag {path} is not a ROS 1 bag (format 2.0): its first line is not {MAGIC!r}")
        record = _read_record(f)
    header = record[0] if record else {}
    index_pos = _u64(header.get("index_pos"))
    # A bag with no messages (closed normally) has its (empty) index at the very end of the file.
    empty = _u64(header.get("chunk_count")) == 0 and _u64(header.get("conn_count")) == 0
    if index_pos > size or (index_pos == size and not empty):
        raise BagError(
            f"bag {path} is truncated: its index should start at byte {index_pos} but the file ends at byte "
            f"{size} (the index and the last chunks are missing)"
        )
    return path, None
