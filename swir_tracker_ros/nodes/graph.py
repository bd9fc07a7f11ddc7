# SPDX-License-Identifier: Apache-2.0
"""What a node knows of the graph around it, reported on /diagnostics so that a supervisor (or an
integrator reading `/diagnostics`) can tell an input nobody publishes from one that is merely quiet."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from rclpy.node import Node

PUBLISHERS_KEY = "publishers {}"


def input_publishers(node: Node, topics: Iterable[str]) -> dict[str, str]:
    """Diagnostic values `publishers <topic>`: the publishers of each input topic this node has discovered.

    The count comes from the node's own participant, so a non-zero count means this process has discovered
    (and, for compatible QoS, matched) a writer of the topic — a supervisor's own view of the graph says
    nothing about whether two other processes have found each other yet.
    """
    return {PUBLISHERS_KEY.format(t): str(node.count_publishers(t)) for t in topics}


def reported_publishers(values: Mapping[str, str], topic: str) -> int:
    """The `publishers <topic>` count in a status's values; 0 when absent or not a number."""
    try:
        return int(values.get(PUBLISHERS_KEY.format(topic), "0"))
    except ValueError:
        return 0
