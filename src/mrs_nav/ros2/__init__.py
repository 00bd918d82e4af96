"""The ROS 2 side of mrs_nav: rclpy code run in the ROS 2 venv (``MRS_NAV_ROS2=1 make install``).

Nothing here may import rospy or :mod:`mrs_nav.ros`: Debian's ROS 1 message packages and the ROS 2 wheels
share module names and cannot live in one process.
"""
