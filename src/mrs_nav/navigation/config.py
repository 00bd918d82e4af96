"""The parameters of a :class:`~mrs_nav.navigation.navigator.Navigator` (shared by its parts)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from mrs_nav.control.goal_approach import ApproachConfig
from mrs_nav.control.path_following import FollowerConfig
from mrs_nav.errors import InvalidInputError
from mrs_nav.navigation.obstacles import OBSTACLE_RANGE_M, RAYTRACE_RANGE_M
from mrs_nav.navigation.recovery import RecoveryConfig
from mrs_nav.robot import BURGER_RADIUS


@dataclass(frozen=True)
class NavigatorConfig:
    """Parameters of :class:`Navigator` (metres, seconds)."""

    robot_radius: float = BURGER_RADIUS
    # Added to the robot radius when inflating the map: the planners keep exactly the inflated distance from
    # obstacles, and the follower's cross-track error and the SLAM pose error eat into it.
    safety_margin_m: float = 0.1
    # Within this distance (m) of the goal the robot leaves the path and drives its axle onto the goal, then
    # turns to the goal heading (control.goal_approach, with the xy / yaw goal tolerances of ``approach``).
    approach_radius_m: float = 0.3
    # A beam return ahead closer than robot_radius + this (m) stops the robot and makes a new plan.
    stop_clearance_m: float = 0.05
    allow_unknown: bool = True
    # Mark laser returns in unknown cells as obstacles (navigation.obstacles): on for a static saved map, whose
    # unknown cells never fill in; off under SLAM, which adds those walls itself.
    mark_unknown: bool = False
    # m from the laser: returns up to obstacle_range_m are marked, beams clear marks up to raytrace_range_m
    # (costmap_2d's obstacle layer; navigation.obstacles)
    obstacle_range_m: float = OBSTACLE_RANGE_M
    raytrace_range_m: float = RAYTRACE_RANGE_M
    stray_distance_m: float = 0.3
    replan_period_s: float = 5.0
    improvement_ratio: float = 0.85
    improvement_min_m: float = 0.2
    max_failed_plans: int = 5
    # Also plan from the robot turned round on the spot and keep the shorter plan: arcs run forward only, so a
    # goal behind the robot otherwise costs a loop.
    plan_turned_round: bool = True
    retry_delay_s: float = 1.0
    progress_m: float = 0.1
    progress_timeout_s: float = 30.0
    map_timeout_s: float = 0.0  # 0 = off: a static map (published once, latched) never refreshes
    # s to hold the robot at a goal reached on a pose in doubt for the localisation to be confident; 0 = fail at once
    confirm_timeout_s: float = 5.0
    follower: FollowerConfig = field(default_factory=FollowerConfig)
    approach: ApproachConfig = field(default_factory=ApproachConfig)
    # what is tried before a goal whose plans keep failing, or that makes no progress, is given up
    recovery: RecoveryConfig = field(default_factory=RecoveryConfig)

    def __post_init__(self) -> None:
        for name in (
            "approach_radius_m",
            "stray_distance_m",
            "improvement_ratio",
            "progress_m",
            "obstacle_range_m",
            "raytrace_range_m",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InvalidInputError(f"navigator {name} must be a positive number, got {value}")
        if not self.replan_period_s > 0.0:  # inf: no periodic replanning (move_base's planner_frequency 0)
            raise InvalidInputError(f"navigator replan_period_s must be > 0 s, got {self.replan_period_s}")
        for name in (
            "robot_radius",
            "safety_margin_m",
            "stop_clearance_m",
            "improvement_min_m",
            "retry_delay_s",
            "progress_timeout_s",
            "map_timeout_s",
            "confirm_timeout_s",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise InvalidInputError(f"navigator {name} must be a number >= 0, got {value}")
        if self.approach_radius_m <= self.approach.xy_tolerance_m:
            raise InvalidInputError(
                f"navigator approach_radius_m ({self.approach_radius_m}) must exceed the xy goal tolerance"
                f" ({self.approach.xy_tolerance_m})"
            )
        if self.max_failed_plans < 1:
            raise InvalidInputError(f"navigator max_failed_plans must be >= 1, got {self.max_failed_plans}")

    @property
    def inflation_m(self) -> float:
        """How far (m) obstacles are grown for planning: the robot radius plus the safety margin."""
        return self.robot_radius + self.safety_margin_m
