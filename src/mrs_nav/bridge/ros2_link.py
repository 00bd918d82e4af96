"""What the ROS 2 bridge's two processes agree on: the routes, their QoS, the frames on the pipe, the child's
environment and how it joins ROS 1.

ROS 1 (Debian's rospy) and ROS 2 (the Jazzy wheels) cannot share a process: both provide ``std_msgs``,
``nav_msgs``, ... under the same names. So the ROS 1 half (:mod:`mrs_nav.ros.ros2_bridge_node`) starts the ROS 2
half (:mod:`mrs_nav.ros2.bridge_half`) in the ROS 2 venv. The ROS 2 half subscribes to the outbound routes' ROS 1
topics itself, as a ROS 1 node of its own without rospy (:mod:`mrs_nav.bridge.tcpros`, named by
:class:`Ros1Endpoint`): each message goes from its publisher to ROS 2 through one process, where handing rospy's
bytes over a pipe added a hop between processes to every message. The pipe (the child's stdin and stdout) carries
what needs rospy: the allow-listed ROS 2 topics into ROS 1 and the NavigateToPose action's exchanges. A pipe rather
than a socket or Zenoh: nothing to listen on or secure, no port to pick, and the child dies with its parent (end
of file on stdin).

A frame is ``<channel: uint16><length: uint32><payload>``, little-endian; the channel is the route's index in
:attr:`Ros2BridgeConfig.routes`.
"""

from __future__ import annotations

import enum
import json
import re
import struct
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import IO, Any

from mrs_nav.bridge.ros2_action import ACTION_NAME, ROS1_ACTION
from mrs_nav.config_files import node_defaults
from mrs_nav.errors import InvalidInputError

FRAME_HEADER = struct.Struct("<HI")
PARTICLE_CLOUD = "nav2_msgs/ParticleCloud"
#: Larger frames are refused: a map of 4000 x 4000 cells is 16 MB.
MAX_FRAME_BYTES = 64 * 1024 * 1024
#: The discovery ranges ROS 2 accepts in ROS_AUTOMATIC_DISCOVERY_RANGE (the default, SUBNET, is not offered).
DISCOVERY_RANGES = ("LOCALHOST", "SUBNET", "SYSTEM_DEFAULT", "OFF")
_NAMESPACE = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*)?$")


class Qos(enum.Enum):
    """The ROS 2 QoS of a route, as Nav2 uses them."""

    SENSOR = "sensor"  # best effort, keep last 5 (sensor data): /scan, /particlecloud
    RELIABLE = "reliable"  # reliable, volatile, keep last 10: /odom, /plan, /cmd_vel, goals
    LATCHED = "latched"  # reliable, transient_local, keep last 1: /map, /amcl_pose (late joiners get the last)
    TF = "tf"  # reliable, volatile, keep last 100: /tf
    TF_STATIC = "tf_static"  # reliable, transient_local, keep last 1: every static transform in one message


@dataclass(frozen=True)
class Route:
    """One bridged topic: its ROS 1 and ROS 2 names (before the namespace), its type (``pkg/Name``, the same
    on both sides unless ``ros2_type`` names the one the ROS 2 half converts it to), the QoS, whether it runs
    ROS 2 -> ROS 1, and whether the robot's namespace applies to its names (not to /tf and /tf_static, which
    several robots share with their frames prefixed: a namespaced bridge sends on only the transforms whose
    child frame carries its namespace)."""

    ros1: str
    ros2: str
    type: str
    qos: Qos
    inbound: bool = False
    namespaced: bool = True
    ros2_type: str = ""

    @property
    def published_type(self) -> str:
        """The type on the ROS 2 side."""
        return self.ros2_type or self.type


