"""The tree grown by RRT and RRT*: nodes with poses, parents and costs, a spatial index, and path extraction.

Nodes live in growing numpy arrays (position, yaw, cost = arc length from the root, parent). Every edge is the
arc from the parent's pose to the child's position, and a child's yaw is that arc's end yaw, so a path through
the tree is a chain of tangent-continuous arcs.

Nearest and near queries go through a :class:`scipy.spatial.cKDTree` built over the first nodes plus a linear
(vectorised) scan of the few nodes added since; the kd-tree is rebuilt when that tail grows past an eighth of
the tree (at least 64 nodes), which keeps both the rebuild cost per insertion and the tail scan small.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import IntArray
from mrs_nav.planning import PlanResult
from mrs_nav.trees import arcs

_MIN_TAIL = 64


class ArcTree:
    """A tree of poses rooted at the start pose; see the module docstring."""

    def __init__(self, root: Pose2D, capacity: int = 1024) -> None:
        capacity = max(16, capacity)
        self.position: FloatArray = np.zeros((capacity, 2))
        self.yaw: FloatArray = np.zeros(capacity)
        self.cost: FloatArray = np.zeros(capacity)
        self.parent: IntArray = np.full(capacity, -1, dtype=np.intp)
        self.children: list[list[int]] = []
        self.size = 0
        self._index: cKDTree | None = None
        self._indexed = 0
        self.add(root.position, root.yaw, -1, 0.0)

    def __len__(self) -> int:
        return self.size

    def add(self, position: npt.ArrayLike, yaw: float, parent: int, cost: float) -> int:
        """Append a node and return its id."""
        if self.size == len(self.yaw):
            grow = len(self.yaw)
            self.position = np.concatenate([self.position, np.zeros((grow, 2))])
            self.yaw = np.concatenate([self.yaw, np.zeros(grow)])
            self.cost = np.concatenate([self.cost, np.zeros(grow)])
            self.parent = np.concatenate([self.parent, np.full(grow, -1, dtype=np.intp)])
        i = self.size
        self.position[i] = position
        self.yaw[i] = yaw
        self.cost[i] = cost
        self.parent[i] = parent
        self.children.append([])
        if parent >= 0:
            self.children[parent].append(i)
        self.size += 1
        if self.size - self._indexed > max(_MIN_TAIL, self.size // 8):
            self._index = cKDTree(self.position[: self.size])
            self._indexed = self.size
        return i

    def reparent(self, node: int, new_parent: int) -> None:
        """Move ``node`` (with its subtree) under ``new_parent``; yaws and costs are the caller's to update."""
        self.children[int(self.parent[node])].remove(node)
        self.parent[node] = new_parent
        self.children[new_parent].append(node)

    def nearest(self, point: FloatArray, k: int = 1) -> tuple[IntArray, FloatArray]:
        """Ids and distances of the ``k`` nodes nearest to ``point`` (fewer when the tree is smaller), nearest first."""
        ids = []
        dists = []
        if self._index is not None:
            kk = min(k, self._indexed)
            d, i = self._index.query(point, k=kk)
            ids.append(np.atleast_1d(i).astype(np.intp))
            dists.append(np.atleast_1d(d))
        tail = np.arange(self._indexed, self.size)
        if len(tail):
            dt = self.position[tail] - point
            ids.append(tail)
            dists.append(np.hypot(dt[:, 0], dt[:, 1]))
        all_ids = np.concatenate(ids)
        all_d = np.concatenate(dists)
        order = np.argsort(all_d, kind="stable")[:k]
        return all_ids[order], all_d[order]

    def within(self, point: FloatArray, radius: float) -> IntArray:
        """Ids of the nodes within ``radius`` metres of ``point`` (any order)."""
        parts = []
        if self._index is not None:
            parts.append(np.asarray(self._index.query_ball_point(point, radius), dtype=np.intp))
        if self.size > self._indexed:
            dt = self.position[self._indexed : self.size] - point
            close = np.flatnonzero(dt[:, 0] ** 2 + dt[:, 1] ** 2 <= radius * radius)
            parts.append(close + self._indexed)
        return np.concatenate(parts) if parts else np.zeros(0, dtype=np.intp)

    def subtree(self, node: int) -> list[list[int]]:
        """The descendants of ``node`` level by level (``node`` itself excluded)."""
        levels = []
        frontier = self.children[node]
        while frontier:
            levels.append(frontier)
            frontier = [c for n in frontier for c in self.children[n]]
        return levels

    def branch(self, node: int) -> IntArray:
        """Node ids from the root to ``node``."""
        chain = [node]
        while self.parent[chain[-1]] >= 0:
            chain.append(int(self.parent[chain[-1]]))
        return np.array(chain[::-1], dtype=np.intp)

    def edges(self) -> arcs.Arcs:
        """The arcs of every edge (child ids 1..size-1, in id order)."""
        child = np.arange(1, self.size)
        par = self.parent[child]
        return arcs.connect(self.position[par], self.yaw[par], self.position[child])

    def path_poses(self, chain: IntArray, step: float, tail: FloatArray | None = None) -> FloatArray:
        """Poses ``(M, 3)`` along the arcs of ``chain`` (root first) every ``step`` metres or less.

        ``tail`` optionally appends one more target position reached by an arc from the chain's last node.
        """
        starts = chain[:-1]
        targets = self.position[chain[1:]]
        start_pos = self.position[starts]
        start_yaw = self.yaw[starts]
        if tail is not None:
            last = chain[-1]
            start_pos = np.vstack([start_pos, self.position[last]])
            start_yaw = np.append(start_yaw, self.yaw[last])
            targets = np.vstack([targets, tail])
        if len(targets) == 0:
            root = chain[0]
            return np.array([[*self.position[root], self.yaw[root]]])
        poses, first = arcs.sample(arcs.connect(start_pos, start_yaw, targets), step)
        # Each arc's first pose repeats the previous arc's last one: keep it once.
        keep = np.ones(len(poses), dtype=bool)
        keep[first[1:-1]] = False
        out: FloatArray = poses[keep]
        return out


@dataclass(frozen=True, eq=False)
class Search:
    """A planner's result with the tree it grew and the improvements it made on the way.

    ``history`` holds ``(iteration, seconds since start, path length in metres)`` each time the best path
    improved (one entry for RRT, which stops at its first path).
    """

    result: PlanResult
    tree: ArcTree
    history: tuple[tuple[int, float, float], ...]
