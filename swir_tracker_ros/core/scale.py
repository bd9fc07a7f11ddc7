# SPDX-License-Identifier: Apache-2.0
"""DSST scale filter: a 1-D correlation filter over a scale pyramid (Danelljan et al., BMVC 2014).

"Accurate Scale Estimation for Robust Visual Tracking", Sec. 2-3 (the scale filter of the Discriminative
Scale Space Tracker; also Danelljan et al., TPAMI 2017, "Discriminative Scale Space Tracking", Sec. 3).
An option of the base filters (`KCFParams.scale_estimator = "dsst"`, same for DCF-CA): translation is
found on the middle search window only, then this filter picks the size, instead of correlating the
translation filter with 5 scaled windows (paper 000 Sec. III-B.2).

For S scales n in {-(S-1)/2, ..., (S-1)/2} (scale step a), a patch of a^n w x a^n h pixels around the
target centre is resampled to a fixed model size (at most `model_max_area` pixels, the first frame's
aspect), its FHOG map flattened into one d-dimensional feature vector f(n); the training sample f is
d x S, one 1-D signal per feature dimension l, weighted by a Hann window over the scales. With the 1-D
Gaussian label g over the scale index (sigma = `sigma_factor` x sqrt(S) steps, centred on n = 0) and
capital letters for DFTs over the scale axis:

- eq. 4 (multi-channel solution): H^l = conj(G) F^l / (sum_k conj(F^k) F^k + lambda);
- eq. 5 (update with learning rate eta): A_t^l = (1 - eta) A_{t-1}^l + eta conj(G) F_t^l,
  B_t = (1 - eta) B_{t-1} + eta sum_k conj(F_t^k) F_t^k;
- eq. 6 (detection on a sample z): y = F^-1{ sum_l conj(A^l) Z^l / (B + lambda) }, the new size being
  a^n* times the current one at the maximum n* of y. Here y is evaluated on `interpolation` points per
  scale step by zero-padding its spectrum (the trigonometric interpolation of fDSST, Danelljan et al.,
  TPAMI 2017, Sec. 4.2), so n* is fractional: with whole 2 % steps a slow size change (and the Kalman
  size velocity) went unmeasured until it reached a step.

Defaults are the paper's (Sec. 4): S = 33, a = 1.02, eta = 0.025, lambda = 0.01, sigma = 1/4 sqrt(S)
steps (its code: nScales / sqrt(33) x 1/4, the same at S = 33), model area 512 px, FHOG cell 4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import cv2
import numpy as np
import scipy.fft as sfft

from swir_tracker_ros.core.base import FilterParams
from swir_tracker_ros.core.features import SmoothedFrame
from swir_tracker_ros.core.fhog import fhog
from swir_tracker_ros.core.windows import FFT_SIZES
from swir_tracker_ros.errors import ParameterError, TrackerError
from swir_tracker_ros.paramfield import param as _f
from swir_tracker_ros.paramfield import validate_params

SCALE_ESTIMATORS = ("search", "dsst")
"""search: the translation filter on the scaled windows (paper 000); dsst: this module's scale filter."""

CELL = 4  # FHOG cell of the scale samples (DSST)


@dataclass
class DSSTParams:
    """The DSST scale filter (Danelljan et al., BMVC 2014, Sec. 4 defaults), for scale_estimator dsst."""

    n_scales: int = _f(33, "S, scales sampled (odd; BMVC 2014: 33)", 3, 99)
    scale_step: float = _f(1.02, "a, size ratio of neighbouring scales (BMVC 2014: 1.02)", 1.001, 1.2)
    sigma_factor: float = _f(
        0.25, "1-D Gaussian label sigma = factor x sqrt(n_scales) scale steps (BMVC 2014: 1/4)", 0.01, 2.0
    )
    lambda_: float = _f(0.01, "regularisation lambda of eq. 4 / 6 (BMVC 2014: 0.01)", 1e-8, 10.0)
    learning_rate: float = _f(0.025, "eta of eq. 5 (BMVC 2014: 0.025)", 0.0, 1.0)
    model_max_area: int = _f(
        512, "scale samples are resampled to at most this many pixels (BMVC 2014 code: 512)", 64, 10000
    )
    interpolation: int = _f(
        8,
        "the scale response is interpolated to this many points per scale step (trigonometric, by "
        "zero-padding its spectrum: fDSST, TPAMI 2017 Sec. 4.2) so that changes below one step are "
        "measured; 1: the best sampled scale (BMVC 2014)",
        1,
        64,
    )

    def validate(self) -> None:
        validate_params(self, "dsst.")

    def check(self) -> None:
        """n_scales must be odd (the label and the factors are centred on scale 1)."""
        if self.n_scales % 2 == 0:
            raise ParameterError(f"parameter dsst.n_scales = {self.n_scales} must be odd")


