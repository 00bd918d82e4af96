"""launch/record.launch records exactly the topics of a session (the constant the demo's writer and the replay
use), and the launch files that start a session can include it."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from mrs_nav.bag import topics as session_topics
from mrs_nav.bag.topics import LOCALISATION_TOPICS, RECORDED_TOPICS, STACK_OUTPUTS
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


def test_recording_leaves_out_what_a_live_stack_publishes_itself():
    """`rosbag play --clock` makes the clock, and the live SLAM, planner and localisation publish their own map,
    path and poses: a recording holding them gave two clocks (time went back) and two maps."""
    recorded = set(_args(LAUNCH / "record.launch")["topics"].split())
    assert recorded.isdisjoint(STACK_OUTPUTS)
    assert {"/clock", "/map", "/path", *LOCALISATION_TOPICS} <= set(STACK_OUTPUTS)
    assert {"/scan", "/odom", "/tf", "/tf_static", "/ground_truth/odom", "/cmd_vel"} <= recorded


def test_demo_writer_records_the_same_topics_and_its_stacks_outputs():
    session = pytest.importorskip("mrs_nav.bag.session", reason="the demo's bag writer is not on this branch")
    # the demo runs SLAM and the planner, not the localisation; their outputs are kept for the replay to compare
    outputs = {session_topics.CLOCK, session_topics.MAP, session_topics.PATH}
    assert {**RECORDED_TOPICS, **{t: STACK_OUTPUTS[t] for t in outputs}} == session.SESSION_TOPICS
