# SPDX-License-Identifier: Apache-2.0
"""TrackerNode in-process: callbacks driven directly, outputs captured (no DDS round trip needed)."""

from __future__ import annotations

import array
import math

import numpy as np
import pytest
import yaml
from conftest import REPO
from rclpy.context import Context
from rclpy.parameter import Parameter
from sensor_msgs.msg import CameraInfo, Image, JointState, RegionOfInterest
from std_srvs.srv import Trigger

from msg_adapters.camera_info import Intrinsics, camera_info_from_intrinsics
from msg_adapters.diagnostics import status_values
from msg_adapters.geometry import box_from_polygon, pan_tilt_error, pan_tilt_error_from_msg
from msg_adapters.image import numpy_to_image
from msg_adapters.stamps import header
from msg_adapters.track_state import track_state_from_msg
from swir_tracker_ros.configs import DEFAULT_CONFIGURATION, ConfigurationChoice, configuration
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.nodes.graph import reported_publishers
from swir_tracker_ros.nodes.tracker_node import DIAG_NAME, TrackerNode, params_yaml
from swir_tracker_ros.nodes.tracker_node_params import (
    FORMAT_CHANGE_FRAMES,
    FrameStats,
    HeadPoseHistory,
    TrackerNodeParams,
)
from swir_tracker_ros.paramfield import flat_fields, rebuild
from swir_tracker_ros.types import Box, TrackResult, TrackState

