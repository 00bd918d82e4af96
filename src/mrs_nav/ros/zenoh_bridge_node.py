"""ZenohBridgeNode: ROS 1 topics out to Zenoh byte for byte, allow-listed goals back in.

Outbound, every topic the master lists that passes the filter is subscribed with ``rospy.AnyMsg``, so the
serialized bytes are forwarded unchanged (no deserialisation, no re-encoding) with the type in the
Encoding schema and the md5 + receive time in the attachment (:mod:`mrs_nav.bridge.wire`). Latched topics
(the map) go through an advanced publisher whose cache answers late joiners. Inbound, only allow-listed
topics are listened to, and :class:`mrs_nav.bridge.inbound.InboundValidator` checks each message first.

The Zenoh side never holds ROS up for long: a put waits at most 50 ms for a congested link and is then
dropped, a session that cannot open is retried by the discovery loop, and Zenoh's own connection retries find
a restarted peer or router.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import rospy
import yaml
import zenoh
import zenoh.ext
from roslib.message import get_message_class

from mrs_nav.bridge.config import BridgeConfig
from mrs_nav.bridge.inbound import InboundValidator
from mrs_nav.bridge.keys import check_topic, topic_key, topic_of_publish_key, types_key
from mrs_nav.bridge.rate_limit import RateLimiter
from mrs_nav.bridge.session import open_session
from mrs_nav.bridge.wire import encode_attachment, encode_definition, encoding_text, schema_of
from mrs_nav.errors import MrsNavError

# Messages dropped by the inbound checks are logged at most once per this many seconds (with a count).
DROP_LOG_PERIOD = 5.0


def load_config() -> BridgeConfig:
    """Private parameters, overridden by the YAML file named in ``~config_file`` when given."""
    params: dict[str, Any] = dict(rospy.get_param("~", {}))
    path = str(params.pop("config_file", "") or "")
    if path:
        try:
            loaded = yaml.safe_load(Path(path).read_text(encoding="utf-8")) or {}
        except (OSError, yaml.YAMLError) as err:
            raise MrsNavError(f"~config_file {path}: {err}") from None
        if not isinstance(loaded, Mapping):
            raise MrsNavError(f"~config_file {path}: expected a mapping of parameters")
        params.update(loaded)
    if not params.get("namespace"):
        params["namespace"] = rospy.get_namespace().strip("/")  # a bridge in /robot1 keys mrs_nav/robot1/...
    return BridgeConfig.from_mapping(params)


@dataclass
class _Outbound:
    """One bridged ROS topic: its ROS subscriber, Zenoh publisher, liveliness token and limiter."""

    topic: str
    type: str
    limiter: RateLimiter
    subscriber: Any = None
    publisher: Any = None
    token: Any = None
    md5: str = ""
    forwarded: int = 0
    limited: int = 0


@dataclass
class _Inbound:
    publisher: Any
    msg_class: Any
    dropped: int = 0
    log_limiter: RateLimiter = field(default_factory=lambda: RateLimiter(1.0 / DROP_LOG_PERIOD))


class ZenohBridgeNode:
    """Bridges ROS topics to Zenoh keys (see the module docstring); call :meth:`start`, then spin."""

    def __init__(self, config: BridgeConfig) -> None:
        self.config = config
        self.prefix = config.key_prefix
        self.validator = InboundValidator(config)
        self._lock = threading.RLock()
        self._session: zenoh.Session | None = None
        self._outbound: dict[str, _Outbound] = {}
        self._definitions: dict[str, tuple[str, str]] = {}  # ROS type -> (md5, full definition)
        self._inbound: dict[str, _Inbound] = {}
        self._unbridgeable: set[str] = set()
        self._zenoh_entities: list[Any] = []
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._session_errors = RateLimiter(1.0 / DROP_LOG_PERIOD)

    # --- life cycle -------------------------------------------------------------------------------------
    def start(self) -> None:
        for rule in self.config.inbound:
            msg_class = get_message_class(rule.type)
            if msg_class is None:
                raise MrsNavError(f"inbound {rule.topic}: message type {rule.type} is not installed")
            self._inbound[rule.topic] = _Inbound(rospy.Publisher(rule.topic, msg_class, queue_size=10), msg_class)
        self._tick()
        # A wall-clock loop, not rospy.Timer: discovery and reconnection must go on when /clock is absent
        # or stopped (use_sim_time with no simulator running yet).
        self._thread = threading.Thread(target=self._loop, name="zenoh_bridge_discovery", daemon=True)
        self._thread.start()
        rospy.on_shutdown(self.close)
        rospy.loginfo(
            "zenoh bridge: prefix %s, %s on listen=%s connect=%s, inbound %s",
            self.prefix, self.config.mode, list(self.config.listen), list(self.config.connect),
            self.validator.allowed_topics() or "none",
        )  # fmt: skip

    def _loop(self) -> None:
        while not self._stop.wait(self.config.discovery_period) and not rospy.is_shutdown():
            self._tick()

    def close(self) -> None:
        self._stop.set()
        with self._lock:
            for out in self._outbound.values():
                if out.subscriber is not None:
                    out.subscriber.unregister()
            session, self._session = self._session, None
        if session is not None:
            session.close()

    def _tick(self) -> None:
        """Open the session if it is not open yet, then look for new topics."""
        if self._session is None:
            self._open()
        self.discover()

    def _open(self) -> None:
        try:
            session = open_session(self.config.zenoh_settings())
        except MrsNavError as err:
            if self._session_errors.allow(time.monotonic()):
                rospy.logerr("zenoh bridge: %s; ROS side unaffected, retrying", err)
            return
        entities = [
            session.declare_queryable(f"{self.prefix}/@types/**", self._answer_types),
            session.declare_queryable(f"{self.prefix}/@bridge/publish/**", self._answer_publish),
        ]
        for topic in self._inbound:
            key = topic_key(self.prefix, topic)
            entities.append(
                session.declare_subscriber(
                    key, lambda s, t=topic: self._on_remote_sample(t, s), allowed_origin=zenoh.Locality.REMOTE
                )
            )
        with self._lock:
            self._session = session
            self._zenoh_entities = entities

    # --- outbound ---------------------------------------------------------------------------------------
    def discover(self) -> None:
        """Subscribe to every published topic that passes the filter and is not bridged yet."""
        try:
            published = rospy.get_published_topics()
        except Exception as err:  # master unreachable for a moment: try again next tick
            rospy.logwarn_throttle(DROP_LOG_PERIOD, f"zenoh bridge: cannot list topics: {err}")
            return
        for topic, type_name in published:
            if topic in self._outbound or topic in self._unbridgeable or not self.config.topics.accepts(topic):
                continue
            try:
                check_topic(topic)
            except MrsNavError as err:  # e.g. a name with characters Zenoh keys cannot hold
                self._unbridgeable.add(topic)
                rospy.logwarn("zenoh bridge: not bridging %s: %s", topic, err)
                continue
            out = _Outbound(topic, type_name, RateLimiter(self.config.max_rate(topic)))
            msg_class = get_message_class(type_name)
            if msg_class is not None:  # serve the definition before the first message when we can
                self._definitions.setdefault(type_name, (msg_class._md5sum, msg_class._full_text))
            with self._lock:
                self._outbound[topic] = out
            # tcp_nodelay: without it Nagle's algorithm holds small messages (odometry) for milliseconds.
            out.subscriber = rospy.Subscriber(
                topic, rospy.AnyMsg, self._on_ros_message, callback_args=out, queue_size=100, tcp_nodelay=True
            )

    def _on_ros_message(self, msg: rospy.AnyMsg, out: _Outbound) -> None:
        received = time.time_ns()
        header = msg._connection_header
        if header.get("callerid") == rospy.get_name():
            return  # our own inbound publication: never echo it back out
        if not out.limiter.allow(time.monotonic()):
            out.limited += 1
            return
        session = self._session
        if session is None:
            return
        if out.publisher is None:
            try:
                self._declare_outbound(session, out, header)
            except (zenoh.ZError, MrsNavError) as err:
                rospy.logwarn_throttle(DROP_LOG_PERIOD, f"zenoh bridge: cannot bridge {out.topic}: {err}")
                return
        if not out.md5:
            return
        try:
            out.publisher.put(msg._buff, attachment=encode_attachment(out.md5, received))
            out.forwarded += 1
        except zenoh.ZError as err:
            rospy.logwarn_throttle(DROP_LOG_PERIOD, f"zenoh bridge: put on {out.topic} failed: {err}")

    def _declare_outbound(self, session: zenoh.Session, out: _Outbound, header: Mapping[str, str]) -> None:
        with self._lock:
            if out.publisher is not None:
                return
            type_name = header.get("type", out.type)
            md5 = header.get("md5sum", "")
            if header.get("message_definition"):
                self._definitions[type_name] = (md5, header["message_definition"])
            key = topic_key(self.prefix, out.topic, self.config.layout, type_name, md5)
            encoding = zenoh.Encoding(encoding_text(type_name))
            if header.get("latching") == "1":
                # Late joiners get the last sample from this cache (advanced subscribers with history).
                out.publisher = zenoh.ext.declare_advanced_publisher(
                    session,
                    key,
                    encoding=encoding,
                    express=True,
                    cache=zenoh.ext.CacheConfig(max_samples=1),
                    publisher_detection=True,
                )
            else:
                # express: sent at once rather than batched with later samples (latency over throughput).
                out.publisher = session.declare_publisher(key, encoding=encoding, express=True)
            out.token = session.liveliness().declare_token(topic_key(self.prefix, out.topic))
            out.type, out.md5 = type_name, md5

    def _answer_types(self, query: zenoh.Query) -> None:
        for type_name, (md5, definition) in list(self._definitions.items()):
            type_key = types_key(self.prefix, type_name)
            if zenoh.KeyExpr(type_key).intersects(query.key_expr):
                query.reply(
                    type_key, encode_definition(type_name, md5, definition), encoding=zenoh.Encoding.APPLICATION_JSON
                )

    # --- inbound ----------------------------------------------------------------------------------------
    def _on_remote_sample(self, topic: str, sample: zenoh.Sample) -> None:
        attachment = sample.attachment.to_bytes() if sample.attachment is not None else None
        self._accept(topic, schema_of(str(sample.encoding)), sample.payload.to_bytes(), attachment)

    def _answer_publish(self, query: zenoh.Query) -> None:
        try:
            topic = topic_of_publish_key(self.prefix, str(query.key_expr))
        except MrsNavError as err:
            query.reply_err(str(err))
            return
        payload = query.payload.to_bytes() if query.payload is not None else b""
        attachment = query.attachment.to_bytes() if query.attachment is not None else None
        schema = schema_of(str(query.encoding)) if query.encoding is not None else ""
        error = self._accept(topic, schema, payload, attachment)
        if error:
            query.reply_err(f"refused: {error}")
        else:
            query.reply(str(query.key_expr), f"published on {topic}")

    def _accept(self, topic: str, schema: str, payload: bytes, attachment: bytes | None) -> str:
        """Validate and publish into ROS; return '' on success, else the reason (also logged, rate-limited)."""
        try:
            self.validator.validate(topic, schema, payload, attachment)
            inbound = self._inbound[topic]
            msg = inbound.msg_class()
            msg.deserialize(payload)
        except Exception as err:  # anything the network sends may be broken: never let it stop the node
            reason = str(err)
            inbound_state = self._inbound.get(topic)
            if inbound_state is None:
                rospy.logwarn_throttle(DROP_LOG_PERIOD, f"zenoh bridge: dropped remote message: {reason}")
            else:
                inbound_state.dropped += 1
                if inbound_state.log_limiter.allow(time.monotonic()):
                    rospy.logwarn(
                        "zenoh bridge: dropped remote message on %s (%d dropped so far): %s",
                        topic, inbound_state.dropped, reason,
                    )  # fmt: skip
            return reason
        inbound.publisher.publish(msg)
        return ""

    def stats(self) -> dict[str, tuple[int, int]]:
        """Per bridged topic: (messages forwarded, messages held back by the rate limit)."""
        with self._lock:
            return {t: (o.forwarded, o.limited) for t, o in self._outbound.items()}
