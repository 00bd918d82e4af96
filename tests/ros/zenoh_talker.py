"""A ROS node of its own publishing std_msgs/UInt32 0, 1, 2, ... (latched) on a topic at a wall-clock rate,
so that tests can kill it like a crashed node: ``python -m tests.ros.zenoh_talker TOPIC RATE_HZ``."""

from __future__ import annotations

import sys
import time

import rospy
from std_msgs.msg import UInt32

if __name__ == "__main__":
    topic, rate = sys.argv[1], float(sys.argv[2])
    rospy.init_node("zenoh_talker", anonymous=True, disable_signals=True)
    publisher = rospy.Publisher(topic, UInt32, queue_size=10, latch=True)
    count = 0
    while not rospy.is_shutdown():
        publisher.publish(UInt32(count))
        count += 1
        time.sleep(1.0 / rate)  # wall clock: this master may have no /clock
