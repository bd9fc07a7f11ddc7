# SPDX-License-Identifier: Apache-2.0
"""The tracker node's stamped, acknowledged target selection: `track/select`, clicks on the image, the
history of recent frames and the catch-up timer (the ROS side of `nodes/selection.py`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from geometry_msgs.msg import Point, PointStamped
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.task import Future

from msg_adapters.errors import MessageError
from msg_adapters.qos import profile
from msg_adapters.selection import Selection, selection_from_click, selection_from_request, selection_reply
from swir_tracker_interfaces.srv import SelectTarget
from swir_tracker_ros import topics
from swir_tracker_ros.nodes.selection import (
    CatchUp,
    Code,
    FrameHistory,
    SelectionRules,
    StoredFrame,
    Verdict,
    fmt_box,
    start_box,
)
from swir_tracker_ros.nodes.tracker_node_params import TrackerNodeParams
from swir_tracker_ros.tracker import Tracker, TrackerParams

CATCHUP_PERIOD_S = 0.001  # the catch-up timer: one stored frame per tick, live callbacks in between
MIB = 1 << 20


class SelectionHost(Protocol):
    """What the selection needs of the tracker node."""

    params: TrackerNodeParams
    tracker_params: TrackerParams
    frame_size: tuple[int, int]  # width, height of the frames being tracked (0, 0 before the first)

    def get_logger(self) -> Any: ...

    def adopt(self, job: CatchUp) -> None:
        """The caught-up track replaces the current one and its last result is published."""

    def shift_between(self, t0: float, t1: float, width: int, height: int) -> tuple[float, float]:
        """Image shift (pixels) the head caused between two frame stamps."""


class Selector:
    """Keeps the recent frames, starts a selection on the frame it names and steps its catch-up."""

    def __init__(self, node: Node, host: SelectionHost, guard: Callable) -> None:
        self.node, self.host = node, host
        p = host.params
        self.history = FrameHistory(p.history_max_age_s, int(p.history_max_mb * MIB))
        self.catchup: CatchUp | None = None
        self._waiting: list[Callable[[Verdict], None]] = []  # who is told the running catch-up's verdict
        self._timer = None
        if p.click_msg != "off":
            click_type = PointStamped if p.click_msg == "point_stamped" else Point
            for image in (p.image_topic, topics.TRACK_DEBUG_IMAGE):
                node.create_subscription(click_type, topics.mouse_left_topic(image), guard(self._on_click),
                                         profile(topics.RELIABLE))
        # A request waits (as a coroutine) for its catch-up: in a group of its own, so that it does not hold
        # the default group that the catch-up timer and the image callbacks run in.
        node.create_service(SelectTarget, topics.TRACK_SELECT, self._on_select,
                            callback_group=ReentrantCallbackGroup())

    @property
    def busy(self) -> bool:
        """A selection is catching up: live frames only join the history."""
        return self.catchup is not None

    def set_bounds(self, params: TrackerNodeParams) -> None:
        self.history.max_age_s = params.history_max_age_s
        self.history.max_bytes = int(params.history_max_mb * MIB)

    def store(self, frame: StoredFrame) -> None:
        self.history.add(frame)

    def select(self, selection: Selection, source: str, done: Callable[[Verdict], None]) -> None:
        """Start `selection` on its stored frame (a rejection is answered at once); `done(verdict)` runs
        when it has caught up, failed or been superseded."""
        p, log = self.host.params, self.host.get_logger()
        rules = SelectionRules(p.select_stamp_tolerance_s, p.select_min_size, p.click_box_size)
        frame = self.history.find(selection.stamp, rules.tolerance_s)
        box = start_box(frame, selection.box, selection.point, rules) if isinstance(frame, StoredFrame) \
            else frame
        if isinstance(box, Verdict):
            log.warning(f"selection from {source} rejected ({box.code.name}): {box.reason}")
            done(box)
            return
        self.end(Verdict(Code.SUPERSEDED, f"superseded by a newer selection from {source}"))
        job = CatchUp(Tracker(self.host.tracker_params), frame, box, self.history, self.host.shift_between)
        log.info(f"selection from {source}: {fmt_box(box)} on the frame stamped {frame.stamp:.3f}, "
                 f"{len(self.history)} frames stored")
        self.catchup, self._waiting = job, [done]
        self._timer = self.node.create_timer(CATCHUP_PERIOD_S, self._advance)

    def end(self, verdict: Verdict) -> None:
        """Stop the running catch-up (if any) and tell whoever waits for it; the current track stays."""
        if self.catchup is None:
            return
        if self._timer is not None:
            self.node.destroy_timer(self._timer)
        waiting, self.catchup, self._waiting, self._timer = self._waiting, None, [], None
        for notify in waiting:
            notify(verdict)

    def _advance(self) -> None:
        """One stored frame of the catch-up per timer tick; when caught up, the new track takes over."""
        job = self.catchup
        try:
            if job is None or not job.step():
                return
        except Exception as exc:  # the core never raises on an ndarray; anything else ends the selection
            self.end(Verdict(Code.TRACKER_FAILED, f"catching up failed: {type(exc).__name__}: {exc}"))
            return
        verdict = job.verdict or Verdict(Code.TRACKER_FAILED, "the catch-up ended without a verdict")
        if verdict.accepted:
            self.host.adopt(job)
        self.end(verdict)

    def _on_click(self, msg: Point | PointStamped) -> None:
        try:
            selection = selection_from_click(msg)
        except MessageError as exc:
            self.host.get_logger().warning(f"ignoring a click: {exc}", throttle_duration_sec=5.0)
            return
        self.select(selection, "a click", self._log_verdict)

    async def _on_select(self, request: SelectTarget.Request, response: SelectTarget.Response
                         ) -> SelectTarget.Response:
        """`track/select`: answered once the track has caught up to the newest frame, or at once with the
        reason it cannot start."""
        try:
            selection = selection_from_request(request)
        except MessageError as exc:
            return selection_reply(response, Code.OUTSIDE_IMAGE.name, str(exc))
        answer: Future = Future()
        self.select(selection, topics.TRACK_SELECT, answer.set_result)
        verdict: Verdict = await answer
        width, height = self.host.frame_size
        return selection_reply(response, verdict.code.name, verdict.reason, verdict.stamp, verdict.box,
                               width, height)

    def _log_verdict(self, verdict: Verdict) -> None:
        if verdict.accepted:
            self.host.get_logger().info(f"selection accepted: {verdict.reason}")
        elif verdict.code is not Code.SUPERSEDED:
            self.host.get_logger().warning(f"selection failed ({verdict.code.name}): {verdict.reason}")