W, H, TW = 240, 192, 24
PATCH = np.random.default_rng(3).integers(0, 2, (TW // 4, TW // 4)).repeat(4, 0).repeat(4, 1)


def scene(cx: float, cy: float, width: int = W, height: int = H, seed: int = 0) -> np.ndarray:
    """uint16 frame: smooth noisy background with a high-contrast checker target centred at (cx, cy)."""
    rng = np.random.default_rng(seed)
    img = 3000.0 + 400.0 * np.sin(np.arange(width) / 37.0)[None, :] + rng.normal(0, 40, (height, width))
    x0, y0 = round(cx - TW / 2), round(cy - TW / 2)
    img[y0:y0 + TW, x0:x0 + TW] += 6000.0 * PATCH
    return np.clip(img, 0, 65535).astype(np.uint16)


class Capture:
    def __init__(self, node: TrackerNode) -> None:
        self.box, self.error, self.state, self.diag, self.typed, self.markers = [], [], [], [], [], []
        out = node.outputs
        out.box.publish = self.box.append
        out.error.publish = self.error.append
        out.state.publish = self.state.append
        out.typed.publish = self.typed.append
        out.image_markers.publish = self.markers.append
        node.pub_diag.publish = self.diag.append


def make(ctx: Context, **params) -> tuple[TrackerNode, Capture]:
    overrides = [Parameter(k, value=v) for k, v in params.items()]
    node = TrackerNode(context=ctx, parameter_overrides=overrides)
    return node, Capture(node)


def feed(node: TrackerNode, pixels: np.ndarray, t: float) -> None:
    node._on_image(numpy_to_image(pixels, header(t, "swir")))


def test_tracks_from_init_box_param_and_publishes_with_image_header(context: Context) -> None:
    node, cap = make(context, init_box=[88.0, 84.0, 24.0, 24.0], fov_h_deg=30.0,
                     ego_motion_compensation=False)
    try:
        for i in range(20):
            feed(node, scene(100.0 + 2 * i, 96.0, seed=i), 10.0 + 0.04 * i)
        assert track_state_from_msg(cap.state[-1]) is TrackState.TRACKING
        box = box_from_polygon(cap.box[-1])
        assert abs(box.cx - 138.0) < 3 and abs(box.cy - 96.0) < 3
        pan, tilt, stamp = pan_tilt_error_from_msg(cap.error[-1])
        assert stamp == pytest.approx(10.0 + 0.04 * 19)
        fx = (W / 2) / math.tan(math.radians(15.0))
        assert pan == pytest.approx(math.atan2(W / 2 - box.cx, fx)) and pan < 0  # target right of centre
        assert tilt == pytest.approx(math.atan2(H / 2 - box.cy, fx))  # square pixels: fy = fx
        assert cap.box[-1].header.frame_id == "swir_pixels"  # pixels, not metres in the camera frame
        assert cap.error[-1].header.frame_id == "pan_link"  # joint angles: the head's pan frame (issue 39)
    finally:
        node.destroy_node()


def test_malformed_and_stale_frames_are_counted_not_raised(context: Context) -> None:
    node, cap = make(context, init_box=[88.0, 84.0, 24.0, 24.0])
    try:
        feed(node, scene(100, 96), 1.0)
        bad = Image(height=H, width=W, encoding="mono16", step=W * 2, data=array.array("B", bytes(10)))
        bad.header = header(1.1)
        node._on_image(bad)
        node._on_image(Image(height=H, width=W, encoding="bogus", step=W * 2, header=header(1.2)))
        feed(node, scene(100, 96), 0.5)  # older than the last processed frame by < 1 s: stale
        feed(node, scene(102, 96), 1.3)
        values, trouble = node.stats.report(1.0)
        assert values["window_dropped_malformed"] == 2 and values["window_dropped_stale"] == 1
        assert values["window_processed"] == 2 and trouble
        assert node._warned["image"][1] == 1  # the second malformed-image warning was held back (throttled)
        assert track_state_from_msg(cap.state[-1]) is TrackState.TRACKING
    finally:
        node.destroy_node()


def test_init_topic_cancel_service_and_bad_init(context: Context) -> None:
    node, cap = make(context)
    try:
        feed(node, scene(100, 96), 1.0)
        assert track_state_from_msg(cap.state[-1]) is TrackState.IDLE and not cap.error
        node._on_init(RegionOfInterest(x_offset=88, y_offset=84, width=0, height=24))  # rejected: zero width
        feed(node, scene(100, 96), 1.04)
        assert track_state_from_msg(cap.state[-1]) is TrackState.IDLE
        node._on_init(RegionOfInterest(x_offset=88, y_offset=84, width=24, height=24))
        feed(node, scene(100, 96), 1.08)
        assert track_state_from_msg(cap.state[-1]) is TrackState.TRACKING
        response = node._on_cancel(Trigger.Request(), Trigger.Response())
        assert response.success and "tracking" in response.message
        feed(node, scene(100, 96), 1.12)
        assert track_state_from_msg(cap.state[-1]) is TrackState.IDLE
        assert box_from_polygon(cap.box[-1]) is None
        node._on_init(RegionOfInterest(x_offset=5000, y_offset=84, width=24, height=24))  # outside the image
        feed(node, scene(100, 96), 1.16)
        assert track_state_from_msg(cap.state[-1]) is TrackState.IDLE
    finally:
        node.destroy_node()


def test_resolution_change_reinitialises_on_the_scaled_box(context: Context) -> None:
    node, cap = make(context, init_box=[88.0, 84.0, 24.0, 24.0])
    try:
        for i in range(5):
            feed(node, scene(100, 96, seed=i), 1.0 + 0.04 * i)
        # Same view at twice the resolution: skipped until FORMAT_CHANGE_FRAMES arrive in a row (one odd
        # frame never ends a track), then restarted on the scaled box.
        for k in range(FORMAT_CHANGE_FRAMES):
            n_box = len(cap.box)
            feed(node, scene(200, 192, width=2 * W, height=2 * H, seed=20 + k), 2.0 + 0.04 * k)
            assert track_state_from_msg(cap.state[-1]) is TrackState.TRACKING
        assert len(cap.box) == n_box + 1  # the last one is tracked, the ones before only answered
        box = box_from_polygon(cap.box[-1])
        assert abs(box.cx - 200) < 4 and abs(box.w - 48) < 6
        feed(node, scene(204, 192, width=2 * W, height=2 * H, seed=9), 2.2)
        assert track_state_from_msg(cap.state[-1]) in (TrackState.TRACKING, TrackState.OCCLUDED)
        for k in range(FORMAT_CHANGE_FRAMES):  # bit depth change: also a clean restart
            feed(node, scene(100, 96).astype(np.uint8), 2.3 + 0.04 * k)
            assert track_state_from_msg(cap.state[-1]) is TrackState.TRACKING
    finally:
        node.destroy_node()


def test_ego_shift_from_joint_states_and_camera_info(context: Context) -> None:
    node, _ = make(context)
    try:
        node.inputs.on_camera_info(camera_info_from_intrinsics(Intrinsics(500.0, 500.0, 120.0, 96.0, W, H)))
        node.inputs.on_camera_info(CameraInfo(width=W, height=H))  # uncalibrated: ignored, previous one kept
        for t, pan, tilt in ((0.9, 0.0, 0.0), (1.1, 0.02, -0.01)):
            node.inputs.on_joint_state(JointState(
                header=header(t), name=["tilt", "pan"], position=[tilt, pan]))
        node.inputs.on_joint_state(JointState(header=header(1.2), name=["pan"], position=[0.5]))  # ignored
        intr = node.inputs.intrinsics(W, H)
        assert intr.fx == 500.0
        assert node.inputs.ego_shift(0.9, intr) == (0.0, 0.0)
        dx, dy = node.inputs.ego_shift(1.0, intr)  # head halfway: pan +0.01 (left), tilt -0.005 (down)
        assert dx == pytest.approx(500 * math.tan(0.01)) and dy == pytest.approx(500 * math.tan(-0.005))
    finally:
        node.destroy_node()


def test_camera_info_beside_the_image_topic(context: Context) -> None:
    """Issue 39: image_topic alone moves the CameraInfo subscription beside it (image_transport's sibling
    convention); an explicit camera_info_topic wins."""
    node, _ = make(context, image_topic="/camera1/image_raw")
    other, _ = make(context, image_topic="/camera1/image_raw", camera_info_topic="/calib/info")
    try:
        assert {s.topic_name for s in node.subscriptions} >= {"/camera1/image_raw", "/camera1/camera_info"}
        assert "/calib/info" in {s.topic_name for s in other.subscriptions}
        assert "/camera1/camera_info" not in {s.topic_name for s in other.subscriptions}
    finally:
        node.destroy_node()
        other.destroy_node()


def test_no_camera_info_is_said_not_silent(context: Context) -> None:
    node, cap = make(context, camera_info_timeout_s=0.0, warn_throttle_s=0.0)
    warnings: list[str] = []
    node._warn = lambda kind, text: warnings.append(text)  # the inputs warn through the node
    node.inputs._warn = node._warn
    try:
        feed(node, scene(100, 96), 1.0)
        feed(node, scene(100, 96), 1.04)
        assert any("no CameraInfo on /camera/camera_info" in w and "fallback" in w for w in warnings), \
            warnings
        node._publish_diagnostics()
        values = status_values(cap.diag[-1], DIAG_NAME)
        assert (values["camera_info_missing"], values["intrinsics"]) == ("true", "fov")
        assert values["camera_info_topic"] == "/camera/camera_info"
    finally:
        node.destroy_node()


def test_zoom_moves_the_focal_length_the_error_uses(context: Context) -> None:
    """Issue 39: the zoom joint through `zoom_focal_scale` scales fx, fy: the same box's error shrinks as the
    head zooms in (tele), under the joint names the bring-up gave."""
    node, cap = make(context, init_box=[128.0, 84.0, 24.0, 24.0], fov_h_deg=30.0,
                     ego_motion_compensation=False, zoom_focal_scale=[0.0, 1.0, 0.5, 2.0, 1.0, 4.0],
                     pan_joint="head1_pan", tilt_joint="head1_tilt", zoom_joint="head1_zoom")
    fx = (W / 2) / math.tan(math.radians(15.0))

    def joints(t: float, zoom: float, names=("head1_pan", "head1_tilt", "head1_zoom")) -> None:
        node.inputs.on_joint_state(JointState(header=header(t), name=list(names), position=[0.0, 0.0, zoom]))

    try:
        errors = []
        for t, zoom in ((1.0, 0.0), (1.04, 0.25), (1.08, 1.0), (1.12, 7.0)):
            joints(t, zoom)
            feed(node, scene(140.0, 96.0), t)
            box = box_from_polygon(cap.box[-1])
            errors.append((pan_tilt_error_from_msg(cap.error[-1])[0], box.cx))
        scales = (1.0, 1.5, 4.0, 4.0)  # linear between the pairs, held beyond the last
        for (pan, cx), scale in zip(errors, scales):
            assert pan == pytest.approx(math.atan2(W / 2 - cx, fx * scale)), (pan, cx, scale)
        assert abs(errors[2][0]) < abs(errors[0][0]) / 3
        assert node.inputs.ignored_joint_states == 0
        joints(1.16, 0.0, names=("pan", "tilt", "zoom"))  # other names: not the head's, counted, not used
        assert node.inputs.ignored_joint_states == 1 and node.inputs.zoom == 7.0
    finally:
        node.destroy_node()


def test_runtime_parameter_changes(context: Context) -> None:
    node, _ = make(context, init_box=[88.0, 84.0, 24.0, 24.0], **{"tracker.configuration": "measured"})
    try:
        feed(node, scene(100, 96), 1.0)
        assert not node.set_parameters([Parameter("tracker.base.psr_threshold", value=-1.0)])[0].successful
        res = node.set_parameters([Parameter("tracker.base.feature", value="nope")])[0]
        assert not res.successful and "nope" in res.reason
        assert not node.set_parameters([Parameter("init_box", value=[1.0, 2.0])])[0].successful
        assert not node.set_parameters([Parameter("image_topic", value="/x")])[0].successful
        # the configuration is chosen at start-up (read-only); its parameters change at run time
        assert not node.set_parameters([Parameter("tracker.configuration", value="cf")])[0].successful
        assert node.set_parameters([Parameter("tracker.memory.ratio", value=0.4)])[0].successful
        assert node.tracker.params.memory.ratio == 0.4 and node.pending_init is not None
        feed(node, scene(100, 96), 1.04)
        assert node.tracker.state is TrackState.TRACKING
    finally:
        node.destroy_node()


def test_bad_startup_parameter_raises(context: Context) -> None:
    with pytest.raises(ParameterError, match="fov_h_deg"):
        TrackerNode(context=context, parameter_overrides=[Parameter("fov_h_deg", value=500.0)])


def test_diagnostics_report(context: Context) -> None:
    node, cap = make(context, init_box=[88.0, 84.0, 24.0, 24.0])
    try:
        node._publish_diagnostics()
        assert status_values(cap.diag[-1], DIAG_NAME)["window_received"] == "0"
        assert cap.diag[-1].status[0].level == b"\x03"  # STALE: no images
        for i in range(6):
            feed(node, scene(100, 96, seed=i), 1.0 + 0.04 * i)
        node._publish_diagnostics()
        values = status_values(cap.diag[-1], DIAG_NAME)
        assert values["window_processed"] == "6" and float(values["latency_ms_p50"]) > 0
        assert values["state"] == "tracking"
        # Which inputs have a publisher: the supervisor of the demo waits for these before it starts.
        assert values["publishers /camera/image_raw"] == "0"
        node.create_publisher(Image, node.params.image_topic, 1)
        node._publish_diagnostics()
        values = status_values(cap.diag[-1], DIAG_NAME)
        assert values["publishers /camera/image_raw"] == "1"
        assert reported_publishers(values, "/camera/image_raw") == 1
        assert reported_publishers(values, "/positioner/joint_states") == 0
        assert reported_publishers({"publishers /x": "?"}, "/x") == 0
    finally:
        node.destroy_node()


def test_frame_stats_counts_skipped_frames_and_head_history() -> None:
    stats = FrameStats()
    for i in [*range(10), 12, 13, 100]:  # frames 10 and 11 missing; then a pause
        stats.frame_stamp(1.0 + 0.04 * i)
    assert stats.skipped == 2
    hist = HeadPoseHistory()
    assert hist.at(1.0) is None
    hist.add(1.0, 0.0, 0.0)
    hist.add(2.0, 1.0, -1.0)
    assert hist.at(1.5) == (0.5, -0.5) and hist.at(0.0) == (0.0, 0.0)
    # newer than the last sample: extrapolated with the last velocity, for at most 0.2 s
    assert hist.at(2.1) == pytest.approx((1.1, -1.1)) and hist.at(9.0) == pytest.approx((1.2, -1.2))
    hist.add(0.5, 3.0, 3.0)  # time went backwards: history restarts
    assert hist.at(2.0) == (3.0, 3.0)


def test_debug_image_only_with_subscribers(context: Context) -> None:
    node, _ = make(context, init_box=[88.0, 84.0, 24.0, 24.0])
    debug: list[Image] = []
    node.outputs.debug.publish = debug.append
    try:
        feed(node, scene(100, 96), 1.0)
        assert not debug
        node.create_subscription(Image, "/track/debug_image", lambda _m: None, 1)
        assert node.outputs.debug.get_subscription_count() == 1
        feed(node, scene(102, 96), 1.04)
        assert len(debug) == 1 and debug[0].encoding == "bgr8" and (debug[0].width, debug[0].height) == (W, H)
        pixels = np.frombuffer(debug[0].data, np.uint8).reshape(H, W, 3)
        assert (pixels[..., 1] > 200).sum() > 4 * TW  # the green tracking box is drawn
    finally:
        node.destroy_node()


def test_params_file_and_docs_list_every_parameter() -> None:
    """params/tracker.yaml declares exactly the node's and the core's parameters (nested blocks for the
    per-filter Params) with valid values (regenerate it with `tracker --params-yaml`), and
    docs/tracker_node.md documents each one."""
    doc = yaml.safe_load((REPO / "params" / "tracker.yaml").read_text())["/**"]["ros__parameters"]
    core = doc.pop("tracker")
    docs = (REPO / "docs" / "tracker_node.md").read_text()
    choice = {k: core.pop(k) for k in ("configuration", "base_filter")}
    assert ConfigurationChoice(**choice) == ConfigurationChoice()
    default = configuration(DEFAULT_CONFIGURATION)  # the core's parameters: the default configuration's
    for prefix, params, values in (("", TrackerNodeParams(), doc), ("tracker.", default, core)):
        names = {name for name, _, _ in flat_fields(params)}
        hint = f"{type(params).__name__}: run `tracker --params-yaml > params/tracker.yaml`"
        assert set(_flatten(values)) == names, hint
        rebuild(params, _flatten(values)).validate()
        missing = [n for n in names if f"`{prefix}{n}`" not in docs]
        assert not missing, f"docs/tracker_node.md lacks {missing}"


def _flatten(values: dict, prefix: str = "") -> dict:
    out: dict = {}
    for k, v in values.items():
        out.update(_flatten(v, f"{prefix}{k}.") if isinstance(v, dict) else {prefix + k: v})
    return out


def test_generated_params_yaml_loads_back_to_the_defaults() -> None:
    doc = yaml.safe_load(params_yaml())["/**"]["ros__parameters"]
    core = doc.pop("tracker")
    assert TrackerNodeParams(**doc) == TrackerNodeParams()
    assert (core.pop("configuration"), core.pop("base_filter")) == (DEFAULT_CONFIGURATION, "")
    default = configuration(DEFAULT_CONFIGURATION)
    assert rebuild(configuration(DEFAULT_CONFIGURATION), _flatten(core)) == default


def test_head_motion_reaches_the_core_as_ego_shift(context: Context) -> None:
    node, _ = make(context, init_box=[88.0, 84.0, 24.0, 24.0], fov_h_deg=30.0)
    try:
        feed(node, scene(100, 96), 1.0)  # initialises the track
        seen: list[tuple[float, float]] = []
        update = node.tracker.update

        def spy(frame, ego_shift=(0.0, 0.0), **kw):
            seen.append(ego_shift)
            return update(frame, ego_shift=ego_shift, **kw)

        node.tracker.update = spy
        for t, pan in ((0.95, 0.0), (1.05, 0.01), (1.15, 0.02)):
            node.inputs.on_joint_state(JointState(
                header=header(t), name=["pan", "tilt"], position=[pan, 0.0]))
        feed(node, scene(100, 96), 1.05)
        feed(node, scene(100, 96), 1.15)
        fx = (W / 2) / math.tan(math.radians(15.0))
        # pan +0.01 rad (left) per frame moves the scene right by fx * tan(0.01) pixels
        assert seen[-1][0] == pytest.approx(fx * math.tan(0.01)) and seen[-1][1] == pytest.approx(0.0)
        node.set_parameters([Parameter("ego_motion_compensation", value=False)])
        node.inputs.on_joint_state(JointState(
            header=header(1.25), name=["pan", "tilt"], position=[0.03, 0.0]))
        feed(node, scene(100, 96), 1.25)
        assert seen[-1] == (0.0, 0.0)
    finally:
        node.destroy_node()


def test_the_error_aims_at_the_last_accepted_box_while_the_verdict_rejects_the_box(context: Context) -> None:
    """Issue 46: a network-led track's rejected frame (state occluded) carries the network's answer as `box`
    and its last accepted box as `aim`: track/box shows the answer, the head's error comes from `aim`."""
    node, cap = make(context, fov_h_deg=30.0, ego_motion_compensation=False)
    try:
        intr = node.inputs.intrinsics(W, H)
        answer, held = Box(180.0, 60.0, 20.0, 20.0), Box(100.0, 90.0, 20.0, 20.0)
        rejected = TrackResult(answer, TrackState.OCCLUDED, aim=held)
        for result in (rejected, TrackResult(answer, TrackState.TRACKING)):
            node.outputs.publish(header(1.0, "swir"), result, intr)
            assert box_from_polygon(cap.box[-1]).cx == pytest.approx(answer.cx)
            pan, tilt, _ = pan_tilt_error_from_msg(cap.error[-1])
            aim = result.aim_box
            assert (pan, tilt) == pytest.approx(pan_tilt_error(aim.cx, aim.cy, intr))
        assert cap.error[0] != cap.error[1]
    finally:
        node.destroy_node()


@pytest.mark.usefixtures("nanotrack_weights", "lighttrack_weights")
def test_the_judged_configuration_declares_its_judge_and_refuses_bad_weights(context: Context) -> None:
    node, cap = make(context, init_box=[88.0, 84.0, 24.0, 24.0], **{"tracker.configuration": "judged"})
    try:
        weights = node.get_parameter("tracker.lead.second.weights").value
        assert list(weights) == pytest.approx(node.tracker.params.lead.second.weights)
        res = node.set_parameters([Parameter("tracker.lead.second.weights", value=[1.0, 2.0])])[0]
        assert not res.successful and "weights" in res.reason
        for i in range(5):
            feed(node, scene(100.0 + 2 * i, 96.0, seed=i), 10.0 + 0.04 * i)
        assert cap.state and node.tracker._track.lead.second is not None
    finally:
        node.destroy_node()
