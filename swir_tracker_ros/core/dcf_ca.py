# SPDX-License-Identifier: Apache-2.0
"""Context-aware linear correlation filter DCF-CA (Mueller et al., CVPR 2017; dissertation eqs. 4.90-4.92)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from swir_tracker_ros.core.features import FEATURE_KINDS
from swir_tracker_ros.core.kcf import _check, gaussian_label_spectrum, irfft2, linear_correlation, rfft2
from swir_tracker_ros.errors import ParameterError


@dataclass
class DCFCAParams:
    """DCF-CA defaults of the reference code used by the dissertation (Table in seed-003 §1.1)."""

    padding: float = field(
        default=2.0, metadata={"doc": "window = (1 + padding) x target", "min": 0.5, "max": 4.0}
    )
    lambda1: float = field(default=1e-4, metadata={"doc": "ridge regularisation", "min": 1e-8, "max": 1.0})
    lambda2: float = field(
        default=25.0, metadata={"doc": "context regularisation", "min": 0.0, "max": 1000.0}
    )
    interp_factor: float = field(
        default=0.015, metadata={"doc": "learning rate delta", "min": 0.0, "max": 1.0}
    )
    output_sigma_factor: float = field(
        default=0.1, metadata={"doc": "label sigma / sqrt(w h)", "min": 0.01, "max": 1.0}
    )
    n_context: int = field(
        default=4, metadata={"doc": "context patches (up, down, left, right)", "min": 0, "max": 4}
    )
    feature: str = field(default="hog", metadata={"doc": "feature type", "choices": FEATURE_KINDS})
    cell_size: int = field(default=4, metadata={"doc": "feature cell in pixels", "min": 1, "max": 8})

    def validate(self) -> None:
        _check("padding", self.padding, 0.5, 4.0)
        _check("lambda1", self.lambda1, 1e-8, 1.0)
        _check("lambda2", self.lambda2, 0.0, 1000.0)
        _check("interp_factor", self.interp_factor, 0.0, 1.0)
        _check("output_sigma_factor", self.output_sigma_factor, 0.01, 1.0)
        _check("n_context", self.n_context, 0, 4)
        if self.feature not in FEATURE_KINDS:
            raise ParameterError(f"feature={self.feature!r} is not one of {FEATURE_KINDS}")
        _check("cell_size", self.cell_size, 1, 8)


def context_offsets(target_w: float, target_h: float, n: int) -> list[tuple[float, float]]:
    """Centre offsets of the context patches: one target size up, down, left and right (first n)."""
    return [(0.0, -target_h), (0.0, target_h), (-target_w, 0.0), (target_w, 0.0)][:n]


class DCFCA:
    """Linear-kernel correlation filter with context regularisation.

    Training (dissertation eq. 4.90, dual form of the reference code):
        alpha_f = y_f / (k_f^{x0 x0} + lambda1 + lambda2 * sum_i k_f^{xi xi})
    with k the channel-summed linear kernel; the model (alpha_f, x0_f) is blended with rate gamma
    (eq. 4.92). Detection: g = F^-1(alpha_f * k_f^{z x0}) (eq. 4.91).
    """

    def __init__(self, params: DCFCAParams, feat_shape: tuple[int, int, int], target_cells: float) -> None:
        self.params = params
        self.shape = (feat_shape[1], feat_shape[2])
        sigma = max(target_cells * params.output_sigma_factor, 0.25)
        self.yf = gaussian_label_spectrum(self.shape[0], self.shape[1], float(sigma))
        self.model_xf: np.ndarray | None = None
        self.model_alphaf: np.ndarray | None = None

    @property
    def trained(self) -> bool:
        return self.model_alphaf is not None

    def train(self, x: np.ndarray, context: np.ndarray | None, rate: float) -> None:
        """x: (C, rows, cols) target sample; context: (K, C, rows, cols) or None; rate: gamma_t."""
        xf = rfft2(x)
        kf = linear_correlation(xf, xf, self.shape).real
        denom = kf + self.params.lambda1
        if context is not None and len(context) and self.params.lambda2 > 0:
            cf = rfft2(context)
            kn = np.einsum("kchw,kchw->hw", cf, np.conj(cf)).real / (x.size)
            denom = denom + self.params.lambda2 * kn
        alphaf = self.yf / denom
        if self.model_alphaf is None or rate >= 1.0:
            self.model_xf, self.model_alphaf = xf, alphaf
        elif rate > 0.0:
            self.model_xf = (1.0 - rate) * self.model_xf + rate * xf
            self.model_alphaf = (1.0 - rate) * self.model_alphaf + rate * alphaf

    def respond(self, z: np.ndarray) -> np.ndarray:
        """Responses (N, rows, cols) of feature maps z (N, C, rows, cols)."""
        if self.model_alphaf is None:
            raise RuntimeError("DCFCA.respond called before train")
        kzf = linear_correlation(rfft2(z), self.model_xf, self.shape)
        return irfft2(self.model_alphaf[None] * kzf, self.shape)
