"""Recovery behaviours tried before a goal is given up, as move_base's.

When planning has failed ``max_failed_plans`` times in a row, or the robot has got no closer to the goal for
``progress_timeout_s``, the :class:`~mrs_nav.navigation.navigator.Navigator` asks :class:`Recoveries` for the
next behaviour of the configured list, runs it and plans again; when the list is used up the goal is aborted
with the reason. The behaviours (move_base's default list, under its names):

* ``conservative_reset``: drop the marks (:mod:`.obstacles`) farther than ``conservative_reset_dist_m`` from the
  robot: stale marks of places it cannot see any more;
* ``rotate_recovery``: turn a full circle on the spot at the robot's angular limit, so that the laser sweeps all
  round and clears (or marks again) what is near;
* ``aggressive_reset``: drop every mark; what is really there is marked again by the next scans.

Each behaviour is tried once per goal; the list starts again once the robot has got ``progress_m`` closer to the
goal. move_base's switches map onto the list (:meth:`RecoveryConfig.from_move_base`): ``recovery_behavior_enabled``
false empties it, ``clearing_rotation_allowed`` false leaves the rotation out. Times in seconds of the caller's
clock, angles in radians, distances in metres.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D, wrap_angle
from mrs_nav.robot import BURGER_MAX_ANGULAR

__all__ = ["Recoveries", "RecoveryBehavior", "RecoveryConfig", "Rotation"]


class RecoveryBehavior(Enum):
    """A recovery behaviour, by move_base's name for it."""

    CONSERVATIVE_RESET = "conservative_reset"
    ROTATE_RECOVERY = "rotate_recovery"
    AGGRESSIVE_RESET = "aggressive_reset"


@dataclass(frozen=True)
class RecoveryConfig:
    """Which recoveries run, in order, and how."""

    behaviors: tuple[RecoveryBehavior, ...] = tuple(RecoveryBehavior)
    conservative_reset_dist_m: float = 3.0
    rotation_speed_rad_s: float = BURGER_MAX_ANGULAR
    # A rotation that has not turned a full circle by then (the robot held, a wheel blocked) ends anyway.
    rotation_timeout_s: float = 10.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.conservative_reset_dist_m) and self.conservative_reset_dist_m >= 0.0):
            raise InvalidInputError(
                f"recovery conservative_reset_dist must be a number >= 0 m, got {self.conservative_reset_dist_m}"
            )
        for name in ("rotation_speed_rad_s", "rotation_timeout_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"recovery {name} must be a positive number, got {value}")
        if len(set(self.behaviors)) != len(self.behaviors):
            raise InvalidInputError(f"recovery behaviours are listed twice: {[b.value for b in self.behaviors]}")

    @classmethod
    def from_move_base(
        cls,
        *,
        recovery_behavior_enabled: bool,
        clearing_rotation_allowed: bool,
        recovery_behaviors: Sequence[str],
        conservative_reset_dist: float,
        rotation_speed: float,
    ) -> RecoveryConfig:
        """The configuration that move_base's parameters of these names describe (``recovery_behaviors``: the
        behaviours' names, in the order to try them)."""
        known = {b.value: b for b in RecoveryBehavior}
        unknown = [name for name in recovery_behaviors if name not in known]
        if unknown:
            raise InvalidInputError(f"recovery_behaviors: unknown {unknown}; expected some of {sorted(known)}")
        behaviors = tuple(known[name] for name in recovery_behaviors) if recovery_behavior_enabled else ()
        if not clearing_rotation_allowed:
            behaviors = tuple(b for b in behaviors if b is not RecoveryBehavior.ROTATE_RECOVERY)
        return cls(behaviors, conservative_reset_dist, rotation_speed)


class Recoveries:
    """Which recovery comes next for the current goal."""

    def __init__(self, config: RecoveryConfig) -> None:
        self.config = config
        self._next = 0

    @property
    def tried(self) -> tuple[RecoveryBehavior, ...]:
        """The behaviours run since the last :meth:`reset`, in order."""
        return self.config.behaviors[: self._next]

    def reset(self) -> None:
        """Start the list again (a new goal, or progress towards it)."""
        self._next = 0

    def next(self) -> RecoveryBehavior | None:
        """The next behaviour to run, None when all have been tried."""
        if self._next >= len(self.config.behaviors):
            return None
        self._next += 1
        return self.config.behaviors[self._next - 1]

    def describe(self) -> str:
        """``"n/N"``: the place of the last behaviour returned in the list."""
        return f"{self._next}/{len(self.config.behaviors)}"


class Rotation:
    """A full turn on the spot, counted from the poses the robot reports."""

    def __init__(self, config: RecoveryConfig, now: float) -> None:
        self.config = config
        self._deadline = now + config.rotation_timeout_s
        self._yaw: float | None = None
        self.turned = 0.0  # rad so far

    def command(self, pose: Pose2D, now: float) -> float | None:
        """The angular speed (rad/s) to command at ``pose``; None once the turn is complete or timed out."""
        if self._yaw is not None:
            self.turned += abs(wrap_angle(pose.yaw - self._yaw))
        self._yaw = pose.yaw
        if self.turned >= 2.0 * math.pi or now >= self._deadline:
            return None
        return self.config.rotation_speed_rad_s
