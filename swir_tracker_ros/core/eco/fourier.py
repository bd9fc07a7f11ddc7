# SPDX-License-Identifier: Apache-2.0
"""Fourier-series maths of the continuous-domain filter (C-COT, Danelljan et al., ECCV 2016; ECO, CVPR 2017).

Conventions used by every ECO module:

- A feature block is a map of N x M cells of `cell` pixels covering the whole image sample (period T = N cell
  = M cell in both axes is the sample's support, the same for every block). Its continuous interpolation
  (C-COT eq. 1) J{x}(t) = sum_n x[n] b(t - t_n) has the Fourier coefficients X^[k] b^[k] (C-COT eq. 4), where
  X is the DFT of the samples and b^ the coefficients of the interpolation kernel b (a cubic spline, Keys
  a = -0.75, as the ECO reference configuration).
- Phases are taken about the CENTRE of the sample: sample n sits at t_n = n - (N - 1) / 2 cells, so a target
  in the middle of the image sample is at t = 0, the label peaks at 0 and the spatial regularisation window
  is smallest at 0 (the reference code keeps the top-left corner as origin; both are the same model).
- Spectra are stored as HALF spectra: rows ky = -K..K (centred, 2K + 1 rows), columns kx = 0..Kx. For a real
  signal the other half follows from X^[-k] = conj(X^[k]). An even N or M is made odd as the reference
  code's `filter_sz = feature_sz + (feature_sz + 1) % 2`: the interpolated signal has a coefficient at -N/2
  AND at +N/2, both X[N/2] b^[+-N/2] (the DFT is N-periodic), with their own phases about the centre.
- Inner products over the full spectrum are `2 Re sum(conj(a) b) - Re sum over the column kx = 0`.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import scipy.fft as sfft


def half_size(n: int) -> int:
    """K of a grid of n samples: the coefficients kept are -K..K (n odd: (n - 1) / 2; n even: n / 2)."""
    return n // 2


def _poly_cos_integral(coeffs: tuple[float, ...], lo: float, hi: float, omega: np.ndarray) -> np.ndarray:
    """Exact integral over [lo, hi] of sum_j coeffs[j] x^j cos(omega x), vectorised over omega.

    Repeated integration by parts: I_n = x^n sin(wx) / w - n / w J_{n-1}, J_n = -x^n cos(wx) / w + n / w
    I_{n-1};
    omega = 0 is the plain polynomial integral.
    """
    w = np.asarray(omega, dtype=np.float64)
    out = np.zeros_like(w)
    zero = np.abs(w) < 1e-12
    ws = np.where(zero, 1.0, w)

    def antiderivative(x: float) -> np.ndarray:
        total = np.zeros_like(w)
        s, c = np.sin(ws * x), np.cos(ws * x)
        for j, a in enumerate(coeffs):
            if a == 0.0:
                continue
            # I_j(x) = int x^j cos(wx): unrolled recursion
            i_val, j_val = s / ws, -c / ws  # I_0, J_0
            for n in range(1, j + 1):
                i_new = x**n * s / ws - n / ws * j_val
                j_new = -(x**n) * c / ws + n / ws * i_val
                i_val, j_val = i_new, j_new
            total += a * i_val
        return total

    out = antiderivative(hi) - antiderivative(lo)
    if zero.any():
        poly = sum(a * (hi ** (j + 1) - lo ** (j + 1)) / (j + 1) for j, a in enumerate(coeffs))
        out[zero] = poly
    return out


def cubic_kernel_ft(f: np.ndarray, a: float = -0.75) -> np.ndarray:
    """Continuous Fourier transform B(f) of the cubic convolution (Keys) kernel with parameter `a` (f in
    cycles
    per sample spacing): b(x) = (a+2)|x|^3 - (a+3)|x|^2 + 1 on |x| <= 1, a|x|^3 - 5a|x|^2 + 8a|x| - 4a on
    1 < |x| < 2 (C-COT Sec. 3.1, the kernel the ECO reference configuration uses). B is real and even; B(0) =
    1.
    """
    omega = 2.0 * math.pi * np.asarray(f, dtype=np.float64)
    inner = _poly_cos_integral((1.0, 0.0, -(a + 3.0), a + 2.0), 0.0, 1.0, omega)
    outer = _poly_cos_integral((-4.0 * a, 8.0 * a, -5.0 * a, a), 1.0, 2.0, omega)
    return 2.0 * (inner + outer)


@lru_cache(maxsize=64)
def interp_factors(n: int, a: float = -0.75) -> np.ndarray:
    """Per-axis factor for a block of n cells: b^[k] = B(k / n) / n (C-COT eq. 4, kernel spacing one cell,
    period
    n cells) times the phase exp(2 pi i k c / n), c = (n - 1) / 2, that moves the origin to the sample centre;
    k = -K..K (complex128, 2K + 1 values)."""
    K = half_size(n)
    k = np.arange(-K, K + 1, dtype=np.float64)
    c = (n - 1) / 2.0
    return cubic_kernel_ft(k / n, a) / n * np.exp(2j * math.pi * k * c / n)


def centred_spectrum(x: np.ndarray, a: float = -0.75) -> np.ndarray:
    """Interpolated half spectrum (..., 2K + 1, Kx + 1) complex64 of real maps (..., N, M) (C-COT eq. 4).

    rfft2 (unnormalised, as the reference code's fft2), rows reordered to ky = -K..K (an even axis's Nyquist
    row used for -N/2 and +N/2), then multiplied by the per-axis interpolation factors: these are exactly the
    Fourier coefficients |k| <= K of the kernel-interpolated signal J{x} over the period of N cells.
    """
    n, m = x.shape[-2:]
    xf = sfft.rfft2(x, axes=(-2, -1), workers=1)
    # rows in the order ky = -K..K (an even axis's Nyquist row X[N/2] = X[-N/2] used at both ends)
    xf = np.take(xf, _centred_rows(n), axis=-2)
    return xf * _factors(n, m, a)


@lru_cache(maxsize=64)
def _centred_rows(n: int) -> np.ndarray:
    """FFT row index of each centred row ky = -K..K."""
    K = half_size(n)
    return np.arange(-K, K + 1) % n


@lru_cache(maxsize=64)
def _factors(n: int, m: int, a: float) -> np.ndarray:
    """Outer product of the row and column interpolation factors (2K + 1, Kx + 1), complex64."""
    fy = interp_factors(n, a)
    fx = interp_factors(m, a)[half_size(m) :]
    return (fy[:, None] * fx[None, :]).astype(np.complex64)


def gaussian_label(
    k_y: int, k_x: int, sigma_y: float, sigma_x: float, period: tuple[float, float]
) -> np.ndarray:
    """Half spectrum (2 k_y + 1, k_x + 1) of the periodic Gaussian label of standard deviation sigma (same
    units
    as the period), by the Poisson summation formula: y^[k] = sqrt(2 pi) sigma / T exp(-2 (pi sigma k / T)^2)
    per axis (C-COT Sec. 3.2; the reference code's label)."""
    ky = np.arange(-k_y, k_y + 1, dtype=np.float64)
    kx = np.arange(0, k_x + 1, dtype=np.float64)
    ty, tx = period
    gy = math.sqrt(2 * math.pi) * sigma_y / ty * np.exp(-2.0 * (math.pi * sigma_y * ky / ty) ** 2)
    gx = math.sqrt(2 * math.pi) * sigma_x / tx * np.exp(-2.0 * (math.pi * sigma_x * kx / tx) ** 2)
    return (gy[:, None] * gx[None, :]).astype(np.complex64)


def shift_phase(k_y: int, k_x: int, dy: float, dx: float) -> np.ndarray:
    """Half-spectrum factor exp(i (ky dy + kx dx)) (dy, dx in radians of the period: 2 pi shift / T) that
    moves
    a signal by -shift: multiplying X^ by it maps x(t) to x(t + shift), i.e. content at `shift` to the centre
    (the reference code's `shift_sample`)."""
    ky = np.arange(-k_y, k_y + 1, dtype=np.float64)
    kx = np.arange(0, k_x + 1, dtype=np.float64)
    return (np.exp(1j * dy * ky)[:, None] * np.exp(1j * dx * kx)[None, :]).astype(np.complex64)


def half_inner(a: np.ndarray, b: np.ndarray) -> float:
    """Real inner product <a, b> over the FULL spectrum of two half spectra (last axis kx = 0..Kx):
    2 Re sum conj(a) b - Re sum_{kx=0} conj(a) b (Parseval over the Hermitian-symmetric whole)."""
    return float(2.0 * np.vdot(a, b).real - np.vdot(a[..., 0], b[..., 0]).real)


def embed_rows(k_small: int, k_large: int) -> slice:
    """Rows of a (2 k_large + 1)-row half spectrum that hold a (2 k_small + 1)-row one (centred)."""
    return slice(k_large - k_small, k_large + k_small + 1)


def symmetrise(xf: np.ndarray) -> np.ndarray:
    """Make the column kx = 0 Hermitian in place, x^[-ky, 0] = conj(x^[ky, 0]), by averaging the two halves
    (the reference code's `symmetrize_filter` copies one half); returns xf."""
    col = xf[..., 0]
    col[...] = 0.5 * (col + np.conj(col[..., ::-1]))
    return xf


def sample_grid(sf: np.ndarray, n_y: int, n_x: int) -> np.ndarray:
    """The real function sum_k s^[k] exp(2 pi i (ky ty / n_y + kx tx / n_x)) on the n_y x n_x grid of integer
    (ty, tx), index 0 = t 0 and indices past the middle negative (FFT order); n >= 2K + 1 per axis.

    The half spectrum (2K + 1, Kx + 1) is zero-padded into the rfft layout and transformed back (irfft2 with
    the 1/N normalisation undone)."""
    ky, kx = half_size(sf.shape[-2]), sf.shape[-1] - 1
    full = np.zeros((*sf.shape[:-2], n_y, n_x // 2 + 1), dtype=np.complex64)
    full[..., : ky + 1, : kx + 1] = sf[..., ky:, :]
    full[..., n_y - ky :, : kx + 1] = sf[..., :ky, :]
    return sfft.irfft2(full, s=(n_y, n_x), axes=(-2, -1), workers=1) * np.float32(n_y * n_x)
