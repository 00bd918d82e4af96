"""A remote monitor: a Zenoh session that discovers the bridged topics, fetches their definitions and
decodes them with rosbags, measuring per-topic rate and latency. Needs no ROS.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import zenoh
import zenoh.ext

from mrs_nav.bridge.decoder import MessageDecoder, noetic_store
from mrs_nav.bridge.keys import publish_key, robot_prefix, status_key, topic_of_key, types_key
from mrs_nav.bridge.session import open_client_session
from mrs_nav.bridge.wire import decode_attachment, decode_definition, decode_status, encoding_text, schema_of
from mrs_nav.errors import InvalidInputError, MrsNavError
from mrs_nav.geometry import quaternion_from_yaw

GOAL_TOPIC = "/move_base_simple/goal"
GOAL_TYPE = "geometry_msgs/PoseStamped"
# Arrival times kept per topic for the rate (last N samples) and latencies for the percentiles.
_WINDOW = 100


@dataclass
class TopicStats:
    """Arrivals of one topic: count, recent arrival times (s, monotonic), latencies (ms), whether a live ROS
    publisher stands behind it (the bridge's liveliness token) and when the bridge received the last message
    (ns since the epoch, from its attachment: a late joiner's cached sample keeps its true age)."""

    type: str = ""
    count: int = 0
    arrivals: deque[float] = field(default_factory=lambda: deque(maxlen=_WINDOW))
    latencies_ms: deque[float] = field(default_factory=lambda: deque(maxlen=_WINDOW))
    payload: bytes = b""
    alive: bool = False
    received_ns: int = 0

    def age_s(self, now_ns: int) -> float:
        """Seconds since the bridge received the last message (NaN when none carried a receive time)."""
        return (now_ns - self.received_ns) / 1e9 if self.received_ns else math.nan

    def stale(self, now: float, now_ns: int) -> bool:
        """No live ROS publisher any more, or silent for 3 of its own periods (a topic that has only sent one
        message, a latched map, is judged by its publisher alone)."""
        if not self.alive:
            return True
        rate = self.rate_hz(self.arrivals[-1]) if self.arrivals else 0.0
        return rate > 0 and self.age_s(now_ns) > 3.0 / rate

    def rate_hz(self, now: float) -> float:
        """Mean rate over the recent arrivals; 0 once the topic has been silent for 3 of its periods."""
        if len(self.arrivals) < 2:
            return 0.0
        span = self.arrivals[-1] - self.arrivals[0]
        rate = (len(self.arrivals) - 1) / span if span > 0 else 0.0
        return 0.0 if rate > 0 and now - self.arrivals[-1] > 3.0 / rate else rate

    def latency_ms(self, q: float) -> float:
        return float(np.percentile(np.fromiter(self.latencies_ms, float), q)) if self.latencies_ms else math.nan


class RemoteMonitor:
    """Watches the bridge whose keys start with ``prefix`` through the endpoints in ``connect``."""

    def __init__(
        self,
        connect: list[str],
        prefix: str = "mrs_nav",
        timeout: float = 2.0,
        mode: str = "peer",
        config_file: str = "",
    ) -> None:
        self.connect = connect
        self.prefix = robot_prefix(prefix)
        if not self.prefix:
            raise InvalidInputError("key prefix '': the monitor reads the mrs_nav key layout, which needs one")
        self.timeout = timeout
        self.mode = mode
        self.config_file = config_file
        self.decoder = MessageDecoder()
        self._lock = threading.Lock()
        self._stats: dict[str, TopicStats] = {}
        self._alive: set[str] = set()
        self._session: zenoh.Session | None = None
        self._owns_session = False
        self._entities: list[Any] = []

    def open(self) -> RemoteMonitor:
        """Open a session of our own on ``connect`` and watch through it."""
        self.attach(open_client_session(self.connect, self.mode, self.config_file))
        self._owns_session = True
        return self

    def attach(self, session: zenoh.Session) -> RemoteMonitor:
        """Watch through an open session (a fleet's shared one), which :meth:`close` leaves open."""
        self._session = session
        pattern = f"{self.prefix}/**"
        self._entities = [
            session.liveliness().declare_subscriber(pattern, self._on_liveliness, history=True),
            # History with late-publisher detection: the latched map's cache answers us when we join.
            zenoh.ext.declare_advanced_subscriber(
                session, pattern, self._on_sample, history=zenoh.ext.HistoryConfig(detect_late_publishers=True)
            ),
        ]
        return self

    def close(self) -> None:
        """Stop watching: undeclare the subscribers, then close the session if it is the monitor's own (on a
        shared session nothing else would stop the callbacks; zenoh-python 1.6 also left an advanced subscriber's
        callback running after its session closed, its issue 624)."""
        session, self._session = self._session, None
        entities, self._entities = self._entities, []
        for entity in entities:
            entity.undeclare()
        if session is not None and self._owns_session:
            session.close()  # type: ignore[no-untyped-call]

    def __enter__(self) -> RemoteMonitor:
        return self.open()

    def __exit__(self, *_: object) -> None:
        self.close()

    # --- callbacks (Zenoh threads): store only, decode later ----------------------------------------------
    def _on_liveliness(self, sample: zenoh.Sample) -> None:
        try:
            topic = topic_of_key(self.prefix, str(sample.key_expr))
        except MrsNavError:
            return
        with self._lock:
            if sample.kind == zenoh.SampleKind.PUT:
                self._alive.add(topic)
            else:
                self._alive.discard(topic)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        now_ns = time.time_ns()
        try:
            topic = topic_of_key(self.prefix, str(sample.key_expr))
        except MrsNavError:
            return
        received_ns = 0
        if sample.attachment is not None:
            with contextlib.suppress(MrsNavError):  # a foreign publisher's attachment: no latency, still count it
                received_ns = decode_attachment(sample.attachment.to_bytes()).receive_time_ns
        with self._lock:
            stats = self._stats.setdefault(topic, TopicStats())
            stats.type = schema_of(str(sample.encoding))
            stats.count += 1
            stats.arrivals.append(time.monotonic())
            # The first sample may be a late joiner's cached one, old by design: its age is news, not latency.
            if received_ns and stats.count > 1:
                stats.latencies_ms.append((now_ns - received_ns) / 1e6)
            stats.received_ns = received_ns
            stats.payload = sample.payload.to_bytes()

    # --- queries --------------------------------------------------------------------------------------------
    def topics(self) -> dict[str, TopicStats]:
        """Topics announced by liveliness tokens or seen in samples, with their statistics."""
        with self._lock:
            for topic in self._alive - set(self._stats):
                self._stats[topic] = TopicStats()
            for topic, stats in self._stats.items():
                stats.alive = topic in self._alive
            return dict(sorted(self._stats.items()))

    def status(self) -> dict[str, Any]:
        """The bridge's own report (:func:`mrs_nav.bridge.wire.decode_status`); InvalidInputError when no bridge
        answers within the timeout, so that a monitor pointed at the wrong place says so."""
        session = self._require_session()
        deadline = time.monotonic() + self.timeout
        # A peer learns the bridge's queryable some milliseconds after it connects, and a query nobody is known
        # to answer ends at once: ask again until the timeout.
        while True:
            remaining = deadline - time.monotonic()
            for reply in session.get(status_key(self.prefix), timeout=max(0.05, remaining)):
                if reply.ok is not None:
                    return decode_status(reply.ok.payload.to_bytes())
            if remaining <= 0:
                break
            time.sleep(0.05)
        where = ", ".join(self.connect)
        raise InvalidInputError(f"no bridge under prefix {self.prefix!r} answered on {where} within {self.timeout:g} s")

    def latest(self, topic: str) -> Any:
        """The last message of ``topic`` decoded with its fetched definition, or None if none arrived."""
        with self._lock:
            stats = self._stats.get(topic)
            type_name, payload = (stats.type, stats.payload) if stats else ("", b"")
        if not payload or not type_name:
            return None
        if not self.decoder.known(type_name):
            self.fetch_definition(type_name)
        return self.decoder.decode(type_name, payload)

    def fetch_definition(self, type_name: str) -> None:
        """Ask the bridge for the definition of ``type_name`` and register it with the decoder."""
        session = self._require_session()
        for reply in session.get(types_key(self.prefix, type_name), timeout=self.timeout):
            if reply.ok is not None:
                name, md5, definition = decode_definition(reply.ok.payload.to_bytes())
                self.decoder.register(name, definition, md5)
                return
        raise InvalidInputError(f"no bridge under {self.prefix!r} answered the definition of {type_name}")

    def send_goal(self, x: float, y: float, yaw: float, frame: str = "map") -> tuple[bool, str]:
        """Ask the bridge to publish a goal; (accepted, the bridge's answer or why nothing answered)."""
        payload = serialize_goal(x, y, yaw, frame)
        session = self._require_session()
        replies = session.get(
            publish_key(self.prefix, GOAL_TOPIC),
            payload=payload,
            encoding=zenoh.Encoding(encoding_text(GOAL_TYPE)),
            timeout=self.timeout,
        )
        for reply in replies:
            if reply.ok is not None:
                return True, reply.ok.payload.to_string()
            if reply.err is not None:
                return False, reply.err.payload.to_string()
        # The bridge's access control drops queries it would refuse anyway, so silence is the refusal.
        return False, (
            f"no bridge under {self.prefix!r} on {', '.join(self.connect)} took the goal: {GOAL_TOPIC} is not in "
            "its inbound allow-list, its access control does not let this session send it, or no bridge is there"
        )

    def _require_session(self) -> zenoh.Session:
        if self._session is None:
            raise InvalidInputError("the monitor is not connected (call open() first)")
        return self._session


def serialize_goal(x: float, y: float, yaw: float, frame: str = "map", stamp_ns: int | None = None) -> bytes:
    """ROS 1 bytes of a geometry_msgs/PoseStamped goal at (x, y) m, heading ``yaw`` rad, in ``frame``, stamped
    ``stamp_ns`` (ns since the epoch; default now: the bridge refuses goals older than a few seconds)."""
    store = noetic_store()
    types = store.types
    qx, qy, qz, qw = quaternion_from_yaw(yaw)
    sec, nanosec = divmod(time.time_ns() if stamp_ns is None else stamp_ns, 1_000_000_000)
    msg = types["geometry_msgs/msg/PoseStamped"](
        types["std_msgs/msg/Header"](0, types["builtin_interfaces/msg/Time"](sec, nanosec), frame),
        types["geometry_msgs/msg/Pose"](
            types["geometry_msgs/msg/Point"](x, y, 0.0), types["geometry_msgs/msg/Quaternion"](qx, qy, qz, qw)
        ),
    )
    return bytes(store.serialize_ros1(msg, "geometry_msgs/msg/PoseStamped"))
