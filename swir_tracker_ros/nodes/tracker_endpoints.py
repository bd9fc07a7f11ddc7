# SPDX-License-Identifier: Apache-2.0
"""Every topic and service of the tracker node, as data: the "Topics and services" table of
docs/tracker_node.md is generated from it (`python -m swir_tracker_ros.param_files`), and
test_tracker_endpoints.py checks it against the publishers, subscriptions and services of a running node.
"""

from __future__ import annotations

from dataclasses import dataclass

from swir_tracker_ros import topics

IMAGE_TYPES = {"raw": "sensor_msgs/msg/Image", "compressed": "sensor_msgs/msg/CompressedImage"}
CLICK_TYPES = {"point": "geometry_msgs/msg/Point", "point_stamped": "geometry_msgs/msg/PointStamped"}


@dataclass(frozen=True)
class Endpoint:
    """One topic or service: its (default, relative) name, the parameter that renames it, ROS type,
    direction (`in`, `out`, `service`), QoS, what it carries, and the parameter values it exists with."""

    name: str
    type: str
    direction: str
    qos: str
    content: str
    param: str = ""
    when: tuple[tuple[str, str], ...] = ()  # (parameter, value) pairs; empty: always


_BOX = ("corners TL, TR, BR, BL (x = column, y = row, z = 0) in pixels while `tracking` / `occluded`, "
        "the empty polygon when `idle` / `lost`; frame_id `<image frame_id>_pixels` (pixels, not metres: "
        "no TF frame)")
_STATE = ("every processed frame: status `swir_tracker/track`, message = state, values `state, peak, psr, "
          "apce, huber_threshold, search_mode, measured, scale`; level OK (tracking, idle), WARN (occluded), "
          "ERROR (lost)")
_CLICK = ("a left click selects the target: the object under it (see \"Selecting a target\"); `point`: on "
          "the newest frame; `point_stamped`: on the frame with its header stamp")

