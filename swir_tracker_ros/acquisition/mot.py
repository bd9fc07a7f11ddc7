# SPDX-License-Identifier: Apache-2.0
"""Multi-pedestrian tracking by detection, life cycle of paper 004 Section 3.1 (a Kalman track per target)."""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from swir_tracker_ros.acquisition.association import CostWeights, Detection, assign, cost_matrix, pair_edges
from swir_tracker_ros.acquisition.descriptors import Appearance, BaseWeights, describe, to_gray8
from swir_tracker_ros.acquisition.motion import (
    ALL_EDGES,
    box_from_state,
    box_model,
    edge_model,
    initial_covariance,
    measurement,
    measurement_matrix,
    state_from_box,
)
from swir_tracker_ros.acquisition.siamese import SiameseFamily
from swir_tracker_ros.kalman.standard import predict, update
from swir_tracker_ros.paramfield import param as _f
from swir_tracker_ros.paramfield import validate_params
from swir_tracker_ros.types import Box

RATE_REF = 25.0  # Hz of the life-cycle counts of MotParams (TUD-Campus, paper 004's sequences)


@dataclass
class MotParams:
    """Association and life-cycle parameters (paper 004 values where it states them)."""

    w1: float = _f(100.0, "weight of the whole-box Siamese distance alpha (eq. 7)", 0.0, 1e4)
    w2: float = _f(25.0, "weight of the summed quadrant Siamese distances beta (eq. 7)", 0.0, 1e4)
    w3: float = _f(300.0, "weight of the edge-LBP RMS distance tau (eq. 11)", 0.0, 1e5)
    w_lbp: float = _f(20.0, "base: uniform-LBP histogram difference hL (eq. 1)", 0.0, 1e4)
    w_mean: float = _f(20.0, "base: mean intensity difference (eq. 1)", 0.0, 1e4)
    w_std: float = _f(10.0, "base: intensity standard deviation difference (eq. 1)", 0.0, 1e4)
    w_height: float = _f(10.0, "base: relative height difference (eq. 1)", 0.0, 1e4)
    w_width: float = _f(10.0, "base: relative width difference (eq. 1)", 0.0, 1e4)
    w_score: float = _f(5.0, "base: 1 - detection score (eq. 1)", 0.0, 1e4)
    w_overlap: float = _f(20.0, "base: 1 - IoU with the predicted box (eq. 1)", 0.0, 1e4)
    w_dst: float = _f(200.0, "motion: distance to the prediction per box height (eq. 2)", 0.0, 1e4)
    w_dev: float = _f(100.0, "motion: deviation from the motion pattern per box height (eq. 2)", 0.0, 1e4)
    use_edge: bool = _f(True, "add the engineered edge-LBP score w3*tau")
    use_siamese: bool = _f(True, "add the Siamese score gamma (needs the ONNX models)")
    gate_chi2: float = _f(9.21, "Mahalanobis gate on the centre, chi^2 with 2 dof (0.99)", 0.1, 1e4)
    max_cost: float = _f(1e6, "reject an assignment costing more than this", 0.0, 1e9)
    min_iou: float = _f(0.3, "a track and a detection pair only when the predicted box and the "
                        "detection (anchored at its visible edges) overlap at least this much (IoU; SORT's "
                        "gate); 0 = the Mahalanobis gate alone (paper 004)", 0.0, 1.0)
    high_score: float = _f(0.0, "two-stage assignment (ByteTrack): detections scoring below this only "
                           "continue confirmed tracks left over by the stronger ones and never start a "
                           "track; 0 = one stage", 0.0, 1.0)
    start_score: float = _f(0.0, "a detection left over starts a track only when it scores at least this "
                            "(ByteTrack's track activation threshold, 0.7 there); weaker ones only continue "
                            "tracks", 0.0, 1.0)
    partial_ratio: float = _f(0.75, "a detection narrower or shorter than this fraction of the predicted "
                              "box, cut from one side and inside it, is partial (an occluder or the image "
                              "border hides the rest): gated and updated on its visible edges only, template "
                              "kept; 0 = every detection is full (the paper)", 0.0, 1.0)
    partial_one_sided: float = _f(0.5, "a cut is one-sided when the detection's near edge moved at most this "
                                  "fraction of its far edge (else a change of scale, measured in full)",
                                  0.0, 1.0)
    partial_inside: float = _f(0.9, "a partial detection pairs with a track only when at least this "
                               "fraction of its area lies inside the predicted box: a part of the target is "
                               "inside the target's box (the tenth left is the prediction's error); 0 = no "
                               "such test", 0.0, 1.0)
    partial_max_run: int = _f(5, "after this many partial updates in a row a track is updated in full "
                              "again: a change of size that lasts is the target's (5 hits, as confirm_hits)",
                              1, 1000)
    confirm_hits: int = _f(5, "a tentative track is confirmed after this many further hits (paper 004: 5; "
                            "SORT's min_hits: 3); 0 = confirmed at birth", 0, 100)
    frame_rate: float = _f(25.0, "rate (Hz) at which detections arrive (camera rate / detect_every); the "
                           f"three miss counts below are frames at {RATE_REF:g} Hz and are scaled by "
                           f"frame_rate / {RATE_REF:g} (at least 1), as the peers scale their lost-track "
                           "buffer",
                           0.1, 1000.0)
    tentative_max_miss: int = _f(5, "a tentative track missed this many frames is deleted", 1, 100)
    history_threshold: int = _f(20, "a confirmed track missed this many frames becomes drifting", 1, 1000)
    drift_threshold: int = _f(15, "a drifting track missed this many more frames is deleted", 1, 1000)
    display_max_miss: int = _f(1, "a confirmed track is output while missed at most this many frames "
                               "(the paper shows it until it drifts, 20, and those boxes are mostly false "
                               "positives; SORT and ByteTrack only while matched, 0; 1 bridges one missed "
                               "detection)", 0, 1000)
    output_detection: bool = _f(False, "publish a matched track with the detection it was matched to "
                                "(as SORT and ByteTrack do) instead of the filtered box")
    history_len: int = _f(10, "positions kept for the motion pattern", 2, 100)
    siamese_min_w: int = _f(19, "Siamese nets only for boxes at least this wide (px)", 1, 10000)
    siamese_min_h: int = _f(50, "Siamese nets only for boxes at least this tall (px)", 1, 10000)
    q_pos: float = _f(1.0, "process noise, acceleration variance (px/frame^2)^2", 0.0, 1e4)
    q_size: float = _f(4.0, "process noise of the box size random walk (px^2)", 0.0, 1e4)
    r_pos_rel: float = _f(0.08, "centre measurement std as a fraction of the box height", 1e-3, 1.0)
    r_size_rel: float = _f(0.1, "size measurement std as a fraction of the box height", 1e-3, 1.0)
    v0_rel: float = _f(0.15, "initial velocity std as a fraction of the box height per frame", 1e-3, 10.0)

    def validate(self) -> None:
        """Raise `ParameterError` naming the first bad field (`paramfield.validate_params`)."""
        validate_params(self)

    def frames(self, count: int) -> int:
        """A miss count given in frames at RATE_REF Hz, in frames at frame_rate (at least 1): a track is
        kept for the same time whatever the rate (at 1 Hz, 20 frames of 25 Hz are 1 frame, not 20 s)."""
        return max(1, round(count * self.frame_rate / RATE_REF))

    def cost_weights(self) -> CostWeights:
        base = BaseWeights(self.w_lbp, self.w_mean, self.w_std, self.w_height, self.w_width, self.w_score,
                           self.w_overlap)
        return CostWeights(base, self.w1, self.w2, self.w3, self.w_dst, self.w_dev, self.use_edge,
                           self.use_siamese, self.gate_chi2, self.max_cost, self.partial_ratio,
                           self.partial_one_sided, self.partial_max_run, self.min_iou,
                           self.partial_inside)


