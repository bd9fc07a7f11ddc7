# SPDX-License-Identifier: Apache-2.0
"""Gated cost matrix and optimal assignment: C = mu + m, mu = theta + w3 tau + gamma (paper 004 eq. 11)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from scipy.optimize import linear_sum_assignment

from swir_tracker_ros.acquisition.descriptors import (
    Appearance,
    BaseWeights,
    base_appearance_cost,
    rms_distance,
    siamese_distance,
)
from swir_tracker_ros.acquisition.motion import (
    ALL_EDGES,
    anchored_box,
    edge_gate_distance2,
    gate_distances2,
    gate_threshold,
    measurement_matrix,
    motion_cost,
    track_visible_edges,
)
from swir_tracker_ros.types import Box

FORBIDDEN = 1e9  # cost of a pair outside the gate (never accepted)


@dataclass(frozen=True)
class Detection:
    """One detector output: box, class score in [0, 1] and (after description) its appearance."""

    box: Box
    score: float = 1.0
    appearance: Appearance | None = None


class TrackLike(Protocol):
    """What the association needs to know about a track."""

    x: np.ndarray
    P: np.ndarray
    R: np.ndarray
    predicted: Box
    appearance: Appearance
    history: Sequence[tuple[float, float]]
    partial_run: int  # consecutive partial updates so far


@dataclass(frozen=True)
class CostWeights:
    """Weights of the pair cost; w1, w2, w3 are paper 004's (eq. 7 and 11)."""

    base: BaseWeights = field(default_factory=BaseWeights)
    w1: float = 100.0  # whole-box Siamese distance alpha
    w2: float = 25.0  # sum of the four quadrant Siamese distances beta
    w3: float = 300.0  # edge-LBP RMS distance tau
    w_dst: float = 200.0  # motion: distance to the prediction (per box height)
    w_dev: float = 100.0  # motion: deviation from the motion pattern (per box height)
    use_edge: bool = True
    use_siamese: bool = True
    gate_chi2: float = 9.21  # chi^2_2(0.99)
    max_cost: float = 250.0  # assignments above this are rejected (project choice)
    # Partial detections (ours, motion.visible_edges): under partial_ratio of the predicted w or h, cut from
    # one side (near edge moved at most partial_one_sided of the far edge's move), while the track has had
    # fewer than partial_max_run partial updates in a row.
    partial_ratio: float = 0.75
    partial_one_sided: float = 0.5
    partial_max_run: int = 5
    min_iou: float = 0.0  # a pair needs this IoU between the prediction and the (anchored) detection box
    partial_inside: float = 0.0  # area fraction of a partial detection inside the prediction


def inside_fraction(box: Box, outer: Box) -> float:
    """Fraction of box's area inside outer (0 for a degenerate box)."""
    ix = max(0.0, min(box.x + box.w, outer.x + outer.w) - max(box.x, outer.x))
    iy = max(0.0, min(box.y + box.h, outer.y + outer.h) - max(box.y, outer.y))
    return ix * iy / box.area if box.area > 0 else 0.0


def pair_edges(t: TrackLike, box: Box, w: CostWeights) -> tuple[int, ...]:
    """The edges of a detection box that measure track t (`motion.visible_edges`); every edge once the track
    has had partial_max_run partial updates in a row: a change of size seen that long is the target's."""
    ratio = w.partial_ratio if t.partial_run < w.partial_max_run else 0.0
    return track_visible_edges(t.x, t.P, t.R, box, ratio, w.partial_one_sided, w.gate_chi2)


def cost_matrix(tracks: Sequence[TrackLike], dets: Sequence[Detection], w: CostWeights) -> np.ndarray:
    """Pair costs C(i, j) = theta + w3 tau + gamma + m (eq. 11 + eq. 2); FORBIDDEN outside the gate.

    A full detection is gated on its centre (Section 3.1, chi^2 with 2 dof). A partial one (cut by an
    occluder or the image border, `motion.visible_edges`) is gated on its visible edges against the same
    edges of the predicted full box, at the same confidence, and its motion cost m is that of the full box
    anchored at those edges (ours): its own centre is not the target's.

    gamma is only defined when both sides carry embeddings (boxes >= the Siamese minimum size); other gated
    pairs get the median gamma of the defined pairs of this frame so that one assignment problem keeps
    comparable costs (notes seed-004 1.7), or 0 when no pair has one.
    """
    n, m = len(tracks), len(dets)
    C = np.full((n, m), FORBIDDEN)
    gamma = np.full((n, m), np.nan)
    centres = np.array([d.box.center for d in dets], dtype=np.float64).reshape(m, 2)
    H = measurement_matrix()
    for i, t in enumerate(tracks):
        pred = t.predicted
        inside = gate_distances2(t.x, t.P, t.R, centres) <= w.gate_chi2
        edges = [pair_edges(t, d.box, w) for d in dets]
        for j, e in enumerate(edges):
            if e != ALL_EDGES:
                d2 = edge_gate_distance2(t.x, t.P, H, t.R, dets[j].box, e)
                inside[j] = d2 <= gate_threshold(w.gate_chi2, len(e))
        for j in np.flatnonzero(inside):
            d = dets[j]
            a = d.appearance
            if a is None:
                raise ValueError("detections must be described before association")
            anchored = anchored_box(pred, d.box, edges[j])
            if w.min_iou > 0.0 and pred.iou(anchored) < w.min_iou:
                continue
            if edges[j] != ALL_EDGES and inside_fraction(d.box, pred) < w.partial_inside:
                continue
            c = base_appearance_cost(t.appearance, pred, a, d.box, d.score, w.base)
            if w.use_edge:
                c += w.w3 * rms_distance(t.appearance.edge, a.edge)
            c += motion_cost(pred, anchored, t.history, w.w_dst, w.w_dev)
            C[i, j] = c
            if w.use_siamese:
                g = siamese_distance(t.appearance, a, w.w1, w.w2)
                if g is not None:
                    gamma[i, j] = g
    if w.use_siamese:
        gated = C < FORBIDDEN
        defined = gated & np.isfinite(gamma)
        fill = float(np.median(gamma[defined])) if defined.any() else 0.0
        C[gated] += np.where(np.isfinite(gamma[gated]), gamma[gated], fill)
    return C


def assign(C: np.ndarray, max_cost: float) -> tuple[list[tuple[int, int]], list[int], list[int]]:
    """Hungarian assignment (scipy's linear_sum_assignment) of a cost matrix; pairs costing more than max_cost
    (and all forbidden pairs) are dropped. Returns (matches, unmatched rows, unmatched columns)."""
    n, m = C.shape
    matches: list[tuple[int, int]] = []
    if n and m:
        rows, cols = linear_sum_assignment(C)
        matches = [(int(r), int(c)) for r, c in zip(rows, cols)
                   if C[r, c] <= max_cost and C[r, c] < FORBIDDEN]
    mr = {r for r, _ in matches}
    mc = {c for _, c in matches}
    return matches, [r for r in range(n) if r not in mr], [c for c in range(m) if c not in mc]
