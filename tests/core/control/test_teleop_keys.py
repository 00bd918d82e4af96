"""turtlebot3_teleop_key's keys, steps, limits and ramp, without ROS."""

from __future__ import annotations

import pytest

from mrs_nav.control.teleop_keys import HELP, TeleopState, press, tick
from mrs_nav.robot import BURGER_MAX_ANGULAR, BURGER_MAX_LINEAR


def _keys(keys: str, state: TeleopState | None = None) -> TeleopState:
    state = state or TeleopState()
    for key in keys:
        after = press(state, key)
        assert after is not None
        state = after
    return state


def test_w_x_a_d_step_the_targets_by_turtlebot3s_steps() -> None:
    assert _keys("www").target_linear == 0.03
    assert _keys("wwwx").target_linear == 0.02
    assert _keys("aa").target_angular == 0.2
    assert _keys("aad").target_angular == 0.1
    assert _keys("w" * 10).target_linear == 0.1  # no 0.09999999999999999 from summed steps


def test_targets_stop_at_the_burgers_limits() -> None:
    assert _keys("w" * 40).target_linear == BURGER_MAX_LINEAR
    assert _keys("x" * 40).target_linear == -BURGER_MAX_LINEAR
    assert _keys("a" * 40).target_angular == BURGER_MAX_ANGULAR
    assert _keys("d" * 40).target_angular == -BURGER_MAX_ANGULAR


@pytest.mark.parametrize("stop", [" ", "s"])
def test_space_and_s_stop_at_once(stop: str) -> None:
    moving = TeleopState(0.2, 1.0, 0.2, 1.0)
    assert press(moving, stop) == TeleopState()


def test_other_keys_change_nothing_and_q_or_ctrl_c_quit() -> None:
    state = _keys("wa")
    assert press(state, "z") == state
    assert press(state, "q") is None
    assert press(state, "\x03") is None


def test_the_command_ramps_half_a_step_per_tick_towards_the_target() -> None:
    state = _keys("ww")  # target 0.02 m/s
    speeds = []
    for _ in range(5):
        state = tick(state)
        speeds.append(state.command[0])
    assert speeds == pytest.approx([0.005, 0.01, 0.015, 0.02, 0.02])
    back = _keys("xxxx", state)  # target -0.02: down by 0.005 per tick, never a jump
    assert tick(back).command[0] == pytest.approx(0.015)


def test_help_and_status_look_like_turtlebot3s() -> None:
    assert "Control Your TurtleBot3!" in HELP
    assert "w/x : increase/decrease linear velocity (Burger : ~ 0.22)" in HELP
    assert "a/d : increase/decrease angular velocity (Burger : ~ 2.84)" in HELP
    assert "space key, s : force stop" in HELP
    assert _keys("wwa").status() == "currently:\tlinear vel 0.02\t angular vel 0.1"
