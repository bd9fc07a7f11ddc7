# SPDX-License-Identifier: Apache-2.0
"""Feature blocks of the ECO filter and their compression (ECO Sec. 3.1, eq. 3-7: the projection matrix P).

A block is one feature kind on its own cell grid over the same image sample (the reference configuration's
gray setup: FHOG on 6-pixel cells and intensity channels on 4-pixel cells). Each block of a sample is
normalised so that its mean squared value is 1 (the reference code's `normalize_power` 2 with
`normalize_size` and `normalize_dim`), multiplied by a cosine window (Hann of n + 2 points without its zero
ends, reference code), compressed to D of its C channels by P (ECO eq. 3: P^T x) and taken to the Fourier
domain (core/eco/fourier.py). The features themselves are the repository's: `core/fhog.py` (Piotr Dollar's
FHOG, 31 channels; hard orientation bins by default, as the reference code's `fhog` with softBin -1) and
`core/channels.py` (cell mean intensity plus a soft intensity histogram, standing in for the reference code's
lookup table `intensityChannelNorm6`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from types import ModuleType

import numpy as np

from swir_tracker_ros.core import kernels
from swir_tracker_ros.core.channels import intensity_channels
from swir_tracker_ros.core.eco.fourier import centred_spectrum
from swir_tracker_ros.core.fhog import N_CHANNELS, fhog

BLOCK_KINDS = ("hog", "intensity")


@dataclass(frozen=True)
class BlockSpec:
    """One feature block: kind, cell size in sample pixels, compressed dimension D, histogram bins
    (intensity)."""

    kind: str
    cell: int
    dim: int
    bins: int = 0
    soft: bool = True  # FHOG orientation binning

    @property
    def channels(self) -> int:
        """C, the block's channel count before compression."""
        return N_CHANNELS if self.kind == "hog" else 1 + self.bins


@lru_cache(maxsize=32)
def cosine_window(ny: int, nx: int) -> np.ndarray:
    """Hann window of n + 2 points with its two zero ends dropped, outer product (ny, nx) float32
    (reference)."""
    return np.outer(np.hanning(ny + 2)[1:-1], np.hanning(nx + 2)[1:-1]).astype(np.float32)


def compiled() -> ModuleType | None:
    """core/eco/kernels.py (numba loops) when in use (core/kernels.py: numba importable, `USE_JIT` on)."""
    return kernels.eco_jit()


def block_features(patches: np.ndarray, spec: BlockSpec) -> np.ndarray:
    """Raw feature maps (N, C, rows, cols) float32 of sample patches (N, H, W) in [0, 1]; H, W multiples of
    the cell."""
    if spec.kind == "hog":
        return fhog(patches, spec.cell, soft=spec.soft)
    if spec.kind == "intensity":
        jit = compiled()
        if jit is None:
            return intensity_channels(patches, spec.cell, spec.bins)
        n, h, w = patches.shape
        out = np.empty((n, 1 + spec.bins, h // spec.cell, w // spec.cell), dtype=np.float32)
        jit.intensity_cells_kernel(np.ascontiguousarray(patches, dtype=np.float32), spec.cell, spec.bins, out)
        return out
    raise ValueError(f"unknown ECO feature block {spec.kind!r}; expected one of {BLOCK_KINDS}")


def normalise(x: np.ndarray) -> np.ndarray:
    """Scale each sample's block (N, C, rows, cols) in place to a mean square of 1 (reference code's feature
    normalisation: x sqrt(rows cols C / sum x^2))."""
    n = x.shape[0]
    energy = np.einsum("nchw,nchw->n", x, x)
    scale = np.sqrt(np.float32(x[0].size) / (energy + np.float32(1e-12))).astype(np.float32)
    x *= scale.reshape(n, 1, 1, 1)
    return x


def extract(patches: np.ndarray, specs: tuple[BlockSpec, ...]) -> list[np.ndarray]:
    """Normalised (not yet windowed or projected) blocks of the patches, one (N, C, rows, cols) array each."""
    return [normalise(block_features(patches, s)) for s in specs]


def pca_projection(x: np.ndarray, dim: int) -> np.ndarray:
    """Initial projection matrix P (C, D) of a block (C, rows, cols): the D leading eigenvectors of the
    channel
    covariance of the mean-free cells (ECO Sec. 3.1: P initialised by PCA, reference `proj_init_method`
    pca)."""
    c = x.shape[0]
    flat = x.reshape(c, -1).astype(np.float64)
    flat = flat - flat.mean(axis=1, keepdims=True)
    _, vecs = np.linalg.eigh(flat @ flat.T)
    return np.ascontiguousarray(vecs[:, ::-1][:, :dim]).astype(np.float32)


def project(x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """ECO eq. 3's P^T x on feature maps or spectra (..., C, rows, cols) -> (..., D, rows, cols)."""
    *lead, c, h, w = x.shape
    out = np.matmul(p.T.astype(x.dtype), x.reshape(*lead, c, h * w))
    return out.reshape(*lead, p.shape[1], h, w)


def spectra(blocks: list[np.ndarray], a: float) -> list[np.ndarray]:
    """Windowed, interpolated half spectra of (projected or not) blocks (C-COT eq. 4), complex64."""
    out = []
    for x in blocks:
        win = cosine_window(x.shape[-2], x.shape[-1])
        out.append(centred_spectrum(x * win, a))
    return out