@dataclass
class ScaleOptions(FilterParams):
    """Size estimation, template geometry and response analysis of a base filter: the fields every
    filter's Params shares (KCFParams, DCFCAParams inherit them, so they are declared once)."""

    scale_estimator: str = _f(
        "search",
        "size estimation: search (paper 000: the filter on every scaled window) or dsst (Danelljan et al., "
        "BMVC 2014: translation on the middle window only, then a 1-D scale filter; core/scale.py)",
        choices=SCALE_ESTIMATORS,
    )
    dsst: DSSTParams = field(
        default_factory=DSSTParams, metadata={"doc": "DSST scale filter (core/scale.py)"}
    )
    fft_sizes: str = _f(
        "exact",
        "template cell counts: exact ((1 + padding) x target rounded to whole cells, the papers), or (ours, "
        "an option) smooth7 / smooth5: each moved to the nearest 7- / 5-smooth number, fast FFT sizes (the "
        "window in the image is unchanged, resampled a few per cent finer or coarser); not the default: the "
        "resampled window tracks worse from shifted starts",
        choices=FFT_SIZES,
    )
    large_target_halving: float = _f(
        100.0,
        "model works at half resolution when sqrt(w h) >= this many pixels (KCF reference); 0 disables",
        0.0,
        10000.0,
    )
    psr_exclusion_px: int = _f(
        10,
        "side of the square around the peak excluded from the PSR sidelobe, in template pixels (paper 000: "
        "10x10); ceil(px / cell) response cells",
        1,
        100,
    )


@lru_cache(maxsize=8)
def _label_spectrum(n: int, sigma: float) -> np.ndarray:
    """rfft of the 1-D Gaussian label over the scale index, peak at the middle index (n = 0)."""
    ss = np.arange(n) - n // 2
    return sfft.rfft(np.exp(-0.5 * ss**2 / sigma**2)).astype(np.complex64)


