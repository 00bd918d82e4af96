"""Bags are read as written: a connection whose definition differs from Noetic's is decoded by its own
definition when it has the same fields, and refused (one line naming topic, type and md5) when it has not."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from rosbags.rosbag1 import Reader, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from mrs_nav.bag.io import read_messages, typestore
from mrs_nav.bag.messages import ODOMETRY, odometry_message, pose_from_odometry
from mrs_nav.errors import BagError
from mrs_nav.geometry import Pose2D

REPO = Path(__file__).resolve().parents[3]
NOETIC_POINT = "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\n"


def odometry_definition(point: str) -> tuple[str, str, object]:
    """Noetic's nav_msgs/Odometry with its geometry_msgs/Point section replaced: (definition, md5, store)."""
    text = typestore().generate_msgdef(ODOMETRY)[0]
    assert NOETIC_POINT in text
    text = text.replace(NOETIC_POINT, point)
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(text, ODOMETRY))
    return text, store.generate_msgdef(ODOMETRY)[1], store


def write_odometry(bag: Path, point: str, poses: list[Pose2D], md5: str | None = None) -> str:
    """A bag of /odom messages in the layout of ``point`` (serialised by that layout); returns the md5 stored."""
    text, digest, store = odometry_definition(point)
    noetic = typestore()
    with Writer(bag) as writer:
        conn = writer.add_connection("/odom", ODOMETRY, msgdef=text, md5sum=md5 or digest)
        for k, pose in enumerate(poses):
            raw = noetic.serialize_ros1(odometry_message(pose, float(k), "odom", "base_footprint"), ODOMETRY)
            message = noetic.deserialize_ros1(raw, ODOMETRY)
            writer.write(conn, k * 1_000_000_000, _serialize_in(store, message))
    return md5 or digest


def _serialize_in(store, message):
    """``message`` (Noetic's classes) serialised with ``store``'s layout, field by field by name (a point's
    ``u`` and ``v`` taking its ``x`` and ``y``)."""

    def convert(value, typename):
        if typename not in store.fielddefs:
            return value
        fields = store.fielddefs[typename][1]
        kwargs = {}
        for name, desc in fields:
            sub = getattr(value, {"u": "x", "v": "y"}.get(name, name))
            kwargs[name] = convert(sub, desc[1]) if isinstance(desc[1], str) else sub
        return store.types[typename](**kwargs)

    return store.serialize_ros1(convert(message, ODOMETRY), ODOMETRY)


def test_odometry_with_x_and_y_swapped_in_its_definition_is_read_as_written(tmp_path):
    bag = tmp_path / "swapped.bag"
    write_odometry(bag, "MSG: geometry_msgs/Point\nfloat64 y\nfloat64 x\n", [Pose2D(1.0, 2.0, 0.3)])
    ((_, _, message),) = list(read_messages(bag, ["/odom"]))
    pose = pose_from_odometry(message)
    assert (pose.x, pose.y) == pytest.approx((1.0, 2.0))
    assert pose.yaw == pytest.approx(0.3)


@pytest.mark.parametrize(
    ("point", "md5", "why"),
    [
        ("MSG: geometry_msgs/Point\nfloat64 u\nfloat64 v\n", None, "other fields"),
        ("MSG: geometry_msgs/Point\nfloat32 x\nfloat32 y\n", None, "other fields"),
        ("MSG: geometry_msgs/Point\nfloat64 y\nfloat64 x\n", "0123456789abcdef0123456789abcdef", "hashes to"),
    ],
)
def test_a_definition_that_cannot_be_read_as_written_is_refused(tmp_path, point, md5, why):
    bag = tmp_path / "other.bag"
    stored = write_odometry(bag, point, [Pose2D(1.0, 2.0, 0.3)], md5)
    with pytest.raises(BagError) as caught:
        list(read_messages(bag, ["/odom"]))
    line = str(caught.value)
    assert "\n" not in line
    for word in ("/odom", ODOMETRY, stored, why):
        assert word in line


def test_replay_of_a_bag_with_its_own_odometry_layout_gives_the_same_metrics(tmp_path):
    """simple.bag rewritten with /odom in a layout of x and y swapped: the replay's metrics are the same."""
    source = REPO / "tests" / "data" / "bags" / "simple.bag"
    swapped = tmp_path / "swapped.bag"
    text, digest, store = odometry_definition("MSG: geometry_msgs/Point\nfloat64 y\nfloat64 x\n")
    noetic = typestore()
    with Reader(source) as reader, Writer(swapped) as writer:
        out = {}
        for conn in reader.connections:
            if conn.topic == "/odom":
                out[conn.id] = writer.add_connection(conn.topic, conn.msgtype, msgdef=text, md5sum=digest)
            else:
                out[conn.id] = writer.add_connection(
                    conn.topic, conn.msgtype, msgdef=conn.msgdef.data, md5sum=conn.digest, latching=conn.ext.latching
                )
        for conn, stamp, raw in reader.messages():
            if conn.topic == "/odom":
                raw = _serialize_in(store, noetic.deserialize_ros1(raw, ODOMETRY))
            writer.write(out[conn.id], stamp, raw)
    metrics = []
    for bag in (source, swapped):
        out_dir = tmp_path / bag.stem
        result = subprocess.run(
            [sys.executable, "-m", "mrs_nav", "replay", str(bag), "--slam", "--out", str(out_dir)],
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
        assert result.returncode == 0, result.stderr
        metrics.append(json.loads((out_dir / "metrics.json").read_text()))
    assert metrics[0] == metrics[1]
