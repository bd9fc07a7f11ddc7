# SPDX-License-Identifier: Apache-2.0
"""`swir_tracker_ros.topics.QoS` -> rclpy `QoSProfile` (the profiles themselves are defined there)."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from swir_tracker_ros.topics import QoS


def profile(qos: QoS) -> QoSProfile:
    """Keep-last `qos.depth`, reliable or best effort, volatile or transient local."""
    reliability = ReliabilityPolicy.RELIABLE if qos.reliable else ReliabilityPolicy.BEST_EFFORT
    durability = DurabilityPolicy.TRANSIENT_LOCAL if qos.transient_local else DurabilityPolicy.VOLATILE
    return QoSProfile(depth=qos.depth, history=HistoryPolicy.KEEP_LAST, durability=durability,
                      reliability=reliability)
