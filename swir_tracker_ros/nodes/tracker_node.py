# SPDX-License-Identifier: Apache-2.0
"""The tracker node: camera image -> msg_adapters -> Tracker.update -> track/* (docs/tracker_node.md)."""

from __future__ import annotations

import dataclasses
import sys
import time

import cv2
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.node import Node
from sensor_msgs.msg import CompressedImage, Image, RegionOfInterest
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from msg_adapters.compressed import compressed_to_numpy
from msg_adapters.diagnostics import OK, STALE, WARN, diagnostic_array, node_status_name, status
from msg_adapters.errors import MessageError
from msg_adapters.geometry import box_from_roi
from msg_adapters.image import Frame, image_to_numpy
from msg_adapters.qos import profile
from msg_adapters.stamps import header_of, stamp_to_seconds
from msg_adapters.trigger import trigger_reply
from swir_tracker_ros import topics
from swir_tracker_ros.configs import DEFAULT_CONFIGURATION, ConfigurationChoice, configuration
from swir_tracker_ros.errors import ModelError, ParameterError, TrackerError
from swir_tracker_ros.nodes.graph import check_topic_names, input_publishers
from swir_tracker_ros.nodes.param_docs import GENERATED, ParamsFile, usage_lines
from swir_tracker_ros.nodes.param_docs import params_yaml as render_params_file
from swir_tracker_ros.nodes.ros_params import bind_parameters
from swir_tracker_ros.nodes.runner import run_node, signals_deferred, user_arguments
from swir_tracker_ros.nodes.selection import CatchUp, Code, StoredFrame, Verdict
from swir_tracker_ros.nodes.tracker_inputs import HeadInputs
from swir_tracker_ros.nodes.tracker_node_params import (
    FormatWatch,
    FrameStats,
    TrackerNodeParams,
    fmt_key,
    frame_problem,
    missing_models,
)
from swir_tracker_ros.nodes.tracker_outputs import ACTIVE, IDLE_RESULT, TrackOutputs
from swir_tracker_ros.nodes.tracker_selection import MIB, Selector
from swir_tracker_ros.tracker import Tracker, TrackerParams
from swir_tracker_ros.types import Box, TrackResult, TrackState

NODE_NAME = "tracker"
DIAG_NAME = "tracker_node"  # the task: the status is `<node full name>: tracker_node` (node_status_name)
TRACKER_PREFIX = "tracker."


