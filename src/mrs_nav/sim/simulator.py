"""The simulator: Burger-like robots in a world, stepped at a fixed rate, with laser, odometry and contacts.

One step advances sim time by ``1 / physics_rate`` seconds: each robot's command limiter turns its last
(v, omega) into wheel-rate targets, ODE steps all bodies together, each robot's wheel odometry integrates what
its hinges turned, contacts with obstacles and other robots are counted per robot, and every
``physics_rate / laser.rate``-th step each robot takes a scan (stamped at exact multiples of the laser period;
the other robots are in it). Sim time is ``steps / physics_rate``, never an accumulated float. Given the same
world, configuration, start poses, seed and command sequences, two simulators produce identical states,
odometry and scans.

:class:`MultiRobotSimulator` hosts any number of robots (:class:`SimulatedRobot` each); :class:`Simulator` is
the one-robot API on top of it. Robot ``i`` draws its laser and odometry noise from the ``2i``-th and
``2i+1``-th children of the seed, so the first robot of a fleet sees exactly what a lone robot would.

No ROS here: the ROS node (``mrs_nav.ros.simulator_node``), the benchmarks and offline scenarios all drive
this class.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D, wrap_angle
from mrs_nav.limits import MAX_COORDINATE_M, MAX_SHAPES
from mrs_nav.maps.world import Box, World
from mrs_nav.sim.commands import CommandLimiter, Twist2D
from mrs_nav.sim.laser import Laser, LaserParams, Scan
from mrs_nav.sim.odometry import Odometry, WheelOdometry
from mrs_nav.sim.physics import Physics, RobotBody, WheelState
from mrs_nav.sim.robot import BurgerParams


@dataclass(frozen=True)
class SimulatorConfig:
    """Robot, laser, fixed physics rate (Hz), extra odometry noise (fraction of wheel travel) and seed."""

    robot: BurgerParams = field(default_factory=BurgerParams)
    laser: LaserParams = field(default_factory=LaserParams)
    physics_rate: float = 100.0
    odom_noise: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.physics_rate) and self.physics_rate > 0.0):
            raise InvalidInputError(f"physics rate must be positive, got {self.physics_rate}")
        ratio = self.physics_rate / self.laser.rate
        if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-6:
            raise InvalidInputError(
                f"physics rate {self.physics_rate} Hz must be a whole multiple of the laser rate {self.laser.rate} Hz"
            )

    @property
    def dt(self) -> float:
        """The fixed physics step (s)."""
        return 1.0 / self.physics_rate

    @property
    def steps_per_scan(self) -> int:
        return round(self.physics_rate / self.laser.rate)


@dataclass(frozen=True)
class ContactStats:
    """Contacts between a robot and obstacles (or other robots, named as such) since the start.

    ``events`` counts contacts begun: a step touching after at least ``CONTACT_GAP`` s without touching (a
    robot pushing against a wall bounces in and out of contact from step to step; that is one collision, not
    dozens). ``steps`` counts the steps spent touching, ``obstacles`` names every obstacle ever touched and
    ``in_contact`` is the state after the last step.
    """

    events: int = 0
    steps: int = 0
    obstacles: frozenset[str] = frozenset()
    in_contact: bool = False


CONTACT_GAP = 0.25  # s without touching before a new touch counts as a new contact event


@dataclass
class _StepClock:
    """Sim time as the count of physics steps taken at ``rate`` Hz; calling it gives the time (s)."""

    rate: float
    steps: int = 0

    def __call__(self) -> float:
        return self.steps / self.rate


class SimulatedRobot:
    """One robot of a :class:`MultiRobotSimulator`: its commands, wheel odometry, laser and contacts."""

    def __init__(
        self,
        physics: Physics,
        index: int,
        start: Pose2D,
        config: SimulatorConfig,
        *,
        seeds: tuple[np.random.SeedSequence, np.random.SeedSequence],
        clock: Callable[[], float],
    ) -> None:
        self._physics = physics
        self._index = index
        self.start = start
        self._body: RobotBody = physics.robots[index]
        self._config = config
        self._clock = clock
        laser_seed, odom_seed = seeds
        self._laser = Laser(config.laser, np.random.default_rng(laser_seed))
        self._odometry = WheelOdometry(config.robot, config.odom_noise, np.random.default_rng(odom_seed), self.start)
        self._limiter = CommandLimiter(config.robot)
        self._wheels = self._body.wheels()
        self._contacts = ContactStats()
        self._last_touch_step = -(10**9)
        self._last_scan: Scan | None = None

    @property
    def name(self) -> str:
        return self._body.name

    # -- driving (called by the simulator) ----------------------------------------------------------------------

    def wheel_rates(self, dt: float) -> tuple[float, float]:
        """The wheel-rate targets (rad/s) for the next step of ``dt`` s, from the limited command."""
        command = self._limiter.update(self._clock(), dt)
        return self._config.robot.wheel_rates(command.v, command.omega)

    def after_step(self, touched: set[str], steps: int) -> Scan | None:
        """Integrate odometry and count contacts after physics step number ``steps``; scan if one is due."""
        dt = self._config.dt
        wheels = self._body.wheels()
        self._odometry.update(
            wrap_angle(wheels.left_angle - self._wheels.left_angle),
            wrap_angle(wheels.right_angle - self._wheels.right_angle),
            dt,
        )
        self._wheels = wheels

        c = self._contacts
        new_event = bool(touched) and (steps - self._last_touch_step) * dt > CONTACT_GAP
        if touched:
            self._last_touch_step = steps
        self._contacts = ContactStats(
            events=c.events + int(new_event),
            steps=c.steps + int(bool(touched)),
            obstacles=c.obstacles | touched if touched else c.obstacles,
            in_contact=bool(touched),
        )

        if steps % self._config.steps_per_scan == 0:
            self._last_scan = self.scan_now()
            return self._last_scan
        return None

    # -- commanding ---------------------------------------------------------------------------------------------

    def set_command(self, v: float, omega: float) -> Twist2D:
        """Command forward speed ``v`` (m/s) and turn rate ``omega`` (rad/s); returns them clamped to the limits.

        The command holds until the next one, or until ``command_timeout`` s of sim time pass without one.
        """
        return self._limiter.receive(v, omega, self._clock())

    def teleport(self, pose: Pose2D) -> None:
        """Put the robot, stopped, at ``pose`` (world frame) without its odometry noticing: a kidnapping.

        Raises InvalidInputError if the robot would overlap an obstacle or another robot there (it then stays
        where it was).
        """
        self._physics.move_robot(self._index, pose)

    # -- reading ------------------------------------------------------------------------------------------------

    @property
    def command(self) -> Twist2D:
        """The (v, omega) applied at the last step, after limits, ramps and the watchdog."""
        return self._limiter.current

    @property
    def watchdog_stopped(self) -> bool:
        """Whether no command arrived within the timeout, so the robot is being stopped."""
        return self._limiter.timed_out(self._clock())

    def ground_truth(self) -> Pose2D:
        """True pose of ``base_footprint`` in the world frame."""
        return self._body.pose()

    def ground_truth_twist(self) -> Twist2D:
        """True body velocity (m/s, rad/s) in the robot frame."""
        v, omega = self._body.twist()
        return Twist2D(v, omega)

    def odometry(self) -> Odometry:
        """Wheel odometry in this robot's ``odom`` frame (equal to the world frame at time zero)."""
        return self._odometry.state(self._clock())

    def wheels(self) -> WheelState:
        """Wheel hinge angles (rad, wrapped to [-pi, pi]) and rates (rad/s), e.g. for joint_states."""
        return self._wheels

    @property
    def last_scan(self) -> Scan | None:
        return self._last_scan

    def scan_now(self) -> Scan:
        """A scan from the current pose, outside the laser's schedule (draws from the laser's noise stream)."""
        sections = self._physics.laser_sections(self._index, self._config.laser.mount_z)
        return self._laser.scan(self._body.pose(), self._clock(), sections)

    @property
    def contacts(self) -> ContactStats:
        return self._contacts

    @property
    def chassis_height(self) -> float:
        """Height (m) of the chassis centre above the ground; a sanity check that the robot stays upright."""
        return self._body.height()


