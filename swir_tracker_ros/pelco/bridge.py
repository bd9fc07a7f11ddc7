# SPDX-License-Identifier: Apache-2.0
"""ROS-free core of the positioner bridge: modes, watchdog, control timing, queries, safe shutdown."""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from swir_tracker_ros.pelco import codec
from swir_tracker_ros.pelco.controller import STOP, MotionCommand, PanTiltController
from swir_tracker_ros.pelco.feedback import Feedback, Pose, probe_head
from swir_tracker_ros.pelco.follow import Demand, Follower, percentile_ms
from swir_tracker_ros.pelco.link import Log, SerialLink, no_log
from swir_tracker_ros.pelco.manual import (
    HeadMode,
    Manual,
    Move,
    MoveGoal,
    MoveKind,
    absolute_goal,
    limit_problem,
    move_done,
    move_problem,
)
from swir_tracker_ros.pelco.params import PositionerParams
from swir_tracker_ros.types import TrackState

__all__ = ["HeadMode", "MoveGoal", "MoveKind", "Pose", "PositionerBridge"]
ModeListener = Callable[[HeadMode, str], None]
RELEASED_TEXT = "released: another controller owns the bus"


class PositionerBridge:
    """Drives a Pelco-D head on a `SerialLink` from the mode's source of commands; call `step()` often.

    Modes (docs/positioner.md): `tracking` follows the tracker's error and the target's rate, `manual` the
    operator's jog / move / zoom, `idle` holds the head stopped, `released` writes nothing at all. Every
    mode change writes a stop first. A frame is written when the command changes or `keepalive_period` has
    passed; the first frame after every (re)connection is a stop (not in `released`). `shutdown()` writes a
    stop (not in `released`) and closes the port.
    """

    def __init__(self, params: PositionerParams, link: SerialLink | None = None, *, log: Log = no_log,
                 clock: Callable[[], float] = time.monotonic, on_mode: ModeListener | None = None,
                 mode: HeadMode | None = None) -> None:
        self.p = params.validate()
        self.log, self.clock = log, clock
        self.link = link or SerialLink(params.port, params.baud, log=log, backoff_min=params.reconnect_min,
                                       backoff_max=params.reconnect_max, clock=clock)
        self.controller = PanTiltController(params)
        self.decoder = codec.StreamDecoder()
        self.feedback = Feedback(params)
        self.follower = Follower(params)
        self.manual = Manual(params)
        self.mode = HeadMode(params.initial_mode if mode is None else mode)  # no stop yet: not connected
        self.on_mode = on_mode or (lambda _mode, _reason: None)
        self._last_sent: MotionCommand | None = None
        self._last_sent_time = -math.inf
        self._next_control = -math.inf
        self._last_control: float | None = None
        self._input_pending = False
        self.command: MotionCommand = STOP
        self.reason = "starting"
        self.frames_sent = 0
        self.write_ages: list[float] = []  # frame stamp -> tracking command on the wire, s

    # -- inputs ---------------------------------------------------------------------------------------
    def set_params(self, params: PositionerParams) -> None:
        """Accept a validated runtime change (the link keeps its URL until restart)."""
        self.p = params.validate()
        self.controller = PanTiltController(params)
        self.feedback.p = self.follower.p = self.manual.p = params

    def _now(self, now: float | None) -> float:
        return self.clock() if now is None else now

    def on_error(self, pan_error: float, tilt_error: float, now: float | None = None,
                 age: float = 0.0) -> None:
        """/track/pan_tilt_error, `age` s after its camera frame (0 when unstamped)."""
        if self.follower.on_error(pan_error, tilt_error, self._now(now), age):
            self._input_pending = True

    def on_rate(self, pan_rate: float, tilt_rate: float, now: float | None = None, age: float = 0.0) -> None:
        """track/target_rate: the target's angular rate (rad/s), `age` s after its camera frame."""
        self.follower.on_rate(pan_rate, tilt_rate, self._now(now), age)

    def on_state(self, state: TrackState, now: float | None = None) -> None:
        self.follower.on_state(state, self._now(now))

    @property
    def track_state(self) -> TrackState | None:
        return self.follower.state

    # -- ownership ------------------------------------------------------------------------------------
    def set_mode(self, mode: HeadMode, reason: str, now: float | None = None) -> tuple[bool, str]:
        """Hand the head to `mode`: a stop is written first (also before `released` falls silent)."""
        mode = HeadMode(mode)
        if mode == self.mode:
            return True, f"already {mode.value}"
        now = self._now(now)
        old, self.mode = self.mode, mode
        self.manual.clear(f"mode changed to {mode.value}")
        self.follower.reset()
        self.controller.reset()
        self.feedback.reset()
        if self.link.connected:
            self._send(STOP, now)
        self.command, self.reason = STOP, RELEASED_TEXT if mode == HeadMode.RELEASED else mode.value
        self.on_mode(mode, reason)
        return True, f"mode {old.value} -> {mode.value} ({reason})"

    def _take_manual(self, what: str, now: float) -> str:
        """'' when a manual command may run (switching to manual first), else the reason it may not."""
        if self.mode == HeadMode.RELEASED:
            return f"{what} refused: the head is released (set the mode to take it back)"
        if not self.link.connected:
            return f"{what} refused: port {self.p.port} unavailable"
        if self.mode != HeadMode.MANUAL:
            self.set_mode(HeadMode.MANUAL, what, now)
        return ""

    # -- manual commands (each pre-empts tracking) -----------------------------------------------------
    def jog(self, pan_rate: float, tilt_rate: float, now: float | None = None) -> tuple[bool, str]:
        """Move at these joint rates (rad/s) until `jog_timeout` after the last jog."""
        now = self._now(now)
        if not (math.isfinite(pan_rate) and math.isfinite(tilt_rate)):
            return False, f"jog refused: rates must be finite, got {pan_rate}, {tilt_rate}"
        problem = self._take_manual("jog", now)
        if problem:
            return False, problem
        self.manual.jog(pan_rate, tilt_rate, now)
        self._input_pending = True
        return True, "jogging"

    def zoom(self, direction: int, now: float | None = None) -> tuple[bool, str]:
        """Zoom in (+1, tele), out (-1, wide) or stop (0) until told otherwise."""
        if direction not in (-1, 0, 1):
            return False, f"zoom direction must be -1 (wide), 0 (stop) or +1 (tele), got {direction}"
        now = self._now(now)
        problem = self._take_manual("zoom", now)
        if problem:
            return False, problem
        self.manual.zoom = direction
        self._input_pending = True
        return True, {1: "zooming in", -1: "zooming out", 0: "zoom stopped"}[direction]

    def start_move(self, goal: MoveGoal, now: float | None = None) -> tuple[Move | None, str]:
        """(the move, '') or (None, why not) for an absolute, relative or preset move."""
        now = self._now(now)
        pose = self.pose(now)
        problem = move_problem(goal, self.p, pose)
        if not problem and goal.kind != MoveKind.PRESET:
            problem = limit_problem(*absolute_goal(goal, pose), self.p)
        problem = problem or self._take_manual(f"{goal.kind.value} move", now)
        if problem:
            return None, problem
        move = self.manual.start(goal, pose, now)
        self._input_pending = True
        return move, ""

    def cancel_move(self, move: Move, now: float | None = None) -> None:
        """Stop the head if `move` is still the running one (a cancelled action goal)."""
        if self.manual.move is move and not move.done:
            self.manual.abort_move("cancelled")
            self.controller.reset()
            self._send(STOP, self._now(now))
        move.finish(False, "cancelled")

    def preset(self, action: str, number: int) -> tuple[bool, str]:
        """Store ('set') or delete ('clear') preset `number` (1-255) in the head; moves nothing."""
        if not 1 <= number <= 255:
            return False, f"preset must be 1-255, got {number}"
        if self.mode == HeadMode.RELEASED:
            return False, f"{action} preset refused: the head is released (set the mode to take it back)"
        encode = {"set": codec.set_preset, "clear": codec.clear_preset}[action]
        if not self.link.write(encode(self.p.address, number)):
            return False, f"{action} preset refused: port {self.p.port} unavailable"
        self.frames_sent += 1
        return True, f"preset {number} {'stored' if action == 'set' else 'cleared'}"

    # -- outputs --------------------------------------------------------------------------------------
    def pose(self, now: float | None = None) -> Pose | None:
        """Last feedback if both joints are known within `feedback_timeout`, else None."""
        return self.feedback.pose(self._now(now))

    def stats(self) -> dict[str, str]:
        f = self.feedback
        return {
            "connected": str(self.link.connected).lower(), "mode": self.mode.value, "reason": self.reason,
            "command": self.command.to_bytes(self.p.address).hex(" "), "frames_sent": str(self.frames_sent),
            "replies": str(f.replies), "checksum_errors": str(self.decoder.checksum_errors),
            "discarded_bytes": str(self.decoder.discarded), "query_timeouts": str(f.timeouts),
            "connects": str(self.link.connects), "link_failures": str(self.link.failures),
            "feed_forward": str(self.follower.feed_forward_on).lower(),
        }

    def latency_report(self) -> dict[str, float]:
        """Frame stamp -> bridge arrival and -> Pelco frame written (ms), since the last report."""
        ages, self.write_ages = self.write_ages, []
        return {**self.follower.latency_report(), "command_age_ms_p50": percentile_ms(ages, 50),
                "command_age_ms_p95": percentile_ms(ages, 95)}

    # -- loop -----------------------------------------------------------------------------------------
    def step(self, now: float | None = None) -> None:
        """Reconnect if due, read replies, run the controller when a period is due (or a fresh input
        arrived, at most twice per period), pace queries. In `released` only reads."""
        now = self._now(now)
        if self.link.poll(now):
            self.decoder.reset()
            self.controller.reset()
            self.feedback.reset()
            if self.mode != HeadMode.RELEASED:
                self._send(STOP, now)  # whatever the head was doing while we were away, stop it first
        for frame in self.decoder.feed(self.link.read()):
            self.feedback.on_frame(frame, now)
        if self.mode == HeadMode.RELEASED:
            return
        period = 1.0 / self.p.control_rate
        early = self._input_pending and now - (self._last_control or -math.inf) >= 0.5 * period
        if now >= self._next_control or early:
            self._input_pending = False
            self._next_control = max(self._next_control + period, now) if not early else now + period
            self._control(now, period)
        self.feedback.poll(now, self.link)

    def _control(self, now: float, period: float) -> None:
        dt = period if self._last_control is None else min(max(now - self._last_control, 0.0), 5 * period)
        self._last_control = now
        if not self.link.connected:
            self.controller.reset()
            self.command, self.reason = STOP, "link down"
            return
        demand: Demand | None = None
        if self.mode == HeadMode.TRACKING:
            demand, cmd = self._tracking(now, dt)
        elif self.mode == HeadMode.MANUAL:
            cmd = self._manual(now, dt)
            if cmd is None:  # a position move is under way: the head runs it, the bridge only listens
                return
        else:
            self.controller.reset()
            cmd, self.reason = STOP, "idle"
        self.command = cmd
        keepalive = self.p.keepalive_period > 0 and now - self._last_sent_time >= self.p.keepalive_period
        if (cmd != self._last_sent or keepalive) and self._send(cmd, now) and demand is not None:
            self.write_ages.append(demand.error_age)
            del self.write_ages[:-500]

    def _positions(self, now: float) -> tuple[float | None, float | None]:
        timeout = self.p.feedback_timeout
        return self.feedback.pan.estimate(now, timeout), self.feedback.tilt.estimate(now, timeout)

    def _tracking(self, now: float, dt: float) -> tuple[Demand | None, MotionCommand]:
        demand = self.follower.demand(now, self.controller.sent_rates)
        pan, tilt = self._positions(now)
        if isinstance(demand, str):
            self.reason = demand
        elif self.p.require_feedback and (pan is None or tilt is None):
            self.reason = "position unknown"
        else:
            cmd = self.controller.step(demand.pan_error, demand.tilt_error, dt, pan, tilt, demand.gain,
                                       demand.feed_forward)
            self.reason = "moving" if not cmd.is_stop else "deadband or limit"
            return demand, cmd
        self.controller.reset()
        return None, STOP

    def _manual(self, now: float, dt: float) -> MotionCommand | None:
        move = self.manual.move
        if move is not None:
            if not move.sent:
                move.sent = self.link.write(move.frames)
                self.frames_sent += move.sent
                self._last_sent, self.reason = None, f"{move.goal.kind.value} move"
                return None
            done, move.errors = move_done(move, self.pose(now), now)
            if not done and now < move.deadline:
                return None
            move.finish(done, "reached the goal" if done else
                        f"not complete after {self.p.move_timeout:g} s (move_timeout); stopped")
            self.manual.move = None
        pan, tilt = self._positions(now)
        rates = self.manual.rates(now)
        if rates == (0.0, 0.0) and self.manual.zoom == 0:
            self.controller.reset()
            self.reason = "manual: holding"
            return STOP
        self.reason = "manual: jog" if rates != (0.0, 0.0) else "manual: zoom"
        if self.p.require_feedback and (pan is None or tilt is None) and rates != (0.0, 0.0):
            self.reason, rates = "position unknown", (0.0, 0.0)
        return self.controller.rates(*rates, dt, pan, tilt, self.manual.zoom)

    def _send(self, cmd: MotionCommand, now: float) -> bool:
        if self.link.write(cmd.to_bytes(self.p.address)):
            self._last_sent, self._last_sent_time = cmd, now
            self.frames_sent += 1
            return True
        self._last_sent = None
        return False

    # -- life cycle -----------------------------------------------------------------------------------
    def open_and_check(self, timeout: float) -> str:
        """Open the port now and, when the head is queried (feedback_rate > 0), wait up to `timeout` s for
        a position reply; '' on success, else why not (the lifecycle's configure)."""
        if not self.link.connected and not self.link.poll(self.clock()):
            return f"cannot open {self.p.port}"
        return probe_head(self.link, self.decoder, self.feedback, timeout, self.clock)

    def shutdown(self) -> str:
        """Write a stop (reopening the port once if it is down), let it leave, close. Returns 'written',
        'not written' (port unavailable) or 'released' (nothing written: the head belongs to another
        controller, and a stop could cut its move short)."""
        if self.mode == HeadMode.RELEASED:
            self.link.close()
            return "released"
        if not self.link.connected:
            self.link.poll(math.inf)
        sent = self.link.write(STOP.to_bytes(self.p.address)) and self.link.drain()
        if sent:
            self.frames_sent += 1
        self.link.close()
        return "written" if sent else "not written"
