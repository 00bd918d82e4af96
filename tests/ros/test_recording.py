"""Recording with Debian's ``rosbag record`` (launch/record.launch) beside the simulator, and replaying the bags
offline: a recording closed normally (bz2) and one killed with SIGKILL (lz4, left as ``.bag.active``); and played
the standard way (``rosbag play --clock``) into the live SLAM."""

from __future__ import annotations

import itertools
import json
import os
import signal
import threading
from pathlib import Path
from typing import Any

import pytest

from mrs_nav.bag.io import bag_topics, read_messages
from mrs_nav.bag.salvage import readable_bag, salvage_bag
from mrs_nav.cli.main import main
from mrs_nav.errors import BagError
from mrs_nav.ros_processes import process
from tests.rosharness import RosMaster, node_pid, wait_for

pytestmark = pytest.mark.ros

MIN_SCANS = 10  # on disk before the recording is stopped
# Topics the simulator alone publishes (no SLAM, no navigation in this test), bar its /clock, which is not recorded.
SIM_TOPICS = {"/scan", "/odom", "/tf", "/tf_static", "/ground_truth/odom"}


def _scans_on_disk(active: Path, probe: Path) -> int:
    """Scans in the whole chunks ``rosbag record`` has written so far."""
    try:
        salvage_bag(active, probe)
        return sum(1 for _ in read_messages(probe, ["/scan"]))
    except BagError:
        return 0
    finally:
        probe.unlink(missing_ok=True)


def _record(master: RosMaster, rospy: Any, bag: Path, options: str, *, kill: bool) -> None:
    """Run the simulator at maximum rate, turning the robot on the spot, and record.launch until 8 sim seconds
    are in the bag."""
    from geometry_msgs.msg import Twist

    turn = Twist()
    turn.linear.x, turn.angular.z = 0.05, 1.0
    written = Path(f"{bag}.active")
    cmd = rospy.Publisher("/cmd_vel", Twist, queue_size=1)
    try:
        with master.launch("simulation.launch", "real_time_factor:=0", name=f"sim-{bag.stem}"):
            wait_for(lambda: rospy.get_time() > 0.5, 60.0, "/clock from the simulator")
            with master.launch("record.launch", f"bag:={bag}", f"options:={options}", name=f"record-{bag.stem}"):
                wait_for(written.is_file, 30.0, f"{written} from rosbag record")
                start = rospy.get_time()

                def turned() -> bool:
                    cmd.publish(turn)  # the simulator's watchdog stops the robot without fresh commands
                    return bool(rospy.get_time() > start + 8.0)

                wait_for(turned, 120.0, "8 sim seconds of recording")
                # rosbag record may subscribe to /scan well after the file is open (at max rate 8 sim seconds can
                # pass first on a loaded machine): the scans must be on disk before the kill loses its queue.
                probe = bag.with_name(f"{bag.stem}-probe.bag")
                wait_for(lambda: turned() and _scans_on_disk(written, probe) >= MIN_SCANS, 120.0, "scans on disk", 0.5)
                if kill:
                    os.kill(node_pid(master, "/record"), signal.SIGKILL)
    finally:
        cmd.unregister()


