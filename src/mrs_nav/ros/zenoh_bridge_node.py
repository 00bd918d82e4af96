"""ZenohBridgeNode: ROS 1 topics out to Zenoh byte for byte, allow-listed goals back in.

Outbound, every topic the master lists that passes the filter is subscribed with ``rospy.AnyMsg``, so the
serialized bytes are forwarded unchanged (no deserialisation, no re-encoding) with the type in the
Encoding schema and the md5 + receive time in the attachment (:mod:`mrs_nav.bridge.wire`). Latched topics
(the map) go through an advanced publisher whose cache answers late joiners. Inbound, only allow-listed
topics are listened to, and :class:`mrs_nav.bridge.inbound.InboundValidator` checks each message first.

Inbound, a payload's size is checked before it is copied out of Zenoh, then its content (with its header stamp's
age on the wall clock), then the topic's rate limit; every refusal is counted and logged at most once per
``DROP_LOG_PERIOD`` per topic. A listen endpoint a network reaches without TLS and client authentication stops
the node at start unless ``insecure`` is set, and is then warned at every start.

Liveness follows the ROS graph: a topic whose last ROS publisher is gone loses its liveliness token and its
late-joiner cache, and when the master no longer lists the bridge's subscriptions or publications (it was
restarted) the bridge registers them again, so restarted nodes are heard without restarting the bridge.

The Zenoh side never holds ROS up for long: a put waits at most 50 ms for a congested link and is then
dropped, a session that cannot open is retried by the discovery loop, and Zenoh's own connection retries find
a restarted peer or router. A configuration that cannot work (a TLS endpoint without certificates, a missing
Zenoh file) stops the node at start with one line instead.
"""

from __future__ import annotations

import functools
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import rosgraph
import rospy
import zenoh
import zenoh.ext
from roslib.message import get_message_class

from mrs_nav.bridge.config import MAX_FILE_BYTES, BridgeConfig, InboundRule
from mrs_nav.bridge.inbound import InboundValidator
from mrs_nav.bridge.keys import (
    KeyLayout,
    check_topic,
    discovery_key,
    services_pattern,
    status_key,
    topic_key,
    topic_of_publish_key,
    types_key,
)
from mrs_nav.bridge.rate_limit import RateLimiter
from mrs_nav.bridge.session import bridge_settings, open_session, refuse_lowlatency, zenoh_config
from mrs_nav.bridge.wire import (
    attachment_prefix,
    encode_definition,
    encode_status,
    encoding_text,
    schema_of,
    stamp_attachment,
)
from mrs_nav.config_files import node_defaults
from mrs_nav.errors import MrsNavError
from mrs_nav.textfiles import load_yaml, read_text

NODE = "zenoh_bridge"
# Messages dropped by the inbound checks are logged at most once per this many seconds (with a count).
DROP_LOG_PERIOD = 5.0
# Discovery ticks a bridged topic may go without our registration at the master or a connection to any of its
# publishers before the bridge acts (subscribes again, or withdraws the topic).
SUSPECT_TICKS = 3


def load_config() -> BridgeConfig:
    """Private parameters (defaults: config/zenoh_bridge.yaml), overridden by the YAML file named in
    ``~config_file`` when given."""
    params: dict[str, Any] = {**node_defaults(NODE), **rospy.get_param("~", {})}
    path = str(params.pop("config_file") or "")
    if path:
        where = f"~config_file {path}"
        loaded = load_yaml(read_text(Path(path), MAX_FILE_BYTES, "~config_file"), where) or {}
        if not isinstance(loaded, Mapping):
            raise MrsNavError(f"{where}: expected a mapping of parameters")
        params.update(loaded)
    if not params.get("namespace"):
        params["namespace"] = rospy.get_namespace().strip("/")  # a bridge in /robot1 keys mrs_nav/robot1/...
    return BridgeConfig.from_mapping(params)


