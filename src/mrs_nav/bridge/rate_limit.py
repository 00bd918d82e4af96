"""A per-topic rate limiter that keeps the average output rate at the configured maximum."""

from __future__ import annotations

import math

from mrs_nav.errors import InvalidInputError


class RateLimiter:
    """Let through at most ``max_rate`` events per second on average (0 = no limit).

    Slots are ``1/max_rate`` s apart. An event at time ``t`` passes when ``t`` reaches the next slot; the
    slot then advances by one period from where it was (not from ``t``), so input jitter does not erode
    the rate: with input at 100 Hz and a 10 Hz limit, exactly every tenth-ish message passes and the mean
    stays 10 Hz rather than the 9.1 Hz a "time since last" rule gives. After a pause longer than a period
    the schedule restarts at ``t`` (no burst to catch up).
    """

    def __init__(self, max_rate: float) -> None:
        if not math.isfinite(max_rate) or max_rate < 0:
            raise InvalidInputError(f"max rate {max_rate!r}: expected a finite rate >= 0 Hz (0 = no limit)")
        self.period = 1.0 / max_rate if max_rate > 0 else 0.0
        self._next = -math.inf

    def allow(self, t: float) -> bool:
        """Whether an event at time ``t`` (seconds, monotonic) passes; updates the schedule if it does."""
        if self.period == 0.0:
            return True
        if t < self._next:
            return False
        late = t - self._next
        self._next = self._next + self.period if late < self.period else t + self.period
        return True
