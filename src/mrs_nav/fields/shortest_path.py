"""The true shortest path for a point between circles and boxes (tangent visibility graph + Dijkstra).

Among circles and convex polygons, a shortest path is made of straight segments tangent to the circles or
through box corners, and arcs along the circles' boundaries. A box corner is a circle of radius 0 here, so one
construction covers both. The graph holds:

- the start, the goal and the tangent points of every start/goal-to-circle tangent: from a point at distance
  ``d > r`` from centre ``c`` the tangent points are ``c + r (cos(phi +- a), sin(phi +- a))`` with ``phi`` the
  direction from ``c`` to the point and ``a = acos(r / d)``;
- the four bitangents of every pair of circles: lines ``n . x = k`` with ``|n| = 1``, ``n . c_1 - k = r_1`` and
  ``n . c_2 - k = s r_2`` (``s = +1`` outer, ``s = -1`` inner tangents), so with ``u`` the unit vector from
  ``c_1`` to ``c_2`` at distance ``D``: ``n = m u +- sqrt(1 - m^2) u_perp``, ``m = (s r_2 - r_1) / D``, touching
  at ``c_1 - r_1 n`` and ``c_2 - s r_2 n``;
- straight edges (length ``|p - q|``) between those points when the segment crosses no circle, and arc edges
  (length ``r |delta angle|``) between angularly consecutive tangent points of one circle when the arc lies
  outside every other circle (overlapping circles hide parts of each other's boundary).

Every segment and arc is checked against the whole obstacle set, boxes included (a segment along a box's side
grazes it, which the tolerance allows; one across a box is blocked).

Dijkstra on that graph gives the exact shortest length (up to the tolerance ``1e-9`` m on grazing contacts).
"""

from __future__ import annotations

import heapq
import itertools
import math
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError, NoPathFoundError
from mrs_nav.geometry import FloatArray
from mrs_nav.maps.admissible import obstacles_refusal
from mrs_nav.maps.obstacles import BoolArray, Obstacles
from mrs_nav.maps.occupancy_grid import IntArray

_TOL = 1e-9
_ARC_SAMPLES = 16


@dataclass(frozen=True)
class ShortestPath:
    """Length (m) of the shortest path and a polyline ``(N, 2)`` drawing it (arcs outlined from outside)."""

    length_m: float
    points: FloatArray


def _point_tangents(p: FloatArray, circle: FloatArray) -> list[FloatArray]:
    centre, r = circle[:2], circle[2]
    offset = p - centre
    d = math.hypot(*offset)
    if d <= r:
        return []
    if r == 0.0:
        return [centre]
    phi, a = math.atan2(offset[1], offset[0]), math.acos(r / d)
    return [centre + r * np.array([math.cos(phi + s * a), math.sin(phi + s * a)]) for s in (1.0, -1.0)]


def _bitangents(c1: FloatArray, c2: FloatArray) -> list[tuple[FloatArray, FloatArray]]:
    between = c2[:2] - c1[:2]
    dist = math.hypot(*between)
    if dist <= _TOL:
        return []
    u = between / dist
    u_perp = np.array([-u[1], u[0]])
    out = []
    # With a corner (radius 0) the inner and outer tangents coincide: one sign gives both lines.
    for s in (1.0, -1.0) if c1[2] > 0.0 and c2[2] > 0.0 else (1.0,):
        m = (s * c2[2] - c1[2]) / dist
        if abs(m) > 1.0:
            continue
        for side in (1.0, -1.0):
            n = m * u + side * math.sqrt(1.0 - m * m) * u_perp
            out.append((c1[:2] - c1[2] * n, c2[:2] - s * c2[2] * n))
    return out


def _arc_outline(circle: FloatArray, start_angle: float, sweep: float) -> FloatArray:
    """Corners of a polyline hugging an arc from outside (each of its edges touches the circle), ends excluded.

    With ``m`` pieces of angle ``delta = sweep / m`` the corners sit at angles ``start + (k + 1/2) delta`` and
    radius ``r / cos(delta / 2)``, so the drawn path is collision free and only slightly longer than the arc.
    """
    pieces = max(1, math.ceil(abs(sweep) / (math.pi / 16)))
    delta = sweep / pieces
    theta = start_angle + delta * (np.arange(pieces) + 0.5)
    radius = circle[2] / math.cos(delta / 2.0)
    return np.asarray(circle[:2] + radius * np.column_stack([np.cos(theta), np.sin(theta)]), dtype=np.float64)


def shortest_path(start: tuple[float, float], goal: tuple[float, float], obstacles: Obstacles) -> ShortestPath:
    """The shortest path from ``start`` to ``goal`` avoiding the circles and boxes of ``obstacles``.

    Raises :class:`InvalidInputError` when an endpoint is inside an obstacle, and :class:`NoPathFoundError` when
    the obstacles enclose an endpoint.
    """
    corners = obstacles.box_corners().reshape(-1, 2)
    obs = np.vstack([obstacles.circles, np.column_stack([corners, np.zeros(len(corners))])])
    a, b = np.asarray(start, dtype=np.float64), np.asarray(goal, dtype=np.float64)
    for name, p in (("start", a), ("goal", b)):
        why = obstacles_refusal(obstacles, p[0], p[1], tolerance_m=_TOL)
        if why:
            raise InvalidInputError(f"{name} ({p[0]}, {p[1]}) is {why}")
    graph = _TangentGraph(a, b, obs)
    xy = np.array(graph.points)
    # A bitangent may touch a circle only where it is tangent: tangent points inside another circle are hidden.
    visible = ~obstacles.contains(xy, -_TOL * 1e3)
    visible[:2] = True
    edges: list[list[tuple[int, float]]] = [[] for _ in graph.points]
    _straight_edges(edges, xy, np.array(graph.segments), visible, obstacles)
    arcs = _arc_edges(edges, xy, graph.on_circle, visible, obstacles)
    best, before = _dijkstra(edges)
    if not math.isfinite(best[1]):
        raise NoPathFoundError(f"no path from {tuple(start)} to {tuple(goal)} between the obstacles")

    chain = [1]
    while chain[-1] != 0:
        chain.append(int(before[chain[-1]]))
    chain.reverse()
    drawn = [xy[0]]
    for k1, k2 in itertools.pairwise(chain):
        if (k1, k2) in arcs:
            drawn.extend(_arc_outline(obs[arcs[(k1, k2)][0]], *arcs[(k1, k2)][1:]))
        drawn.append(xy[k2])
    return ShortestPath(float(best[1]), np.array(drawn))


