"""Lockstep: keep a simulator running flat out no further ahead of its controller than one control period.

At maximum rate a simulator can run hundreds of times faster than real time while a controller on sim time
still needs some wall time per tick (callbacks, tf, planning). Unchecked, the simulation runs far ahead: the
robot drives blind on a stale command, then the command watchdog stops it. In lockstep the simulator records
the sim time ``t_c`` at which each command arrives and steps only while

    sim_time < t_c + period

so the controller, ticking every ``period`` of sim time, always sees the state it is commanding. Two escapes
keep the pair live whatever the controller does: until a first command arrives the simulation runs freely (a
lone simulator, or a controller still waiting for its map or tf, which it can only get with time moving), and
when no command has arrived for ``timeout`` seconds of *wall* time the controller is taken as gone and the
simulation runs freely again until the next command re-engages the lock.

:class:`LockstepGate` is the decision only (pure, thread-safe); the caller waits for a command with
:meth:`LockstepGate.wait_for_command` when :meth:`LockstepGate.may_step` says no.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from mrs_nav.errors import InvalidInputError


@dataclass(frozen=True)
class LockstepConfig:
    """``period``: sim seconds the simulation may run past the last command (one control period, 0.1 s for the
    10 Hz navigation nodes); ``timeout``: wall seconds of controller silence after which it runs freely."""

    period: float = 0.1
    timeout: float = 1.0

    def __post_init__(self) -> None:
        for name in ("period", "timeout"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"~lockstep_{name}: must be a positive number of seconds, got {value}")


class LockstepGate:
    """Whether the simulation may take its next step, given the sim time of the last command received.

    ``wall_clock`` (monotonic seconds) is injectable so tests can drive the timeout without sleeping.
    """

    def __init__(self, config: LockstepConfig, wall_clock: Callable[[], float] = time.monotonic) -> None:
        self.config = config
        self._wall_clock = wall_clock
        self._changed = threading.Condition()
        self._command_sim_time: float | None = None
        self._command_wall_time = -math.inf

    def on_command(self, sim_time: float) -> None:
        """A command arrived while the simulation stood at ``sim_time`` (s): extend the horizon from there."""
        with self._changed:
            self._command_sim_time = sim_time
            self._command_wall_time = self._wall_clock()
            self._changed.notify_all()

    def reset(self) -> None:
        """Forget the controller (e.g. sim time restarted): run freely until the next command."""
        with self._changed:
            self._command_sim_time = None
            self._command_wall_time = -math.inf
            self._changed.notify_all()

    @property
    def horizon(self) -> float:
        """Sim time (s) up to which stepping is allowed; +inf while no controller holds the lock."""
        with self._changed:
            return self._horizon_locked()

    def _horizon_locked(self) -> float:
        if self._command_sim_time is None:
            return math.inf
        if self._wall_clock() - self._command_wall_time > self.config.timeout:
            return math.inf  # the controller went silent: do not wait for it any longer
        return self._command_sim_time + self.config.period

    def may_step(self, sim_time: float) -> bool:
        """True when a step from ``sim_time`` (s) stays within the horizon (a 1 µs tolerance absorbs the
        float sum of fixed steps)."""
        with self._changed:
            return sim_time < self._horizon_locked() - 1e-6

    def wait_for_command(self, sim_time: float, max_wait: float) -> bool:
        """Block (at most ``max_wait`` wall seconds, and never past the silence timeout) until stepping from
        ``sim_time`` is allowed; returns whether it is."""
        deadline = self._wall_clock() + max_wait
        with self._changed:
            while sim_time >= self._horizon_locked() - 1e-6:
                now = self._wall_clock()
                # wake at the silence timeout at the latest, so the free-run escape takes effect on time
                wake = min(deadline, self._command_wall_time + self.config.timeout + 1e-3)
                if now >= deadline:
                    return False
                self._changed.wait(max(wake - now, 1e-4))
            return True
