# SPDX-License-Identifier: Apache-2.0
"""What `launch/bringup.launch.py` starts for one real head, as plain data (no launch, no rclpy).

`bringup_nodes(BringupArgs(...), share)` lists the nodes of one tracking head: `tracker` and
`positioner_bridge`, plus `acquisition` when asked, all in the head's namespace, each with its params file
and the launch arguments as parameter overrides. Nothing simulated is started: the camera driver and the
Pelco-D head are the site's. The launch file turns each `NodeSpec` into a `launch_ros.actions.Node`;
`NodeSpec.command()` is the same process as a command line (`launch_ros` passes the name, namespace,
params files and overrides the same way), for a machine without `ros2 launch`:

    python -m swir_tracker_ros.nodes.bringup namespace:=head1 port:=/dev/ttyUSB0   # prints the commands
"""

from __future__ import annotations

import json
import shlex
import sys
from dataclasses import dataclass, field, fields
from pathlib import Path

import yaml

from swir_tracker_ros import topics

PACKAGE = "swir_tracker_ros"


@dataclass(frozen=True)
class LaunchArgument:
    """One launch argument: name, default (text, as `ros2 launch` passes it) and description."""

    name: str
    default: str
    description: str


# The arguments of bringup.launch.py, in the order `ros2 launch ... --show-args` lists them.
ARGUMENTS = (
    LaunchArgument("namespace", "", "namespace of the head (head1: every topic under /head1/...); '' = root"),
    LaunchArgument("image_topic", topics.IMAGE, "camera image topic (relative: in the namespace; absolute: "
                   "as the driver publishes it, e.g. /camera1/image_raw)"),
    LaunchArgument("camera_info_topic", topics.CAMERA_INFO, "camera_info topic of the same camera"),
    LaunchArgument("image_transport", "raw",
                   "raw (sensor_msgs/Image) or compressed (CompressedImage on <image_topic>/compressed)"),
    LaunchArgument("port", "/dev/ttyUSB0", "serial port of the head, or a pyserial URL (socket://host:port "
                   "for a serial device server)"),
    LaunchArgument("baud", "9600", "Pelco-D line speed (2400, 4800, 9600)"),
    LaunchArgument("address", "1", "Pelco-D address (receiver id) of the head, 1-255"),
    LaunchArgument("tracker_params", "", "tracker params file ('' = the installed params/tracker.yaml)"),
    LaunchArgument("positioner_params", "", "positioner params file ('' = the installed positioner.yaml)"),
    LaunchArgument("acquisition", "false", "also start the acquisition node (pedestrians, hand-off)"),
    LaunchArgument("acquisition_params", "", "acquisition params file ('' = the installed one)"),
)


def _truthy(text: str) -> bool:
    value = text.strip().lower()
    if value not in ("1", "true", "yes", "on", "0", "false", "no", "off"):
        raise ValueError(f"{text!r} is not true or false")
    return value in ("1", "true", "yes", "on")


@dataclass(frozen=True)
class BringupArgs:
    """The launch arguments, parsed (defaults as in ARGUMENTS)."""

    namespace: str = ""
    image_topic: str = topics.IMAGE
    camera_info_topic: str = topics.CAMERA_INFO
    image_transport: str = "raw"
    port: str = "/dev/ttyUSB0"
    baud: int = 9600
    address: int = 1
    tracker_params: str = ""
    positioner_params: str = ""
    acquisition: bool = False
    acquisition_params: str = ""

    @classmethod
    def from_text(cls, values: dict[str, str]) -> BringupArgs:
        """From `name: text` pairs (launch configurations); `ValueError` naming a bad or unknown one."""
        known = {a.name for a in ARGUMENTS}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(f"unknown bringup argument(s) {unknown}; known: {sorted(known)}")
        kinds = {f.name: f.type for f in fields(cls)}
        parsed: dict[str, object] = {}
        for name, text in values.items():
            try:
                kind = kinds[name]
                parsed[name] = int(text) if kind == "int" else _truthy(text) if kind == "bool" else text
            except ValueError as exc:
                raise ValueError(f"bringup argument {name}:={text!r}: {exc}") from None
        args = cls(**parsed)  # type: ignore[arg-type]
        if args.image_transport not in topics.TRANSPORTS:
            raise ValueError(f"bringup argument image_transport:={args.image_transport!r} is not one of "
                             f"{topics.TRANSPORTS}")
        return args


@dataclass(frozen=True)
class NodeSpec:
    """One node to start: executable of the package, node name, namespace, params files and overrides."""

    executable: str
    name: str
    namespace: str
    params_files: tuple[str, ...]
    overrides: dict[str, object] = field(default_factory=dict)

    def ros_args(self) -> list[str]:
        """The `--ros-args` that launch_ros gives this node (name, namespace, files, then overrides)."""
        out = ["--ros-args", "-r", f"__node:={self.name}"]
        if self.namespace:
            out += ["-r", f"__ns:=/{self.namespace.strip('/')}"]
        for path in self.params_files:
            out += ["--params-file", path]
        for key, value in self.overrides.items():
            out += ["-p", f"{key}:={_yaml(value)}"]
        return out

    def command(self, bin_dir: str) -> list[str]:
        """The command line of this node with its executable in `bin_dir` (lib/<package>, or a venv's bin)."""
        return [str(Path(bin_dir) / self.executable), *self.ros_args()]


def _yaml(value: object) -> str:
    """`-p name:=value` text that rcl's YAML reading turns back into `value` (a string stays a string)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return value if value and isinstance(yaml.safe_load(value), str) else json.dumps(value)
    return repr(value)


def bringup_nodes(args: BringupArgs, share: str) -> list[NodeSpec]:
    """The nodes of one real head: tracker and positioner bridge (and acquisition when asked)."""
    params = Path(share) / "params"
    ns = args.namespace.strip("/")
    tracker = NodeSpec("tracker", "tracker", ns, (args.tracker_params or str(params / "tracker.yaml"),),
                       {"image_topic": args.image_topic, "camera_info_topic": args.camera_info_topic,
                        "image_transport": args.image_transport})
    positioner = NodeSpec("positioner_bridge", "positioner_bridge", ns,
                          (args.positioner_params or str(params / "positioner.yaml"),),
                          {"port": args.port, "baud": args.baud, "address": args.address})
    nodes = [tracker, positioner]
    if args.acquisition:
        nodes.append(NodeSpec("acquisition", "acquisition", ns,
                              (args.acquisition_params or str(params / "acquisition.yaml"),),
                              {"image_topic": args.image_topic}))
    return nodes


def main(argv: list[str] | None = None) -> int:
    """Print the commands of a bring-up (`name:=value` arguments as for `ros2 launch`)."""
    argv = sys.argv[1:] if argv is None else argv
    share = str(Path(__file__).resolve().parents[2])  # the source tree: params/ beside the package
    try:
        values = dict(a.split(":=", 1) for a in argv)
        args = BringupArgs.from_text(values)
    except ValueError as exc:
        print(f"bringup: error: {exc}", file=sys.stderr)
        return 2
    for spec in bringup_nodes(args, share):
        print(shlex.join(spec.command(str(Path(sys.prefix) / "bin"))))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
