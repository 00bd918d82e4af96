"""The ``mrs-nav`` command: offline tools that need no ROS master."""
