# SPDX-License-Identifier: Apache-2.0
"""What `launch/bringup.launch.py` starts for one real head, as plain data (no launch, no rclpy).

`bringup_nodes(BringupArgs(...), share)` lists the nodes of one tracking head: `tracker`, `positioner_bridge`
and `robot_state_publisher` (the head's URDF, `urdf/swir_head.urdf.template` filled with the joint names and
frame prefix), plus `acquisition` when asked, all in the head's namespace, each with its params file and the
launch arguments as parameter overrides. The joint names are given once here and passed to every node; the
bridge's joint states are remapped to `<namespace>/joint_states`, where robot_state_publisher reads them.
Nothing simulated is started: the camera driver and the Pelco-D head are the site's. The launch file turns
each `NodeSpec` into a `launch_ros.actions.Node` (a `LifecycleNode` driven through `lifecycle` with
managed:=true); `NodeSpec.command()` is the same process as a command line (`launch_ros` passes the name,
namespace, params files and overrides the same way), for a machine without `ros2 launch`:

    python -m swir_tracker_ros.nodes.bringup namespace:=head1 port:=/dev/ttyUSB0   # prints the commands
"""

from __future__ import annotations

import json
import re
import shlex
import string
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
    LaunchArgument("camera_info_topic", "", "camera_info topic of the same camera; '' = beside the image "
                   "(image_transport's convention: <dirname(image_topic)>/camera_info)"),
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
    LaunchArgument("acquisition_detector", "", "acquisition detector: motion, hog or yolox (learned, needs "
                   "`make models`); '' = the params file's"),
    LaunchArgument("pan_joint", "pan", "name of the pan joint: in the URDF, the bridge's joint states and "
                   "what the tracker and acquisition read"),
    LaunchArgument("tilt_joint", "tilt", "name of the tilt joint (as pan_joint)"),
    LaunchArgument("zoom_joint", "zoom", "name of the zoom joint in the joint states (0 wide .. 1 tele)"),
    LaunchArgument("frame_prefix", "auto", "prefix of the head's TF frames (<prefix>base_link, ...); auto = "
                   "'<namespace>/' ('' in the root namespace)"),
    LaunchArgument("robot_description", "", "URDF file of the head ('' = the installed urdf/swir_head.urdf."
                   "template filled with the joint names and frame prefix)"),
    LaunchArgument("robot_state_publisher", "true", "start robot_state_publisher (TF from the URDF and the "
                   "joint states on <namespace>/joint_states)"),
    LaunchArgument("use_sim_time", "false", "every node on the /clock topic's time"),
    LaunchArgument("log_level", "info", "log level of every node (debug, info, warn, error, fatal)"),
    LaunchArgument("respawn", "false", "restart a node that exits (after respawn_delay 2 s)"),
    LaunchArgument("managed", "false", "start the bridge as a lifecycle node, then configure and activate "
                   "it"),
    LaunchArgument("dds_profile", "", "Fast DDS XML profile for every node ('' = the installed "
                   "config/fastdds_shm_udp.xml: large shared memory and UDP; 'none' = the environment's)"),
)
LOG_LEVELS = ("debug", "info", "warn", "error", "fatal")
RESPAWN_DELAY_S = 2.0
# The head's geometry in the installed URDF template (metres): replace the file for another head.
HEAD_GEOMETRY = {"pan_height": "0.10", "tilt_height": "0.08", "camera_forward": "0.05",
                 "tilt_min": "-1.5707963", "tilt_max": "1.5707963", "max_rate": "1.0"}
URDF_TEMPLATE = "urdf/swir_head.urdf.template"
DDS_PROFILE = "config/fastdds_shm_udp.xml"
RSP = "robot_state_publisher"
JOINT_STATES = "joint_states"  # where robot_state_publisher reads the joint states (in the namespace)


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
    camera_info_topic: str = ""
    image_transport: str = "raw"
    port: str = "/dev/ttyUSB0"
    baud: int = 9600
    address: int = 1
    tracker_params: str = ""
    positioner_params: str = ""
    acquisition: bool = False
    acquisition_params: str = ""
    acquisition_detector: str = ""
    pan_joint: str = "pan"
    tilt_joint: str = "tilt"
    zoom_joint: str = "zoom"
    frame_prefix: str = "auto"
    robot_description: str = ""
    robot_state_publisher: bool = True
    use_sim_time: bool = False
    log_level: str = "info"
    respawn: bool = False
    managed: bool = False
    dds_profile: str = ""

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
        if args.log_level.lower() not in LOG_LEVELS:
            raise ValueError(f"bringup argument log_level:={args.log_level!r} is not one of {LOG_LEVELS}")
        joints = (args.pan_joint, args.tilt_joint, args.zoom_joint)
        if len(set(joints)) != 3 or not all(joints):
            raise ValueError(f"bringup arguments pan_joint, tilt_joint, zoom_joint must be distinct names: "
                             f"{joints}")
        return args

    @property
    def prefix(self) -> str:
        """The TF frame prefix: `frame_prefix`, or `<namespace>/` for auto."""
        if self.frame_prefix != "auto":
            return self.frame_prefix
        ns = self.namespace.strip("/")
        return f"{ns}/" if ns else ""


