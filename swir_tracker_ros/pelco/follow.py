# SPDX-License-Identifier: Apache-2.0
"""Tracking mode: the tracker's error and the target's angular rate -> what the joints should do.

The head follows a moving target without lag when its rate is fed forward and the P/PI term only corrects
what remains (a P loop alone chasing a ramp trails it by rate / kp: 0.82 deg at 0.82 deg/s and kp 1,
issue 34). Every input carries the time of the camera frame it describes, so the follower knows how old it
is: a fresh error is carried forward to now with the rate difference, a stale one gets no feed-forward.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.pelco.params import PositionerParams
from swir_tracker_ros.types import TrackState

STOPPING_STATES = (TrackState.LOST, TrackState.IDLE)
# While occluded the head coasts on the median of the target's rates measured over this long before the
# occlusion began (s): the tracker's velocity already sags while the target slides behind the occluder
# (0.82 -> 0.56 deg/s over the last 0.3 s in demo seed 505), so the very last rate under-states it.
COAST_RATE_WINDOW = 0.5


@dataclass(frozen=True)
class Sample:
    """One pan/tilt input pair; `measured` is its camera frame's time and `received` its arrival, both
    on the bridge's clock (s)."""

    pan: float
    tilt: float
    measured: float
    received: float


@dataclass(frozen=True)
class Demand:
    """What tracking asks of the controller this period: errors (rad, carried to now), the P/PI gain and
    the feed-forward rates (rad/s)."""

    pan_error: float
    tilt_error: float
    gain: float
    feed_forward: tuple[float, float]
    error_age: float  # s from the error's camera frame to now


def coast_factor(occluded_for: float, coast_time: float, coast_decay: float) -> float:
    """Weight of the feed-forward while the tracker coasts on its prediction (state `occluded`).

    1 for `coast_time` seconds (the prediction is the best guess of where the target went), then
    falling linearly to 0 over `coast_decay` seconds, so a target that stopped behind an occluder is not
    chased across the scene: w = clip(1 - (t - coast_time) / coast_decay, 0, 1).
    """
    if occluded_for <= coast_time:
        return 1.0
    if coast_decay <= 0.0:
        return 0.0
    return min(max(1.0 - (occluded_for - coast_time) / coast_decay, 0.0), 1.0)


def lead_factor(error: float, feed_forward: float, lead_limit: float) -> float:
    """Weight of a measured target's feed-forward: clip(1 + sign(w_ff) * e / lead_limit, 0, 1).

    While the head lags the target or is on it (the error points along the feed-forward rate) the rate
    is trusted in full; as the head gets ahead of the target (the target is slowing down or stopping,
    and the tracker's velocity estimate takes a few frames to follow) it fades out, reaching zero at a
    lead of `lead_limit` rad. The lead at which a stopped target holds the head then falls from
    w / kp to w / (kp + w / lead_limit). `lead_limit` 0 turns this off.
    """
    if lead_limit <= 0.0 or feed_forward == 0.0:
        return 1.0
    return min(max(1.0 + math.copysign(1.0, feed_forward) * error / lead_limit, 0.0), 1.0)


def carried_error(error: float, target_rate: float, head_rate: float, age: float, max_age: float) -> float:
    """The error at `now` from an error measured `age` seconds ago: e + (w_target - w_head) * age.

    The target kept moving at its rate and the head at its commanded rate since the frame was exposed
    (first-order prediction over the loop's latency); the carry is capped at `max_age` seconds.
    """
    return error + (target_rate - head_rate) * min(max(age, 0.0), max_age)


def percentile_ms(values: list[float], q: float) -> float:
    """q-th percentile of seconds, in ms (nan when empty)."""
    return 1e3 * float(np.percentile(values, q)) if values else math.nan


