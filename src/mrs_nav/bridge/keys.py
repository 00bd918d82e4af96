"""Zenoh key expressions for ROS topics, type definitions and the bridge's control queryables.

Layout ``mrs_nav`` (default): a topic ``/a/b`` of the robot with key prefix ``P`` travels on ``P/a/b``; the
prefix is ``mrs_nav`` joined with the robot's namespace (``mrs_nav/robot1``). Bridge services live under
chunks starting with ``@``, which Zenoh's ``**`` never matches, so ``P/**`` selects data only:

- ``P/@types/<pkg>/<Type>``: queryable answering the message definition (JSON, see :mod:`.wire`),
- ``P/@bridge/status``: queryable answering what the bridge bridges (see :mod:`.wire`),
- ``P/@bridge/publish/<topic>``: queryable through which a remote peer asks to publish into ROS (answered
  with an ok or an error reply naming why it was refused),
- liveliness tokens on each data key ``P/<topic>`` announce the bridged topics.

Layout ``zenoh-bridge-ros1`` reproduces the data keys of eclipse-zenoh's ROS 1 bridge as released in
zenoh-plugin-ros1 1.0.0-rc.1, ``<hex(type)>/<md5>/<topic>`` with an empty prefix (a non-empty one is
inserted before the topic), and its discovery beacons
``ros1_discovery_info/*/pub/<hex(type)>/<md5>/*/<topic>`` (:func:`discovery_key`), so a zenoh-bridge-ros1 on
another master finds and subscribes to our topics. The ``@`` services stay under the prefix, or under
``mrs_nav`` when the prefix is empty.
"""

from __future__ import annotations

import enum
import re

from mrs_nav.errors import InvalidInputError

# A ROS graph resource name (ROS wiki "Names"): slash-separated chunks of [A-Za-z][A-Za-z0-9_]*; the
# bridge only handles global names, and Zenoh forbids '*', '$', '?', '#' inside key chunks anyway.
_TOPIC = re.compile(r"^(/[A-Za-z~_][A-Za-z0-9_]*)+$")
_PREFIX = re.compile(r"^[A-Za-z0-9_\-.]+(/[A-Za-z0-9_\-.]+)*$")
_TYPE = re.compile(r"^[A-Za-z][A-Za-z0-9_]*/(msg/)?[A-Za-z][A-Za-z0-9_]*$")


class KeyLayout(enum.Enum):
    """How topics map to Zenoh keys."""

    MRS_NAV = "mrs_nav"
    ZENOH_BRIDGE_ROS1 = "zenoh-bridge-ros1"


def check_topic(topic: str) -> str:
    """Return ``topic`` if it is a global ROS topic name usable as a key, else raise InvalidInputError."""
    if not _TOPIC.match(topic):
        raise InvalidInputError(f"topic {topic!r}: expected a global ROS name like /move_base_simple/goal")
    return topic


def check_type(type_name: str) -> str:
    """Return ``type_name`` (``pkg/Type``) if well formed, else raise InvalidInputError."""
    if not _TYPE.match(type_name):
        raise InvalidInputError(f"message type {type_name!r}: expected pkg/Type, e.g. nav_msgs/Odometry")
    return type_name


def robot_prefix(prefix: str, namespace: str = "") -> str:
    """The key prefix of one robot: ``prefix`` then the namespace's chunks (``mrs_nav`` + ``/r1`` -> ``mrs_nav/r1``);
    may be empty (zenoh-bridge-ros1's layout has none)."""
    prefix = prefix.strip("/")
    ns = namespace.strip("/")
    full = f"{prefix}/{ns}" if prefix and ns else prefix or ns
    if full and not _PREFIX.match(full):
        raise InvalidInputError(f"key prefix {full!r}: expected chunks of letters, digits, '_', '-', '.'")
    return full


def topic_key(
    prefix: str, topic: str, layout: KeyLayout = KeyLayout.MRS_NAV, type_name: str = "", md5: str = ""
) -> str:
    """The data key of ``topic`` (see the module docstring for both layouts)."""
    chunk = check_topic(topic).strip("/")
    if layout is KeyLayout.MRS_NAV:
        return f"{prefix}/{chunk}"
    head = f"{check_type(type_name).encode().hex()}/{md5}"
    return f"{head}/{prefix}/{chunk}" if prefix else f"{head}/{chunk}"


def data_pattern(prefix: str, layout: KeyLayout) -> str:
    """Key expression matching every data key of the bridge."""
    if layout is KeyLayout.MRS_NAV:
        return f"{prefix}/**"
    return f"*/*/{prefix}/**" if prefix else "*/*/**"


def services_pattern(prefix: str) -> str:
    """Where the ``@types`` and ``@bridge`` services live: the prefix, or ``mrs_nav`` when it is empty."""
    return prefix or "mrs_nav"


DISCOVERY_ROOT = "ros1_discovery_info"


def discovery_key(topic: str, type_name: str, md5: str) -> str:
    """zenoh-bridge-ros1's announcement that a ROS publisher of ``topic`` is bridged (discovery and bridge
    namespaces ``*``, as its releases use)."""
    return f"{DISCOVERY_ROOT}/*/pub/{check_type(type_name).encode().hex()}/{md5}/*/{check_topic(topic).strip('/')}"


def discovery_pattern() -> str:
    return f"{DISCOVERY_ROOT}/**"


def topic_of_key(prefix: str, key: str) -> str:
    """Inverse of :func:`topic_key` for the ``mrs_nav`` layout: ``P/a/b`` -> ``/a/b``."""
    head = prefix + "/"
    if not key.startswith(head) or len(key) == len(head):
        raise InvalidInputError(f"key {key!r} is not under prefix {prefix!r}")
    return check_topic("/" + key[len(head) :])


def types_key(prefix: str, type_name: str) -> str:
    """Key of the definition of ``pkg/Type`` (``pkg/msg/Type`` accepted): ``P/@types/pkg/Type``."""
    pkg, _, name = check_type(type_name).partition("/")
    return f"{prefix}/@types/{pkg}/{name.removeprefix('msg/')}"


def publish_key(prefix: str, topic: str) -> str:
    """Key of the queryable through which a remote peer publishes ``topic`` into ROS."""
    return f"{prefix}/@bridge/publish/{check_topic(topic).strip('/')}"


STATUS_SUFFIX = "/@bridge/status"


def status_key(prefix: str) -> str:
    """Key of the queryable answering the bridge's status (JSON, see :mod:`.wire`)."""
    return f"{services_pattern(prefix)}{STATUS_SUFFIX}"


def topic_of_publish_key(prefix: str, key: str) -> str:
    """Inverse of :func:`publish_key`."""
    return topic_of_key(f"{prefix}/@bridge/publish", key)