ENDPOINTS: tuple[Endpoint, ...] = (
    Endpoint(topics.IMAGE, IMAGE_TYPES["raw"], "in", "best effort, keep last 1",
             "the frames; always the newest, never a backlog", "image_topic", (("image_transport", "raw"),)),
    Endpoint(topics.transport_topic(topics.IMAGE, "compressed"), IMAGE_TYPES["compressed"], "in",
             "best effort, keep last 1", "the frames as JPEG or PNG (8- or 16-bit), image_transport's "
             "`compressed`", "image_topic", (("image_transport", "compressed"),)),
    Endpoint(topics.CAMERA_INFO, "sensor_msgs/msg/CameraInfo", "in", "best effort, 10",
             "beside the image by default (`<dirname(image_topic)>/camera_info`); K (with binning/ROI, "
             "REP-104) gives fx, fy, cx, cy, scaled by `zoom_focal_scale` at the zoom joint's position; D "
             "(plumb_bob, rational_polynomial) is undone for the error; none within `camera_info_timeout_s`: "
             "a throttled warning and the FOV fallback", "camera_info_topic"),
    Endpoint(topics.JOINT_STATES, "sensor_msgs/msg/JointState", "in", "best effort, 10",
             "joints `pan_joint`, `tilt_joint` (rad) for ego-motion compensation, `zoom_joint` (0 wide .. 1 "
             "tele) for the focal length; other names: counted on /diagnostics and warned about; bring-up: "
             "`joint_states`", "joint_states_topic"),
    Endpoint(topics.TRACK_INIT, "sensor_msgs/msg/RegionOfInterest", "in", "reliable, 10",
             "select the target: its box in full-resolution pixels (x, y offset, width, height); starts on "
             "the next frame, no answer"),
    *(Endpoint(topics.mouse_left_topic(image), CLICK_TYPES[kind], "in", "reliable, 10", _CLICK,
               "image_topic" if image == topics.IMAGE else "", (("click_msg", kind),))
      for image in (topics.IMAGE, topics.TRACK_DEBUG_IMAGE) for kind in CLICK_TYPES),
    Endpoint(topics.TRACK_SELECT, topics.SERVICE_TYPES[topics.TRACK_SELECT], "service", "",
             "select the target on the frame with the request's stamp (a box or a point); answered when "
             "the track has caught up: accepted with the start box, or rejected with a code and reason"),
    Endpoint(topics.TRACK_CANCEL, topics.SERVICE_TYPES[topics.TRACK_CANCEL], "service", "",
             "stop tracking; state -> `idle`"),
    Endpoint(topics.TRACK_BOX, topics.TYPES[topics.TRACK_BOX], "out", "reliable, 10", _BOX),
    Endpoint(topics.TRACK_DETECTIONS, topics.TYPES[topics.TRACK_DETECTIONS], "out", "reliable, 10",
             "every processed frame, with track/box: one Detection2D while `tracking` / `occluded` (bbox "
             "centre and size in pixels, theta 0; one hypothesis: class_id the state, score the "
             "correlation peak in [0, 1]; id the track's number, new at each start), none while `idle` / "
             "`lost`; the image's header (vision_msgs convention)"),
    Endpoint(topics.PAN_TILT_ERROR, topics.TYPES[topics.PAN_TILT_ERROR], "out", "reliable, 10",
             "x = pan error, y = tilt error (rad), z = 0; only while `tracking` / `occluded`; of the box, "
             "or while a network-led track's verdict rejects the network's answer of its last accepted box "
             "(the head never follows a rejected box); the image's stamp, frame_id `angles_frame_id` (the "
             "head's pan link: joint angles, not a vector in the optical frame)"),
    Endpoint(topics.TARGET_RATE, topics.TYPES[topics.TARGET_RATE], "out", "reliable, 10",
             "the target's angular rate (rad/s, x pan, y tilt, REP-103) in the head's base frame: the Kalman "
             "box-centre velocity through the intrinsics over the camera's median frame period, plus the "
             "head's rate from the joint states when `ego_motion_compensation` is off; with the error, once "
             "5 frame intervals are known (the bridge feeds it forward, docs/positioner.md)"),
    Endpoint(topics.TRACK_STATE, topics.TYPES[topics.TRACK_STATE], "out", "reliable, 10", _STATE),
    Endpoint(topics.TRACK_STATE_TYPED, topics.TYPES[topics.TRACK_STATE_TYPED], "out", "reliable, 10",
             "the same state as typed fields (box as whole pixels, frames_occluded)"),
    Endpoint(topics.TRACK_MARKERS, topics.TYPES[topics.TRACK_MARKERS], "out", "reliable, 10",
             "per frame: id 0 the box (POLYGON, outline coloured by state: green tracking, amber occluded), "
             "id 1 the search windows (LINE_LIST, orange), ns `swir_tracker`, the image's header, lifetime "
             "1 s; REMOVE while `idle` / `lost`"),
    Endpoint(topics.TRACK_DEBUG_IMAGE, topics.TYPES[topics.TRACK_DEBUG_IMAGE], "out", "reliable, 1",
             "only while someone subscribes: bgr8 frame (16-bit stretched to 8), box coloured by state, "
             "search windows, a status line"),
    Endpoint(topics.transport_topic(topics.TRACK_DEBUG_IMAGE, "compressed"), IMAGE_TYPES["compressed"], "out",
             "reliable, 1", "the same picture as JPEG (`debug_jpeg_quality`), only while someone subscribes"),
    Endpoint(topics.DIAGNOSTICS, topics.TYPES[topics.DIAGNOSTICS], "out", "reliable, 10",
             "every `diagnostics_period_s`: status `<node full name>: tracker_node` (e.g. `/head1/tracker: "
             "tracker_node`), hardware_id the node's full "
             "name (see below)"),
)

MARKER = ("<!-- topics and services of the tracker node (swir_tracker_ros/nodes/tracker_endpoints.py): "
          "generated by `python -m swir_tracker_ros.param_files`, do not edit -->")


def active(endpoint: Endpoint, params: dict[str, str]) -> bool:
    """Whether the node has this endpoint with these parameter values (e.g. {'image_transport': 'raw'})."""
    return all(params.get(key) == value for key, value in endpoint.when)


def markdown_rows() -> list[str]:
    rows = []
    for e in ENDPOINTS:
        name = f"`{e.param}` (`{e.name}`)" if e.param else f"`{e.name}`"
        if e.param and e.name.startswith(topics.IMAGE) and e.name != topics.IMAGE:
            name = f"`<image_topic>{e.name[len(topics.IMAGE):]}` (`{e.name}`)"
        when = "; ".join(f"`{k}` {v}" for k, v in e.when)
        content = e.content.replace("|", "\\|") + (f" (with {when})" if when else "")
        kind = e.type.replace("/msg/", "/").replace("/srv/", "/")
        rows.append(f"| {name} | `{kind}` | {e.direction} | {e.qos} | {content} |")
    return rows


def markdown_table() -> str:
    return "\n".join(["| name | type | direction | QoS | content |", "|---|---|---|---|---|",
                      *markdown_rows()])
