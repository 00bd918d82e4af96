"""Zenoh bridge core: key layout, wire format, configuration, rate limits, decoding and inbound checks.

ROS-free: the node in :mod:`mrs_nav.ros.zenoh_bridge_node` wires these to rospy, and the remote monitor
(:mod:`mrs_nav.bridge.monitor`) uses them with nothing but eclipse-zenoh and rosbags.
"""

from mrs_nav.bridge.config import BridgeConfig, InboundRule, TopicFilter
from mrs_nav.bridge.keys import KeyLayout
from mrs_nav.bridge.rate_limit import RateLimiter
from mrs_nav.bridge.wire import Attachment, decode_attachment, encode_attachment

__all__ = [
    "Attachment",
    "BridgeConfig",
    "InboundRule",
    "KeyLayout",
    "RateLimiter",
    "TopicFilter",
    "decode_attachment",
    "encode_attachment",
]
