# SPDX-License-Identifier: Apache-2.0
"""Background-aware correlation filter (BACF; Kiani Galoogahi, Fagg, Lucey, ICCV 2017) on real FFTs.

A multi-channel LINEAR filter h of the target's size (D cells per channel) is trained over a window T
cells large, several times the target (`BACFParams.padding`): every circular shift of the whole window
is a training sample, and since h is cropped to the target support (the binary crop P), the shifts that
put background under h are real negatives, not the periodic copies of the target that a window-sized
KCF sees (the boundary effect). Paper eq. 2 (spatial):

    E(h) = 1/2 sum_j || y(j) - sum_k h_k^T P x_k[Delta tau_j] ||^2 + lambda / 2 sum_k || h_k ||^2.

With the DFT-domain auxiliary filter g^ = sqrt(T) (F P^T (x) I_K) h (eq. 4), the augmented Lagrangian
(eq. 5) is minimised by ADMM (eq. 6-12), each subproblem in closed form:

- g^ (eq. 9-10, per frequency t, a K x K rank-one system solved by Sherman-Morrison):
  (x^(t) x^(t)^H + T mu I) g^(t) = x^(t) conj(y^(t)) - T zeta^(t) + T mu h^(t);
- h (eq. 7-8): h = T / (lambda + mu T) P (mu g + zeta), g and zeta the inverse DFTs, i.e. the
  unconstrained solution cropped to the target support;
- zeta^ <- zeta^ + mu (g^ - h^) (eq. 11), mu <- min(beta mu, mu_max) (eq. 12).

Conventions: unnormalised DFTs (`kcf.rfft2`), the response to a feature map z is
F^-1(sum_k conj(h^_k) z^_k) (correlation with the constrained filter; its peak at (0, 0) means no
displacement; the reference code correlates with g^, `detect_with` g), the online model
is the sample spectrum x^ blended with the learning rate (the reference code), and ADMM restarts from
g = h = zeta = 0, mu = mu0 on every training call. The half spectra of `rfft2` are enough: every step
is per frequency or a real inverse/forward transform, so Hermitian symmetry is kept.

Defaults are the paper's / its reference code's: search area 5x the target, at most 50^2 cells,
lambda 0.01, learning rate 0.013, output sigma 1/16 of the target size, 2 ADMM iterations, mu0 1,
beta 10, mu_max 1e4; 5 scales (here the pipeline's scale search, or the DSST option).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft

from swir_tracker_ros.core.fft import gaussian_label_spectrum, irfft2, rfft2
from swir_tracker_ros.core.kcf import KCFParams
from swir_tracker_ros.errors import TrackerError
from swir_tracker_ros.paramfield import param as _f
from swir_tracker_ros.paramfield import validate_params


@dataclass
class BACFParams(KCFParams):
    """BACF pipeline (ICCV 2017; reference code defaults): filter, window, ADMM. The failure test (PSR),
    update gate (peak / LMCF) and feature settings are KCF's (inherited, each default written once in
    KCFParams); `kernel_sigma` is not read (BACF is a linear filter)."""

    padding: float = _f(
        4.0, "training / search window = (1 + padding) x target (BACF: search area scale 5)", 0.5, 8.0
    )
    kernel_sigma: float = _f(
        KCFParams.kernel_sigma, "not read: BACF is a linear filter (inherited from KCFParams)", 0.01, 10.0
    )
    feature: str = _f(
        "hog_soft",
        "filter features (choices as kcf.feature): soft FHOG, what BACF was measured with here; hog_gray "
        "is the BACF paper's HOG + grayscale, not tuned for it here",
        choices=KCFParams.__dataclass_fields__["feature"].metadata["choices"],
    )
    lambda_: float = _f(0.01, "lambda of eq. 2, weight of ||h||^2 (BACF: 0.01)", 1e-8, 10.0)
    interp_factor: float = _f(0.013, "learning rate of the sample model (BACF: 0.013)", 0.0, 1.0)
    output_sigma_factor: float = _f(
        1.0 / 16.0, "Gaussian label sigma = sqrt(w h) x factor / cell (BACF: 1/16)", 0.01, 1.0
    )
    window_shape: str = _f(
        "proportional",
        "proportional: (1 + padding) x the target's width and height, as kcf (better here from shifted "
        "starts); square: a square of the same area, side (1 + padding) sqrt(w h) (BACF reference: "
        "search_area_shape square)",
        choices=("square", "proportional"),
    )
    max_window_cells: int = _f(
        2500,
        "the window is resampled so its feature map has at most this many cells (BACF filter_max_area "
        "50^2); bounds the cost of a large window",
        64,
        100000,
    )
    admm_iterations: int = _f(2, "ADMM iterations per training call (BACF: 2)", 1, 100)
    admm_mu: float = _f(1.0, "initial penalty mu of the augmented Lagrangian (eq. 5; BACF: 1)", 1e-6, 1e6)
    admm_beta: float = _f(10.0, "penalty growth mu <- beta mu per iteration (eq. 12; BACF: 10)", 1.0, 1e3)
    admm_mu_max: float = _f(1e4, "largest penalty mu (eq. 12; BACF: 1e4)", 1e-6, 1e9)
    detect_with: str = _f(
        "h",
        "filter that detection correlates with: h, the constrained filter (zero off the target support, "
        "eq. 8: no boundary effect), or g, the unconstrained ADMM variable of the last iteration (the "
        "reference code's g_f)",
        choices=("h", "g"),
    )
    psr_window: float = _f(
        2.5,
        "(ours) the PSR sidelobe is taken over this many target sizes around the peak (the kcf window: "
        "2.5), not over the whole 5x response, so a look-alike farther away does not count as failure and "
        "the paper 000 threshold keeps its meaning; 0: the whole response",
        0.0,
        10.0,
    )
    psr_ratio: float = _f(
        0.0,
        "(ours) failure also when PSR < this ratio x the mean PSR of the frames that updated the model "
        "(relative test as LMCF's / the dissertation's APCE tests); psr_threshold stays the absolute "
        "floor; 0: psr_threshold alone (paper 000)",
        0.0,
        2.0,
    )
    reference_peak: float = _f(
        1.0,
        "(ours) responses are scaled so the first-frame self-response peaks at this value, as KCF's "
        "does (~1), so the PSR / peak thresholds and the Huber map of eq. 38 keep their meaning; 0: raw",
        0.0,
        10.0,
    )

    def validate(self) -> None:
        validate_params(self, "bacf.")


def support_mask(shape: tuple[int, int], support: tuple[int, int]) -> tuple[slice, slice]:
    """Rows and columns of the filter support P: a `support` (rows, cols) block at the window centre.

    The window is centred on the target, so the filter that correlates the target to the label's peak
    at (0, 0) sits where the target sits in the window (correlation: r(tau) = sum_n h(n) x(n + tau)).
    """
    rows, cols = shape
    sr = max(1, min(rows, support[0]))
    sc = max(1, min(cols, support[1]))
    r0, c0 = (rows - sr) // 2, (cols - sc) // 2
    return slice(r0, r0 + sr), slice(c0, c0 + sc)


class BACF:
    """One BACF model over feature maps of fixed shape (C, rows, cols) with a filter of `support` cells.

    `train(x, rate)` blends the sample model with `x` (rate 1: replace) and solves for the filter by
    ADMM; `respond(z)` returns the responses of a batch (N, C, rows, cols) as (N, rows, cols).
    """

    def __init__(
        self,
        params: BACFParams,
        feat_shape: tuple[int, int, int],
        target_cells: float,
        support: tuple[int, int],
    ) -> None:
        self.params = params
        self.shape = (feat_shape[1], feat_shape[2])
        sigma = max(target_cells * params.output_sigma_factor, 0.25)
        self.yf = gaussian_label_spectrum(self.shape[0], self.shape[1], float(sigma))
        self.rows, self.cols = support_mask(self.shape, support)
        # Pruned transforms of the h-step: h is zero off the support rows, so the DFT along the rows
        # is a (rows x support-rows) matrix product each way (K R s_r (C/2+1) products instead of two
        # full 2-D transforms of the K channels).
        n, r = self.shape[0], np.arange(self.rows.start, self.rows.stop)
        phase = 2j * np.pi * np.outer(np.arange(n), r) / n
        self._row_dft = np.exp(-phase).astype(np.complex64)  # (R, s_r): support rows -> frequencies
        self._row_idft = (np.exp(phase).T / n).astype(np.complex64)  # (s_r, R): frequencies -> rows
        self.model_xf: np.ndarray | None = None
        self.gf: np.ndarray | None = None  # detection filter: the g^ of the last ADMM iteration
        self.hf: np.ndarray | None = None  # the constrained filter's spectrum (support-limited h)
        self.h: np.ndarray | None = None  # the constrained filter, spatial (C, rows, cols), zero off P
        self.detector: np.ndarray | None = None  # the spectrum `respond` uses (`detect_with`)

    @property
    def trained(self) -> bool:
        return self.gf is not None

    def train(self, x: np.ndarray, rate: float, iterations: int | None = None) -> list[float]:
        """Blend the sample model with x (C, rows, cols) at `rate` and run ADMM (eq. 6-12).

        Returns the objective E(h) of eq. 2 after each iteration when `iterations` is given (tests;
        costs one extra correlation per iteration), else an empty list.
        """
        p = self.params
        xf = rfft2(x).astype(np.complex64)
        if self.model_xf is None or rate >= 1.0:
            self.model_xf = xf
        elif rate > 0.0:
            self.model_xf = (1.0 - rate) * self.model_xf + rate * xf
        else:
            return []
        trace = iterations is not None
        n_iter = iterations if iterations is not None else p.admm_iterations
        mf = self.model_xf
        T = float(self.shape[0] * self.shape[1])
        yf = self.yf
        mfc = np.conj(mf)
        sxx = np.einsum("khw,khw->hw", mf, mfc).real.astype(np.float32)  # x^H x per frequency
        xy = mf * np.conj(yf)  # x conj(y)
        gf = np.zeros_like(mf)
        hf = np.zeros_like(mf)
        lf = np.zeros_like(mf)
        cols = self.shape[1]
        block = np.zeros((mf.shape[0], self._row_idft.shape[0], cols), dtype=np.float32)
        mu = p.admm_mu
        objective: list[float] = []
        for it in range(n_iter):
            # g^-subproblem (eq. 10, Sherman-Morrison): c = x conj(y) - T zeta + T mu h; g = c / (T mu) -
            # x (x^H c) / (T mu (T mu + x^H x))
            tm = T * mu
            if it == 0:  # zeta = h = 0: c = x conj(y), and x^H c = (x^H x) conj(y), so g = c / (T mu + x^H x)
                gf = xy / (tm + sxx)[None]
            else:
                c = xy - T * lf + tm * hf
                xc = np.einsum("khw,khw->hw", mfc, c)
                gf = (c - mf * (xc / (tm + sxx))[None]) / tm
            # h-subproblem (eq. 8): the unconstrained solution cropped to the support P; inverse DFT of
            # the support rows only, then of the columns (an irfft2 restricted to the rows of P)
            rows = sfft.irfft(np.matmul(self._row_idft, mu * gf + lf), n=cols, axis=-1, workers=1)
            block[:, :, self.cols] = (T / (p.lambda_ + tm)) * rows[:, :, self.cols]
            hf = np.matmul(self._row_dft, sfft.rfft(block, axis=-1, workers=1).astype(np.complex64))
            lf = lf + mu * (gf - hf)  # eq. 11
            mu = min(p.admm_beta * mu, p.admm_mu_max)  # eq. 12
            if trace:
                objective.append(self.objective(self._spatial(block)))
        self.gf, self.hf, self.h = gf.astype(np.complex64), hf, self._spatial(block)
        self.detector = self.hf if p.detect_with == "h" else self.gf
        return objective

    def _spatial(self, block: np.ndarray) -> np.ndarray:
        """The full-window filter (K, rows, cols) from its support rows (K, s_r, cols)."""
        h = np.zeros((block.shape[0], *self.shape), dtype=np.float32)
        h[:, self.rows] = block
        return h

    def objective(self, h: np.ndarray) -> float:
        """E(h) of eq. 2 for the current sample model: 1/2 ||y - sum_k x_k (*) h_k||^2 + lambda/2 ||h||^2."""
        if self.model_xf is None:
            raise TrackerError("BACF.objective called before train")
        hf = rfft2(h)
        r = irfft2(np.einsum("khw,khw->hw", np.conj(hf), self.model_xf), self.shape)
        y = irfft2(self.yf, self.shape)
        reg = 0.5 * self.params.lambda_ * np.sum(h.astype(np.float64) ** 2)
        return float(0.5 * np.sum((y - r) ** 2) + reg)

    def respond(self, z: np.ndarray) -> np.ndarray:
        """Responses (N, rows, cols) of feature maps z (N, C, rows, cols): F^-1(sum_k conj(h^_k) z^_k)
        (or g^ with `detect_with` g)."""
        if self.detector is None:
            raise TrackerError("BACF.respond called before train")
        zf = rfft2(z)
        return irfft2(np.einsum("nkhw,khw->nhw", zf, np.conj(self.detector)), self.shape)
