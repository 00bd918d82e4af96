"""Every shell command shown in README.md and docs/, and what runs it.

``tests/test_docs.py`` extracts each command from the ```sh/```bash/```shell/```console blocks and looks it up here
(after collapsing blanks and dropping comments). A command in the docs that is missing here fails, and so does an
entry here that no page shows any more, or that names a test that does not exist. Kinds:

- ``Run``: the docs test runs it itself, in a scratch folder holding copies of ``worlds/`` and ``maps/`` and the
  regression bags under ``tests/data/bags`` (the commands of one page run in order, in one folder, so a later
  command may read what an earlier one wrote), or in the checkout (``cwd="checkout"``); it must exit 0.
- ``Covered``: an existing test runs it, or what it starts, in the form the test gives (named ``file::function``).
- ``Parsed``: ``mrs-nav``'s own parser accepts it (the options exist and their values are valid); not run, for
  the reason given.
- ``Manual``: needs something no test here has (a display for rviz, the user's robot or network, root); the reason
  says what.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Run:
    cwd: str = "scratch"  # or "checkout"


@dataclass(frozen=True)
class Covered:
    test: str  # tests/<file>.py::<function>
    how: str = ""  # how the test's form differs from the command, when it does


@dataclass(frozen=True)
class Parsed:
    why: str


@dataclass(frozen=True)
class Manual:
    why: str


Entry = Run | Covered | Parsed | Manual

_BENCH = "a benchmark of minutes that rewrites bench/RESULTS.md"
_ROBOT = "needs a robot (or a simulation) reachable at the placeholder address"
_SLAM = "tests/ros/test_slam_node.py::test_map_and_pose_while_driving"
_SAVED_MAP = "tests/ros/test_navigation_saved_map.py::test_slam_then_saved_map_then_goals_in_other_rooms"
_FLEET = "tests/ros/test_zenoh_fleet.py::test_multi_robot_launch_with_a_router_is_one_fleet"
_FLEET_MONITOR = (
    "tests/ros/test_zenoh_fleet.py::test_monitor_finds_every_robot_behind_the_router_and_commands_the_one_it_names"
)
_TLS = "tests/ros/test_zenoh_network.py::test_secured_bridge_as_the_robots_router"

_PLAY_RECIPE = "tests/ros/test_recording.py::test_a_recording_plays_into_live_slam_the_standard_way"

_ROS2 = "tests/ros/test_ros2_bridge.py::test_a_ros2_node_receives_odom_scan_map_and_tf"
_ROS2_GOAL = "tests/ros/test_ros2_bridge.py::test_a_ros2_goal_pose_drives_the_robot_there"
_ROS2_ACTION = "tests/ros/test_ros2_bridge.py::test_a_navigate_to_pose_goal_is_reached_with_feedback"
_ROS2_ROBOTS = (
    "tests/ros/test_ros2_multi_robot.py::test_each_robot_is_under_its_namespace_on_ros2_and_takes_its_own_goal"
)

COMMANDS: dict[str, Entry] = {
    # README.md
    "make demo": Manual("installs Debian packages with apt as root; the two commands it then runs are run here"),
    "make test": Manual("installs Debian packages with apt as root, then runs every test; .ci/run runs it in CI"),
    "source env.sh": Run(cwd="checkout"),
    "mrs-nav --help": Run(),
    "mrs-nav plan --world worlds/simple.world --planner rrt_star --start -1.5,-1.5,0 --goal 1.5,1.5 "
    "--png rrt.png": Run(),
    "mrs-nav plan --world worlds/simple.world --planner potential_field --start -1.5,-1.5,0 --goal 1.5,1.5 "
    "--json": Run(),  # README.md and docs/cli/plan.md
    "mrs-nav figures --out demo_out/figures --seed 0": Run(),
    "mrs-nav demo --out demo_out --json": Run(),
    "mrs-nav replay demo_out/session.bag --slam --out replay_out --json": Run(),
    "roslaunch mrs_nav slam.launch": Covered(_SLAM, "headless (rviz:=false) at real_time_factor:=0"),
    "roslaunch mrs_nav rrt_navigation.launch": Covered(
        "tests/ros/test_rrt_navigation_slam.py::test_the_arena_goal_is_reached_on_the_slam_map_without_contact",
        "headless, at max rate in lockstep; the test publishes the 2D Nav Goal rviz would",
    ),
    # docs/tutorials/ros2.md, docs/nodes/ros2_bridge.md
    "MRS_NAV_ROS2=1 make install": Manual("installs Debian packages with apt as root; make test makes the ROS 2 venv"),
    "roslaunch mrs_nav ros2_bridge.launch": Covered(_ROS2, "on a domain of the test's own"),
    "roslaunch mrs_nav ros2_bridge.launch domain_id:=7 allow_inbound:=[/goal_pose]": Covered(
        _ROS2_GOAL, "on a domain of the test's own"
    ),
    "roslaunch mrs_nav multi_robot.launch robots:=2 ros2:=true ros2_domain_id:=7 "
    "ros2_allow_inbound:=[/navigate_to_pose]": Covered(_ROS2_ROBOTS, "on a domain of the test's own, at max rate"),
    "roslaunch mrs_nav ros2_bridge.launch domain_id:=7 allow_inbound:=[/navigate_to_pose]": Covered(
        _ROS2_ACTION, "on a domain of the test's own"
    ),
    "roslaunch mrs_nav ros2_bridge.launch domain_id:=7 allow_inbound:=[/goal_pose,/initialpose]": Covered(
        _ROS2_GOAL, "on a domain of the test's own, with /goal_pose allowed"
    ),
    "roslaunch mrs_nav ros2_bridge.launch namespace:=tb3_0 node_name:=ros2_bridge_tb3_0 domain_id:=7": Covered(
        _ROS2_ROBOTS, "multi_robot.launch ros2:=true starts it so in each robot's namespace"
    ),
    # docs/ros.md
    "cd ~/catkin_ws && catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 && source devel/setup.bash": Manual(
        "builds in the user's own catkin workspace"
    ),
    # docs/cli/
    "mrs-nav bench --help": Run(),
    "mrs-nav bench potential-field": Parsed(_BENCH),
    "mrs-nav bench planners": Parsed(_BENCH),
    "mrs-nav bench slam": Parsed(_BENCH),
    "mrs-nav bench slam-sweep --log a.log.gz --log b.log.gz --grid maxUrange=10,30 --grid delta=0.05,0.1": Parsed(
        "needs the user's logs; tests/core/bench/test_slam_sweep.py sweeps two small logs by a grid"
    ),
    "mrs-nav bench navigation --seeds 20": Parsed(_BENCH),
    "mrs-nav bench bridge --duration 60 --floors 10": Parsed(_BENCH),
    "mrs-nav bench fleet --robots 3 --duration 30": Parsed(_BENCH),
    "mrs-nav bench ros2 --duration 90": Parsed(_BENCH),
    "mrs-nav carmen2bag ../shared/data/intel-corrected.log.gz intel.bag": Covered(
        "tests/core/cli/test_carmen2bag_replay.py::test_carmen2bag_then_replay", "on an excerpt of the same log"
    ),
    "mrs-nav replay intel.bag --slam --out intel_out --relations ../shared/data/intel.relations --json": Covered(
        "tests/core/slam/eval/test_relations.py::test_replay_scores_relations_on_a_converted_log"
    ),
    "mrs-nav carmen2bag --help": Run(),
    'mrs-nav demo --world office --goals "2,-2;-7.5,3.5" --out demo_out/office': Covered(
        "tests/core/stack/test_demo.py::test_a_goal_in_another_room_of_the_office_is_reached",
        "the first of the two goals, with an iteration budget",
    ),
    "mrs-nav demo --help": Run(),
    "mrs-nav figures --help": Run(),
    'pip install "mrs_nav[monitor]"': Covered(
        "tests/ros/test_zenoh_network.py::test_the_monitor_from_a_wheel_in_a_fresh_venv", "from the package's wheel"
    ),
    "mrs-nav monitor --connect tcp/ROBOT:7447": Parsed(_ROBOT + "; the dashboard runs until stopped"),
    "mrs-nav monitor --connect tcp/ROBOT:7447 --once --json": Covered(
        "tests/ros/test_zenoh_bridge_simulation.py::test_the_monitor_sees_the_simulated_robot_drive"
    ),
    "mrs-nav monitor --connect tcp/ROBOT:7447 --duration 5 --snapshot robot.png": Covered(
        "tests/ros/test_zenoh_bridge.py::test_a_late_joiner_gets_the_latched_map", "with --once"
    ),
    "mrs-nav monitor --connect tcp/ROBOT:7447 --send-goal 1.5,0.5,0": Covered(
        "tests/ros/test_zenoh_bridge.py::test_an_allowed_remote_goal_reaches_ros"
    ),
    "mrs-nav monitor --connect tls/ROBOT:7447 --mode client --zenoh-config operator.json5": Covered(_TLS),
    "mrs-nav monitor --help": Run(),
    "mrs-nav plan --circles '[[0, 0.25, 0.3], [0, -0.25, 0.3]]' --start -1.5,0 --goal 1.5,0 --seed 7": Run(),
    "mrs-nav plan --map maps/simple.yaml --planner rrt_star --start -1.5,-1.5,0 --goal 1.5,1.5 --json": Run(),
    "mrs-nav plan --world worlds/simple.world --planner rrt --start -1.5,-1.5,0 --goal 1.5,1.5 --png rrt.png": Run(),
    "python -m mrs_nav.maps.rasterize worlds/simple.world maps/simple.yaml": Run(),
    "mrs-nav plan --help": Run(),
    "mrs-nav replay tests/data/bags/simple.bag --slam --out replay_out --json": Run(),
    "mrs-nav replay --help": Run(),
    "mrs-nav replay tests/data/bags --out runs/": Covered(
        "tests/core/replay/test_batch.py::test_report_holds_each_bag_to_its_golden"
    ),
    "mrs-nav replay a.bag b.bag c.bag --workers 2 --slam": Covered(
        "tests/core/replay/test_batch.py::test_local_workers_give_byte_identical_outputs"
    ),
    "mrs-nav replay /data/sessions --cluster tcp://scheduler:8786": Covered(
        "tests/core/replay/test_batch.py::test_a_two_worker_dask_cluster_gives_the_serial_result",
        "on a local two-worker cluster",
    ),
    "mrs-nav router --help": Run(),
    # docs/nodes/
    "roslaunch mrs_nav potential_field_navigation.launch goal_x:=1.5 goal_y:=1.5": Covered(
        "tests/ros/test_potential_field_navigation.py::test_the_course_arena_goal_is_reached_without_contact",
        "at max rate in lockstep",
    ),
    "roslaunch mrs_nav simulation.launch": Covered(
        "tests/ros/test_simulator_node.py::test_scan_odom_tf_and_clock_arrive_at_their_rates_in_sim_time",
        "at real_time_factor:=0",
    ),
    "roslaunch mrs_nav simulation.launch world:=$(rospack find mrs_nav)/worlds/office.world x:=-5 y:=-5": Covered(
        "tests/ros/test_simulator_pacing.py::test_real_time_factor_paces_sim_time_against_the_wall_clock",
        "world:=office (the bare name) at real_time_factor:=2",
    ),
    "roslaunch mrs_nav simulation.launch real_time_factor:=0 headless:=false": Manual(
        "headless:=false starts rviz: needs a display"
    ),
    "roslaunch mrs_nav rrt_navigation.launch real_time_factor:=0 lockstep:=true": Covered(
        "tests/ros/test_rrt_navigation_slam.py::test_the_arena_goal_is_reached_on_the_slam_map_without_contact",
        "rviz:=false",
    ),
    "roslaunch mrs_nav slam.launch world:=$(rospack find mrs_nav)/worlds/office.world x:=-5 y:=-5 rviz:=false": Covered(
        _SAVED_MAP, "at real_time_factor:=4"
    ),
    "roslaunch mrs_nav slam.launch sim:=false play:=$HOME/mrs_nav_session.bag rviz:=false": Covered(
        "tests/ros/test_slam_play.py::test_a_recorded_session_is_mapped_live_with_only_the_live_map_and_correction"
    ),
    "roslaunch mrs_nav slam.launch sim:=false use_sim_time:=false": Manual(
        "a real robot's driver publishes /scan and /odom"
    ),
    "roslaunch mrs_nav zenoh_bridge.launch": Covered(
        "tests/ros/test_zenoh_bridge.py::test_bytes_arrive_unchanged_and_decode_with_rosbags",
        "listening on a free port",
    ),
    "roslaunch mrs_nav zenoh_bridge.launch connect:=tcp/ROUTER:7447 config_file:=my_bridge.yaml": Covered(
        "tests/ros/test_zenoh_bridge.py::test_an_allowed_remote_goal_reaches_ros", "the test's router; allow_goal:=true"
    ),
    "roslaunch mrs_nav zenoh_bridge.launch mode:=router listen:=tls/0.0.0.0:7447 zenoh_config:=robot.json5": Covered(
        _TLS, "on 127.0.0.1 with the test's certificates"
    ),
    # docs/tutorials/
    "openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days 365 -subj /CN=robot-ca "
    "-addext basicConstraints=critical,CA:TRUE -keyout ca.key -out ca.pem": Run(),
    "for name in robot operator; do\n"
    "openssl req -new -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -subj /CN=$name -keyout $name.key "
    "-out $name.csr\n"
    "printf 'subjectAltName=IP:192.168.1.20\\nextendedKeyUsage=serverAuth,clientAuth\\n' > $name.ext\n"
    "openssl x509 -req -in $name.csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 365 -extfile $name.ext "
    "-out $name.pem\n"
    "done": Run(),
    "printf 'operator:CHANGE-ME\\nviewer:CHANGE-ME-TOO\\n' > users.txt": Run(),
    "roslaunch mrs_nav zenoh_bridge.launch mode:=router listen:=tls/0.0.0.0:7447 zenoh_config:=$PWD/robot.json5 "
    "config_file:=$PWD/bridge.yaml": Covered(_TLS, "on 127.0.0.1 with the test's certificates"),
    "mrs-nav monitor --connect tls/192.168.1.20:7447 --mode client --zenoh-config operator.json5 "
    "--send-goal 1,0.5,0": Covered(_TLS),
    "roslaunch mrs_nav slam.launch world:=$(rospack find mrs_nav)/worlds/office.world x:=-5 y:=-5": Covered(
        _SAVED_MAP, "rviz is left out where there is no display"
    ),
    "rosrun mrs_nav map_saver -f ~/office": Covered(_SAVED_MAP),
    "rosrun mrs_nav teleop_keyboard": Covered(
        "tests/ros/test_teleop_keyboard.py::test_keys_drive_cmd_vel_and_quitting_stops_the_robot_and_restores_the_terminal",
        "typed into a tmux terminal",
    ),
    "roslaunch mrs_nav navigation.launch map_file:=$HOME/office.yaml "
    "world:=$(rospack find mrs_nav)/worlds/office.world x:=-5 y:=-5": Covered(_SAVED_MAP, "at max rate in lockstep"),
    "rosservice call /global_localization": Covered(
        "tests/ros/test_localisation_node.py::test_global_localization_service_converges_within_60_s_and_60_updates",
        "the service called through rospy",
    ),
    "roslaunch mrs_nav multi_robot.launch robots:=3": Manual(
        "three robots with rviz: needs a display (tests run two, headless)"
    ),
    "roslaunch mrs_nav multi_robot.launch robots:=2 real_time_factor:=0 lockstep:=true rviz:=false": Covered(
        "tests/ros/test_multi_robot.py::test_two_robots_with_crossing_goals_reach_them_without_contact"
    ),
    "mrs-nav router --listen tls/0.0.0.0:7447 --zenoh-config router.json5": Covered(
        "tests/core/cli/test_router.py::test_clients_of_the_router_reach_each_other_and_sigterm_stops_it",
        "on 127.0.0.1 over tcp; the TLS configuration as tests/ros/test_zenoh_network.py makes it",
    ),
    "roslaunch mrs_nav zenoh_bridge.launch mode:=client listen:= connect:=tcp/ROUTER:7447 namespace:=tb3_0 "
    "node_name:=zenoh_bridge_tb3_0": Covered(_FLEET_MONITOR, "three namespaces on one master, the test's router"),
    "roslaunch mrs_nav multi_robot.launch robots:=3 zenoh_router:=tcp/ROUTER:7447 allow_goal:=true": Covered(
        _FLEET, "two robots, headless"
    ),
    "mrs-nav monitor --connect tcp/ROUTER:7447 --mode client --fleet --snapshot fleet.png": Covered(
        _FLEET_MONITOR, "with --once"
    ),
    "mrs-nav monitor --connect tcp/ROUTER:7447 --mode client --fleet --robot tb3_1 --send-goal 1.5,0.5,0": Covered(
        _FLEET_MONITOR
    ),
    "mrs-nav replay tests/data/bags/office.bag --slam --out office_map --json": Run(),
    "roslaunch mrs_nav record.launch bag:=$HOME/mrs_nav_session.bag": Covered(
        "tests/test_record_launch.py::test_record_launch_runs_debians_rosbag_record_on_those_topics"
    ),
    "roslaunch mrs_nav simulation.launch record:=true bag:=$HOME/mrs_nav_session.bag": Covered(
        _PLAY_RECIPE, "with real_time_factor:=0, driving by /cmd_vel"
    ),
    "roslaunch mrs_nav slam.launch sim:=false": Covered(_PLAY_RECIPE, "with rviz:=false (no display)"),
    "rosbag play --clock $HOME/mrs_nav_session.bag": Covered(_PLAY_RECIPE),
    "mrs-nav replay robot.bag --slam --scan-topic /base_scan --base-frame base_link --out robot_map": Covered(
        "tests/core/replay/test_foreign_bags.py::test_topics_and_frames_are_options_with_gmappings_names",
        "a gmapping-tutorial bag with /base_scan, also with --odom-frame",
    ),
    "mrs-nav replay $HOME/mrs_nav_session.bag --slam --out my_map --json": Covered(
        "tests/ros/test_recording.py::test_closed_recording_replays", "a bag recorded by record.launch"
    ),
    "mrs-nav replay $HOME/mrs_nav_session.bag --slam --out my_map_10m --param maxUrange=10 --param delta=0.1": Covered(
        "tests/core/slam/test_config_limits.py::test_extreme_replay_params_are_one_error_line",
        "--param read and checked",
    ),
}
