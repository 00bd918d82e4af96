"""A ROS 1 node that only subscribes and takes each message as its serialised bytes, without rospy.

The ROS 2 bridge's ROS 2 half cannot import rospy (:mod:`mrs_nav.bridge.ros2_link` says why), and handing it every
message from a rospy process over a pipe costs a hop between processes per message: on a quiet machine that hop
and rospy's own were most of the bridge's latency above an rclpy-to-rclpy floor. So the ROS 2 half subscribes to
the ROS 1 topics itself, speaking the two protocols a ROS 1 subscriber needs (the ROS wiki's "ROS/Master_Slave_APIs"
and "ROS/TCPROS"), with the standard library only:

- **XML-RPC with the master**: ``registerSubscriber`` answers with the publishers' URIs; the master calls
  ``publisherUpdate`` on this node's own XML-RPC server when they change; ``unregisterSubscriber`` at the end.
- **TCPROS with each publisher**: ``requestTopic`` on the publisher's URI gives a host and port; this node's
  connection header (``callerid``, ``topic``, ``md5sum=*`` and ``type=*`` as ``rospy.AnyMsg`` sends them,
  ``tcp_nodelay=1``) is answered by the publisher's (its ``type``; a latched publisher then sends its last
  message at once); then every message is a little-endian ``uint32`` length and the message's ROS 1 bytes.

One thread reads each publisher's connection and calls the subscription's callbacks with the bytes, as rospy does.
A connection that fails while the master still lists its publisher is tried again every :data:`RETRY_PERIOD_S`;
one the publisher closes ends (the master says if the publisher comes back). The master is asked for its pid
every :data:`POLL_PERIOD_S` and a master that restarted (:mod:`mrs_nav.master_restart`'s rule) is given every
subscription again, as :mod:`mrs_nav.ros.master_watch` does for rospy nodes.
"""

from __future__ import annotations

import contextlib
import os
import re
import socket
import socketserver
import struct
import threading
import xmlrpc.client
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import IO, Any
from xmlrpc.server import SimpleXMLRPCServer

from mrs_nav.errors import InvalidInputError
from mrs_nav.master_restart import MasterLiveness, MasterState
from mrs_nav.ros_processes import TimeoutTransport

LENGTH = struct.Struct("<I")
POLL_PERIOD_S = 1.0  # wall s between two questions to the master
RETRY_PERIOD_S = 1.0  # wall s before a failed connection to a listed publisher is tried again
CALL_TIMEOUT_S = 5.0  # wall s an XML-RPC call or a TCP connect may take
#: A longer message or connection header is refused (the connection closed): 4000 x 4000 map cells are 16 MB.
MAX_MESSAGE_BYTES = 256 * 1024 * 1024
FAILURE_LOG_EVERY = 100  # a callback failing on every message is logged on the 1st, 101st, ... failure

#: The slave API's calls this node answers (each by its ``_api_`` method of the same name in snake case).
SLAVE_API = (
    "publisherUpdate",
    "requestTopic",
    "getPid",
    "getMasterUri",
    "getSubscriptions",
    "getPublications",
    "getBusStats",
    "getBusInfo",
    "paramUpdate",
    "shutdown",
)

Callback = Callable[[bytes], None]
Log = Callable[[str], None]


def _snake(name: str) -> str:
    return re.sub(r"([A-Z])", lambda m: "_" + m.group(1).lower(), name)


def encode_header(fields: Mapping[str, str]) -> bytes:
    """A TCPROS connection header: the total length, then each ``key=value`` after its own length."""
    body = b"".join(LENGTH.pack(len(item)) + item for item in (f"{k}={v}".encode() for k, v in fields.items()))
    return LENGTH.pack(len(body)) + body


def decode_header(body: bytes) -> dict[str, str]:
    """The fields of a connection header's body (after its total length); InvalidInputError if malformed."""
    fields: dict[str, str] = {}
    at = 0
    while at < len(body):
        if at + LENGTH.size > len(body):
            raise InvalidInputError(f"TCPROS header: a field length cut short at byte {at}")
        (size,) = LENGTH.unpack_from(body, at)
        at += LENGTH.size
        if at + size > len(body):
            raise InvalidInputError(f"TCPROS header: a field of {size} bytes at byte {at} runs past the header")
        key, equals, value = body[at : at + size].decode("utf-8", errors="replace").partition("=")
        if not equals:
            raise InvalidInputError(f"TCPROS header: field {key[:40]!r} has no '='")
        fields[key] = value
        at += size
    return fields


