"""The package's layers: a module may import its own folder and lower layers, never a higher one.

The ranks below are the architecture the README's development section describes; a new folder gets a rank here
(the test fails for a folder it does not know), and an import that points up fails with its file and line.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "mrs_nav"

# Lower numbers are lower layers. Folders of one rank do not import each other either.
RANKS: dict[str, int] = {
    # shared types and constants at the bottom
    "errors": 0,
    "geometry": 1,
    "robot": 1,
    "resources": 1,
    "limits": 1,
    "textfiles": 1,
    "atomic_write": 1,
    "jit": 1,
    "clock_jump": 1,
    "master_restart": 1,  # when a node registers again with a restarted roscore (the rule)
    "planning": 2,
    "motion_model": 2,
    "options": 2,
    "tables": 2,
    "ros_processes": 2,
    "config_files": 2,  # every node parameter's default (config/*.yaml)
    "ignored_params": 1,  # gmapping/amcl/move_base parameters the nodes ignore (data)
    "param_aliases": 1,  # move_base's names for the nodes' own parameters
    # the algorithms, each on the layers below it
    "maps": 3,
    "control": 4,
    "sim": 4,
    "fields": 5,
    "trees": 5,
    "slam": 5,
    "bridge": 5,
    "localisation": 5,
    "bag": 6,
    "navigation": 6,
    "stack": 7,
    "replay": 7,
    # front ends
    "figures": 8,
    "bench": 9,
    "cli": 10,
    "ros": 10,
    "ros2": 10,  # the ROS 2 half of ros2_bridge (rclpy, in its own venv; never imports rospy)
    "__main__": 11,
    "__init__": 11,
}


def _unit(module: str) -> str:
    """``mrs_nav.maps.world`` -> ``maps``; ``mrs_nav.errors`` -> ``errors``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _imports(path: Path) -> list[tuple[int, str]]:
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "mrs_nav":
            if node.module == "mrs_nav":
                found += [(node.lineno, f"mrs_nav.{alias.name}") for alias in node.names]
            else:
                found.append((node.lineno, node.module))
        elif isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if a.name.split(".")[0] == "mrs_nav"]
    return found


def test_every_folder_and_module_has_a_layer() -> None:
    units = {p.stem if p.is_file() else p.name for p in PACKAGE.iterdir() if p.suffix == ".py" or p.is_dir()}
    units.discard("__pycache__")
    units.discard("config")  # data, not code: the link to the checkout's config/ that a wheel carries
    assert units - RANKS.keys() == set(), "give the new folder or module a rank in tests/test_layers.py"


def test_no_layer_imports_a_higher_or_sibling_layer() -> None:
    wrong = []
    for path in sorted(PACKAGE.rglob("*.py")):
        relative = path.relative_to(PACKAGE.parent).with_suffix("")
        own = _unit(".".join(relative.parts))
        for line, module in _imports(path):
            target = _unit(module)
            if target in {own, "__init__"} and module != "mrs_nav":
                continue
            if module == "mrs_nav" or target == "__version__":
                continue
            if RANKS[target] >= RANKS[own]:
                where = f"{relative}.py:{line} ({own}, layer {RANKS[own]})"
                wrong.append(f"{where} imports {module} (layer {RANKS[target]})")
    assert wrong == []
