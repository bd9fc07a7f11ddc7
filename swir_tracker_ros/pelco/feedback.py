# SPDX-License-Identifier: Apache-2.0
"""Position feedback of a Pelco-D head: one query at a time on the half-duplex line, replies -> angles."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from swir_tracker_ros.pelco import codec
from swir_tracker_ros.pelco.link import SerialLink
from swir_tracker_ros.pelco.params import PositionerParams
from swir_tracker_ros.pelco.units import raw_to_angle, wrap_rad

# A joint whose measured rate is below this is standing still (rad/s): 0.3 deg/s, a third of the slowest
# useful tracking speed, and above the finite-difference noise of 0.01-degree words over a 0.1 s query cycle.
STILL_RATE = 0.005


@dataclass(frozen=True)
class Pose:
    """Last known head pose, our convention (rad, rad/s); `time` on the bridge clock."""

    pan: float
    tilt: float
    pan_velocity: float
    tilt_velocity: float
    time: float

    @property
    def still(self) -> bool:
        return abs(self.pan_velocity) < STILL_RATE and abs(self.tilt_velocity) < STILL_RATE


class Axis:
    """Position feedback of one joint with a finite-difference velocity."""

    def __init__(self, wraps: bool = True) -> None:
        self.wraps = wraps
        self.angle: float | None = None
        self.time = -math.inf
        self.velocity = 0.0

    def update(self, angle: float, now: float) -> None:
        if self.angle is not None and now - self.time > 1e-3:
            d = wrap_rad(angle - self.angle) if self.wraps else angle - self.angle
            self.velocity = d / (now - self.time)
        self.angle, self.time = angle, now

    def known(self, now: float, timeout: float) -> float | None:
        return self.angle if self.angle is not None and now - self.time <= timeout else None

    def estimate(self, now: float, timeout: float) -> float | None:
        """Known angle extrapolated to `now` with the measured velocity (for the soft limits)."""
        angle = self.known(now, timeout)
        return None if angle is None else angle + self.velocity * (now - self.time)


class Feedback:
    """Paces the position queries and decodes the replies (pan, tilt and, if enabled, zoom)."""

    def __init__(self, params: PositionerParams) -> None:
        self.p = params
        self.pan, self.tilt, self.zoom = Axis(), Axis(), Axis(wraps=False)
        self._queue: list[str] = []
        self._query: str | None = None
        self._query_time = -math.inf
        self._next = -math.inf
        self.replies = 0
        self.timeouts = 0

    def reset(self) -> None:
        """Drop the query in flight (reconnection, or the bus handed over)."""
        self._query, self._queue = None, []

    def on_frame(self, frame: codec.Frame, now: float) -> None:
        p = self.p
        if frame.address != p.address or frame.cmd1 != 0:
            return
        if frame.cmd2 == codec.PAN_POSITION_REPLY:
            sign = -p.pan_position_sign if p.invert_pan else p.pan_position_sign
            self.pan.update(raw_to_angle(frame.word, sign, p.pan_zero_deg), now)
            what = "pan"
        elif frame.cmd2 == codec.TILT_POSITION_REPLY:
            sign = -p.tilt_position_sign if p.invert_tilt else p.tilt_position_sign
            self.tilt.update(raw_to_angle(frame.word, sign, p.tilt_zero_deg), now)
            what = "tilt"
        elif frame.cmd2 == codec.ZOOM_POSITION_REPLY:
            self.zoom.update(min(frame.word / p.zoom_word_max, 1.0), now)
            what = "zoom"
        else:
            return
        self.replies += 1
        if self._query == what:
            self._query = None

    def poll(self, now: float, link: SerialLink) -> None:
        """One query at a time, one reply per query (half-duplex lines; flir_ptu issue #29)."""
        if self.p.feedback_rate <= 0.0 or not link.connected:
            return
        if self._query is not None and now - self._query_time > self.p.reply_timeout:
            self.timeouts += 1
            self._query = None
        if self._query is None and not self._queue and now >= self._next:
            self._next = max(self._next + 1.0 / self.p.feedback_rate, now)
            self._queue = ["pan", "tilt", "zoom"] if self.p.zoom_feedback else ["pan", "tilt"]
        if self._query is None and self._queue:
            what = self._queue.pop(0)
            if link.write(codec.query(self.p.address, what)):
                self._query, self._query_time = what, now

    def pose(self, now: float) -> Pose | None:
        """Last feedback if both joints are known within `feedback_timeout`, else None."""
        timeout = self.p.feedback_timeout
        pan, tilt = self.pan.known(now, timeout), self.tilt.known(now, timeout)
        if pan is None or tilt is None:
            return None
        # The joints are queried one after the other: bring the older reading forward to the newer one's
        # time with its velocity, so that the pose and its stamp describe one instant.
        t = max(self.pan.time, self.tilt.time)
        pan += self.pan.velocity * (t - self.pan.time)
        tilt += self.tilt.velocity * (t - self.tilt.time)
        return Pose(pan, tilt, self.pan.velocity, self.tilt.velocity, t)

    def zoom_position(self, now: float) -> float | None:
        """Zoom as a fraction 0 (wide) .. 1 (tele) when the head reported it recently, else None."""
        return self.zoom.known(now, self.p.feedback_timeout) if self.p.zoom_feedback else None


def probe_head(link: SerialLink, decoder: codec.StreamDecoder, feedback: Feedback, timeout: float,
               clock: Callable[[], float] = time.monotonic) -> str:
    """Query the pan position once on an open link and wait up to `timeout` s for the reply; '' when the
    head answered (or is never queried: feedback_rate 0), else why not."""
    p = feedback.p
    if p.feedback_rate <= 0.0:
        return ""
    replies, end = feedback.replies, clock() + timeout
    link.write(codec.query(p.address, "pan"))
    while clock() < end and feedback.replies == replies:
        for frame in decoder.feed(link.read()):
            feedback.on_frame(frame, clock())
        time.sleep(0.01)
    if feedback.replies == replies:
        return (f"no reply from the head at address {p.address} on {p.port} within {timeout:g} s "
                "(wiring, baud, address?)")
    return ""
