"""move_base's names for parameters mrs_nav's nodes read under their own, and how a value given under one is taken.

A move_base user's tuning arrives under the planners' and costmaps' sub-namespaces (``~DWAPlannerROS/max_vel_x``,
``~global_costmap/robot_radius``, TurtleBot3's ``dwa_local_planner_params_burger.yaml`` loaded into ``~``). Where
such a name means what one of the node's own parameters means, the node reads it as that parameter
(:func:`apply_aliases`); the node's own name and its default stay in ``config/<node>.yaml``, the one source of
defaults. amcl's and gmapping's names are the localisation's and SLAM node's own names, so only rrt_navigation
(move_base) has aliases. The other names under these namespaces are accepted but ignored
(:mod:`mrs_nav.ignored_params`).

A value given under an alias is taken when the node's own name holds its default (the launch files load the
defaults into ``~``, so "set" cannot mean "present"); given under both with different values, or under two aliases
with different values, it is an error naming both, so that no tuning is dropped without a word.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Any

from mrs_nav.errors import InvalidInputError


def _under(namespaces: tuple[str, ...], own: str, *names: str) -> dict[str, str]:
    """``{namespace/name: own}`` for each namespace and each of ``names`` (default: ``own`` itself)."""
    return {f"{namespace}/{name}": own for namespace in namespaces for name in names or (own,)}


_LOCAL_PLANNERS = ("TrajectoryPlannerROS", "DWAPlannerROS")
_COSTMAPS = ("global_costmap", "local_costmap")
# costmap_2d's layered form (plugins) puts the obstacle layer's parameters in its own sub-namespace
_OBSTACLE_LAYERS = (*_COSTMAPS, *(f"{costmap}/obstacle_layer" for costmap in _COSTMAPS))
_RRT_NAVIGATION: dict[str, str] = {
    **_under(_LOCAL_PLANNERS, "xy_goal_tolerance"),
    **_under(_LOCAL_PLANNERS, "yaw_goal_tolerance"),
    **_under(_LOCAL_PLANNERS, "max_vel_x"),
    **_under(_LOCAL_PLANNERS, "max_vel_theta"),
    "DWAPlannerROS/max_rot_vel": "max_vel_theta",  # dwa_local_planner's older name
    **_under(_COSTMAPS, "robot_radius"),
    **_under(_OBSTACLE_LAYERS, "obstacle_range"),
    **_under(_OBSTACLE_LAYERS, "raytrace_range"),
    "global_costmap/global_frame": "map_frame",  # the local costmap's global_frame is odom: not the map frame
    **_under(_COSTMAPS, "base_frame", "robot_base_frame"),
    **_under(("NavfnROS", "GlobalPlanner"), "allow_unknown"),
    "recovery_behaviour_enabled": "recovery_behavior_enabled",  # move_base reads the British spelling too
}

#: ``{node: {alias (relative to the node's ~): the node's own parameter}}``.
ALIASES: Mapping[str, Mapping[str, str]] = MappingProxyType({"rrt_navigation": MappingProxyType(_RRT_NAVIGATION)})


def aliases_of(node: str, name: str) -> list[str]:
    """The aliases of ``node``'s parameter ``name``, in table order."""
    return [alias for alias, target in ALIASES.get(node, {}).items() if target == name]


def apply_aliases(
    node: str,
    values: Mapping[str, Any],
    given: Mapping[str, Any],
    defaults: Mapping[str, Any],
    convert: Callable[[str, Any, Any], Any],
) -> dict[str, Any]:
    """``values`` (the node's own names) with each parameter given under an alias in ``given`` (``{alias: raw
    value}``) taken from there, converted by ``convert(alias, raw, default)``; an alias whose value disagrees with
    another alias's or with the own name's when that is off its default raises InvalidInputError naming both."""
    result = dict(values)
    taken: dict[str, tuple[str, Any]] = {}  # own name -> (alias, value) taken for it
    for alias, target in ALIASES.get(node, {}).items():
        if alias not in given:
            continue
        value = convert(alias, given[alias], defaults[target])
        if target in taken and taken[target][1] != value:
            other, other_value = taken[target]
            raise InvalidInputError(
                f"~{other} ({other_value!r}) and ~{alias} ({value!r}) both set {node}'s ~{target}: give one value"
            )
        own = values[target]
        if own != defaults[target] and own != value:
            raise InvalidInputError(
                f"~{alias} ({value!r}) is move_base's name for ~{target}, which is set to {own!r}: give one of them"
            )
        taken[target] = (alias, value)
        result[target] = value
    return result