def read_block(stream: IO[bytes]) -> bytes | None:
    """The next length-prefixed block (a header or a message) from ``stream``; None at its end between blocks.
    InvalidInputError for a block cut short or longer than :data:`MAX_MESSAGE_BYTES`."""
    prefix = stream.read(LENGTH.size)
    if not prefix:
        return None
    if len(prefix) < LENGTH.size:
        raise InvalidInputError("TCPROS: connection closed inside a length")
    (size,) = LENGTH.unpack(prefix)
    if size > MAX_MESSAGE_BYTES:
        raise InvalidInputError(f"TCPROS: a block of {size} bytes exceeds {MAX_MESSAGE_BYTES}")
    block = stream.read(size)
    if len(block) < size:
        raise InvalidInputError(f"TCPROS: connection closed inside a block ({len(block)} of {size} bytes)")
    return block


@dataclass
class Subscription:
    """One ROS 1 topic: its type (``pkg/Name``), the callbacks given each message's bytes, and ``refuse``, told
    when a publisher's type is another (the connection is then closed)."""

    topic: str
    type: str
    refuse: Callable[[str, str], None]
    callbacks: list[Callback] = field(default_factory=list)
    publishers: frozenset[str] = frozenset()


class _XmlRpcServer(socketserver.ThreadingMixIn, SimpleXMLRPCServer):
    daemon_threads = True
    allow_reuse_address = True


class _XmlRpcServer6(_XmlRpcServer):
    address_family = socket.AF_INET6


def _server_for(bind: str) -> _XmlRpcServer:
    """This node's XML-RPC server on a free port of ``bind`` (an IPv6 address with ROS_IPV6=on, as rospy's)."""
    server_class = _XmlRpcServer6 if ":" in bind else _XmlRpcServer
    return server_class((bind, 0), logRequests=False, allow_none=True)


