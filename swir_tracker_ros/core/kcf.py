# SPDX-License-Identifier: Apache-2.0
"""Kernelized correlation filter (Henriques et al., TPAMI 2015; paper 000 eqs. 3-8) on real FFTs."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.confidence import PSR_FAILURE
from swir_tracker_ros.core.features import FEATURE_KINDS
from swir_tracker_ros.core.fft import gaussian_label_spectrum, irfft2, rfft2
from swir_tracker_ros.core.kernels import corr_jit
from swir_tracker_ros.core.scale import ScaleOptions
from swir_tracker_ros.errors import TrackerError
from swir_tracker_ros.paramfield import param as _f
from swir_tracker_ros.paramfield import validate_params


@dataclass
class KCFParams(ScaleOptions):
    """KCF pipeline of paper 000: filter (Henriques et al. 2015, HOG defaults), failure test and update gate.

    `KCFParams.gray()` gives the raw-pixel set of the MATLAB reference.
    """

    padding: float = _f(1.5, "search window = (1 + padding) x target (paper 000: 2.5x)", 0.5, 4.0)
    lambda_: float = _f(1e-4, "ridge regularisation lambda (eq. 1)", 1e-8, 1.0)
    kernel_sigma: float = _f(0.5, "Gaussian kernel sigma (eq. 7); 0.2 is the raw-gray value", 0.01, 10.0)
    interp_factor: float = _f(0.02, "model learning rate; 0.075 is the raw-gray value", 0.0, 1.0)
    output_sigma_factor: float = _f(0.1, "Gaussian label sigma = sqrt(w h) x factor / cell", 0.01, 1.0)
    feature: str = _f(
        "hog_gray",
        "filter features: 31-channel FHOG (cell 4) with soft orientation bins as in Piotr's fhog "
        "(hog_soft: paper 000), with hard nearest bins (hog), soft FHOG plus the cell-mean intensity "
        "(hog_gray, ours: the intensity a thermal or SWIR target differs most in) or plus an 8-bin "
        "intensity histogram (hog_ih), or raw gray (cell 1)",
        choices=FEATURE_KINDS,
    )
    cell_size: int = _f(4, "FHOG cell size in pixels (gray features always use 1)", 1, 8)
    psr_threshold: float = _f(
        PSR_FAILURE, "failure detection: PSR below this switches to 9 windows (paper 000 eq. 10)", 0.0, 100.0
    )
    update_peak_threshold: float = _f(
        0.5, "update gate `peak`: model updated only when the peak exceeds this (paper 000)", 0.0, 2.0
    )
    update_gate: str = _f(
        "lmcf",
        "confident-update gate: peak (paper 000: peak > update_peak_threshold) or lmcf (ours after Wang et "
        "al., CVPR 2017, eq. 12: peak and APCE both above a ratio of their means over the updated frames)",
        choices=("peak", "lmcf"),
    )
    lmcf_peak_ratio: float = _f(0.7, "gate lmcf: beta1, peak >= beta1 x mean peak (LMCF)", 0.0, 2.0)
    lmcf_apce_ratio: float = _f(0.45, "gate lmcf: beta2, APCE >= beta2 x mean APCE (LMCF)", 0.0, 2.0)

    @classmethod
    def gray(cls) -> KCFParams:
        """Raw-pixel KCF of the MATLAB reference: sigma 0.2, interpolation 0.075, cell 1."""
        return cls(kernel_sigma=0.2, interp_factor=0.075, feature="gray", cell_size=1)

    def validate(self) -> None:
        validate_params(self, "kcf.")


def gaussian_correlation(
    zf: np.ndarray, zz: np.ndarray, xf: np.ndarray, xx: float, sigma: float, shape: tuple[int, int]
) -> np.ndarray:
    """Spectrum of the Gaussian kernel correlation k^{xz} for a batch (paper 000 eq. 7).

    zf: (N, C, rows, cols//2+1) spectra, zz: (N,) squared norms, xf: (C, rows, cols//2+1) model
    spectrum with squared norm xx. Returns (N, rows, cols//2+1).
    """
    numel = zf.shape[1] * shape[0] * shape[1]
    cj = corr_jit()
    if cj is not None and zf.dtype == xf.dtype == np.complex64:  # the einsum's sums, compiled (corr_jit.py)
        cross = np.empty((zf.shape[0], *zf.shape[2:]), dtype=np.complex64)
        cj.cross_spectrum_kernel(np.ascontiguousarray(zf), np.ascontiguousarray(xf), cross)
    else:
        cross = np.einsum("nchw,chw->nhw", zf, np.conj(xf))
    return _kernel_spectrum(cross, zz, xx, sigma, shape, numel)


def _kernel_spectrum(
    cross: np.ndarray, zz: np.ndarray, xx: float, sigma: float, shape: tuple[int, int], numel: int
) -> np.ndarray:
    """The rest of `gaussian_correlation` from the channel-summed cross-power spectrum (paper 000 eq. 7)."""
    xy = irfft2(cross, shape)
    d = np.maximum(0.0, (zz[:, None, None] + xx - 2.0 * xy) / numel)
    return rfft2(np.exp(-d / sigma**2))


_CHUNK_BYTES = 1 << 20  # spectra of this many bytes a chunk stay in a core's L2 cache (512 KB-1 MB)


_KEEP_SPECTRA = 9  # `KCF.respond` keeps the spectra of batches up to this size (normal mode: 1-5 windows)
_KEPT_BATCHES = 3  # ... of the last this many such batches (the scale climb correlates up to 3 per frame)


def _chunked_cross_spectrum(
    z: np.ndarray, xf: np.ndarray, cross_spectrum_kernel: Callable, keep: bool = False
) -> tuple[np.ndarray, list[np.ndarray]]:
    """sum_c rfft2(z)[:, c] * conj(xf[c]) with the FFTs done a few windows at a time and each chunk's
    spectra consumed by the compiled channel sum while they are still in cache (no 8 MB spectrum array
    for a 41-window lattice). The same numbers as the einsum over the whole batch: each plane's FFT is
    independent of the batch it is computed in, and the kernel sums the channels in the einsum's order.
    Also returns the chunks' spectra when `keep` (else an empty list)."""
    n, c, rows, cols = z.shape
    k = cols // 2 + 1
    cross = np.empty((n, rows, k), dtype=np.complex64)
    step = max(1, _CHUNK_BYTES // (c * rows * k * 8))
    chunks = []
    for i in range(0, n, step):
        zf = rfft2(z[i : i + step])
        cross_spectrum_kernel(zf, xf, cross[i : i + step])
        if keep:
            chunks.append(zf)
    return cross, chunks


class KCF:
    """One KCF model over feature maps of fixed shape (C, rows, cols).

    `train(x, rate)` learns alpha (eq. 6) from a windowed feature map and blends the model with
    learning rate `rate` (1.0 on the first frame); `respond(z)` returns the responses (eq. 8) of a
    batch of feature maps (N, C, rows, cols) as (N, rows, cols).
    """

    def __init__(self, params: KCFParams, feat_shape: tuple[int, int, int], target_cells: float) -> None:
        self.params = params
        self.shape = (feat_shape[1], feat_shape[2])
        sigma = max(target_cells * params.output_sigma_factor, 0.25)
        self.yf = gaussian_label_spectrum(self.shape[0], self.shape[1], float(sigma))
        self.model_x: np.ndarray | None = None
        self.model_xf: np.ndarray | None = None
        self.model_alphaf: np.ndarray | None = None
        # the last batches (each with its FFT chunks and chunk length), most recent last
        self._spectra: list[tuple[np.ndarray, list[np.ndarray], int]] = []
        # (model_x, d, basis P, spectrum of P'x) of the last `projection` call
        self._projection: tuple[np.ndarray, int, np.ndarray, np.ndarray] | None = None

    @property
    def trained(self) -> bool:
        return self.model_alphaf is not None

    def spectrum(self, z: np.ndarray, index: int) -> np.ndarray | None:
        """rfft2 of window `index` of the batch `z` (1, C, rows, cols//2+1) if `z` is one of the batches of
        the last `_KEPT_BATCHES` `respond` calls whose spectra were kept (compiled path, at most
        `_KEEP_SPECTRA` windows); else None. Lets the long-term memory score the winning window without a
        second FFT (BaseFilter)."""
        for batch, chunks, step in reversed(self._spectra):
            if batch is z:
                chunk = chunks[index // step]
                return chunk[index % step : index % step + 1]
        return None

    def sample(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(xf, alphaf) of the training sample x: its spectrum and the dual coefficients of eq. 6 learnt
        from it alone (the same for every KCF of equal Params and shape: the long-term memory is one)."""
        xf = rfft2(x)
        xx = np.array([float(np.vdot(x, x))])
        kf = gaussian_correlation(xf[None], xx, xf, float(xx[0]), self.params.kernel_sigma, self.shape)[0]
        return xf, self.yf / (kf + self.params.lambda_)  # eq. 6

    def train(self, x: np.ndarray, rate: float, sample: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """Learn from x at learning rate `rate`; `sample`: `self.sample(x)` if already computed."""
        xf, alphaf = self.sample(x) if sample is None else sample
        if self.model_alphaf is None or rate >= 1.0:
            self.model_x, self.model_xf, self.model_alphaf = x.copy(), xf, alphaf
        else:
            self.model_x = (1.0 - rate) * self.model_x + rate * x
            self.model_xf = (1.0 - rate) * self.model_xf + rate * xf
            self.model_alphaf = (1.0 - rate) * self.model_alphaf + rate * alphaf

    def respond(self, z: np.ndarray) -> np.ndarray:
        return self.respond_spectra(z, None)

    def projection(self, d: int) -> np.ndarray:
        """(C, d) orthonormal basis of the d principal channel directions of the model x (eigenvectors of
        the C x C second-moment matrix of its channels, largest eigenvalues first: the PCA feature
        compression of fDSST, Danelljan et al. "Discriminative Scale Space Tracking", TPAMI 2017), computed
        once per model."""
        return self._projected_model(d)[0]

    def _projected_model(self, d: int) -> tuple[np.ndarray, np.ndarray]:
        """(basis P of `projection`, rfft2 of the projected model P'x), kept while the model is unchanged."""
        kept = self._projection
        if kept is not None and kept[0] is self.model_x and kept[1] == d:
            return kept[2], kept[3]
        if self.model_x is None:
            raise TrackerError("KCF.projection called before train")
        x = self.model_x.reshape(self.model_x.shape[0], -1).astype(np.float64)
        _vals, vecs = np.linalg.eigh(x @ x.T)
        basis = np.ascontiguousarray(vecs[:, ::-1][:, :d], dtype=np.float32)
        xpf = rfft2(np.tensordot(basis.T, self.model_x, axes=1).astype(np.float32)).astype(np.complex64)
        self._projection = (self.model_x, d, basis, xpf)
        return basis, xpf

    def respond_projected(self, zp: np.ndarray, zz: np.ndarray, d: int) -> np.ndarray:
        """Approximate `respond` of windows z given as their projections zp = P'z on `projection(d)` and
        their full squared norms zz: eq. 7 with the cross-correlation sum_c z_c * x_c replaced by
        sum_k (P'z)_k * (P'x)_k = z * (P P'x), exact when x lies in the span of P."""
        _basis, xpf = self._projected_model(d)
        zf = rfft2(zp)
        cross = np.einsum("nchw,chw->nhw", zf, np.conj(xpf))
        xx = float(np.vdot(self.model_x, self.model_x))
        numel = self.model_x.shape[0] * self.shape[0] * self.shape[1]
        kzf = _kernel_spectrum(cross, zz, xx, self.params.kernel_sigma, self.shape, numel)
        return irfft2(self.model_alphaf[None] * kzf, self.shape)

    def respond_spectra(self, z: np.ndarray, zf: np.ndarray | None) -> np.ndarray:
        """`respond` of the batch z whose spectra rfft2(z) are `zf` (None: computed here, chunk by chunk;
        the spectra of batches up to `_KEEP_SPECTRA` windows are then kept for `spectrum`)."""
        if self.model_alphaf is None:
            raise TrackerError("KCF.respond called before train")
        zz = np.einsum("nchw,nchw->n", z, z)
        xx = float(np.vdot(self.model_x, self.model_x))
        sigma = self.params.kernel_sigma
        cj = corr_jit()
        if cj is not None and z.dtype == np.float32 and self.model_xf.dtype == np.complex64:
            # gaussian_correlation's numbers, its FFT and channel sum fused chunk by chunk (core/corr_jit.py)
            xf = np.ascontiguousarray(self.model_xf)
            if zf is None:
                keep = len(z) <= _KEEP_SPECTRA
                zc = np.ascontiguousarray(z)
                cross, chunks = _chunked_cross_spectrum(zc, xf, cj.cross_spectrum_kernel, keep)
                if keep and chunks:  # a reused buffer (the lattice's) is kept once, with its new spectra
                    kept = [k for k in self._spectra if k[0] is not z][1 - _KEPT_BATCHES :]
                    self._spectra = [*kept, (z, chunks, len(chunks[0]))]
            else:
                cross = np.empty((zf.shape[0], *zf.shape[2:]), dtype=np.complex64)
                cj.cross_spectrum_kernel(np.ascontiguousarray(zf), xf, cross)
            numel = z.shape[1] * self.shape[0] * self.shape[1]
            kzf = _kernel_spectrum(cross, zz, xx, sigma, self.shape, numel)
        else:
            zf = rfft2(z) if zf is None else zf
            kzf = gaussian_correlation(zf, zz, self.model_xf, xx, sigma, self.shape)
        return irfft2(self.model_alphaf[None] * kzf, self.shape)  # eq. 8
