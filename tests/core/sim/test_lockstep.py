"""LockstepGate: the simulation is held within one period of the last command, and runs freely otherwise."""

from __future__ import annotations

import math
import threading
import time

import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.sim import LockstepConfig, LockstepGate, LockstepSwitch


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


class Publishers:
    """The command topic's connected publishers, as the node's subscriber counts them."""

    def __init__(self, count: int) -> None:
        self.count = count
        self.asked = 0

    def __call__(self) -> int:
        self.asked += 1
        return self.count


def connected_gate(count: int) -> tuple[LockstepGate, FakeWall, Publishers, list[LockstepSwitch]]:
    wall, publishers, switches = FakeWall(), Publishers(count), []
    gate = LockstepGate(LockstepConfig(period=0.1, timeout=1.0, stall_timeout=30.0), wall, publishers, switches.append)
    return gate, wall, publishers, switches


def test_a_connected_but_silent_controller_is_waited_for_past_the_short_timeout() -> None:
    gate, wall, _, switches = connected_gate(1)  # still connected, no command for a while
    gate.on_command(2.0)
    wall.now += 0.9
    assert not gate.may_step(2.1)
    wall.now += 4.1  # past the short timeout: one period of grace (its tick may lie just past the horizon)
    assert gate.may_step(2.1)
    assert not gate.may_step(2.2)
    assert gate.horizon == pytest.approx(2.2)
    wall.now += 24.0
    assert not gate.may_step(2.2)
    assert switches == []
    gate.on_command(2.2)  # it comes back: one period from its command, no switch happened
    assert gate.may_step(2.2)
    assert not gate.may_step(2.3)
    assert switches == []


def test_a_connected_controller_silent_after_a_stop_releases_the_simulation_after_the_short_timeout() -> None:
    """A navigation node without its heartbeat goes silent once a goal ends or is cancelled, its last command a
    zero twist: the robot stands still, so running on drives nobody blind (a 30 s wait stalled every cancel)."""
    gate, wall, _, switches = connected_gate(1)
    gate.on_command(2.0, moving=False)
    wall.now += 0.9
    assert not gate.may_step(2.1)
    wall.now += 0.2
    assert gate.may_step(2.1)
    assert gate.may_step(50.0)
    assert switches == [LockstepSwitch(True, 2.1, pytest.approx(1.1), 1, moving=False)]


def test_a_silent_controller_without_a_connected_publisher_is_gone_after_the_short_timeout() -> None:
    gate, wall, publishers, switches = connected_gate(1)
    gate.on_command(2.0)
    wall.now += 0.5
    assert not gate.may_step(2.1)
    assert publishers.asked == 0  # within the short timeout the count is not even asked
    publishers.count = 0  # killed: its connection closed
    wall.now += 0.6
    assert gate.may_step(2.2)
    assert gate.may_step(50.0)
    assert switches == [LockstepSwitch(True, 2.2, pytest.approx(1.1), 0)]


def test_a_connected_controller_silent_past_the_stall_timeout_is_given_up() -> None:
    gate, wall, _, switches = connected_gate(2)
    gate.on_command(2.0)
    wall.now += 30.5
    assert gate.may_step(2.2)
    assert gate.may_step(9.0)
    assert switches == [LockstepSwitch(True, 2.2, pytest.approx(30.5), 2)]  # reported once, not per step
    wall.now += 2.0
    gate.on_command(9.0)  # a command re-engages the lock, reported once
    assert not gate.may_step(9.1)
    assert switches[1:] == [LockstepSwitch(False, 9.0, pytest.approx(32.5))]
    gate.on_command(9.1)
    assert len(switches) == 2


def test_wait_for_command_waits_for_a_connected_controller_past_the_short_timeout() -> None:
    gate = LockstepGate(LockstepConfig(period=0.1, timeout=0.05, stall_timeout=30.0), publishers=lambda: 1)
    gate.on_command(0.0)
    start = time.monotonic()
    assert not gate.wait_for_command(0.2, 0.3)  # no free run at 0.05 s (past the grace): it gives up at max_wait
    assert 0.25 < time.monotonic() - start < 1.0


@pytest.mark.parametrize(("period", "timeout"), [(0.0, 1.0), (0.1, -1.0), (math.nan, 1.0), (0.1, math.inf)])
def test_bad_parameters_are_refused(period: float, timeout: float) -> None:
    with pytest.raises(InvalidInputError, match="lockstep"):
        LockstepConfig(period=period, timeout=timeout)


def test_a_stall_timeout_below_the_short_timeout_is_refused() -> None:
    with pytest.raises(InvalidInputError, match="lockstep_stall_timeout"):
        LockstepConfig(timeout=2.0, stall_timeout=1.0)