class MultiRobotSimulator:
    """Steps several robots in one world: they see each other in their scans and collide physically.

    Robot ``i`` starts at ``starts[i]`` and is named ``names[i]`` (default ``robot_<i>``), the name the other
    robots' contact statistics report it under.
    """

    def __init__(
        self,
        world: World,
        config: SimulatorConfig | None = None,
        starts: Sequence[Pose2D] = (Pose2D(0.0, 0.0, 0.0),),
        names: Sequence[str] | None = None,
    ) -> None:
        self.config = config or SimulatorConfig()
        self.world = world
        # World files are held to these on loading; a World built in code is held to them here. Every scan casts
        # its rays against every shape, so their number is what bounds the cost of a step.
        shapes = len(world.boxes) + len(world.cylinders)
        if shapes > MAX_SHAPES:
            raise InvalidInputError(
                f"world {world.name}: {shapes} boxes and cylinders, above the limit of {MAX_SHAPES}"
            )
        for start in starts:
            if max(abs(start.x), abs(start.y)) > MAX_COORDINATE_M:
                raise InvalidInputError(f"start ({start.x:g}, {start.y:g}) is more than {MAX_COORDINATE_M:g} m out")
        self._physics = Physics(world, self.config.robot, starts, names)
        seeds = np.random.SeedSequence(self.config.seed).spawn(2 * len(starts))
        # The robots read the time from this counter, not from the simulator: a closure over the simulator would
        # make every simulator a reference cycle, freed by the cycle collector, which may clear pyode's objects
        # before their own deallocation runs (an ignored TypeError in JointGroup.__dealloc__).
        self._clock = _StepClock(self.config.physics_rate)
        self.robots: tuple[SimulatedRobot, ...] = tuple(
            SimulatedRobot(
                self._physics, i, start, self.config, seeds=(seeds[2 * i], seeds[2 * i + 1]), clock=self._clock
            )
            for i, start in enumerate(starts)
        )

    @property
    def time(self) -> float:
        """Sim time (s) since the start."""
        return self._clock()

    @property
    def steps(self) -> int:
        return self._clock.steps

    def add_box(self, box: Box) -> None:
        """Put a static box into the world at run time (an obstacle the map does not have); it joins
        :attr:`world`. Raises :class:`InvalidInputError` for a box without finite numbers and positive sizes."""
        numbers = (box.x, box.y, box.z, box.yaw, box.size_x, box.size_y, box.size_z)
        if not all(math.isfinite(v) for v in numbers) or min(box.size_x, box.size_y, box.size_z) <= 0.0:
            raise InvalidInputError(f"box {box.name!r}: pose and sizes must be finite, sizes > 0, got {box}")
        self._physics.add_box(box)
        self.world = replace(self.world, boxes=(*self.world.boxes, box))

    def step(self) -> list[Scan | None]:
        """Advance one physics step; returns per robot the scan taken at the end of it, if one was due."""
        dt = self.config.dt
        rates = [robot.wheel_rates(dt) for robot in self.robots]
        touched = self._physics.step(rates, dt)
        self._clock.steps += 1
        return [robot.after_step(t, self._clock.steps) for robot, t in zip(self.robots, touched, strict=True)]


