"""Worlds: static boxes and cylinders read from Gazebo SDF ``.world`` files.

A world is what every part of mrs_nav agrees on about the environment: the simulator builds its ODE geoms
from it, the potential field turns it into repulsive circles, and the map rasteriser draws it. Only what the
simulator can honour is accepted: static models whose collisions are boxes or cylinders standing upright
(roll = pitch = 0). Poses are composed model * link * collision, as SDF defines them. Anything else (meshes,
spheres, moving models, tilted shapes, unresolvable includes) is rejected with :class:`WorldFileError` naming
the file and the element, rather than silently simulating a different world.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrs_nav.errors import WorldFileError
from mrs_nav.geometry import FloatArray
from mrs_nav.limits import MAX_COORDINATE_M, MAX_SHAPES, MAX_SIZE_M
from mrs_nav.robot import BURGER_HEIGHT
from mrs_nav.textfiles import DESCRIPTION_LIMIT, read_text

# Includes that carry no obstacle: the ground is part of every simulation and light does not collide.
_HARMLESS_INCLUDES = frozenset({"model://ground_plane", "model://sun"})
# World children that do not describe geometry.
_IGNORED_WORLD_CHILDREN = frozenset(
    {
        "light",
        "physics",
        "scene",
        "gui",
        "gravity",
        "magnetic_field",
        "atmosphere",
        "spherical_coordinates",
        "state",
        "wind",
        "audio",
        "plugin",
        "population",
    }
)
_TILT_TOLERANCE = 1e-6
# An SDF double as Gazebo's parser reads it; Python's float() would also take "0_2", "nan", "infinity", "١".
_SDF_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


@dataclass(frozen=True)
class Box:
    """An upright box: centre (x, y, z) in metres, heading ``yaw`` in radians, full sizes in metres."""

    name: str
    x: float
    y: float
    z: float
    yaw: float
    size_x: float
    size_y: float
    size_z: float

    def corners(self) -> FloatArray:
        """The four footprint corners, counter-clockwise, shape (4, 2)."""
        hx, hy = self.size_x / 2.0, self.size_y / 2.0
        local = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        corners: FloatArray = local @ np.array([[c, s], [-s, c]]) + np.array([self.x, self.y])
        return corners


@dataclass(frozen=True)
class Cylinder:
    """An upright cylinder: axis at (x, y), centre height z, radius and length in metres."""

    name: str
    x: float
    y: float
    z: float
    radius: float
    length: float


@dataclass(frozen=True)
class World:
    """The static obstacles of a world file."""

    name: str
    boxes: tuple[Box, ...]
    cylinders: tuple[Cylinder, ...]
    source: str = ""

    def bounds(self, margin: float = 0.0) -> tuple[float, float, float, float]:
        """Axis-aligned (xmin, ymin, xmax, ymax) of every obstacle footprint, grown by ``margin``."""
        points = [b.corners() for b in self.boxes]
        points += [
            np.array([[c.x - c.radius, c.y - c.radius], [c.x + c.radius, c.y + c.radius]]) for c in self.cylinders
        ]
        if not points:
            return (-margin, -margin, margin, margin)
        allp = np.vstack(points)
        lo, hi = allp.min(axis=0) - margin, allp.max(axis=0) + margin
        return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


@dataclass(frozen=True)
class _Pose3:
    """x, y, z and yaw of an SDF pose whose roll and pitch are zero."""

    x: float
    y: float
    z: float
    yaw: float

    def compose(self, other: _Pose3) -> _Pose3:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return _Pose3(
            self.x + c * other.x - s * other.y,
            self.y + s * other.x + c * other.y,
            self.z + other.z,
            self.yaw + other.yaw,
        )


_IDENTITY = _Pose3(0.0, 0.0, 0.0, 0.0)


class _Reader:
    """Walks one parsed SDF tree; ``where`` names the file in every error."""

    def __init__(self, where: str) -> None:
        self.where = where

    def fail(self, element: str, why: str) -> WorldFileError:
        return WorldFileError(f"{self.where}: <{element}>: {why}")

    def floats(self, text: str | None, count: int, element: str) -> list[float]:
        parts = (text or "").split()
        if not all(_SDF_NUMBER.fullmatch(p) for p in parts):
            raise self.fail(element, f"expected {count} numbers, got {text!r}")
        values = [float(p) for p in parts]
        if len(values) != count or not all(math.isfinite(v) for v in values):
            raise self.fail(element, f"expected {count} finite numbers, got {text!r}")
        return values

    def pose(self, parent: ET.Element, path: str) -> _Pose3:
        node = parent.find("pose")
        if node is None:
            return _IDENTITY
        if node.get("relative_to"):
            raise self.fail(f"{path}/pose", "relative_to frames are not supported")
        x, y, z, roll, pitch, yaw = self.floats(node.text, 6, f"{path}/pose")
        if abs(roll) > _TILT_TOLERANCE or abs(pitch) > _TILT_TOLERANCE:
            raise self.fail(f"{path}/pose", "only upright shapes (roll = pitch = 0) can be simulated")
        return _Pose3(x, y, z, yaw)

    def positive(self, values: list[float], element: str) -> list[float]:
        if any(v <= 0.0 or v > MAX_SIZE_M for v in values):
            raise self.fail(element, f"sizes must be positive and at most {MAX_SIZE_M:g} m, got {values}")
        return values

    def placed(self, shape: Box | Cylinder, pose: _Pose3, height: float, path: str) -> Box | Cylinder:
        """``shape`` when it lies within the stated extent and stands in the robot's way (ground to its top)."""
        if max(abs(pose.x), abs(pose.y), abs(pose.z)) > MAX_COORDINATE_M:
            raise self.fail(
                f"{path}/pose",
                f"position ({pose.x:g}, {pose.y:g}, {pose.z:g}) is more than {MAX_COORDINATE_M:g} m from the origin",
            )
        bottom, top = pose.z - height / 2.0, pose.z + height / 2.0
        if bottom >= BURGER_HEIGHT or top <= 0.0:
            raise self.fail(
                path,
                f"spans z = {bottom:g} .. {top:g} m, which misses the robot (0 .. {BURGER_HEIGHT} m): the simulator "
                "only models obstacles that stand in the robot's way; remove it or move it down to the ground",
            )
        return shape

    def plane(self, shape: ET.Element, gpath: str) -> None:
        """Accept a ground plane (normal straight up, SDF's default); refuse a tilted or vertical one.

        Any other plane would be a wall or a ramp that the simulator and the maps would silently lack.
        """
        normal = shape.findtext("normal")
        if normal is None:
            return
        nx, ny, nz = self.floats(normal, 3, f"{gpath}/normal")
        if nz <= 0.0 or math.hypot(nx, ny) > _TILT_TOLERANCE * nz:
            raise self.fail(f"{gpath}/normal", f"only a ground plane (normal 0 0 1) is supported, got {normal!r}")

    def collision(self, node: ET.Element, pose: _Pose3, path: str) -> Box | Cylinder | None:
        geometry = node.find("geometry")
        if geometry is None:
            raise self.fail(path, "collision without <geometry>")
        shapes = list(geometry)
        if len(shapes) != 1:
            raise self.fail(f"{path}/geometry", "expected exactly one shape")
        shape = shapes[0]
        gpath = f"{path}/geometry/{shape.tag}"
        if shape.tag == "box":
            sx, sy, sz = self.positive(self.floats(shape.findtext("size"), 3, f"{gpath}/size"), gpath)
            return self.placed(Box(path, pose.x, pose.y, pose.z, pose.yaw, sx, sy, sz), pose, sz, path)
        if shape.tag == "cylinder":
            (radius,) = self.positive(self.floats(shape.findtext("radius"), 1, f"{gpath}/radius"), gpath)
            (length,) = self.positive(self.floats(shape.findtext("length"), 1, f"{gpath}/length"), gpath)
            return self.placed(Cylinder(path, pose.x, pose.y, pose.z, radius, length), pose, length, path)
        if shape.tag == "plane":
            self.plane(shape, gpath)
            return None  # a ground plane: every simulation has one already
        raise self.fail(gpath, "unsupported geometry (only box and cylinder are simulated)")

    def model(self, node: ET.Element, boxes: list[Box], cylinders: list[Cylinder]) -> None:
        name = node.get("name") or "?"
        path = f"model[{name}]"
        if node.find("model") is not None:
            raise self.fail(f"{path}/model", "nested models are not supported")
        if node.findtext("static", "false").strip().lower() not in ("1", "true"):
            raise self.fail(f"{path}/static", "only static models can be simulated as obstacles")
        model_pose = self.pose(node, path)
        for link in node.findall("link"):
            lpath = f"{path}/link[{link.get('name') or '?'}]"
            link_pose = model_pose.compose(self.pose(link, lpath))
            for col in link.findall("collision"):
                cpath = f"{lpath}/collision[{col.get('name') or '?'}]"
                shape = self.collision(col, link_pose.compose(self.pose(col, cpath)), cpath)
                if isinstance(shape, Box):
                    boxes.append(shape)
                elif isinstance(shape, Cylinder):
                    cylinders.append(shape)
                if len(boxes) + len(cylinders) > MAX_SHAPES:
                    raise self.fail(cpath, f"more than {MAX_SHAPES} boxes and cylinders in one world")

    def world(self, root: ET.Element) -> World:
        if root.tag != "sdf":
            raise self.fail(root.tag, "root element must be <sdf>")
        worlds = root.findall("world")
        if len(worlds) != 1:
            raise self.fail("sdf", f"expected exactly one <world>, found {len(worlds)}")
        node = worlds[0]
        boxes: list[Box] = []
        cylinders: list[Cylinder] = []
        for child in node:
            if child.tag == "model":
                self.model(child, boxes, cylinders)
            elif child.tag == "include":
                uri = (child.findtext("uri") or "").strip()
                if uri not in _HARMLESS_INCLUDES:
                    raise self.fail(f"include[{uri}]", "included models cannot be resolved; inline them")
            elif child.tag not in _IGNORED_WORLD_CHILDREN:
                raise self.fail(child.tag, "unsupported world element")
        return World(node.get("name") or "world", tuple(boxes), tuple(cylinders), self.where)


def parse_world(text: str, where: str = "<string>") -> World:
    """Parse SDF text; ``where`` names the source in errors."""
    try:
        root = ET.fromstring(text)
    except (ET.ParseError, RecursionError) as err:
        raise WorldFileError(f"{where}: malformed XML: {err}") from err
    return _Reader(where).world(root)


def load_world(path: str | Path) -> World:
    """Load a Gazebo SDF ``.world`` file."""
    path = Path(path)
    return parse_world(read_text(path, DESCRIPTION_LIMIT, "world file", WorldFileError), str(path))
