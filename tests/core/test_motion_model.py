import math
from dataclasses import astuple

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.motion_model import IN_PLACE_M, OdometryNoise, apply_motion, decompose, noisy_odometry

coords = st.floats(-20, 20)
angles = st.floats(-math.pi, math.pi)


@given(coords, coords, angles, coords, coords, angles)
def test_decompose_then_apply_returns_the_end_pose(x0, y0, t0, x1, y1, t1):  # noqa: PLR0917
    start, end = Pose2D(x0, y0, t0), Pose2D(x1, y1, t1)
    reached = apply_motion(start, *decompose(start, end))
    assert reached.x == pytest.approx(end.x, abs=1e-6)
    assert reached.y == pytest.approx(end.y, abs=1e-6)
    assert math.cos(reached.yaw - end.yaw) == pytest.approx(1.0, abs=1e-9)


def test_backward_motion_keeps_the_first_rotation_small():
    rot1, trans, _ = decompose(Pose2D(0, 0, 0), Pose2D(-1.0, 0.0, 0.0))
    assert trans == pytest.approx(-1.0)
    assert rot1 == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("drift", [(0.0015, 0.0015), (0.0, -0.003), (-0.002, 0.0)])
def test_a_turn_with_millimetres_of_drift_has_the_noise_of_a_turn_on_the_spot(drift):
    noise = OdometryNoise(0.02, 0.02, 0.02, 0.02)
    start = Pose2D(-6.98, -0.95, -1.19)
    on_the_spot = noise.std_devs(*decompose(start, Pose2D(start.x, start.y, -0.34)))
    drifted = noise.std_devs(*decompose(start, Pose2D(start.x + drift[0], start.y + drift[1], -0.34)))
    assert drifted == pytest.approx(on_the_spot, abs=1e-3)
    assert on_the_spot[2] == pytest.approx(math.sqrt(0.02) * 0.85)  # all of the turn in rot2


def test_a_motion_of_a_centimetre_or_more_keeps_its_first_rotation():
    rot1, trans, rot2 = decompose(Pose2D(0, 0, 0), Pose2D(0.0, IN_PLACE_M, 0.0))
    assert rot1 == pytest.approx(math.pi / 2)
    assert OdometryNoise(1.0, 0.0, 0.0, 0.0).std_devs(rot1, trans, rot2) == pytest.approx((math.pi / 2, 0, math.pi / 2))


TRUTH = [Pose2D(0.5 * i, math.sin(i), 0.3 * i) for i in range(30)]


def test_zero_noise_reproduces_the_truth():
    odom = noisy_odometry(TRUTH, OdometryNoise(0, 0, 0, 0), np.random.default_rng(0))
    for a, b in zip(odom, TRUTH, strict=True):
        assert astuple(a)[:2] == pytest.approx(astuple(b)[:2], abs=1e-9)


def test_noise_is_seeded_and_grows_with_alphas():
    small = OdometryNoise(0.001, 0.001, 0.001, 0.001)
    big = OdometryNoise(0.05, 0.05, 0.05, 0.05)
    a = noisy_odometry(TRUTH, small, np.random.default_rng(7))
    assert a == noisy_odometry(TRUTH, small, np.random.default_rng(7))
    assert a != noisy_odometry(TRUTH, small, np.random.default_rng(8))
    b = noisy_odometry(TRUTH, big, np.random.default_rng(7))

    def drift(odom):
        return math.hypot(odom[-1].x - TRUTH[-1].x, odom[-1].y - TRUTH[-1].y)

    assert drift(b) > drift(a) > 0.0


def test_negative_alphas_are_rejected():
    with pytest.raises(InvalidInputError, match="alphas"):
        OdometryNoise.of([0.1, -0.1, 0.1, 0.1])
