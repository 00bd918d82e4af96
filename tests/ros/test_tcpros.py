"""A ROS 1 subscriber without rospy (mrs_nav.bridge.tcpros, the ROS 2 bridge's way into ROS 1) against real rospy
publishers and a real roscore: each message arrives as the bytes rospy serialised, publishers that come later
and latched messages reach it, a publisher of another type is refused, ROS's tools see it, and a restarted master
is given its subscriptions again."""

from __future__ import annotations

import io
import subprocess
import threading
import xmlrpc.client
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mrs_nav.bridge.tcpros import RawSubscriberNode
from mrs_nav.ros_processes import process
from tests.rosharness import RosMaster, wait_for

pytestmark = pytest.mark.ros


class Inbox:
    """What a subscription received, and what was refused."""

    def __init__(self) -> None:
        self.messages: list[bytes] = []
        self.refused: list[str] = []
        self._lock = threading.Lock()

    def take(self, payload: bytes) -> None:
        with self._lock:
            self.messages.append(payload)

    def refuse(self, topic: str, reason: str) -> None:
        self.refused.append(f"{topic}: {reason}")


def _subscriber(master_uri: str, name: str) -> RawSubscriberNode:
    return RawSubscriberNode(master_uri, name, "127.0.0.1", "127.0.0.1", print)


def _subscribers_of(master_uri: str, topic: str) -> list[str]:
    _, _, (_, subscribed, _) = xmlrpc.client.ServerProxy(master_uri).getSystemState("/pytest")
    return next((nodes for name, nodes in subscribed if name == topic), [])


def _serialised(msg: Any) -> bytes:
    buffer = io.BytesIO()
    msg.serialize(buffer)
    return buffer.getvalue()


@pytest.fixture
def raw(ros_master: RosMaster, request: pytest.FixtureRequest) -> Iterator[RawSubscriberNode]:
    node = _subscriber(ros_master.uri, f"/tcpros_{request.node.name[:40]}")
    try:
        yield node
    finally:
        node.close()


def test_each_message_arrives_as_the_bytes_rospy_sent_to_every_callback(
    rospy_node: Any, raw: RawSubscriberNode
) -> None:
    from nav_msgs.msg import Odometry

    rospy = rospy_node
    publisher = rospy.Publisher("/tcpros_test/odom", Odometry, queue_size=10)
    first, second = Inbox(), Inbox()
    try:
        raw.subscribe("/tcpros_test/odom", "nav_msgs/Odometry", first.take, first.refuse)
        raw.subscribe("/tcpros_test/odom", "nav_msgs/Odometry", second.take, second.refuse)
        wait_for(lambda: publisher.get_num_connections() == 1, 10.0, "the raw subscriber's connection")
        sent = []
        for k in range(5):
            msg = Odometry()
            msg.header.frame_id, msg.child_frame_id = "odom", "base_footprint"
            msg.pose.pose.position.x, msg.twist.twist.angular.z = 0.5 * k, -0.25
            msg.pose.covariance = [float(i) for i in range(36)]
            publisher.publish(msg)  # rospy numbers header.seq
            sent.append(_serialised(msg))
        wait_for(lambda: len(first.messages) == 5 and len(second.messages) == 5, 10.0, "five odometry messages")
    finally:
        publisher.unregister()
    assert first.messages == sent
    assert second.messages == sent
    assert not first.refused


def test_a_publisher_that_comes_later_and_a_latched_message_reach_it(rospy_node: Any, raw: RawSubscriberNode) -> None:
    from std_msgs.msg import String

    rospy = rospy_node
    later, latched = Inbox(), Inbox()
    raw.subscribe("/tcpros_test/later", "std_msgs/String", later.take, later.refuse)
    kept = rospy.Publisher("/tcpros_test/latched", String, queue_size=1, latch=True)
    publisher = rospy.Publisher("/tcpros_test/later", String, queue_size=10)
    try:
        kept.publish(String("published before anyone subscribed"))
        raw.subscribe("/tcpros_test/latched", "std_msgs/String", latched.take, latched.refuse)
        wait_for(lambda: publisher.get_num_connections() == 1, 10.0, "the master's publisherUpdate to the subscriber")
        publisher.publish(String("after"))
        wait_for(lambda: later.messages and latched.messages, 10.0, "the later publisher's and the latched message")
    finally:
        publisher.unregister()
        kept.unregister()
    assert later.messages == [_serialised(String("after"))]
    assert latched.messages == [_serialised(String("published before anyone subscribed"))]


