"""Private parameters are read as the type of their default, and a wrong kind names the parameter."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.ros.params import _convert, unknown_params_message
from mrs_nav.ros_processes import process
from tests.rosharness import RosMaster, wait_for


def test_numbers_come_as_the_defaults_type() -> None:
    assert _convert("rate", 10, 1.0) == 10.0
    assert isinstance(_convert("rate", 10, 1.0), float)
    assert math.isnan(_convert("goal_x", "nan", math.nan))  # roslaunch's value="nan" arrives as text
    assert _convert("seed", 3, -1) == 3
    assert _convert("lockstep", True, False) is True
    assert _convert("frame", "map", "odom") == "map"


@pytest.mark.parametrize(
    ("value", "default", "match"),
    [
        ("fast", 1.0, "~p: expected a number"),
        (1.5, 0, "~p: expected int"),
        (1, False, "~p: expected bool"),
        (True, 0, "~p: expected int"),
        ("nan", 1.0, "~p: expected a number, got NaN"),
        (3, "odom", "~p: expected str"),
    ],
)
def test_a_wrong_kind_names_the_parameter(value: object, default: object, match: str) -> None:
    with pytest.raises(InvalidInputError, match=match):
        _convert("p", value, default)  # type: ignore[type-var]


def test_rrt_navigation_max_iterations_caps_a_plan_and_a_cap_below_one_is_refused() -> None:
    import numpy as np

    from mrs_nav.geometry import Pose2D
    from mrs_nav.maps.occupancy_grid import OccupancyGrid
    from mrs_nav.navigation.plan_worker import rrt_planner
    from mrs_nav.ros.rrt_navigation_config import RrtNavigationConfig

    config = RrtNavigationConfig(time_budget_s=5.0, max_iterations=40)
    plan = rrt_planner(config.planner, config.time_budget_s, config.max_iterations)
    grid = OccupancyGrid(np.zeros((60, 60), dtype=np.int8), 0.05, (0.0, 0.0, 0.0))
    result = plan(grid, Pose2D(0.5, 0.5, 0.0), (2.5, 2.5), np.random.default_rng(0))  # no path would raise
    assert result.iterations == 40  # the cap, long before the 5 s budget
    with pytest.raises(InvalidInputError, match=r"~max_iterations: must be >= 1 \(0 = no cap\), got -3"):
        RrtNavigationConfig(max_iterations=-3)


@pytest.mark.parametrize(
    ("argument", "message"),
    [
        ("_seed:=4000000000", "ERROR: ~seed: 4000000000 is outside the integers ROS parameters can hold"),
        ("_seed:=-3000000000", "ERROR: ~seed: -3000000000 is outside the integers ROS parameters can hold"),
        ("_seed:=[1,", "ERROR: _seed:=[1,: invalid command-line parameters: while parsing a flow node"),
    ],
)
def test_a_command_line_parameter_the_parameter_server_cannot_hold_is_one_line(
    ros_master: RosMaster, argument: str, message: str
) -> None:
    # rospy raised OverflowError (XML-RPC's 32-bit integers) or ROSInitException from inside init_node
    done = subprocess.run(
        ["rosrun", "mrs_nav", "simulator", "_world:=simple", argument],
        env=ros_master.env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 1
    assert done.stderr.strip().splitlines() == [done.stderr.strip()]
    assert done.stderr.startswith(message)


# rospy's timer divides by the period and a Duration of 1e300 s overflows: the map -> odom thread died and the
# node ran on without it
@pytest.mark.parametrize(
    ("values", "match"),
    [
        ({"transform_publish_period": 1e-300}, r"~transform_publish_period: must lie in \[0.001, 10\] s, got 1e-300"),
        ({"transform_publish_period": 1e300}, r"~transform_publish_period: .* got 1e\+300"),
        ({"transform_tolerance": 1e300}, r"~transform_tolerance: must lie in \[0, 10\] s, got 1e\+300"),
        ({"tf_wait": -1.0}, r"~tf_wait: must lie in \[0, 10\] s"),
    ],
)
def test_localisation_tf_timing_out_of_range_is_refused_at_start_up(values: dict[str, float], match: str) -> None:
    from mrs_nav.localisation import LocalisationConfig
    from mrs_nav.ros.localisation_node import LocalisationNodeConfig

    with pytest.raises(InvalidInputError, match=match):
        LocalisationNodeConfig(filter=LocalisationConfig(), **values)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("values", "match"),
    [
        ({"transform_publish_period": 1e-300}, r"~transform_publish_period: must lie in \[0.001, 10\] s"),
        ({"transform_publish_period": math.nan}, r"~transform_publish_period: .* got nan"),
        ({"tf_wait": 1e300}, r"~tf_wait: must lie in \[0, 10\] s, got 1e\+300"),
    ],
)
def test_slam_tf_timing_out_of_range_is_refused_at_start_up(values: dict[str, float], match: str) -> None:
    from mrs_nav.ros.slam_node import SlamNodeConfig
    from mrs_nav.slam import SlamConfig

    with pytest.raises(InvalidInputError, match=match):
        SlamNodeConfig(slam=SlamConfig(), **values)  # type: ignore[arg-type]


def test_a_filter_parameter_written_with_an_exponent_is_read_as_a_number(ros_master: RosMaster) -> None:
    # rosparam hands "1e+3" (no dot) over as text: it was refused as "expected a number"; now it is read and
    # then held to the alphas' range
    done = subprocess.run(
        ["rosrun", "mrs_nav", "localisation", "_odom_alpha1:=1e+3", "__name:=amcl_exponent"],
        env=ros_master.env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    fatal = [line for line in (done.stdout + done.stderr).splitlines() if "[FATAL]" in line]
    assert done.returncode == 1
    assert len(fatal) == 1
    assert "odom_alpha1: must lie in [0, 10], got 1e+03" in fatal[0]


def test_names_the_file_lacks_are_unknown_or_ignored_with_the_reason() -> None:
    assert unknown_params_message("slam", ["delta", "maxUrange"]) is None
    assert unknown_params_message("slam", ["bogus", "particles", "delta", "typo"]) == (
        "slam: unknown parameters ~bogus, ~typo (not in slam.yaml); ignored. "
        "~particles: mrs_nav SLAM has no particle filter; ignored"
    )
    assert unknown_params_message("tf_filter", ["particles"]) == (
        "tf_filter: unknown parameter ~particles (not in tf_filter.yaml); ignored"
    )


def test_rosrun_slam_with_gmapping_tuning_warns_once_naming_each(ros_master: RosMaster, tmp_path: Path) -> None:
    """``_particles`` and ``_minimumScore`` did nothing without a word, and so did a typo."""
    log = tmp_path / "slam.log"
    args = ["rosrun", "mrs_nav", "slam", "__name:=slam_params", "_particles:=30", "_minimumScore:=50", "_bogus:=1"]
    with process(args, ros_master.env, log):
        wait_for(lambda: "slam: resolution" in log.read_text(), 60.0, "slam started")
    warnings = [line for line in log.read_text().splitlines() if "WARN" in line and "ignored" in line]
    assert len(warnings) == 1, log.read_text()
    assert "unknown parameter ~bogus (not in slam.yaml); ignored" in warnings[0]
    assert "~minimumScore: mrs_nav SLAM matches scans by a correlative search plus ICP" in warnings[0]
    assert "~particles: mrs_nav SLAM has no particle filter; ignored" in warnings[0]


def _apply(given: dict[str, object], **own: object) -> dict[str, object]:
    from mrs_nav.config_files import node_defaults
    from mrs_nav.param_aliases import apply_aliases

    defaults = node_defaults("rrt_navigation")
    return apply_aliases("rrt_navigation", {**defaults, **own}, given, defaults, _convert)


def test_move_base_names_are_read_as_the_nodes_own_and_a_clash_is_one_error() -> None:
    values = _apply({"DWAPlannerROS/max_vel_theta": 2.75, "global_costmap/robot_radius": 0.2})
    assert values["max_vel_theta"] == 2.75
    assert values["robot_radius"] == 0.2
    # the own name at its default (loaded from the YAML) and the alias agreeing with a set own name both pass
    assert _apply({"TrajectoryPlannerROS/xy_goal_tolerance": 0.1}, xy_goal_tolerance=0.1)["xy_goal_tolerance"] == 0.1
    with pytest.raises(InvalidInputError, match=r"~TrajectoryPlannerROS/xy_goal_tolerance \(0.1\) is move_base's "):
        _apply({"TrajectoryPlannerROS/xy_goal_tolerance": 0.1}, xy_goal_tolerance=0.2)
    with pytest.raises(InvalidInputError, match=r"~global_costmap/obstacle_range \(2.0\) and .*both set"):
        _apply({"global_costmap/obstacle_range": 2.0, "local_costmap/obstacle_range": 2.5})
    with pytest.raises(InvalidInputError, match="~DWAPlannerROS/max_vel_x: expected a number"):
        _apply({"DWAPlannerROS/max_vel_x": "fast"})


def test_an_alias_is_known_and_the_rest_of_its_namespace_ignored_with_the_reason() -> None:
    message = unknown_params_message("rrt_navigation", ["DWAPlannerROS/max_vel_x", "controller_frequency"])
    assert message is None
    message = unknown_params_message("rrt_navigation", ["DWAPlannerROS/max_vel_x", "DWAPlannerROS/acc_lim_x"])
    assert message is not None
    assert message.startswith("rrt_navigation: ~DWAPlannerROS: rrt_navigation follows")


def test_a_launched_navigation_node_takes_move_base_tuning(ros_master: RosMaster, tmp_path: Path) -> None:
    """TurtleBot3's DWA file puts max_vel_theta 2.75 under ~DWAPlannerROS: the node drives at that limit now,
    and the same limit given under both names differently stops it with one line."""
    log = tmp_path / "nav.log"
    name = "nav_aliases"
    env = ros_master.env
    for key, value in (("DWAPlannerROS/max_vel_theta", "2.75"), ("global_costmap/robot_radius", "0.2")):
        subprocess.run(["rosparam", "set", f"/{name}/{key}", value], env=env, check=True, timeout=30)
    with process(["rosrun", "mrs_nav", "rrt_navigation", f"__name:={name}"], env, log):
        wait_for(lambda: "max_vel_theta 2.75" in log.read_text(), 60.0, "the node's limits logged")
    assert "robot_radius 0.2" in log.read_text()
    assert "unknown" not in log.read_text()
    subprocess.run(["rosparam", "set", f"/{name}/max_vel_theta", "2.0"], env=env, check=True, timeout=30)
    done = subprocess.run(
        ["rosrun", "mrs_nav", "rrt_navigation", f"__name:={name}"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 1
    fatal = [line for line in (done.stdout + done.stderr).splitlines() if "[FATAL]" in line]
    assert len(fatal) == 1
    assert "~DWAPlannerROS/max_vel_theta (2.75) is move_base's name for ~max_vel_theta, which is set to 2.0" in fatal[0]
