"""The ROS 2 half of ros2_bridge: ROS 1 topics out on ROS 2, allowed ROS 2 topics back to the ROS 1 half.

Started by :mod:`mrs_nav.ros.ros2_bridge_node` as ``python -m mrs_nav.ros2.bridge_half CONFIG_JSON ENDPOINT_JSON``
in the ROS 2 venv, with ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE set
(:func:`mrs_nav.bridge.ros2_link.child_environment`). It subscribes to the outbound ROS 1 topics as a ROS 1 node
of its own (:mod:`mrs_nav.bridge.tcpros`) and publishes each message's bytes rewritten as CDR; the allowed inbound
topics and the NavigateToPose action go through the ROS 1 half in :mod:`mrs_nav.bridge.ros2_link`'s frames on
stdin and stdout. Logs go to stderr (the ROS 1 node's output). It exits when stdin ends (the ROS 1 half is gone).
A message that cannot be converted is dropped and counted, never fatal.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
import xmlrpc.client
from functools import partial
from typing import IO, Any

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

from mrs_nav.bridge.ros1_cdr import Ros1ToCdr
from mrs_nav.bridge.ros2_action import ACTION_CHANNEL, ACTION_NAME
from mrs_nav.bridge.ros2_link import Qos, Ros1Endpoint, Ros2BridgeConfig, Route, encode_frame, read_frame
from mrs_nav.bridge.tcpros import RawSubscriberNode
from mrs_nav.errors import MrsNavError
from mrs_nav.ros2.conversions import CONVERSIONS
from mrs_nav.ros2.messages import codec, fields_of, message_class
from mrs_nav.ros2.navigate_to_pose import NavigateToPoseServer
from mrs_nav.ros2.runtime import spinning_node

# Dropped messages are logged at most once per this many seconds per route (with the count).
DROP_LOG_PERIOD = 5.0
# Executor threads with the NavigateToPose action: each executing goal waits in one, cancels need another.
ACTION_THREADS = 4

QOS: dict[Qos, QoSProfile] = {
    Qos.SENSOR: qos_profile_sensor_data,
    Qos.RELIABLE: QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE),
    Qos.LATCHED: QoSProfile(
        depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
    ),
    # as tf2_ros's broadcasters
    Qos.TF: QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE),
    Qos.TF_STATIC: QoSProfile(
        depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
    ),
}


def log(text: str) -> None:
    print(f"ros2_bridge (ROS 2 side): {text}", file=sys.stderr, flush=True)


class _Drops:
    """Per-route count of dropped messages, logged at a bounded rate (from any thread)."""

    def __init__(self) -> None:
        self.counts: dict[str, int] = {}
        self._logged: dict[str, float] = {}
        self._lock = threading.Lock()

    def drop(self, topic: str, reason: str) -> None:
        with self._lock:
            self.counts[topic] = self.counts.get(topic, 0) + 1
            now = time.monotonic()
            if now - self._logged.get(topic, -DROP_LOG_PERIOD) < DROP_LOG_PERIOD:
                return
            self._logged[topic] = now
            count = self.counts[topic]
        log(f"dropped a message on {topic} ({count} so far): {reason}")


class BridgeHalf:
    """Publishers for the outbound routes, subscriptions for the allowed inbound ones."""

    def __init__(self, config: Ros2BridgeConfig, node: Node, out: IO[bytes]) -> None:
        self.config = config
        self.node = node
        self.codec = codec()
        self.cdr = Ros1ToCdr(fields_of)
        self.drops = _Drops()
        self._out = out
        self._out_lock = threading.Lock()
        self.routes = config.routes
        self.publishers: dict[int, Any] = {}
        self._static: dict[str, Any] = {}  # child frame -> its latest static transform
        self._transforms_lock = threading.Lock()  # each ROS 1 publisher's messages come in a thread of their own
        for channel, route in enumerate(self.routes):
            topic = config.ros2_topic(route)
            cls = message_class(route.published_type)
            if route.inbound:
                node.create_subscription(
                    cls, topic, lambda m, c=channel, r=route: self._to_ros1(c, r, m), QOS[route.qos]
                )
            else:
                self.publishers[channel] = node.create_publisher(cls, topic, QOS[route.qos])
        self.action: NavigateToPoseServer | None = None
        if config.allow_action:
            self.action = NavigateToPoseServer(node, config.action_names[0], self.codec, self._send, log)

    def forward(self, channel: int, payload: bytes) -> None:
        """One ROS 1 message of an outbound channel (or a frame of the action's from the ROS 1 half): publish it on
        its ROS 2 topic (or give it to the action). Called from each ROS 1 connection's thread."""
        if channel == ACTION_CHANNEL and self.action is not None:
            try:
                self.action.deliver(payload)
            except MrsNavError as err:
                self.drops.drop(ACTION_NAME, str(err))
            return
        publisher = self.publishers.get(channel)
        if publisher is None:
            self.drops.drop(f"channel {channel}", "not an outbound channel")
            return
        route = self.routes[channel]
        try:
            if self._as_bytes(route):
                publisher.publish(self.cdr.transcode(route.type, payload))
                return
            msg = self.codec.decode(route.type, payload)
        except MrsNavError as err:
            self.drops.drop(route.ros2, str(err))
            return
        if route.qos in (Qos.TF, Qos.TF_STATIC):
            with self._transforms_lock:
                msg = self._transforms(route, msg)
            if msg is None:
                return
        if route.ros2_type:
            msg = CONVERSIONS[route.ros2_type](msg)
        publisher.publish(msg)

    def _as_bytes(self, route: Route) -> bool:
        """Whether ``route``'s messages go out as CDR bytes rewritten from ROS 1's (no message object: rclpy
        publishes bytes as they are): all but those converted to another type and the transforms this half sorts
        or gathers (a namespaced bridge's /tf, every /tf_static), which are few."""
        if route.ros2_type:
            return False
        return route.qos is not Qos.TF_STATIC and not (route.qos is Qos.TF and self.config.namespace)

    def _transforms(self, route: Route, msg: Any) -> Any:
        """The robot's own transforms of a TFMessage (see Ros2BridgeConfig.own_frame), None if none is left.

        /tf_static in ROS 1 has a latched publisher per node; on ROS 2 this half is one publisher whose
        transient_local history keeps one message, so each static message sent is every static transform so far.
        """
        mine = [t for t in msg.transforms if self.config.own_frame(t.child_frame_id)]
        if route.qos is Qos.TF_STATIC:
            self._static.update((t.child_frame_id, t) for t in mine)
            mine = list(self._static.values())
        if not mine:
            return None
        msg.transforms = mine
        return msg

    def _to_ros1(self, channel: int, route: Route, msg: Any) -> None:
        try:
            self._send(channel, self.codec.encode(route.type, msg))
        except MrsNavError as err:
            self.drops.drop(route.ros2, str(err))

    def _send(self, channel: int, payload: bytes) -> None:
        frame = encode_frame(channel, payload)
        with self._out_lock:
            self._out.write(frame)
            self._out.flush()

    def close(self) -> None:
        if self.action is not None:
            self.action.close()


def _subscribe(ros1: RawSubscriberNode, half: BridgeHalf, endpoint: Ros1Endpoint) -> None:
    """The outbound channels' ROS 1 topics, each message to :meth:`BridgeHalf.forward`."""
    for channel, topic in endpoint.topics.items():
        ros1.subscribe(topic, half.routes[channel].type, partial(half.forward, channel), half.drops.drop)


def _shut_down(reason: str) -> None:
    """The ROS 1 master or a user (rosnode kill) ended this node: the process ends, and the ROS 1 half with it."""
    log(f"exiting: {reason}")
    os.kill(os.getpid(), signal.SIGTERM)


def main(argv: list[str]) -> int:
    config = Ros2BridgeConfig.from_json(argv[1])
    endpoint = Ros1Endpoint.from_json(argv[2])
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr  # stdout carries frames only
    # Ctrl-C at a terminal or roslaunch's SIGINT to the group reaches this process too: it ends when the ROS 1
    # half closes its stdin instead, so that the last frames are not cut off.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threads = ACTION_THREADS if config.allow_action else 1
    with spinning_node("ros2_bridge", config.namespace, threads) as node:
        half = BridgeHalf(config, node, stdout)
        ros1 = RawSubscriberNode(endpoint.master_uri, endpoint.caller_id, endpoint.host, endpoint.bind, log)
        try:
            try:
                _subscribe(ros1, half, endpoint)
            except (OSError, xmlrpc.client.Error, MrsNavError) as err:
                log(f"cannot subscribe on ROS 1 at {endpoint.master_uri}: {err}")
                return 1
            ros1.watch_master(_shut_down)
            log(
                f"domain {config.domain_id}, discovery {config.discovery_range}, namespace {config.namespace or '/'}, "
                f"inbound {list(config.allow_inbound) or 'none'}; on ROS 1 as {endpoint.caller_id}, "
                f"{len(endpoint.topics)} topics"
            )
            while (frame := read_frame(stdin)) is not None:
                half.forward(*frame)
        except MrsNavError as err:
            log(f"pipe from the ROS 1 half broken: {err}")
            return 1
        finally:
            ros1.close()
            half.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