@dataclass(frozen=True)
class NodeSpec:
    """One node to start: package and executable, node name, namespace, params files, overrides, remappings,
    extra arguments, whether it respawns and the lifecycle transitions bring-up drives it through."""

    executable: str
    name: str
    namespace: str
    params_files: tuple[str, ...]
    overrides: dict[str, object] = field(default_factory=dict)
    package: str = PACKAGE
    remappings: tuple[tuple[str, str], ...] = ()
    arguments: tuple[str, ...] = ()  # before --ros-args (e.g. the bridge's --managed)
    log_level: str = ""
    respawn: bool = False
    lifecycle: tuple[str, ...] = ()  # transitions after start: ("configure", "activate")

    def ros_args(self) -> list[str]:
        """The `--ros-args` that launch_ros gives this node (name, namespace, remappings, log level, files,
        then overrides)."""
        out = ["--ros-args", "-r", f"__node:={self.name}"]
        if self.namespace:
            out += ["-r", f"__ns:=/{self.namespace.strip('/')}"]
        for source, target in self.remappings:
            out += ["-r", f"{source}:={target}"]
        if self.log_level:
            out += ["--log-level", self.log_level]
        for path in self.params_files:
            out += ["--params-file", path]
        for key, value in self.overrides.items():
            out += ["-p", f"{key}:={_yaml(value)}"]
        return out

    def command(self, bin_dir: str) -> list[str]:
        """The command line of this node with its executable in `bin_dir` (lib/<package>, or a venv's bin);
        another package's node (robot_state_publisher) through `ros2 run`."""
        exe = [str(Path(bin_dir) / self.executable)] if self.package == PACKAGE else \
            ["ros2", "run", self.package, self.executable]
        return [*exe, *self.arguments, *self.ros_args()]


def _yaml(value: object) -> str:
    """`-p name:=value` text that rcl's YAML reading turns back into `value` (a string stays a string)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return value if value and "\n" not in value and yaml.safe_load(value) == value else json.dumps(value)
    return repr(value)


def head_urdf(args: BringupArgs, share: str) -> str:
    """The head's URDF: `robot_description` read as is, or the installed template filled with the joint
    names, the frame prefix and HEAD_GEOMETRY (string.Template: no xacro needed)."""
    if args.robot_description:
        return Path(args.robot_description).read_text()
    template = string.Template((Path(share) / URDF_TEMPLATE).read_text())
    robot = (args.prefix.strip("/").replace("/", "_") or "swir") + "_head"
    text = template.substitute(prefix=args.prefix, pan_joint=args.pan_joint, tilt_joint=args.tilt_joint,
                               robot_name=robot, **HEAD_GEOMETRY)
    return re.sub(r">\s+<", "><", re.sub(r"<!--.*?-->", "", text, flags=re.DOTALL)).strip()  # one line


def dds_profile(args: BringupArgs, share: str) -> str | None:
    """The FASTRTPS_DEFAULT_PROFILES_FILE every node gets, or None to keep the environment's."""
    if args.dds_profile.strip().lower() == "none":
        return None
    return args.dds_profile or str(Path(share) / DDS_PROFILE)


def bringup_nodes(args: BringupArgs, share: str) -> list[NodeSpec]:
    """The nodes of one real head: tracker, positioner bridge, robot_state_publisher (and acquisition when
    asked). The joint names and the joint-states topic are given here once and passed to every node."""
    params = Path(share) / "params"
    ns = args.namespace.strip("/")
    joints = {"pan_joint": args.pan_joint, "tilt_joint": args.tilt_joint}
    common: dict[str, object] = {"use_sim_time": True} if args.use_sim_time else {}
    level = "" if args.log_level.lower() == "info" else args.log_level.lower()
    spec = {"namespace": ns, "log_level": level, "respawn": args.respawn}
    tracker = NodeSpec(
        "tracker", "tracker", params_files=(args.tracker_params or str(params / "tracker.yaml"),),
        overrides={"image_topic": args.image_topic, "camera_info_topic": args.camera_info_topic,
                   "image_transport": args.image_transport, **joints, "zoom_joint": args.zoom_joint,
                   "joint_states_topic": JOINT_STATES, "angles_frame_id": f"{args.prefix}pan_link", **common},
        **spec)
    managed = {"arguments": ("--managed",), "lifecycle": ("configure", "activate")} if args.managed else {}
    positioner = NodeSpec(
        "positioner_bridge", "positioner_bridge",
        params_files=(args.positioner_params or str(params / "positioner.yaml"),),
        overrides={"port": args.port, "baud": args.baud, "address": args.address, **joints,
                   "zoom_joint": args.zoom_joint, **common},
        remappings=((topics.JOINT_STATES, JOINT_STATES),), **managed, **spec)
    nodes = [tracker, positioner]
    if args.robot_state_publisher:
        nodes.append(NodeSpec(RSP, RSP, params_files=(), package=RSP,
                              overrides={"robot_description": head_urdf(args, share), **common}, **spec))
    if args.acquisition:
        nodes.append(NodeSpec(
            "acquisition", "acquisition",
            params_files=(args.acquisition_params or str(params / "acquisition.yaml"),),
            overrides={"image_topic": args.image_topic, "image_transport": args.image_transport,
                       "camera_info_topic": args.camera_info_topic, "joint_states_topic": JOINT_STATES,
                       **joints, **common,
                       **({"detector": args.acquisition_detector} if args.acquisition_detector else {})},
            **spec))
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
    profile = dds_profile(args, share)
    if profile:
        print(shlex.join(["export", f"FASTRTPS_DEFAULT_PROFILES_FILE={profile}"]))
    for spec in bringup_nodes(args, share):
        line = shlex.join(spec.command(str(Path(sys.prefix) / "bin")))
        print(line + (f"   # respawn after {RESPAWN_DELAY_S:g} s" if spec.respawn else ""))
        full = "/" + "/".join(p for p in (spec.namespace, spec.name) if p)
        for transition in spec.lifecycle:
            print(shlex.join(["ros2", "lifecycle", "set", full, transition]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
