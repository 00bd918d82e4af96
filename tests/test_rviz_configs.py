"""The rviz configurations shipped with the launch files: each parses, and every topic a display shows is one a node
of the stack publishes (a typo would leave a display silently empty); the 2D Pose Estimate and 2D Nav Goal tools
publish where the nodes listen. Each shipped launch's rviz shows only topics that launch publishes (a Map display
on a topic nobody publishes sits in a warning state: slam.launch's Costmap did), and opens framed on the world it
simulates (the office did not fit at the old fixed 60 px/m centred on (0, 0))."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from mrs_nav.maps.view import RENDER_PX, bounds_of, framed_config, framing
from tests.rosharness import REPO

CONFIGS = sorted((REPO / "rviz").glob("*.rviz"))
# Every topic name a node of the stack uses appears as a string literal in its node module.
NODE_SOURCES = "\n".join(p.read_text() for p in (REPO / "src" / "mrs_nav" / "ros").glob("*.py"))


def _topics(tree: Any, strip: bool = True) -> Iterator[str]:
    """Every ``Topic:`` in the tree, without a robot namespace (``/tb3_1/map`` -> ``/map``, multi_robot.rviz)
    unless ``strip`` is false."""
    if isinstance(tree, dict):
        for key, value in tree.items():
            if key == "Topic" and isinstance(value, str):
                yield re.sub(r"^/tb3_\d+/", "/", value) if strip else value
            else:
                yield from _topics(value, strip)
    elif isinstance(tree, list):
        for item in tree:
            yield from _topics(item, strip)


def test_every_launch_file_names_a_shipped_config() -> None:
    named = {m for p in (REPO / "launch").glob("*.launch") for m in re.findall(r"rviz/([\w.]+\.rviz)", p.read_text())}
    assert named
    assert named <= {p.name for p in CONFIGS}


@pytest.mark.parametrize("config", CONFIGS, ids=lambda p: p.name)
def test_each_topic_is_one_the_stack_uses(config: Path) -> None:
    manager = yaml.safe_load(config.read_text())["Visualization Manager"]
    displayed = set(_topics(manager["Displays"]))
    assert displayed
    tools = set(_topics(manager["Tools"])) - {"/clicked_point"}  # rviz's Publish Point: for the user's own nodes
    assert tools <= {"/initialpose", "/move_base_simple/goal"}
    for topic in displayed | tools:
        name = topic.lstrip("/")
        assert f'"{name}"' in NODE_SOURCES or f'"/{name}"' in NODE_SOURCES, f"{config.name}: {topic} is used by no node"


# What each node publishes that a display could show (relative names, under the node's namespace).
PUBLISHED = {
    "simulator": ("clock", "odom", "scan", "ground_truth/odom", "joint_states"),
    "slam": ("map", "map_metadata"),
    "map_server": ("map", "map_metadata"),
    "localisation": ("amcl_pose", "particlecloud"),
    "rrt_navigation": ("path", "move_base/global_costmap/costmap"),
}
LAUNCHES = [
    ("simulation.launch", "headless:=false"),
    ("slam.launch",),
    ("rrt_navigation.launch",),
    ("navigation.launch",),
    ("navigation.launch", "navigation:=false"),
    ("multi_robot.launch",),
    ("multi_robot.launch", "robots:=2"),
    ("multi_robot.launch", "robots:=1", f"map_file:={REPO}/maps/simple.yaml"),
]


def _loaded(launch: str, args: tuple[str, ...], monkeypatch: pytest.MonkeyPatch) -> Any:
    """The launch as Debian's roslaunch reads it (includes and arguments resolved), without starting anything."""
    import roslaunch.config

    monkeypatch.setenv("ROS_PACKAGE_PATH", str(REPO))
    return roslaunch.config.load_config_default([(str(REPO / "launch" / launch), list(args))], None, verbose=False)


def _published(config: Any) -> set[str]:
    """Every topic a node of the loaded launch publishes, resolved (namespace, the simulator's robots, remaps)."""
    topics = set()
    for node in config.nodes:
        if node.package != "mrs_nav" or node.type not in PUBLISHED:
            continue
        prefixes = [""]
        robots = config.params.get(f"{node.namespace}{node.name}/robots")
        if node.type == "simulator" and robots is not None and str(robots.value).strip():
            prefixes = [f"tb3_{i}/" for i in range(len(str(robots.value).split(";")))]
        remaps = dict(node.remap_args)
        for prefix in prefixes:
            for name in PUBLISHED[node.type]:
                relative = remaps.get(prefix + name, prefix + name)
                topics.add(relative if relative.startswith("/") else node.namespace + relative)
    return topics


def _rviz_args(config: Any) -> list[str]:
    (rviz,) = [node for node in config.nodes if node.name == "rviz"]
    return str(rviz.args).split()


