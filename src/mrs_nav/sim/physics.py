"""Rigid-body physics of one or several robots among a world's static obstacles, with the Open Dynamics Engine.

Each robot (:class:`RobotBody`) is three bodies: a chassis (an upright cylinder of the footprint radius, clear
of the ground, with a frictionless caster sphere at the back) and two wheel spheres on hinge joints driven by
velocity motors with a torque limit. The world's boxes and cylinders become static ODE geoms; a plane is the
ground. Contacts use ODE's friction pyramid scaled by the normal force (``Approx1``), so a wheel slips when the
motor asks for more traction than friction gives, and the odometry (read from the hinges) shows it. Every
robot's geoms sit in a space of their own, so robots collide with each other like with a wall (each is told
the other's name). A robot's laser is cast against the cross-sections at its height of the static geoms and
the other robots' geoms (:meth:`Physics.laser_sections`), never against its own chassis.

The python3-pyode traps (wrong joint and contact constants, swallowed callback errors, geoms destroyed with
their Python object) are handled by :mod:`mrs_nav.sim.ode_bindings` and by keeping every geom referenced here.

``dWorldStep`` (the exact big-matrix solver) is used rather than ``quickStep``: for three bodies it is as fast,
it converges fully, and it draws no random numbers (quickStep reorders constraints with ODE's global random
generator), so two simulations built alike step identically.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import ode

from mrs_nav.errors import InvalidInputError
from mrs_nav.geometry import Pose2D
from mrs_nav.maps.world import Box, World
from mrs_nav.sim.laser import Sections
from mrs_nav.sim.ode_bindings import (
    CONTACT_APPROX1,
    CONTACT_SOFT_CFM,
    CONTACT_SOFT_ERP,
    PARAM_FMAX,
    PARAM_VEL,
    collide_spaces,
)
from mrs_nav.sim.robot import BurgerParams

GRAVITY = 9.81  # m/s^2
_CONTACT_ERP = 0.8
_CONTACT_CFM = 1e-5


def _rotation_z(yaw: float) -> tuple[float, ...]:
    """Row-major 3x3 rotation by ``yaw`` about z, as ODE takes it."""
    c, s = math.cos(yaw), math.sin(yaw)
    return (c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)


def _cross_sections(geoms: Iterable[Any], height: float) -> Sections:
    """The cross-sections at ``height`` (m) of upright ODE boxes, cylinders (axis along z) and spheres.

    Robots tilt by at most a few hundredths of a radian on their wheels and caster, so their chassis cylinder
    is taken as upright too (its section's error is below a tenth of a millimetre).
    """
    circles: list[tuple[float, float, float]] = []
    rects: list[tuple[float, float, float, float, float]] = []
    for geom in geoms:
        x, y, z = geom.getPosition()
        if isinstance(geom, ode.GeomBox):
            size_x, size_y, size_z = geom.getLengths()
            if abs(height - z) <= size_z / 2.0:
                r = geom.getRotation()
                rects.append((x, y, math.atan2(r[3], r[0]), size_x / 2.0, size_y / 2.0))
        elif isinstance(geom, ode.GeomCylinder):
            radius, length = geom.getParams()
            if abs(height - z) <= length / 2.0:
                circles.append((x, y, radius))
        elif isinstance(geom, ode.GeomSphere):
            radius = geom.getRadius()
            if abs(height - z) < radius:
                circles.append((x, y, math.sqrt(radius**2 - (height - z) ** 2)))
    return Sections(
        np.array(circles, dtype=np.float64).reshape(-1, 3), np.array(rects, dtype=np.float64).reshape(-1, 5)
    )


@dataclass(frozen=True)
class WheelState:
    """Hinge angles (rad, unbounded is not guaranteed: ODE wraps them to [-pi, pi]) and rates (rad/s)."""

    left_angle: float
    right_angle: float
    left_rate: float
    right_rate: float


class RobotBody:
    """One Burger-like robot's bodies, geoms (in a space of their own) and wheel motors in an ODE world."""

    def __init__(self, world: Any, params: BurgerParams, start: Pose2D, name: str) -> None:
        self.params = params
        self.name = name
        self.space = ode.SimpleSpace()
        p = params
        rotation = _rotation_z(start.yaw)
        c, s = math.cos(start.yaw), math.sin(start.yaw)

        def world_point(x: float, y: float, z: float) -> tuple[float, float, float]:
            return (start.x + c * x - s * y, start.y + s * x + c * y, z)

        self._chassis_z = p.chassis_clearance + p.chassis_height / 2.0
        self.chassis = ode.Body(world)
        mass = ode.Mass()
        mass.setCylinderTotal(p.chassis_mass, 3, p.footprint_radius, p.chassis_height)
        self.chassis.setMass(mass)
        self.chassis.setPosition(world_point(p.com_x, 0.0, self._chassis_z))
        self.chassis.setRotation(rotation)
        self._chassis_geom = ode.GeomCylinder(self.space, p.footprint_radius, p.chassis_height)
        self._chassis_geom.setBody(self.chassis)
        self._chassis_geom.setOffsetPosition((-p.com_x, 0.0, 0.0))
        self._caster_geom = ode.GeomSphere(self.space, p.caster_radius)
        self._caster_geom.setBody(self.chassis)
        self._caster_geom.setOffsetPosition((p.caster_x - p.com_x, 0.0, p.caster_radius - self._chassis_z))

        self._wheel_bodies: list[Any] = []
        self._wheel_geoms: list[Any] = []
        self._hinges: list[Any] = []
        for side in (1.0, -1.0):  # left (+y) first, then right
            anchor = world_point(0.0, side * p.wheel_separation / 2.0, p.wheel_radius)
            body = ode.Body(world)
            wmass = ode.Mass()
            wmass.setSphereTotal(p.wheel_mass, p.wheel_radius)
            body.setMass(wmass)
            body.setPosition(anchor)
            body.setRotation(rotation)
            geom = ode.GeomSphere(self.space, p.wheel_radius)
            geom.setBody(body)
            hinge = ode.HingeJoint(world)
            # Rate is body1 relative to body2: with (chassis, wheel) and axis -y (in the body frame) a positive
            # rate rolls the robot forward.
            hinge.attach(self.chassis, body)
            hinge.setAnchor(anchor)
            hinge.setAxis((s, -c, 0.0))
            hinge.setParam(PARAM_FMAX, p.wheel_torque_limit)
            hinge.setParam(PARAM_VEL, 0.0)
            self._wheel_bodies.append(body)
            self._wheel_geoms.append(geom)
            self._hinges.append(hinge)
        self.surface = {
            self._chassis_geom: p.body_friction,
            self._caster_geom: p.caster_friction,
            self._wheel_geoms[0]: p.wheel_friction,
            self._wheel_geoms[1]: p.wheel_friction,
        }

    def set_wheel_rates(self, left_rate: float, right_rate: float) -> None:
        """Motor targets (rad/s) for the next steps."""
        self._hinges[0].setParam(PARAM_VEL, left_rate)
        self._hinges[1].setParam(PARAM_VEL, right_rate)

    def pose(self) -> Pose2D:
        """True planar pose of ``base_footprint`` in the world frame."""
        x, y, _ = self.chassis.getRelPointPos((-self.params.com_x, 0.0, 0.0))
        r = self.chassis.getRotation()
        return Pose2D(x, y, math.atan2(r[3], r[0]))

    def twist(self) -> tuple[float, float]:
        """True (forward speed m/s, yaw rate rad/s) of the chassis, in its own frame."""
        vx, vy, _ = self.chassis.getRelPointVel((-self.params.com_x, 0.0, 0.0))
        yaw = self.pose().yaw
        return (vx * math.cos(yaw) + vy * math.sin(yaw), self.chassis.getAngularVel()[2])

    def apply_motion(self, m: Pose2D) -> None:
        """Move every body by the planar rigid motion ``m`` (world frame) and stop it: hinge angles are kept."""
        turn = _rotation_z(m.yaw)
        c, s = math.cos(m.yaw), math.sin(m.yaw)
        for body in (self.chassis, *self._wheel_bodies):
            x, y, z = body.getPosition()
            body.setPosition((m.x + c * x - s * y, m.y + s * x + c * y, z))
            r = body.getRotation()
            body.setRotation(
                tuple(sum(turn[3 * i + k] * r[3 * k + j] for k in range(3)) for i in range(3) for j in range(3))
            )
            body.setLinearVel((0.0, 0.0, 0.0))
            body.setAngularVel((0.0, 0.0, 0.0))

    def height(self) -> float:
        """Height (m) of the chassis centre: stays near its start unless the robot climbs or sinks."""
        return float(self.chassis.getPosition()[2])

    def wheels(self) -> WheelState:
        left, right = self._hinges
        return WheelState(left.getAngle(), right.getAngle(), left.getAngleRate(), right.getAngleRate())


class Physics:
    """An ODE world holding one or several Burger-like robots and a :class:`World`'s static obstacles.

    Robot ``i`` starts at ``starts[i]`` and is called ``names[i]`` (default ``robot_<i>``) in the contacts the
    others report; :attr:`robots` gives each one's state.
    """

    def __init__(
        self, world: World, params: BurgerParams, starts: Sequence[Pose2D], names: Sequence[str] | None = None
    ) -> None:
        names = list(names) if names is not None else [f"robot_{i}" for i in range(len(starts))]
        if not starts or len(names) != len(starts) or len(set(names)) != len(names):
            raise InvalidInputError(f"need at least one robot and one distinct name per start, got {names}")
        self.params = params
        self._world = ode.World()
        self._world.setGravity((0.0, 0.0, -GRAVITY))
        self._world.setERP(0.2)
        self._world.setCFM(1e-6)
        self._contacts = ode.JointGroup()
        # Spaces: each robot's geoms, the ground, the obstacles (which the laser casts against, with the other
        # robots' spaces).
        self._ground_space = ode.SimpleSpace()
        self.obstacle_space = ode.HashSpace()
        self._ground = ode.GeomPlane(self._ground_space, (0.0, 0.0, 1.0), 0.0)
        self._obstacles: dict[Any, str] = {}
        # The static geoms' cross-sections per laser height (m): the obstacles change only in add_box.
        self._static_sections: dict[float, Sections] = {}
        self._add_obstacles(world)
        self.robots = [RobotBody(self._world, params, start, name) for start, name in zip(starts, names, strict=True)]
        self._owner = {geom: i for i, robot in enumerate(self.robots) for geom in robot.surface}
        self._touched: list[set[str]] = [set() for _ in self.robots]
        for i, start in enumerate(starts):
            touching = self._touching(i)
            if touching:
                who = f"robot {names[i]}" if len(starts) > 1 else "a robot"
                raise InvalidInputError(
                    f"start pose ({start.x:.3f}, {start.y:.3f}) of {who} of radius {params.footprint_radius} m "
                    f"overlaps {', '.join(sorted(touching))} in world {world.name!r}"
                )

    # -- construction -------------------------------------------------------------------------------------------

    def _add_obstacles(self, world: World) -> None:
        for box in world.boxes:
            self.add_box(box)
        for cyl in world.cylinders:
            geom = ode.GeomCylinder(self.obstacle_space, cyl.radius, cyl.length)  # axis along z
            geom.setPosition((cyl.x, cyl.y, cyl.z))
            self._obstacles[geom] = cyl.name

    def add_box(self, box: Box) -> None:
        """Put a static box into the world (the laser sees it from the next scan)."""
        geom = ode.GeomBox(self.obstacle_space, (box.size_x, box.size_y, box.size_z))
        geom.setPosition((box.x, box.y, box.z))
        geom.setRotation(_rotation_z(box.yaw))
        self._obstacles[geom] = box.name
        self._static_sections.clear()

    # -- stepping -----------------------------------------------------------------------------------------------

    def _touching(self, index: int) -> set[str]:
        """Names of the obstacles and other robots that robot ``index`` overlaps now."""
        names: set[str] = set()

        def note(g1: Any, g2: Any) -> None:
            if ode.collide(g1, g2):
                names.add(self._obstacles.get(g1) or self._obstacles[g2])

        def note_robot(g1: Any, g2: Any) -> None:
            if ode.collide(g1, g2):
                names.add(other.name)

        robot = self.robots[index]
        collide_spaces(robot.space, self.obstacle_space, note)
        for other in self.robots:
            if other is not robot:
                collide_spaces(robot.space, other.space, note_robot)
        return names

    def _join(self, g1: Any, g2: Any, contacts: list[Any], mu: float) -> None:
        for contact in contacts:
            contact.setMode(CONTACT_SOFT_ERP | CONTACT_SOFT_CFM | CONTACT_APPROX1)
            contact.setMu(mu)
            contact.setSoftERP(_CONTACT_ERP)
            contact.setSoftCFM(_CONTACT_CFM)
            joint = ode.ContactJoint(self._world, self._contacts, contact)
            joint.attach(g1.getBody(), g2.getBody())

    def _near_ground(self, g1: Any, g2: Any) -> None:
        contacts = ode.collide(g1, g2)
        if contacts:
            # Each robot part has its own grip on the floor: rubber wheels, a frictionless caster.
            robot = self.robots[self._owner.get(g1, self._owner.get(g2, 0))]
            self._join(g1, g2, contacts, robot.surface.get(g1, robot.surface.get(g2, 0.0)))

    def _near_obstacle(self, g1: Any, g2: Any) -> None:
        contacts = ode.collide(g1, g2)
        if contacts:
            index = self._owner.get(g1, self._owner.get(g2, 0))
            self._touched[index].add(self._obstacles.get(g1) or self._obstacles[g2])
            self._join(g1, g2, contacts, self.params.body_friction)

    def _near_robot(self, g1: Any, g2: Any) -> None:
        contacts = ode.collide(g1, g2)
        if contacts:
            first, second = self._owner[g1], self._owner[g2]
            self._touched[first].add(self.robots[second].name)
            self._touched[second].add(self.robots[first].name)
            self._join(g1, g2, contacts, self.params.body_friction)

    def step(self, rates: Sequence[tuple[float, float]], dt: float) -> list[set[str]]:
        """Drive robot ``i``'s wheel motors at ``rates[i]`` = (left, right) rad/s for ``dt`` s.

        Returns, per robot, the names of the obstacles and robots it touched during the step (empty if none).
        """
        for robot, (left, right) in zip(self.robots, rates, strict=True):
            robot.set_wheel_rates(left, right)
        self._touched = [set() for _ in self.robots]
        for robot in self.robots:
            collide_spaces(robot.space, self._ground_space, self._near_ground)
            collide_spaces(robot.space, self.obstacle_space, self._near_obstacle)
        for i, robot in enumerate(self.robots):
            for other in self.robots[i + 1 :]:
                collide_spaces(robot.space, other.space, self._near_robot)
        self._world.step(dt)
        self._contacts.empty()
        return self._touched

    # -- state --------------------------------------------------------------------------------------------------

    def laser_sections(self, index: int, height: float) -> Sections:
        """What robot ``index``'s laser at ``height`` (m) can hit: the cross-sections there of the obstacles and
        of every other robot at its current pose."""
        static = self._static_sections.get(height)
        if static is None:
            static = self._static_sections[height] = _cross_sections(self._obstacles, height)
        others = _cross_sections((g for i, r in enumerate(self.robots) if i != index for g in r.surface), height)
        return Sections.join([static, others])

    def move_robot(self, index: int, pose: Pose2D) -> None:
        """Teleport robot ``index``, at rest, so that its ``base_footprint`` is at ``pose`` (the kidnapped-robot
        test).

        Every body is moved by the same planar rigid motion, so the wheels keep their hinge angles and the wheel
        odometry sees no motion at all. A pose overlapping an obstacle or another robot raises InvalidInputError
        and leaves the robot where it was.
        """
        robot = self.robots[index]
        motion = pose.compose(robot.pose().inverse())
        robot.apply_motion(motion)
        touching = self._touching(index)
        if touching:
            robot.apply_motion(motion.inverse())
            raise InvalidInputError(
                f"pose ({pose.x:.3f}, {pose.y:.3f}) of a robot of radius {self.params.footprint_radius} m overlaps "
                f"{', '.join(sorted(touching))}"
            )
