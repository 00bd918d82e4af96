"""Reading a node's private (``~``) parameters, the one place every node does it.

``private_params("slam")`` reads every parameter of ``config/slam.yaml`` (:mod:`mrs_nav.config_files`), each
as the type of its default there, falling back to that default when it is not set: the node's only defaults,
so ``rosrun`` (nothing loaded into ``~``) and ``roslaunch`` (the file loaded) start from the same values.
``private_param("rate", 10.0)`` returns ``~rate`` converted to the type of its default (bool, int, float or
str), or the default when the parameter is not set. A value of the wrong kind (``rate: "fast"``, a float for an
int, anything but a bool for a bool) raises :class:`InvalidInputError` naming the parameter, so a node stops at
start-up with one line instead of carrying a bad value. Ranges are checked by the core configs themselves.

``private_params`` also warns once about the names under the node's ``~`` that its file lacks
(:func:`unknown_params_message`): a typo, or a gmapping/amcl/move_base parameter this stand-in ignores
(:mod:`mrs_nav.ignored_params`, named with the reason), would otherwise do nothing without a word. move_base's
names for the node's own parameters (``~DWAPlannerROS/max_vel_x``: :mod:`mrs_nav.param_aliases`) are read as
those parameters.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any, TypeVar

import rospy

from mrs_nav.config_files import defaults_path, node_defaults
from mrs_nav.errors import InvalidInputError
from mrs_nav.ignored_params import IGNORED
from mrs_nav.param_aliases import ALIASES, apply_aliases

T = TypeVar("T", bool, int, float, str)


def _convert(name: str, value: Any, default: T) -> T:
    # isinstance on the default (bool first: a bool is an int) lets mypy check each branch for its type
    if isinstance(default, bool):
        if isinstance(value, bool):
            return value
    elif isinstance(default, int):
        if isinstance(value, int) and not isinstance(value, bool):
            return value
    elif isinstance(default, float):
        # roslaunch hands ``value="nan"`` over as a string; any text Python reads as a number is one.
        if isinstance(value, (int, float, str)) and not isinstance(value, bool):
            try:
                result = float(value)
            except ValueError:
                raise InvalidInputError(f"~{name}: expected a number, got {value!r}") from None
            if math.isnan(result) and not math.isnan(default):
                raise InvalidInputError(f"~{name}: expected a number, got NaN")
            return result
    elif isinstance(value, str):
        return value
    raise InvalidInputError(f"~{name}: expected {type(default).__name__}, got {value!r}")


def private_param(name: str, default: T) -> T:
    """``~name`` of the calling node as the type of ``default`` (``default`` itself when unset)."""
    if not rospy.has_param(f"~{name}"):
        return default
    return _convert(name, rospy.get_param(f"~{name}"), default)


def private_params(node: str) -> dict[str, Any]:
    """Every parameter of ``node`` (``config/<node>.yaml``): ``~name`` as the type of its default there (lists
    and mappings as given), the default where unset, or the value given under move_base's name for it."""
    given = _given_names()
    message = unknown_params_message(node, given)
    if message is not None:
        rospy.logwarn(message)
    defaults = node_defaults(node)
    values: dict[str, Any] = {}
    for name, default in defaults.items():
        if isinstance(default, bool | int | float | str):
            # read as the default's own type at run time; mypy's constrained type variable takes one type a call
            values[name] = private_param(name, default)  # type: ignore[type-var]
        else:
            values[name] = rospy.get_param(f"~{name}", default)
    aliases = {alias: rospy.get_param(f"~{alias}") for alias in ALIASES.get(node, {}) if alias in given}
    return apply_aliases(node, values, aliases, defaults, _convert)


def _given_names() -> set[str]:
    """The names under the calling node's ``~``, relative to it (``DWAPlannerROS/max_vel_x``)."""
    prefix = rospy.get_name().rstrip("/") + "/"
    return {name[len(prefix) :] for name in rospy.get_param_names() if name.startswith(prefix)}


def unknown_params_message(node: str, given: Iterable[str]) -> str | None:
    """One line naming each of ``given`` (names under the node's ``~``) that ``config/<node>.yaml`` lacks and that
    are no alias of a name it has: those ignored on purpose with the reason, the others as unknown; ``None`` when
    every name is known. A mapping (``DWAPlannerROS/acc_lim_x``) counts by its first name."""
    known, aliases = node_defaults(node), ALIASES.get(node, {})
    ignored = IGNORED.get(node, {})
    first_names = {name.split("/")[0] for name in given if name not in aliases}
    strange = sorted(name for name in first_names if name not in known)
    if not strange:
        return None
    parts = [f"~{name}: {ignored[name]}; ignored" for name in strange if name in ignored]
    unknown = [f"~{name}" for name in strange if name not in ignored]
    if unknown:
        parts.insert(
            0,
            f"unknown parameter{'s' * (len(unknown) > 1)} {', '.join(unknown)} (not in "
            f"{defaults_path(node).name}); ignored",
        )
    return f"{node}: " + ". ".join(parts)
