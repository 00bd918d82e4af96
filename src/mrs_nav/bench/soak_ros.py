"""The ROS soak of ``mrs-nav bench soak``: the product's nodes as separate processes, measured from /proc.

A roscore on a free port, ``roslaunch mrs_nav rrt_navigation.launch real_time_factor:=0 lockstep:=true
rviz:=false`` in the course arena from (-1.5, -1.5) (simulator, SLAM, RRT* navigation and Debian's
robot_state_publisher), and :mod:`mrs_nav.ros.soak_peer` driving the laps and making the clock jump. RRT* plans a
fixed :data:`~mrs_nav.bench.soak.PLAN_ITERATIONS` iterations (a second launch file given to roslaunch sets the
node's ``max_iterations``, with a wall-clock budget far above what they take) rather than for the default
wall-clock budget, which would spend more CPU per plan on a quieter machine and so read a change of load as growth.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mrs_nav.bench.soak_rules import Lap, Usage, jumps_due
from mrs_nav.geometry import Pose2D
from mrs_nav.resources import WORLDS_DIR
from mrs_nav.ros_processes import RosProcessError, process, read_clock, roscore, roslaunch_command
from mrs_nav.tables import markdown_table

#: The mrs_nav nodes of the launch, measured (robot_state_publisher is Debian's, roscore's rosout the master's).
NODES = ("/simulator", "/slam", "/rrt_navigation")
START = Pose2D(-1.5, -1.5, 0.0)
#: Wall s for the peer beyond the requested minutes: the last lap, a slow start.
PEER_MARGIN_S = 1800.0
#: What the nodes must go on publishing after a jump (:class:`mrs_nav.ros.clock_jumper.Activity`'s names).
PUBLISHED = ("map->odom", "/map", "/cmd_vel")
#: Wall-clock cap (s) per plan, far above what the fixed iterations take on a loaded machine.
PLAN_CAP_S = 10.0


@dataclass(frozen=True)
class RosSoak:
    """The laps (usage per node), the clock jumps as the peer recorded them, and the sim seconds driven."""

    laps: list[Lap]
    jumps: list[dict[str, Any]]
    sim_s: float


def planner_overrides(path: Path, iterations: int) -> Path:
    """A launch file setting the navigation node's plan to ``iterations`` iterations (given to roslaunch after
    the main one, whose parameters it overrides)."""
    path.write_text(
        "<launch>\n"
        f'  <param name="/rrt_navigation/max_iterations" value="{iterations}"/>\n'
        f'  <param name="/rrt_navigation/time_budget" value="{PLAN_CAP_S}"/>\n'
        "</launch>\n",
        encoding="utf-8",
    )
    return path


def laps_from_json(data: dict[str, Any]) -> list[Lap]:
    """The peer's laps as :class:`Lap` records."""
    return [
        Lap(
            {node: Usage(int(rss), float(cpu)) for node, (rss, cpu) in lap["usage"].items()},
            lap["scans"],
            lap["reached"],
        )
        for lap in data["laps"]
    ]


def ros_soak(minutes: float, jump_every: float, seed: int, iterations: int) -> RosSoak:
    """Run the ROS soak (see the module's docstring)."""
    with tempfile.TemporaryDirectory(prefix="mrs_nav_soak_") as tmp:
        log_dir = Path(tmp)
        with roscore(log_dir) as env:
            launch = roslaunch_command(
                "rrt_navigation.launch",
                WORLDS_DIR / "simple.world",
                START,
                str(planner_overrides(log_dir / "plan.launch", iterations)),
                "real_time_factor:=0",
                "lockstep:=true",
                "rviz:=false",
                f"seed:={seed}",
            )
            with process(launch, env, log_dir / "launch.log") as proc:
                read_clock(env, timeout=120.0)  # the launch is up and /use_sim_time set before the peer starts
                out = log_dir / "soak.json"
                peer = [sys.executable, "-m", "mrs_nav.ros.soak_peer", "--out", str(out), "--minutes", str(minutes)]
                peer += ["--jump-every", str(jump_every), *(f"--node={node}" for node in NODES)]
                timeout = 60.0 * minutes + PEER_MARGIN_S
                try:
                    done = subprocess.run(peer, env=env, timeout=timeout, check=False)
                except subprocess.TimeoutExpired:
                    raise RosProcessError(f"the soak peer did not end within {timeout:.0f} s") from None
                if done.returncode != 0 or not out.is_file() or proc.poll() is not None:
                    log = (log_dir / "launch.log").read_text(errors="replace")[-800:]
                    raise RosProcessError(f"the ROS soak failed (peer exit {done.returncode}): {log}")
                data = json.loads(out.read_text())
    return RosSoak(laps_from_json(data), data["jumps"], data["sim_s"])


def jumps_section(jumps: list[dict[str, Any]], minutes: float, every_min: float) -> tuple[str, bool]:
    """Markdown: each clock jump, the goal under it, the goal sent again after it and what the nodes published
    from the resumption to that goal's end; whether every scheduled jump happened and was survived."""
    expected = jumps_due(60.0 * minutes, every_min, minutes)
    if not expected and not jumps:
        return "No clock jumps (--clock-jump-every 0).\n\n", True
    rows = [
        [
            i + 1,
            jump["at_min"],
            abs(jump["offset_s"]),
            f"({jump['goal'][0]:g}, {jump['goal'][1]:g})",
            jump["first"],
            jump["after"],
            "-" if jump["error_m"] is None else f"{jump['error_m']:.3f}",
            *(jump["published"].get(what, 0) for what in PUBLISHED),
        ]
        for i, jump in enumerate(jumps)
    ]
    survived = [j["after"] == "SUCCEEDED" and all(j["published"].get(what, 0) > 0 for what in PUBLISHED) for j in jumps]
    header = ["jump", "at (wall min)", "sim clock back by (s)", "goal", "goal under the jump", "same goal sent again"]
    header += ["true distance then (m)", *(f"{what} after" for what in PUBLISHED)]
    return (
        f"Clock jumps: every {every_min:g} wall min the simulator is paused (SIGSTOP), one /clock message 1 s behind "
        "or 10 s / 185 s ahead of it is published and held 1.5 s, and the simulator resumed (SIGCONT): the nodes' "
        "time goes back by 1 s, 10 s or 185 s while a goal is being driven. The goal under the jump ends (ABORTED "
        "is the nodes' answer to a jump back) and is sent again; counts are the messages from the resumption to "
        f"the end of that goal. {len(jumps)} of {expected} scheduled jumps made, {sum(survived)} survived (the goal "
        "after it SUCCEEDED and map->odom, /map and a moving /cmd_vel went on).\n\n"
        + markdown_table(header, rows)
        + "\n\n",
        len(jumps) == expected and all(survived),
    )
