"""The ``tf_filter`` node: relays one tf topic to another without the transforms from given parent frames.

``slam.launch play:=BAG`` plays a recorded session's ``/tf`` as ``tf_recorded``; this node passes it on to ``tf``
without the recorded ``map -> odom`` (``~drop_parents: [map]``), so the live SLAM node's correction is the only
one. (Debian 12 packages topic_tools' binaries without the package manifest roslaunch needs to find them.)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import rospy
from tf2_msgs.msg import TFMessage

from mrs_nav.errors import InvalidInputError
from mrs_nav.ros.navigation_conversions import publish_unless_shutdown
from mrs_nav.ros.params import private_params

NODE = "tf_filter"


@dataclass(frozen=True)
class TfFilterConfig:
    """The node's private parameters: the parent frames whose transforms are dropped (comma-separated in
    ``~drop_parents``; default: config/tf_filter.yaml)."""

    drop_parents: frozenset[str]

    @classmethod
    def from_params(cls) -> TfFilterConfig:
        return cls.from_values(private_params(NODE))

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> TfFilterConfig:
        names = frozenset(n.strip().lstrip("/") for n in values["drop_parents"].split(",") if n.strip())
        if not names:
            raise InvalidInputError("~drop_parents: name at least one frame")
        return cls(names)


class TfFilterNode:
    """Subscribes ``tf_in`` and publishes ``tf_out`` (remap them), minus the dropped transforms."""

    def __init__(self, config: TfFilterConfig) -> None:
        self.config = config
        self._pub = rospy.Publisher("tf_out", TFMessage, queue_size=100)
        self._sub = rospy.Subscriber("tf_in", TFMessage, self._on_tf, queue_size=100)

    def _on_tf(self, msg: TFMessage) -> None:
        kept = [t for t in msg.transforms if t.header.frame_id.lstrip("/") not in self.config.drop_parents]
        if kept:
            publish_unless_shutdown(self._pub, TFMessage(transforms=kept), "tf_filter")