def scale_patches(
    img: np.ndarray | SmoothedFrame,
    cx: float,
    cy: float,
    w: float,
    h: float,
    factors: np.ndarray,
    out_w: int,
    out_h: int,
) -> np.ndarray:
    """(S, out_h, out_w) float32: for each factor s the region of s w x s h pixels centred on (cx, cy),
    resampled to out_w x out_h (replicated borders).

    Two OpenCV calls for all S scales instead of one resize each: the bounding region of the largest
    scale is blurred once (Gaussian, sigma = half the shrink factor at s = 1, as `features.sample_patch`
    pre-filters a strong shrink; none when the model is not smaller), then ONE `cv2.remap` samples every
    scale's grid bilinearly (output pixel centres at the region's sub-pixel positions).
    """
    ih, iw = img.shape
    n = len(factors)
    shrink = max(w / out_w, h / out_h)
    pad = 2 + (round(4.0 * shrink + 1) if shrink > 1.0 else 0)
    half_w, half_h = 0.5 * w * float(factors.max()), 0.5 * h * float(factors.max())
    rx0, ry0 = math.floor(cx - half_w) - pad, math.floor(cy - half_h) - pad
    rx1, ry1 = math.ceil(cx + half_w) + pad + 1, math.ceil(cy + half_h) + pad + 1
    if isinstance(img, SmoothedFrame):
        img = img.ensure(ry0, ry1, rx0, rx1)
    if rx0 >= 0 and ry0 >= 0 and rx1 <= iw and ry1 <= ih:
        region = img[ry0:ry1, rx0:rx1]
    else:  # replicate the border: clipped index vectors (small region, one fancy-index copy)
        region = img[np.ix_(np.clip(np.arange(ry0, ry1), 0, ih - 1), np.clip(np.arange(rx0, rx1), 0, iw - 1))]
    if shrink > 1.0:
        region = cv2.GaussianBlur(region, (0, 0), sigmaX=0.5 * shrink, borderType=cv2.BORDER_REPLICATE)
    u = (np.arange(out_w, dtype=np.float32) + np.float32(0.5)) / np.float32(out_w) - np.float32(0.5)
    v = (np.arange(out_h, dtype=np.float32) + np.float32(0.5)) / np.float32(out_h) - np.float32(0.5)
    f = factors.astype(np.float32)[:, None, None]
    map_x = np.float32(cx - rx0 - 0.5) + f * np.float32(w) * u[None, None, :]  # pixel centres at +0.5
    map_y = np.float32(cy - ry0 - 0.5) + f * np.float32(h) * v[None, :, None]
    map_x = np.ascontiguousarray(np.broadcast_to(map_x, (n, out_h, out_w)).reshape(n * out_h, out_w))
    map_y = np.ascontiguousarray(np.broadcast_to(map_y, (n, out_h, out_w)).reshape(n * out_h, out_w))
    out = cv2.remap(region, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(n, out_h, out_w)


class ScaleFilter:
    """DSST 1-D scale filter for a target whose first-frame size is w0 x h0 (module docstring)."""

    def __init__(self, params: DSSTParams, w0: float, h0: float, soft: bool = True) -> None:
        self.params = params
        s = params.n_scales
        self.factors = params.scale_step ** (np.arange(s) - s // 2)  # ascending, 1.0 in the middle
        self.window = np.hanning(s).astype(np.float32)[:, None] if s > 2 else np.ones((s, 1), np.float32)
        self.gf = _label_spectrum(s, params.sigma_factor * math.sqrt(s))[:, None]
        k = math.sqrt(params.model_max_area / (w0 * h0)) if w0 * h0 > params.model_max_area else 1.0
        self.model_w = max(2 * CELL, math.floor(w0 * k / CELL) * CELL)
        self.model_h = max(2 * CELL, math.floor(h0 * k / CELL) * CELL)
        self.soft = soft
        self.num: np.ndarray | None = None  # conj(A) of eq. 5, (S//2+1, d)
        self.den: np.ndarray | None = None  # B of eq. 5, (S//2+1, 1)

    @property
    def trained(self) -> bool:
        return self.num is not None

    def sample(self, img: np.ndarray, cx: float, cy: float, w: float, h: float) -> np.ndarray:
        """The d x S training / test sample as an (S, d) float32 array, Hann-weighted over the scales."""
        patches = scale_patches(img, cx, cy, w, h, self.factors, self.model_w, self.model_h)
        feats = fhog(patches, CELL, soft=self.soft).reshape(len(self.factors), -1)
        feats *= self.window
        return feats

    def train(self, img: np.ndarray, cx: float, cy: float, w: float, h: float, rate: float) -> None:
        """Eq. 5 at the target box (cx, cy, w, h); rate 1 (or the first call) replaces the model."""
        ff = sfft.rfft(self.sample(img, cx, cy, w, h), axis=0, workers=1)
        num = self.gf * np.conj(ff)  # conj(conj(G) F) = G conj(F), kept conjugated for eq. 6
        den = np.einsum("sd,sd->s", ff, np.conj(ff)).real[:, None]
        if self.num is None or rate >= 1.0:
            self.num, self.den = num, den
        elif rate > 0.0:
            self.num = (1.0 - rate) * self.num + rate * num
            self.den = (1.0 - rate) * self.den + rate * den

    def response(
        self, img: np.ndarray, cx: float, cy: float, w: float, h: float, upsample: int = 1
    ) -> np.ndarray:
        """Eq. 6 over the S scales of the box (cx, cy, w, h); index i is the size factor `factors[i]`.

        upsample K > 1: the same response on K points per scale step (S K values, index i / K), by
        zero-padding its spectrum (trigonometric interpolation, fDSST TPAMI 2017 Sec. 4.2).
        """
        if self.num is None or self.den is None:
            raise TrackerError("ScaleFilter.response called before train")
        zf = sfft.rfft(self.sample(img, cx, cy, w, h), axis=0, workers=1)
        yf = np.einsum("sd,sd->s", self.num, zf) / (self.den[:, 0] + self.params.lambda_)
        n = len(self.factors)
        return sfft.irfft(yf, n=n * upsample, workers=1) * upsample

    def estimate(self, img: np.ndarray, cx: float, cy: float, w: float, h: float) -> float:
        """Size factor a^n* of the best scale for a target of w x h centred at (cx, cy); n* to 1 /
        `interpolation` of a step, within the sampled range."""
        k = self.params.interpolation
        n = len(self.factors)
        y = self.response(img, cx, cy, w, h, k)[: (n - 1) * k + 1]  # not past the largest sampled scale
        return float(self.params.scale_step ** (int(np.argmax(y)) / k - n // 2))
