"""The ODE simulator: driving accuracy, contacts with walls, the watchdog, limits and determinism."""

from __future__ import annotations

import gc
import math
from pathlib import Path

import numpy as np
import pytest

from mrs_nav.errors import InvalidInputError, WorldFileError
from mrs_nav.geometry import Pose2D, wrap_angle
from mrs_nav.maps.world import Box, World, load_world
from mrs_nav.sim import LaserParams, Simulator, SimulatorConfig
from mrs_nav.sim.commands import Twist2D

START = Pose2D(-1.5, -1.5, 0.0)


@pytest.fixture(scope="module")
def arena(simple_world: Path) -> World:
    return load_world(simple_world)


@pytest.fixture(scope="module")
def simple_world() -> Path:
    return Path(__file__).resolve().parents[3] / "worlds" / "simple.world"


def drive(sim: Simulator, v: float, omega: float, seconds: float) -> None:
    """Hold a command for ``seconds`` (re-sent every step, as a 100 Hz controller would), then stop."""
    for _ in range(round(seconds * sim.config.physics_rate)):
        sim.set_command(v, omega)
        sim.step()
    sim.set_command(0.0, 0.0)
    sim.run(1.0)


def test_one_metre_at_0_2_m_per_s_ends_within_2_cm(arena: World) -> None:
    sim = Simulator(arena, start=START)
    drive(sim, 0.2, 0.0, 5.0)
    end = sim.ground_truth()
    assert math.hypot(end.x - (START.x + 1.0), end.y - START.y) < 0.02
    assert sim.ground_truth_twist().v == pytest.approx(0.0, abs=1e-3)
    # no slip on a flat floor: the wheel odometry agrees with the truth
    odom = sim.odometry().pose
    assert math.hypot(odom.x - end.x, odom.y - end.y) < 0.005
    assert sim.contacts.events == 0


def test_full_turn_in_place_returns_within_2_degrees(arena: World) -> None:
    sim = Simulator(arena, start=START)
    drive(sim, 0.0, math.pi / 4.0, 8.0)
    end = sim.ground_truth()
    assert abs(math.degrees(wrap_angle(end.yaw - START.yaw))) < 2.0
    assert math.hypot(end.x - START.x, end.y - START.y) < 0.01


def test_driving_into_a_wall_never_passes_it_and_counts_one_contact(arena: World) -> None:
    sim = Simulator(arena, start=Pose2D(1.0, -1.0, 0.2))
    radius = sim.config.robot.footprint_radius
    deepest = -math.inf
    for _ in range(1500):
        sim.set_command(0.22, 0.0)
        sim.step()
        deepest = max(deepest, sim.ground_truth().x + radius - 2.0)  # inner face of the east wall at x = 2
    assert deepest < 0.005  # a few mm of soft contact at most
    assert sim.contacts.events == 1
    assert sim.contacts.in_contact
    assert sim.contacts.steps > 500
    assert sim.contacts.obstacles == {"model[arena_walls]/link[wall_east]/collision[collision]"}
    assert sim.chassis_height == pytest.approx(0.1025, abs=0.005)  # still upright on the floor
    # the wheels spin against the wall: odometry overshoots, as on the real robot
    assert sim.odometry().pose.x > sim.ground_truth().x + 0.5


@pytest.mark.parametrize(("v", "omega"), [(0.22, 0.0), (0.0, 2.84), (0.22, 2.84)])
def test_watchdog_stops_the_robot_within_half_a_second_of_the_last_command(
    arena: World, v: float, omega: float
) -> None:
    sim = Simulator(arena, start=START)
    sim.set_command(v, omega)
    sim.run(1.0)  # at full speed
    sim.set_command(v, omega)  # the last command
    last = sim.time
    sim.run(0.25)
    assert not sim.watchdog_stopped
    sim.run(0.1)
    assert sim.watchdog_stopped
    while sim.time < last + 0.5:
        sim.step()
    twist = sim.ground_truth_twist()
    assert abs(twist.v) < 0.01  # m/s
    assert abs(twist.omega) < 0.05  # rad/s
    assert sim.command == Twist2D()


def test_commands_are_clamped_to_the_burger_limits_and_ramped(arena: World) -> None:
    sim = Simulator(arena, start=START)
    clamped = sim.set_command(1.0, -5.0)
    assert (clamped.v, clamped.omega) == (0.22, -2.84)
    sim.step()
    limits = sim.config.robot
    assert sim.command.v == pytest.approx(limits.max_linear_accel * sim.config.dt)
    assert sim.command.omega == pytest.approx(-limits.max_angular_accel * sim.config.dt)
    with pytest.raises(InvalidInputError, match="finite"):
        sim.set_command(math.nan, 0.0)


