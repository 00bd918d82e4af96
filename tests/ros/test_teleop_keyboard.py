"""``rosrun mrs_nav teleop_keyboard`` typed at in a real terminal (tmux send-keys), read on /cmd_vel."""

from __future__ import annotations

import shutil
import subprocess
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.rosharness import RosMaster, wait_for

pytestmark = [
    pytest.mark.ros,
    pytest.mark.skipif(shutil.which("tmux") is None, reason="needs tmux (tools/install.sh installs it)"),
]


class Terminal:
    """A shell in a detached tmux session on a server of its own, at the master of ``env``."""

    def __init__(self, env: dict[str, str]) -> None:
        self.env = env
        self.socket = f"mrs-nav-{uuid.uuid4().hex[:8]}"
        self._tmux("new-session", "-d", "-s", "t", "-x", "100", "-y", "40", "bash --norc --noprofile")

    def _tmux(self, *args: str) -> str:
        done = subprocess.run(
            ["tmux", "-L", self.socket, *args], env=self.env, capture_output=True, text=True, timeout=10, check=True
        )
        return done.stdout

    def type(self, *keys: str) -> None:
        self._tmux("send-keys", "-t", "t", *keys)

    def screen(self) -> str:
        return self._tmux("capture-pane", "-p", "-J", "-t", "t")  # -J: wrapped lines joined, so a text is found whole

    def close(self) -> None:
        subprocess.run(
            ["tmux", "-L", self.socket, "kill-server"], env=self.env, capture_output=True, timeout=10, check=False
        )


@pytest.fixture
def terminal(ros_master: RosMaster) -> Iterator[Terminal]:
    term = Terminal(ros_master.env)
    try:
        yield term
    finally:
        term.close()


@pytest.mark.parametrize("quit_key", ["C-c", "q"])
def test_keys_drive_cmd_vel_and_quitting_stops_the_robot_and_restores_the_terminal(
    ros_master: RosMaster, rospy_node: Any, terminal: Terminal, tmp_path: Path, quit_key: str
) -> None:
    rospy = rospy_node
    from geometry_msgs.msg import Twist

    got: list[tuple[float, float]] = []
    sub = rospy.Subscriber("/cmd_vel", Twist, lambda m: got.append((m.linear.x, m.angular.z)), queue_size=100)
    node = f"/teleop_{quit_key[0].lower()}"
    try:
        terminal.type(f"rosrun mrs_nav teleop_keyboard __name:={node[1:]}", "Enter")
        wait_for(lambda: "Control Your TurtleBot3!" in terminal.screen(), 60.0, "the help text")
        wait_for(lambda: sub.get_num_connections() > 0, 30.0, "the teleop's /cmd_vel")

        def last_is(linear: float, angular: float) -> bool:
            return bool(got) and got[-1] == pytest.approx((linear, angular), abs=1e-9)

        terminal.type("w", "w", "w", "a")
        wait_for(lambda: last_is(0.03, 0.1), 10.0, "0.03 m/s, 0.1 rad/s after w w w a")
        assert "linear vel 0.03" in terminal.screen()
        assert "angular vel 0.1" in terminal.screen()
        terminal.type("x", "d")
        wait_for(lambda: last_is(0.02, 0.0), 10.0, "0.02 m/s, 0 rad/s after x d")
        terminal.type("s")
        wait_for(lambda: last_is(0.0, 0.0), 10.0, "a stop after s")
        terminal.type(*"w" * 30)
        wait_for(lambda: last_is(0.22, 0.0), 20.0, "the Burger's 0.22 m/s after 30 w")
        assert max(linear for linear, _ in got) == pytest.approx(0.22)
        terminal.type(quit_key)
        stty = tmp_path / "stty.txt"
        # the shell gets the keys only once the node has exited and handed the terminal back
        terminal.type(f"stty -a > {stty}", "Enter")
        wait_for(lambda: stty.exists() and "speed" in stty.read_text(), 30.0, "the shell back after the quit key")
    finally:
        sub.unregister()
    assert got[-1] == (0.0, 0.0)  # the last command stops the robot
    settings = stty.read_text().split()
    assert {"icanon", "echo", "isig"} <= set(settings), stty.read_text()  # not -icanon, -echo, -isig