class TrackerNode(Node):
    """Wraps `Tracker`; owns no algorithm: decode, call the core, publish, keep statistics."""

    def __init__(self, **node_kwargs) -> None:
        super().__init__(NODE_NAME, **node_kwargs)
        self.params = bind_parameters(self, TrackerNodeParams, on_change=self._on_node_params)
        check_topic_names(self.params)
        # the named configuration first; its own parameters are declared with its values as defaults
        self.choice = bind_parameters(self, ConfigurationChoice, prefix=TRACKER_PREFIX)
        self.tracker_params = bind_parameters(self, self.choice.build(), prefix=TRACKER_PREFIX,
                                              on_change=self._on_tracker_params, vet=missing_models)
        cv2.setNumThreads(self.params.threads)
        try:
            self.tracker = Tracker(self.tracker_params)
        except ModelError as exc:  # one line, exit 2: the network configurations without their model files
            raise ModelError(f"{exc}; or track without a network: tracker.configuration:=measured") from None
        with signals_deferred():  # a Ctrl-C inside numba's ctypes callbacks would be swallowed there
            Tracker.warm_up()  # the compiled loops load now (~1 s), not on the first tracked frame
        self.stats = FrameStats()
        self.pending_init: Box | None = Box(*self.params.init_box) if self.params.init_box else None
        self.last_box: Box | None = None
        self.last_result: TrackResult | None = None
        self.last_stamp = 0.0
        self.format = FormatWatch()  # the size and pixel format of the frames being tracked
        self._restart: str | None = None  # why the pending init restarts a running track (never silent)
        self.window_start = time.monotonic()
        self._warned: dict[str, tuple[float, int]] = {}  # kind -> (time of the last warning, held back)
        p = self.params
        self._untracked = 0.0  # frame periods received while a selection caught up, unseen by the core
        self.outputs = TrackOutputs(self)
        guard, output = self._guard, profile(topics.RELIABLE)
        self.pub_diag = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, output)
        # a queue of one: the executor always takes the newest frame, never a backlog
        image_type = Image if p.image_transport == "raw" else CompressedImage
        self.image_input = topics.transport_topic(p.image_topic, p.image_transport)
        self.create_subscription(image_type, self.image_input, guard(self._on_image), profile(topics.LATEST),
                                 event_callbacks=SubscriptionEventCallbacks(message_lost=self._on_lost))
        self.inputs = HeadInputs(self, p, guard, self._warn)  # camera_info, joint states, ego-motion
        self.create_subscription(RegionOfInterest, topics.TRACK_INIT, guard(self._on_init), output)
        self.create_service(Trigger, topics.TRACK_CANCEL, self._on_cancel)
        self.selector = Selector(self, self, guard)  # track/select, clicks, recent frames, catch-up
        self.diag_timer = self.create_timer(p.diagnostics_period_s, self._guard(self._publish_diagnostics))
        base = type(self.tracker_params.base).__name__
        self.get_logger().info(f"tracking {self.resolve_topic_name(self.image_input)} ({p.image_transport}) "
                               f"with configuration {self.choice.configuration} ({base}); "
                               f"init box: {p.init_box or 'none'}")

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

    def _on_lost(self, info) -> None:
        """DDS lost image samples on the way (fragments of a large frame, a full socket buffer): transport
        loss, counted apart from frames overwritten in the depth-1 queue (`dropped_lost` on /diagnostics)."""
        self.stats.lost += int(info.total_count_change)

    def _on_image(self, msg: Image | CompressedImage) -> None:
        t_recv = time.perf_counter()
        self.stats.received += 1
        hdr = header_of(msg)
        stamp = stamp_to_seconds(hdr.stamp)
        if self._is_stale(stamp):
            self.stats.stale += 1
            return
        try:
            frame = image_to_numpy(msg) if isinstance(msg, Image) else compressed_to_numpy(msg)
        except MessageError as exc:
            self.stats.malformed += 1
            self._warn("image", f"dropped a malformed image: {exc}")
            return
        self._on_frame(hdr, stamp, frame, t_recv)

    def _on_frame(self, hdr: Header, stamp: float, frame: Frame, t_recv: float) -> None:
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
        depth = (self.params.bit_depth or frame.bit_depth) if pixels.dtype.itemsize == 2 else None
        self.selector.store(StoredFrame(stamp, pixels, depth, elapsed, hdr))
        intr = self.inputs.intrinsics(width, height)
        if self.selector.busy:  # this frame waits in the history for the selection's catch-up
            self._untracked += elapsed
            self.outputs.publish_state(hdr, self._unmeasured(), width, height)
            return
        shift = self.inputs.ego_shift(stamp, intr)
        t_core = time.perf_counter()
        result = self._track(pixels, shift, {} if depth is None else {"bit_depth": depth},
                             elapsed + self._untracked)
        self._untracked = 0.0
        core_ms = (time.perf_counter() - t_core) * 1e3
        self.outputs.publish(hdr, result, intr, self._head_motion(stamp))
        self.outputs.publish_debug(pixels, result, hdr, self.params.debug_jpeg_quality)
        now = time.perf_counter()
        self.stats.processed += 1
        self.stats.latency_ms.append((now - t_recv) * 1e3)
        self.stats.core_ms.append(core_ms)
        self.stats.overhead_ms.append((now - t_recv) * 1e3 - core_ms)
        if stamp > 0:
            self.stats.age_ms.append((self.get_clock().now().nanoseconds * 1e-9 - stamp) * 1e3)

    def _on_init(self, msg: RegionOfInterest) -> None:
        try:
            box = box_from_roi(msg)
        except MessageError as exc:
            self._warn("init", f"ignoring {topics.TRACK_INIT}: {exc}")
            return
        self.selector.end(Verdict(Code.SUPERSEDED, f"superseded by {topics.TRACK_INIT}"))
        self.pending_init = box
        self.get_logger().info(f"target selected: {box.as_tuple()} (starts on the next frame)")

    def _on_cancel(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        was = self.tracker.state.value
        self.selector.end(Verdict(Code.SUPERSEDED, f"cancelled on {topics.TRACK_CANCEL}"))
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
        self.selector.set_bounds(params)
        self.params = self.inputs.params = params

    def _on_tracker_params(self, params: TrackerParams) -> None:
        """New core parameters: a fresh core, re-initialised on the last box at the next frame."""
        self.selector.end(Verdict(Code.SUPERSEDED, "superseded by a change of the tracker parameters"))
        self.tracker_params, self.tracker = params, Tracker(params)  # models checked by `missing_models`
        if self.pending_init is None and self.last_box is not None and self.last_result is not None \
                and self.last_result.state in ACTIVE:
            self.pending_init = self.last_box
            self._restart = "the parameter change"
        self.get_logger().info("tracker parameters changed; core restarted")

    # ------------------------------------------------------------------ stamped selection (Selector)
    @property
    def frame_size(self) -> tuple[int, int]:
        """(width, height) of the frames being tracked; (0, 0) before the first."""
        shape = self.format.key[0] if self.format.key else (0, 0)
        return int(shape[1]), int(shape[0])

    def adopt(self, job: CatchUp) -> None:
        """A selection has caught up: its core replaces the current one; its newest result is published."""
        self.tracker, self.last_result, self.last_box = job.tracker, job.result, job.box
        if job.result is not None and job.result.state in ACTIVE:
            self.last_box = job.result.box
        self.pending_init, self._restart, self._untracked = None, None, 0.0
        self.inputs.prev_pose = self.inputs.poses.at(job.frame.stamp)
        height, width = job.frame.pixels.shape[:2]
        self.outputs.publish(job.frame.msg_header, job.result, self.inputs.intrinsics(width, height),
                             self._head_motion(job.frame.stamp))

    def _head_motion(self, stamp: float) -> tuple[float, tuple[float, float]] | None:
        """`HeadInputs.head_motion` with the camera's median frame period (known after 5 intervals)."""
        return self.inputs.head_motion(stamp, self.stats.period(50.0))

    def shift_between(self, t0: float, t1: float, width: int, height: int) -> tuple[float, float]:
        """Image shift caused by the head between two frame stamps (the Selector's catch-up asks)."""
        return self.inputs.shift_between(t0, t1, width, height)

    def _unmeasured(self) -> TrackResult:
        """The current state without a measurement: what a frame that the core did not see reports."""
        last = self.last_result
        if last is None or self.tracker.state is TrackState.IDLE:
            return IDLE_RESULT
        return dataclasses.replace(last, measured=False, model_updated=False, search_windows=())

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
        """Follow the frame size / pixel format (`FormatWatch`); a reason to skip this frame, or None.

        A persistent change restarts the core on the last (or the pending) box scaled to the new size.
        """
        active = self.tracker.state in ACTIVE and self.last_box is not None
        skip, old = self.format.check(pixels, holding=active or self.pending_init is not None)
        if old is None:
            return skip
        (oh, ow), (nh, nw) = old[0][:2], pixels.shape[:2]
        self.inputs.prev_pose = None
        self.selector.history.clear()  # a selection names a frame of the new format
        self.selector.end(Verdict(Code.TRACKER_FAILED, "the image format changed while catching up"))
        if self.pending_init is not None:
            self.pending_init = _scale_box(self.pending_init, nw / ow, nh / oh)
        elif active:
            self.pending_init = _scale_box(self.last_box, nw / ow, nh / oh)
            self._restart = "the format change"
        self.tracker.reset()
        if self.pending_init is not None:  # nothing tracked and nothing selected: nothing to say
            self.get_logger().warning(f"image format changed from {fmt_key(old)} to "
                                      f"{fmt_key(self.format.key)}; tracker re-initialised on "
                                      f"{_fmt_box(self.pending_init)}")
        return None

    def _skip(self, header: Header, reason: str) -> None:
        """A decoded frame the core is not given: counted, warned about (throttled), and answered on
        track/state with the unchanged track state (measured false), never a silent stop."""
        self.stats.unusable += 1
        self._warn("unusable", f"skipped a frame: {reason}")
        self.outputs.publish_state(header, self._unmeasured(), *self.frame_size)

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

    def _publish_diagnostics(self) -> None:
        now = time.monotonic()
        values, trouble = self.stats.report(now - self.window_start)
        self.window_start = now
        received = values["window_received"]
        if received == 0:
            level, text = STALE, f"no images on {self.resolve_topic_name(self.image_input)}"
        elif trouble:
            level, text = WARN, "frames dropped or callback errors in the last period"
        else:
            level, text = OK, "ok"
        state = self.last_result.state.value if self.last_result else TrackState.IDLE.value
        values = {"state": state, **self.inputs.report(), **values,
                  "selecting": "true" if self.selector.busy else "false",
                  "history_frames": len(self.selector.history),
                  "history_mb": self.selector.history.nbytes / MIB,
                  **input_publishers(self, (self.image_input, self.inputs.camera_info_topic,
                                            self.params.joint_states_topic))}
        header = Header(stamp=self.get_clock().now().to_msg())
        name = self.get_fully_qualified_name()
        self.pub_diag.publish(diagnostic_array(header, [status(node_status_name(name, DIAG_NAME), level, text,
                                                               values, name)]))


def _scale_box(box: Box, sx: float, sy: float) -> Box:
    return Box(box.x * sx, box.y * sy, box.w * sx, box.h * sy)


def _fmt_box(box: Box) -> str:
    return "(" + ", ".join(f"{v:.1f}" for v in box.as_tuple()) + ")"


def usage() -> str:
    """`tracker --help`: how to start the node and every parameter with its default."""
    lines = ["usage: tracker [--help | --params-yaml]",
             "       tracker --ros-args --params-file params/tracker.yaml [-p name:=value ...]",
             "", "Tracks one target in a SWIR image stream; see docs/tracker_node.md.", "", "parameters:"]
    for prefix, cls in (("", TrackerNodeParams), (TRACKER_PREFIX, ConfigurationChoice),
                        (TRACKER_PREFIX, TrackerParams)):
        lines += usage_lines(cls, prefix)
    return "\n".join(lines)


PARAMS_FILE = ParamsFile(
    "params/tracker.yaml", "/**",
    (("", TrackerNodeParams, ""),
     ("tracker", (ConfigurationChoice, configuration(DEFAULT_CONFIGURATION)),
      "the core: a named configuration (swir_tracker_ros/configs/) and its TrackerParams")),
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
    return run_node(NODE_NAME, TrackerNode, args, startup_errors=(ParameterError, ModelError), usage=usage)


if __name__ == "__main__":
    sys.exit(main())