class TrackStatus(str, Enum):
    TENTATIVE = "tentative"  # "unstable": not displayed
    CONFIRMED = "confirmed"  # "stable": displayed, coasting while missed
    DRIFTING = "drifting"  # kept and predicted, not displayed


@dataclass
class Track:
    """One target: Kalman state over [cx, cy, w, h, vx, vy], last appearance, motion history, life cycle."""

    id: int
    x: np.ndarray
    P: np.ndarray
    R: np.ndarray
    appearance: Appearance
    history: deque
    status: TrackStatus = TrackStatus.TENTATIVE
    hits: int = 1
    misses: int = 0
    age: int = 1
    matched: bool = True
    partial_run: int = 0  # consecutive partial updates (motion.visible_edges)
    last_box: Box = field(default_factory=lambda: Box(0, 0, 1, 1))
    output_detection: bool = False  # MotParams.output_detection

    @property
    def predicted(self) -> Box:
        return box_from_state(self.x)

    @property
    def box(self) -> Box:
        return box_from_state(self.x)

    @property
    def output_box(self) -> Box:
        """The box published for this track: the detection it was matched to this frame when that detection
        showed the whole target (as SORT and ByteTrack publish), else the filtered state."""
        if self.matched and self.partial_run == 0 and self.output_detection:
            return self.last_box
        return box_from_state(self.x)

    @property
    def displayed(self) -> bool:
        return self.status is TrackStatus.CONFIRMED


