# SPDX-License-Identifier: Apache-2.0
"""Context-aware linear correlation filter DCF-CA (Mueller et al., CVPR 2017; dissertation eqs. 4.90-4.92)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.features import FEATURE_KINDS
from swir_tracker_ros.core.fft import gaussian_label_spectrum, irfft2, linear_correlation, rfft2
from swir_tracker_ros.core.scale import ScaleOptions
from swir_tracker_ros.errors import TrackerError
from swir_tracker_ros.paramfield import param as _f
from swir_tracker_ros.paramfield import validate_params


@dataclass
class DCFCAParams(ScaleOptions):
    """DCF-CA pipeline of the dissertation: filter (reference code defaults, seed-003 §1.1), APCE tests."""

    padding: float = _f(2.0, "window = (1 + padding) x target (3x)", 0.5, 4.0)
    lambda1: float = _f(1e-4, "ridge regularisation lambda1", 1e-8, 1.0)
    lambda2: float = _f(25.0, "context regularisation lambda2", 0.0, 1000.0)
    interp_factor: float = _f(0.015, "learning rate delta (eq. 4.92)", 0.0, 1.0)
    output_sigma_factor: float = _f(0.1, "Gaussian label sigma = sqrt(w h) x factor / cell", 0.01, 1.0)
    n_context: int = _f(4, "context patches (up, down, left, right)", 0, 4)
    feature: str = _f(
        "hog_soft", "filter features: FHOG with soft (hog_soft) or hard (hog) bins, or raw gray",
        choices=FEATURE_KINDS,
    )
    cell_size: int = _f(4, "FHOG cell size in pixels (gray features always use 1)", 1, 8)
    reference_peak: float = _f(
        0.55,
        "(ours) responses are scaled so the first-frame self-response peaks at this value; it puts "
        "the tracking peaks at the dissertation's 0.2-0.29 (Fig. 4.6), the range eq. 6.9 expects; 0: raw",
        0.0,
        10.0,
    )
    apce_occlusion_ratio: float = _f(
        0.6, "occlusion when APCE <= ratio x mean APCE (eq. 4.96)", 0.0, 2.0
    )
    apce_update_ratio: float = _f(
        0.583, "no model update when APCE <= ratio x mean (eq. 4.97)", 0.0, 2.0
    )

    def validate(self) -> None:
        validate_params(self, "dcf_ca.")


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
            raise TrackerError("DCFCA.respond called before train")
        kzf = linear_correlation(rfft2(z), self.model_xf, self.shape)
        return irfft2(self.model_alphaf[None] * kzf, self.shape)