def test_same_seed_same_run_and_another_seed_other_noise(arena: World) -> None:
    def run(seed: int) -> tuple[Pose2D, Pose2D, np.ndarray]:
        sim = Simulator(arena, SimulatorConfig(seed=seed, odom_noise=0.02), START)
        scans = []
        for i in range(300):
            sim.set_command(0.2, 0.8 * math.sin(i / 50.0))
            scan = sim.step()
            if scan is not None:
                scans.append(scan.ranges)
        return sim.ground_truth(), sim.odometry().pose, np.array(scans)

    truth_a, odom_a, scans_a = run(3)
    truth_b, odom_b, scans_b = run(3)
    assert truth_a == truth_b
    assert odom_a == odom_b
    assert np.array_equal(scans_a, scans_b)
    truth_c, odom_c, scans_c = run(4)
    assert truth_c == truth_a  # physics is noise-free: only the sensors differ
    assert odom_c != odom_a
    assert not np.array_equal(scans_c, scans_a)


def test_odometry_noise_makes_drift_and_the_truth_stays_apart(arena: World) -> None:
    sim = Simulator(arena, SimulatorConfig(odom_noise=0.05, seed=1), START)
    drive(sim, 0.2, 0.3, 6.0)
    odom, truth = sim.odometry().pose, sim.ground_truth()
    assert math.hypot(odom.x - truth.x, odom.y - truth.y) > 0.002
    assert sim.odometry().stamp == sim.time


def test_scans_come_at_the_laser_rate_with_exact_stamps(arena: World) -> None:
    sim = Simulator(arena, start=START)
    scans = sim.run(2.0)
    assert [s.stamp for s in scans] == pytest.approx([0.2 * k for k in range(1, 11)])
    assert sim.time == pytest.approx(2.0)


def test_start_inside_an_obstacle_is_refused(arena: World) -> None:
    with pytest.raises(InvalidInputError, match=r"overlaps model\[cylinder\]"):
        Simulator(arena, start=Pose2D(0.3, 0.2, 0.0))


def test_configuration_errors_are_named() -> None:
    with pytest.raises(InvalidInputError, match="whole multiple"):
        SimulatorConfig(physics_rate=100.0, laser=LaserParams(rate=7.0))
    with pytest.raises(InvalidInputError, match="physics rate"):
        SimulatorConfig(physics_rate=0.0)


def test_a_world_with_an_unsupported_element_fails_naming_file_and_element(tmp_path: Path) -> None:
    bad = tmp_path / "bad.world"
    bad.write_text(
        '<sdf version="1.6"><world name="w"><model name="ball"><static>true</static><link name="l">'
        '<collision name="c"><geometry><sphere><radius>1</radius></sphere></geometry></collision>'
        "</link></model></world></sdf>"
    )
    with pytest.raises(WorldFileError, match=r"bad\.world: <model\[ball\]/link\[l\]/collision\[c\]/geometry/sphere>"):
        Simulator(load_world(bad))
    bad.write_text('<sdf version="1.6"><world name="w"><model name="m">')
    with pytest.raises(WorldFileError, match=r"bad\.world: malformed XML"):
        load_world(bad)


def test_a_world_built_in_code_is_held_to_the_shape_limit() -> None:
    boxes = tuple(Box(f"b{i}", i % 100, i // 100, 0.25, 0.0, 0.5, 0.5, 0.5) for i in range(2001))
    with pytest.raises(InvalidInputError, match="2001 boxes and cylinders, above the limit of 2000"):
        Simulator(World("many", boxes, ()))
    with pytest.raises(InvalidInputError, match="more than 1000 m out"):
        Simulator(World("empty", (), ()), start=Pose2D(1e6, 0.0, 0.0))


def test_a_simulator_is_freed_by_its_reference_count_not_the_cycle_collector(arena: World) -> None:
    # In a reference cycle the collector may clear pyode's objects before they deallocate: a JointGroup then
    # raised an ignored TypeError at the end of test sessions. Nothing of a used simulator may be cyclic garbage.
    # Only the simulator's own objects are looked for among the garbage: a thread another test left running may
    # make cycles of its own in the meantime (85 objects once, in a full run on a loaded machine).
    Simulator(arena, SimulatorConfig(seed=1), START).step()  # compiled kernels, caches
    gc.collect()
    gc.disable()
    gc.set_debug(gc.DEBUG_SAVEALL)
    try:
        sim = Simulator(arena, SimulatorConfig(seed=1), START)
        for _ in range(30):
            sim.step()
        del sim
        gc.collect()
        ours = [type(o).__qualname__ for o in gc.garbage if type(o).__module__.split(".")[0] in {"ode", "mrs_nav"}]
        assert ours == []
    finally:
        gc.set_debug(0)
        gc.garbage.clear()
        gc.enable()
