# SPDX-License-Identifier: Apache-2.0
"""bind_parameters: descriptors, YAML overrides, start-up validation and runtime change rejection."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pytest
from rcl_interfaces.msg import ParameterType
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter

from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.nodes.ros_params import bind_parameters


@dataclass
class DemoParams:
    gain: float = field(default=0.5, metadata={"doc": "Loop gain.", "min": 0.0, "max": 1.0})
    window: int = field(default=8, metadata={"doc": "Window length in frames.", "min": 1})
    enabled: bool = field(default=True, metadata={"doc": "Switch."})
    mode: str = field(default="fast", metadata={"doc": "Mode.", "choices": ("fast", "slow")})
    box: list[float] = field(default_factory=list, metadata={"doc": "Optional x, y, w, h."})
    topic: str = field(default="/in", metadata={"doc": "Input topic.", "read_only": True})

    def validate(self) -> None:
        if self.box and len(self.box) != 4:
            raise ParameterError(f"parameter box must have 4 values (x, y, w, h), got {len(self.box)}")


def make_node(ctx: Context, name: str = "params_test", **kw) -> Node:
    return Node(name, context=ctx, **kw)


def test_declares_descriptors_and_defaults(context: Context) -> None:
    node = make_node(context)
    try:
        params = bind_parameters(node, DemoParams, prefix="demo.")
        assert params == DemoParams()
        gain = node.describe_parameter("demo.gain")
        assert gain.type == ParameterType.PARAMETER_DOUBLE
        assert gain.description == "Loop gain."
        assert (gain.floating_point_range[0].from_value, gain.floating_point_range[0].to_value) == (0.0, 1.0)
        window = node.describe_parameter("demo.window")
        assert window.type == ParameterType.PARAMETER_INTEGER and window.integer_range[0].from_value == 1
        assert "fast" in node.describe_parameter("demo.mode").description
        assert node.describe_parameter("demo.box").type == ParameterType.PARAMETER_DOUBLE_ARRAY
        assert node.describe_parameter("demo.topic").read_only
    finally:
        node.destroy_node()


def test_yaml_overrides_are_read(context: Context, tmp_path: Path) -> None:
    yaml = tmp_path / "p.yaml"
    yaml.write_text("params_test:\n  ros__parameters:\n    demo:\n      gain: 0.25\n      mode: slow\n"
                    "      box: [1.0, 2.0, 3.0, 4.0]\n")
    node = make_node(context, cli_args=["--ros-args", "--params-file", str(yaml)])
    try:
        params = bind_parameters(node, DemoParams, prefix="demo.")
        assert params.gain == 0.25 and params.mode == "slow" and params.box == [1.0, 2.0, 3.0, 4.0]
        assert params.window == 8
    finally:
        node.destroy_node()


def test_integer_overrides_widen_to_float_parameters(context: Context) -> None:
    node = make_node(context, cli_args=["--ros-args", "-p", "demo.gain:=1", "-p", "demo.box:=[1, 2, 3, 4]"])
    try:
        params = bind_parameters(node, DemoParams, prefix="demo.")
        assert params.gain == 1.0 and isinstance(params.gain, float)
        assert params.box == [1.0, 2.0, 3.0, 4.0]
        assert node.get_parameter("demo.gain").type_ == Parameter.Type.DOUBLE
    finally:
        node.destroy_node()


@pytest.mark.parametrize(("name", "value", "words"), [
    ("demo.gain", 1.5, ["demo.gain"]),
    ("demo.mode", "medium", ["demo.mode", "medium"]),
    ("demo.box", [1.0, 2.0], ["box", "4 values"]),
    ("demo.window", "eight", ["demo.window"]),
])
def test_bad_startup_value_raises_parameter_error(context: Context, name: str, value, words) -> None:
    node = make_node(context, parameter_overrides=[Parameter(name, value=value)])
    try:
        with pytest.raises(ParameterError) as info:
            bind_parameters(node, DemoParams, prefix="demo.")
        for w in words:
            assert w in str(info.value)
    finally:
        node.destroy_node()


def test_runtime_changes_validated_and_reported(context: Context) -> None:
    node = make_node(context)
    seen: list[DemoParams] = []
    try:
        bind_parameters(node, DemoParams, prefix="demo.", on_change=seen.append)
        ok = node.set_parameters([Parameter("demo.gain", value=0.75)])[0]
        assert ok.successful
        assert seen and seen[-1].gain == 0.75
        for bad in (Parameter("demo.gain", value=2.0), Parameter("demo.mode", value="medium"),
                    Parameter("demo.box", value=[1.0]), Parameter("demo.window", value=0),
                    Parameter("demo.gain", value="x"), Parameter("demo.topic", value="/other")):
            res = node.set_parameters([bad])[0]
            assert not res.successful, bad.name
            assert res.reason
        assert len(seen) == 1
        assert node.get_parameter("demo.gain").value == 0.75
        assert node.get_parameter("demo.mode").value == "fast"
    finally:
        node.destroy_node()


def test_two_bindings_on_one_node_stay_apart(context: Context) -> None:
    node = make_node(context)
    a_seen: list[DemoParams] = []
    b_seen: list[DemoParams] = []
    try:
        bind_parameters(node, DemoParams, prefix="a.", on_change=a_seen.append)
        bind_parameters(node, DemoParams, prefix="b.", on_change=b_seen.append)
        assert node.set_parameters([Parameter("b.window", value=3)])[0].successful
        assert not a_seen and b_seen[-1].window == 3
    finally:
        node.destroy_node()
