"""When a bench publisher starts its periodic load, so that two publishers in two processes keep a fixed phase.

``bench ros2`` measures the bridged chain and its rclpy floor at the same time on one machine. Each publisher
sends every topic at ``start + k / rate``; with starts taken from each process's own ``now``, the two chains'
instants fell at a relative phase that changed from run to run, and when they coincided the two chains competed
for the same cores (2 here) and disturbed each other's latency by an amount that depended on that phase. Starting
both on a grid of ``CLOCK_MONOTONIC`` (one clock per machine) with a given phase each fixes how far apart they are.
"""

from __future__ import annotations

import math
import time

from mrs_nav.options import number_option

#: Every bench rate (/odom 50 or 100 Hz, /scan 5 Hz, /map 1 Hz) repeats within one second.
GRID_S = 1.0
LEAD_S = 0.2  # at least this long from now to the first message: the caller's threads start meanwhile
#: A publisher's ``--phase`` (s past a whole second): finite, within one grid step.
phase_option = number_option(0.0, GRID_S)


def start_on_grid(phase: float, now: float | None = None) -> float:
    """The first ``time.monotonic()`` instant at least :data:`LEAD_S` after ``now`` (default: now) that lies
    ``phase`` seconds past a whole :data:`GRID_S`."""
    earliest = (time.monotonic() if now is None else now) + LEAD_S
    return math.ceil((earliest - phase) / GRID_S) * GRID_S + phase
