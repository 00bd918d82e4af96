"""Whether a periodic input (laser scans, the localisation's map->odom correction) has gone quiet: in sim time and
relative to the input's own rate, so that a loaded machine, whose callbacks run late by a scan period or two,
does not read as a dead laser or a lost localisation (issue 38: the navigation warned several times a minute at a
load of 11-14 on 2 cores with fixed 0.15 s / 0.4 s limits while all was well)."""

from __future__ import annotations

import math
import statistics
from collections import deque
from dataclasses import dataclass, field

from mrs_nav.errors import InvalidInputError

WINDOW = 20  # intervals the period is the median of: a burst of late arrivals does not shift it


@dataclass
class QuietWatch:
    """Arrival times of one input; quiet once none came for ``periods`` of its median interval, and never
    sooner than ``floor_s`` (s, sim time). Before two arrivals the period is unknown and ``floor_s`` alone counts."""

    floor_s: float
    periods: float
    _last: float = -math.inf
    _intervals: deque[float] = field(default_factory=lambda: deque(maxlen=WINDOW))

    def __post_init__(self) -> None:
        if not (math.isfinite(self.floor_s) and self.floor_s >= 0.0):
            raise InvalidInputError(f"quiet time floor: must be a number >= 0, got {self.floor_s}")
        if not (math.isfinite(self.periods) and self.periods >= 1.0):
            raise InvalidInputError(f"stale_periods: must be a number >= 1, got {self.periods}")

    def arrived(self, t: float) -> None:
        """Note an arrival at sim time ``t``; one not after the last (a repeat) only keeps the last."""
        if t > self._last:
            if math.isfinite(self._last):
                self._intervals.append(t - self._last)
            self._last = t

    def reset(self) -> None:
        """Forget every arrival (the clock went back)."""
        self._last = -math.inf
        self._intervals.clear()

    @property
    def period(self) -> float | None:
        """The median interval between arrivals (s), None before two."""
        return statistics.median(self._intervals) if self._intervals else None

    def timeout_s(self, period: float | None = None) -> float:
        """How long without an arrival counts as quiet (s): ``periods`` of ``period`` (default: the input's own
        median interval; a heartbeat re-sent faster than it changes is better judged by the rate of what drives
        it), and never less than ``floor_s``."""
        period = self.period if period is None else period
        return self.floor_s if period is None else max(self.floor_s, self.periods * period)

    @property
    def last(self) -> float:
        """Sim time of the last arrival (-inf before any)."""
        return self._last

    def quiet(self, now: float, period: float | None = None) -> bool:
        """True when nothing arrived within :meth:`timeout_s` before ``now`` (also before any arrival)."""
        return now - self._last > self.timeout_s(period)
