# SPDX-License-Identifier: Apache-2.0
"""Felzenszwalb HOG (FHOG, 31 channels) for a batch of equally sized patches, at compiled speed.

Three compiled loops (core/fhog_jit.py, numba, pinned in requirements.txt) do the gradients, the
orientation binning with the bilinear scatter into cells, and the block normalisation (with the cosine
window); `cv2.cartToPolar` gives magnitude and angle in between: ~5 passes over the pixels' data instead
of ~25 numpy passes (docs/experiments.md). Without numba the numpy path below is used: `cv2.Sobel` gradients,
ONE `np.add.at` that scatters every pixel into its 2 orientation bins x 2 x cells, a row pooling over
`cell` row phases, and the block normalisation on the (small) cell grid. Both give the numbers of the
replaced `np.bincount` code exactly (float64 cell sums in its order, every float32 operation in its
order): that implementation is kept in test/fhog_reference.py and test/test_core_fhog.py pins
bit-identical results on real frames for both paths. Every pixel-sized array is a reused per-shape
buffer (fresh multi-MB arrays cost a page fault per 4 kB; docs/experiments.md).
"""

from __future__ import annotations

from functools import lru_cache
from types import ModuleType

import cv2
import numpy as np

from swir_tracker_ros.core import kernels

N_ORIENT = 9  # contrast-insensitive orientations; 2 * N_ORIENT contrast-sensitive bins
N_BINS = 2 * N_ORIENT
N_CHANNELS = 3 * N_ORIENT + 4  # 18 sensitive + 9 insensitive + 4 texture = 31
CLIP = 0.2
TEXTURE_WEIGHT = 0.2357  # 1 / sqrt(18), as in Felzenszwalb et al. and Dollar's fhog
_BIN_SCALE = np.float32(N_BINS / (2.0 * np.pi))  # radians -> orientation bin units