class _TangentGraph:
    """The graph's nodes (start 0, goal 1, then tangent points, each on circle ``on_circle[k]``, -1 for the two
    ends) and the candidate straight segments between them (not yet checked for collisions)."""

    def __init__(self, start: FloatArray, goal: FloatArray, obs: FloatArray) -> None:
        self.obs = obs
        self.points: list[FloatArray] = [start, goal]
        self.on_circle: list[int] = [-1, -1]
        self.corner_node: dict[int, int] = {}  # a corner is one node, whichever tangent reaches it
        self.segments: list[tuple[int, int]] = [(0, 1)]
        for i, circle in enumerate(obs):
            for end in (0, 1):
                self.segments.extend((end, self.add(t, i)) for t in _point_tangents(self.points[end], circle))
            for j in range(i + 1, obs.shape[0]):
                for p, q in _bitangents(circle, obs[j]):
                    self.segments.append((self.add(p, i), self.add(q, j)))

    def add(self, p: FloatArray, circle: int) -> int:
        """The node of point ``p`` on ``circle`` (a corner's existing node when it has one)."""
        corner = self.obs[circle, 2] == 0.0
        if corner and circle in self.corner_node:
            return self.corner_node[circle]
        self.points.append(p)
        self.on_circle.append(circle)
        if corner:
            self.corner_node[circle] = len(self.points) - 1
        return len(self.points) - 1


def _straight_edges(
    edges: list[list[tuple[int, float]]], xy: FloatArray, pairs: IntArray, visible: BoolArray, obstacles: Obstacles
) -> None:
    """Add to ``edges`` the segments of ``pairs`` that cross no obstacle between visible ends."""
    free = obstacles.segments_free(xy[pairs[:, 0]], xy[pairs[:, 1]], clearance=-_TOL)
    for (p, q), ok in zip(pairs, free, strict=True):
        if ok and visible[p] and visible[q]:
            length = float(np.hypot(*(xy[p] - xy[q])))
            edges[p].append((q, length))
            edges[q].append((p, length))


def _arc_edges(
    edges: list[list[tuple[int, float]]], xy: FloatArray, on_circle: list[int], visible: BoolArray, obstacles: Obstacles
) -> dict[tuple[int, int], tuple[int, float, float]]:
    """Add to ``edges`` the arcs between angularly consecutive visible tangent points of each circle that stay
    outside every other obstacle; return them as ``(node, node) -> (circle, start angle, signed sweep)``."""
    arcs: dict[tuple[int, int], tuple[int, float, float]] = {}
    for i, circle in enumerate(obstacles.circles):
        members = [k for k, c in enumerate(on_circle) if c == i and visible[k]]
        if len(members) < 2:
            continue
        angles = np.arctan2(xy[members, 1] - circle[1], xy[members, 0] - circle[0])
        order = np.argsort(angles)
        for n_k in range(len(order)):
            k1, k2 = members[order[n_k]], members[order[(n_k + 1) % len(order)]]
            t1 = float(angles[order[n_k]])
            sweep = (float(angles[order[(n_k + 1) % len(order)]]) - t1) % (2.0 * math.pi)
            if k1 == k2 or sweep <= 0.0 or ((k1, k2) in arcs and abs(arcs[(k1, k2)][2]) <= sweep):
                continue
            theta = t1 + sweep * np.linspace(0.0, 1.0, _ARC_SAMPLES)[1:-1]
            arc = circle[:2] + circle[2] * np.column_stack([np.cos(theta), np.sin(theta)])
            if obstacles.contains(arc, -_TOL * 1e3).any():
                continue
            length = float(circle[2] * sweep)
            edges[k1].append((k2, length))
            edges[k2].append((k1, length))
            arcs[(k1, k2)] = (i, t1, sweep)
            arcs[(k2, k1)] = (i, t1 + sweep, -sweep)
    return arcs


def _dijkstra(edges: list[list[tuple[int, float]]]) -> tuple[FloatArray, IntArray]:
    """Least cost from node 0 to every node settled before node 1 (inf where not reached), and each one's
    predecessor (-1 for none)."""
    best = np.full(len(edges), np.inf)
    before = np.full(len(edges), -1)
    best[0] = 0.0
    queue = [(0.0, 0)]
    while queue:
        cost, node = heapq.heappop(queue)
        if node == 1:
            break
        if cost > best[node]:
            continue
        for nxt, length in edges[node]:
            if cost + length < best[nxt]:
                best[nxt] = cost + length
                before[nxt] = node
                heapq.heappush(queue, (cost + length, nxt))
    return best, before
