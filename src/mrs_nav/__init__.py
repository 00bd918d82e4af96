"""mrs_nav: navigation for a TurtleBot3-Burger-like differential-drive robot.

The package root and every module outside :mod:`mrs_nav.ros` are the ROS-free core: algorithms on numpy
arrays and small dataclasses. :mod:`mrs_nav.ros` adapts them to rospy nodes.
"""

__version__ = "0.1.0"
