# SPDX-License-Identifier: Apache-2.0
"""The tracker node's topics and services are the ones docs/tracker_node.md lists: the table is generated
from nodes/tracker_endpoints.py, and a node built with each image transport and click type has exactly
those publishers, subscriptions and services (in its namespace)."""

from __future__ import annotations

import pytest
from conftest import REPO
from rclpy.context import Context
from rclpy.parameter import Parameter

from swir_tracker_ros import topics
from swir_tracker_ros.nodes.param_docs import replace_block
from swir_tracker_ros.nodes.tracker_endpoints import ENDPOINTS, MARKER, active, markdown_table
from swir_tracker_ros.nodes.tracker_node import TrackerNode

RCL_OWN = {"/rosout", "/parameter_events"}


def _type_name(cls: type) -> str:
    module = cls.__module__.split(".")  # swir_tracker_interfaces.srv._select_target
    return f"{module[0]}/{module[1]}/{cls.__name__}"


def test_docs_table_is_the_generated_one() -> None:
    text = (REPO / "docs" / "tracker_node.md").read_text()
    assert MARKER in text
    assert replace_block(text, MARKER, markdown_table()) == text, "run python -m swir_tracker_ros.param_files"


@pytest.mark.parametrize(("transport", "click"), [("raw", "point"), ("compressed", "point_stamped"),
                                                   ("raw", "off")])
def test_the_node_has_exactly_the_listed_endpoints(context: Context, transport: str, click: str) -> None:
    params = {"image_transport": transport, "click_msg": click}
    node = TrackerNode(context=context, namespace="/head7",
                       parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
    try:
        found = {(p.topic_name, _type_name(p.msg_type), "out") for p in node.publishers}
        found |= {(s.topic_name, _type_name(s.msg_type), "in") for s in node.subscriptions}
        services = {(node.resolve_service_name(s.srv_name), _type_name(s.srv_type)) for s in node.services}
        found |= {(name, kind, "service") for name, kind in services
                  if not name.startswith("/head7/tracker/")}  # rclpy's parameter services
        found = {f for f in found if f[0] not in RCL_OWN}
        listed = {(topics.absolute(e.name, "/head7"), e.type, e.direction)
                  for e in ENDPOINTS if active(e, params)}
        assert found == listed
    finally:
        node.destroy_node()
