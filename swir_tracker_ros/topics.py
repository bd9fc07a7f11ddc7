# SPDX-License-Identifier: Apache-2.0
"""The ROS graph's names, message types and QoS, defined once (docs/interfaces.md, "ROS graph").

Plain values, no rclpy: nodes, the demo, the harness and parameter defaults import the names from here;
`msg_adapters.qos.profile` turns a `QoS` into an rclpy `QoSProfile`.

Every name of a head (camera, tracker, positioner, acquisition, simulated scene) is relative: it resolves in
the node's namespace, so `--ros-args -r __ns:=/head1` moves a whole head and two heads share one graph.
Only the graph-wide names are absolute (`/diagnostics`, `/clock`). A rosbag2 recording stores fully
qualified names: `absolute(name)` is a name as a head in the root namespace publishes it (the bag harness,
the demo's recordings).
"""

from __future__ import annotations

from dataclasses import dataclass

# Topics and services of one head, by the role they play (relative names).
IMAGE = "camera/image_raw"
CAMERA_INFO = "camera/camera_info"
JOINT_STATES = "positioner/joint_states"
TRACK_INIT = "track/init"
TRACK_SELECT = "track/select"  # swir_tracker_interfaces/srv/SelectTarget service
TRACK_CANCEL = "track/cancel"  # std_srvs/Trigger service
TRACK_BOX = "track/box"
PAN_TILT_ERROR = "track/pan_tilt_error"
TRACK_STATE = "track/state"
TRACK_STATE_TYPED = "track/state_typed"
TRACK_MARKERS = "track/image_markers"
TRACK_DEBUG_IMAGE = "track/debug_image"
TRACK_DETECTIONS = "track/detections"  # vision_msgs/Detection2DArray: the tracked box (issue 39)
GROUND_TRUTH_BOX = "ground_truth/box"
GROUND_TRUTH_STATE = "ground_truth/state"
GROUND_TRUTH_OCCLUDED = "ground_truth/occluded"
SCENE_START = "scene/start"  # std_srvs/Trigger service
ACQUISITION_TRACKS = "acquisition/tracks"
ACQUISITION_CANDIDATES = "acquisition/candidates"
ACQUISITION_SELECT = "acquisition/select"
ACQUISITION_DEBUG_IMAGE = "acquisition/debug_image"
ACQUISITION_DETECTIONS = "acquisition/detections"  # vision_msgs/Detection2DArray: the detector's boxes
ACQUISITION_TRACK_DETECTIONS = "acquisition/track_detections"  # the same type: the associated tracks
# Graph-wide names (absolute): every node's health, and the simulated clock.
DIAGNOSTICS = "/diagnostics"
CLOCK = "/clock"

# image_transport's naming (image_transport / rqt_image_view): a base image topic's transports and clicks.
TRANSPORTS = ("raw", "compressed")
COMPRESSED_SUFFIX = "/compressed"
MOUSE_LEFT_SUFFIX = "_mouse_left"


def transport_topic(image_topic: str, transport: str) -> str:
    """The topic an image_transport `transport` of the base `image_topic` travels on (`<base>/compressed`)."""
    if transport not in TRANSPORTS:
        raise ValueError(f"image transport {transport!r} is not one of {TRANSPORTS}")
    return image_topic if transport == "raw" else image_topic + COMPRESSED_SUFFIX


def camera_info_topic(image_topic: str) -> str:
    """The camera_info beside a base image topic (image_transport's sibling convention, as
    `image_transport::getCameraInfoTopic`): `<dirname(image_topic)>/camera_info`; `/camera1/image_raw` ->
    `/camera1/camera_info`, `image_raw` -> `camera_info`."""
    head, sep, _ = image_topic.rpartition("/")
    return f"{head}{sep}camera_info" if head or sep else "camera_info"


def mouse_left_topic(image_topic: str) -> str:
    """Where rqt_image_view publishes a left click on the image `image_topic` (`<base>_mouse_left`)."""
    return image_topic + MOUSE_LEFT_SUFFIX


def absolute(name: str, namespace: str = "/") -> str:
    """`name` resolved in `namespace` (no remapping, no `~`): `camera/image_raw` -> `/camera/image_raw`."""
    if name.startswith("/"):
        return name
    return namespace.rstrip("/") + "/" + name