class RawSubscriberNode:
    """A ROS 1 node named ``caller_id`` with subscriptions only (see the module docstring).

    ``host`` is the name other nodes reach it by (``ROS_IP``/``ROS_HOSTNAME`` as rospy reads them), ``bind`` the
    address its XML-RPC server listens on. :meth:`close` unregisters and ends every connection."""

    def __init__(self, master_uri: str, caller_id: str, host: str, bind: str, log: Log) -> None:
        self.master_uri = master_uri
        self.caller_id = caller_id
        self.log = log
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self._subscriptions: dict[str, Subscription] = {}
        self._links: dict[tuple[str, str], _Link] = {}
        self._server = _server_for(bind)
        for wire_name in SLAVE_API:
            self._server.register_function(getattr(self, "_api_" + _snake(wire_name)), wire_name)
        named = f"[{host}]" if ":" in host else host  # an IPv6 address in a URI is bracketed
        self.uri = f"http://{named}:{self._server.server_address[1]}/"
        self._on_shutdown: Callable[[str], None] = lambda reason: None
        threading.Thread(target=self._server.serve_forever, name="tcpros-xmlrpc", daemon=True).start()

    def _master(self) -> Any:
        return xmlrpc.client.ServerProxy(self.master_uri, transport=TimeoutTransport(CALL_TIMEOUT_S))

    def subscribe(self, topic: str, type_name: str, callback: Callback, refuse: Callable[[str, str], None]) -> None:
        """Gives ``callback`` the bytes of every message on ``topic`` (registered with the master now)."""
        with self._lock:
            known = self._subscriptions.get(topic)
            if known is not None and known.type != type_name:
                raise InvalidInputError(f"{topic}: subscribed as {known.type} already, not {type_name}")
            subscription = known or Subscription(topic, type_name, refuse)
            subscription.callbacks.append(callback)
            self._subscriptions[topic] = subscription
        if known is None:
            self._register(subscription)

    def watch_master(self, on_shutdown: Callable[[str], None]) -> None:
        """Starts the master watch (see the module docstring); ``on_shutdown`` is called when the master or a
        user (``rosnode kill``) asks this node to shut down."""
        self._on_shutdown = on_shutdown
        threading.Thread(target=self._watch, name="tcpros-master", daemon=True).start()

    def _register(self, subscription: Subscription) -> None:
        code, status, publishers = self._master().registerSubscriber(
            self.caller_id, subscription.topic, subscription.type, self.uri
        )
        if code != 1:
            raise InvalidInputError(f"master refused the subscription to {subscription.topic}: {status}")
        self.publisher_update(subscription.topic, publishers)

    def publisher_update(self, topic: str, publishers: list[str]) -> None:
        """Connects to the listed publishers of ``topic`` not yet connected.

        A connection to a publisher no longer listed is left to end by itself, as rospy leaves it: a publisher
        that unregisters closes its connections, and a master that has just restarted lists only the publishers
        that have registered again so far, while the others still send."""
        with self._lock:
            subscription = self._subscriptions.get(topic)
            if subscription is None or self._closed.is_set():
                return
            subscription.publishers = frozenset(publishers)
            for uri in subscription.publishers:
                if (topic, uri) not in self._links:
                    link = self._links[(topic, uri)] = _Link(self, subscription, uri)
                    link.start()

    def wanted(self, link: _Link) -> bool:
        """Whether ``link`` should connect (again): it is the one for its publisher, listed for its topic."""
        with self._lock:
            current = self._links.get((link.subscription.topic, link.publisher))
            listed = link.publisher in link.subscription.publishers
            return not self._closed.is_set() and current is link and listed

    def forget(self, link: _Link) -> None:
        with self._lock:
            if self._links.get((link.subscription.topic, link.publisher)) is link:
                del self._links[(link.subscription.topic, link.publisher)]

    def _watch(self) -> None:
        liveness = MasterLiveness()
        while not self._closed.wait(POLL_PERIOD_S):
            pid: int | None = None
            try:
                code, _, answer = self._master().getPid(self.caller_id)
                pid = int(answer) if code == 1 else None
            except (OSError, xmlrpc.client.Error):
                pid = None
            change = liveness.observe(pid)
            if change is None:
                continue
            if change.state is MasterState.LOST:
                self.log(f"ROS master at {self.master_uri} lost; the topics' connections stay up")
                continue
            with self._lock:
                subscriptions = list(self._subscriptions.values())
            try:
                for subscription in subscriptions:
                    self._register(subscription)
                self.log(f"ROS master back (pid {change.pid}): {len(subscriptions)} subscriptions registered again")
            except (OSError, xmlrpc.client.Error, InvalidInputError) as err:
                self.log(f"ROS master back but registering again failed: {err}")

    def close(self) -> None:
        """Unregisters every subscription (if the master answers) and ends every connection."""
        if self._closed.is_set():
            return
        self._closed.set()
        with self._lock:
            topics = list(self._subscriptions)
            links = list(self._links.values())
            self._links.clear()
        for link in links:
            link.close()
        for topic in topics:
            with contextlib.suppress(OSError, xmlrpc.client.Error):
                self._master().unregisterSubscriber(self.caller_id, topic, self.uri)
        self._server.shutdown()
        self._server.server_close()

    # The slave API (the ROS wiki's "ROS/Slave_API"): each answers [code, status message, value].

    def _api_publisher_update(self, caller_id: str, topic: str, publishers: list[str]) -> list[Any]:
        self.publisher_update(topic, publishers)
        return [1, "", 0]

    def _api_request_topic(self, caller_id: str, topic: str, protocols: list[Any]) -> list[Any]:
        return [-1, f"{self.caller_id} publishes nothing ({topic} asked)", []]

    def _api_get_pid(self, caller_id: str) -> list[Any]:
        return [1, "", os.getpid()]

    def _api_get_master_uri(self, caller_id: str) -> list[Any]:
        return [1, "", self.master_uri]

    def _api_get_subscriptions(self, caller_id: str) -> list[Any]:
        with self._lock:
            return [1, "", [[s.topic, s.type] for s in self._subscriptions.values()]]

    def _api_get_publications(self, caller_id: str) -> list[Any]:
        return [1, "", []]

    def _api_get_bus_stats(self, caller_id: str) -> list[Any]:
        return [1, "", [[], [], []]]

    def _api_get_bus_info(self, caller_id: str) -> list[Any]:
        with self._lock:
            links = list(self._links.values())
        info = [
            [i, link.publisher, "i", "TCPROS", link.subscription.topic, link.connected] for i, link in enumerate(links)
        ]
        return [1, "", info]

    def _api_param_update(self, caller_id: str, key: str, value: Any) -> list[Any]:
        return [1, "", 0]

    def _api_shutdown(self, caller_id: str, message: str = "") -> list[Any]:
        reason = f"shutdown asked by {caller_id}: {message}"
        self.log(reason)
        threading.Thread(target=self._on_shutdown, args=(reason,), daemon=True).start()
        return [1, "", 0]


