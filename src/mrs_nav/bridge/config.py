"""The bridge's configuration: Zenoh endpoints, key prefix, topic filters, rate limits and the inbound
allow-list, validated once into frozen dataclasses.

The same mapping comes from ROS private parameters or from a YAML file. ``config/zenoh_bridge.yaml`` holds
every key with its default, which :class:`BridgeConfig` reads: peer mode listening on ``tcp/127.0.0.1:7447``,
prefix ``mrs_nav``, every topic out except ``/rosout*`` and ``/clock``, no rate limit, nothing inbound, and the
bridge's access control on (remote sessions may only put on allow-listed inbound keys). Multicast scouting is
always off: the bridge only talks to endpoints it is given.
TLS, authentication and the rest of Zenoh's transport settings come from a Zenoh JSON5 file
(``zenoh_config``), passed through.
"""

from __future__ import annotations

import functools
import ipaddress
import math
import re
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from mrs_nav.bridge.acl import access_control
from mrs_nav.bridge.exposure import Credential
from mrs_nav.bridge.keys import KeyLayout, check_topic, check_type, robot_prefix
from mrs_nav.config_files import node_default
from mrs_nav.errors import InvalidInputError
from mrs_nav.textfiles import yaml12_number

MODES = ("peer", "client", "router")
_default = functools.partial(node_default, "zenoh_bridge")  # every default: config/zenoh_bridge.yaml
DEFAULT_LISTEN: tuple[str, ...] = tuple(_default("listen"))
DEFAULT_ALLOW: tuple[str, ...] = tuple(_default("allow"))
DEFAULT_DENY: tuple[str, ...] = tuple(_default("deny"))
DEFAULT_LAYOUT = KeyLayout(_default("layout"))
# An inbound message may be this big (a PoseStamped with a 256-character frame is 332 bytes) and arrive this
# often per topic (a person clicking goals) unless its rule says otherwise.
DEFAULT_INBOUND_BYTES = 1024
DEFAULT_INBOUND_RATE = 2.0
# An inbound message's header stamp (the sender's clock, seconds since the epoch) may be this old on the bridge's
# clock: a goal crosses a network in milliseconds and a congested or briefly lost link (Zenoh reconnects within
# retry_period, 1 s) delays it by a second or two, while a goal recorded and replayed later, or one that waited
# in a queue while the robot moved on, is refused. Machines that command a robot keep their clocks in step
# (NTP agrees to milliseconds), so a stamp may lead the bridge's clock by CLOCK_TOLERANCE_S at most.
DEFAULT_INBOUND_AGE = 5.0
CLOCK_TOLERANCE_S = 0.5
# The files the bridge, router and monitor read (bridge YAML, Zenoh JSON5, PEM certificates, keys and CA bundles,
# password dictionaries): a few KB each, and a whole public CA bundle is about 200 KB.
MAX_FILE_BYTES = 1 << 20
# discovery_period asks the master for the whole graph each time: more often than 10 times a second loads it for
# nothing; a dead topic is withdrawn after 3 periods, so past a minute remote users see a vanished map for minutes.
DISCOVERY_PERIOD_S = (0.1, 60.0)
# zenoh-bridge-ros1 forgets a topic after 3 of its 1 s discovery periods without a beacon, and ours go out once
# per discovery_period.
PLUGIN_FORGETS_S = 3.0
# retry_period is the longest wait between reconnections; Zenoh's first retry comes after 100 ms anyway.
RETRY_PERIOD_S = (0.1, 3600.0)
_ENDPOINT = re.compile(r"^(tcp|udp|tls|quic|ws|unixsock-stream)/([^?#\s]+)([?#]\S*)?$")
_HOST_PORT = re.compile(r"^(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9]([A-Za-z0-9.-]*[A-Za-z0-9])?):([0-9]{1,5})$")