class MultiTargetTracker:
    """Tracking by detection (paper 004): predict, describe, gate, cost, Hungarian, update, life cycle."""

    def __init__(self, params: MotParams | None = None, siamese: SiameseFamily | None = None) -> None:
        self.params = params or MotParams()
        self.params.validate()
        if self.params.use_siamese and siamese is None:
            siamese = SiameseFamily.load_default()
        self.siamese = siamese if self.params.use_siamese else None
        self.weights = self.params.cost_weights()
        self.tracks: list[Track] = []
        self.next_id = 1
        self.frame_index = 0
        self.last_timing_s = 0.0  # association time of the last frame (description + cost + assignment)

    def reset(self) -> None:
        self.tracks.clear()
        self.next_id = 1
        self.frame_index = 0

    def _noise(self, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        p = self.params
        return box_model(p.q_pos, p.q_size, p.r_pos_rel * h, p.r_size_rel * h)

    def describe(self, gray: np.ndarray, dets: Sequence[Detection]) -> list[Detection]:
        """Attach engineered features (and Siamese embeddings for large enough boxes) to detections."""
        out = [Detection(d.box, d.score, describe(gray, d.box)) for d in dets]
        if self.siamese is None:
            return out
        p = self.params
        big = [k for k, d in enumerate(out) if d.box.w >= p.siamese_min_w and d.box.h >= p.siamese_min_h]
        if big:
            emb, parts = self.siamese.embed(gray, [out[k].box for k in big])
            for n, k in enumerate(big):
                a = out[k].appearance
                assert a is not None
                out[k] = Detection(out[k].box, out[k].score, Appearance(a.lbp, a.mean, a.std, a.edge,
                                                                        emb[n], parts[n]))
        return out

    def step(self, frame: np.ndarray, detections: Sequence[Detection],
             ego_shift: tuple[float, float] = (0.0, 0.0)) -> list[Track]:
        """Process one frame; returns the displayed (confirmed, non-drifting) tracks.

        ego_shift (px, +x right, +y down) is the image shift caused by head motion since the last frame and
        is added to every prediction.
        """
        p = self.params
        self.frame_index += 1
        gray = to_gray8(frame)
        h_img, w_img = gray.shape
        dets = [d for d in detections if d.box.is_valid() and d.box.intersects_image(w_img, h_img)]
        t0 = time.perf_counter()
        for t in self.tracks:
            F, Q, _, R = self._noise(float(t.x[3]))
            t.x, t.P = predict(t.x, t.P, F, Q)
            t.x[0] += ego_shift[0]
            t.x[1] += ego_shift[1]
            t.R = R
            t.matched = False
            t.age += 1
        described = self.describe(gray, dets)
        matches, unmatched_tracks, unmatched_dets = self._associate(described)
        self.last_timing_s = time.perf_counter() - t0
        for i, j in matches:
            self._update(self.tracks[i], described[j])
        for i in unmatched_tracks:
            self._miss(self.tracks[i])
        for j in unmatched_dets:
            if described[j].score >= p.start_score:
                self._spawn(described[j])
        self.tracks = [t for t in self.tracks if t.status is not None and not self._dead(t)]
        for t in self.tracks:
            t.history.append((float(t.x[0]), float(t.x[1])))
        return [t for t in self.tracks if t.displayed and t.misses <= p.display_max_miss]

    def _associate(self, dets: Sequence[Detection]) -> tuple[list[tuple[int, int]], list[int], list[int]]:
        """Two-stage assignment (ByteTrack, Zhang et al. ECCV 2022, Section 3): every track against the
        detections scoring at least `high_score` first, then the confirmed tracks left over against the
        weaker detections, with the same cost; a weak detection left over never starts a track (it is
        returned as matched to nothing and not spawned). high_score 0 = one stage (paper 004)."""
        p = self.params
        hi = [j for j, d in enumerate(dets) if d.score >= p.high_score]
        lo = [j for j, d in enumerate(dets) if d.score < p.high_score]
        C = cost_matrix(self.tracks, [dets[j] for j in hi], self.weights)
        m1, un_t, un_hi = assign(C, self.weights.max_cost)
        matches = [(i, hi[j]) for i, j in m1]
        rest = [i for i in un_t if self.tracks[i].status is not TrackStatus.TENTATIVE]
        if lo and rest:
            C2 = cost_matrix([self.tracks[i] for i in rest], [dets[j] for j in lo], self.weights)
            m2, _, _ = assign(C2, self.weights.max_cost)
            matches += [(rest[i], lo[j]) for i, j in m2]
        matched = {i for i, _ in matches}
        return matches, [i for i in range(len(self.tracks)) if i not in matched], [hi[j] for j in un_hi]

    def _update(self, t: Track, d: Detection) -> None:
        """Kalman update and template replacement (Section 3.1). A partial detection (`motion.visible_edges`)
        updates the state with its visible edges only (`motion.edge_model`), with the measurement noise of
        the predicted box, and keeps the template of the last full detection (ours: an arm coming out from
        behind a pole must neither shrink the box nor become the appearance the whole body is compared
        with; notes seed-004 Section 4 names the paper's unconditional template replacement a drift risk)."""
        p = self.params
        assert d.appearance is not None
        edges = pair_edges(t, d.box, self.weights)
        if edges == ALL_EDGES:
            _, _, H, R = self._noise(d.box.h)
            t.x, t.P = update(t.x, t.P, measurement(d.box), R, H)
            t.appearance = d.appearance  # template replaced by the last associated detection (Section 3.1)
            t.partial_run = 0
        else:
            z, He, Re = edge_model(measurement_matrix(), t.R, d.box, edges)
            t.x, t.P = update(t.x, t.P, z, Re, He)
            t.partial_run += 1
        t.last_box = d.box
        t.hits += 1
        t.misses = 0
        t.matched = True
        confirm = t.status is TrackStatus.TENTATIVE and t.hits > p.confirm_hits
        if confirm or t.status is TrackStatus.DRIFTING:
            t.status = TrackStatus.CONFIRMED

    def _miss(self, t: Track) -> None:
        p = self.params
        t.misses += 1
        t.partial_run = 0  # a run of partial views is consecutive frames
        if t.status is TrackStatus.CONFIRMED and t.misses >= p.frames(p.history_threshold):
            t.status = TrackStatus.DRIFTING

    def _dead(self, t: Track) -> bool:
        p = self.params
        if t.status is TrackStatus.TENTATIVE:
            return t.misses >= p.frames(p.tentative_max_miss)
        if t.status is TrackStatus.DRIFTING:
            return t.misses >= p.frames(p.history_threshold) + p.frames(p.drift_threshold)
        return False

    def _spawn(self, d: Detection) -> None:
        p = self.params
        assert d.appearance is not None
        _, _, _, R = self._noise(d.box.h)
        P0 = initial_covariance(d.box, p.r_pos_rel * d.box.h, p.r_size_rel * d.box.h, p.v0_rel * d.box.h)
        hist: deque = deque(maxlen=p.history_len)
        status = TrackStatus.CONFIRMED if p.confirm_hits == 0 else TrackStatus.TENTATIVE  # 0 further hits
        self.tracks.append(Track(self.next_id, state_from_box(d.box), P0, R, d.appearance, hist, status,
                                 last_box=d.box, output_detection=p.output_detection))
        self.next_id += 1
