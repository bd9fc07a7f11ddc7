# SPDX-License-Identifier: Apache-2.0
"""The positioner bridge's ROS surface, shared by the unmanaged and the managed (lifecycle) node: tracker
inputs, joint states, mode, diagnostics, the control services and the move action (docs/positioner.md)."""

from __future__ import annotations

import time
from collections.abc import Callable

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.node import Node
from rclpy.task import Future
from sensor_msgs.msg import JointState

from msg_adapters import diagnostics
from msg_adapters.errors import MessageError
from msg_adapters.geometry import pan_tilt_error_from_msg
from msg_adapters.head import (
    head_joint_state,
    jog_rates,
    mode_from_request,
    mode_msg,
    move_feedback,
    move_request,
    move_result,
    preset_from_request,
    set_mode_reply,
    zoom_from_request,
)
from msg_adapters.joint_state import PanTiltSample
from msg_adapters.qos import profile
from msg_adapters.rate import target_rate_from_msg
from msg_adapters.stamps import header
from msg_adapters.track_state import track_state_from_msg
from msg_adapters.trigger import trigger_reply
from swir_tracker_interfaces.action import MoveHead
from swir_tracker_interfaces.msg import HeadJog, HeadMode
from swir_tracker_interfaces.srv import HeadPreset, SetHeadMode, ZoomHead
from swir_tracker_ros import topics
from swir_tracker_ros.nodes.graph import input_publishers
from swir_tracker_ros.pelco.bridge import HeadMode as Mode
from swir_tracker_ros.pelco.bridge import MoveGoal, MoveKind, PositionerBridge
from swir_tracker_ros.pelco.params import PositionerParams

STATUS_NAME = "positioner"  # the task: the status is `<node full name>: positioner` (node_status_name)
FEEDBACK_PERIOD = 0.1  # s between two MoveHead feedback messages


