"""One source per node parameter: config/<node>.yaml.

For every node the YAML keys, the parameters the node reads, the config classes' field defaults and the rows of
the generated table in docs/nodes/<node>.md are the same set with the same values (and the table the same
units); ``from_params`` with nothing set gives the YAML's values (rosrun == roslaunch).
"""

from __future__ import annotations

import ast
import dataclasses
import math
import re
import subprocess
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import pytest

from mrs_nav.config_files import NODES, node_defaults, parameter_docs
from mrs_nav.resources import CHECKOUT

ROS_DIR = CHECKOUT / "src" / "mrs_nav" / "ros"
sys.path.insert(0, str(CHECKOUT / "tools"))
import param_docs  # noqa: E402


class _Recorded(Mapping[str, Any]):
    """A mapping that remembers which keys were read by name."""

    def __init__(self, values: Mapping[str, Any]) -> None:
        self._values = dict(values)
        self.read: set[str] = set()

    def __getitem__(self, key: str) -> Any:
        self.read.add(key)
        return self._values[key]

    def __iter__(self) -> Iterator[str]:
        raise AssertionError("read the parameters by name, so that each one is known to be used")

    def __len__(self) -> int:
        return len(self._values)


def _node_values(node: str) -> dict[str, Any]:
    """The YAML's values, with the one a node cannot start without (a world file) filled in."""
    values = dict(node_defaults(node))
    if "world" in values:
        values["world"] = str(CHECKOUT / "worlds" / "simple.world")
    return values


def _builders() -> dict[str, Any]:
    from mrs_nav.ros.potential_field_navigation_node import PotentialFieldNavigationConfig
    from mrs_nav.ros.rrt_navigation_config import RrtNavigationConfig
    from mrs_nav.ros.simulator_node import SimulatorNodeConfig
    from mrs_nav.ros.tf_filter_node import TfFilterConfig

    return {
        "simulator": SimulatorNodeConfig,
        "rrt_navigation": RrtNavigationConfig,
        "potential_field_navigation": PotentialFieldNavigationConfig,
        "tf_filter": TfFilterConfig,
    }


def _default_of(field: dataclasses.Field[Any]) -> Any:
    if field.default_factory is not dataclasses.MISSING:
        return field.default_factory()
    return field.default


@pytest.mark.parametrize("node", ["simulator", "rrt_navigation", "potential_field_navigation", "tf_filter"])
def test_the_node_reads_exactly_its_yaml_keys_and_its_field_defaults_are_the_yaml_values(node: str) -> None:
    config_class = _builders()[node]
    values = _Recorded(_node_values(node))
    config = config_class.from_values(values)  # a key the YAML lacks: KeyError
    assert values.read == set(node_defaults(node)), "YAML keys the node does not read"
    for field in dataclasses.fields(config_class):
        if field.name == "world":  # filled in above
            continue
        if field.default is not dataclasses.MISSING or field.default_factory is not dataclasses.MISSING:
            assert getattr(config, field.name) == _default_of(field), f"{node}: default of {field.name}"


def _core_split(node: str) -> tuple[Any, Any, str]:
    from mrs_nav.localisation import LocalisationConfig
    from mrs_nav.ros.localisation_node import LocalisationNodeConfig
    from mrs_nav.ros.slam_node import SlamNodeConfig
    from mrs_nav.slam import SlamConfig

    return {
        "slam": (SlamNodeConfig, SlamConfig, "slam"),
        "localisation": (LocalisationNodeConfig, LocalisationConfig, "filter"),
    }[node]


@pytest.mark.parametrize("node", ["slam", "localisation"])
def test_the_core_and_node_config_fields_are_the_yaml_keys_with_the_yaml_values(node: str) -> None:
    node_class, core_class, core_field = _core_split(node)
    yaml_values = node_defaults(node)
    own = {f.name: f for f in dataclasses.fields(node_class) if f.name != core_field}
    core = {f.name: f for f in dataclasses.fields(core_class)}
    assert set(own) | set(core) == set(yaml_values)
    assert not set(own) & set(core)
    for name, field in {**own, **core}.items():
        assert field.default == yaml_values[name], f"{node}: default of {name}"
    config = node_class.from_values(yaml_values)
    assert getattr(config, core_field) == core_class()
    assert {name: getattr(config, name) for name in own} == {name: yaml_values[name] for name in own}


