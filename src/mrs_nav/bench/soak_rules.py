"""The rules of ``mrs-nav bench soak``: laps, the start and end windows, flatness, and when the clock jumps.

A lap is one round of the arena's four corners; for each measured process it holds the resident set size (RSS)
at its end and the CPU time (user + kernel) spent in it, and the scans simulated in it. The first lap maps the
arena and is a warm-up; the :data:`WINDOW` laps after it are the start window and the last :data:`WINDOW` laps
the end window (a lap's replans vary, so one lap is a noisy sample). A process is flat when, from the start window
to the end window, neither its RSS nor its CPU time per simulated scan grew by more than :data:`TOLERANCE`.

The clock jumps every ``every_min`` wall minutes from the start of the soak, while the run is still within its
requested minutes, cycling through :data:`JUMP_OFFSETS_S` (see :mod:`mrs_nav.ros.clock_jumper`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

CORNERS = ((1.5, 1.5), (-1.5, 1.5), (1.5, -1.5), (-1.5, -1.5))
#: Largest growth of RSS and of CPU time per scan from the start window to the end window.
TOLERANCE = 0.10
#: Laps in each of the start and end windows.
WINDOW = 3
#: Fewest laps of a soak: the warm-up and both windows.
MIN_LAPS = 1 + 2 * WINDOW
#: The /clock offsets published in turn: 1 s behind the simulator (the nodes' time goes back 1 s at once), then
#: 10 s and 185 s ahead (it goes back 10 s and 185 s when the simulator resumes; 185 s is a restarted simulator).
JUMP_OFFSETS_S = (-1.0, 10.0, 185.0)


@dataclass(frozen=True)
class Usage:
    """One process over a span: its RSS at the end (bytes) and the CPU seconds it spent."""

    rss: int
    cpu_s: float


@dataclass(frozen=True)
class Lap:
    """One round of the corners (or several as one): each process's usage, scans simulated, goals reached."""

    usage: Mapping[str, Usage]
    scans: float
    reached: int

    def cpu_per_scan_ms(self, process: str) -> float:
        return 1000.0 * self.usage[process].cpu_s / self.scans if self.scans else math.nan


@dataclass(frozen=True)
class Growth:
    """One process from the start window to the end window: relative growth of RSS and of CPU per scan."""

    rss: float
    cpu_per_scan: float

    @property
    def flat(self) -> bool:
        return self.rss <= TOLERANCE and self.cpu_per_scan <= TOLERANCE


def window(laps: Sequence[Lap]) -> Lap:
    """Consecutive laps as one: each process's RSS at the last, CPU time, scans and goals summed."""
    usage = {
        name: Usage(laps[-1].usage[name].rss, sum(lap.usage[name].cpu_s for lap in laps)) for name in laps[-1].usage
    }
    return Lap(usage, sum(lap.scans for lap in laps), sum(lap.reached for lap in laps))


def windows(laps: Sequence[Lap]) -> tuple[Lap, Lap]:
    """The start window (the laps after the warm-up) and the end window (the last laps)."""
    if len(laps) < MIN_LAPS:
        raise ValueError(f"a soak needs at least {MIN_LAPS} laps, got {len(laps)}")
    return window(laps[1 : 1 + WINDOW]), window(laps[-WINDOW:])


def growth(start: Lap, end: Lap) -> dict[str, Growth]:
    """Each process's growth from ``start`` to ``end``."""
    return {
        name: Growth(
            end.usage[name].rss / start.usage[name].rss - 1.0,
            end.cpu_per_scan_ms(name) / start.cpu_per_scan_ms(name) - 1.0,
        )
        for name in start.usage
    }


def jumps_due(elapsed_s: float, every_min: float, minutes: float) -> int:
    """How many clock jumps are due ``elapsed_s`` wall seconds into a soak of ``minutes`` with one every
    ``every_min`` minutes (0: none); none at or after the requested end."""
    if every_min <= 0.0:
        return 0
    last = math.ceil(minutes / every_min) - 1  # jumps strictly before the end
    return max(0, min(int(elapsed_s // (60.0 * every_min)), last))


def jump_offset(index: int) -> float:
    """The /clock offset (s) of jump number ``index`` (from 0)."""
    return JUMP_OFFSETS_S[index % len(JUMP_OFFSETS_S)]