@dataclass
class _Outbound:
    """One bridged ROS topic: its ROS subscriber, Zenoh publisher, liveliness token and limiter. ``topic`` is
    the name the robot knows it by (keys, status, logs), ``ros_topic`` the one on the master (namespaced)."""

    topic: str
    ros_topic: str
    type: str
    limiter: RateLimiter
    subscriber: Any = None
    publisher: Any = None
    token: Any = None
    md5: str = ""
    attachment: bytes = b""  # what every attachment of the topic starts with (wire.attachment_prefix)
    forwarded: int = 0
    limited: int = 0
    last_received: float = 0.0  # time.monotonic() of the last ROS message, 0 before the first
    suspect: int = 0  # consecutive discovery ticks without our registration or any publisher connection


@dataclass
class _Refusals:
    """Remote messages refused on one topic (or on topics outside the allow-list), and the log's pace."""

    count: int = 0
    log_limiter: RateLimiter = field(default_factory=lambda: RateLimiter(1.0 / DROP_LOG_PERIOD))


@dataclass
class _Inbound:
    rule: InboundRule
    publisher: Any
    msg_class: Any
    limiter: RateLimiter
    accepted: int = 0
    refused: _Refusals = field(default_factory=_Refusals)


class ZenohBridgeNode:
    """Bridges ROS topics to Zenoh keys (see the module docstring); call :meth:`start`, then spin."""

    def __init__(self, config: BridgeConfig) -> None:
        self.config = config
        self._name = rospy.get_name()  # constructed after init_node; asked once, not per message
        self.prefix = config.key_prefix
        self.services = services_pattern(self.prefix)
        self.validator = InboundValidator(config)
        self.settings, self._insecure = bridge_settings(
            config, {t: self.validator.md5(t) for t in self.validator.allowed_topics()}
        )
        self._lock = threading.RLock()
        self._session: zenoh.Session | None = None
        self._outbound: dict[str, _Outbound] = {}
        self._definitions: dict[str, tuple[str, str]] = {}  # ROS type -> (md5, full definition)
        self._inbound: dict[str, _Inbound] = {}
        self._unbridgeable: set[str] = set()
        self._refused_elsewhere = _Refusals()  # queries and puts on topics outside the allow-list
        self._zenoh_entities: list[Any] = []
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._session_errors = RateLimiter(1.0 / DROP_LOG_PERIOD)

    # --- life cycle -------------------------------------------------------------------------------------
    def start(self) -> None:
        # Raise now if the configuration cannot work.
        refuse_lowlatency(zenoh_config(self.settings, self.config.zenoh_config), self.config.zenoh_config)
        for warning in self._insecure:  # every start: an open robot must not be forgotten
            rospy.logwarn("zenoh bridge: %s", warning)
        for rule in self.config.inbound:
            msg_class = get_message_class(rule.type)
            if msg_class is None:
                raise MrsNavError(f"inbound {rule.topic}: message type {rule.type} is not installed")
            publisher = rospy.Publisher(self.config.ros_topic(rule.topic), msg_class, queue_size=10)
            self._inbound[rule.topic] = _Inbound(rule, publisher, msg_class, RateLimiter(rule.max_rate))
        self._tick()
        # A wall-clock loop, not rospy.Timer: discovery and reconnection must go on when /clock is absent
        # or stopped (use_sim_time with no simulator running yet).
        self._thread = threading.Thread(target=self._loop, name="zenoh_bridge_discovery", daemon=True)
        self._thread.start()
        rospy.on_shutdown(self.close)
        rospy.loginfo(
            "zenoh bridge: prefix %r, %s on listen=%s connect=%s, zenoh_config %s, access control %s, inbound %s",
            self.prefix, self.config.mode, list(self.config.listen), list(self.config.connect),
            self.config.zenoh_config or "none", "on" if self.config.acl else "off",
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
        """Open the session if it is not open yet, follow the ROS graph, announce for zenoh-bridge-ros1."""
        if self._session is None:
            self._open()
        self.discover()
        if self.config.layout is KeyLayout.ZENOH_BRIDGE_ROS1:
            self._announce()

    def _open(self) -> None:
        try:
            session = open_session(self.settings, self.config.zenoh_config)
        except MrsNavError as err:
            if self._session_errors.allow(time.monotonic()):
                rospy.logerr("zenoh bridge: %s; ROS side unaffected, retrying", err)
            return
        entities: list[Any] = [  # queryables and subscribers: each is undeclared on close
            session.declare_queryable(f"{self.services}/@types/**", self._answer_types),
            session.declare_queryable(f"{self.services}/@bridge/publish/**", self._answer_publish),
            session.declare_queryable(status_key(self.prefix), self._answer_status),
        ]
        for topic, inbound in self._inbound.items():
            key = topic_key(self.prefix, topic, self.config.layout, inbound.rule.type, self.validator.md5(topic))
            entities.append(
                session.declare_subscriber(
                    key, functools.partial(self._on_remote_sample, topic), allowed_origin=zenoh.Locality.REMOTE
                )
            )
        with self._lock:
            self._session = session
            self._zenoh_entities = entities

    # --- outbound ---------------------------------------------------------------------------------------
    def discover(self) -> None:
        """Follow the ROS graph: bridge new topics that pass the filter, retire topics whose last ROS publisher
        is gone, and register again what a restarted master no longer lists."""
        me = rospy.get_name()
        try:
            master = rosgraph.Master(me)
            publishers, subscribers, _ = master.getSystemState()
            types = dict(master.getTopicTypes())
        except Exception as err:  # master unreachable for a moment: try again next tick
            rospy.logwarn_throttle(DROP_LOG_PERIOD, f"zenoh bridge: cannot ask the master: {err}")
            return
        publishing = {topic: set(nodes) for topic, nodes in publishers}
        subscribing = {topic: set(nodes) for topic, nodes in subscribers}
        for topic, nodes in publishing.items():
            if nodes - {me} and topic not in self._outbound:
                self._bridge(topic, types.get(topic, ""))
        for topic, out in list(self._outbound.items()):
            others = publishing.get(topic, set()) - {me}
            listed = me in subscribing.get(topic, set())
            if not others:
                self._retire(out)  # the last publisher unregistered
                continue
            if listed and out.subscriber.get_num_connections() > 0:
                out.suspect = 0
                continue
            out.suspect += 1
            if out.suspect < SUSPECT_TICKS:  # a registration or connection may still be under way
                continue
            if listed:  # the master lists publishers, none of which we reach: killed without unregistering
                self._retire(out)
            else:  # the master forgot us (it was restarted): register again
                rospy.logwarn("zenoh bridge: the master does not list our subscription to %s; subscribing again", topic)
                out.subscriber.unregister()
                out.subscriber = self._subscribe(out)
                out.suspect = 0
        for inbound in self._inbound.values():
            ros_topic = self.config.ros_topic(inbound.rule.topic)
            if me not in publishing.get(ros_topic, set()):
                rospy.logwarn(
                    "zenoh bridge: the master does not list our publisher of %s; registering again", ros_topic
                )
                inbound.publisher.unregister()
                inbound.publisher = rospy.Publisher(ros_topic, inbound.msg_class, queue_size=10)

    def _bridge(self, ros_topic: str, type_name: str) -> None:
        topic = self.config.robot_topic(ros_topic)
        if topic is None or ros_topic in self._unbridgeable or not self.config.topics.accepts(topic) or not type_name:
            return
        try:
            check_topic(topic)
        except MrsNavError as err:  # e.g. a name with characters Zenoh keys cannot hold
            self._unbridgeable.add(ros_topic)
            rospy.logwarn("zenoh bridge: not bridging %s: %s", ros_topic, err)
            return
        out = _Outbound(topic, ros_topic, type_name, RateLimiter(self.config.max_rate(topic)))
        msg_class = get_message_class(type_name)
        if msg_class is not None:  # serve the definition before the first message when we can
            self._definitions.setdefault(type_name, (msg_class._md5sum, msg_class._full_text))
        with self._lock:
            self._outbound[ros_topic] = out
        out.subscriber = self._subscribe(out)

    def _subscribe(self, out: _Outbound) -> Any:
        # tcp_nodelay: without it Nagle's algorithm holds small messages (odometry) for milliseconds.
        return rospy.Subscriber(
            out.ros_topic, rospy.AnyMsg, self._on_ros_message, callback_args=out, queue_size=100, tcp_nodelay=True
        )

    def _retire(self, out: _Outbound) -> None:
        """The topic has no live ROS publisher: withdraw its token and cache (it is rediscovered if one comes)."""
        with self._lock:
            self._outbound.pop(out.ros_topic, None)
            publisher, token, out.publisher, out.token = out.publisher, out.token, None, None
        out.subscriber.unregister()
        if token is None:
            return  # nothing was announced (no message ever came): nothing to withdraw or to log
        for entity in (token, publisher):
            try:
                entity.undeclare()
            except zenoh.ZError as err:
                rospy.logwarn("zenoh bridge: withdrawing %s: %s", out.topic, err)
        rospy.loginfo("zenoh bridge: %s has no live ROS publisher any more; token and cache withdrawn", out.topic)

    def _announce(self) -> None:
        """zenoh-bridge-ros1's discovery beacon (an empty best-effort put per bridged publisher and period; its
        bridges forget a topic after 3 silent periods)."""
        session = self._session
        if session is None:
            return
        with self._lock:
            keys = [discovery_key(o.topic, o.type, o.md5) for o in self._outbound.values() if o.md5]
        for key in keys:
            try:
                session.put(
                    key, b"", congestion_control=zenoh.CongestionControl.DROP, priority=zenoh.Priority.BACKGROUND
                )
            except zenoh.ZError as err:
                rospy.logwarn_throttle(DROP_LOG_PERIOD, f"zenoh bridge: announcing {key}: {err}")

    def _on_ros_message(self, msg: rospy.AnyMsg, out: _Outbound) -> None:
        # Every message reaches this code cold (10 ms apart, after other processes ran): each operation costs
        # ~20x its warm time here, so the hot path does only what it must (the attachment's fixed part is made
        # once per topic).
        received = time.time_ns()
        header = msg._connection_header
        if header.get("callerid") == self._name:
            return  # our own inbound publication: never echo it back out
        out.last_received = time.monotonic()
        if not out.limiter.allow(out.last_received):
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
        publisher = out.publisher
        if publisher is None or not out.md5:  # retired meanwhile, or no md5 to announce
            return
        try:
            publisher.put(msg._buff, attachment=stamp_attachment(out.attachment, received))
            out.forwarded += 1
        except zenoh.ZError as err:
            rospy.logwarn_throttle(DROP_LOG_PERIOD, f"zenoh bridge: put on {out.topic} failed: {err}")

    def _declare_outbound(self, session: zenoh.Session, out: _Outbound, header: Mapping[str, str]) -> None:
        with self._lock:
            if out.publisher is not None or self._outbound.get(out.ros_topic) is not out:
                return  # declared already, or retired while this message was on its way: announce nothing
            type_name = header.get("type", out.type)
            md5 = header.get("md5sum", "")
            attachment = attachment_prefix(md5) if md5 else b""  # raises on a malformed md5: nothing declared
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
            out.token = session.liveliness().declare_token(key)
            out.type, out.md5, out.attachment = type_name, md5, attachment

    def _answer_types(self, query: zenoh.Query) -> None:
        for type_name, (md5, definition) in list(self._definitions.items()):
            type_key = types_key(self.services, type_name)
            if zenoh.KeyExpr(type_key).intersects(query.key_expr):
                query.reply(
                    type_key, encode_definition(type_name, md5, definition), encoding=zenoh.Encoding.APPLICATION_JSON
                )

    def _answer_status(self, query: zenoh.Query) -> None:
        now = time.monotonic()
        with self._lock:
            topics = {
                o.topic: {
                    "type": o.type,
                    "forwarded": o.forwarded,
                    "limited": o.limited,
                    "age_s": round(now - o.last_received, 3) if o.last_received else None,
                }
                for o in self._outbound.values()
            }
        inbound = {t: {"accepted": i.accepted, "dropped": i.refused.count} for t, i in self._inbound.items()}
        status = {"topics": topics, "inbound": inbound, "refused": self._refused_elsewhere.count}
        query.reply(status_key(self.prefix), encode_status(status), encoding=zenoh.Encoding.APPLICATION_JSON)

    # --- inbound ----------------------------------------------------------------------------------------
    def _on_remote_sample(self, topic: str, sample: zenoh.Sample) -> None:
        self._accept(topic, schema_of(str(sample.encoding)), sample.payload, sample.attachment)

    def _answer_publish(self, query: zenoh.Query) -> None:
        try:
            topic = topic_of_publish_key(self.services, str(query.key_expr))
        except MrsNavError as err:
            query.reply_err(self._refuse(None, str(err)))
            return
        schema = schema_of(str(query.encoding)) if query.encoding is not None else ""
        error = self._accept(topic, schema, query.payload, query.attachment)
        if error:
            query.reply_err(f"refused: {error}")
        else:
            query.reply(str(query.key_expr), f"published on {topic}")

    def _accept(self, topic: str, schema: str, payload: zenoh.ZBytes | None, attachment: zenoh.ZBytes | None) -> str:
        """Check and publish into ROS; return '' on success, else the reason (counted, logged at a bounded rate).

        The cheap checks come first and copy nothing out of Zenoh's buffer: the allow-list, then the payload's
        size; then the content, then the topic's rate.
        """
        inbound = self._inbound.get(topic)
        if inbound is None:
            allowed = ", ".join(self._inbound) or "nothing"
            return self._refuse(None, f"{topic} is not in the bridge's inbound allow-list (allowed: {allowed})")
        size = len(payload) if payload is not None else 0
        if size > inbound.rule.max_bytes:
            return self._refuse(inbound, f"{size} bytes exceed the {inbound.rule.max_bytes}-byte limit of {topic}")
        data = payload.to_bytes() if payload is not None else b""
        try:
            self.validator.validate(
                topic, schema, data, attachment.to_bytes() if attachment is not None else None, now=time.time()
            )
            msg = inbound.msg_class()
            msg.deserialize(data)
            if hasattr(msg, "header"):
                # The stamp was the sender's wall clock, checked for age above; in ROS it is ROS time (sim time
                # in a simulation), as rviz stamps its goals, so that a recording places the goal where it came.
                msg.header.stamp = rospy.Time.now()
        except Exception as err:  # anything the network sends may be broken: never let it stop the node
            return self._refuse(inbound, str(err))
        # The rate counts valid messages only, so that a stream of junk cannot crowd out a real goal.
        if not inbound.limiter.allow(time.monotonic()):
            return self._refuse(inbound, f"more than {inbound.rule.max_rate:g} messages/s on {topic}")
        inbound.publisher.publish(msg)
        inbound.accepted += 1
        return ""

    def _refuse(self, inbound: _Inbound | None, reason: str) -> str:
        refusals = inbound.refused if inbound is not None else self._refused_elsewhere
        with self._lock:
            refusals.count += 1
            log = refusals.log_limiter.allow(time.monotonic())
        if log:
            where = f"on {inbound.rule.topic}" if inbound is not None else "outside the allow-list"
            rospy.logwarn(
                "zenoh bridge: dropped remote message %s (%d dropped so far): %s", where, refusals.count, reason
            )
        return reason
