"""Process figures from Linux /proc (mrs_nav.ros_processes) that the benches report."""

import numpy as np

from mrs_nav.ros_processes import resident_bytes


def test_resident_bytes_sees_memory_taken():
    before = resident_bytes()
    block = np.ones(64 * 1024 * 1024 // 8)  # 64 MB written
    assert resident_bytes() - before > 48 * 1024 * 1024
    del block
