"""Messages the ROS 2 half converts to another type before publishing (a route's ``ros2_type``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from mrs_nav.bridge.ros2_link import PARTICLE_CLOUD
from mrs_nav.ros2.messages import message_class


def particle_cloud(poses: Any) -> Any:
    """geometry_msgs/PoseArray -> nav2_msgs/ParticleCloud. ROS 1's cloud (amcl's and mrs_nav's) carries no
    weights, so each particle gets 1/N: what the PoseArray shows, not the filter's weights before resampling."""
    particle = message_class("nav2_msgs/Particle")
    weight = 1.0 / len(poses.poses) if poses.poses else 0.0
    cloud = message_class(PARTICLE_CLOUD)()
    cloud.header = poses.header
    cloud.particles = [particle(pose=pose, weight=weight) for pose in poses.poses]
    return cloud


#: The ROS 2 type a route publishes -> how its ROS 1 message becomes one.
CONVERSIONS: dict[str, Callable[[Any], Any]] = {PARTICLE_CLOUD: particle_cloud}