#: ROS 1 -> ROS 2. tf2_msgs/TFMessage and nav2_msgs are not among the ROS 2 wheels: the install step generates
#: them (tools/install_ros2.sh). The particle cloud goes out twice: as ROS 1's amcl names it (a PoseArray, for
#: rviz2's PoseArray display) and as Nav2's amcl does (/particle_cloud, nav2_msgs/ParticleCloud, for Nav2's
#: rviz2 plugin and tools written against Nav2).
OUTBOUND: tuple[Route, ...] = (
    Route("/scan", "/scan", "sensor_msgs/LaserScan", Qos.SENSOR),
    Route("/odom", "/odom", "nav_msgs/Odometry", Qos.RELIABLE),
    Route("/map", "/map", "nav_msgs/OccupancyGrid", Qos.LATCHED),
    Route("/path", "/plan", "nav_msgs/Path", Qos.RELIABLE),
    Route(
        "/amcl_pose",
        "/amcl_pose",
        "geometry_msgs/PoseWithCovarianceStamped",
        Qos.LATCHED,
    ),
    Route("/particlecloud", "/particlecloud", "geometry_msgs/PoseArray", Qos.SENSOR),
    Route("/particlecloud", "/particle_cloud", "geometry_msgs/PoseArray", Qos.SENSOR, ros2_type=PARTICLE_CLOUD),
    Route("/tf", "/tf", "tf2_msgs/TFMessage", Qos.TF, namespaced=False),
    Route("/tf_static", "/tf_static", "tf2_msgs/TFMessage", Qos.TF_STATIC, namespaced=False),
)
#: ROS 2 -> ROS 1, each only when its ROS 2 name is in the allow-list (``allow_inbound``).
INBOUND: tuple[Route, ...] = (
    Route("/cmd_vel", "/cmd_vel", "geometry_msgs/Twist", Qos.RELIABLE, inbound=True),
    Route(
        "/move_base_simple/goal",
        "/goal_pose",
        "geometry_msgs/PoseStamped",
        Qos.RELIABLE,
        inbound=True,
    ),
    Route(
        "/initialpose",
        "/initialpose",
        "geometry_msgs/PoseWithCovarianceStamped",
        Qos.RELIABLE,
        inbound=True,
    ),
)


def _namespaced(namespace: str, topic: str) -> str:
    return f"/{namespace}{topic}" if namespace else topic


@dataclass(frozen=True)
class Ros2BridgeConfig:
    """The bridge's parameters (defaults: config/ros2_bridge.yaml)."""

    namespace: str
    domain_id: int
    discovery_range: str
    allow_inbound: tuple[str, ...]
    python: str

    @classmethod
    def from_mapping(cls, params: Mapping[str, Any]) -> Ros2BridgeConfig:
        merged = {**node_defaults("ros2_bridge"), **params}
        known = {r.ros2 for r in INBOUND} | {ACTION_NAME}
        allow = tuple(str(t) for t in merged["allow_inbound"] or ())
        unknown = sorted(set(allow) - known)
        if unknown:
            raise InvalidInputError(
                f"allow_inbound: {unknown} not among the inbound topics and actions {sorted(known)}"
            )
        domain = int(merged["domain_id"])
        if not 0 <= domain <= 232:
            raise InvalidInputError(f"domain_id: {domain} is outside 0..232")
        discovery = str(merged["discovery_range"]).upper()
        if discovery not in DISCOVERY_RANGES:
            raise InvalidInputError(f"discovery_range: {discovery!r} is not one of {', '.join(DISCOVERY_RANGES)}")
        namespace = str(merged["namespace"]).strip("/")
        if not _NAMESPACE.match(namespace):
            raise InvalidInputError(f"namespace: {namespace!r} is not a valid ROS namespace")
        return cls(namespace, domain, discovery, allow, str(merged["python"]))

    @property
    def routes(self) -> tuple[Route, ...]:
        """Every outbound route, then the allowed inbound ones; a frame's channel is an index in this."""
        return OUTBOUND + tuple(r for r in INBOUND if r.ros2 in self.allow_inbound)

    @property
    def allow_action(self) -> bool:
        """Whether the ROS 2 half serves NavigateToPose (sent on to move_base)."""
        return ACTION_NAME in self.allow_inbound

    @property
    def action_names(self) -> tuple[str, str]:
        """NavigateToPose's name on ROS 2 and move_base's on ROS 1, in the robot's namespace."""
        return _namespaced(self.namespace, ACTION_NAME), _namespaced(self.namespace, "/" + ROS1_ACTION)

    def ros1_topic(self, route: Route) -> str:
        return _namespaced(self.namespace, route.ros1) if route.namespaced else route.ros1

    def ros2_topic(self, route: Route) -> str:
        return _namespaced(self.namespace, route.ros2) if route.namespaced else route.ros2

    def own_frame(self, frame: str) -> bool:
        """Whether a transform to ``frame`` belongs to this bridge's robot (every frame without a namespace)."""
        return not self.namespace or frame.lstrip("/").startswith(self.namespace + "/")

    def to_json(self) -> str:
        return json.dumps(asdict(self))

    @classmethod
    def from_json(cls, text: str) -> Ros2BridgeConfig:
        fields = json.loads(text)
        return cls(**{**fields, "allow_inbound": tuple(fields["allow_inbound"])})