class Follower:
    """Holds the latest tracker inputs and turns them into a `Demand` (or a reason to stop)."""

    def __init__(self, params: PositionerParams) -> None:
        self.p = params
        self.error: Sample | None = None
        self.rate: Sample | None = None
        self.tracked: list[Sample] = []  # the rates measured while the target was tracked, recent ones
        self.state: TrackState | None = None
        self.state_since = -math.inf
        self.feed_forward_on = False
        self.arrival_ages: list[float] = []  # frame -> bridge, s, of the errors since the last report

    def reset(self) -> None:
        """Forget the inputs (a mode change): tracking starts again from fresh messages only."""
        self.error = self.rate = None
        self.tracked = []

    def on_error(self, pan: float, tilt: float, now: float, age: float = 0.0) -> bool:
        """A /track/pan_tilt_error message `age` s after its frame (0: unstamped); False if not finite."""
        if not (math.isfinite(pan) and math.isfinite(tilt)):
            return False
        age = max(age, 0.0) if math.isfinite(age) else 0.0
        self.error = Sample(pan, tilt, now - age, now)
        self.arrival_ages.append(age)
        del self.arrival_ages[:-500]
        return True

    def on_rate(self, pan_rate: float, tilt_rate: float, now: float, age: float = 0.0) -> bool:
        """A track/target_rate message (rad/s of the target, head base frame); False if not finite."""
        if not (math.isfinite(pan_rate) and math.isfinite(tilt_rate)):
            return False
        age = max(age, 0.0) if math.isfinite(age) else 0.0
        self.rate = Sample(pan_rate, tilt_rate, now - age, now)
        if self.state != TrackState.OCCLUDED:
            self.tracked = [s for s in self.tracked if s.measured >= self.rate.measured - COAST_RATE_WINDOW]
            self.tracked.append(self.rate)
        return True

    def coast_rate(self) -> Sample | None:
        """The rate to coast on while occluded: the per-axis median of the rates measured over the last
        COAST_RATE_WINDOW of tracking, stamped with the newest of them (None without one)."""
        if not self.tracked:
            return None
        last = self.tracked[-1]
        return Sample(float(np.median([s.pan for s in self.tracked])),
                      float(np.median([s.tilt for s in self.tracked])), last.measured, last.received)

    def on_state(self, state: TrackState, now: float) -> None:
        if state != self.state:
            self.state_since = now
        self.state = state

    def demand(self, now: float, head_rate: tuple[float, float]) -> Demand | str:
        """This period's demand, or the reason the head must stop (watchdog, tracker lost or idle)."""
        p, err = self.p, self.error
        if err is None or now - err.received > p.watchdog_timeout:
            return "watchdog: no pan/tilt error"
        if self.state in STOPPING_STATES:
            return f"tracker {self.state.value}"
        age = now - err.measured
        gain, weight, rate = 1.0, 1.0, self.rate
        fresh = (rate is not None and now - rate.measured <= p.max_input_age
                 and now - rate.received <= p.watchdog_timeout and age <= p.max_input_age)
        if self.state == TrackState.OCCLUDED:
            # Coast on the rate the target had when it was last seen (the tracker's own prediction may
            # slow down or drift while it searches), fresh when the occlusion began, fading out in time.
            gain, rate = p.occluded_gain, self.coast_rate()
            weight = coast_factor(now - self.state_since, p.coast_time, p.coast_decay)
            fresh = rate is not None and self.state_since - rate.measured <= p.max_input_age
        self.feed_forward_on = fresh and p.feed_forward > 0.0 and weight > 0.0
        if not self.feed_forward_on:
            return Demand(err.pan, err.tilt, gain, (0.0, 0.0), age)
        ff = (p.feed_forward * weight * rate.pan, p.feed_forward * weight * rate.tilt)
        if self.state != TrackState.OCCLUDED:  # a measured error says whether the target keeps its rate
            ff = (ff[0] * lead_factor(err.pan, ff[0], p.lead_limit),
                  ff[1] * lead_factor(err.tilt, ff[1], p.lead_limit))
        pan = carried_error(err.pan, ff[0], head_rate[0], age, p.error_prediction_max)
        tilt = carried_error(err.tilt, ff[1], head_rate[1], age, p.error_prediction_max)
        return Demand(pan, tilt, gain, ff, age)

    def latency_report(self) -> dict[str, float]:
        """Frame -> bridge arrival ages (ms) since the last report; starts a new window."""
        ages, self.arrival_ages = self.arrival_ages, []
        return {"error_age_ms_p50": percentile_ms(ages, 50), "error_age_ms_p95": percentile_ms(ages, 95)}
