"""Recording with Debian's ``rosbag record`` (launch/record.launch) beside the simulator, and replaying the bags
offline: a recording closed normally (bz2) and one killed with SIGKILL (lz4, left as ``.bag.active``)."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path
from typing import Any

import pytest

from mrs_nav.bag.io import bag_topics, read_messages
from mrs_nav.bag.salvage import readable_bag, salvage_bag
from mrs_nav.cli.main import main
from mrs_nav.errors import BagError
from tests.rosharness import RosMaster, node_pid, wait_for

pytestmark = pytest.mark.ros

# Topics the simulator alone publishes (no SLAM, no navigation in this test).
MIN_SCANS = 10  # on disk before the recording is stopped
SIM_TOPICS = {"/scan", "/odom", "/tf", "/tf_static", "/clock", "/ground_truth/odom"}


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
