# SPDX-License-Identifier: Apache-2.0
"""ROS-free core of the positioner bridge: watchdog, control timing, position queries, safe shutdown."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from swir_tracker_ros.pelco import codec
from swir_tracker_ros.pelco.controller import STOP, MotionCommand, PanTiltController
from swir_tracker_ros.pelco.link import Log, SerialLink, no_log
from swir_tracker_ros.pelco.params import PositionerParams
from swir_tracker_ros.pelco.units import raw_to_angle, wrap_rad
from swir_tracker_ros.types import TrackState

STOPPING_STATES = (TrackState.LOST, TrackState.IDLE)


@dataclass(frozen=True)
class Pose:
    """Last known head pose, our convention (rad, rad/s); `time` on the bridge clock."""

    pan: float
    tilt: float
    pan_velocity: float
    tilt_velocity: float
    time: float


class _Axis:
    """Position feedback of one joint with a finite-difference velocity."""

    def __init__(self) -> None:
        self.angle: float | None = None
        self.time = -math.inf
        self.velocity = 0.0

    def update(self, angle: float, now: float) -> None:
        if self.angle is not None and now - self.time > 1e-3:
            self.velocity = wrap_rad(angle - self.angle) / (now - self.time)
        self.angle, self.time = angle, now

    def known(self, now: float, timeout: float) -> float | None:
        return self.angle if self.angle is not None and now - self.time <= timeout else None

    def estimate(self, now: float, timeout: float) -> float | None:
        """Known angle extrapolated to `now` with the measured velocity (for the soft limits)."""
        angle = self.known(now, timeout)
        return None if angle is None else angle + self.velocity * (now - self.time)


class PositionerBridge:
    """Turns the latest pan/tilt error into Pelco-D frames on a `SerialLink`; call `step()` often.

    A stop is commanded when the error is older than `watchdog_timeout`, the tracker state is lost or
    idle, the error is inside the deadband, or (with `require_feedback`) the position is unknown. A frame
    is written when the command changes or `keepalive_period` has passed; the first frame after every
    (re)connection is a stop. `shutdown()` writes a stop and closes the port.
    """

    def __init__(self, params: PositionerParams, link: SerialLink | None = None, *, log: Log = no_log,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.p = params.validate()
        self.log, self.clock = log, clock
        self.link = link or SerialLink(params.port, params.baud, log=log, backoff_min=params.reconnect_min,
                                       backoff_max=params.reconnect_max, clock=clock)
        self.controller = PanTiltController(params)
        self.decoder = codec.StreamDecoder()
        self.pan, self.tilt = _Axis(), _Axis()
        self._error: tuple[float, float] = (0.0, 0.0)
        self._error_time = -math.inf
        self.track_state: TrackState | None = None
        self._last_sent: MotionCommand | None = None
        self._last_sent_time = -math.inf
        self._next_control = -math.inf
        self._last_control: float | None = None
        self._queue: list[str] = []
        self._query: str | None = None
        self._query_time = -math.inf
        self._next_feedback = -math.inf
        self.command: MotionCommand = STOP
        self.reason = "starting"
        self.frames_sent = 0
        self.replies = 0
        self.query_timeouts = 0

    # -- inputs ---------------------------------------------------------------------------------------
    def set_params(self, params: PositionerParams) -> None:
        """Accept a validated runtime change (the link keeps its URL until restart)."""
        self.p = params.validate()
        self.controller = PanTiltController(params)

    def on_error(self, pan_error: float, tilt_error: float, now: float | None = None) -> None:
        if math.isfinite(pan_error) and math.isfinite(tilt_error):
            self._error = (pan_error, tilt_error)
            self._error_time = self.clock() if now is None else now

    def on_state(self, state: TrackState) -> None:
        self.track_state = state

    # -- outputs --------------------------------------------------------------------------------------
    def pose(self, now: float | None = None) -> Pose | None:
        """Last feedback if both joints are known within `feedback_timeout`, else None."""
        now = self.clock() if now is None else now
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

    def stats(self) -> dict[str, str]:
        return {
            "connected": str(self.link.connected).lower(), "reason": self.reason,
            "command": self.command.to_bytes(self.p.address).hex(" "), "frames_sent": str(self.frames_sent),
            "replies": str(self.replies), "checksum_errors": str(self.decoder.checksum_errors),
            "discarded_bytes": str(self.decoder.discarded), "query_timeouts": str(self.query_timeouts),
            "connects": str(self.link.connects), "link_failures": str(self.link.failures),
        }

    # -- loop -----------------------------------------------------------------------------------------
    def step(self, now: float | None = None) -> None:
        """Reconnect if due, read replies, pace queries, and run the controller when a period is due."""
        now = self.clock() if now is None else now
        if self.link.poll(now):
            self.decoder.reset()
            self.controller.reset()
            self._query, self._queue = None, []
            self._send(STOP, now)  # whatever the head was doing while we were away, stop it first
        for frame in self.decoder.feed(self.link.read()):
            self._on_frame(frame, now)
        if now >= self._next_control:
            period = 1.0 / self.p.control_rate
            self._next_control = max(self._next_control + period, now)
            self._control(now, period)
        self._feedback(now)

    def _on_frame(self, frame: codec.Frame, now: float) -> None:
        if frame.address != self.p.address or frame.cmd1 != 0:
            return
        p = self.p
        if frame.cmd2 == codec.PAN_POSITION_REPLY:
            sign = -p.pan_position_sign if p.invert_pan else p.pan_position_sign
            self.pan.update(raw_to_angle(frame.word, sign, p.pan_zero_deg), now)
            what = "pan"
        elif frame.cmd2 == codec.TILT_POSITION_REPLY:
            sign = -p.tilt_position_sign if p.invert_tilt else p.tilt_position_sign
            self.tilt.update(raw_to_angle(frame.word, sign, p.tilt_zero_deg), now)
            what = "tilt"
        else:
            return
        self.replies += 1
        if self._query == what:
            self._query = None

    def _feedback(self, now: float) -> None:
        """One query at a time, one reply per query (half-duplex lines; flir_ptu issue #29)."""
        if self.p.feedback_rate <= 0.0 or not self.link.connected:
            return
        if self._query is not None and now - self._query_time > self.p.reply_timeout:
            self.query_timeouts += 1
            self._query = None
        if self._query is None and not self._queue and now >= self._next_feedback:
            self._next_feedback = max(self._next_feedback + 1.0 / self.p.feedback_rate, now)
            self._queue = ["pan", "tilt"]
        if self._query is None and self._queue:
            what = self._queue.pop(0)
            if self.link.write(codec.query(self.p.address, what)):
                self._query, self._query_time = what, now

    def _decide(self, now: float, dt: float) -> MotionCommand:
        p = self.p
        if now - self._error_time > p.watchdog_timeout:
            self.reason = "watchdog: no pan/tilt error"
        elif self.track_state in STOPPING_STATES:
            self.reason = f"tracker {self.track_state.value}"
        else:
            pan = self.pan.estimate(now, p.feedback_timeout)
            tilt = self.tilt.estimate(now, p.feedback_timeout)
            if p.require_feedback and (pan is None or tilt is None):
                self.reason = "position unknown"
            else:
                gain = p.occluded_gain if self.track_state == TrackState.OCCLUDED else 1.0
                cmd = self.controller.step(*self._error, dt, pan, tilt, gain)
                self.reason = "moving" if not cmd.is_stop else "deadband or limit"
                return cmd
        self.controller.reset()
        return STOP

    def _control(self, now: float, period: float) -> None:
        dt = period if self._last_control is None else min(max(now - self._last_control, 0.0), 5 * period)
        self._last_control = now
        if not self.link.connected:
            self.controller.reset()
            self.command, self.reason = STOP, "link down"
            return
        self.command = self._decide(now, dt)
        keepalive = self.p.keepalive_period > 0 and now - self._last_sent_time >= self.p.keepalive_period
        if self.command != self._last_sent or keepalive:
            self._send(self.command, now)

    def _send(self, cmd: MotionCommand, now: float) -> None:
        if self.link.write(cmd.to_bytes(self.p.address)):
            self._last_sent, self._last_sent_time = cmd, now
            self.frames_sent += 1
        else:
            self._last_sent = None

    def shutdown(self) -> bool:
        """Write a stop (reopening the port once if it is down), let it leave, close; True if sent."""
        if not self.link.connected:
            self.link.poll(math.inf)
        sent = self.link.write(STOP.to_bytes(self.p.address)) and self.link.drain()
        if sent:
            self.frames_sent += 1
        self.link.close()
        return sent