# The message type of every topic (ROS type names: rosbag2 connections, rclpy classes via msg_adapters).
_TYPES: dict[str, str] = {
    IMAGE: "sensor_msgs/msg/Image",
    CAMERA_INFO: "sensor_msgs/msg/CameraInfo",
    JOINT_STATES: "sensor_msgs/msg/JointState",
    TRACK_INIT: "sensor_msgs/msg/RegionOfInterest",
    TRACK_BOX: "geometry_msgs/msg/PolygonStamped",
    PAN_TILT_ERROR: "geometry_msgs/msg/Vector3Stamped",
    TRACK_STATE: "diagnostic_msgs/msg/DiagnosticArray",
    TRACK_STATE_TYPED: "swir_tracker_interfaces/msg/TrackState",
    TRACK_MARKERS: "visualization_msgs/msg/ImageMarker",
    TRACK_DEBUG_IMAGE: "sensor_msgs/msg/Image",
    TRACK_DETECTIONS: "vision_msgs/msg/Detection2DArray",
    DIAGNOSTICS: "diagnostic_msgs/msg/DiagnosticArray",
    GROUND_TRUTH_BOX: "geometry_msgs/msg/PolygonStamped",
    GROUND_TRUTH_STATE: "diagnostic_msgs/msg/DiagnosticArray",
    GROUND_TRUTH_OCCLUDED: "std_msgs/msg/Bool",
    ACQUISITION_TRACKS: "visualization_msgs/msg/MarkerArray",
    ACQUISITION_CANDIDATES: "visualization_msgs/msg/MarkerArray",
    ACQUISITION_SELECT: "std_msgs/msg/UInt32",
    ACQUISITION_DEBUG_IMAGE: "sensor_msgs/msg/Image",
    ACQUISITION_DETECTIONS: "vision_msgs/msg/Detection2DArray",
    ACQUISITION_TRACK_DETECTIONS: "vision_msgs/msg/Detection2DArray",
    CLOCK: "rosgraph_msgs/msg/Clock",
}
# By the relative name and by the name in the root namespace (what a bag of a root-namespace head holds).
TYPES: dict[str, str] = {**_TYPES, **{absolute(name): kind for name, kind in _TYPES.items()}}
SERVICE_TYPES: dict[str, str] = {
    TRACK_SELECT: "swir_tracker_interfaces/srv/SelectTarget",
    TRACK_CANCEL: "std_srvs/srv/Trigger",
    SCENE_START: "std_srvs/srv/Trigger",
}


@dataclass(frozen=True)
class QoS:
    """A keep-last QoS: history depth and reliable (True) or best-effort (False) delivery; volatile unless
    `transient_local` (late subscribers get the last `depth` samples)."""

    depth: int
    reliable: bool
    transient_local: bool = False


# Inputs from sensors: the newest sample only, never waiting for a lost one (a best-effort subscriber
# matches reliable and best-effort publishers alike).
LATEST = QoS(1, reliable=False)
SENSOR = QoS(10, reliable=False)
# Outputs, commands and health: every message delivered.
RELIABLE = QoS(10, reliable=True)
# The debug picture: reliable (its large frames would lose fragments best effort), newest only.
DEBUG_IMAGE = QoS(1, reliable=True)
# The simulated camera: reliable and shallow, so a best-effort tracker gets the newest frame and a
# reliable recorder every frame, lost fragments of the large image re-sent.
CAMERA = QoS(2, reliable=True)
# Recorders (demo supervisor, harness replay): reliable with room for bursts; images shallower.
RECORD = QoS(50, reliable=True)
RECORD_IMAGE = QoS(10, reliable=True)

# The pan-tilt head's control surface and the target's rate (issue 34; docs/positioner.md). Relative names:
# they resolve in the node's namespace (`__ns:=/head1` moves a head and its tracker together).
TARGET_RATE = "track/target_rate"  # Vector3Stamped: the target's angular rate, rad/s (x pan, y tilt)
HEAD_MODE = "positioner/mode"  # swir_tracker_interfaces/HeadMode, LATCHED
HEAD_SET_MODE = "positioner/set_mode"  # swir_tracker_interfaces/SetHeadMode service
HEAD_JOG = "positioner/jog"  # swir_tracker_interfaces/HeadJog (dead-man jog by joint rate)
HEAD_MOVE = "positioner/move"  # swir_tracker_interfaces/MoveHead action
HEAD_GOTO_PRESET = "positioner/goto_preset"  # swir_tracker_interfaces/HeadPreset service
HEAD_SET_PRESET = "positioner/set_preset"  # swir_tracker_interfaces/HeadPreset service
HEAD_CLEAR_PRESET = "positioner/clear_preset"  # swir_tracker_interfaces/HeadPreset service
HEAD_ZOOM = "positioner/zoom"  # swir_tracker_interfaces/ZoomHead service
TYPES.update({
    TARGET_RATE: "geometry_msgs/msg/Vector3Stamped",
    HEAD_MODE: "swir_tracker_interfaces/msg/HeadMode",
    HEAD_JOG: "swir_tracker_interfaces/msg/HeadJog",
})
# State that a late subscriber must still get (who owns the head): the last sample, kept by the publisher.
LATCHED = QoS(1, reliable=True, transient_local=True)
