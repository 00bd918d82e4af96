"""The SLAM's internal tuning (loop closure, keyframes): frozen dataclasses whose bad values are refused up front."""

import math

import pytest

from mrs_nav.errors import InvalidInputError
from mrs_nav.slam import Slam
from mrs_nav.slam.keyframes import KeyframeConfig
from mrs_nav.slam.loop_closure import LoopConfig


@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda: LoopConfig(every_m=-1.0), "every_m"),
        (lambda: LoopConfig(far_agrees=(0.2, math.nan)), "far_agrees"),
        (lambda: KeyframeConfig(radius_m=-0.1), "radius_m"),
    ],
)
def test_a_negative_or_nan_setting_is_refused_by_name(make, name):
    with pytest.raises(InvalidInputError, match=rf"setting {name} must be"):
        make()


def test_the_slam_uses_the_tuning_it_is_given():
    slam = Slam(loops=LoopConfig(far_after_m=math.inf), keyframes=KeyframeConfig(scans_kept_per_node=0))
    assert slam.loop_closer.config.far_after_m == math.inf
    assert slam.keyframes.scans_kept_per_node == 0
    assert Slam().loop_closer.config == LoopConfig()  # the defaults are the dataclass's own
