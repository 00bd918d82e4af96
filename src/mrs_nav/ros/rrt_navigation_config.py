"""The ``rrt_navigation`` node's parameters (``config/rrt_navigation.yaml``, move_base's names where they mean the
same) read into one frozen config: the navigator's, the costmap marking's and the recoveries' parts."""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from mrs_nav.config_files import node_default, node_defaults
from mrs_nav.control.goal_approach import ApproachConfig
from mrs_nav.control.path_following import FollowerConfig
from mrs_nav.errors import InvalidInputError
from mrs_nav.navigation.marking import MarkingConfig
from mrs_nav.navigation.navigator import PLANNERS, NavigatorConfig
from mrs_nav.navigation.recovery import RecoveryConfig
from mrs_nav.ros.params import private_params

NODE = "rrt_navigation"
_default = functools.partial(node_default, NODE)


def _navigator(values: Mapping[str, Any]) -> NavigatorConfig:
    """The navigator's part of the parameters (move_base's names) as its config."""
    max_linear, max_angular = values["max_vel_x"], values["max_vel_theta"]
    follower = FollowerConfig(
        speed=values["speed"],
        epsilon=values["epsilon"],
        gain=values["gain"],
        max_linear=max_linear,
        max_angular=max_angular,
    )
    approach = ApproachConfig(
        xy_tolerance_m=values["xy_goal_tolerance"],
        yaw_tolerance_rad=values["yaw_goal_tolerance"],
        max_linear=max_linear,
        max_angular=max_angular,
    )
    planner_frequency = values["planner_frequency"]
    if not (math.isfinite(planner_frequency) and planner_frequency >= 0.0):
        raise InvalidInputError(f"~planner_frequency: must be a number >= 0 (0 = off), got {planner_frequency}")
    return NavigatorConfig(
        robot_radius=values["robot_radius"],
        safety_margin_m=values["safety_margin"],
        stop_clearance_m=values["stop_clearance"],
        approach_radius_m=values["approach_radius"],
        allow_unknown=values["allow_unknown"],
        mark_unknown=values["mark_unknown"],
        stray_distance_m=values["stray_distance"],
        replan_period_s=1.0 / planner_frequency if planner_frequency > 0.0 else math.inf,
        improvement_ratio=values["improvement_ratio"],
        max_failed_plans=values["max_failed_plans"],
        retry_delay_s=values["retry_delay"],
        progress_timeout_s=values["progress_timeout"],
        confirm_timeout_s=values["confirm_timeout"],
        map_timeout_s=values["map_timeout"],
        obstacle_range_m=values["obstacle_range"],
        raytrace_range_m=values["raytrace_range"],
        follower=follower,
        approach=approach,
        recovery=RecoveryConfig.from_move_base(
            recovery_behavior_enabled=values["recovery_behavior_enabled"],
            clearing_rotation_allowed=values["clearing_rotation_allowed"],
            recovery_behaviors=_recovery_names(values["recovery_behaviors"]),
            conservative_reset_dist=values["conservative_reset_dist"],
            rotation_speed=max_angular,
        ),
    )


def _marking(values: Mapping[str, Any]) -> MarkingConfig:
    """When scans may mark the costmap (the localisation's confidence), from the parameters."""
    return MarkingConfig(
        max_xy_stddev_m=values["marking_xy_stddev"],
        max_yaw_stddev_rad=values["marking_yaw_stddev"],
        max_tf_gap_m=values["marking_tf_xy_tolerance"],
        max_tf_gap_rad=values["marking_tf_yaw_tolerance"],
    )


@dataclass(frozen=True)
class RrtNavigationConfig:
    """The node's private parameters (defaults: config/rrt_navigation.yaml)."""

    planner: str = _default("planner")
    time_budget_s: float = _default("time_budget")
    max_iterations: int | None = None  # None (~max_iterations 0): the wall-clock budget alone ends a plan
    controller_frequency: float = _default("controller_frequency")
    pose_timeout_s: float = _default("pose_timeout")
    correction_timeout_s: float = _default("correction_timeout")
    correction_freshness_s: float = _default("correction_freshness")
    scan_timeout_s: float = _default("scan_timeout")
    stale_periods: float = _default("stale_periods")  # a hold is warned of after this many scan periods
    # s (sim) to wait for tf at a scan's stamp: the odometry of that instant is on its way with the scan
    transform_tolerance_s: float = _default("transform_tolerance")
    map_frame: str = _default("map_frame")
    odom_frame: str = _default("odom_frame")
    base_frame: str = _default("base_frame")
    seed: int | None = None  # None (~seed < 0): random
    heartbeat: bool = _default("heartbeat")
    navigator: NavigatorConfig = field(default_factory=lambda: _navigator(node_defaults(NODE)))
    marking: MarkingConfig = field(default_factory=lambda: _marking(node_defaults(NODE)))

    def __post_init__(self) -> None:
        if self.planner not in PLANNERS:
            raise InvalidInputError(f"~planner: expected one of {', '.join(PLANNERS)}, got {self.planner!r}")
        for name in ("time_budget_s", "controller_frequency", "pose_timeout_s", "correction_timeout_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"~{name}: must be a positive number, got {value}")
        if self.max_iterations is not None and self.max_iterations < 1:
            raise InvalidInputError(f"~max_iterations: must be >= 1 (0 = no cap), got {self.max_iterations}")
        if not (math.isfinite(self.stale_periods) and self.stale_periods >= 1.0):
            raise InvalidInputError(f"~stale_periods: must be a number >= 1, got {self.stale_periods}")
        for name in ("correction_freshness_s", "scan_timeout_s", "transform_tolerance_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise InvalidInputError(f"~{name}: must be a number >= 0 (0 = off), got {value}")

    @classmethod
    def from_params(cls) -> RrtNavigationConfig:
        """Read the ``~`` parameters (defaults: config/rrt_navigation.yaml)."""
        return cls.from_values(private_params(NODE))

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> RrtNavigationConfig:
        """The config from every parameter of config/rrt_navigation.yaml by name."""
        seed, max_iterations = values["seed"], values["max_iterations"]
        return cls(
            planner=values["planner"],
            time_budget_s=values["time_budget"],
            max_iterations=None if max_iterations == 0 else max_iterations,
            controller_frequency=values["controller_frequency"],
            pose_timeout_s=values["pose_timeout"],
            correction_timeout_s=values["correction_timeout"],
            correction_freshness_s=values["correction_freshness"],
            scan_timeout_s=values["scan_timeout"],
            stale_periods=values["stale_periods"],
            transform_tolerance_s=values["transform_tolerance"],
            map_frame=values["map_frame"],
            odom_frame=values["odom_frame"],
            base_frame=values["base_frame"],
            seed=None if seed < 0 else seed,
            heartbeat=values["heartbeat"],
            navigator=_navigator(values),
            marking=_marking(values),
        )


def _recovery_names(value: Any) -> list[str]:
    """``~recovery_behaviors``: the names of the recoveries in order, as strings or as move_base's
    ``{name: ..., type: ...}`` entries (the name is what counts)."""
    if not isinstance(value, list):
        raise InvalidInputError(f"~recovery_behaviors: expected a list, got {value!r}")
    names = [entry.get("name") if isinstance(entry, dict) else entry for entry in value]
    if not all(isinstance(name, str) for name in names):
        raise InvalidInputError(f"~recovery_behaviors: expected names, got {value!r}")
    return [str(name) for name in names]
