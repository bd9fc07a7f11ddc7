# SPDX-License-Identifier: Apache-2.0
"""Stamped target selection, ROS-free: the recent frames, the checks that accept or reject a selection,
and the catch-up that starts a track in the past and brings it to the present (docs/tracker_node.md,
"Selecting a target").

The operator selects a target on a frame that is already 100-500 ms old, on a head that may be moving.
`FrameHistory` keeps the decoded frames of the last `max_age_s` seconds (and at most `max_bytes`); a
selection names the stamp of the frame it was made on. `resolve()` finds that frame and the start box (the
box itself, or `box_around_point` for a click) or says why not (`Verdict`); `CatchUp` then runs
`Tracker.init` on that frame and `Tracker.update` on every stored frame since, one frame per `step()`, with
the ego shift of the head between consecutive frames from the head poses known at catch-up time (which by
then include the joint states that arrived after the frames). The node calls `step()` from a timer, so live
frames keep arriving between steps and are appended to the history the catch-up works through.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from swir_tracker_ros.errors import TrackerError
from swir_tracker_ros.nodes.point_box import box_around_point
from swir_tracker_ros.tracker import Tracker
from swir_tracker_ros.types import Box, TrackResult, TrackState


class Code(str, Enum):
    """Outcome of a selection; the names are swir_tracker_interfaces/srv/SelectTarget's constants."""

    ACCEPTED = "accepted"
    NO_FRAME = "no frame"
    STAMP_TOO_OLD = "stamp too old"
    OUTSIDE_IMAGE = "outside the image"
    TOO_SMALL = "too small"
    NO_OBJECT = "no object"
    SUPERSEDED = "superseded"
    TRACKER_FAILED = "tracker failed"


@dataclass(frozen=True)
class Verdict:
    """The answer to a selection: a code, a one-line reason and, once accepted, where the track started."""

    code: Code
    reason: str
    stamp: float = 0.0
    box: Box | None = None

    @property
    def accepted(self) -> bool:
        return self.code is Code.ACCEPTED


@dataclass(frozen=True)
class StoredFrame:
    """A decoded frame as the tracker saw it: stamp (s), pixels, bit-depth hint for 16-bit frames, frame
    periods since the previous frame (> 1 when frames were lost), and the message header (opaque here)."""

    stamp: float
    pixels: np.ndarray
    bit_depth: int | None
    elapsed: float
    msg_header: Any = None


class FrameHistory:
    """The frames of the last `max_age_s` seconds, newest last, at most `max_bytes` of pixels in all."""

    def __init__(self, max_age_s: float, max_bytes: int) -> None:
        self.max_age_s, self.max_bytes = max_age_s, max_bytes
        self.frames: deque[StoredFrame] = deque()
        self.nbytes = 0

    def __len__(self) -> int:
        return len(self.frames)

    def add(self, frame: StoredFrame) -> None:
        """Append the newest frame and drop the oldest ones beyond the age and memory bounds (the newest
        frame is always kept)."""
        self.frames.append(frame)
        self.nbytes += frame.pixels.nbytes
        while len(self.frames) > 1 and (self.nbytes > self.max_bytes
                                        or frame.stamp - self.frames[0].stamp > self.max_age_s):
            self.nbytes -= self.frames.popleft().pixels.nbytes

    def clear(self) -> None:
        self.frames.clear()
        self.nbytes = 0

    def after(self, stamp: float) -> StoredFrame | None:
        """The oldest stored frame newer than `stamp`, or None."""
        return next((f for f in self.frames if f.stamp > stamp), None)

    def find(self, stamp: float, tolerance_s: float) -> StoredFrame | Verdict:
        """The frame nearest to `stamp` (0: the newest) within `tolerance_s`, or a rejection saying why."""
        if not self.frames:
            return Verdict(Code.NO_FRAME, "no frame received yet")
        newest, oldest = self.frames[-1], self.frames[0]
        if stamp <= 0.0:
            return newest
        best = min(self.frames, key=lambda f: abs(f.stamp - stamp))
        if abs(best.stamp - stamp) <= tolerance_s:
            return best
        if stamp < oldest.stamp:
            age, kept = newest.stamp - stamp, newest.stamp - oldest.stamp
            return Verdict(Code.STAMP_TOO_OLD, f"stamp {stamp:.3f} is {age:.3f} s before the newest frame; "
                           f"the oldest stored frame is {kept:.3f} s old (history_max_age_s "
                           f"{self.max_age_s:g}, {len(self.frames)} frames stored)")
        if stamp > newest.stamp:
            return Verdict(Code.NO_FRAME, f"no frame with stamp {stamp:.3f} yet (the newest is "
                           f"{newest.stamp:.3f})")
        return Verdict(Code.NO_FRAME, f"no stored frame within {tolerance_s:g} s of stamp {stamp:.3f} "
                       f"(nearest {best.stamp:.3f})")


