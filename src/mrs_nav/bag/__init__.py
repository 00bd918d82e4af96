"""ROS 1 bags read and written offline with rosbags (no ROS install needed), and message <-> core conversions."""

from mrs_nav.bag.io import BagWriter, bag_topics, read_messages, typestore

__all__ = ["BagWriter", "bag_topics", "read_messages", "typestore"]
