"""Every tests/rostest/*.test passes under Debian's rostest (its own master on a free port)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from tests.rosharness import REPO, ros_env

pytestmark = pytest.mark.ros


@pytest.mark.parametrize("test_file", sorted((REPO / "tests" / "rostest").glob("*.test")), ids=lambda p: p.name)
def test_rostest_file_passes(test_file: Path, tmp_path: Path) -> None:
    env = ros_env("http://127.0.0.1:1", tmp_path)  # rostest starts its own master and overrides the URI
    env.pop("ROS_MASTER_URI")
    result = subprocess.run(
        ["rostest", "mrs_nav", test_file.name],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]
    assert "RESULT: SUCCESS" in result.stdout