class Simulator:
    """Steps one robot in one world; the Python API behind the ROS node and the benchmarks."""

    def __init__(self, world: World, config: SimulatorConfig | None = None, start: Pose2D | None = None) -> None:
        self.start = start or Pose2D(0.0, 0.0, 0.0)
        self._sim = MultiRobotSimulator(world, config, (self.start,))
        self.config = self._sim.config
        (self._robot,) = self._sim.robots

    @property
    def world(self) -> World:
        """The world, with the boxes added at run time."""
        return self._sim.world

    @property
    def time(self) -> float:
        """Sim time (s) since the start."""
        return self._sim.time

    @property
    def steps(self) -> int:
        return self._sim.steps

    def set_command(self, v: float, omega: float) -> Twist2D:
        """Command forward speed ``v`` (m/s) and turn rate ``omega`` (rad/s); returns them clamped to the limits.

        The command holds until the next one, or until ``command_timeout`` s of sim time pass without one.
        """
        return self._robot.set_command(v, omega)

    def add_box(self, box: Box) -> None:
        """Put a static box into the world at run time (see :meth:`MultiRobotSimulator.add_box`)."""
        self._sim.add_box(box)

    def step(self) -> Scan | None:
        """Advance one physics step; returns the scan taken at the end of it, if one was due."""
        (scan,) = self._sim.step()
        return scan

    def run(self, duration: float) -> list[Scan]:
        """Step for ``duration`` s of sim time (rounded to whole steps); returns the scans taken."""
        if not (math.isfinite(duration) and duration >= 0.0):
            raise InvalidInputError(f"duration must be >= 0, got {duration}")
        scans = []
        for _ in range(round(duration * self.config.physics_rate)):
            scan = self.step()
            if scan is not None:
                scans.append(scan)
        return scans

    def teleport(self, pose: Pose2D) -> None:
        """Put the robot, stopped, at ``pose`` (world frame) without its odometry noticing: a kidnapping.

        Raises InvalidInputError if the robot would overlap an obstacle there (it then stays where it was).
        """
        self._robot.teleport(pose)

    @property
    def command(self) -> Twist2D:
        """The (v, omega) applied at the last step, after limits, ramps and the watchdog."""
        return self._robot.command

    @property
    def watchdog_stopped(self) -> bool:
        """Whether no command arrived within the timeout, so the robot is being stopped."""
        return self._robot.watchdog_stopped

    def ground_truth(self) -> Pose2D:
        """True pose of ``base_footprint`` in the world frame."""
        return self._robot.ground_truth()

    def ground_truth_twist(self) -> Twist2D:
        """True body velocity (m/s, rad/s) in the robot frame."""
        return self._robot.ground_truth_twist()

    def odometry(self) -> Odometry:
        """Wheel odometry in the ``odom`` frame (equal to the world frame at time zero)."""
        return self._robot.odometry()

    def wheels(self) -> WheelState:
        """Wheel hinge angles (rad, wrapped to [-pi, pi]) and rates (rad/s), e.g. for joint_states."""
        return self._robot.wheels()

    @property
    def last_scan(self) -> Scan | None:
        return self._robot.last_scan

    def scan_now(self) -> Scan:
        """A scan from the current pose, outside the laser's schedule (draws from the laser's noise stream)."""
        return self._robot.scan_now()

    @property
    def contacts(self) -> ContactStats:
        return self._robot.contacts

    @property
    def chassis_height(self) -> float:
        """Height (m) of the chassis centre above the ground; a sanity check that the robot stays upright."""
        return self._robot.chassis_height
