"""Lockstep: keep a simulator running flat out no further ahead of its controller than one control period.

At maximum rate a simulator can run hundreds of times faster than real time while a controller on sim time
still needs some wall time per tick (callbacks, tf, planning). Unchecked, the simulation runs far ahead: the
robot drives blind on a stale command, then the command watchdog stops it. In lockstep the simulator records
the sim time ``t_c`` at which each command arrives and steps only while

    sim_time < t_c + period

so the controller, ticking every ``period`` of sim time, always sees the state it is commanding. Escapes keep
the pair live whatever the controller does, each after a silence ``s`` (wall seconds since the last command):

* until a first command arrives the simulation runs freely (a lone simulator, or a controller still waiting
  for its map or tf, which it can only get with time moving);
* ``s > timeout`` with no publisher connected to the command topic: the controller is gone (killed: its TCP
  connection closed), the simulation runs freely;
* ``s > timeout`` when the last command was a stop (zero twist): the robot stands still, so running on drives
  nobody blind; a controller idle between goals (a navigation node launched without its heartbeat goes silent
  after a goal ends or is cancelled) keeps the old release;
* ``s > stall_timeout`` with a publisher still connected and the last command a motion: a controller in the
  middle of a drive commands every tick, so a connected one that is silent is slow, not idle. Running on would
  drive the robot blind on its last command until the watchdog stops it (0.3 s of sim time), so the simulation
  waits much longer for it, and only gives up on one that stays hung.

A connected controller silent for ``timeout`` in the middle of a motion gets one period of grace first: the
horizon moves to ``t_c + 2 period`` and the simulation waits there. A rospy timer on sim time sleeps until
``T + period + (c2 - c1)`` for its tick ``T``, where ``c1 <= c2`` are its two readings of the clock in
``Rate.sleep`` and ``rospy.sleep``; the simulation may move in between (up to ``t_c + period``, ``t_c >= c1 >=
T``), so the next tick can fall past the horizon, up to ``t_c + 2 period``. Without the grace both sides wait
for each other (measured: a loaded machine's navigation node idle in ``rospy.sleep`` while the simulator
waited for it); with it the robot runs at most one period (0.1 s, 2.2 cm at 0.22 m/s) past its controller's last
look, instead of free running.

Free running lasts until the next command re-engages the lock. Each switch is reported once through
``on_switch`` (a :class:`LockstepSwitch`), never per step.

:class:`LockstepGate` is the decision only (pure, thread-safe; the publisher count comes from an injected
callable, so the core never sees ROS); the caller waits for a command with :meth:`LockstepGate.wait_for_command`
when :meth:`LockstepGate.may_step` says no.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from mrs_nav.errors import InvalidInputError

#: How a simulator's log line about a switch to free running starts after its prefix (benches count them).
FREE_RUN_LOG = "lockstep released: running freely from sim time"


@dataclass(frozen=True)
class LockstepConfig:
    """``period``: sim seconds the simulation may run past the last command (one control period, 0.1 s for the
    10 Hz navigation nodes); ``timeout``: wall seconds of silence after which it runs freely when no publisher
    is connected or the last command was a stop; ``stall_timeout``: the same while a publisher is still connected
    and the last command asked for motion (a starved controller)."""

    period: float = 0.1
    timeout: float = 1.0
    stall_timeout: float = 30.0

    def __post_init__(self) -> None:
        for name in ("period", "timeout", "stall_timeout"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"~lockstep_{name}: must be a positive number of seconds, got {value}")
        if self.stall_timeout < self.timeout:
            raise InvalidInputError(
                f"~lockstep_stall_timeout: must be at least ~lockstep_timeout ({self.timeout} s), "
                f"got {self.stall_timeout}"
            )


@dataclass(frozen=True)
class LockstepSwitch:
    """A switch between lockstep and free running, at ``sim_time`` (s). To free running (``free``): after
    ``silent_s`` wall seconds without a command, with ``publishers`` connected then and the last command asking
    for motion (``moving``) or a stop. Back to lockstep: a command arrived after ``silent_s`` wall seconds of free
    running."""

    free: bool
    sim_time: float
    silent_s: float
    publishers: int = 0
    moving: bool = True


def _no_publishers() -> int:
    return 0


class LockstepGate:
    """Whether the simulation may take its next step, given the sim time of the last command received.

    ``wall_clock`` (monotonic seconds) is injectable so tests can drive the timeouts without sleeping;
    ``publishers`` counts the publishers connected to the command topic (none known: the short ``timeout``
    applies); ``on_switch`` hears each switch to and from free running, from the thread that caused it.
    """

    def __init__(
        self,
        config: LockstepConfig,
        wall_clock: Callable[[], float] = time.monotonic,
        publishers: Callable[[], int] = _no_publishers,
        on_switch: Callable[[LockstepSwitch], None] | None = None,
    ) -> None:
        self.config = config
        self._wall_clock = wall_clock
        self._publishers = publishers
        self._on_switch = on_switch
        self._changed = threading.Condition()
        self._command_sim_time: float | None = None
        self._command_wall_time = -math.inf
        self._free = False  # released by a silence, until the next command
        self._moving = False  # whether the last command asked for motion

    def on_command(self, sim_time: float, moving: bool = True) -> None:
        """A command arrived while the simulation stood at ``sim_time`` (s): extend the horizon from there.
        ``moving``: it asks for motion (False: a stop, a zero twist)."""
        with self._changed:
            self._moving = moving
            now = self._wall_clock()
            if self._free:
                self._free = False
                self._report(LockstepSwitch(False, sim_time, now - self._command_wall_time))
            self._command_sim_time = sim_time
            self._command_wall_time = now
            self._changed.notify_all()

    def reset(self) -> None:
        """Forget the controller (e.g. sim time restarted): run freely until the next command."""
        with self._changed:
            self._command_sim_time = None
            self._command_wall_time = -math.inf
            self._free = False
            self._changed.notify_all()

    @property
    def horizon(self) -> float:
        """Sim time (s) up to which stepping is allowed; +inf while no controller holds the lock."""
        with self._changed:
            return self._horizon_locked(None)

    def _horizon_locked(self, sim_time: float | None) -> float:
        """The horizon; a release found here is reported at ``sim_time`` (None: at the last command's)."""
        if self._command_sim_time is None or self._free:
            return math.inf
        silent = self._wall_clock() - self._command_wall_time
        if silent <= self.config.timeout:
            return self._command_sim_time + self.config.period
        # asked only once the short timeout has passed: never per step of a controller that keeps up
        publishers = self._publishers()
        if publishers > 0 and self._moving and silent <= self.config.stall_timeout:
            # connected: starved or waiting for a tick just past the horizon; one period of grace, then wait for it
            return self._command_sim_time + 2.0 * self.config.period
        self._free = True
        at = self._command_sim_time if sim_time is None else sim_time
        self._report(LockstepSwitch(True, at, silent, publishers, self._moving))
        return math.inf

    def _report(self, switch: LockstepSwitch) -> None:
        if self._on_switch is not None:
            self._on_switch(switch)

    def may_step(self, sim_time: float) -> bool:
        """True when a step from ``sim_time`` (s) stays within the horizon (a 1 µs tolerance absorbs the
        float sum of fixed steps)."""
        with self._changed:
            return sim_time < self._horizon_locked(sim_time) - 1e-6

    def _next_escape_locked(self, now: float) -> float:
        """Wall time of the next silence timeout still ahead (the stall timeout once the short one passed)."""
        short = self._command_wall_time + self.config.timeout
        return short if now < short else self._command_wall_time + self.config.stall_timeout

    def wait_for_command(self, sim_time: float, max_wait: float) -> bool:
        """Block (at most ``max_wait`` wall seconds, and never past the next silence timeout) until stepping
        from ``sim_time`` is allowed; returns whether it is. A publisher that disconnects meanwhile is noticed
        at the next call: keep ``max_wait`` short."""
        deadline = self._wall_clock() + max_wait
        with self._changed:
            while sim_time >= self._horizon_locked(sim_time) - 1e-6:
                now = self._wall_clock()
                if now >= deadline:
                    return False
                # wake at the next silence timeout at the latest, so the free-run escape takes effect on time
                wake = min(deadline, self._next_escape_locked(now) + 1e-3)
                self._changed.wait(max(wake - now, 1e-4))
            return True
