"""``mrs-nav monitor``: watch a robot, or a whole fleet, through the Zenoh bridge, with no ROS installed.

Needs only eclipse-zenoh and rosbags (``pip install "mrs_nav[monitor]"``): topics are discovered through the
bridge's liveliness tokens, their definitions fetched from its ``@types`` queryable and the messages decoded
with rosbags. With ``--fleet`` every bridge under the prefix (one per robot, joined through a router) is found
and shown in one dashboard and one snapshot; ``--robot`` names the one a goal is for.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from mrs_nav.cli.common import print_json
from mrs_nav.errors import InvalidInputError, MrsNavError
from mrs_nav.limits import MAX_BENCH_S
from mrs_nav.options import number_option, parse_floats
from mrs_nav.textfiles import check_writable

_SECONDS = number_option(0.0, MAX_BENCH_S)
_PERIOD = number_option(0.05, 3600.0)
_TIMEOUT = number_option(0.01, 3600.0)
# ANSI: cursor home + clear screen, for the live redraw on a terminal.
_CLEAR = "\x1b[H\x1b[2J"


def register(subparsers: Any) -> None:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "monitor",
        help="watch a robot through the Zenoh bridge (no ROS needed)",
        description="Connect to a zenoh_bridge, show pose, speed, goal, path, map and per-topic rates and "
        "latencies; optionally draw a snapshot or send a goal.",
    )
    parser.add_argument(
        "--connect",
        action="append",
        required=True,
        metavar="ENDPOINT",
        help="Zenoh endpoint of the bridge or a router, e.g. tcp/127.0.0.1:7447 (repeatable)",
    )
    parser.add_argument(
        "--prefix", default="mrs_nav", help="key prefix of the robot, or with --fleet of all robots (default: mrs_nav)"
    )
    parser.add_argument(
        "--fleet", action="store_true", help="watch every robot whose bridge answers under --prefix (one per robot)"
    )
    parser.add_argument(
        "--robot", default=None, metavar="NAME", help="with --fleet: the robot --send-goal is for (e.g. tb3_1)"
    )
    parser.add_argument(
        "--mode", choices=("peer", "client"), default="peer", help="Zenoh mode (client when the bridge is a router)"
    )
    parser.add_argument(
        "--zenoh-config",
        default="",
        metavar="JSON5",
        help=(
            "Zenoh configuration file: TLS certificates, user and password; --connect and --mode are laid "
            "over it (they replace its endpoints and mode)"
        ),
    )
    parser.add_argument("--once", action="store_true", help="wait for data (see --duration), print once and exit")
    parser.add_argument(
        "--duration",
        type=number_option(0.0, MAX_BENCH_S),
        default=None,
        metavar="S",
        help="run S seconds then exit (with --once: wait S s)",
    )
    parser.add_argument("--period", type=_PERIOD, default=0.5, metavar="S", help="redraw period, s (default 0.5)")
    parser.add_argument("--json", action="store_true", help="print the final dashboard as one JSON object")
    parser.add_argument(
        "--snapshot", type=Path, default=None, metavar="PNG", help="draw map, robot and path into this PNG file"
    )
    parser.add_argument(
        "--send-goal",
        default=None,
        metavar="X,Y,YAW",
        help="ask the bridge to publish this goal (stamped with this machine's clock: the bridge refuses a goal "
        "older than its max_age, 5 s by default, or ahead of its clock by more than 0.5 s; keep the clocks in sync)",
    )
    parser.add_argument("--frame", default="map", help="frame of --send-goal (default: map)")
    parser.add_argument("--timeout", type=_TIMEOUT, default=2.0, metavar="S", help="query timeout, s (default 2)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    # Imported here so that zenoh, rosbags and matplotlib load only when this command runs.
    from mrs_nav.bridge.monitor import RemoteMonitor  # noqa: PLC0415

    if args.robot is not None and not args.fleet:
        raise InvalidInputError("--robot names a robot of a fleet: add --fleet (or give its --prefix alone)")
    goal = parse_floats(args.send_goal, 3, "--send-goal") if args.send_goal else None
    if args.snapshot is not None:
        check_writable(args.snapshot, "--snapshot")
    connect = [e.strip() for item in args.connect for e in item.split(",") if e.strip()]
    if args.fleet:
        return _run_fleet(args, connect, goal)
    with RemoteMonitor(connect, args.prefix, args.timeout, args.mode, args.zenoh_config) as monitor:
        monitor.status()  # no bridge answering: one ERROR line, exit 1
        if goal is not None and not _send_goal(monitor, goal, args.frame):
            return 1
        if goal is not None and args.duration is None and not args.once:
            return 0
        title = f"mrs-nav monitor: {monitor.prefix} via {', '.join(monitor.connect)}"
        summary = _watch(lambda: _summary(monitor), _render_one, title, args)
        if args.snapshot is not None:
            _snapshot({monitor.prefix: monitor}, args.snapshot)
    if args.json:
        print_json(summary)
    return 0


def _run_fleet(args: argparse.Namespace, connect: list[str], goal: tuple[float, ...] | None) -> int:
    from mrs_nav.bridge.fleet import FleetMonitor  # noqa: PLC0415

    with FleetMonitor(connect, args.prefix, args.timeout, args.mode, args.zenoh_config) as fleet:
        if goal is not None:
            if args.robot is None and len(fleet.robots) > 1:
                raise InvalidInputError(f"--send-goal to which robot? add --robot NAME ({', '.join(fleet.robots)})")
            target = fleet.robot(args.robot) if args.robot is not None else next(iter(fleet.robots.values()))
            if not _send_goal(target, goal, args.frame):
                return 1
            if args.duration is None and not args.once:
                return 0
        title = f"mrs-nav monitor: {len(fleet.robots)} robot(s) under {fleet.root!r} via {', '.join(connect)}"
        summary = _watch(
            lambda: {"robots": {name: _summary(m) for name, m in fleet.robots.items()}}, _render_fleet, title, args
        )
        if args.snapshot is not None:
            _snapshot(fleet.robots, args.snapshot)
    if args.json:
        print_json(summary)
    return 0


def _send_goal(monitor: Any, goal: tuple[float, ...], frame: str) -> bool:
    accepted, answer = monitor.send_goal(goal[0], goal[1], goal[2], frame=frame)
    if not accepted:
        print(f"ERROR: goal not sent: {answer}", file=sys.stderr)
        return False
    print(f"goal ({goal[0]:g}, {goal[1]:g}, {goal[2]:g}) sent to {monitor.prefix}: {answer}")
    return True


def _render_one(summary: dict[str, Any], title: str) -> str:
    from mrs_nav.bridge.dashboard import render  # noqa: PLC0415

    return render(summary, title)


def _render_fleet(summary: dict[str, Any], title: str) -> str:
    from mrs_nav.bridge.dashboard import render  # noqa: PLC0415

    return "\n\n".join([title, *(render(s, f"== {name} ==") for name, s in summary["robots"].items())])


def _watch(
    summarise: Callable[[], dict[str, Any]],
    render: Callable[[dict[str, Any], str], str],
    title: str,
    args: argparse.Namespace,
) -> dict[str, Any]:
    """Redraw until the duration is over (forever without one); return the last summary."""
    live = sys.stdout.isatty() and not args.json and not args.once
    start = time.monotonic()
    wait = args.duration if args.duration is not None else (2.0 if args.once else None)
    while True:
        done = wait is not None and time.monotonic() - start >= wait
        summary = summarise()
        if live:
            sys.stdout.write(_CLEAR + render(summary, title) + "\n")
            sys.stdout.flush()
        if done:
            break
        time.sleep(max(0.05, args.period))
    if not live and not args.json:
        print(render(summary, title))
    return summary


def _summary(monitor: Any) -> dict[str, Any]:
    from mrs_nav.bridge.dashboard import summarise  # noqa: PLC0415

    stats = monitor.topics()
    messages: dict[str, Any] = {}
    errors: dict[str, str] = {}
    for topic in ("/odom", "/move_base_simple/goal", "/path", "/map"):
        if topic in stats:
            try:
                msg = monitor.latest(topic)
            except MrsNavError as err:  # one undecodable topic must not blank the whole dashboard
                errors[topic] = str(err)
                continue
            if msg is not None:
                messages[topic] = msg
    summary = summarise(messages, stats, time.monotonic())
    if errors:
        summary["errors"] = errors
    return summary


def _snapshot(monitors: Mapping[str, Any], out: Path) -> None:
    """One PNG: a panel per robot (each robot's map is in its own map frame)."""
    from mrs_nav.bridge.snapshot import RobotView, draw_snapshot  # noqa: PLC0415

    def get(monitor: Any, topic: str) -> Any:
        try:
            return monitor.latest(topic)
        except MrsNavError:
            return None

    views = {
        name: RobotView(get(m, "/map"), get(m, "/odom"), get(m, "/path"), get(m, "/move_base_simple/goal"))
        for name, m in monitors.items()
    }
    draw_snapshot(out, views)
    print(f"snapshot written to {out}", file=sys.stderr)
