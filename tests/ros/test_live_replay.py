"""A recorded session played with ``rosbag play --clock`` into the live SLAM node (slam.launch sim:=false) gives
the map the offline replay computes: the node and the core are the same algorithm."""

from __future__ import annotations

import json
import subprocess
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from rosbags.rosbag1 import Reader, Writer

from mrs_nav.bag import topics
from mrs_nav.bag.io import typestore
from mrs_nav.replay.map_compare import compare_maps
from mrs_nav.replay.recorded import grid_from_message
from mrs_nav.replay.session_replay import replayed_map
from mrs_nav.replay.slam_replay import replay_slam
from mrs_nav.slam.config import SlamConfig
from tests.rosharness import RosMaster, robot_state_publisher, stop, wait_for

pytestmark = pytest.mark.ros

BAGS = Path(__file__).resolve().parents[1] / "data" / "bags"
# What a robot (or the simulator) publishes; the recorded SLAM output (/map, map->odom) stays out of the input.
INPUT_TOPICS = {topics.SCAN, topics.ODOM, topics.TF, topics.TF_STATIC, topics.CLOCK}


def _sensor_bag(source: Path, target: Path) -> None:
    """Copy of ``source`` with only the robot's own topics, and no map->odom in /tf."""
    store = typestore()
    with Reader(source) as reader:
        writer = Writer(target)
        writer.open()
        added = {}
        for conn in reader.connections:
            if conn.topic in INPUT_TOPICS and conn.topic not in added:
                added[conn.topic] = writer.add_connection(
                    conn.topic, conn.msgtype, typestore=store, latching=int(conn.topic == topics.TF_STATIC)
                )
        connections = [c for c in reader.connections if c.topic in added]
        for conn, stamp, raw in reader.messages(connections=connections):
            if conn.topic == topics.TF:
                msg = store.deserialize_ros1(raw, conn.msgtype)
                msg.transforms = [t for t in msg.transforms if t.header.frame_id.lstrip("/") != "map"]
                if not msg.transforms:
                    continue
                raw = store.serialize_ros1(msg, conn.msgtype)
            writer.write(added[conn.topic], stamp, raw)
        writer.close()


def test_rosbag_play_into_the_slam_node_agrees_with_offline_replay(
    ros_master: RosMaster, rospy_node: Any, tmp_path: Path
) -> None:
    from nav_msgs.msg import OccupancyGrid as GridMsg

    rospy = rospy_node
    bag = tmp_path / "sensors.bag"
    _sensor_bag(BAGS / "simple.bag", bag)
    golden = json.loads((BAGS / "simple.golden.json").read_text())
    params = [o.removeprefix("--param=") for o in golden["options"] if o.startswith("--param=")]
    config = SlamConfig.from_assignments(params)
    offline = replayed_map(replay_slam(bag, config))

    lock = threading.Lock()
    maps: list[Any] = []

    def on_map(msg: Any) -> None:
        with lock:
            maps.append(msg)

    sub = rospy.Subscriber("/map", GridMsg, on_map, queue_size=5)
    try:
        with live_slam(ros_master):
            # Twice real time only: the node drops scans it cannot keep up with, and the machine is shared.
            play_bag(ros_master, bag, "-r", "2")
            end = _last_stamp(bag)
            # The node publishes /map every map_update_interval of sim time; the last one covers the drive's end.
            wait_for(lambda: _latest_stamp(maps, lock) >= end - config.map_update_interval - 0.5, 30.0, "the last /map")
    finally:
        sub.unregister()
    with lock:
        live = grid_from_message(maps[-1])
    agreement = compare_maps(live, offline)
    assert agreement.iou >= 0.95, agreement
    assert agreement.common_known_cells > 1000


@contextmanager
def live_slam(master: RosMaster) -> Iterator[None]:
    """``slam.launch sim:=false`` (no simulator, no rviz) for the ``with`` block, once its SLAM node takes scans.

    sim:=false means a robot already runs: the bags played into it have no /tf_static, so the robot's description
    comes from its own robot_state_publisher, as on a real robot."""
    with robot_state_publisher(master), master.launch("slam.launch", "sim:=false", "rviz:=false") as launch:
        wait_for(
            lambda: launch.poll() is not None or _subscribed(master, "/scan", "/slam"),
            60.0,
            "the slam node subscribing /scan",
        )
        assert launch.poll() is None, "roslaunch exited"
        yield


def play_bag(master: RosMaster, bag: Path, *options: str) -> None:
    """``rosbag play --clock OPTIONS BAG`` to its end (at most 180 s)."""
    play = subprocess.Popen(
        ["rosbag", "play", "--clock", *options, "-q", str(bag)],
        env=master.env,
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.STDOUT,
    )
    try:
        assert play.wait(timeout=180) == 0
    finally:
        stop(play)


def _subscribed(master: RosMaster, topic: str, node: str) -> bool:
    import xmlrpc.client

    code, _, state = xmlrpc.client.ServerProxy(master.uri).getSystemState("/pytest")
    return code == 1 and any(t == topic and node in nodes for t, nodes in state[1])


def _last_stamp(bag: Path) -> float:
    with Reader(bag) as reader:
        return reader.end_time * 1e-9


def _latest_stamp(maps: list[Any], lock: threading.Lock) -> float:
    with lock:
        return maps[-1].header.stamp.to_sec() if maps else -1.0
