"""Planar obstacles for the potential field and the planners: circles and upright boxes.

Circles are rows ``(x, y, r)`` (centre and radius, metres); boxes are rows ``(cx, cy, yaw, hx, hy)`` (centre,
heading in radians and *half* sizes, metres). Everything is vectorised over arrays of query points.

Signed distance of a point ``p`` to the surface of an obstacle (negative inside):

- circle: ``d = |p - c| - r``
- box, with ``q = R(yaw)^T (p - c)`` the point in the box frame and ``e = |q| - h`` (per axis):
  ``d = |max(e, 0)|`` outside, ``d = max(e_x, e_y)`` (<= 0) inside.

The outward normal ``n`` (unit vector from the nearest surface point to ``p``) is what the repulsive field
pushes along; it is ``(p - c) / |p - c|`` for a circle and the rotated ``(q - clip(q, -h, h)) / d`` for a box.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray, cos_sin
from mrs_nav.limits import MAX_COORDINATE_M, MAX_SHAPES, MAX_SIZE_M
from mrs_nav.maps.world import World
from mrs_nav.textfiles import read_text

BoolArray = npt.NDArray[np.bool_]
# An obstacle list of MAX_SHAPES circles is a few tens of kilobytes of JSON.
_MAX_JSON_BYTES = 1 << 20


def _as_float(value: float) -> float:
    """``float(value)``, or inf for an integer beyond float range (rejected as non-finite like any other)."""
    try:
        return float(value)
    except OverflowError:
        return math.inf


def _excerpt(item: Any) -> str:
    """``repr(item)`` cut to one readable line."""
    text = repr(item)
    return text if len(text) <= 80 else text[:77] + "..."


def _frozen(array: npt.ArrayLike, columns: int) -> FloatArray:
    out = np.array(array, dtype=np.float64).reshape(-1, columns)
    out.setflags(write=False)
    return out


@dataclass(frozen=True)
class Obstacles:
    """A set of circles ``(N, 3)`` rows ``(x, y, r)`` and boxes ``(M, 5)`` rows ``(cx, cy, yaw, hx, hy)``.

    Build it with :meth:`from_circles`, :meth:`from_json` or :meth:`from_world`; the constructor checks
    shapes, finiteness and positive sizes. The arrays are read-only.
    """

    circles: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    boxes: FloatArray = field(default_factory=lambda: np.zeros((0, 5)))

    def __post_init__(self) -> None:
        circles = np.asarray(self.circles, dtype=np.float64)
        boxes = np.asarray(self.boxes, dtype=np.float64)
        if circles.ndim != 2 or circles.shape[1] != 3:
            raise InvalidInputError(f"circles must be rows (x, y, r), got an array of shape {circles.shape}")
        if boxes.ndim != 2 or boxes.shape[1] != 5:
            raise InvalidInputError(f"boxes must be rows (cx, cy, yaw, hx, hy), got an array of shape {boxes.shape}")
        for what, rows, sizes in (("circle", circles, circles[:, 2:]), ("box", boxes, boxes[:, 3:])):
            bad = np.flatnonzero(~np.isfinite(rows).all(axis=1))
            if bad.size:
                raise InvalidInputError(f"{what} {bad[0]} has a non-finite value: {rows[bad[0]].tolist()}")
            bad = np.flatnonzero((sizes <= 0.0).any(axis=1) | (sizes > MAX_SIZE_M).any(axis=1))
            if bad.size:
                raise InvalidInputError(
                    f"{what} {bad[0]} must have a positive size of at most {MAX_SIZE_M:g} m, "
                    f"got {rows[bad[0]].tolist()}"
                )
            bad = np.flatnonzero((np.abs(rows[:, :2]) > MAX_COORDINATE_M).any(axis=1))
            if bad.size:
                raise InvalidInputError(
                    f"{what} {bad[0]} lies more than {MAX_COORDINATE_M:g} m from the origin: {rows[bad[0]].tolist()}"
                )
        if circles.shape[0] + boxes.shape[0] > MAX_SHAPES:
            raise InvalidInputError(f"{circles.shape[0] + boxes.shape[0]} obstacles, above the limit of {MAX_SHAPES}")
        object.__setattr__(self, "circles", _frozen(circles, 3))
        object.__setattr__(self, "boxes", _frozen(boxes, 5))

    # ---- construction -------------------------------------------------------------------------------------

    @classmethod
    def from_circles(cls, circles: Sequence[Sequence[float]] | npt.ArrayLike, what: str = "circles") -> Obstacles:
        """Obstacles from a non-empty list of ``(x, y, r)`` circles; ``what`` names the input in errors."""
        try:
            rows = np.array(circles, dtype=np.float64)
        except (TypeError, ValueError):
            raise InvalidInputError(f"{what}: expected a list of [x, y, r] circles") from None
        if rows.size == 0:
            raise InvalidInputError(f"{what}: the obstacle list is empty")
        if rows.ndim != 2 or rows.shape[1] != 3:
            raise InvalidInputError(f"{what}: expected a list of [x, y, r] circles, got shape {rows.shape}")
        try:
            return cls(circles=rows)
        except InvalidInputError as err:
            raise InvalidInputError(f"{what}: {err}") from None

    @classmethod
    def from_json(cls, text: str, what: str = "circles") -> Obstacles:
        """Obstacles from JSON: a list of ``[x, y, r]`` or ``{"x": .., "y": .., "r": ..}`` circles."""
        try:
            data: Any = json.loads(text)
        except json.JSONDecodeError as err:
            raise InvalidInputError(
                f"{what}: not valid JSON ({err.msg} at line {err.lineno} col {err.colno})"
            ) from None
        except ValueError as err:  # an integer of thousands of digits
            raise InvalidInputError(f"{what}: not valid JSON ({err})") from None
        except RecursionError:
            raise InvalidInputError(f"{what}: JSON nested too deeply (a list of [x, y, r] lists is expected)") from None
        if not isinstance(data, list):
            raise InvalidInputError(f"{what}: expected a JSON list of circles, got {type(data).__name__}")
        rows: list[list[float]] = []
        for i, item in enumerate(data):
            values = [item.get(k) for k in ("x", "y", "r")] if isinstance(item, dict) else item
            if (
                not isinstance(values, list)
                or len(values) != 3
                or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)
            ):
                raise InvalidInputError(
                    f"{what}: circle {i} must be [x, y, r] or {{x, y, r}} numbers, got {_excerpt(item)}"
                )
            # Integers beyond float range are as out of range as any other huge value.
            rows.append([_as_float(v) for v in values])
        return cls.from_circles(rows, what)

    @classmethod
    def from_json_file(cls, path: str | Path) -> Obstacles:
        """:meth:`from_json` on the text of a file."""
        return cls.from_json(read_text(Path(path), _MAX_JSON_BYTES, "obstacles"), str(path))

    @classmethod
    def from_world(cls, world: World) -> Obstacles:
        """The cylinders of a world as circles and its boxes (walls included) as boxes."""
        circles = [(c.x, c.y, c.radius) for c in world.cylinders]
        boxes = [(b.x, b.y, b.yaw, b.size_x / 2.0, b.size_y / 2.0) for b in world.boxes]
        return cls(circles=np.array(circles).reshape(-1, 3), boxes=np.array(boxes).reshape(-1, 5))

    def inflated(self, margin: float) -> Obstacles:
        """Every obstacle grown by ``margin`` metres (e.g. the robot radius), so a point stands for the robot."""
        if not math.isfinite(margin) or margin < 0.0:
            raise InvalidInputError(f"inflation margin must be a finite number >= 0, got {margin}")
        circles = self.circles.copy()
        circles[:, 2] += margin
        boxes = self.boxes.copy()
        boxes[:, 3:] += margin
        return Obstacles(circles=circles, boxes=boxes)

    @property
    def count(self) -> int:
        return int(self.circles.shape[0] + self.boxes.shape[0])

    def bounds(self) -> tuple[float, float, float, float] | None:
        """Axis-aligned (xmin, ymin, xmax, ymax) of all footprints, ``None`` when there is no obstacle."""
        if self.count == 0:
            return None
        c = self.circles
        lo = [c[:, :2] - c[:, 2:]]
        hi = [c[:, :2] + c[:, 2:]]
        if self.boxes.shape[0]:
            corners = self.box_corners().reshape(-1, 2)
            lo.append(corners)
            hi.append(corners)
        low, high = np.vstack(lo).min(axis=0), np.vstack(hi).max(axis=0)
        return (float(low[0]), float(low[1]), float(high[0]), float(high[1]))

    def box_corners(self) -> FloatArray:
        """The footprint corners of every box, counter-clockwise, shape ``(M, 4, 2)``."""
        b = self.boxes
        signs = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
        local = signs[None, :, :] * b[:, None, 3:5]
        c, s = (v[:, None] for v in cos_sin(b[:, 2]))
        x = b[:, None, 0] + c * local[..., 0] - s * local[..., 1]
        y = b[:, None, 1] + s * local[..., 0] + c * local[..., 1]
        return np.stack([x, y], axis=-1)

    # ---- distances ----------------------------------------------------------------------------------------

    def surface(self, points: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Signed distance ``(P, K)`` from each point to each obstacle and the outward unit normals ``(P, K, 2)``.

        Obstacles are ordered circles first, then boxes. Inside a box the normal is zero (the field is zero
        there anyway); at a circle's centre it is zero as well.
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        c = self.circles
        rel = p[:, None, :] - c[None, :, :2]
        norm = np.hypot(rel[..., 0], rel[..., 1])
        dist_c = norm - c[None, :, 2]
        normal_c = np.divide(rel, norm[..., None], out=np.zeros_like(rel), where=norm[..., None] > 0.0)
        b = self.boxes
        cos, sin = cos_sin(b[:, 2])
        dx, dy = p[:, None, 0] - b[None, :, 0], p[:, None, 1] - b[None, :, 1]
        q = np.stack([cos * dx + sin * dy, -sin * dx + cos * dy], axis=-1)
        half = b[None, :, 3:5]
        excess = np.abs(q) - half
        outside = np.hypot(*np.maximum(excess, 0.0).transpose(2, 0, 1))
        inside = np.minimum(excess.max(axis=-1), 0.0)
        dist_b = np.where(outside > 0.0, outside, inside)
        local = q - np.clip(q, -half, half)
        local = np.divide(local, outside[..., None], out=np.zeros_like(local), where=outside[..., None] > 0.0)
        normal_b = np.stack([cos * local[..., 0] - sin * local[..., 1], sin * local[..., 0] + cos * local[..., 1]], -1)
        return np.concatenate([dist_c, dist_b], axis=1), np.concatenate([normal_c, normal_b], axis=1)

    def signed_distance(self, points: npt.ArrayLike) -> FloatArray:
        """Distance ``(P,)`` from each point to the nearest obstacle surface, negative inside; ``inf`` if none."""
        dist, _ = self.surface(points)
        if dist.shape[1] == 0:
            return np.full(dist.shape[0], np.inf)
        return np.asarray(dist.min(axis=1), dtype=np.float64)

    def contains(self, points: npt.ArrayLike, clearance: float = 0.0) -> BoolArray:
        """Whether each point lies inside an obstacle grown by ``clearance`` (the surface counts as inside)."""
        return np.asarray(self.signed_distance(points) <= clearance)

    def segments_free(self, starts: npt.ArrayLike, ends: npt.ArrayLike, clearance: float = 0.0) -> BoolArray:
        """Whether each segment ``starts[k] -> ends[k]`` stays more than ``clearance`` away from every obstacle.

        Exact for circles (distance from the centre to the segment ``> r + clearance``); for boxes the box is
        grown by ``clearance`` on each side (a slightly conservative square-cornered growth) and the segment
        clipped against it in the box frame (Liang-Barsky). A negative ``clearance`` tolerates grazing contact,
        which the tangent constructions of the shortest path need.
        """
        a = np.asarray(starts, dtype=np.float64).reshape(-1, 2)
        b = np.asarray(ends, dtype=np.float64).reshape(-1, 2)
        step = b - a
        c = self.circles
        to_centre = c[None, :, :2] - a[:, None, :]
        length2 = np.einsum("ij,ij->i", step, step)[:, None]
        along = np.einsum("ikj,ij->ik", to_centre, step)
        t = np.clip(np.divide(along, length2, out=np.zeros_like(along), where=length2 > 0.0), 0.0, 1.0)
        gap = to_centre - t[..., None] * step[:, None, :]
        hit = np.hypot(gap[..., 0], gap[..., 1]) <= c[None, :, 2] + clearance
        free: BoolArray = ~hit.any(axis=1)
        if self.boxes.shape[0]:
            free &= ~self._segments_hit_boxes(a, step, clearance).any(axis=1)
        return free

    def _segments_hit_boxes(self, a: FloatArray, step: FloatArray, clearance: float) -> BoolArray:
        bx = self.boxes
        cos, sin = cos_sin(bx[:, 2])
        dx, dy = a[:, None, 0] - bx[None, :, 0], a[:, None, 1] - bx[None, :, 1]
        q0 = np.stack([cos * dx + sin * dy, -sin * dx + cos * dy], axis=-1)
        d = np.stack(
            [cos * step[:, None, 0] + sin * step[:, None, 1], -sin * step[:, None, 0] + cos * step[:, None, 1]], -1
        )
        half = bx[None, :, 3:5] + clearance
        with np.errstate(invalid="ignore", divide="ignore"):
            t1, t2 = (-half - q0) / d, (half - q0) / d
        parallel = d == 0.0
        inside_slab = np.abs(q0) <= half
        t_lo = np.where(parallel, np.where(inside_slab, -np.inf, np.inf), np.minimum(t1, t2))
        t_hi = np.where(parallel, np.where(inside_slab, np.inf, -np.inf), np.maximum(t1, t2))
        enter = np.maximum(t_lo.max(axis=-1), 0.0)
        leave = np.minimum(t_hi.min(axis=-1), 1.0)
        return np.asarray(enter <= leave)

    def path_free(self, path: npt.ArrayLike, clearance: float = 0.0) -> bool:
        """Whether every segment of a polyline ``(N, >=2)`` is free (see :meth:`segments_free`)."""
        pts = np.asarray(path, dtype=np.float64)[:, :2]
        if pts.shape[0] == 1:
            return bool(not self.contains(pts, clearance)[0])
        return bool(self.segments_free(pts[:-1], pts[1:], clearance).all())