def test_the_bridge_config_reads_every_yaml_key_with_the_yaml_values() -> None:
    from mrs_nav.bridge.config import BridgeConfig
    from mrs_nav.errors import InvalidInputError

    values = {k: v for k, v in node_defaults("zenoh_bridge").items() if k != "config_file"}  # the node's own
    assert BridgeConfig.from_mapping(values) == BridgeConfig()
    for name, value in values.items():
        BridgeConfig.from_mapping({name: value})  # an unknown key would be refused
    with pytest.raises(InvalidInputError, match="unknown bridge parameter"):
        BridgeConfig.from_mapping({"no_such_key": 1})


def _subscripted_keys(path: Path) -> set[str]:
    """Constant keys read as ``values["..."]`` or ``private_params(...)["..."]`` in a module."""
    keys = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Subscript) and isinstance(node.slice, ast.Constant):
            base = node.value
            named = isinstance(base, ast.Name) and base.id == "values"
            called = isinstance(base, ast.Call) and getattr(base.func, "id", "") == "private_params"
            if named or called:
                keys.add(node.slice.value)
    return keys


def test_the_map_server_reads_its_yaml_keys() -> None:
    assert _subscripted_keys(ROS_DIR / "map_server_node.py") == set(node_defaults("map_server"))


@pytest.mark.parametrize(
    "path", sorted([*ROS_DIR.glob("*_node.py"), *ROS_DIR.glob("*_config.py")]), ids=lambda p: p.stem
)
def test_nodes_read_parameters_only_through_their_yaml(path: Path) -> None:
    """No literal default left in a node: every ``~`` parameter comes from private_params(NODE), and every key
    a node reads by name is in its YAML."""
    text = path.read_text(encoding="utf-8")
    assert "private_param(" not in text
    assert not re.search(r"get_param\(\s*f?[\"']~[^\"']", text), "a ~parameter read around config/<node>.yaml"
    node = re.search(r'^NODE = "(\w+)"', text, re.MULTILINE)
    if "private_params(" in text or "node_defaults(" in text:
        assert node, f"{path.name}: name its config/<node>.yaml as NODE"
    if node:
        assert _subscripted_keys(path) <= set(node_defaults(node[1]))


def _unit_and_range_ok(doc: Any) -> None:
    assert doc.unit, doc
    assert doc.range, doc
    assert doc.meaning, doc
    if doc.range == "-":
        return
    if "|" in doc.range:
        assert doc.default in doc.range.split("|"), doc
        return
    low, sep, high = doc.range.partition("..")
    assert sep, f"{doc.name}: range {doc.range!r} is not LOW..HIGH, a|b or -"
    if isinstance(doc.default, bool | str):
        return
    for value in doc.default.values() if isinstance(doc.default, dict) else [doc.default]:
        if isinstance(value, float) and math.isnan(value):
            continue
        assert not low or float(low) <= value, doc
        assert not high or value <= float(high), doc


@pytest.mark.parametrize("node", NODES)
def test_every_yaml_parameter_has_a_unit_a_range_and_a_meaning(node: str) -> None:
    docs = parameter_docs(node)
    assert [d.name for d in docs] == list(node_defaults(node))
    for doc in docs:
        _unit_and_range_ok(doc)


def test_the_slam_ranges_are_the_ones_it_checks() -> None:
    from mrs_nav.slam.config import LIMITS

    ranges = {d.name: d.range for d in parameter_docs("slam")}
    for name, (low, high) in LIMITS.items():
        assert ranges[name] == f"{low:g}..{high:g}" or [float(x) for x in ranges[name].split("..")] == [low, high]


def _table_rows(node: str) -> dict[str, tuple[str, str, str]]:
    """``{name: (type, default, unit)}`` of the generated table in docs/nodes/<node>.md."""
    page = (CHECKOUT / "docs" / "nodes" / f"{node}.md").read_text(encoding="utf-8")
    block = page.split(param_docs.begin_marker(node), 1)[1].split(param_docs.END, 1)[0]
    rows = {}
    for line in block.strip().splitlines()[2:]:
        cells = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line)[1:-1]]
        rows[cells[0].strip("`").lstrip("~")] = (cells[1], cells[2].strip("`"), cells[3])
    return rows


