"""Bags cut short (no index, or ending inside a chunk), compressed bags, and bags that are not what a replay
needs: each is read as far as it is whole, or refused with one line naming the bag and what is missing."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from rosbags.rosbag1 import Reader, Writer

from mrs_nav.bag.io import read_messages, typestore
from mrs_nav.bag.messages import ODOMETRY, odometry_message, pose_from_odometry
from mrs_nav.bag.salvage import MAGIC, is_unindexed, readable_bag, salvage_bag
from mrs_nav.errors import BagError
from mrs_nav.geometry import Pose2D
from mrs_nav.replay.session_replay import check_types

MESSAGES = 60
PER_CHUNK = 10  # about: the writer closes a chunk once it exceeds its threshold


def _write(path: Path, compression: str | None) -> None:
    """A bag of MESSAGES odometry messages on /odom, in chunks of PER_CHUNK messages."""
    writer = Writer(path)
    if compression:
        writer.set_compression(Writer.CompressionFormat[compression.upper()])
    writer.open()
    conn = writer.add_connection("/odom", ODOMETRY, typestore=typestore(), latching=0)
    one = len(typestore().serialize_ros1(odometry_message(Pose2D(0, 0, 0), 0.0, "odom", "base"), ODOMETRY))
    writer.chunk_threshold = PER_CHUNK * one - 1  # a chunk is closed after PER_CHUNK messages
    for i in range(MESSAGES):
        msg = odometry_message(Pose2D(0.01 * i, 0.0, 0.0), 0.1 * i, "odom", "base_footprint")
        writer.write(conn, 100_000_000 * i + 1, typestore().serialize_ros1(msg, ODOMETRY))
    writer.close()


def _unindexed_copy(bag: Path, out: Path, cut: int | None = None) -> Path:
    """What a killed ``rosbag record`` leaves: header index_pos 0 and the file cut at byte ``cut``."""
    data = bytearray(bag.read_bytes())
    pos = data.index(b"index_pos=", len(MAGIC)) + len(b"index_pos=")
    index_pos = struct.unpack_from("<Q", data, pos)[0]
    struct.pack_into("<Q", data, pos, 0)
    out.write_bytes(bytes(data[: index_pos if cut is None else cut]))
    return out


def _chunks(bag: Path) -> list[tuple[int, int]]:
    """``(file position, message count)`` of each chunk of a closed bag."""
    with Reader(bag) as reader:
        return [(info.pos, sum(info.connection_counts.values())) for info in reader.chunk_infos]


def _xs(bag: Path) -> list[float]:
    return [pose_from_odometry(m).x for _, _, m in read_messages(bag, ["/odom"])]


@pytest.mark.parametrize("compression", [None, "lz4", "bz2"])
def test_killed_recording_is_read_up_to_its_last_whole_chunk(compression, tmp_path):
    bag = tmp_path / "full.bag"
    _write(bag, compression)
    chunks = _chunks(bag)
    assert len(chunks) >= 4
    # Killed in the middle of the fourth chunk: the first three are whole.
    active = _unindexed_copy(bag, tmp_path / "session.bag.active", (chunks[3][0] + chunks[4][0]) // 2)
    before = active.read_bytes()
    assert is_unindexed(active)
    assert not is_unindexed(bag)
    path, note = readable_bag(active, tmp_path / "work")
    assert active.read_bytes() == before  # the input is never written
    assert path.parent == tmp_path / "work"
    assert path.name == "session.bag.salvaged.bag"
    xs = _xs(path)
    whole = sum(count for _, count in chunks[:3])
    assert xs == pytest.approx([0.01 * i for i in range(whole)])  # the whole chunks' messages, in order
    assert note is not None
    assert f"read {whole} messages in 3 whole chunks" in note
    assert "session.bag.active" in note


def test_unindexed_but_complete_recording_keeps_every_message(tmp_path):
    bag = tmp_path / "full.bag"
    _write(bag, "lz4")
    active = _unindexed_copy(bag, tmp_path / "b.bag.active")
    report = salvage_bag(active, tmp_path / "rebuilt.bag")
    assert report.messages == MESSAGES
    assert report.bytes_used == report.bytes_total
    assert _xs(report.output) == pytest.approx(_xs(bag))


def test_indexed_bags_are_read_in_place(tmp_path):
    bag = tmp_path / "ok.bag"
    _write(bag, "bz2")
    assert readable_bag(bag, tmp_path) == (bag, None)


def test_truncated_closed_bag_names_what_is_missing(tmp_path):
    bag = tmp_path / "full.bag"
    _write(bag, "lz4")
    cut = tmp_path / "cut.bag"
    cut.write_bytes(bag.read_bytes()[: bag.stat().st_size // 2])
    with pytest.raises(
        BagError, match=r"bag .*cut\.bag is truncated: its index should start at byte \d+ but the file "
    ):
        readable_bag(cut, tmp_path)


def test_recording_killed_before_its_first_chunk(tmp_path):
    bag = tmp_path / "full.bag"
    _write(bag, None)
    early = _unindexed_copy(bag, tmp_path / "early.bag.active", _chunks(bag)[0][0] + 50)
    with pytest.raises(BagError, match=r"early\.bag\.active has no index and no whole chunk of messages"):
        readable_bag(early, tmp_path)


@pytest.mark.parametrize(
    ("content", "message"),
    [(b"", "is not a ROS 1 bag"), (b"#ROSBAG V1.2\n", "is not a ROS 1 bag"), (None, "does not exist")],
)
def test_not_a_bag(content, message, tmp_path):
    path = tmp_path / "x.bag"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(BagError, match=rf"bag .*x\.bag {message}"):
        readable_bag(path, tmp_path)


def test_unknown_and_wrong_types_name_the_topic(tmp_path):
    bag = tmp_path / "odd.bag"
    writer = Writer(bag)
    writer.open()
    odd = writer.add_connection("/scan", "mrs_test/msg/Blob", msgdef="uint8[] data\n", md5sum="0" * 32)
    writer.write(odd, 1, b"\0\0\0\0")
    writer.close()
    with pytest.raises(
        BagError, match=r"odd\.bag: topic /scan has type mrs_test/msg/Blob, expected sensor_msgs/msg/Las"
    ):
        check_types(bag)
    with pytest.raises(BagError, match=r"odd\.bag: topic /scan has type mrs_test/msg/Blob, which mrs_nav cannot read"):
        list(read_messages(bag, ["/scan"]))
