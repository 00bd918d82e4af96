"""Which topics and frames of a bag the replay reads, found the way gmapping finds them in a live system.

A bag from another robot has its own names: ``/scan`` and ``/tf`` only (as the gmapping tutorials record),
frames such as ``odom -> base_link -> laser``, the laser's mounting on ``/tf_static`` or republished on ``/tf``.
:class:`BagNames` holds the names (gmapping's parameters ``scan``, ``base_frame``, ``odom_frame``,
``map_frame``, defaults from ``config/slam.yaml``); :func:`resolve_frames` reads the bag's transforms up to the
first scan whose frame they link to the base frame and returns :class:`BagFrames`:

* the laser frame is the scan's ``header.frame_id``; its mounting is its planar pose in the base frame, from the
  first transform of each edge between them (``/tf_static``, or ``/tf`` for tf's ``static_transform_publisher``),
  composed in 3-D so that a laser mounted upside down (z axis down) has its angles mirrored;
* odometry is ``odom_topic`` (``nav_msgs/Odometry``) when the bag has it, else tf ``odom_frame -> base frame``;
* the base frame, unless given, is the one the odometry moves: ``/odom``'s ``child_frame_id`` or the child of
  ``odom_frame`` in tf.

A bag whose tf never links the laser to the base is refused naming both frames; a bag without any transform is
read with the laser at the base frame's origin, and says so.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from mrs_nav.bag import topics
from mrs_nav.bag.io import bag_topics, read_messages
from mrs_nav.bag.messages import scan_from_message
from mrs_nav.config_files import node_default
from mrs_nav.errors import BagError
from mrs_nav.geometry import Pose2D, yaw_from_quaternion
from mrs_nav.slam.scan import LaserScanData

Matrix = npt.NDArray[np.float64]

_slam_default = functools.partial(node_default, "slam")


@dataclass(frozen=True)
class BagNames:
    """Topics and frames to read (``base_frame`` empty: the frame the odometry moves)."""

    scan_topic: str = topics.SCAN
    odom_topic: str = topics.ODOM
    base_frame: str = ""
    odom_frame: str = field(default_factory=lambda: str(_slam_default("odom_frame")))
    map_frame: str = field(default_factory=lambda: str(_slam_default("map_frame")))

    def __post_init__(self) -> None:
        # As a live node resolves them: "scan" is /scan (a bag's topics are absolute), "/base_link" is tf1's base_link.
        for name in ("scan_topic", "odom_topic"):
            object.__setattr__(self, name, "/" + getattr(self, name).lstrip("/"))
        for name in ("base_frame", "odom_frame", "map_frame"):
            object.__setattr__(self, name, frame_name(getattr(self, name)))


@dataclass(frozen=True)
class BagFrames:
    """What :func:`resolve_frames` found: the frames, the laser's mounting in the base frame and where odometry
    comes from (``odometry_topic``, or tf ``odom_frame -> odom_child`` when it is None); the base frame's pose in
    ``odom_child`` (None when they are one frame) turns the odometry into the base frame's."""

    names: BagNames
    base_frame: str
    laser_frame: str
    mounting: Pose2D
    laser_upside_down: bool
    odometry_topic: str | None
    odom_child: str
    base_in_odom_child: Pose2D | None
    note: str = ""

    def scan(self, message: Any) -> LaserScanData:
        """The core scan of a ``sensor_msgs/LaserScan`` in the laser frame, as seen from above: a laser mounted
        upside down sweeps the other way round, so its angles change sign."""
        scan = scan_from_message(message)
        if not self.laser_upside_down:
            return scan
        return LaserScanData(-scan.angle_min, -scan.angle_increment, scan.range_min, scan.range_max, scan.ranges)


def frame_name(name: str) -> str:
    """A tf frame id without tf1's leading slash."""
    return name.lstrip("/")


def transform_pose(transform: Any) -> Pose2D:
    """The planar pose of a ``geometry_msgs/TransformStamped``."""
    t, q = transform.transform.translation, transform.transform.rotation
    return Pose2D(float(t.x), float(t.y), yaw_from_quaternion(q.x, q.y, q.z, q.w))


