"""Parameters of gmapping, amcl and move_base that mrs_nav's nodes accept but do not use, and why.

A user's tuning of the ROS node a mrs_nav node stands in for arrives under the same private namespace; these names
are not errors (the launch files and tutorials users bring set them) but do nothing here, so each node names them
once at start-up with the reason (:func:`mrs_nav.ros.params.unknown_params_message`). Names a node does use live in
its ``config/<node>.yaml`` (or are move_base's names for them: :mod:`mrs_nav.param_aliases`, read, not ignored); a
name must not be in both (``tests/core/test_ignored_params.py``).
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

_NO_PARTICLES = "mrs_nav SLAM has no particle filter"
_MATCHER = "mrs_nav SLAM matches scans by a correlative search plus ICP (search_linear, search_angular)"
_LIKELIHOOD = "mrs_nav SLAM scores scans on a likelihood field (sigma)"
_LOCAL_PLANNER = (
    "rrt_navigation follows its plan with its own controller (speed, epsilon, gain); of the local planner's names"
    " it reads xy_goal_tolerance, yaw_goal_tolerance, max_vel_x, max_vel_theta"
)
_COSTMAP = (
    "rrt_navigation keeps one obstacle grid; of the costmap's names it reads robot_radius, obstacle_range,"
    " raytrace_range, global_frame, robot_base_frame"
)
_GLOBAL_PLANNER = "the global planner is chosen with planner (rrt_star|rrt); of its names allow_unknown is read"
#: ``{node: {parameter: reason it is ignored}}`` for the stand-ins of gmapping, amcl and move_base.
IGNORED: Mapping[str, Mapping[str, str]] = MappingProxyType(
    {
        "slam": MappingProxyType(
            {
                "particles": _NO_PARTICLES,
                "resampleThreshold": _NO_PARTICLES,
                "minimumScore": _MATCHER,
                "iterations": _MATCHER,
                "lstep": _MATCHER,
                "astep": _MATCHER,
                "kernelSize": _MATCHER,
                "lsigma": _LIKELIHOOD,
                "ogain": _LIKELIHOOD,
                "lskip": "mrs_nav SLAM matches every beam in range",
                "llsamplerange": _NO_PARTICLES,
                "llsamplestep": _NO_PARTICLES,
                "lasamplerange": _NO_PARTICLES,
                "lasamplestep": _NO_PARTICLES,
                "throttle_scans": "mrs_nav SLAM processes every scan that passes linearUpdate/angularUpdate",
                "occ_thresh": "the map is published as log-odds turned into 0..100 (lfree, loccupied, lmax)",
            }
        ),
        "localisation": MappingProxyType(
            {
                "odom_model_type": "the localisation has one motion model (differential drive, odom_alpha1..4)",
                "odom_alpha5": "the localisation has no omnidirectional motion model",
                "laser_model_type": "the localisation has one laser model (likelihood field)",
                "laser_z_short": "the likelihood-field model has no short-reading term",
                "laser_z_max": "the likelihood-field model has no max-range term",
                "laser_lambda_short": "the likelihood-field model has no short-reading term",
                "do_beamskip": "the localisation does not skip beams by agreement",
                "beam_skip_distance": "the localisation does not skip beams by agreement",
                "beam_skip_threshold": "the localisation does not skip beams by agreement",
                "beam_skip_error_threshold": "the localisation does not skip beams by agreement",
                "gui_publish_rate": "the particle cloud is published after every update",
                "first_map_only": "the localisation takes every map it receives",
                "selective_resampling": "resampling follows resample_interval and the effective sample size",
                "tf_broadcast": "the localisation always publishes map->odom",
            }
        ),
        "rrt_navigation": MappingProxyType(
            {
                "base_global_planner": "the global planner is chosen with planner (rrt_star|rrt)",
                "base_local_planner": _LOCAL_PLANNER,
                "controller_patience": "a stalled robot is caught by progress_timeout",
                "planner_patience": "a failing planner is caught by max_failed_plans",
                "max_planning_retries": "a failing planner is caught by max_failed_plans",
                "oscillation_timeout": "a stalled robot is caught by progress_timeout",
                "oscillation_distance": "a stalled robot is caught by progress_timeout",
                "shutdown_costmaps": "rrt_navigation keeps its obstacle grid while idle",
                "make_plan_clear_costmap": "rrt_navigation plans on the map as it is",
                "make_plan_add_unreachable_goal": "rrt_navigation plans on the map as it is",
                "DWAPlannerROS": _LOCAL_PLANNER,
                "TrajectoryPlannerROS": _LOCAL_PLANNER,
                "NavfnROS": _GLOBAL_PLANNER,
                "GlobalPlanner": _GLOBAL_PLANNER,
                "global_costmap": _COSTMAP,
                "local_costmap": _COSTMAP,
            }
        ),
    }
)
