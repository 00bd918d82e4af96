"""bench multi-robot's CPU window: the stack's CPU between the peer's goals and its last outcome."""

from __future__ import annotations

import pytest

from mrs_nav.bench.multi_robot import _CpuSampler
from mrs_nav.ros_processes import RosProcessError


def test_cpu_between_two_instants_covers_the_window_from_the_samples_around_it() -> None:
    sampler = _CpuSampler(launch_pid=0)
    sampler.samples = [
        (10.0, {"simulator": 1.0}),
        (10.25, {"simulator": 1.5, "slam": 0.2}),
        (10.5, {"simulator": 2.0, "slam": 0.4}),
        (10.75, {"simulator": 2.5, "slam": 0.7}),
    ]
    # from the last sample at or before 10.3 (10.25) to the first at or after 10.6 (10.75); a node that started
    # inside the window counts from zero
    assert sampler.between(10.3, 10.6) == pytest.approx({"simulator": 1.0, "slam": 0.5})
    assert sampler.between(10.0, 10.75) == pytest.approx({"simulator": 1.5, "slam": 0.7})
    with pytest.raises(RosProcessError, match="do not cover"):
        sampler.between(9.0, 10.5)
    with pytest.raises(RosProcessError, match="do not cover"):
        sampler.between(10.0, 11.0)