def test_a_message_whose_handling_fails_does_not_end_the_topic(rospy_node: Any, raw: RawSubscriberNode) -> None:
    from std_msgs.msg import String

    rospy = rospy_node
    inbox = Inbox()

    def fails_on_the_first(payload: bytes) -> None:
        inbox.take(payload)
        if len(inbox.messages) == 1:
            raise RuntimeError("a bug in the handling of one message")

    publisher = rospy.Publisher("/tcpros_test/failing", String, queue_size=10)
    try:
        raw.subscribe("/tcpros_test/failing", "std_msgs/String", fails_on_the_first, inbox.refuse)
        wait_for(lambda: publisher.get_num_connections() == 1, 10.0, "the raw subscriber's connection")
        publisher.publish(String("first"))
        publisher.publish(String("second"))
        wait_for(lambda: len(inbox.messages) == 2, 10.0, "the message after the failed one")
    finally:
        publisher.unregister()
    assert inbox.messages[1] == _serialised(String("second"))


def test_a_publisher_of_another_type_is_refused(rospy_node: Any, raw: RawSubscriberNode) -> None:
    from std_msgs.msg import String

    rospy = rospy_node
    inbox = Inbox()
    publisher = rospy.Publisher("/tcpros_test/typed", String, queue_size=10, latch=True)
    try:
        publisher.publish(String("not an Int32"))
        raw.subscribe("/tcpros_test/typed", "std_msgs/Int32", inbox.take, inbox.refuse)
        wait_for(lambda: bool(inbox.refused), 10.0, "the refusal")
        publisher.publish(String("still not"))
    finally:
        publisher.unregister()
    assert inbox.refused == ["/tcpros_test/typed: type std_msgs/String, expected std_msgs/Int32"]
    assert inbox.messages == []


def test_ros_tools_see_it_and_closing_unregisters(ros_master: RosMaster) -> None:
    node = _subscriber(ros_master.uri, "/tcpros_seen")
    try:
        node.subscribe("/tcpros_test/seen", "std_msgs/String", Inbox().take, Inbox().refuse)
        ping = subprocess.run(["rosnode", "ping", "-c", "1", "/tcpros_seen"], env=ros_master.env,
                              capture_output=True, text=True, timeout=30, check=False)  # fmt: skip
        info = subprocess.run(["rostopic", "info", "/tcpros_test/seen"], env=ros_master.env,
                              capture_output=True, text=True, timeout=30, check=False)  # fmt: skip
        assert ping.returncode == 0, ping.stdout + ping.stderr
        assert "/tcpros_seen" in info.stdout.split("Subscribers:")[1], info.stdout
    finally:
        node.close()
    assert _subscribers_of(ros_master.uri, "/tcpros_test/seen") == []


def test_a_restarted_master_is_given_the_subscriptions_again(tmp_path: Path) -> None:
    """A publisher connected before the restart goes on sending (rostopic pub never registers again, so the new
    master never lists it), and one started after it is connected through the new master."""
    from std_msgs.msg import String

    master = RosMaster(tmp_path)  # its own: restarting the session's would cut the test process's rospy off
    node = _subscriber(master.uri, "/tcpros_restart")
    inbox = Inbox()
    before, after = (_serialised(String(text)) for text in ("before the restart", "after the restart"))
    talkers = [
        ["rostopic", "pub", "-r", "20", "/chatter", "std_msgs/String", f"data: {w} the restart"]
        for w in ("before", "after")
    ]
    try:
        node.subscribe("/chatter", "std_msgs/String", inbox.take, inbox.refuse)
        node.watch_master(lambda reason: None)
        with process(talkers[0], master.env, tmp_path / "talker-before.log"):
            wait_for(lambda: before in inbox.messages, 30.0, "a message from the first publisher")
            master.restart()
            wait_for(lambda: _subscribers_of(master.uri, "/chatter") == ["/tcpros_restart"], 20.0,
                     "the subscription registered with the new master")  # fmt: skip
            count = len(inbox.messages)
            wait_for(lambda: len(inbox.messages) >= count + 10, 10.0, "the first publisher's messages going on")
            with process(talkers[1], master.env, tmp_path / "talker-after.log"):
                wait_for(lambda: after in inbox.messages, 30.0, "a message from a publisher started after the restart")
    finally:
        node.close()
        master.close()
