"""A record of per-tick samples in bounded memory, for runs of any length.

The headless stack records the true and estimated pose at every control tick for its figure and metrics. An
hour-long run would grow that record without end, so :class:`BoundedTrack` keeps at most ``capacity`` rows:
when full it drops every other row and from then on keeps one sample in two (then four, ...). A short run
(fewer samples than the capacity) is kept whole; a long one as an evenly thinned record of all of it.
"""

from __future__ import annotations

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import FloatArray


class BoundedTrack:
    """Rows of ``columns`` floats, at most ``capacity`` of them, evenly thinned once more arrive."""

    def __init__(self, columns: int, capacity: int = 20_000) -> None:
        if columns < 1 or capacity < 2:
            raise InvalidInputError(f"a track needs >= 1 column and a capacity >= 2, got {columns} and {capacity}")
        self._rows = np.empty((capacity, columns))
        self._size = 0
        self._stride = 1  # keep one sample in this many
        self._seen = 0

    def append(self, row: tuple[float, ...]) -> None:
        """Record one sample (kept when it falls on the current stride)."""
        self._seen += 1
        if (self._seen - 1) % self._stride:
            return
        if self._size == self._rows.shape[0]:
            kept = self._rows[: self._size : 2].copy()
            self._size = kept.shape[0]
            self._rows[: self._size] = kept
            self._stride *= 2
            if (self._seen - 1) % self._stride:
                return
        self._rows[self._size] = row
        self._size += 1

    def array(self) -> FloatArray:
        """A copy of the kept rows, oldest first, shape ``(n, columns)``."""
        out: FloatArray = self._rows[: self._size].copy()
        return out

    def __len__(self) -> int:
        return self._size
