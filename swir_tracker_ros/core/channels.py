# SPDX-License-Identifier: Apache-2.0
"""Complementary intensity channels for single-channel (thermal, gray) frames, on the FHOG cell grid.

FHOG describes edges only; a thermal target is often a blob whose contrast, not its outline, sets it
apart. Two cheap channel groups on the same `cell`-pixel grid as FHOG are appended to it:

- **intensity**: the cell mean of the conditioned frame minus 0.5, the gray channel BACF and CSR-DCF
  append to HOG for gray sequences (Kiani Galoogahi et al., ICCV 2017, Sec. 4.1: "HOG + grayscale";
  Lukezic et al., CVPR 2017, Sec. 5: HOG, Colornames and grayscale).
- **intensity histogram**: a soft `bins`-bin histogram of the pixel intensities in each cell (linear
  interpolation between the two nearest bin centres, normalised to sum 1 per cell), a one-channel stand-in
  for the colour-name channels of SAMF/CSR-DCF (Li & Zhu, ECCV-W 2014) and the local intensity
  distribution fields of DFT (Sevilla-Lara & Learned-Miller, CVPR 2012, Sec. 3).
"""

from __future__ import annotations

import numpy as np

from swir_tracker_ros.core.kernels import corr_jit


def cell_means(planes: np.ndarray, cell: int) -> np.ndarray:
    """Means of `cell` x `cell` blocks of (N, K, H, W) planes -> (N, K, H // cell, W // cell) float32
    (the grid FHOG uses: rows and columns past the last whole cell are dropped)."""
    n, k, h, w = planes.shape
    hc, wc = h // cell, w // cell
    cj = corr_jit()
    if cj is not None and cell < 8 and planes.dtype == np.float32:  # the same sums, one compiled pass
        out = np.empty((n, k, hc, wc), dtype=np.float32)
        cj.cell_means_kernel(np.ascontiguousarray(planes), cell, out)
        return out
    blocks = planes[:, :, : hc * cell, : wc * cell].reshape(n, k, hc, cell, wc, cell)
    return blocks.mean(axis=(3, 5), dtype=np.float32)


def intensity_histogram(patches: np.ndarray, bins: int) -> np.ndarray:
    """Soft histogram memberships (N, bins, H, W) of intensities in [0, 1]: bin b is centred at
    (b + 0.5) / bins and a pixel splits its unit weight between the two nearest centres linearly (values
    below the first or above the last centre go wholly to that bin)."""
    t = np.clip(patches * np.float32(bins) - np.float32(0.5), 0.0, np.float32(bins - 1))
    lo = np.floor(t)
    frac = (t - lo).astype(np.float32)
    lo = lo.astype(np.intp)
    centres = np.arange(bins, dtype=np.intp).reshape(1, bins, 1, 1)
    out = np.where(centres == lo[:, None], 1.0 - frac[:, None], np.float32(0.0))
    out += np.where(centres == lo[:, None] + 1, frac[:, None], np.float32(0.0))
    return out.astype(np.float32, copy=False)


def intensity_channels(patches: np.ndarray, cell: int, bins: int) -> np.ndarray:
    """Intensity (1 channel) and, when `bins` > 0, the intensity histogram (`bins` channels) of (N, H, W)
    patches in [0, 1] on the `cell` grid: (N, 1 + bins, H // cell, W // cell) float32."""
    mean = cell_means(patches[:, None], cell) - np.float32(0.5)
    if bins <= 0:
        return mean
    return np.concatenate([mean, cell_means(intensity_histogram(patches, bins), cell)], axis=1)