@pytest.mark.parametrize("node", NODES)
def test_the_documented_table_has_every_parameter_with_its_default_and_unit(node: str) -> None:
    rows = _table_rows(node)
    docs = {d.name: d for d in parameter_docs(node)}
    assert set(rows) == set(docs)
    for name, doc in docs.items():
        assert rows[name] == (doc.type, param_docs.format_default(doc.default), doc.unit), name


def test_param_docs_check_passes() -> None:
    done = subprocess.run(
        [sys.executable, str(CHECKOUT / "tools" / "param_docs.py"), "--check"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr


@pytest.mark.ros
def test_from_params_with_nothing_set_gives_the_yaml_values(rospy_node: Any) -> None:
    """What rosrun gets (nothing loaded into ~) is what roslaunch gets (the YAML loaded)."""
    from mrs_nav.bridge.config import BridgeConfig
    from mrs_nav.ros.localisation_node import LocalisationNodeConfig
    from mrs_nav.ros.slam_node import SlamNodeConfig
    from mrs_nav.ros.zenoh_bridge_node import load_config

    assert not rospy_node.has_param("~"), "the test node has private parameters"
    assert SlamNodeConfig.from_params() == SlamNodeConfig.from_values(node_defaults("slam"))
    assert LocalisationNodeConfig.from_params() == LocalisationNodeConfig.from_values(node_defaults("localisation"))
    assert load_config() == BridgeConfig()
    for node, config_class in _builders().items():
        values = _node_values(node)
        if "world" in values:
            rospy_node.set_param("~world", values["world"])
        try:
            config = config_class.from_params()
        finally:
            if rospy_node.has_param("~world"):
                rospy_node.delete_param("~world")
        if node == "potential_field_navigation":  # "" means the default file under ROS_HOME
            values["trajectory_file"] = str(config.trajectory_file)
        assert config == config_class.from_values(values), node


@pytest.mark.parametrize("launch", sorted((CHECKOUT / "launch").glob("*.launch")), ids=lambda p: p.name)
def test_launch_files_set_only_parameters_the_node_has(launch: Path) -> None:
    """A <param> the node does not read (a misspelling) would be ignored without a word; a loaded parameter
    file must be the node's own."""
    for node in ElementTree.parse(launch).getroot().iter("node"):
        if node.get("pkg") != "mrs_nav" or node.get("type") not in NODES:
            continue
        name = node.get("type", "")
        unknown = {p.get("name") for p in node.iter("param")} - set(node_defaults(name))
        assert not unknown, f"{launch.name}: {name} does not read {sorted(unknown)}"
        for loaded in node.iter("rosparam"):
            if loaded.get("file"):
                assert loaded.get("file") == f"$(find mrs_nav)/config/{name}.yaml", launch.name


def test_ignored_foreign_parameters_are_for_real_nodes_and_never_ones_they_read() -> None:
    """A gmapping/amcl/move_base name the node starts to read must leave the ignored table (the warning would lie)."""
    from mrs_nav.ignored_params import IGNORED

    assert set(IGNORED) <= set(NODES)
    for node, names in IGNORED.items():
        assert not set(names) & set(node_defaults(node)), node
        assert all(reason and not reason.endswith(".") for reason in names.values()), node


def test_move_base_aliases_name_parameters_the_node_reads_and_are_documented() -> None:
    """Each alias stands for a parameter of the node's YAML, is not itself one, and is in the node's page."""
    from mrs_nav.param_aliases import ALIASES

    assert set(ALIASES) <= set(NODES)
    for node, aliases in ALIASES.items():
        assert set(aliases.values()) <= set(node_defaults(node)), node
        assert not set(aliases) & set(node_defaults(node)), node
        page = (CHECKOUT / "docs" / "nodes" / f"{node}.md").read_text(encoding="utf-8")
        missing = [alias for alias in aliases if f"`~{alias}`" not in page]
        assert not missing, f"docs/nodes/{node}.md lacks {missing}"
