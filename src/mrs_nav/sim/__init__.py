"""The ODE simulator of TurtleBot3-Burger-like robots, one or several in a world (no ROS): physics, laser,
odometry, commands."""

from mrs_nav.sim.commands import CommandLimiter, Twist2D
from mrs_nav.sim.laser import LaserParams, Scan
from mrs_nav.sim.lockstep import LockstepConfig, LockstepGate, LockstepSwitch
from mrs_nav.sim.odometry import Odometry
from mrs_nav.sim.robot import BurgerParams
from mrs_nav.sim.simulator import ContactStats, MultiRobotSimulator, SimulatedRobot, Simulator, SimulatorConfig

__all__ = [
    "BurgerParams",
    "CommandLimiter",
    "ContactStats",
    "LaserParams",
    "LockstepConfig",
    "LockstepGate",
    "LockstepSwitch",
    "MultiRobotSimulator",
    "Odometry",
    "Scan",
    "SimulatedRobot",
    "Simulator",
    "SimulatorConfig",
    "Twist2D",
]