def test_closed_recording_replays(ros_master: RosMaster, rospy_node: Any, tmp_path: Path, capsys: Any) -> None:
    bag = tmp_path / "closed.bag"
    _record(ros_master, rospy_node, bag, "--bz2 --chunksize=64", kill=False)
    wait_for(bag.is_file, 30.0, "rosbag record to close the bag")
    assert readable_bag(bag, tmp_path) == (bag, None)
    assert set(bag_topics(bag)) >= SIM_TOPICS
    assert main(["replay", str(bag), "--slam", "--out", str(tmp_path / "out"), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert summary["scans"] >= 3
    assert summary["ate_rmse_m"] < 0.05, summary  # ground truth was recorded too


def test_killed_recording_is_salvaged_and_replays(
    ros_master: RosMaster, rospy_node: Any, tmp_path: Path, capsys: Any
) -> None:
    bag = tmp_path / "killed.bag"
    _record(ros_master, rospy_node, bag, "--lz4 --chunksize=32", kill=True)
    active = Path(f"{bag}.active")
    assert active.is_file()
    assert not bag.exists()
    before = active.read_bytes()
    assert main(["replay", str(active), "--slam", "--out", str(tmp_path / "out"), "--json"]) == 0
    captured = capsys.readouterr()
    assert active.read_bytes() == before  # never written
    assert f"NOTE: bag {active} has no index (recording cut short): read " in captured.err
    summary = json.loads(captured.out.splitlines()[-1])
    assert summary["scans"] >= 3
    salvaged, _ = readable_bag(active, tmp_path / "work")
    assert set(bag_topics(salvaged)) >= SIM_TOPICS


def _subscribed(master: RosMaster, topic: str, node: str) -> bool:
    import rosgraph

    _, subscriptions, _ = rosgraph.Master("/pytest", master_uri=master.uri).getSystemState()
    return any(name == topic and node in nodes for name, nodes in subscriptions)


def test_a_recording_plays_into_live_slam_the_standard_way(
    ros_master: RosMaster, rospy_node: Any, tmp_path: Path
) -> None:
    """docs/tutorials/slam-own-bag.md: `simulation.launch record:=true`, then `rosbag play --clock BAG` into
    `slam.launch sim:=false`. One clock going forward (a recorded /clock beside rosbag's made time go back and
    forth), no jump back logged, and the live SLAM's map->odom."""
    rospy = rospy_node
    from geometry_msgs.msg import Twist
    from rosgraph_msgs.msg import Clock
    from tf2_msgs.msg import TFMessage

    bag = tmp_path / "session.bag"
    turn = Twist()
    turn.linear.x, turn.angular.z = 0.1, 0.5
    cmd = rospy.Publisher("/cmd_vel", Twist, queue_size=1)
    try:
        with ros_master.launch("simulation.launch", "record:=true", f"bag:={bag}", "real_time_factor:=0"):
            wait_for(lambda: rospy.get_time() > 0.5 and _subscribed(ros_master, "/scan", "/record"), 60.0, "recording")
            start = rospy.get_time()

            def driven() -> bool:
                cmd.publish(turn)  # the simulator's watchdog stops the robot without fresh commands
                return bool(rospy.get_time() > start + 12.0)

            wait_for(driven, 120.0, "12 sim seconds of recording")
    finally:
        cmd.unregister()
    wait_for(bag.is_file, 30.0, "rosbag record to close the bag")
    assert set(bag_topics(bag)) == {"/scan", "/odom", "/tf", "/tf_static", "/ground_truth/odom", "/cmd_vel"}

    clocks: list[tuple[str, float]] = []
    corrections: set[str] = set()
    lock = threading.Lock()

    def on_clock(msg: Any) -> None:
        with lock:
            clocks.append((msg._connection_header["callerid"], msg.clock.to_sec()))

    def on_tf(msg: Any) -> None:
        with lock:
            if any(t.header.frame_id.lstrip("/") == "map" for t in msg.transforms):
                corrections.add(msg._connection_header["callerid"])

    subs = [
        rospy.Subscriber("/clock", Clock, on_clock, queue_size=1000),
        rospy.Subscriber("/tf", TFMessage, on_tf, queue_size=100),
    ]
    name = f"slam-live-{bag.stem}"
    try:
        with ros_master.launch("slam.launch", "sim:=false", "rviz:=false", name=name) as slam:
            wait_for(lambda: _subscribed(ros_master, "/scan", "/slam"), 60.0, "the SLAM node")
            with process(["rosbag", "play", "--clock", str(bag)], ros_master.env, tmp_path / "play.log") as play:
                wait_for(lambda: play.poll() is not None, 180.0, "rosbag play to finish the bag")
            assert play.returncode == 0
            assert slam.poll() is None
    finally:
        for sub in subs:
            sub.unregister()
    with lock:
        assert corrections == {"/slam"}
        publishers = {who for who, _ in clocks}
        stamps = [t for _, t in clocks]
    assert len(publishers) == 1, publishers
    assert len(stamps) > 100
    assert all(b >= a for a, b in itertools.pairwise(stamps)), "the clock went back"
    logs = [*ros_master.log_dir.glob(f"{name}-*.log"), *ros_master.log_dir.glob(f"{name}-*/*/*.log")]
    assert logs
    text = "\n".join(p.read_text(errors="replace") for p in logs)
    for jump in ("went back", "jump back in time"):
        assert jump not in text
