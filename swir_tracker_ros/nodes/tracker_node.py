# SPDX-License-Identifier: Apache-2.0
"""The tracker node: camera image -> msg_adapters -> Tracker.update -> /track/* (docs/tracker_node.md)."""

from __future__ import annotations

import dataclasses
import sys
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped, Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, Image, JointState, RegionOfInterest
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from msg_adapters.camera_info import Intrinsics, intrinsics_from_camera_info, intrinsics_from_fov
from msg_adapters.debug_image import render_debug
from msg_adapters.diagnostics import OK, STALE, WARN, diagnostic_array, status
from msg_adapters.errors import MessageError
from msg_adapters.geometry import box_from_roi, box_to_polygon, ego_shift, pan_tilt_error, pan_tilt_to_msg
from msg_adapters.image import image_to_numpy
from msg_adapters.joint_state import joint_state_to_pan_tilt
from msg_adapters.qos import profile
from msg_adapters.rate import head_rate, target_rate
from msg_adapters.stamps import header_of, stamp_to_seconds
from msg_adapters.track_state import track_result_to_msg
from msg_adapters.trigger import trigger_reply
from swir_tracker_ros import topics
from swir_tracker_ros.core import fhog
from swir_tracker_ros.errors import TrackerError
from swir_tracker_ros.nodes.graph import check_topic_names, input_publishers
from swir_tracker_ros.nodes.param_docs import GENERATED, ParamsFile, usage_lines
from swir_tracker_ros.nodes.param_docs import params_yaml as render_params_file
from swir_tracker_ros.nodes.ros_params import bind_parameters
from swir_tracker_ros.nodes.runner import run_node, signals_deferred, user_arguments
from swir_tracker_ros.nodes.tracker_node_params import (
    FORMAT_CHANGE_FRAMES,
    FrameStats,
    HeadPoseHistory,
    TrackerNodeParams,
    frame_problem,
)
from swir_tracker_ros.tracker import Tracker, TrackerParams
from swir_tracker_ros.types import Box, TrackResult, TrackState

NODE_NAME = "tracker"
DIAG_NAME = "swir_tracker/tracker_node"
TRACKER_PREFIX = "tracker."
ACTIVE = (TrackState.TRACKING, TrackState.OCCLUDED)