@lru_cache(maxsize=32)
def _axis_plan(n: int, cell: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bilinear pixel -> cell weights along one axis.

    A pixel at coordinate x sits at cell coordinate c = (x + 0.5) / cell - 0.5 and contributes to cells
    floor(c) and floor(c) + 1 with weights 1 - d and d (d = c - floor(c)); contributions outside the
    grid are dropped (weight 0, index clipped). Returns (i0, i1, w0, w1).
    """
    nc = n // cell
    c = (np.arange(n, dtype=np.float64) + 0.5) / cell - 0.5
    c0 = np.floor(c).astype(np.intp)
    d = c - c0
    i0, i1 = c0, c0 + 1
    w0 = np.where((i0 >= 0) & (i0 < nc), 1.0 - d, 0.0)
    w1 = np.where((i1 >= 0) & (i1 < nc), d, 0.0)
    return np.clip(i0, 0, nc - 1), np.clip(i1, 0, nc - 1), w0.astype(np.float32), w1.astype(np.float32)


@lru_cache(maxsize=32)
def _hist_plan(n: int, h: int, w: int, cell: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Flat accumulator index of each pixel's two x cells in the channel-LAST (n*h, wc, 18) layout
    (the orientation bin is added per frame), and the two bilinear x weights.

    Bin-innermost keeps the scatter of one pixel row inside wc * 18 neighbouring accumulator entries.
    """
    x0, x1, wx0, wx1 = _axis_plan(w, cell)
    wc = w // cell
    rows = (np.arange(n * h, dtype=np.intp) * wc).reshape(n, h, 1)
    return (rows + x0) * N_BINS, (rows + x1) * N_BINS, wx0, wx1


class _Workspace:
    """Per-shape buffers of `cell_histograms`, reused from frame to frame (a fresh multi-MB array costs
    page faults on every call: measured 10 of 16 ms a call on the development machine,
    docs/experiments.md)."""

    def __init__(self, n: int, h: int, w: int, cell: int = 0, jit: bool = False) -> None:
        """Buffers for N patches of H x W pixels; with cell > 0 also the scatter buffers of the numpy
        path, or with `jit` the (much smaller) scratch of the compiled loops."""
        npx = n * h * w
        if cell > 0 and jit:
            hc, wc = h // cell, w // cell
            self.row_acc = np.empty(wc * N_BINS, dtype=np.float64)
            self.hx = np.empty((n * h, wc * N_BINS), dtype=np.float32)
            self.ob0_row, self.ob1_row = np.empty(w, dtype=np.intp), np.empty(w, dtype=np.intp)
            self.m0_row, self.m1_row = np.empty(w, dtype=np.float32), np.empty(w, dtype=np.float32)
            self.hist = np.empty((n, hc, wc * N_BINS), dtype=np.float32)
            self.energy = np.empty((hc + 2, wc + 2), dtype=np.float32)
            self.inv = np.empty((hc + 1, wc + 1), dtype=np.float32)
            self.both = np.empty((3 * N_ORIENT, wc), dtype=np.float32)
            self.tsum = np.empty((4, wc), dtype=np.float32)
        elif cell > 0:
            self.index = np.empty(4 * npx, dtype=np.intp)
            self.weight = np.empty(4 * npx, dtype=np.float64)  # = acc's dtype: ufunc.at's fast loop
            self.acc = np.empty(n * h * (w // cell) * N_BINS, dtype=np.float64)
            self.acc32 = np.empty(n * h * (w // cell) * N_BINS, dtype=np.float32)
        shape = (n * h, w)
        self.gx, self.gy, self.mag, self.ang = (np.empty(shape, dtype=np.float32) for _ in range(4))
        if not jit:  # the numpy path's per-pixel bins and magnitude shares
            self.o, self.m0, self.m1 = (np.empty(shape, dtype=np.float32) for _ in range(3))
            self.ob0, self.ob1 = np.empty(shape, dtype=np.intp), np.empty(shape, dtype=np.intp)


@lru_cache(maxsize=16)
def _workspace(n: int, h: int, w: int, cell: int, jit: bool = False) -> _Workspace:
    return _Workspace(n, h, w, cell, jit)


def warm_up() -> bool:
    """Import numba and load (on a fresh install: compile, ~4 s) the compiled FHOG and correlation loops now
    rather than on the first frame; ~1 s with numba's on-disk cache. True if they are in use."""
    if kernels.fhog_jit() is None:
        return False
    fhog(np.zeros((1, 8, 8), dtype=np.float32), 4, soft=True, window=np.ones((2, 2), dtype=np.float32))
    kernels.warm_up_correlation()
    return True


@lru_cache(maxsize=8)
def _pool_plan(cell: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row phase r of a cell (`_pool_rows`): float32 weight of its own cell row, of the neighbouring
    cell row, and the neighbour's direction (+1 below for d < 0, -1 above for d > 0, 0 at d = 0)."""
    d = [(r + 0.5) / cell - 0.5 for r in range(cell)]
    own = np.array([np.float32(1.0 - abs(v)) for v in d], dtype=np.float32)
    nb = np.array([np.float32(abs(v)) for v in d], dtype=np.float32)
    direction = np.array([1 if v < 0 else -1 if v > 0 else 0 for v in d], dtype=np.intp)
    return own, nb, direction


def gradients(patches: np.ndarray, ws: _Workspace | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Magnitude and orientation in [0, 2 pi) of [-1, 0, 1] / 2 gradients; one-sided differences at the
    border (float32 (N, H, W) -> two float32 (N, H, W); written into `ws`'s buffers when given).

    `cv2.Sobel` with ksize 1 is the plain central difference; the patches are stacked into one image, so
    the border rows and columns (replicated or taken from the neighbouring patch) are overwritten with the
    one-sided differences afterwards.
    """
    n, h, w = patches.shape
    if ws is None:
        ws = _Workspace(n, h, w)
    jit = kernels.fhog_jit()
    if jit is not None and h >= 2 and w >= 2:  # one compiled pass (OpenCV's per-row overhead dominates
        gx, gy = ws.gx, ws.gy  # on the tall, narrow stacks of many small patches)
        jit.gradients_kernel(np.ascontiguousarray(patches, dtype=np.float32), gx, gy)
    else:
        flat = patches.reshape(n * h, w)
        gx = cv2.Sobel(flat, cv2.CV_32F, 1, 0, dst=ws.gx, ksize=1, scale=0.5, borderType=cv2.BORDER_REPLICATE)
        gy = cv2.Sobel(flat, cv2.CV_32F, 0, 1, dst=ws.gy, ksize=1, scale=0.5, borderType=cv2.BORDER_REPLICATE)
        gx3, gy3 = gx.reshape(n, h, w), gy.reshape(n, h, w)
        np.subtract(patches[:, :, 1], patches[:, :, 0], out=gx3[:, :, 0])
        np.subtract(patches[:, :, -1], patches[:, :, -2], out=gx3[:, :, -1])
        np.subtract(patches[:, 1, :], patches[:, 0, :], out=gy3[:, 0, :])
        np.subtract(patches[:, -1, :], patches[:, -2, :], out=gy3[:, -1, :])
    mag, ang = cv2.cartToPolar(gx, gy, magnitude=ws.mag, angle=ws.ang)
    return mag.reshape(n, h, w), ang.reshape(n, h, w)


def _orientation_bins(
    ang: np.ndarray, soft: bool, ws: _Workspace | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Orientation bins among the 18 contrast-sensitive ones (centres at multiples of 20 degrees): the
    lower bin ob0, the upper bin ob1 and the weight od of the upper one (1 - od for the lower; None for
    hard bins).

    soft: the two nearest bins share the gradient linearly (Piotr's fhog, softBin = -1); hard: the whole
    gradient goes to the nearest bin.
    """
    if ws is None:
        ws = _Workspace(1, 1, ang.size)
    shape = ang.shape
    o, ob0, ob1 = ws.o.reshape(shape), ws.ob0.reshape(shape), ws.ob1.reshape(shape)
    np.multiply(ang, _BIN_SCALE, out=o)
    od = None
    lower = ws.m0.reshape(shape)  # scratch
    if soft:
        np.floor(o, out=lower)
        od = np.subtract(o, lower, out=ws.m1.reshape(shape))
    else:
        np.rint(o, out=lower)
    np.copyto(ob1, lower, casting="unsafe")  # raw bin 0..18 (o = 18 only at exactly 2 pi)
    np.take(_LOWER, ob1, out=ob0, mode="clip")  # bin 18 is bin 0 (clip: unbuffered, values are 0..18)
    np.take(_UPPER, ob1, out=ob1, mode="clip")  # the next bin, cyclic
    return ob0, ob1, od


_LOWER = np.array([*range(N_BINS), 0], dtype=np.intp)
_UPPER = np.array([*range(1, N_BINS), 0, 1], dtype=np.intp)


def _pool_rows(hx: np.ndarray, cell: int) -> np.ndarray:
    """Bilinear pooling of pixel rows (n, h, k) into cell rows (n, h // cell, k), float32.

    Row r + cell * i sits at cell coordinate i + (r + 0.5) / cell - 0.5: it gives weight 1 - |d| to cell i
    and |d| to the neighbour on the side of d (dropped at the grid border). One pass per row offset r.
    Rows past the last whole cell (h not a multiple of `cell`) are dropped, as in the reference.
    """
    n, h, k = hx.shape
    hc = h // cell
    out = np.zeros((n, hc, k), dtype=np.float32)
    t = np.empty((n, hc, k), dtype=np.float32)
    for r in range(cell):  # `cell` (4) vectorised passes, not a loop over pixels
        rows = hx[:, r : r + cell * hc : cell]
        d = (r + 0.5) / cell - 0.5
        np.multiply(rows, np.float32(1.0 - abs(d)), out=t)
        out += t
        if d < 0:  # also feeds the cell above
            np.multiply(rows[:, 1:], np.float32(-d), out=t[:, :-1])
            out[:, :-1] += t[:, :-1]
        elif d > 0:  # also feeds the cell below
            np.multiply(rows[:, :-1], np.float32(d), out=t[:, 1:])
            out[:, 1:] += t[:, 1:]
    return out


def cell_histograms(patches: np.ndarray, cell: int, soft: bool = False) -> np.ndarray:
    """Gradient histograms (N, hc, wc, 18) float32: hard or soft orientation bins (`_orientation_bins`),
    bilinear spatial cells.

    One scatter-add (`np.add.at`, 4 entries a pixel: 2 orientation bins x 2 x cells; 2 with hard bins)
    accumulates straight into a reused bin-innermost (N*H, wc, 18) float64 buffer, then `cell` vectorised
    row passes do the y interpolation. Measured under OpenCV 4.14 (docs/experiments.md): 18 per-bin planes
    pooled by `cv2.sepFilter2D` take ~3x longer; the old `np.bincount` is as fast in a warm process but
    allocates its multi-MB output (page faults) on every call.
    """
    if patches.ndim == 2:
        patches = patches[None]
    patches = np.ascontiguousarray(patches, dtype=np.float32)
    jit = kernels.fhog_jit()
    if jit is not None:
        return _jit_histograms(jit, patches, cell, soft).copy()  # the caller owns its result
    n, h, w = patches.shape
    ws = _workspace(n, h, w, cell)
    mag, ang = gradients(patches, ws)
    ob0, ob1, od = _orientation_bins(ang, soft, ws)
    hc, wc = h // cell, w // cell
    c0, c1, wx0, wx1 = _hist_plan(n, h, w, cell)
    npx = n * h * w
    if od is None:  # hard bins: 2 entries a pixel (the upper bin's weight would be 0)
        parts = ((c0, ob0, wx0, mag), (c1, ob0, wx1, mag))
    else:
        m1 = np.multiply(mag, od, out=od)  # od's buffer is m1
        m0 = np.subtract(mag, m1, out=ws.m0.reshape(n, h, w))
        parts = ((c0, ob0, wx0, m0), (c1, ob0, wx1, m0), (c0, ob1, wx0, m1), (c1, ob1, wx1, m1))
    k = len(parts) * npx
    index, weight = ws.index[:k], ws.weight[:k]
    for q, (cx, ob, wx, m) in enumerate(parts):  # 2 or 4 vectorised passes
        np.add(cx, ob, out=index[q * npx : (q + 1) * npx].reshape(n, h, w))
        np.multiply(m, wx, out=weight[q * npx : (q + 1) * npx].reshape(n, h, w))
    acc = ws.acc
    acc.fill(0.0)
    # float64 sums in the reference's order (pass q, then pixel order): the bincount's exact numbers
    np.add.at(acc, index, weight)
    acc32 = ws.acc32
    np.copyto(acc32, acc, casting="same_kind")
    return _pool_rows(acc32.reshape(n, h, wc * N_BINS), cell).reshape(n, hc, wc, N_BINS)


def _jit_histograms(jit: ModuleType, patches: np.ndarray, cell: int, soft: bool) -> np.ndarray:
    """`cell_histograms` by the compiled loop, (N, hc, wc, 18) in a reused buffer (overwritten by the next
    call for the same shape)."""
    n, h, w = patches.shape
    ws = _workspace(n, h, w, cell, True)
    mag, ang = gradients(patches, ws)
    x0, x1, wx0, wx1 = _axis_plan(w, cell)
    jit.cell_histograms_kernel(
        mag.reshape(n * h, w), ang.reshape(n * h, w), h, cell, soft, x0, x1, wx0, wx1, *_pool_plan(cell),
        ws.row_acc, ws.hx, ws.ob0_row, ws.ob1_row, ws.m0_row, ws.m1_row, ws.hist,
    )
    return ws.hist.reshape(n, h // cell, w // cell, N_BINS)


def orientation_histograms(patches: np.ndarray, cell: int, soft: bool = False) -> np.ndarray:
    """`cell_histograms` channel first, (18, N, hc, wc) (a view)."""
    return np.moveaxis(cell_histograms(patches, cell, soft), -1, 0)


@lru_cache(maxsize=16)
def _norm_buffers(n: int, hc: int, wc: int) -> tuple[np.ndarray, np.ndarray]:
    """Two reused (27, n, hc, wc) float32 buffers of the block normalisation."""
    return tuple(np.empty((3 * N_ORIENT, n, hc, wc), dtype=np.float32) for _ in range(2))


def fhog(
    patches: np.ndarray, cell: int = 4, soft: bool = False, window: np.ndarray | None = None
) -> np.ndarray:
    """FHOG features of N patches (N, H, W) float32 -> (N, 31, H//cell, W//cell) float32.

    Channels: 18 contrast-sensitive, 9 contrast-insensitive orientation channels, each the average of
    its 4 block-normalised and 0.2-truncated values, then 4 texture (gradient energy) channels, one per
    normalisation block (Felzenszwalb et al., TPAMI 2010, Sec. 6; the variant used by KCF).
    `window`: optional (H//cell, W//cell) float32 map every channel is multiplied by (the cosine window;
    the same numbers as multiplying the result).
    """
    if patches.ndim == 2:
        patches = patches[None]
    patches = np.ascontiguousarray(patches, dtype=np.float32)
    jit = kernels.fhog_jit()
    if jit is not None:
        hist = _jit_histograms(jit, patches, cell, soft)
        n, hc, wc, _ = hist.shape
        ws = _workspace(n, patches.shape[1], patches.shape[2], cell, True)
        out = np.empty((n, N_CHANNELS, hc, wc), dtype=np.float32)
        use_window = window is not None
        win = np.ascontiguousarray(window, dtype=np.float32) if use_window else ws.inv  # any 2-D float32
        if use_window and win.shape != (hc, wc):
            raise ValueError(f"window of shape {win.shape} for a {hc}x{wc} cell grid")
        jit.normalise_kernel(
            hist, _norm_eps(cell), np.float32(CLIP), np.float32(TEXTURE_WEIGHT), win, use_window,
            ws.energy, ws.inv, ws.both, ws.tsum, out,
        )
        return out
    out = _fhog_numpy(patches, cell, soft)
    if window is not None:
        out *= window
    return out


def _norm_eps(cell: int) -> np.float32:
    """The block normalisation's regulariser (float32, as the numpy path adds it)."""
    return np.float32(1e-4 / (4.0 * cell**4 * 2.0))


def _fhog_numpy(patches: np.ndarray, cell: int, soft: bool) -> np.ndarray:
    """`fhog` on the numpy path (no window)."""
    hist = cell_histograms(patches, cell, soft)  # (n, hc, wc, 18)
    n, hc, wc, _ = hist.shape
    both, t = _norm_buffers(n, hc, wc)  # 18 sensitive + 9 insensitive orientation channels
    both[:N_BINS] = np.moveaxis(hist, -1, 0)  # channel first: long inner loops below
    insens = np.add(both[:N_ORIENT], both[N_ORIENT:N_BINS], out=both[N_BINS:])
    energy = np.einsum("knij,knij->nij", insens, insens)
    e = np.empty((n, hc + 2, wc + 2), dtype=np.float32)  # edge-replicated border of one cell
    e[:, 1:-1, 1:-1] = energy
    e[:, 0, 1:-1], e[:, -1, 1:-1] = energy[:, 0], energy[:, -1]
    e[:, :, 0], e[:, :, -1] = e[:, :, 1], e[:, :, -2]
    # sum of each 2x2 block of (padded) cells; block (i, j) covers padded cells i..i+1, j..j+1
    blocks = e[:, :-1, :-1] + e[:, 1:, :-1] + e[:, :-1, 1:] + e[:, 1:, 1:]  # (n, hc+1, wc+1)
    inv = 1.0 / np.sqrt(blocks + _norm_eps(cell))
    out = np.empty((n, N_CHANNELS, hc, wc), dtype=np.float32)
    orient = np.moveaxis(out[:, : 3 * N_ORIENT], 1, 0)  # (27, n, hc, wc) view
    clip = np.float32(CLIP)
    for q, norm in enumerate((inv[:, :-1, :-1], inv[:, :-1, 1:], inv[:, 1:, :-1], inv[:, 1:, 1:])):
        np.multiply(both, norm, out=t)  # the 4 normalisation blocks around each cell
        np.minimum(t, clip, out=t)
        if q == 0:
            orient[...] = t
        else:
            orient += t
        np.sum(t[:N_BINS], axis=0, out=out[:, 3 * N_ORIENT + q])
        out[:, 3 * N_ORIENT + q] *= np.float32(TEXTURE_WEIGHT)
    orient *= np.float32(0.5)
    return out
