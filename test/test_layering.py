# SPDX-License-Identifier: Apache-2.0
"""The package graph of docs/interfaces.md ("Layers"): who may import whom, where message fields, topic
names and QoS profiles may appear. Static checks over the source (AST and text), no ROS graph needed."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
from conftest import REPO

PKG = REPO / "swir_tracker_ros"
BASE = {"types", "errors", "topics", "paramfield"}
PRODUCT = {"kalman", "core", "policies", "tracker_params", "configs", "track", "tracker", "acquisition",
           "pelco"}
# Each layer and the layers it may import (docs/interfaces.md). Base modules import nothing above them.
ALLOWED: dict[str, set[str]] = {
    "types": set(),
    "errors": set(),
    "topics": set(),
    "paramfield": {"errors"},
    "kalman": BASE,
    "core": BASE | {"kalman"},
    "policies": BASE | {"kalman", "core"},  # the long-term mechanisms around a base filter
    "tracker_params": BASE | {"core", "policies"},
    "configs": BASE | {"core", "policies", "tracker_params"},  # named configurations
    "track": BASE | {"kalman", "core", "policies", "tracker_params"},  # the per-track state of `tracker`
    "tracker": BASE | {"kalman", "core", "policies", "tracker_params", "configs", "track"},
    # the learned detector runs in the core's one runtime, found by its model locator, on frames conditioned
    # as the tracker's (core/siamese/network.py, locator.py, core/conditioning.py)
    "acquisition": BASE | {"kalman", "core"},
    "pelco": BASE,
    "scene": BASE | {"acquisition"},  # scene.crowd hands out acquisition Detections (simulation -> core)
    "msg_adapters": {"types", "topics"},  # one way: the adapters know the public value types, not the reverse
    "nodes": BASE | PRODUCT | {"msg_adapters"},
    # the simulated camera and head; nodes: the node toolkit (runner, parameters); pelco: the simulated head
    # speaks the protocol of pelco/
    "simulation": BASE | {"scene", "msg_adapters", "nodes", "pelco"},
    "harness": BASE | {"kalman", "core", "tracker", "tracker_params", "configs", "scene", "msg_adapters"},
    "demo": BASE | {"scene", "simulation", "nodes", "msg_adapters", "harness"},
}
# The params-file generator (`python -m swir_tracker_ros.param_files`) reads every layer's params; no
# layer imports it (it is in no ALLOWED set above).
ALLOWED["param_files"] = set(ALLOWED) - {"param_files"}
ROS_FREE = BASE | PRODUCT | {"scene"}
ROS_MODULES = {"rclpy", "rosidl_runtime_py", "builtin_interfaces", "std_msgs", "sensor_msgs", "geometry_msgs",
               "diagnostic_msgs", "std_srvs", "visualization_msgs", "rosgraph_msgs",
               "swir_tracker_interfaces"}


def _layer(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] == "msg_adapters":
        return "msg_adapters"
    if parts[0] != "swir_tracker_ros" or len(parts) == 1:
        return None
    return parts[1].removesuffix(".py")


def _sources() -> list[Path]:
    return sorted([*PKG.rglob("*.py"), *(REPO / "msg_adapters").glob("*.py")])


def _imports(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every import in the file; `from pkg import module` gives the module."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{path}:{node.lineno}: relative import"
            mod = node.module or ""
            for a in node.names:
                sub = f"{mod}.{a.name}"
                is_module = (REPO / Path(*sub.split("."))).with_suffix(".py").exists() or \
                    (REPO / Path(*sub.split("."))).is_dir()
                out.append((node.lineno, sub if is_module else mod))
    return out


def _layer_of_file(path: Path) -> str:
    rel = path.relative_to(REPO)
    if rel.parts[0] == "msg_adapters":
        return "msg_adapters"
    return rel.parts[1].removesuffix(".py") if len(rel.parts) > 1 else "swir_tracker_ros"


def test_every_layer_is_known() -> None:
    layers = {_layer_of_file(p) for p in _sources()} - {"__init__"}
    assert layers <= set(ALLOWED), f"add {sorted(layers - set(ALLOWED))} to ALLOWED and docs/interfaces.md"


def test_imports_follow_the_layer_graph() -> None:
    bad = []
    for path in _sources():
        src = _layer_of_file(path)
        if src == "__init__":
            continue
        for line, module in _imports(path):
            dst = _layer(module)
            if dst is not None and dst != src and dst not in ALLOWED[src]:
                bad.append(f"{path.relative_to(REPO)}:{line} {src} -> {dst} ({module})")
            if src in ROS_FREE and module.split(".")[0] in ROS_MODULES:
                bad.append(f"{path.relative_to(REPO)}:{line} {src} is ROS-free but imports {module}")
    assert not bad, "\n".join(bad)


def test_the_allowed_graph_has_no_cycle() -> None:
    seen: dict[str, int] = {}

    def visit(layer: str, path: tuple[str, ...]) -> None:
        assert layer not in path, f"cycle: {' -> '.join((*path, layer))}"
        if seen.get(layer):
            return
        for dep in ALLOWED[layer]:
            visit(dep, (*path, layer))
        seen[layer] = 1

    for layer in ALLOWED:
        visit(layer, ())


# Message fields and wire layouts that only msg_adapters may touch (docs/interfaces.md, "Message seam").
FIELD_ACCESS = re.compile(
    r"\.data\b|from_bytes|\bx_offset\b|\by_offset\b|\.header\b|\.stamp\.sec|\bnanosec\b|\.polygon\b|"
    r"\.vector\.[xyz]\b|\.is_bigendian\b|\.encoding\b|\.markers\b|\bkv\.(key|value)\b|\.status\b\s*(:|$|\))|"
    r"\bfor \w+ in \w+\.status\b|\.success\s*=|\.message\s*=|\.message\.split|\.points\b|"
    r"\.position\[|\.velocity\[")


def _code_lines(path: Path):
    for k, line in enumerate(path.read_text().splitlines(), 1):
        code = line.split("#", 1)[0]
        if code.strip():
            yield k, code


def test_no_message_field_is_read_or_written_outside_msg_adapters() -> None:
    hits = [f"{p.relative_to(REPO)}:{k}: {code.strip()}" for p in sorted(PKG.rglob("*.py"))
            for k, code in _code_lines(p) if FIELD_ACCESS.search(code)]
    assert not hits, "message layouts belong in msg_adapters:\n" + "\n".join(hits)


@pytest.mark.parametrize("code", [
    "sec = int.from_bytes(data[4:8], 'little')", "roi.x_offset", "stamp_to_seconds(msg.header.stamp)",
    "for status in msg.status:", "resp.success = True", "float(result.message.split()[-1])",
    "occluded[t] = bool(msg.data)", "int.from_bytes(raw[8:12], 'little')"])
def test_the_field_pattern_catches_the_old_leaks(code: str) -> None:
    assert FIELD_ACCESS.search(code), code


# a head's names are relative (`track/box`), the graph-wide ones absolute (`/diagnostics`); either spelling
TOPIC = re.compile(r"/?(camera|track|positioner|ground_truth|scene|acquisition)(/\w+)+|/(diagnostics|clock)")


def test_topic_names_and_qos_profiles_are_defined_once() -> None:
    """A string that is a topic name appears only in topics.py; only msg_adapters.qos builds a QoSProfile."""
    hits = []
    files = [*PKG.rglob("*.py"), *(REPO / "msg_adapters").glob("*.py"), *(REPO / "benchmarks").glob("*.py"),
             *(REPO / "launch").glob("*.py")]
    for p in sorted(files):
        tree = ast.parse(p.read_text())
        for node in ast.walk(tree):
            if p != PKG / "topics.py" and isinstance(node, ast.Constant) and isinstance(node.value, str) \
                    and TOPIC.fullmatch(node.value):
                hits.append(f"{p.relative_to(REPO)}:{node.lineno}: {node.value!r}")
            if p != REPO / "msg_adapters" / "qos.py" and isinstance(node, ast.Call) and \
                    getattr(node.func, "id", getattr(node.func, "attr", None)) == "QoSProfile":
                hits.append(f"{p.relative_to(REPO)}:{node.lineno}: QoSProfile(...)")
    assert not hits, "names: swir_tracker_ros/topics.py; QoS: topics + msg_adapters.qos\n" + "\n".join(hits)


@pytest.mark.parametrize("name", ["track/box", "/track/box", "camera/image_raw", "positioner/joint_states",
                                  "/diagnostics", "ground_truth/box"])
def test_the_topic_pattern_catches_both_spellings(name: str) -> None:
    assert TOPIC.fullmatch(name), name


# Issue 37: a module a reader can hold in mind.
MAX_FILE_LINES, MAX_CLASS_LINES = 400, 300


def test_no_module_or_class_beyond_the_size_bounds() -> None:
    too_long = []
    for path in sorted(PKG.rglob("*.py")):
        text = path.read_text()
        rel = path.relative_to(PKG).as_posix()
        lines = text.count("\n")
        if lines > MAX_FILE_LINES:
            too_long.append(f"{rel}: {lines} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.ClassDef) and node.end_lineno - node.lineno + 1 > MAX_CLASS_LINES:
                too_long.append(f"{rel}: class {node.name} {node.end_lineno - node.lineno + 1} lines")
    assert not too_long, too_long
