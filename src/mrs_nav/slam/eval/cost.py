"""How the SLAM's cost behaves along a log (issue 40, "a cost that does not grow with the map"): the CPU time per
processed scan at the start of a log against its end, its tail against its median, and the memory above the
imports per square metre mapped.

Lines: the median CPU per scan of the last :data:`SHARE` of the processed scans at most :data:`GROWTH_LINE` times
that of the first (a cost that grows with the map or the pose graph shows there first), the 95th percentile at most
:data:`TAIL_LINE` times the median (the spikes of loop closures and map rebuilds), peak memory at most
:data:`MEMORY_LINE_MB`. Bytes per square metre have no line: they say what a map of another size would take.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.slam.grid import LogOddsGrid

SHARE = 0.1  # of the processed scans: the first and the last tenth
GROWTH_LINE = 1.2  # the last tenth's median CPU per scan over the first tenth's, at most
TAIL_LINE = 3.0  # p95 CPU per scan over the median, at most
MEMORY_LINE_MB = 500.0  # peak resident memory of the replaying process, at most


@dataclass(frozen=True)
class CostAlongLog:
    """CPU time per processed scan (ms) of one replay: the median of its first and of its last :data:`SHARE` of
    scans, the median and 95th percentile over all of them, and how many there were."""

    scans: int
    first_median_ms: float
    last_median_ms: float
    median_ms: float
    p95_ms: float

    @property
    def growth(self) -> float:
        """The last share's median over the first share's (1.0: flat)."""
        return self.last_median_ms / self.first_median_ms if self.first_median_ms > 0.0 else math.inf

    @property
    def tail(self) -> float:
        """The 95th percentile over the median."""
        return self.p95_ms / self.median_ms if self.median_ms > 0.0 else math.inf

    @property
    def flat(self) -> bool:
        """Whether the cost per scan stays within :data:`GROWTH_LINE` from the start of the log to its end."""
        return self.growth <= GROWTH_LINE

    @property
    def tail_bounded(self) -> bool:
        """Whether the 95th percentile is within :data:`TAIL_LINE` times the median."""
        return self.tail <= TAIL_LINE


def cost_along(ms_per_scan: Sequence[float], share: float = SHARE) -> CostAlongLog:
    """The :class:`CostAlongLog` of the CPU times (ms) of the processed scans in log order; the first and last
    ``share`` of them are at least one scan each. Raises :class:`InvalidInputError` on no scans, a time that is
    negative or not finite, or a share outside (0, 0.5]."""
    if not 0.0 < share <= 0.5:
        raise InvalidInputError(f"cost along a log: the share of scans must be in (0, 0.5], got {share}")
    ms = np.asarray(ms_per_scan, dtype=np.float64)
    if ms.size == 0:
        raise InvalidInputError("cost along a log: no processed scans")
    if not np.all(np.isfinite(ms)) or np.any(ms < 0.0):
        raise InvalidInputError("cost along a log: CPU times must be finite and >= 0")
    k = max(1, round(share * ms.size))
    return CostAlongLog(
        scans=int(ms.size),
        first_median_ms=float(np.median(ms[:k])),
        last_median_ms=float(np.median(ms[-k:])),
        median_ms=float(np.median(ms)),
        p95_ms=float(np.percentile(ms, 95)),
    )


def mapped_area_m2(grid: LogOddsGrid) -> float:
    """The area (m^2) the map has observed: its cells of log-odds other than 0 (seen free or occupied). Read it
    with every tile drawn (:attr:`mrs_nav.slam.slam.Slam.grid` draws them): an out-of-date tile counts as unseen."""
    used = int(grid.tiles[0])
    return int(np.count_nonzero(grid.logodds[:used])) * grid.resolution**2


def bytes_per_m2(memory_bytes: float, area_m2: float) -> float:
    """``memory_bytes`` per square metre of ``area_m2`` (NaN for no area)."""
    return memory_bytes / area_m2 if area_m2 > 0.0 else math.nan


def cost_failures(cost: CostAlongLog, peak_mb: float | None = None) -> list[str]:
    """The lines ``cost`` (and the peak memory, MB, when given) breaks, in words; empty when it keeps them all."""
    failures = []
    if not cost.flat:
        failures.append(f"last/first tenth {cost.growth:.2f} > {GROWTH_LINE}")
    if not cost.tail_bounded:
        failures.append(f"p95/median {cost.tail:.2f} > {TAIL_LINE}")
    if peak_mb is not None and peak_mb > MEMORY_LINE_MB:
        failures.append(f"peak RSS {peak_mb:.0f} MB > {MEMORY_LINE_MB:.0f} MB")
    return failures