@pytest.mark.parametrize("launch", LAUNCHES, ids=" ".join)
def test_each_launch_shows_only_what_it_publishes(launch: tuple[str, ...], monkeypatch: pytest.MonkeyPatch) -> None:
    config = _loaded(launch[0], launch[1:], monkeypatch)
    args = _rviz_args(config)
    rviz_config = Path(args[args.index("-d") + 1])
    # as rviz_if_display hands it to rviz: the displays named by --drop left out
    dropped = [args[i + 1] for i, arg in enumerate(args) if arg == "--drop"]
    manager = yaml.safe_load(framed_config(rviz_config.read_text(), None, dropped))["Visualization Manager"]
    published = _published(config) | set(_topics(manager["Tools"], strip=False))  # rviz's tools publish theirs
    unpublished = {
        (display.get("Name"), topic)
        for display in _enabled_displays(manager["Displays"])
        for topic in _topics(display, strip=False)
        if topic not in published
    }
    assert not unpublished, f"{' '.join(launch)}: {rviz_config.name} shows what nothing publishes: {unpublished}"


def _enabled_displays(displays: list[Any]) -> Iterator[Any]:
    """The enabled displays, those inside enabled groups too."""
    for display in displays:
        if not display.get("Enabled", True):
            continue
        if display.get("Class") == "rviz/Group":
            yield from _enabled_displays(display.get("Displays", []))
        else:
            yield display


@pytest.mark.parametrize("launch", LAUNCHES, ids=" ".join)
def test_each_launch_opens_rviz_framed_on_its_world_with_the_robot_well_inside(
    launch: tuple[str, ...], monkeypatch: pytest.MonkeyPatch
) -> None:
    config = _loaded(launch[0], launch[1:], monkeypatch)
    args = _rviz_args(config)
    assert "--frame" in args, f"{launch[0]}: rviz is not framed on the world"
    bounds = bounds_of(Path(args[args.index("--frame") + 1]))
    view = framing(bounds)
    half_w, half_h = RENDER_PX[0] / 2 / view.scale, RENDER_PX[1] / 2 / view.scale
    xmin, ymin, xmax, ymax = bounds
    assert view.x - half_w <= xmin
    assert xmax <= view.x + half_w
    assert view.y - half_h <= ymin
    assert ymax <= view.y + half_h
    for x, y in _starts(config):
        assert abs(x - view.x) < 0.9 * half_w, f"start x {x} at the window's edge"
        assert abs(y - view.y) < 0.9 * half_h, f"start y {y} at the window's edge"


def _starts(config: Any) -> list[tuple[float, float]]:
    """The simulated robots' start positions (``~robots`` "x y yaw; ...", else ``~x``, ``~y``)."""
    robots = config.params.get("/simulator/robots")
    if robots is not None and str(robots.value).strip():
        return [(float(p.split()[0]), float(p.split()[1])) for p in str(robots.value).split(";")]
    return [(float(config.params["/simulator/x"].value), float(config.params["/simulator/y"].value))]


@pytest.mark.parametrize("world", sorted((REPO / "worlds").glob("*.world")), ids=lambda p: p.name)
def test_every_shipped_world_fits_the_window_at_a_scale_that_fills_it(world: Path) -> None:
    xmin, ymin, xmax, ymax = bounds_of(world)
    view = framing((xmin, ymin, xmax, ymax))
    shown = (RENDER_PX[0] / view.scale, RENDER_PX[1] / view.scale)
    assert shown[0] >= xmax - xmin
    assert shown[1] >= ymax - ymin
    # filled: the world takes most of the shorter side (not a speck in the middle)
    assert max((xmax - xmin) / shown[0], (ymax - ymin) / shown[1]) > 0.7
    framed = yaml.safe_load(framed_config((REPO / "rviz" / "mrs_nav.rviz").read_text(), view))
    current = framed["Visualization Manager"]["Views"]["Current"]
    assert (current["X"], current["Y"], current["Scale"]) == (view.x, view.y, view.scale)
    assert current["Target Frame"] == "<Fixed Frame>"


def test_rviz_if_display_hands_rviz_a_framed_copy_without_the_dropped_displays(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """What rviz is started on: the config's copy under $ROS_HOME/rviz framing the office, the robots that do
    not run left out; a world that cannot be read leaves the config as it is, with one line."""
    import importlib.machinery
    import importlib.util

    loader = importlib.machinery.SourceFileLoader("rviz_if_display", str(REPO / "scripts" / "rviz_if_display"))
    spec = importlib.util.spec_from_loader("rviz_if_display", loader)
    assert spec is not None
    script = importlib.util.module_from_spec(spec)
    loader.exec_module(script)
    monkeypatch.setenv("ROS_HOME", str(tmp_path))
    config = REPO / "rviz" / "multi_robot.rviz"
    office = REPO / "worlds" / "office.world"
    args = ["-d", str(config), "--frame", str(office), "--drop", "tb3_2", "--drop", "saved_map", "__name:=rviz"]
    assert script.adapted(args) == ["-d", str(tmp_path / "rviz" / "multi_robot.rviz"), "__name:=rviz"]
    manager = yaml.safe_load((tmp_path / "rviz" / "multi_robot.rviz").read_text())["Visualization Manager"]
    assert [d["Name"] for d in manager["Displays"]] == ["Grid", "tb3_0", "tb3_1"]
    view = framing(bounds_of(office))
    assert manager["Views"]["Current"]["Scale"] == view.scale
    assert script.adapted(["-d", str(config), "--frame", str(tmp_path / "none.world")]) == ["-d", str(config)]