@dataclass(frozen=True)
class SelectionRules:
    """How a selection is checked and a click turned into a box (node parameters)."""

    tolerance_s: float = 0.1
    min_size: float = 4.0
    click_box_size: float = 32.0


def start_box(frame: StoredFrame, box: Box | None, point: tuple[float, float] | None,
              rules: SelectionRules) -> Box | Verdict:
    """The box a selection starts from on `frame` (the box, or the object under the point), or why not."""
    height, width = frame.pixels.shape[:2]
    if point is not None:
        x, y = point
        if not (0.0 <= x < width and 0.0 <= y < height):
            return Verdict(Code.OUTSIDE_IMAGE, f"point ({x:g}, {y:g}) is outside the {width}x{height} image")
        found = box_around_point(frame.pixels, x, y, rules.click_box_size, rules.min_size)
        box = found.box
    if box is None:
        return Verdict(Code.NO_OBJECT, "the selection has neither a box nor a point")
    if not (box.is_finite() and 0.0 <= box.cx < width and 0.0 <= box.cy < height):
        return Verdict(Code.OUTSIDE_IMAGE, f"box {fmt_box(box)} has its centre outside the {width}x{height} "
                       "image")
    if min(box.w, box.h) < rules.min_size:
        return Verdict(Code.TOO_SMALL, f"box {fmt_box(box)} is smaller than select_min_size "
                       f"{rules.min_size:g} px on a side")
    return box


def fmt_box(box: Box) -> str:
    return "(" + ", ".join(f"{v:.1f}" for v in box.as_tuple()) + ")"


# ego shift (dx, dy) pixels of the scene between the stamps of two frames (head poses), for frames of a size
EgoShift = Callable[[float, float, int, int], tuple[float, float]]


class CatchUp:
    """A track started on a stored frame and brought up to the newest stored one, a frame per `step()`.

    `done` once the newest stored frame has been tracked (or the track failed); then `verdict` says how it
    went, `tracker` is the caught-up core and `result` / `frame` its last result and frame.
    """

    def __init__(self, tracker: Tracker, frame: StoredFrame, box: Box, history: FrameHistory,
                 shift: EgoShift) -> None:
        self.tracker, self.history, self.shift = tracker, history, shift
        self.start, self.frame, self.box = frame, frame, box
        self.frames_done = 0
        self.verdict: Verdict | None = None
        self.result: TrackResult | None = None
        try:
            tracker.init(frame.pixels, box, bit_depth=frame.bit_depth)
        except TrackerError as exc:
            self.verdict = Verdict(Code.TRACKER_FAILED, f"cannot start on {fmt_box(box)}: {exc}")
            return
        self.result = TrackResult(box=box, state=TrackState.TRACKING, measured=True)

    @property
    def done(self) -> bool:
        return self.verdict is not None

    def step(self) -> bool:
        """Track the next stored frame; True when caught up (or failed)."""
        if self.done:
            return True
        nxt = self.history.after(self.frame.stamp)
        if nxt is None:
            self._finish()
            return True
        if nxt.pixels.shape != self.frame.pixels.shape or nxt.pixels.dtype != self.frame.pixels.dtype:
            self.verdict = Verdict(Code.TRACKER_FAILED, "the image format changed while catching up")
            return True
        height, width = nxt.pixels.shape[:2]
        shift = self.shift(self.frame.stamp, nxt.stamp, width, height)
        self.result = self.tracker.update(nxt.pixels, ego_shift=shift, bit_depth=nxt.bit_depth,
                                          frames=nxt.elapsed)
        self.frame = nxt
        self.frames_done += 1
        if self.result.state not in (TrackState.TRACKING, TrackState.OCCLUDED):
            self.verdict = Verdict(Code.TRACKER_FAILED, f"the track was {self.result.state.value} after "
                                   f"{self.frames_done} frames of catching up")
            return True
        return False

    def _finish(self) -> None:
        self.verdict = Verdict(Code.ACCEPTED, f"tracking from {fmt_box(self.box)} on the frame stamped "
                               f"{self.start.stamp:.3f}; caught up over {self.frames_done} frames",
                               self.start.stamp, self.box)
