"""`slam.launch sim:=false play:=BAG`: a recorded session played into the live SLAM node on sim time, without
the bag's own /map, /path and map->odom."""

from __future__ import annotations

import threading
from typing import Any

import pytest

from tests.rosharness import REPO, RosMaster, wait_for

pytestmark = pytest.mark.ros


def test_a_recorded_session_is_mapped_live_with_only_the_live_map_and_correction(
    ros_master: RosMaster, rospy_node: Any
) -> None:
    rospy = rospy_node
    from nav_msgs.msg import OccupancyGrid
    from tf2_msgs.msg import TFMessage

    lock = threading.Lock()
    map_sources: set[str] = set()
    correction_sources: set[str] = set()

    def on_map(msg: Any) -> None:
        with lock:
            map_sources.add(msg._connection_header["callerid"])

    def on_tf(msg: Any) -> None:
        with lock:
            for t in msg.transforms:
                if t.header.frame_id.lstrip("/") == "map":
                    correction_sources.add(msg._connection_header["callerid"])

    subs = [
        rospy.Subscriber("/map", OccupancyGrid, on_map, queue_size=10),
        rospy.Subscriber("/tf", TFMessage, on_tf, queue_size=100),
    ]
    bag = REPO / "tests" / "data" / "bags" / "simple.bag"
    try:
        with ros_master.launch(
            "slam.launch", "sim:=false", "rviz:=false", f"play:={bag}", "play_options:=-r 4"
        ) as proc:
            wait_for(lambda: proc.poll() is not None or len(map_sources) > 0, 60.0, "a map from the live SLAM")
            wait_for(lambda: len(correction_sources) > 0, 30.0, "map->odom on /tf")
            assert rospy.get_param("/use_sim_time") is True
            published = dict(rospy.get_published_topics())
            assert "/path" not in published
            # until late in the bag (42 s, its clock from 0): a fixed span after the first map ran past the bag's end
            # on a loaded machine, where the first map came late
            wait_for(lambda: rospy.get_time() > 35.0, 120.0, "35 s of the bag")
            assert proc.poll() is None
        with lock:
            assert map_sources == {"/slam"}
            assert correction_sources == {"/slam"}
    finally:
        for sub in subs:
            sub.unregister()