class _Link(threading.Thread):
    """One publisher's connection for one topic, read in its own thread."""

    def __init__(self, node: RawSubscriberNode, subscription: Subscription, publisher: str) -> None:
        super().__init__(name=f"tcpros {subscription.topic}", daemon=True)
        self.node = node
        self.subscription = subscription
        self.publisher = publisher
        self.connected = False
        self.failures = 0
        self._socket: socket.socket | None = None
        self._stop = threading.Event()

    def close(self) -> None:
        self._stop.set()
        sock = self._socket
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)

    def run(self) -> None:
        said = False
        while not self._stop.is_set() and self.node.wanted(self):
            try:
                self._read()
                break  # the publisher closed the connection: it is going away; the master says if it comes back
            except (OSError, xmlrpc.client.Error, InvalidInputError) as err:
                if not said and not self._stop.is_set():
                    self.node.log(f"{self.subscription.topic} from {self.publisher}: {err}; trying again")
                    said = True
            finally:
                self.connected = False
                if self._socket is not None:
                    self._socket.close()
                    self._socket = None
            self._stop.wait(RETRY_PERIOD_S)
        self.node.forget(self)

    def _read(self) -> None:
        topic = self.subscription.topic
        proxy: Any = xmlrpc.client.ServerProxy(self.publisher, transport=TimeoutTransport(CALL_TIMEOUT_S))
        code, status, protocol = proxy.requestTopic(self.node.caller_id, topic, [["TCPROS"]])
        if code != 1 or not protocol or protocol[0] != "TCPROS":
            raise InvalidInputError(f"publisher offers no TCPROS connection ({status})")
        self._socket = socket.create_connection((protocol[1], int(protocol[2])), timeout=CALL_TIMEOUT_S)
        if self._stop.is_set():
            return
        # without it Nagle's algorithm holds small messages (odometry) for milliseconds
        self._socket.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        header = {"callerid": self.node.caller_id, "topic": topic, "md5sum": "*", "type": "*", "tcp_nodelay": "1"}
        self._socket.sendall(encode_header(header))
        self._socket.settimeout(None)
        with self._socket.makefile("rb") as stream:
            reply = read_block(stream)
            if reply is None:
                raise InvalidInputError("publisher closed the connection before its header")
            answer = decode_header(reply)
            if "error" in answer:
                raise InvalidInputError(f"publisher refused the connection: {answer['error']}")
            if answer.get("type") != self.subscription.type:
                self.subscription.refuse(topic, f"type {answer.get('type')}, expected {self.subscription.type}")
                self._stop.set()
                return
            self.connected = True
            while (message := read_block(stream)) is not None:
                for callback in self.subscription.callbacks:
                    self._deliver(callback, message)

    def _deliver(self, callback: Callback, message: bytes) -> None:
        """Calls ``callback``; a failure of one message's handling is logged (the first, then every
        :data:`FAILURE_LOG_EVERY`th), never the end of the connection."""
        try:
            callback(message)
        except Exception as err:  # whatever the handling raised, the topic keeps flowing
            self.failures += 1
            if self.failures % FAILURE_LOG_EVERY == 1:
                self.node.log(
                    f"{self.subscription.topic}: a message's handling failed ({self.failures} so far): {err!r}"
                )