class HeadSurface:
    """Everything the bridge shows on the ROS graph, around a `PositionerBridge` that exists while the
    node is configured (`bridge`) and steps while it is active (`active`)."""

    def __init__(self, node: Node, params: PositionerParams) -> None:
        self.node, self.params = node, params
        self.bridge: PositionerBridge | None = None
        self.active = False
        self._bad_messages = 0
        self._waiters: list[tuple[float, Future]] = []
        latest, reliable = profile(topics.LATEST), profile(topics.RELIABLE)
        # Best effort accepts both reliable and best-effort publishers; only the latest input matters.
        guard = self._guard
        node.create_subscription(Vector3Stamped, topics.PAN_TILT_ERROR, guard(self._on_error), latest)
        node.create_subscription(Vector3Stamped, topics.TARGET_RATE, guard(self._on_rate), latest)
        node.create_subscription(DiagnosticArray, topics.TRACK_STATE, guard(self._on_state), reliable)
        node.create_subscription(HeadJog, topics.HEAD_JOG, guard(self._on_jog), latest)
        self.joint_pub = node.create_publisher(JointState, topics.JOINT_STATES, reliable)
        self.diag_pub = node.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, reliable)
        self.mode_pub = node.create_publisher(HeadMode, topics.HEAD_MODE, profile(topics.LATCHED))
        node.create_service(SetHeadMode, topics.HEAD_SET_MODE, guard(self._on_set_mode))
        node.create_service(HeadPreset, topics.HEAD_GOTO_PRESET, guard(self._preset_service("goto")))
        node.create_service(HeadPreset, topics.HEAD_SET_PRESET, guard(self._preset_service("set")))
        node.create_service(HeadPreset, topics.HEAD_CLEAR_PRESET, guard(self._preset_service("clear")))
        node.create_service(ZoomHead, topics.HEAD_ZOOM, guard(self._on_zoom))
        self.action = ActionServer(node, MoveHead, topics.HEAD_MOVE, execute_callback=self._execute,
                                   goal_callback=lambda _goal: GoalResponse.ACCEPT,
                                   cancel_callback=lambda _handle: CancelResponse.ACCEPT)
        p = params
        tick = min(200.0, max(50.0, 2.0 * p.control_rate, 4.0 * p.feedback_rate))
        node.create_timer(1.0 / tick, self._tick)
        node.create_timer(1.0 / p.joint_state_rate, self._publish_joint_state)
        node.create_timer(1.0, self._publish_diagnostics)

    # -- life cycle -----------------------------------------------------------------------------------
    def make_bridge(self, mode: Mode | None = None) -> PositionerBridge:
        """A bridge on `params.port` (the port opens at its first step or `open_and_check`)."""
        self.bridge = PositionerBridge(self.params, log=self._log, clock=time.monotonic,
                                       on_mode=self._on_mode, mode=mode)
        return self.bridge

    def set_params(self, params: PositionerParams) -> None:
        self.params = params
        if self.bridge is not None:
            self.bridge.set_params(params)

    def publish_mode(self, mode: Mode, reason: str) -> None:
        self.mode_pub.publish(mode_msg(mode.value, reason, self._now_seconds()))

    def destroy(self) -> None:
        """Release the action server before the node (rclpy can abort at exit otherwise)."""
        for _, future in self._waiters:
            future.cancel()
        self._waiters = []
        self.action.destroy()

    # -- helpers --------------------------------------------------------------------------------------
    def _log(self, level: str, text: str) -> None:
        # one call site per severity: rclpy refuses a severity change at the same call site
        if level == "warn":
            self.node.get_logger().warning(text)
        else:
            self.node.get_logger().info(text)

    def _guard(self, fn: Callable) -> Callable:
        """A callback that never takes the node down: an unexpected exception is logged, and a service
        answers success false with the reason."""
        def wrapped(*args):
            try:
                return fn(*args)
            except Exception as exc:
                text = f"{getattr(fn, '__name__', 'callback')} failed: {type(exc).__name__}: {exc}"
                if self.node.context.ok():
                    self.node.get_logger().error(text, throttle_duration_sec=5.0)
                return trigger_reply(args[1], False, text) if len(args) == 2 else None
        return wrapped

    def _on_mode(self, mode: Mode, reason: str) -> None:
        self.node.get_logger().info(f"head mode: {mode.value} ({reason})")
        self.publish_mode(mode, reason)

    def _now_seconds(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    def _age(self, stamp: float) -> float:
        """Seconds from a message's header stamp to now on the node clock (0 for an unstamped message)."""
        return max(self._now_seconds() - stamp, 0.0) if stamp > 0 else 0.0

    def _bad(self, topic: str, exc: Exception) -> None:
        self._bad_messages += 1
        self.node.get_logger().warning(f"ignoring {topic}: {exc}", throttle_duration_sec=5.0)

    def _running(self) -> PositionerBridge | None:
        return self.bridge if self.active else None

    # -- inputs ---------------------------------------------------------------------------------------
    def _on_error(self, msg: Vector3Stamped) -> None:
        self._pan_tilt_input(msg, pan_tilt_error_from_msg, topics.PAN_TILT_ERROR, PositionerBridge.on_error)

    def _on_rate(self, msg: Vector3Stamped) -> None:
        self._pan_tilt_input(msg, target_rate_from_msg, topics.TARGET_RATE, PositionerBridge.on_rate)

    def _pan_tilt_input(self, msg: Vector3Stamped, read: Callable, topic: str, deliver: Callable) -> None:
        """Read (pan, tilt, stamp) with `read` and hand it to the running bridge with its age."""
        try:
            pan, tilt, stamp = read(msg)
        except MessageError as exc:
            return self._bad(topic, exc)
        if (bridge := self._running()) is not None:
            deliver(bridge, pan, tilt, age=self._age(stamp))

    def _on_state(self, msg: DiagnosticArray) -> None:
        try:
            state = track_state_from_msg(msg)
        except MessageError as exc:
            return self._bad(topics.TRACK_STATE, exc)
        if (bridge := self._running()) is not None:
            bridge.on_state(state)

    def _on_jog(self, msg: HeadJog) -> None:
        try:
            rates = jog_rates(msg, self.params.pan_joint, self.params.tilt_joint)
        except MessageError as exc:
            return self._bad(topics.HEAD_JOG, exc)
        bridge = self._running()
        ok, text = (False, "jog refused: the bridge is not active") if bridge is None else bridge.jog(*rates)
        if not ok:
            self.node.get_logger().warning(text, throttle_duration_sec=5.0)

    # -- services -------------------------------------------------------------------------------------
    def _on_set_mode(self, request: SetHeadMode.Request, response: SetHeadMode.Response
                     ) -> SetHeadMode.Response:
        bridge = self._running()
        current = bridge.mode.value if bridge is not None else Mode.RELEASED.value
        try:
            mode = Mode(mode_from_request(request))
        except MessageError as exc:
            return set_mode_reply(response, False, f"refused: {exc}", current)
        if bridge is None:
            return set_mode_reply(response, False, "refused: the bridge is not active", current)
        ok, text = bridge.set_mode(mode, topics.HEAD_SET_MODE)
        return set_mode_reply(response, ok, text, bridge.mode.value)

    def _preset_service(self, action: str) -> Callable:
        def serve(request: HeadPreset.Request, response: HeadPreset.Response) -> HeadPreset.Response:
            bridge, number = self._running(), preset_from_request(request)
            if bridge is None:
                return trigger_reply(response, False, f"{action} preset refused: the bridge is not active")
            if action == "goto":
                move, problem = bridge.start_move(MoveGoal(MoveKind.PRESET, preset=number))
                ok, text = (move is not None), problem or f"going to preset {number}"
            else:
                ok, text = bridge.preset(action, number)
            self._log("info" if ok else "warn", text)
            return trigger_reply(response, ok, text)

        return serve

    def _on_zoom(self, request: ZoomHead.Request, response: ZoomHead.Response) -> ZoomHead.Response:
        bridge = self._running()
        if bridge is None:
            return trigger_reply(response, False, "zoom refused: the bridge is not active")
        return trigger_reply(response, *bridge.zoom(zoom_from_request(request)))

    # -- action ---------------------------------------------------------------------------------------
    def _sleep(self, seconds: float) -> Future:
        """A future the tick timer completes after `seconds` (awaited by the action's coroutine)."""
        future = Future()
        self._waiters.append((time.monotonic() + seconds, future))
        return future

    def _joints(self) -> dict[str, float]:
        pose = self.bridge.pose() if self.bridge is not None else None
        if pose is None:
            return {}
        return {self.params.pan_joint: pose.pan, self.params.tilt_joint: pose.tilt}

    async def _execute(self, handle) -> MoveHead.Result:
        bridge = self._running()
        try:
            req = move_request(handle.request, self.params.pan_joint, self.params.tilt_joint)
            problem = "" if bridge is not None else "the bridge is not active"
        except MessageError as exc:
            req, problem = None, str(exc)
        move = None
        if not problem:
            goal = MoveGoal(MoveKind(req.kind), req.pan, req.tilt, req.preset, req.tolerance)
            move, problem = bridge.start_move(goal)
        if move is None:
            self._log("warn", f"move refused: {problem}")
            handle.abort()
            return move_result(False, f"refused: {problem}", self._joints(), [])
        self._log("info", f"{req.kind} move started")
        while not move.done:
            if handle.is_cancel_requested:
                bridge.cancel_move(move)
                handle.canceled()
                return move_result(False, "cancelled", self._joints(), move.errors)
            elapsed = time.monotonic() - move.started
            handle.publish_feedback(move_feedback(self._joints(), move.errors, elapsed))
            await self._sleep(FEEDBACK_PERIOD)
        (handle.succeed if move.success else handle.abort)()
        self._log("info" if move.success else "warn", f"{req.kind} move: {move.outcome}")
        return move_result(move.success, move.outcome, self._joints(), move.errors)

    # -- timers ---------------------------------------------------------------------------------------
    def _tick(self) -> None:
        now = time.monotonic()
        due = [f for t, f in self._waiters if t <= now]
        self._waiters = [(t, f) for t, f in self._waiters if t > now]
        for future in due:
            future.set_result(None)
        if (bridge := self._running()) is not None:
            bridge.step()

    def _publish_joint_state(self) -> None:
        bridge = self._running()
        mono = time.monotonic()
        pose = bridge.pose(mono) if bridge is not None else None
        if pose is None:
            return
        stamp = max(self._now_seconds() - (mono - pose.time), 0.0)
        sample = PanTiltSample(pose.pan, pose.tilt, pose.pan_velocity, pose.tilt_velocity, stamp)
        p = self.params
        self.joint_pub.publish(head_joint_state(sample, p.frame_id, (p.pan_joint, p.tilt_joint),
                                                bridge.feedback.zoom_position(mono), p.zoom_joint))

    def _publish_diagnostics(self) -> None:
        b, p = self.bridge, self.params
        inputs = input_publishers(self.node, (topics.PAN_TILT_ERROR, topics.TARGET_RATE, topics.TRACK_STATE))
        if b is None or not self.active:
            level, text, values = diagnostics.WARN, "inactive (lifecycle)", {}
        else:
            values = {**b.stats(), **{k: f"{v:.1f}" for k, v in b.latency_report().items()}}
            if b.mode == Mode.RELEASED:
                level, text = diagnostics.OK, b.reason
            elif not b.link.connected:
                level, text = diagnostics.ERROR, f"port {p.port} unavailable, retrying"
            elif b.pose() is None and p.feedback_rate > 0:
                level, text = diagnostics.WARN, "no position feedback"
            else:
                level, text = diagnostics.OK, b.reason
            values["feedback"] = "true" if b.pose() is not None else "false"
        values = dict(values, bad_messages=self._bad_messages, **inputs)
        # the port names the head: two heads at address 1 on their own lines differ (issue 39)
        name = diagnostics.node_status_name(self.node.get_fully_qualified_name(), STATUS_NAME)
        st = diagnostics.status(name, level, text, values, hardware_id=f"pelco-d:{p.address}@{p.port}")
        self.diag_pub.publish(diagnostics.diagnostic_array(header(self._now_seconds()), [st]))
