"""Compiled steps of the corridor sampler (:mod:`mrs_nav.trees.guide`): the goal distance under one point and one
guided target from pre-drawn random numbers, so that a guided sample is one compiled call instead of a dozen numpy
calls on eight elements (issue 42: that glue was most of a first path's time after the route itself).

Grids enter as :func:`mrs_nav.trees.kernels.grid_args` tuples; positional arguments only (explicit signatures).
"""

# ruff: noqa: PLR0917

from __future__ import annotations

import numba
import numpy as np
from numba import types as nt

from mrs_nav.geometry import FloatArray
from mrs_nav.trees.kernels import GridArgs, _at, _cell

_F = nt.float64
_I = nt.intp
_F1 = nt.Array(_F, 1, "C")
_F2 = nt.Array(_F, 2, "C")
_B2 = nt.Array(nt.boolean, 2, "C")
_GRID = nt.Tuple((_B2, _B2, _F, _F, _F, _F, _F))  # type: ignore[no-untyped-call]
_XY = nt.UniTuple(_F, 2)  # type: ignore[no-untyped-call]


@numba.njit(_F(_F, _F, _F2, _I, _GRID), cache=True)
def field_at(x: float, y: float, distance: FloatArray, factor: int, grid: GridArgs) -> float:
    """The coarse field ``distance`` (cells of ``factor`` grid cells) under ``(x, y)``; inf outside the grid."""
    _, free, x0, y0, c, s, res = grid
    row, col = _cell(x, y, x0, y0, c, s, res)
    if not (0 <= row < free.shape[0] and 0 <= col < free.shape[1]):
        return np.inf
    out: float = distance[row // factor, col // factor]
    return out


@numba.njit(_XY(_F1, _F2, _F, _F, _F1, _F2, _GRID), cache=True)
def guided_target(
    ahead: FloatArray,
    noise: FloatArray,
    frontier: float,
    lookahead: float,
    to_go: FloatArray,
    path: FloatArray,
    grid: GridArgs,
) -> tuple[float, float]:
    """The first free one (in the conservative mask) of the candidates ``path`` point at ``frontier - ahead[i] *
    lookahead`` metres to go (``to_go`` decreasing along ``path``) plus ``noise[i]``; the first candidate when
    none is free (a target in a wall only wastes an iteration)."""
    cons = grid[0]
    _, _, x0, y0, c, s, res = grid
    first_x, first_y = 0.0, 0.0
    for i in range(len(ahead)):
        want = frontier - ahead[i] * lookahead
        # The first corridor point with at most ``want`` metres to go (searchsorted on the decreasing to_go).
        k = min(np.searchsorted(-to_go, -want), len(path) - 1)
        x, y = path[k, 0] + noise[i, 0], path[k, 1] + noise[i, 1]
        if i == 0:
            first_x, first_y = x, y
        row, col = _cell(x, y, x0, y0, c, s, res)
        if _at(cons, row, col):
            return x, y
    return first_x, first_y