def check_endpoint(endpoint: str) -> str:
    """Return ``endpoint`` if it reads as a Zenoh locator, PROTO/HOST:PORT (or unixsock-stream/PATH), optionally
    followed by Zenoh's ``?metadata`` or ``#config``; else raise InvalidInputError naming what is wrong.

    Zenoh itself only finds a bad address when the session opens, and for a connect endpoint not even then: it
    retries it quietly, and a monitor would report that no bridge answered."""
    found = _ENDPOINT.match(endpoint)
    if not found:
        raise InvalidInputError(f"endpoint {endpoint!r}: expected PROTO/ADDRESS, e.g. tcp/127.0.0.1:7447")
    if found[1] == "unixsock-stream":
        return endpoint
    address = _HOST_PORT.match(found[2])
    if not address:
        raise InvalidInputError(
            f"endpoint {endpoint!r}: expected {found[1]}/HOST:PORT, HOST a name, an IPv4 address or an [IPv6] one"
        )
    if address[1].startswith("["):
        try:
            ipaddress.IPv6Address(address[1][1:-1])
        except ValueError:
            raise InvalidInputError(f"endpoint {endpoint!r}: {address[1]} is not an IPv6 address") from None
    if int(address[3]) > 65535:
        raise InvalidInputError(f"endpoint {endpoint!r}: port {address[3]} is not in 0..65535")
    return endpoint


def _compile(patterns: Iterable[str], what: str) -> tuple[re.Pattern[str], ...]:
    out = []
    for pattern in patterns:
        try:
            out.append(re.compile(pattern))
        except re.error as err:
            raise InvalidInputError(f"{what}: bad regular expression {pattern!r}: {err}") from None
    return tuple(out)


