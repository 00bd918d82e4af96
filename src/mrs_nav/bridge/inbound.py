"""Checking what a remote peer asks to publish into ROS before anything reaches a ROS topic."""

from __future__ import annotations

import time
from typing import Any

from mrs_nav.bridge.config import CLOCK_TOLERANCE_S, BridgeConfig, InboundRule
from mrs_nav.bridge.decoder import deserialize_exactly, first_non_finite, noetic_store
from mrs_nav.bridge.wire import decode_attachment, ros_type, rosbags_type
from mrs_nav.errors import InvalidInputError


class InboundValidator:
    """Accepts a remote message only if its topic is allow-listed, its type (Encoding schema and, when an
    attachment is present, md5) is the rule's type, it deserialises to exactly one message, every number in
    it is finite, and its header names the rule's frame and is stamped (sender's clock, s since the epoch)
    at most the rule's ``max_age`` before the bridge's clock and at most ``CLOCK_TOLERANCE_S`` after it.

    Types come from rosbags' Noetic typestore, so the check needs no ROS and never trusts the sender's
    definition.
    """

    def __init__(self, config: BridgeConfig) -> None:
        self.config = config
        store = noetic_store()
        self._md5: dict[str, str] = {}
        for rule in config.inbound:
            try:
                self._md5[rule.topic] = str(store.generate_msgdef(rosbags_type(rule.type), ros_version=1)[1])
            except Exception as err:
                raise InvalidInputError(f"inbound {rule.topic}: unknown message type {rule.type}: {err}") from None

    def allowed_topics(self) -> list[str]:
        return [rule.topic for rule in self.config.inbound]

    def validate(
        self, topic: str, schema: str, payload: bytes, attachment: bytes | None = None, now: float | None = None
    ) -> Any:
        """The decoded message (rosbags object) if acceptable; InvalidInputError naming the reason otherwise.
        ``now`` is the bridge's clock in s since the epoch (default: this machine's)."""
        rule = self.config.inbound_rule(topic)
        if rule is None:
            allowed = ", ".join(self.allowed_topics()) or "nothing"
            raise InvalidInputError(f"{topic} is not in the bridge's inbound allow-list (allowed: {allowed})")
        if ros_type(schema) != rule.type:
            raise InvalidInputError(f"{topic} accepts {rule.type} only, got {schema or 'no type'}")
        if attachment:
            md5 = decode_attachment(attachment).md5
            if md5 != self._md5[topic]:
                raise InvalidInputError(f"{topic}: md5 {md5} is not the one of {rule.type} ({self._md5[topic]})")
        msg = deserialize_exactly(noetic_store(), rule.type, payload)
        bad = first_non_finite(msg)
        if bad:
            raise InvalidInputError(f"{topic}: field {bad} is not a finite number")
        header = getattr(msg, "header", None)
        if rule.frame and header is not None and header.frame_id != rule.frame:
            raise InvalidInputError(f"{topic}: frame {header.frame_id!r}, expected {rule.frame!r}")
        if header is not None:
            _check_age(rule, header.stamp.sec + header.stamp.nanosec * 1e-9, time.time() if now is None else now)
        return msg

    def md5(self, topic: str) -> str:
        return self._md5[topic]


def _check_age(rule: InboundRule, stamp: float, now: float) -> None:
    """Refuse a stamp older than the rule's ``max_age`` or ahead of ``now`` by more than the clock tolerance."""
    age = now - stamp
    if age > rule.max_age:
        raise InvalidInputError(
            f"{rule.topic}: stamped {age:.1f} s ago, older than its max_age {rule.max_age:g} s (a replayed or "
            "delayed message, or the sender's clock is not synchronised)"
        )
    if age < -CLOCK_TOLERANCE_S:
        raise InvalidInputError(
            f"{rule.topic}: stamped {-age:.1f} s in the future, beyond the {CLOCK_TOLERANCE_S:g} s clock tolerance "
            "(the sender's clock is not synchronised)"
        )
