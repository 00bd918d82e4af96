"""The one source of every node parameter's default: ``config/<node>.yaml``.

Each node's file holds all its private parameters. The launch files load it into the node's ``~``; the node's
``from_params`` reads every key of it as the parameter's default (so ``rosrun``, with nothing loaded, gets the
same values); and the core config classes take their field defaults from it, so the CLI, replay and benchmarks
start from the same values too.

Every parameter line carries a comment in one machine-readable format, from which ``tools/param_docs.py``
writes the node's parameter table in ``docs/nodes/<node>.md``::

    name: default  # [unit] (range) meaning
                   # further lines of the meaning (comment-only lines, indented)

``unit`` is ``-`` for none (names, switches, counts, ratios); ``range`` is ``LOW..HIGH`` (either end may be
left out), ``a|b|c`` (the accepted words) or ``-`` (anything of the type). Comment lines at column 0 are free
text.
"""

from __future__ import annotations

import functools
import re
import types
from collections.abc import Mapping
from pathlib import Path
from typing import Any, NamedTuple

import yaml

from mrs_nav.errors import InvalidInputError
from mrs_nav.resources import CONFIG_DIR

#: The nodes whose parameters live in ``config/<node>.yaml``.
NODES = (
    "simulator",
    "slam",
    "localisation",
    "rrt_navigation",
    "potential_field_navigation",
    "zenoh_bridge",
    "ros2_bridge",
    "map_server",
    "tf_filter",
)

_KEY_LINE = re.compile(r"^(?P<name>[A-Za-z_]\w*):(?P<value>.*)$")
_DOC = re.compile(r"\s#\s*\[(?P<unit>[^\]]*)\]\s*\((?P<range>[^)]*)\)\s*(?P<meaning>.*)$")
_CONTINUATION = re.compile(r"^\s+#\s?(?P<text>.*)$")


class ParameterDoc(NamedTuple):
    """One parameter as its node's YAML documents it: name, default, unit, range, meaning."""

    name: str
    default: Any
    unit: str
    range: str
    meaning: str

    @property
    def type(self) -> str:
        """The ROS parameter type the node reads: that of the default."""
        kinds = {bool: "bool", int: "int", float: "double", str: "string", list: "list", dict: "dict"}
        return kinds.get(type(self.default), type(self.default).__name__)


def defaults_path(node: str) -> Path:
    if node not in NODES:
        raise InvalidInputError(f"no parameter file for node {node!r}; nodes: {', '.join(NODES)}")
    return CONFIG_DIR / f"{node}.yaml"


@functools.cache
def _text(node: str) -> str:
    path = defaults_path(node)
    try:
        return path.read_text(encoding="utf-8")
    except OSError as err:
        raise InvalidInputError(f"cannot read the {node} defaults {path}: {err.strerror or err}") from None


@functools.cache
def node_defaults(node: str) -> Mapping[str, Any]:
    """``{parameter: default}`` of ``node`` (read-only; lists and mappings as YAML gives them)."""
    try:
        values = yaml.safe_load(_text(node))
    except yaml.YAMLError as err:
        raise InvalidInputError(f"{node} defaults {defaults_path(node)}: {err}") from None
    if not isinstance(values, dict):
        raise InvalidInputError(f"{node} defaults {defaults_path(node)}: expected a mapping of parameters")
    return types.MappingProxyType(values)


def node_default(node: str, name: str) -> Any:
    """The default of parameter ``name`` of ``node``; a name the file lacks is an error naming both."""
    values = node_defaults(node)
    if name not in values:
        raise InvalidInputError(f"{node} defaults {defaults_path(node)} lack {name}")
    return values[name]


def parameter_docs(node: str) -> list[ParameterDoc]:
    """Every parameter of ``node`` in file order with its unit, range and meaning; a parameter line without
    the ``# [unit] (range) meaning`` comment is an error naming it."""
    values = node_defaults(node)
    found: list[tuple[str, str, str, list[str]]] = []  # name, unit, range, lines of the meaning
    continues = False
    for number, line in enumerate(_text(node).splitlines(), start=1):
        key = _KEY_LINE.match(line)
        more = _CONTINUATION.match(line)
        if key:
            doc = _DOC.search(key["value"])
            if doc is None:
                raise InvalidInputError(
                    f"{defaults_path(node)}:{number}: {key['name']} lacks its '# [unit] (range) meaning' comment"
                )
            found.append((key["name"], doc["unit"].strip(), doc["range"].strip(), [doc["meaning"].strip()]))
            continues = True
        elif continues and more:
            found[-1][3].append(more["text"].strip())
        else:
            continues = False
    return [
        ParameterDoc(name, values[name], unit, span, " ".join(filter(None, text))) for name, unit, span, text in found
    ]
