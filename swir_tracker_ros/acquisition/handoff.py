# SPDX-License-Identifier: Apache-2.0
"""Hand-off to the single-object tracker: select by ID, automatic confirmation, lost-target candidates."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from swir_tracker_ros.acquisition.association import CostWeights
from swir_tracker_ros.acquisition.descriptors import Appearance, rms_distance, siamese_distance
from swir_tracker_ros.acquisition.motion import (
    box_from_state,
    box_model,
    initial_covariance,
    measurement,
    state_from_box,
)
from swir_tracker_ros.kalman.standard import predict, update
from swir_tracker_ros.types import Box


@dataclass(frozen=True)
class TrackView:
    """What hand-off needs of a displayed track."""

    id: int
    box: Box
    appearance: Appearance | None = None


def select(tracks: Sequence[TrackView], track_id: int) -> Box | None:
    """Box of the displayed track with this ID, or None when no such track is displayed."""
    for t in tracks:
        if t.id == track_id:
            return t.box
    return None


@dataclass(frozen=True)
class AutoInitParams:
    """Automatic initialisation, dissertation 003 Section 3.3.2.1 (steps 4-7)."""

    iou_threshold: float = 0.5  # a motion box updates the temporary track when IoU(prediction, box) > this
    required_updates: int = 5  # updates needed to hand the candidate off
    window: int = 10  # frames of temporary tracking before a candidate is restarted
    q_pos: float = 1.0
    q_size: float = 4.0
    r_rel: float = 0.08


@dataclass
class _Candidate:
    x: np.ndarray
    P: np.ndarray
    updates: int = 0
    frames: int = 0


@dataclass
class AutoInitialiser:
    """Temporary Kalman tracks on motion boxes; the first one updated `required_updates` times within
    `window` frames is confirmed and returned as the box to hand off."""

    params: AutoInitParams = field(default_factory=AutoInitParams)
    candidates: list[_Candidate] = field(default_factory=list)

    def reset(self) -> None:
        self.candidates.clear()

    def step(self, boxes: Sequence[Box], ego_shift: tuple[float, float] = (0.0, 0.0)) -> Box | None:
        """One detection frame: predict every temporary track, shifted by the image shift the head's motion
        caused since the last call (ego_shift, px, as `MultiTargetTracker.step`), update it with the box
        it overlaps most, start one on every box left over; the confirmed box, or None."""
        p = self.params
        used: set[int] = set()
        confirmed: Box | None = None
        for c in self.candidates:
            F, Q, H, R = box_model(p.q_pos, p.q_size, p.r_rel * c.x[3], p.r_rel * c.x[3])
            c.x, c.P = predict(c.x, c.P, F, Q)
            c.x[0] += ego_shift[0]
            c.x[1] += ego_shift[1]
            c.frames += 1
            pred = box_from_state(c.x)
            ious = [(pred.iou(b), k) for k, b in enumerate(boxes) if k not in used]
            if ious:
                best, k = max(ious)
                if best > p.iou_threshold:
                    used.add(k)
                    c.x, c.P = update(c.x, c.P, measurement(boxes[k]), R, H)
                    c.updates += 1
            if c.updates >= p.required_updates and confirmed is None:
                confirmed = box_from_state(c.x)
        self.candidates = [c for c in self.candidates
                           if c.frames < p.window and c.updates < p.required_updates]
        for k, b in enumerate(boxes):
            if k not in used and b.is_valid():
                r = p.r_rel * b.h
                self.candidates.append(_Candidate(state_from_box(b), initial_covariance(b, r, r, 0.15 * b.h)))
        if confirmed is not None:
            self.candidates.clear()
        return confirmed


def appearance_distance(a: Appearance, b: Appearance, w: CostWeights) -> float:
    """Position-free part of the pair cost (eq. 1 intensity and texture terms, w3 * tau, gamma)."""
    d = (w.base.lbp * 0.5 * float(np.abs(a.lbp - b.lbp).sum()) + w.base.mean * abs(a.mean - b.mean) / 255.0
         + w.base.std * min(1.0, abs(a.std - b.std) / 128.0))
    if w.use_edge:
        d += w.w3 * rms_distance(a.edge, b.edge)
    if w.use_siamese:
        g = siamese_distance(a, b, w.w1, w.w2)
        d += g if g is not None else 0.0
    return d


def lost_candidates(target: Appearance, tracks: Sequence[TrackView], w: CostWeights,
                    k: int = 3) -> list[tuple[int, float]]:
    """The k displayed tracks most similar to the lost target: (track id, distance), most similar first."""
    scored = [(t.id, appearance_distance(target, t.appearance, w))
              for t in tracks if t.appearance is not None]
    return sorted(scored, key=lambda s: s[1])[:k]