class TrackerNode(Node):
    """Wraps `Tracker`; owns no algorithm: decode, call the core, publish, keep statistics."""

    def __init__(self, **node_kwargs) -> None:
        super().__init__(NODE_NAME, **node_kwargs)
        self.params = bind_parameters(self, TrackerNodeParams, on_change=self._on_node_params)
        check_topic_names(self.params)
        self.tracker_params = bind_parameters(self, TrackerParams, prefix=TRACKER_PREFIX,
                                              on_change=self._on_tracker_params)
        self.tracker = Tracker(self.tracker_params)
        with signals_deferred():  # a Ctrl-C inside numba's ctypes callbacks would be swallowed there
            fhog.warm_up()  # the compiled FHOG loops load now (~1 s), not on the first tracked frame
        self.stats = FrameStats()
        self.poses = HeadPoseHistory()
        self.camera_intr: Intrinsics | None = None
        self.pending_init: Box | None = Box(*self.params.init_box) if self.params.init_box else None
        self.last_box: Box | None = None
        self.last_result: TrackResult | None = None
        self.last_stamp = 0.0
        self.frame_key: tuple | None = None  # (shape, dtype) of the frames being tracked
        self._new_key: tuple | None = None  # a different format seen while tracking, and how often in a row
        self._new_key_count = 0
        self._restart: str | None = None  # why the pending init restarts a running track (never silent)
        self.prev_pose: tuple[float, float] | None = None
        self.window_start = time.monotonic()
        self._warned: dict[str, tuple[float, int]] = {}  # kind -> (time of the last warning, held back)
        p = self.params
        output, sensor = profile(topics.RELIABLE), profile(topics.SENSOR)
        self.pub_box = self.create_publisher(PolygonStamped, topics.TRACK_BOX, output)
        self.pub_error = self.create_publisher(Vector3Stamped, topics.PAN_TILT_ERROR, output)
        self.pub_rate = self.create_publisher(Vector3Stamped, topics.TARGET_RATE, output)
        self.pub_state = self.create_publisher(DiagnosticArray, topics.TRACK_STATE, output)
        self.pub_debug = self.create_publisher(Image, topics.TRACK_DEBUG_IMAGE, profile(topics.DEBUG_IMAGE))
        self.pub_diag = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, output)
        guard = self._guard
        # a queue of one: the executor always takes the newest frame, never a backlog
        self.create_subscription(Image, p.image_topic, guard(self._on_image), profile(topics.LATEST))
        self.create_subscription(CameraInfo, p.camera_info_topic, guard(self._on_camera_info), sensor)
        self.create_subscription(JointState, p.joint_states_topic, guard(self._on_joint_state), sensor)
        self.create_subscription(RegionOfInterest, topics.TRACK_INIT, guard(self._on_init), output)
        self.create_service(Trigger, topics.TRACK_CANCEL, self._on_cancel)
        self.diag_timer = self.create_timer(p.diagnostics_period_s, self._guard(self._publish_diagnostics))
        self.get_logger().info(f"tracking {p.image_topic} with {self.tracker_params.pipeline}/"
                               f"{self.tracker_params.variant}; init box: {p.init_box or 'none'}")

    # ------------------------------------------------------------------ callbacks
    def _guard(self, fn):
        """Wrap a callback so that no exception escapes into the executor (logged, counted, throttled)."""
        def wrapped(*args):
            try:
                fn(*args)
            except Exception as exc:  # a callback must never take the node down
                if not self.context.ok():
                    return  # a signal shut the context down under the callback: not an error
                self.stats.errors += 1
                self._warn(fn.__name__, f"{fn.__name__} failed: {type(exc).__name__}: {exc}")
        return wrapped

    def _warn(self, kind: str, text: str) -> None:
        """A warning of one kind at most every `warn_throttle_s`, saying how many were held back."""
        now = time.monotonic()
        last, held = self._warned.get(kind, (-1e18, 0))
        if now - last < self.params.warn_throttle_s:
            self._warned[kind] = (last, held + 1)
            return
        self._warned[kind] = (now, 0)
        self.get_logger().warning(text + (f" ({held} similar since the last warning)" if held else ""))

    def _on_image(self, msg: Image) -> None:
        t_recv = time.perf_counter()
        self.stats.received += 1
        hdr = header_of(msg)
        stamp = stamp_to_seconds(hdr.stamp)
        if self._is_stale(stamp):
            self.stats.stale += 1
            return
        try:
            frame = image_to_numpy(msg)
        except MessageError as exc:
            self.stats.malformed += 1
            self._warn("image", f"dropped a malformed image: {exc}")
            return
        skipped_before = self.stats.skipped
        self.stats.frame_stamp(stamp)
        # frames since the last processed one (1 + those skipped in between): the core's Kalman prediction
        # advances over them (Tracker.update(frames=...))
        elapsed = 1.0 + max(self.stats.skipped - skipped_before, 0)
        self.last_stamp = stamp
        pixels = frame.pixels
        height, width = pixels.shape[:2]
        skip = frame_problem(pixels) or self._check_format(pixels)
        if skip:
            self._skip(hdr, skip)
            return
        intr = self._intrinsics(width, height)
        shift = self._ego_shift(stamp, intr)
        hint = {"bit_depth": self.params.bit_depth or frame.bit_depth} if pixels.dtype.itemsize == 2 else {}
        t_core = time.perf_counter()
        result = self._track(pixels, shift, hint, elapsed)
        core_ms = (time.perf_counter() - t_core) * 1e3
        self._publish(hdr, result, intr)
        if self.pub_debug.get_subscription_count() > 0:
            self.pub_debug.publish(render_debug(pixels, result, hdr))
        now = time.perf_counter()
        self.stats.processed += 1
        self.stats.latency_ms.append((now - t_recv) * 1e3)
        self.stats.core_ms.append(core_ms)
        self.stats.overhead_ms.append((now - t_recv) * 1e3 - core_ms)
        if stamp > 0:
            self.stats.age_ms.append((self.get_clock().now().nanoseconds * 1e-9 - stamp) * 1e3)

    def _on_camera_info(self, msg: CameraInfo) -> None:
        try:
            self.camera_intr = intrinsics_from_camera_info(msg)
        except MessageError as exc:
            self._warn("camera_info", f"ignoring CameraInfo, using the FOV fallback: {exc}")

    def _on_joint_state(self, msg: JointState) -> None:
        try:
            pan, tilt, stamp = joint_state_to_pan_tilt(msg)
        except MessageError as exc:
            self._warn("joint_state", f"ignoring a joint state: {exc}")
            return
        self.poses.add(stamp, pan, tilt)

    def _on_init(self, msg: RegionOfInterest) -> None:
        try:
            self.pending_init = box_from_roi(msg)
        except MessageError as exc:
            self._warn("init", f"ignoring {topics.TRACK_INIT}: {exc}")
            return
        self.get_logger().info(f"target selected: {self.pending_init.as_tuple()} (starts on the next frame)")

    def _on_cancel(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        was = self.tracker.state.value
        self.tracker.reset()
        self.pending_init = None
        self._restart = None
        self.last_box = None
        self.last_result = None
        text = f"tracking cancelled (state was {was})"
        self.get_logger().info(text)
        return trigger_reply(response, True, text)

    def _on_node_params(self, params: TrackerNodeParams) -> None:
        if params.init_box and params.init_box != self.params.init_box:
            self.pending_init = Box(*params.init_box)
        if params.diagnostics_period_s != self.params.diagnostics_period_s:
            self.destroy_timer(self.diag_timer)
            self.diag_timer = self.create_timer(params.diagnostics_period_s,
                                                self._guard(self._publish_diagnostics))
        self.params = params

    def _on_tracker_params(self, params: TrackerParams) -> None:
        """New core parameters: a fresh core, re-initialised on the last box at the next frame."""
        self.tracker_params = params
        self.tracker = Tracker(params)
        if self.pending_init is None and self.last_box is not None and self.last_result is not None \
                and self.last_result.state in ACTIVE:
            self.pending_init = self.last_box
            self._restart = "the parameter change"
        self.get_logger().info("tracker parameters changed; core restarted")

    # ------------------------------------------------------------------ per-frame pieces
    def _is_stale(self, stamp: float) -> bool:
        """Older than (or equal to) the last frame, or older than max_frame_age_s on the node clock.

        A jump back by more than a second is a restarted source (bag loop), not a stale frame.
        """
        if stamp > 0 and self.last_stamp > 0 and self.last_stamp - 1.0 < stamp <= self.last_stamp:
            return True
        max_age = self.params.max_frame_age_s
        return max_age > 0 and stamp > 0 and self.get_clock().now().nanoseconds * 1e-9 - stamp > max_age

    def _check_format(self, pixels) -> str | None:
        """Follow the frame size / pixel format; a reason to skip this frame, or None to track it.

        Without a track or a pending selection a new format is taken at once. Otherwise a frame of another
        format is skipped until FORMAT_CHANGE_FRAMES of that format arrive in a row; then the core restarts
        on the last (or the pending) box scaled to the new size. One odd frame (a driver glitch) therefore
        never ends a track, and a genuine, persistent change re-initialises it.
        """
        key = (pixels.shape, pixels.dtype.str)
        old = self.frame_key
        if old is None or old == key:
            self.frame_key, self._new_key, self._new_key_count = key, None, 0
            return None
        active = self.tracker.state in ACTIVE and self.last_box is not None
        if active or self.pending_init is not None:  # a track, or a selection made in the old format
            self._new_key_count = self._new_key_count + 1 if key == self._new_key else 1
            self._new_key = key
            if self._new_key_count < FORMAT_CHANGE_FRAMES:
                return (f"format {_fmt_key(key)} differs from the tracked {_fmt_key(old)} "
                        f"({self._new_key_count} of {FORMAT_CHANGE_FRAMES} in a row before re-initialising)")
        (oh, ow), (nh, nw) = old[0][:2], key[0][:2]
        self.frame_key, self._new_key, self._new_key_count = key, None, 0
        self.prev_pose = None
        if self.pending_init is not None:
            self.pending_init = _scale_box(self.pending_init, nw / ow, nh / oh)
        elif active:
            self.pending_init = _scale_box(self.last_box, nw / ow, nh / oh)
            self._restart = "the format change"
        self.tracker.reset()
        if self.pending_init is not None:  # nothing tracked and nothing selected: nothing to say
            self.get_logger().warning(f"image format changed from {_fmt_key(old)} to {_fmt_key(key)}; "
                                      f"tracker re-initialised on {_fmt_box(self.pending_init)}")
        return None

    def _skip(self, header: Header, reason: str) -> None:
        """A decoded frame the core is not given: counted, warned about (throttled), and answered on
        /track/state with the unchanged track state (measured false), never a silent stop."""
        self.stats.unusable += 1
        self._warn("unusable", f"skipped a frame: {reason}")
        last = self.last_result
        if last is None or self.tracker.state is TrackState.IDLE:
            result = TrackResult(box=Box(0.0, 0.0, 0.0, 0.0), state=TrackState.IDLE)
        else:
            result = dataclasses.replace(last, measured=False, model_updated=False, search_windows=())
        self.pub_state.publish(track_result_to_msg(result, header))

    def _intrinsics(self, width: int, height: int) -> Intrinsics:
        if self.params.use_camera_info and self.camera_intr is not None:
            return self.camera_intr.scaled_to(width, height)
        return intrinsics_from_fov(width, height, self.params.fov_h_deg, self.params.fov_v_deg)

    def _ego_shift(self, stamp: float, intr: Intrinsics) -> tuple[float, float]:
        """Image shift caused by the head since the previous frame (head pose interpolated at the stamp)."""
        pose = self.poses.at(stamp)
        prev, self.prev_pose = self.prev_pose, pose
        if not self.params.ego_motion_compensation or pose is None or prev is None:
            return (0.0, 0.0)
        return ego_shift(pose[0] - prev[0], pose[1] - prev[1], intr)

    def _track(self, pixels, shift: tuple[float, float], hint: dict, elapsed: float = 1.0
               ) -> TrackResult | None:
        if self.pending_init is not None:
            box, self.pending_init = self.pending_init, None
            fresh = Tracker(self.tracker_params)  # a rejected box leaves the current track running
            restart, self._restart = self._restart, None
            try:
                fresh.init(pixels, box, **hint)
            except TrackerError as exc:
                if restart and self.tracker.state not in ACTIVE:  # the track ended: say so, never throttled
                    self.get_logger().warning(f"track ended: cannot re-initialise on {_fmt_box(box)} "
                                              f"after {restart}: {exc}")
                else:
                    self._warn("init", f"cannot start tracking {box.as_tuple()}: {exc}")
            else:
                self.tracker = fresh
                result = TrackResult(box=box, state=TrackState.TRACKING, measured=True)
                self.last_result, self.last_box = result, box
                return result
        if self.tracker.state is TrackState.IDLE:
            self.last_result = None
            return None
        result = self.tracker.update(pixels, ego_shift=shift, **hint, frames=elapsed)
        self.last_result = result
        if result.state in ACTIVE:
            self.last_box = result.box
        return result

    def _publish(self, header: Header, result: TrackResult | None, intr: Intrinsics) -> None:
        if result is None:
            result = TrackResult(box=Box(0.0, 0.0, 0.0, 0.0), state=TrackState.IDLE)
        active = result.state in ACTIVE and result.box.is_finite()
        self.pub_box.publish(box_to_polygon(result.box if active else None, header))
        if active:
            pan, tilt = pan_tilt_error(result.box.cx, result.box.cy, intr)
            self.pub_error.publish(pan_tilt_to_msg(pan, tilt, header))
            period, stamp = self.stats.period(50.0), stamp_to_seconds(header.stamp)
            ego = self.params.ego_motion_compensation
            head = (0.0, 0.0) if ego else head_rate(self.poses.at, stamp, period)
            if period > 0 and head is not None:  # track/target_rate: the error's layout and header
                rate = target_rate(result.box.cx, result.box.cy, result.velocity, period, intr, head)
                self.pub_rate.publish(pan_tilt_to_msg(*rate, header))
        self.pub_state.publish(track_result_to_msg(result, header))

    def _publish_diagnostics(self) -> None:
        now = time.monotonic()
        values, trouble = self.stats.report(now - self.window_start)
        self.window_start = now
        received = values["window_received"]
        if received == 0:
            level, text = STALE, f"no images on {self.params.image_topic}"
        elif trouble:
            level, text = WARN, "frames dropped or callback errors in the last period"
        else:
            level, text = OK, "ok"
        state = self.last_result.state.value if self.last_result else TrackState.IDLE.value
        values = {"state": state, "intrinsics": "camera_info" if self.params.use_camera_info and
                  self.camera_intr is not None else "fov", **values,
                  **input_publishers(self, (self.params.image_topic, self.params.camera_info_topic,
                                            self.params.joint_states_topic))}
        header = Header(stamp=self.get_clock().now().to_msg())
        self.pub_diag.publish(diagnostic_array(header, [status(DIAG_NAME, level, text, values, NODE_NAME)]))


def _scale_box(box: Box, sx: float, sy: float) -> Box:
    return Box(box.x * sx, box.y * sy, box.w * sx, box.h * sy)


def _fmt_key(key: tuple) -> str:
    shape, dtype = key
    return "x".join(map(str, shape)) + f" {np.dtype(dtype).name}"


def _fmt_box(box: Box) -> str:
    return "(" + ", ".join(f"{v:.1f}" for v in box.as_tuple()) + ")"


def usage() -> str:
    """`tracker --help`: how to start the node and every parameter with its default."""
    lines = ["usage: tracker [--help | --params-yaml]",
             "       tracker --ros-args --params-file params/tracker.yaml [-p name:=value ...]",
             "", "Tracks one target in a SWIR image stream; see docs/tracker_node.md.", "", "parameters:"]
    for prefix, cls in (("", TrackerNodeParams), (TRACKER_PREFIX, TrackerParams)):
        lines += usage_lines(cls, prefix)
    return "\n".join(lines)


PARAMS_FILE = ParamsFile(
    "params/tracker.yaml", "/**",
    (("", TrackerNodeParams, ""),
     ("tracker", TrackerParams, "the tracking core (swir_tracker_ros.tracker.TrackerParams)")),
    "Parameters of the `tracker` node (docs/tracker_node.md), every one at its default. " + GENERATED
    + " swir_tracker_ros/nodes/tracker_node_params.py and the core's params, not this file. Ranges are "
    "enforced; invalid runtime changes are rejected. `tracker --params-yaml` prints the same text. "
    "Use: ros2 run swir_tracker_ros tracker --ros-args --params-file params/tracker.yaml")


def params_yaml() -> str:
    """`tracker --params-yaml`: a params file with every parameter at its default, documented."""
    return render_params_file(PARAMS_FILE)


def main(argv: list[str] | None = None) -> int:
    """Console entry point `tracker`: spin until SIGINT/SIGTERM; exit 2 on a bad parameter."""
    args = list(sys.argv if argv is None else argv)
    if "--params-yaml" in user_arguments(args):
        sys.stdout.write(params_yaml())
        return 0
    return run_node(NODE_NAME, TrackerNode, args, usage=usage)


if __name__ == "__main__":
    sys.exit(main())
