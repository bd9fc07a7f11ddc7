# SPDX-License-Identifier: Apache-2.0
"""What a node knows of the graph around it, reported on /diagnostics so that a supervisor (or an
integrator reading `/diagnostics`) can tell an input nobody publishes from one that is merely quiet."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping

from rclpy.exceptions import NameValidationException
from rclpy.expand_topic_name import expand_topic_name
from rclpy.node import Node
from rclpy.validate_full_topic_name import validate_full_topic_name

from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.topics import absolute

PUBLISHERS_KEY = "publishers {}"


def input_publishers(node: Node, topics: Iterable[str]) -> dict[str, str]:
    """Diagnostic values `publishers <topic>`: the publishers of each input topic this node has discovered,
    keyed by the fully qualified name the node subscribes (namespace and remappings applied).

    The count comes from the node's own participant, so a non-zero count means this process has discovered
    (and, for compatible QoS, matched) a writer of the topic — a supervisor's own view of the graph says
    nothing about whether two other processes have found each other yet.
    """
    out = {}
    for t in topics:
        name = node.resolve_topic_name(t)
        out[PUBLISHERS_KEY.format(name)] = str(node.count_publishers(name))
    return out


def reported_publishers(values: Mapping[str, str], topic: str, namespace: str = "/") -> int:
    """The `publishers <topic>` count in a status's values (a relative `topic` resolved in `namespace`);
    0 when absent or not a number."""
    try:
        return int(values.get(PUBLISHERS_KEY.format(absolute(topic, namespace)), "0"))
    except ValueError:
        return 0


def _first_line(exc: Exception) -> str:
    """The reason in rcl's / rclpy's name-validation text, on one line without the source location."""
    text = str(exc).split("\n")[0].split(", at /")[0].rstrip(":")
    for prefix in ("Invalid topic name: ",):
        text = text.removeprefix(prefix)
    return text.split(" is invalid: ", 1)[-1]


def check_topic_names(params: object) -> None:
    """Raise `ParameterError` naming the parameter when a `*_topic` field of `params` is not a valid ROS
    topic name ('', 'bad topic!!', '/a//b', 'x/', '1abc'), before any subscription is created."""
    for f in dataclasses.fields(params):  # type: ignore[arg-type]
        value = getattr(params, f.name)
        if not f.name.endswith("_topic") or not isinstance(value, str):
            continue
        if value == "" and f.metadata.get("empty_derived"):  # '' = derived from another name
            continue
        try:
            validate_full_topic_name(expand_topic_name(value, "node", "/"))
        except (ValueError, NameValidationException) as exc:
            raise ParameterError(f"parameter {f.name} = {value!r} is not a valid topic name: "
                                 f"{_first_line(exc)}") from None