def ros2_python(configured: str, environ: Mapping[str, str], main_prefix: str) -> Path:
    """The ROS 2 venv's interpreter: ``configured`` if given, else ``$VENV_ROS2/bin/python``, else the
    ``.venv-ros2`` beside the running venv (where ``MRS_NAV_ROS2=1 make install`` puts it)."""
    if configured:
        return Path(configured)
    if environ.get("VENV_ROS2"):
        return Path(environ["VENV_ROS2"]) / "bin" / "python"
    return Path(main_prefix).parent / ".venv-ros2" / "bin" / "python"


def child_environment(config: Ros2BridgeConfig, environ: Mapping[str, str], package_root: Path) -> dict[str, str]:
    """The ROS 2 half's environment: this process's, without what would mix ROS 1 into it, plus its domain.

    PYTHONPATH is only the folder holding mrs_nav (not Debian's ROS 1 packages), and the wheels' bootstrap
    marker is dropped so that the child's bootstrap sets LD_LIBRARY_PATH for itself again."""
    env = {k: v for k, v in environ.items() if k not in ("PYTHONPATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE")}
    env.pop("ROS_LOCALHOST_ONLY", None)  # deprecated; would override the range given here
    env["PYTHONPATH"] = str(package_root)
    env["ROS_DOMAIN_ID"] = str(config.domain_id)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = config.discovery_range
    env["RMW_IMPLEMENTATION"] = "rmw_fastrtps_cpp"
    env["PYTHONUNBUFFERED"] = "1"
    return env


@dataclass(frozen=True)
class Ros1Endpoint:
    """How the ROS 2 half joins ROS 1 (:mod:`mrs_nav.bridge.tcpros`): the master's URI, its node name, the host
    other nodes reach it by and the address it listens on (as rospy finds them for the ROS 1 half), and each
    outbound channel's ROS 1 topic as the ROS 1 half resolves it (its remappings applied)."""

    master_uri: str
    caller_id: str
    host: str
    bind: str
    topics: dict[int, str]

    def to_json(self) -> str:
        return json.dumps(asdict(self))

    @classmethod
    def from_json(cls, text: str) -> Ros1Endpoint:
        fields = json.loads(text)
        return cls(**{**fields, "topics": {int(channel): topic for channel, topic in fields["topics"].items()}})


def child_command(python: Path, config: Ros2BridgeConfig, endpoint: Ros1Endpoint) -> list[str]:
    return [str(python), "-m", "mrs_nav.ros2.bridge_half", config.to_json(), endpoint.to_json()]


def encode_frame(channel: int, payload: bytes | memoryview) -> bytes:
    if len(payload) > MAX_FRAME_BYTES:
        raise InvalidInputError(f"frame of {len(payload)} bytes exceeds {MAX_FRAME_BYTES}")
    return FRAME_HEADER.pack(channel, len(payload)) + bytes(payload)


def read_frame(stream: IO[bytes]) -> tuple[int, bytes] | None:
    """The next ``(channel, payload)`` from ``stream``; None at its end. InvalidInputError on a frame too large
    or cut short (the stream is then out of step and unusable)."""
    header = stream.read(FRAME_HEADER.size)
    if not header:
        return None
    if len(header) < FRAME_HEADER.size:
        raise InvalidInputError("pipe closed inside a frame header")
    channel, length = FRAME_HEADER.unpack(header)
    if length > MAX_FRAME_BYTES:
        raise InvalidInputError(f"frame of {length} bytes exceeds {MAX_FRAME_BYTES}")
    payload = stream.read(length)
    if len(payload) < length:
        raise InvalidInputError(f"pipe closed inside a frame ({len(payload)} of {length} bytes)")
    return channel, payload


def package_root() -> Path:
    """The folder holding the mrs_nav package (what the ROS 2 half's PYTHONPATH needs)."""
    return Path(__file__).resolve().parents[2]
