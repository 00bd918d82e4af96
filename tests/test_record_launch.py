"""launch/record.launch records exactly the topics of a session (the constant the demo's writer and the replay
use), and the launch files that start a session can include it."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from mrs_nav.bag.topics import LOCALISATION_TOPICS, RECORDED_TOPICS
from tests.rosharness import REPO

LAUNCH = REPO / "launch"


def _args(path):
    return {a.get("name"): a.get("default") for a in ET.parse(path).getroot().findall("arg")}


def test_record_launch_topics_are_the_session_topics():
    topics = _args(LAUNCH / "record.launch")["topics"].split()
    assert len(topics) == len(set(topics))
    assert set(topics) == set(RECORDED_TOPICS)


def test_record_launch_runs_debians_rosbag_record_on_those_topics():
    node = ET.parse(LAUNCH / "record.launch").getroot().find("node")
    assert (node.get("pkg"), node.get("type")) == ("rosbag", "record")
    assert "$(arg topics)" in node.get("args")
    assert "-O $(arg bag)" in node.get("args")


def test_session_launch_files_include_recording_on_request():
    for name in ("simulation.launch", "slam.launch", "rrt_navigation.launch", "navigation.launch"):
        path = LAUNCH / name
        if not path.is_file():
            continue  # not on this branch yet
        root = ET.parse(path).getroot()
        includes = [i for i in root.iter("include") if i.get("file", "").endswith("record.launch")]
        passes = any(
            i.get("file", "").endswith(("simulation.launch", "slam.launch"))
            and {a.get("name") for a in i.iter("arg")} >= {"record", "bag"}
            for i in root.iter("include")
        )
        assert [i.get("if") for i in includes] == ["$(arg record)"] or passes, name
        assert _args(path).get("record") == "false", name


def test_demo_writer_records_the_same_topics():
    session = pytest.importorskip("mrs_nav.bag.session", reason="the demo's bag writer is not on this branch")
    # the demo runs SLAM, not the localisation: everything else
    others = {t: m for t, m in RECORDED_TOPICS.items() if t not in LOCALISATION_TOPICS}
    assert others == session.SESSION_TOPICS


def test_a_navigation_session_on_a_saved_map_records_the_localisation():
    assert set(LOCALISATION_TOPICS) == {"/amcl_pose", "/particlecloud"}
    assert set(LOCALISATION_TOPICS) <= set(_args(LAUNCH / "record.launch")["topics"].split())
