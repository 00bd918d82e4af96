"""The tree grown by RRT and RRT*: nodes with poses, parents and costs, nearest-node queries and path extraction.

Nodes live in growing numpy arrays (position, yaw, cost = arc length from the root, parent). Every edge is the
arc from the parent's pose to the child's position, and a child's yaw is that arc's end yaw, so a path through
the tree is a chain of tangent-continuous arcs.

Nearest and near queries are one compiled linear scan over the nodes (:mod:`mrs_nav.trees.kernels`): at the
sizes a search reaches (thousands of nodes) a scan costs a few microseconds, less than one call into a kd-tree
and without the rebuilds a growing tree needs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mrs_nav.errors import NoPathFoundError
from mrs_nav.geometry import FloatArray, Pose2D
from mrs_nav.maps.occupancy_grid import IntArray
from mrs_nav.planning import PlanResult
from mrs_nav.trees import arcs, kernels


class ArcTree:
    """A tree of poses rooted at the start pose; see the module docstring."""

    def __init__(self, root: Pose2D, capacity: int = 1024) -> None:
        capacity = max(16, capacity)
        self.position: FloatArray = np.zeros((capacity, 2))
        self.yaw: FloatArray = np.zeros(capacity)
        self.cost: FloatArray = np.zeros(capacity)
        self.parent: IntArray = np.full(capacity, -1, dtype=np.intp)
        # Each node's children as a linked list (first child, next sibling; -1 ends it): arrays the compiled
        # rewire walks and edits, where lists of lists would stay in Python.
        self.first_child: IntArray = np.full(capacity, -1, dtype=np.intp)
        self.next_sibling: IntArray = np.full(capacity, -1, dtype=np.intp)
        self.size = 0
        self.add(root.position, root.yaw, -1, 0.0)

    def __len__(self) -> int:
        return self.size

    @property
    def arrays(self) -> kernels.TreeArrays:
        """The node arrays as the compiled kernels take them (the arrays themselves, not copies)."""
        return self.position, self.yaw, self.cost, self.parent, self.first_child, self.next_sibling

    def reserve(self, count: int = 1) -> None:
        """Make room for ``count`` more nodes (doubling the arrays, or more, when they are too small)."""
        if self.size + count <= len(self.yaw):
            return
        grow = max(len(self.yaw), self.size + count - len(self.yaw))
        self.position = np.concatenate([self.position, np.zeros((grow, 2))])
        self.yaw = np.concatenate([self.yaw, np.zeros(grow)])
        self.cost = np.concatenate([self.cost, np.zeros(grow)])
        self.parent = np.concatenate([self.parent, np.full(grow, -1, dtype=np.intp)])
        self.first_child = np.concatenate([self.first_child, np.full(grow, -1, dtype=np.intp)])
        self.next_sibling = np.concatenate([self.next_sibling, np.full(grow, -1, dtype=np.intp)])

    def add(self, position: npt.ArrayLike, yaw: float, parent: int, cost: float) -> int:
        """Append a node and return its id."""
        self.reserve()
        i = self.size
        self.position[i] = position
        self.yaw[i] = yaw
        self.cost[i] = cost
        if parent >= 0:
            kernels.link(self.arrays, i, parent)
        self.size += 1
        return i

    def add_chain(self, way: FloatArray, parent: int = 0) -> range:
        """Append the chain of arcs ``way`` (rows ``(x, y, end yaw, length)``) below ``parent``; the new ids."""
        self.reserve(len(way))
        first = self.size
        self.size = kernels.add_chain(self.arrays, first, parent, np.ascontiguousarray(way))
        return range(first, self.size)

    def nearest(self, point: FloatArray, k: int = 1) -> tuple[IntArray, FloatArray]:
        """Ids and distances of the ``k`` nodes nearest to ``point`` (fewer when the tree is smaller), nearest first."""
        return kernels.nearest_k(self.position, self.size, float(point[0]), float(point[1]), k)

    def within(self, point: FloatArray, radius: float) -> IntArray:
        """Ids of the nodes within ``radius`` metres of ``point`` (in id order)."""
        return kernels.within_radius(self.position, self.size, float(point[0]), float(point[1]), radius)

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
        return kernels.chain_poses(start_pos, start_yaw, np.ascontiguousarray(targets, dtype=np.float64), step)


@dataclass(frozen=True, eq=False)
class Search:
    """A tree planner's result with the tree it grew and the improvements it made on the way.

    ``history`` holds ``(iteration, seconds since start, path length in metres)`` each time the best path
    improved (one entry for RRT, which stops at its first path).
    """

    result: PlanResult
    tree: ArcTree
    history: tuple[tuple[int, float, float], ...]


class NoPathInTreeError(NoPathFoundError):
    """A tree planner used its budget without reaching the goal; ``tree`` is what it grew (for drawing)."""

    def __init__(self, reason: str, tree: ArcTree, *, time_s: float, iterations: int) -> None:
        super().__init__(reason, time_s=time_s, iterations=iterations, nodes=len(tree))
        self.tree = tree


def budget_used_up(tree: ArcTree, *, used_iterations: bool, time_s: float, iterations: int) -> NoPathInTreeError:
    """The error of a tree search that found no path within its iteration (or else time) budget."""
    reason = "iteration budget used up" if used_iterations else "time budget used up"
    return NoPathInTreeError(f"no path found: {reason}", tree, time_s=time_s, iterations=iterations)
