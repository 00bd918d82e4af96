"""The shared test master: a node killed before it could unregister must not take down a later node.

The session's roscore outlives every launch. A node SIGKILLed by a test (or by roslaunch at the end of its grace
period) stays registered with its old XML-RPC port; when a node of the same name registers again, the master tells
the old port to shut down, and the process now listening there (a node of another launch) obeys. A CI run lost its
simulator this way. The harness forgets dead nodes before and after every launch."""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrs_nav.ros_processes import free_port
from tests.rosharness import RosMaster, forget_dead_nodes, wait_for

pytestmark = pytest.mark.ros

# A rospy node of the given name on the given XML-RPC port, running until it is told to shut down.
NODE = """
import sys, rospy
from std_msgs.msg import Empty
rospy.init_node(sys.argv[1], xmlrpc_port=int(sys.argv[2]), disable_signals=True)
rospy.Publisher("/" + sys.argv[1], Empty, queue_size=1)
print("up", flush=True)
rospy.spin()  # returns when the master tells the node to shut down
"""


def _node(master: RosMaster, name: str, port: int, log: Path) -> subprocess.Popen[bytes]:
    proc = subprocess.Popen(
        [sys.executable, "-c", NODE, name, str(port)], env=master.env, stdout=log.open("wb"), stderr=subprocess.STDOUT
    )
    wait_for(lambda: b"up" in log.read_bytes(), 30.0, f"node {name} on port {port}")
    return proc


@pytest.fixture
def nodes(ros_master: RosMaster, tmp_path: Path) -> Iterator[list[subprocess.Popen[bytes]]]:
    procs: list[subprocess.Popen[bytes]] = []
    yield procs
    for proc in procs:
        proc.kill()
        proc.wait(timeout=10)
    forget_dead_nodes(ros_master.uri)


def test_a_killed_nodes_name_reused_does_not_shut_down_the_new_owner_of_its_port(
    ros_master: RosMaster, nodes: list[subprocess.Popen[bytes]], tmp_path: Path
) -> None:
    port = free_port()
    stale = _node(ros_master, "harness_stale", port, tmp_path / "stale.log")
    nodes.append(stale)
    stale.send_signal(signal.SIGKILL)  # no chance to unregister
    stale.wait(timeout=10)
    assert forget_dead_nodes(ros_master.uri) == ["/harness_stale"]
    bystander = _node(ros_master, "harness_bystander", port, tmp_path / "bystander.log")  # the port, reused
    nodes.append(bystander)
    nodes.append(_node(ros_master, "harness_stale", free_port(), tmp_path / "again.log"))  # the name, reused
    with pytest.raises(subprocess.TimeoutExpired):
        bystander.wait(timeout=3.0)  # still running: the master had no stale port to send shutdown to
    assert forget_dead_nodes(ros_master.uri) == []  # live nodes are left alone
