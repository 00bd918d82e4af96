"""A plain ROS 2 node for the ros2_bridge tests, run by the ROS 2 venv's python (never imports mrs_nav).

``python ros2_peer.py NAMESPACE``: subscribes to the bridge's ROS 2 topics with the QoS a ROS 2 user would
pick and prints one JSON line per topic on its first message and then at most every 0.5 s (``{"topic", "count",
...}``); reads commands from stdin: ``goal X Y`` publishes a geometry_msgs/PoseStamped (frame map) on
``goal_pose``; ``navigate NAME X Y`` sends a nav2_msgs NavigateToPose goal on ``navigate_to_pose`` and prints
``{"action": NAME, ...}`` lines: ``accepted``, ``feedback`` (at most every 0.5 s, with the count), ``status`` and
the result's ``error_code``/``error_msg`` at the end; ``cancel NAME`` asks to cancel it (``cancel_goals``: how many
the server took). ``server`` prints whether the action server is there. ROS_DOMAIN_ID and
ROS_AUTOMATIC_DISCOVERY_RANGE come from the environment.
"""

import json
import sys
import threading
import time

import rclpy
from geometry_msgs.msg import PoseArray, PoseStamped
from nav2_msgs.action import NavigateToPose
from nav2_msgs.msg import ParticleCloud
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.action import ActionClient
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
    if isinstance(msg, ParticleCloud):
        return {
            "frame": msg.header.frame_id,
            "xs": [p.pose.position.x for p in msg.particles],
            "weights": [p.weight for p in msg.particles],
        }
    if isinstance(msg, PoseArray):
        return {"frame": msg.header.frame_id, "xs": [p.position.x for p in msg.poses]}
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
            ("particlecloud", PoseArray, qos_profile_sensor_data),  # ROS 1 amcl's name and type
            ("particle_cloud", ParticleCloud, qos_profile_sensor_data),  # Nav2 amcl's
        ]
        for name, cls, qos in topics:
            self.create_subscription(cls, name, lambda m, n=name: self.heard(n, m), qos)
        self.goal_pub = self.create_publisher(PoseStamped, "goal_pose", RELIABLE)
        self.navigator = ActionClient(self, NavigateToPose, "navigate_to_pose")
        self.goals = {}
        self.feedbacks = {}

    def pose(self, x, y):
        msg = PoseStamped()
        msg.header.frame_id = "map"
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.pose.position.x, msg.pose.position.y = x, y
        msg.pose.orientation.w = 1.0
        return msg

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
        self.goal_pub.publish(self.pose(x, y))
        emit({"sent": "goal", "subscribers": self.goal_pub.get_subscription_count()})

    def navigate(self, name, x, y):
        printed = [-1.0]

        def on_feedback(msg):
            fb = msg.feedback
            self.feedbacks[name] = self.feedbacks.get(name, 0) + 1
            now = time.monotonic()
            if now - printed[0] < 0.5:
                return
            printed[0] = now
            p = fb.current_pose.pose.position
            emit(
                {
                    "action": name,
                    "feedback": self.feedbacks[name],
                    "x": p.x,
                    "y": p.y,
                    "frame": fb.current_pose.header.frame_id,
                    "distance": fb.distance_remaining,
                    "navigation_time": fb.navigation_time.sec + fb.navigation_time.nanosec * 1e-9,
                    "eta": fb.estimated_time_remaining.sec + fb.estimated_time_remaining.nanosec * 1e-9,
                    "recoveries": fb.number_of_recoveries,
                }
            )

        def on_result(future):
            response = future.result()
            emit(
                {
                    "action": name,
                    "status": response.status,
                    "error_code": response.result.error_code,
                    "error_msg": response.result.error_msg,
                    "feedbacks": self.feedbacks.get(name, 0),
                }
            )

        def on_goal(future):
            handle = future.result()
            self.goals[name] = handle
            emit({"action": name, "accepted": handle.accepted})
            if handle.accepted:
                handle.get_result_async().add_done_callback(on_result)

        goal = NavigateToPose.Goal(pose=self.pose(x, y))
        self.navigator.send_goal_async(goal, feedback_callback=on_feedback).add_done_callback(on_goal)

    def cancel(self, name):
        def on_cancel(future):
            emit({"action": name, "cancel_goals": len(future.result().goals_canceling)})

        self.goals[name].cancel_goal_async().add_done_callback(on_cancel)


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
        # Requests of the action client go out from the executor's thread: rclpy (Jazzy) files a request's
        # future only after sending it, and a response taken by the spinning thread in between is dropped
        # ("Ignoring unexpected goal response"), its future never done (seen once in CI).
        elif words[:1] == ["navigate"]:
            executor.create_task(peer.navigate, words[1], float(words[2]), float(words[3]))
        elif words[:1] == ["cancel"]:
            executor.create_task(peer.cancel, words[1])
        elif words[:1] == ["server"]:
            emit({"server": peer.navigator.server_is_ready()})
    stop.set()  # in this order: tearing rclpy down under a spinning executor raises or aborts
    spinner.join()
    executor.shutdown()
    peer.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    main()
