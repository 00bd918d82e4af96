"""The rviz configurations shipped with the launch files: each parses, and every topic a display shows is one a node
of the stack publishes (a typo would leave a display silently empty); the 2D Pose Estimate and 2D Nav Goal tools
publish where the nodes listen."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.rosharness import REPO

CONFIGS = sorted((REPO / "rviz").glob("*.rviz"))
# Every topic name a node of the stack uses appears as a string literal in its node module.
NODE_SOURCES = "\n".join(p.read_text() for p in (REPO / "src" / "mrs_nav" / "ros").glob("*.py"))


def _topics(tree: Any) -> Iterator[str]:
    """Every ``Topic:`` in the tree, without a robot namespace (``/tb3_1/map`` -> ``/map``, multi_robot.rviz)."""
    if isinstance(tree, dict):
        for key, value in tree.items():
            if key == "Topic" and isinstance(value, str):
                yield re.sub(r"^/tb3_\d+/", "/", value)
            else:
                yield from _topics(value)
    elif isinstance(tree, list):
        for item in tree:
            yield from _topics(item)


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
