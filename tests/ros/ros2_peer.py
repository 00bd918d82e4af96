"""A plain ROS 2 node for the ros2_bridge tests, run by the ROS 2 venv's python (never imports mrs_nav).

``python ros2_peer.py NAMESPACE``: subscribes to the bridge's ROS 2 topics with the QoS a ROS 2 user would
pick and prints one JSON line per topic on its first message and then at most every 0.5 s (``{"topic", "count",
...}``); reads commands from stdin: ``goal X Y`` publishes a geometry_msgs/PoseStamped (frame map) on
``goal_pose``. ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE come from the environment.
"""

import json
import sys
import threading
import time

import rclpy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
TF = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


_OUT = threading.Lock()


def emit(line):
    """One JSON line on stdout; callbacks and the command loop print from different threads."""
    with _OUT:
        sys.stdout.write(json.dumps(line) + "\n")
        sys.stdout.flush()


def summary(msg):
    if isinstance(msg, Odometry):
        p = msg.pose.pose.position
        return {"frame": msg.header.frame_id, "child": msg.child_frame_id, "x": p.x, "y": p.y}
    if isinstance(msg, LaserScan):
        return {"frame": msg.header.frame_id, "beams": len(msg.ranges), "first": float(msg.ranges[0])}
    if isinstance(msg, OccupancyGrid):
        info = msg.info
        return {
            "frame": msg.header.frame_id,
            "width": info.width,
            "height": info.height,
            "cells": len(msg.data),
            "resolution": info.resolution,
            "occupied": sum(1 for v in msg.data if v > 50),
        }
    if isinstance(msg, TFMessage):
        return {"pairs": sorted([t.header.frame_id, t.child_frame_id] for t in msg.transforms)}
    return {}


class Peer(Node):
    def __init__(self, namespace):
        super().__init__("ros2_peer", namespace=namespace or "/")
        self.lock = threading.Lock()
        self.counts = {}
        self.printed = {}
        topics = [
            ("odom", Odometry, RELIABLE),
            ("scan", LaserScan, qos_profile_sensor_data),
            ("map", OccupancyGrid, LATCHED),
            ("/tf", TFMessage, TF),
            ("/tf_static", TFMessage, LATCHED),
        ]
        for name, cls, qos in topics:
            self.create_subscription(cls, name, lambda m, n=name: self.heard(n, m), qos)
        self.goal_pub = self.create_publisher(PoseStamped, "goal_pose", RELIABLE)

    def heard(self, topic, msg):
        now = time.monotonic()
        about = summary(msg)
        key = (topic, str(about.get("pairs")))  # each set of transforms has its own pace
        with self.lock:
            self.counts[topic] = self.counts.get(topic, 0) + 1
            if now - self.printed.get(key, -1.0) < 0.5:
                return
            self.printed[key] = now
            line = {"topic": topic, "count": self.counts[topic], **about}
        emit(line)

    def goal(self, x, y):
        msg = PoseStamped()
        msg.header.frame_id = "map"
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.pose.position.x, msg.pose.position.y = x, y
        msg.pose.orientation.w = 1.0
        self.goal_pub.publish(msg)
        emit({"sent": "goal", "subscribers": self.goal_pub.get_subscription_count()})


def main():
    rclpy.init()
    peer = Peer(sys.argv[1] if len(sys.argv) > 1 else "")
    executor = SingleThreadedExecutor()
    executor.add_node(peer)
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.1)

    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()
    emit({"ready": True})
    for line in sys.stdin:
        words = line.split()
        if words[:1] == ["goal"]:
            peer.goal(float(words[1]), float(words[2]))
    stop.set()  # in this order: tearing rclpy down under a spinning executor raises or aborts
    spinner.join()
    executor.shutdown()
    peer.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    main()
