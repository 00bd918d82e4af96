"""Driving the robot from the keyboard as turtlebot3_teleop_key does (TurtleBot3's Noetic teleop).

``w``/``x`` raise/lower the target linear speed by 0.01 m/s, ``a``/``d`` the target angular speed by 0.1 rad/s,
each clamped to the Burger's limits; space or ``s`` stops. As in turtlebot3_teleop_key the commanded speeds move
towards the targets by at most half a step per tick (its ``makeSimpleProfile``), so the robot never jumps from
full speed ahead to full speed back. ROS-free: the node (``scripts/teleop_keyboard``) reads keys, calls
:func:`press` and :func:`tick`, and publishes :attr:`TeleopState.command`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from mrs_nav.robot import BURGER_MAX_ANGULAR, BURGER_MAX_LINEAR

#: Change of the target linear speed per key (m/s).
LINEAR_STEP = 0.01
#: Change of the target angular speed per key (rad/s).
ANGULAR_STEP = 0.1
#: Keys that end the program (``q``; Ctrl-C arrives as this byte in a raw terminal).
QUIT_KEYS = frozenset({"q", "\x03"})
#: The help is printed again after this many key presses, as turtlebot3_teleop_key does.
HELP_EVERY = 20

_STEPS = {"w": (LINEAR_STEP, 0.0), "x": (-LINEAR_STEP, 0.0), "a": (0.0, ANGULAR_STEP), "d": (0.0, -ANGULAR_STEP)}

HELP = f"""
Control Your TurtleBot3!
---------------------------
Moving around:
        w
   a    s    d
        x

w/x : increase/decrease linear velocity (Burger : ~ {BURGER_MAX_LINEAR})
a/d : increase/decrease angular velocity (Burger : ~ {BURGER_MAX_ANGULAR})

space key, s : force stop

q or CTRL-C to quit
"""


def _clamp(value: float, limit: float) -> float:
    return min(max(value, -limit), limit)


def _toward(current: float, target: float, slop: float) -> float:
    """``current`` moved towards ``target`` by at most ``slop``."""
    return min(target, current + slop) if target > current else max(target, current - slop)


@dataclass(frozen=True)
class TeleopState:
    """Targets set by the keys and the speeds commanded now (m/s, rad/s)."""

    target_linear: float = 0.0
    target_angular: float = 0.0
    linear: float = 0.0
    angular: float = 0.0

    @property
    def command(self) -> tuple[float, float]:
        """(linear m/s, angular rad/s) to publish."""
        return self.linear, self.angular

    def status(self) -> str:
        """The line turtlebot3_teleop_key prints after a key that changed the targets."""
        return f"currently:\tlinear vel {self.target_linear:.2f}\t angular vel {self.target_angular:.1f}"


def press(state: TeleopState, key: str) -> TeleopState | None:
    """The state after ``key``: the same state for a key without a meaning, ``None`` for a quit key."""
    if key in QUIT_KEYS:
        return None
    if key in (" ", "s"):
        return TeleopState()
    if key not in _STEPS:
        return state
    linear, angular = _STEPS[key]
    # round: ten presses of 0.01 give 0.1, not 0.09999999999999999, in the status line and on /cmd_vel
    return replace(
        state,
        target_linear=round(_clamp(state.target_linear + linear, BURGER_MAX_LINEAR), 2),
        target_angular=round(_clamp(state.target_angular + angular, BURGER_MAX_ANGULAR), 2),
    )


def tick(state: TeleopState) -> TeleopState:
    """One control tick: the commanded speeds half a key step closer to the targets."""
    return replace(
        state,
        linear=_toward(state.linear, state.target_linear, LINEAR_STEP / 2),
        angular=_toward(state.angular, state.target_angular, ANGULAR_STEP / 2),
    )