def _matrix(transform: Any) -> Matrix:
    """The 4x4 homogeneous matrix of a ``geometry_msgs/TransformStamped`` (its quaternion normalised)."""
    t, q = transform.transform.translation, transform.transform.rotation
    x, y, z, w = (float(v) for v in (q.x, q.y, q.z, q.w))
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if norm > 0.0:
        x, y, z, w = x / norm, y / norm, z / norm, w / norm
    matrix = np.eye(4)
    matrix[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    matrix[:3, 3] = [float(t.x), float(t.y), float(t.z)]
    return matrix


def planar(matrix: Matrix) -> Pose2D:
    """The planar pose of a 4x4 transform: its position and the heading of its x axis."""
    return Pose2D(float(matrix[0, 3]), float(matrix[1, 3]), math.atan2(matrix[1, 0], matrix[0, 0]))


def upside_down(matrix: Matrix) -> bool:
    """Whether a frame's z axis points down in its parent: a laser mounted so sweeps the other way round."""
    return bool(matrix[2, 2] < 0.0)


class FrameTree:
    """The first transform seen of every ``parent -> child`` edge: the fixed part of a robot's tf tree, in 3-D (a
    laser mounted upside down is a rotation about x)."""

    def __init__(self) -> None:
        self.parents: dict[str, tuple[str, Matrix]] = {}

    def add(self, message: Any) -> None:
        """Take the edges of a ``tf2_msgs/TFMessage`` not seen before."""
        for transform in message.transforms:
            child = frame_name(transform.child_frame_id)
            if child not in self.parents:
                self.parents[child] = (frame_name(transform.header.frame_id), _matrix(transform))

    def children(self, parent: str) -> list[str]:
        return [child for child, (p, _) in self.parents.items() if p == parent]

    def _ancestors(self, frame: str) -> dict[str, Matrix]:
        """``frame``'s transform in itself and in each frame above it."""
        chain = {frame: np.eye(4)}
        matrix, current = chain[frame], frame
        while current in self.parents:
            current, edge = self.parents[current]
            if current in chain:  # a loop in a malformed tree
                break
            matrix = edge @ matrix
            chain[current] = matrix
        return chain

    def relative(self, base: str, frame: str) -> Matrix | None:
        """``frame``'s transform in ``base`` through their nearest common frame, None when no edges link them."""
        above_frame, above_base = self._ancestors(frame), self._ancestors(base)
        common = next((f for f in above_frame if f in above_base), None)
        if common is None:
            return None
        return np.asarray(np.linalg.inv(above_base[common]) @ above_frame[common], dtype=np.float64)

    @property
    def frames(self) -> list[str]:
        return sorted({*self.parents, *(p for p, _ in self.parents.values())})


@dataclass
class _Found:
    laser_frame: str | None = None
    odom_child: str | None = None


def resolve_frames(bag: Path, names: BagNames) -> BagFrames:
    """The frames of ``bag`` read with ``names`` (see the module docstring); :class:`BagError` naming the topic or
    frame when the scans, the odometry or the laser's mounting cannot be found."""
    present = bag_topics(bag)
    listed = ", ".join(sorted(present)) or "none"
    if names.scan_topic not in present:
        raise BagError(f"bag {bag} has no {names.scan_topic} topic (topics: {listed}); --scan-topic names another")
    has_odom = names.odom_topic in present
    has_tf = bool({topics.TF, topics.TF_STATIC} & set(present))
    if not has_odom and topics.TF not in present:
        raise BagError(
            f"bag {bag} has no odometry: neither {names.odom_topic} (--odom-topic) nor {topics.TF} (topics: {listed})"
        )
    tree, found = FrameTree(), _Found()
    wanted = [topics.TF_STATIC, topics.TF, names.scan_topic, *([names.odom_topic] if has_odom else [])]
    for topic, _, msg in read_messages(bag, wanted):
        if topic in {topics.TF, topics.TF_STATIC}:
            tree.add(msg)
        elif topic == names.scan_topic:
            found.laser_frame = found.laser_frame or frame_name(msg.header.frame_id)
        else:
            found.odom_child = found.odom_child or frame_name(msg.child_frame_id)
        if found.laser_frame is not None and _linked(tree, names, found, has_odom) is not None:
            break
    if found.laser_frame is None:
        raise BagError(f"bag {bag}: no message on {names.scan_topic}")
    linked = _linked(tree, names, found, has_odom)
    if linked is not None:
        return _frames(tree, names, found.laser_frame, linked, has_odom=has_odom)
    moved = [found.odom_child] if has_odom else tree.children(names.odom_frame)
    base = names.base_frame or next((frame for frame in moved if frame is not None), None)
    if base is None:
        raise BagError(
            f"bag {bag}: tf never has a transform from the odometry frame '{names.odom_frame}' (frames in tf: "
            f"{', '.join(tree.frames) or 'none'}); --odom-frame names another"
        )
    if not has_tf:
        note = f"bag {bag} has no tf: the laser (frame '{found.laser_frame}') is taken at the origin of '{base}'"
        at_base = (base, base, np.eye(4))
        return _frames(tree, names, found.laser_frame, at_base, has_odom=has_odom, note=note)
    raise BagError(
        f"bag {bag}: tf never links the laser frame '{found.laser_frame}' (of {names.scan_topic}) to the base frame "
        f"'{base}' (frames in tf: {', '.join(tree.frames) or 'none'}); --base-frame names another"
    )


def _linked(tree: FrameTree, names: BagNames, found: _Found, has_odom: bool) -> tuple[str, str, Matrix] | None:
    """(odometry child frame, base frame, laser mounting in the base) once the transforms read so far link them."""
    if found.laser_frame is None:
        return None
    candidates = [found.odom_child] if has_odom else tree.children(names.odom_frame)
    for child in candidates:
        if child is None:
            continue
        base = names.base_frame or child
        mounting = tree.relative(base, found.laser_frame)
        if mounting is not None and tree.relative(child, base) is not None:
            return child, base, mounting
    return None


def _frames(
    tree: FrameTree, names: BagNames, laser: str, link: tuple[str, str, Matrix], *, has_odom: bool, note: str = ""
) -> BagFrames:
    """The frames found; ``link``: (odometry child frame, base frame, laser mounting in the base)."""
    child, base, mounting = link
    base_in_child = tree.relative(child, base) if base != child else None
    if not has_odom:
        source = f"odometry from tf {names.odom_frame} -> {child} (no {names.odom_topic} topic)"
        note = f"{note}; {source}" if note else source
    return BagFrames(
        names=names,
        base_frame=base,
        laser_frame=laser,
        mounting=planar(mounting),
        laser_upside_down=upside_down(mounting),
        odometry_topic=names.odom_topic if has_odom else None,
        odom_child=child,
        base_in_odom_child=None if base_in_child is None else planar(base_in_child),
        note=note,
    )
