"""LockstepGate: the simulation is held within one period of the last command, and runs freely otherwise."""

from __future__ import annotations

import math
import threading
import time

import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.sim import LockstepConfig, LockstepGate


class FakeWall:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_runs_freely_until_a_first_command() -> None:
    gate = LockstepGate(LockstepConfig(period=0.1, timeout=1.0), FakeWall())
    assert gate.horizon == math.inf
    assert gate.may_step(1e6)


def test_holds_within_one_period_of_the_last_command() -> None:
    gate = LockstepGate(LockstepConfig(period=0.1, timeout=1.0), FakeWall())
    gate.on_command(5.0)
    assert gate.horizon == pytest.approx(5.1)
    steps, t = 0, 5.0
    while gate.may_step(t):  # 100 Hz physics from the command on
        t = 5.0 + (steps + 1) * 0.01
        steps += 1
    assert steps == 10
    assert t == pytest.approx(5.1)
    gate.on_command(t)  # the next command releases exactly one more period
    assert gate.may_step(t)
    assert not gate.may_step(5.2)


def test_a_silent_controller_releases_the_simulation_after_the_wall_timeout() -> None:
    wall = FakeWall()
    gate = LockstepGate(LockstepConfig(period=0.1, timeout=1.0), wall)
    gate.on_command(2.0)
    wall.now += 0.9
    assert not gate.may_step(2.1)
    wall.now += 0.2
    assert gate.may_step(2.1)
    assert gate.may_step(50.0)
    gate.on_command(50.0)  # a controller that comes back takes the lock again
    assert not gate.may_step(50.1)


def test_reset_forgets_the_controller() -> None:
    gate = LockstepGate(LockstepConfig(), FakeWall())
    gate.on_command(1.0)
    gate.reset()
    assert gate.may_step(10.0)


def test_wait_for_command_wakes_when_a_command_arrives() -> None:
    gate = LockstepGate(LockstepConfig(period=0.1, timeout=5.0))
    gate.on_command(0.0)
    assert not gate.wait_for_command(0.1, 0.01)  # nothing arrives: gives up after max_wait
    threading.Timer(0.05, gate.on_command, args=(0.1,)).start()
    start = time.monotonic()
    assert gate.wait_for_command(0.1, 2.0)
    assert time.monotonic() - start < 1.0


def test_wait_for_command_returns_at_the_silence_timeout() -> None:
    gate = LockstepGate(LockstepConfig(period=0.1, timeout=0.05))
    gate.on_command(0.0)
    start = time.monotonic()
    assert gate.wait_for_command(0.1, 2.0)
    assert time.monotonic() - start < 1.0


@pytest.mark.parametrize(("period", "timeout"), [(0.0, 1.0), (0.1, -1.0), (math.nan, 1.0), (0.1, math.inf)])
def test_bad_parameters_are_refused(period: float, timeout: float) -> None:
    with pytest.raises(InvalidInputError, match="lockstep"):
        LockstepConfig(period=period, timeout=timeout)
