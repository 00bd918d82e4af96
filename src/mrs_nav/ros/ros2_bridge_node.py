"""Ros2BridgeNode: the ROS 1 half of ros2_bridge; it starts the ROS 2 half and publishes what comes back.

The ROS 2 half subscribes to the outbound routes' ROS 1 topics itself, as the ROS 1 node ``<this node>_ros2_side``
(:mod:`mrs_nav.bridge.ros2_link` says why); this half tells it the master, the host and each topic's name with
this node's remappings applied (:class:`~mrs_nav.bridge.ros2_link.Ros1Endpoint`). Inbound frames (only the
allow-listed ROS 2 topics) come back on the child's stdout, are checked (exactly one message of the route's type,
every number finite) and published on the ROS 1 topic; the NavigateToPose action goes on to move_base here too.
When the ROS 2 half exits, the node ends with an error: roslaunch then reports it (``required`` in the launch
file).
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import threading
from typing import IO, Any

import rosgraph
import rosgraph.network
import rospy
from roslib.message import get_message_class

from mrs_nav.bridge.decoder import deserialize_exactly, first_non_finite, noetic_store
from mrs_nav.bridge.ros2_action import ACTION_CHANNEL
from mrs_nav.bridge.ros2_link import (
    Ros1Endpoint,
    Ros2BridgeConfig,
    Route,
    child_command,
    child_environment,
    encode_frame,
    package_root,
    read_frame,
    ros2_python,
)
from mrs_nav.errors import MrsNavError
from mrs_nav.ros.params import private_params
from mrs_nav.ros.ros2_bridge_action import MoveBaseForwarder

NODE = "ros2_bridge"
#: The ROS 2 half's name on ROS 1 is this node's with this suffix.
ROS2_SIDE_SUFFIX = "_ros2_side"
# Refusals and drops are logged at most once per this many seconds per topic (with the count).
DROP_LOG_PERIOD = 5.0


def ros1_endpoint(config: Ros2BridgeConfig) -> Ros1Endpoint:
    """Where and as whom the ROS 2 half subscribes to the outbound topics (as rospy would for this node)."""
    topics = {
        channel: rospy.resolve_name(config.ros1_topic(route))
        for channel, route in enumerate(config.routes)
        if not route.inbound
    }
    return Ros1Endpoint(
        rosgraph.get_master_uri(),
        rospy.get_name() + ROS2_SIDE_SUFFIX,
        rosgraph.network.get_host_name(),
        rosgraph.network.get_bind_address(),
        topics,
    )


def load_config() -> Ros2BridgeConfig:
    params = private_params(NODE)
    if not params["namespace"]:
        params["namespace"] = rospy.get_namespace().strip("/")
    return Ros2BridgeConfig.from_mapping(params)


class Ros2BridgeNode:
    """Starts the ROS 2 half and wires the routes to it; :meth:`wait` blocks until either half ends."""

    def __init__(self, config: Ros2BridgeConfig) -> None:
        self.config = config
        self.refused: dict[str, int] = {}
        python = ros2_python(config.python, os.environ, sys.prefix)
        if not python.exists():
            raise MrsNavError(f"no ROS 2 venv at {python.parent.parent}: make it with `MRS_NAV_ROS2=1 make install`")
        self.child = subprocess.Popen(
            child_command(python, config, ros1_endpoint(config)),
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            env=child_environment(config, os.environ, package_root()),
        )
        assert self.child.stdin is not None
        assert self.child.stdout is not None
        self._to_child: IO[bytes] = self.child.stdin
        self._lock = threading.Lock()
        self._closing = False
        self._publishers: dict[int, tuple[Route, Any, Any]] = {}
        for channel, route in enumerate(config.routes):
            if route.inbound:
                msg_class = get_message_class(route.type)
                publisher = rospy.Publisher(config.ros1_topic(route), msg_class, queue_size=10)
                self._publishers[channel] = (route, msg_class, publisher)
        self._action = MoveBaseForwarder(config.action_names[1], self._send) if config.allow_action else None
        self._reader = threading.Thread(target=self._read_child, args=(self.child.stdout,), daemon=True)
        self._reader.start()
        rospy.on_shutdown(self.close)
        rospy.loginfo(
            "ros2 bridge: ROS 2 half pid %d (%s), domain %d, discovery %s, inbound %s",
            self.child.pid, python, config.domain_id, config.discovery_range, list(config.allow_inbound) or "none",
        )  # fmt: skip

    def _send(self, channel: int, payload: bytes) -> None:
        frame = encode_frame(channel, payload)
        with self._lock:
            self._to_child.write(frame)
            self._to_child.flush()

    def _read_child(self, stream: IO[bytes]) -> None:
        try:
            while (frame := read_frame(stream)) is not None:
                self._publish_inbound(*frame)
        except MrsNavError as err:
            rospy.logerr("ros2 bridge: pipe from the ROS 2 half broken: %s", err)
        code = self.child.wait()
        if not self._closing:
            rospy.logfatal("ros2 bridge: the ROS 2 half exited (code %s)", code)
            rospy.signal_shutdown("ROS 2 half exited")

    def _publish_inbound(self, channel: int, payload: bytes) -> None:
        if channel == ACTION_CHANNEL and self._action is not None:
            try:
                self._action.deliver(payload)
            except MrsNavError as err:
                self._refuse("NavigateToPose", str(err))
            return
        entry = self._publishers.get(channel)
        if entry is None:
            self._refuse(f"channel {channel}", "not an allowed inbound channel")
            return
        route, msg_class, publisher = entry
        try:
            bad = first_non_finite(deserialize_exactly(noetic_store(), route.type, payload))
            if bad:
                raise MrsNavError(f"field {bad} is not a finite number")
            msg = msg_class()
            msg.deserialize(payload)
        except Exception as err:  # anything from the other side may be broken: never let it stop the node
            self._refuse(route.ros2, str(err))
            return
        publisher.publish(msg)

    def _refuse(self, topic: str, reason: str) -> None:
        self.refused[topic] = self.refused.get(topic, 0) + 1
        rospy.logwarn_throttle(
            DROP_LOG_PERIOD, f"ros2 bridge: dropped on {topic} ({self.refused[topic]} so far): {reason}"
        )

    def close(self) -> None:
        self._closing = True
        if self._action is not None:
            self._action.close()
        with self._lock, contextlib.suppress(OSError):  # a broken pipe: the ROS 2 half has gone already
            self._to_child.close()  # the ROS 2 half ends at the end of its input
        try:
            self.child.wait(timeout=5.0)
        except subprocess.TimeoutExpired:
            self.child.kill()
