"""Ctrl-C, SIGTERM or SIGHUP unwind a command: its temporary folder is removed and it says so in one line."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.rosharness import REPO

BAG = REPO / "tests" / "data" / "bags" / "office.bag"


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_killed_replay_removes_its_temporary_folder(tmp_path: Path, signum: signal.Signals) -> None:
    # An unindexed copy, so that replay rebuilds it inside its temporary folder before the SLAM run.
    data = bytearray(BAG.read_bytes())
    at = data.index(b"index_pos=") + len(b"index_pos=")
    data[at : at + 8] = bytes(8)
    active = tmp_path / "office.bag.active"
    active.write_bytes(bytes(data))
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    env = {**os.environ, "TMPDIR": str(scratch), "PYTHONPATH": str(REPO / "src")}
    command = [sys.executable, "-m", "mrs_nav", "replay", str(active), "--slam", "--out", str(tmp_path / "out")]
    with subprocess.Popen(command, env=env, stderr=subprocess.PIPE, text=True) as process:
        deadline = time.monotonic() + 60.0
        while not any(scratch.glob("mrs_nav_replay_*/*.salvaged.bag")) and time.monotonic() < deadline:
            assert process.poll() is None, process.stderr.read() if process.stderr else ""
            time.sleep(0.05)
        assert any(scratch.glob("mrs_nav_replay_*")), "replay never made its temporary folder"
        process.send_signal(signum)
        _, err = process.communicate(timeout=60)
    assert process.returncode == 130
    assert err.strip().splitlines()[-1] == f"ERROR: interrupted ({signum.name})"
    assert list(scratch.iterdir()) == []
    assert active.read_bytes() == bytes(data)  # the input is never written
