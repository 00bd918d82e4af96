"""Property-based fuzzing of the bag readers: flipped bytes, cut files and lost indexes give messages or a
:class:`~mrs_nav.errors.BagError`, never another exception; and the messages that bags which are not damaged
deserve (an empty bag, a folder, a device)."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rosbags.rosbag1 import Writer

from mrs_nav.bag.io import read_messages, typestore
from mrs_nav.bag.messages import ODOMETRY, odometry_message
from mrs_nav.bag.salvage import MAGIC, readable_bag
from mrs_nav.errors import BagError
from mrs_nav.geometry import Pose2D
from tests.core.fuzzing import attempt

TOPICS = ("/odom", "/ground_truth/odom")


def _bag(path: Path, compression: str | None) -> bytes:
    writer = Writer(path)
    if compression:
        writer.set_compression(Writer.CompressionFormat[compression.upper()])
    writer.open()
    store = typestore()
    connections = [writer.add_connection(topic, ODOMETRY, typestore=store, latching=0) for topic in TOPICS]
    writer.chunk_threshold = 2000  # several chunks
    for i in range(40):
        raw = store.serialize_ros1(odometry_message(Pose2D(0.01 * i, 0.0, 0.0), 0.1 * i, "odom", "base"), ODOMETRY)
        writer.write(connections[i % 2], 100_000_000 * i + 1, raw)
    writer.close()
    return path.read_bytes()


class Bags(dict[str, bytes]):
    """The bytes of one small bag per compression, shown briefly in hypothesis' failure reports."""

    def __repr__(self) -> str:
        return f"Bags({sorted(self)})"


@pytest.fixture(scope="module")
def bags(tmp_path_factory: pytest.TempPathFactory) -> Bags:
    folder = tmp_path_factory.mktemp("bags")
    return Bags({c or "none": _bag(folder / f"{c}.bag", c) for c in (None, "bz2", "lz4")})


def _unindexed(data: bytes) -> bytes:
    """What a killed ``rosbag record`` leaves: the bag header's index_pos set to 0."""
    out = bytearray(data)
    at = out.index(b"index_pos=") + len(b"index_pos=")
    out[at : at + 8] = struct.pack("<Q", 0)
    return bytes(out)


def _read_all(path: Path, workdir: Path) -> int:
    bag, _note = readable_bag(path, workdir)
    return sum(1 for _ in read_messages(bag, TOPICS))


DAMAGE = st.tuples(
    st.sampled_from(["none", "bz2", "lz4"]),  # chunk compression
    st.booleans(),  # unindexed (.bag.active)
    st.lists(st.tuples(st.integers(0, 1 << 20), st.integers(1, 255)), min_size=1, max_size=6),  # xor at offsets
    st.one_of(st.none(), st.integers(0, 1 << 20)),  # cut at
)


@given(DAMAGE)
@settings(max_examples=300)
def test_damaged_bags_give_messages_or_a_bag_error(
    bags: Bags, tmp_path_factory: pytest.TempPathFactory, damage: tuple[str, bool, list[tuple[int, int]], int | None]
) -> None:
    compression, active, flips, cut = damage
    data = bytearray(_unindexed(bags[compression]) if active else bags[compression])
    for position, mask in flips:
        data[position % len(data)] ^= mask
    if cut is not None:
        data = data[: cut % (len(data) + 1)]
    folder = tmp_path_factory.mktemp("fuzz")
    path = folder / ("session.bag.active" if active else "session.bag")
    path.write_bytes(bytes(data))
    count = attempt(lambda: _read_all(path, folder), BagError)
    if isinstance(count, str):
        # names the bag, or the rebuilt copy of it when a message inside a whole chunk is damaged
        assert str(path) in count or f"{path.name.removesuffix('.active')}.salvaged.bag" in count
        return
    assert 0 <= count <= 40
    assert path.read_bytes() == bytes(data)  # the input is never written


def test_an_empty_bag_is_not_called_truncated(tmp_path: Path) -> None:
    path = tmp_path / "empty.bag"
    writer = Writer(path)  # rosbags
    writer.open()
    writer.close()
    bag, note = readable_bag(path, tmp_path)
    assert (bag, note) == (path, None)
    with pytest.raises(BagError, match="has no /odom topic"):
        list(read_messages(bag, TOPICS, required=["/odom"]))


def test_an_empty_bag_from_debians_rosbag_is_not_called_truncated(tmp_path: Path) -> None:
    rosbag = pytest.importorskip("rosbag")
    path = tmp_path / "empty.bag"
    rosbag.Bag(str(path), "w").close()
    assert path.read_bytes().startswith(MAGIC)
    assert readable_bag(path, tmp_path) == (path, None)


def test_a_folder_or_a_device_is_named_as_such(tmp_path: Path) -> None:
    with pytest.raises(BagError, match="is a folder, not a bag file"):
        readable_bag(tmp_path, tmp_path)
    with pytest.raises(BagError, match="is not a regular file"):
        readable_bag(Path("/dev/zero"), tmp_path)
    with pytest.raises(BagError, match="does not exist"):
        readable_bag(tmp_path / "missing.bag", tmp_path)
