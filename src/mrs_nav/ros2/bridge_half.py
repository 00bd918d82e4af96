"""The ROS 2 half of ros2_bridge: ROS 1 bytes from stdin out on ROS 2 topics, allowed ROS 2 topics back on stdout.

Started by :mod:`mrs_nav.ros.ros2_bridge_node` as ``python -m mrs_nav.ros2.bridge_half CONFIG_JSON`` in the ROS 2
venv, with ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE set (:func:`mrs_nav.bridge.ros2_link.child_environment`).
Frames are :mod:`mrs_nav.bridge.ros2_link`'s; logs go to stderr (the ROS 1 node's output). It exits when stdin
ends (the ROS 1 half is gone). A message that cannot be converted is dropped and counted, never fatal.
"""

from __future__ import annotations

import signal
import sys
import threading
import time
from typing import IO, Any

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

from mrs_nav.bridge.ros1_cdr import Ros1ToCdr
from mrs_nav.bridge.ros2_action import ACTION_CHANNEL, ACTION_NAME
from mrs_nav.bridge.ros2_link import Qos, Ros2BridgeConfig, Route, encode_frame, read_frame
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
    """Per-route count of dropped messages, logged at a bounded rate."""

    def __init__(self) -> None:
        self.counts: dict[str, int] = {}
        self._logged: dict[str, float] = {}

    def drop(self, topic: str, reason: str) -> None:
        self.counts[topic] = self.counts.get(topic, 0) + 1
        now = time.monotonic()
        if now - self._logged.get(topic, -DROP_LOG_PERIOD) >= DROP_LOG_PERIOD:
            self._logged[topic] = now
            log(f"dropped a message on {topic} ({self.counts[topic]} so far): {reason}")


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
        """One frame from the ROS 1 half: decode it and publish on its ROS 2 topic (or give it to the action)."""
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


def main(argv: list[str]) -> int:
    config = Ros2BridgeConfig.from_json(argv[1])
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr  # stdout carries frames only
    # Ctrl-C at a terminal or roslaunch's SIGINT to the group reaches this process too: it ends when the ROS 1
    # half closes its stdin instead, so that the last frames are not cut off.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threads = ACTION_THREADS if config.allow_action else 1
    with spinning_node("ros2_bridge", config.namespace, threads) as node:
        half = BridgeHalf(config, node, stdout)
        log(
            f"domain {config.domain_id}, discovery {config.discovery_range}, namespace {config.namespace or '/'}, "
            f"inbound {list(config.allow_inbound) or 'none'}"
        )
        try:
            while (frame := read_frame(stdin)) is not None:
                half.forward(*frame)
        except MrsNavError as err:
            log(f"pipe from the ROS 1 half broken: {err}")
            return 1
        finally:
            half.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