@dataclass(frozen=True)
class TopicFilter:
    """Which ROS topics go out: a topic passes if it fully matches an ``allow`` regex and no ``deny`` one."""

    allow: tuple[str, ...] = DEFAULT_ALLOW
    deny: tuple[str, ...] = DEFAULT_DENY
    _allow: tuple[re.Pattern[str], ...] = field(init=False, repr=False, compare=False)
    _deny: tuple[re.Pattern[str], ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_allow", _compile(self.allow, "allow"))
        object.__setattr__(self, "_deny", _compile(self.deny, "deny"))

    def accepts(self, topic: str) -> bool:
        return any(p.fullmatch(topic) for p in self._allow) and not any(p.fullmatch(topic) for p in self._deny)


@dataclass(frozen=True)
class InboundRule:
    """A topic remote peers may publish into ROS, its only accepted type, the frame its header must name (empty:
    not checked), and the largest age in s of its header stamp on the bridge's clock (messages without a header
    are not aged)."""

    topic: str
    type: str
    frame: str = ""
    max_bytes: int = DEFAULT_INBOUND_BYTES
    max_rate: float = DEFAULT_INBOUND_RATE
    max_age: float = DEFAULT_INBOUND_AGE

    def __post_init__(self) -> None:
        check_topic(self.topic)
        check_type(self.type)
        if self.max_bytes <= 0:
            raise InvalidInputError(f"inbound {self.topic} max_bytes {self.max_bytes!r}: expected bytes > 0")
        if not math.isfinite(self.max_rate) or self.max_rate <= 0:
            raise InvalidInputError(f"inbound {self.topic} max_rate {self.max_rate!r}: expected a rate > 0 Hz")
        if not math.isfinite(self.max_age) or self.max_age <= 0:
            raise InvalidInputError(f"inbound {self.topic} max_age {self.max_age!r}: expected an age > 0 s")


@dataclass(frozen=True)
class BridgeConfig:
    """Everything the bridge node reads from its parameters; see the module docstring for defaults.

    ``max_rates`` maps a topic regex to its maximum outbound rate in Hz (first full match wins; unmatched
    topics get ``default_max_rate``; 0 = unlimited). ``discovery_period`` (s) is how often the master is
    asked for new topics. ``retry_period`` (s) bounds how long a lost Zenoh connection waits before the
    next reconnection attempt. ``zenoh_config`` names a Zenoh JSON5 file (TLS, authentication, ...) whose
    settings the bridge's own (mode, endpoints, scouting) are laid over; ``acl`` adds the bridge's access
    control (:mod:`mrs_nav.bridge.acl`), ``operators`` naming who may send inbound messages (Zenoh usernames
    or certificate common names, each checked as every credential the Zenoh configuration checks; empty: anyone
    who can connect). ``insecure`` lets the bridge listen where a network reaches it without TLS and client
    authentication (:mod:`mrs_nav.bridge.exposure`), warned at every start.
    """

    mode: str = _default("mode")
    listen: tuple[str, ...] = DEFAULT_LISTEN
    connect: tuple[str, ...] = tuple(_default("connect"))
    prefix: str = _default("prefix")
    namespace: str = _default("namespace")
    layout: KeyLayout = DEFAULT_LAYOUT
    topics: TopicFilter = TopicFilter()
    max_rates: tuple[tuple[str, float], ...] = tuple(_default("max_rates").items())
    default_max_rate: float = _default("default_max_rate")
    inbound: tuple[InboundRule, ...] = ()  # the file's inbound: [] (rules are built by from_mapping)
    discovery_period: float = _default("discovery_period")
    retry_period: float = _default("retry_period")
    zenoh_config: str = _default("zenoh_config")
    acl: bool = _default("acl")
    operators: tuple[str, ...] = tuple(_default("operators"))
    insecure: bool = _default("insecure")
    _rates: tuple[tuple[re.Pattern[str], float], ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise InvalidInputError(f"mode {self.mode!r}: expected one of {', '.join(MODES)}")
        for endpoint in (*self.listen, *self.connect):
            check_endpoint(endpoint)
        if not self.listen and not self.connect:
            raise InvalidInputError("listen and connect are both empty: the bridge would reach nobody")
        if not robot_prefix(self.prefix, self.namespace) and self.layout is KeyLayout.MRS_NAV:
            raise InvalidInputError("prefix is empty: only the zenoh-bridge-ros1 layout works without one")
        for name, value, (low, high) in (
            ("discovery_period", self.discovery_period, DISCOVERY_PERIOD_S),
            ("retry_period", self.retry_period, RETRY_PERIOD_S),
        ):
            if not low <= value <= high:  # NaN fails too
                raise InvalidInputError(f"{name} {value!r}: expected {low:g} .. {high:g} s")
        if self.layout is KeyLayout.ZENOH_BRIDGE_ROS1 and self.discovery_period >= PLUGIN_FORGETS_S:
            raise InvalidInputError(
                f"discovery_period {self.discovery_period!r}: with the zenoh-bridge-ros1 layout it must be below "
                f"{PLUGIN_FORGETS_S:g} s, or remote zenoh-bridge-ros1 instances forget our topics between beacons"
            )
        for pattern, rate in (*self.max_rates, ("default_max_rate", self.default_max_rate)):
            if not math.isfinite(rate) or rate < 0:
                raise InvalidInputError(f"max rate of {pattern!r}: {rate!r} is not a finite rate >= 0 Hz")
        topics = [rule.topic for rule in self.inbound]
        if len(set(topics)) != len(topics):
            raise InvalidInputError(f"inbound: a topic is listed twice in {topics}")
        patterns = _compile((p for p, _ in self.max_rates), "max_rates")
        object.__setattr__(self, "_rates", tuple(zip(patterns, (r for _, r in self.max_rates), strict=True)))

    @property
    def key_prefix(self) -> str:
        """``prefix`` joined with the robot namespace, e.g. ``mrs_nav/robot1``."""
        return robot_prefix(self.prefix, self.namespace)

    def ros_topic(self, topic: str) -> str:
        """The ROS name of the robot's ``topic``: ``/odom`` of the robot in namespace ``tb3_0`` is ``/tb3_0/odom``.

        Keys, filters, rate limits and inbound rules name topics as the robot sees them, so that every robot of a
        fleet is watched and commanded with the same names under its own key prefix."""
        namespace = self.namespace.strip("/")
        return f"/{namespace}{topic}" if namespace else topic

    def robot_topic(self, ros_topic: str) -> str | None:
        """Inverse of :meth:`ros_topic`; None for a topic outside the robot's namespace (another robot's)."""
        namespace = self.namespace.strip("/")
        if not namespace:
            return ros_topic
        head = f"/{namespace}/"
        return ros_topic[len(head) - 1 :] if ros_topic.startswith(head) else None

    def max_rate(self, topic: str) -> float:
        """Maximum outbound rate of ``topic`` in Hz (0 = unlimited)."""
        for pattern, rate in self._rates:
            if pattern.fullmatch(topic):
                return rate
        return self.default_max_rate

    def inbound_rule(self, topic: str) -> InboundRule | None:
        """The rule allowing ``topic`` in, or None when remote peers may not publish it."""
        return next((rule for rule in self.inbound if rule.topic == topic), None)

    def zenoh_settings(
        self, inbound_md5: Mapping[str, str], credentials: Collection[Credential] = ()
    ) -> dict[str, Any]:
        """Zenoh configuration entries (path -> JSON value) for this bridge (see :func:`zenoh_settings`), with
        its access control; ``inbound_md5`` maps inbound topics to their md5 sums, ``credentials`` are those the
        Zenoh file checks (:func:`mrs_nav.bridge.exposure.credentials`), each of which an operator must pass."""
        settings = zenoh_settings(self.mode, self.listen, self.connect, self.retry_period)
        if self.acl:
            inbound = [(rule.topic, rule.type, inbound_md5.get(rule.topic, "")) for rule in self.inbound]
            settings["access_control"] = access_control(
                self.key_prefix, self.layout, inbound, self.operators, credentials
            )
        return settings

    @classmethod
    def from_mapping(cls, params: Mapping[str, Any]) -> BridgeConfig:
        """Build from a parameter mapping (ROS ``~`` params or YAML); unknown keys are errors."""
        known = {
            "mode", "listen", "connect", "prefix", "namespace", "layout", "allow", "deny", "max_rates",
            "default_max_rate", "inbound", "discovery_period", "retry_period", "zenoh_config", "acl", "operators",
            "insecure",
        }  # fmt: skip
        unknown = sorted(set(params) - known - {"config_file"})
        if unknown:
            raise InvalidInputError(f"unknown bridge parameter(s) {unknown}; known: {sorted(known)}")
        kwargs: dict[str, Any] = {}
        for key in ("mode", "prefix", "namespace", "zenoh_config"):
            if key in params:
                kwargs[key] = _text(params[key], key)
        for key in ("listen", "connect", "operators"):
            if key in params:
                kwargs[key] = _text_list(params[key], key)
        for key in ("default_max_rate", "discovery_period", "retry_period"):
            if key in params:
                kwargs[key] = _number(params[key], key)
        for key in ("acl", "insecure"):
            if key in params:
                if not isinstance(params[key], bool):
                    raise InvalidInputError(f"{key}: expected true or false, got {params[key]!r}")
                kwargs[key] = params[key]
        if "layout" in params:
            try:
                kwargs["layout"] = KeyLayout(params["layout"])
            except ValueError:
                choices = ", ".join(layout.value for layout in KeyLayout)
                raise InvalidInputError(f"layout {params['layout']!r}: expected one of {choices}") from None
        kwargs["topics"] = TopicFilter(
            _text_list(params.get("allow", DEFAULT_ALLOW), "allow"),
            _text_list(params.get("deny", DEFAULT_DENY), "deny"),
        )
        rates = params.get("max_rates") or {}
        if not isinstance(rates, Mapping):
            raise InvalidInputError(f"max_rates: expected a mapping topic-regex -> Hz, got {rates!r}")
        kwargs["max_rates"] = tuple((str(k), _number(v, f"max_rates[{k}]")) for k, v in rates.items())
        kwargs["inbound"] = tuple(_rule(item) for item in params.get("inbound") or [])
        return cls(**kwargs)


def zenoh_settings(
    mode: str, listen: Iterable[str], connect: Iterable[str], retry_period: float = 1.0
) -> dict[str, Any]:
    """Zenoh configuration entries for a session on given endpoints, multicast scouting always off.

    Timestamping is on because advanced publishers (history for late joiners) need it; connection retries
    back off from 100 ms to ``retry_period`` so a restarted peer or router is found again quickly. A sample
    waits up to 50 ms (Zenoh's default: 1 ms) for room in a congested transmit queue before it is dropped:
    on a busy 2-core machine 1 ms lost odometry messages, and 50 ms is still far below what would back up
    the bridge's ROS subscriber queues. Express publishers send every sample in a batch of its own, so the data
    queue (Zenoh's default: 2 batches per link) holds 2 samples: 16 (Zenoh's maximum) lets a link whose transmit
    thread is held off the CPU fall 16 samples behind (160 ms of odometry) before puts wait at all; batches are
    allocated lazily, so an idle link costs nothing.
    """
    # Checked here, where every session's endpoints pass: Zenoh's own message for a malformed one is a Rust debug
    # dump naming its source files.
    listen, connect = [check_endpoint(e) for e in listen], [check_endpoint(e) for e in connect]
    retry_ms = round(retry_period * 1000)
    return {
        "mode": mode,
        "listen/endpoints": listen,
        "connect/endpoints": connect,
        "connect/retry": {"period_init_ms": 100, "period_max_ms": retry_ms, "period_increase_factor": 2},
        "scouting/multicast/enabled": False,
        "timestamping/enabled": True,
        "transport/link/tx/queue/congestion_control/drop/wait_before_drop": 50_000,  # µs
        "transport/link/tx/queue/congestion_control/drop/max_wait_before_drop_fragments": 250_000,  # µs
        "transport/link/tx/queue/size/data": 16,  # batches
    }


def _text(value: Any, what: str) -> str:
    if not isinstance(value, str):
        raise InvalidInputError(f"{what}: expected text, got {value!r}")
    return value


def _text_list(value: Any, what: str) -> tuple[str, ...]:
    """A list of strings, or one comma-separated string (what a roslaunch argument gives)."""
    if isinstance(value, str):
        return tuple(v.strip() for v in value.split(",") if v.strip())
    if not isinstance(value, list | tuple) or not all(isinstance(v, str) for v in value):
        raise InvalidInputError(f"{what}: expected a list of strings, got {value!r}")
    return tuple(value)


def _number(value: Any, what: str) -> float:
    value = yaml12_number(value)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InvalidInputError(f"{what}: expected a number, got {value!r}")
    return float(value)


def _integer(value: Any, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InvalidInputError(f"{what}: expected a whole number, got {value!r}")
    return value


def _rule(item: Any) -> InboundRule:
    if isinstance(item, str):
        item = {"topic": item}
    if not isinstance(item, Mapping) or "topic" not in item:
        raise InvalidInputError(f"inbound: expected {{topic, type, frame}} entries, got {item!r}")
    topic = _text(item["topic"], "inbound topic")
    default_type = KNOWN_INBOUND.get(topic, ("", ""))
    type_name = _text(item.get("type", default_type[0]), f"inbound {topic} type")
    if not type_name:
        raise InvalidInputError(f"inbound {topic}: name its message type (type: pkg/Type)")
    unknown = sorted(set(item) - {"topic", "type", "frame", "max_bytes", "max_rate", "max_age"})
    if unknown:
        raise InvalidInputError(
            f"inbound {topic}: unknown key(s) {unknown}; known: topic, type, frame, max_bytes, max_rate, max_age"
        )
    return InboundRule(
        topic,
        type_name,
        _text(item.get("frame", default_type[1]), f"inbound {topic} frame"),
        _integer(item.get("max_bytes", DEFAULT_INBOUND_BYTES), f"inbound {topic} max_bytes"),
        _number(item.get("max_rate", DEFAULT_INBOUND_RATE), f"inbound {topic} max_rate"),
        _number(item.get("max_age", DEFAULT_INBOUND_AGE), f"inbound {topic} max_age"),
    )


# Topics whose type and frame are fixed by DESIGN.md, so that ``inbound: [/move_base_simple/goal]`` suffices.
KNOWN_INBOUND = {"/move_base_simple/goal": ("geometry_msgs/PoseStamped", "map")}
