# SPDX-License-Identifier: Apache-2.0
"""Generative sample space model: a Gaussian mixture over the training samples (ECO Sec. 3.2, eq. 8-10).

Every new sample x_j (the projected, interpolated half spectra of one frame) starts a component m with prior
weight pi_m = gamma (the learning rate) and mean mu_m = x_j, all other weights are scaled by (1 - gamma), so
the weights always sum to 1. When the number of components would exceed L: a component whose weight fell
below the minimum `gamma (1 - gamma)^(2 L)` (reference code) is replaced by the new sample; otherwise the two
closest components k, l are merged into pi_n = pi_k + pi_l, mu_n = (pi_k mu_k + pi_l mu_l) / (pi_k + pi_l)
(ECO eq. 10). "The two closest" includes the new sample, which is then merged into its nearest component.
Distances ||mu_k - mu_l||^2 come from a Gram matrix of inner products kept up to date (reference code), so a
frame costs one inner product per stored component. The filter is then trained on the L means with their
weights as sample weights (ECO eq. 9).

The bookkeeping (weights, Gram matrix, choice of the merge) is plain functions of small arrays; the class
only owns the storage.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.eco.fourier import half_inner


@dataclass(frozen=True)
class Update:
    """What `plan_update` decided: write the new sample at `new_id` (or -1: merged), merge component
    `merge_b` into `merge_a` with weights (wa, wb) (-1: no merge; merge_b == -2: the new sample merges)."""

    new_id: int
    merge_a: int
    merge_b: int
    wa: float
    wb: float


def plan_update(
    weights: np.ndarray, dist: np.ndarray, new_dist: np.ndarray, count: int, rate: float, min_weight: float
) -> Update:
    """The ECO Sec. 3.2 decision for one new sample (weights are the priors BEFORE this sample's update).

    weights (L,), dist (L, L) squared distances among the stored components (inf on the diagonal and for
    empty slots), new_dist (L,) squared distances of the new sample to them, count stored components."""
    L = weights.shape[0]
    if count < L:
        return Update(count, -1, -1, 0.0, 0.0)
    low = int(np.argmin(weights))
    if weights[low] < min_weight:
        return Update(low, -1, -1, 0.0, 0.0)
    near = int(np.argmin(new_dist))
    pair = int(np.argmin(dist))
    a, b = divmod(pair, L)
    if new_dist[near] < dist[a, b]:  # the new sample is closer to a component than any two components
        return Update(-1, near, -2, float(weights[near] * (1.0 - rate)), rate)
    if weights[b] > weights[a]:
        a, b = b, a
    return Update(b, a, b, float(weights[a] * (1.0 - rate)), float(weights[b] * (1.0 - rate)))


def update_weights(weights: np.ndarray, plan: Update, rate: float, count: int) -> np.ndarray:
    """New prior weights after `plan` (sum 1): the others scaled by 1 - rate, the new sample gets rate."""
    w = weights.copy()
    if count == 0:
        w[:] = 0.0
        w[0] = 1.0
        return w
    if plan.merge_b == -2:  # new sample merged into merge_a
        w *= 1.0 - rate
        w[plan.merge_a] += rate
        return w
    if plan.merge_a >= 0:  # two components merged into merge_a, the new one takes merge_b's slot
        w *= 1.0 - rate
        w[plan.merge_a] += w[plan.merge_b]
        w[plan.merge_b] = rate
        return w
    w[plan.new_id] = 0.0  # a free or discarded slot
    total = w.sum()
    if total > 0:
        w *= (1.0 - rate) / total
    w[plan.new_id] = rate
    return w


class SampleSpace:
    """L components of half spectra, one (L, D, rows, cols) complex64 array per feature block."""

    def __init__(self, shapes: list[tuple[int, int, int]], n_components: int, rate: float) -> None:
        self.L, self.rate = n_components, rate
        self.samples = [np.zeros((n_components, *s), dtype=np.complex64) for s in shapes]
        self.weights = np.zeros(n_components, dtype=np.float64)
        self.gram = np.zeros((n_components, n_components), dtype=np.float64)
        self.dist = np.full((n_components, n_components), np.inf, dtype=np.float64)
        self.count = 0
        self.min_weight = rate * (1.0 - rate) ** (2 * n_components)  # reference code's discard threshold

    def _inner_with(self, xs: list[np.ndarray]) -> np.ndarray:
        """<mu_l, x> for every stored component l (full-spectrum real inner products)."""
        g = np.zeros(self.L, dtype=np.float64)
        n = self.count
        if n == 0:
            return g
        for s, x in zip(self.samples, xs):  # Re sum conj(mu) x = Re sum mu conj(x): conjugate the one sample
            g[:n] += 2.0 * (s[:n].reshape(n, -1) @ np.conj(x.reshape(-1))).real
            g[:n] -= (s[:n, ..., 0].reshape(n, -1) @ np.conj(x[..., 0].reshape(-1))).real
        return g

    def add(self, xs: list[np.ndarray]) -> Update:
        """Insert one new sample (list of per-block half spectra (D, rows, cols)); returns the decision."""
        g = self._inner_with(xs)
        norm = sum(half_inner(x, x) for x in xs)
        diag = np.diag(self.gram)
        new_dist = np.full(self.L, np.inf)
        n = self.count
        new_dist[:n] = np.maximum(norm + diag[:n] - 2.0 * g[:n], 0.0)
        plan = plan_update(self.weights, self.dist, new_dist, n, self.rate, self.min_weight)
        self.weights = update_weights(self.weights, plan, self.rate, n)
        if plan.merge_b == -2:  # new sample merged into an existing component
            a = plan.merge_a
            ta = plan.wa / (plan.wa + plan.wb)
            for s, x in zip(self.samples, xs):
                s[a] = ta * s[a] + (1.0 - ta) * x
            ga = ta * self.gram[:, a] + (1.0 - ta) * g
            gaa = ta * ta * self.gram[a, a] + (1.0 - ta) ** 2 * norm + 2 * ta * (1.0 - ta) * g[a]
            self._set_gram(a, ga, gaa)
        else:
            if plan.merge_a >= 0:
                a, b = plan.merge_a, plan.merge_b
                ta = plan.wa / (plan.wa + plan.wb)
                for s in self.samples:
                    s[a] = ta * s[a] + (1.0 - ta) * s[b]
                ga = ta * self.gram[:, a] + (1.0 - ta) * self.gram[:, b]
                gaa = (
                    ta * ta * self.gram[a, a]
                    + (1.0 - ta) ** 2 * self.gram[b, b]
                    + 2 * ta * (1 - ta) * self.gram[a, b]
                )
                g[a] = ta * g[a] + (1.0 - ta) * g[b]
                self._set_gram(a, ga, gaa)
            k = plan.new_id
            for s, x in zip(self.samples, xs):
                s[k] = x
            self._set_gram(k, g, norm)
            if self.count < self.L:
                self.count += 1
        return plan

    def _set_gram(self, i: int, column: np.ndarray, norm_i: float) -> None:
        """Replace component i's row / column of the Gram matrix and the distances that follow from it."""
        self.gram[:, i] = column
        self.gram[i, :] = column
        self.gram[i, i] = norm_i
        d = np.maximum(norm_i + np.diag(self.gram) - 2.0 * self.gram[:, i], 0.0)
        n = max(self.count, i + 1)
        d[n:] = np.inf
        d[i] = np.inf
        self.dist[:, i] = d
        self.dist[i, :] = d

    def replace_all(self, xs: list[np.ndarray]) -> None:
        """Re-insert the first (only) sample after the projection changed (first frame, ECO Sec. 3.1)."""
        for s, x in zip(self.samples, xs):
            s[0] = x
        self.gram[0, 0] = sum(half_inner(x, x) for x in xs)
