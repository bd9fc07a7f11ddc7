# SPDX-License-Identifier: Apache-2.0
"""Patch sampling (crop + resize in one warp) and the feature maps the correlation filters consume."""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import cv2
import numpy as np

from swir_tracker_ros.core.channels import intensity_channels
from swir_tracker_ros.core.fhog import N_CHANNELS, fhog
from swir_tracker_ros.types import Box

HOG_KINDS = ("hog", "hog_soft")  # FHOG with hard or soft orientation bins
INTENSITY_BINS = {"hog_gray": 0, "hog_ih": 8}  # soft FHOG + intensity (+ histogram bins): core/channels.py
FEATURE_KINDS = (*HOG_KINDS, *INTENSITY_BINS, "gray")


_BLUR_ALIGN = 32  # columns: a multiple of the widest SIMD float vector x 2 (AVX-512: 16 lanes)


def _blur_margin(sigma: float) -> int:
    """Half width of the kernel cv2.GaussianBlur builds for a float image: ksize = round(8 sigma + 1) | 1."""
    return (round(sigma * 8 + 1) | 1) // 2


def blur_rect(
    img: np.ndarray, sigma: float, r0: int, r1: int, c0: int, c1: int
) -> tuple[np.ndarray, int, int]:
    """Gaussian blur (sigma, replicated borders) of the frame region that holds rows [r0, r1) and columns
    [c0, c1) (within the frame): (blurred slab, its first row, its first column).

    Only that region plus the kernel half width k is blurred, bit for bit the values of blurring the whole
    frame. Each slab edge is the frame's own edge or k pixels away from every pixel asked for; the columns
    also start on a multiple of _BLUR_ALIGN and span a multiple of it (or end at the frame edge), so
    OpenCV's vectorised row loops cover the same pixels in the same lanes as on the whole frame (an
    unaligned column cut was ~3e-7 off; full-width rows need no alignment).
    """
    k = _blur_margin(sigma)
    ih, iw = img.shape[:2]
    r0, r1 = max(r0 - k, 0), min(r1 + k, ih)
    c0 = max(c0 - k, 0) // _BLUR_ALIGN * _BLUR_ALIGN
    c1 = min(c1 + k, iw)
    if c1 < iw:
        c1 = min(c0 + -(-(c1 - c0) // _BLUR_ALIGN) * _BLUR_ALIGN, iw)
    return cv2.GaussianBlur(img[r0:r1, c0:c1], (0, 0), sigmaX=sigma, borderType=cv2.BORDER_REPLICATE), r0, c0


class SmoothedFrame:
    """A frame blurred with `sigma` only where it is read (ours): `presmooth` of the whole frame, bit for bit,
    at the cost of the windows' regions (`sample_patch` and `scale.scale_patches` call `ensure`).

    The blurred values go into a frame-sized buffer, tile by tile (_BLUR_ALIGN x _BLUR_ALIGN pixels); a
    read whose tiles are all done costs one look-up. `shape`, `dtype` and `ndim` are the frame's.
    """

    def __init__(self, raw: np.ndarray, sigma: float) -> None:
        self.raw, self.sigma = raw, sigma
        self.buf = np.empty_like(raw)
        t = _BLUR_ALIGN
        self._done = np.zeros((-(-raw.shape[0] // t), -(-raw.shape[1] // t)), dtype=bool)

    @property
    def shape(self) -> tuple[int, ...]:
        return self.raw.shape

    @property
    def dtype(self) -> np.dtype:
        return self.raw.dtype

    @property
    def ndim(self) -> int:
        return self.raw.ndim

    def ensure(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        """The buffer, with rows [r0, r1) x columns [c0, c1) (clamped into the frame) blurred."""
        ih, iw = self.raw.shape[:2]
        t = _BLUR_ALIGN
        tr0, tr1 = max(r0, 0) // t, -(-min(max(r1, 1), ih) // t)
        tc0, tc1 = max(c0, 0) // t, -(-min(max(c1, 1), iw) // t)
        tr0, tc0 = min(tr0, tr1 - 1), min(tc0, tc1 - 1)
        todo = ~self._done[tr0:tr1, tc0:tc1]
        if todo.any():
            # one tile more on each side: the next, slightly larger scale window or the training window
            # a few pixels on is then read from tiles already done, not blurred again with this rectangle
            nr, nc = self._done.shape
            tr0, tr1, tc0, tc1 = max(tr0 - 1, 0), min(tr1 + 1, nr), max(tc0 - 1, 0), min(tc1 + 1, nc)
            todo = ~self._done[tr0:tr1, tc0:tc1]
            rows, cols = np.nonzero(todo.any(axis=1))[0], np.nonzero(todo.any(axis=0))[0]
            a0, a1 = (tr0 + rows[0]) * t, min((tr0 + rows[-1] + 1) * t, ih)
            b0, b1 = (tc0 + cols[0]) * t, min((tc0 + cols[-1] + 1) * t, iw)
            slab, s0, d0 = blur_rect(self.raw, self.sigma, a0, a1, b0, b1)
            self.buf[a0:a1, b0:b1] = slab[a0 - s0 : a1 - s0, b0 - d0 : b1 - d0]
            self._done[tr0 + rows[0] : tr0 + rows[-1] + 1, tc0 + cols[0] : tc0 + cols[-1] + 1] = True
        return self.buf


def sample_patch(
    img: np.ndarray | SmoothedFrame, box: Box, out_w: int, out_h: int, out: np.ndarray | None = None
) -> np.ndarray:
    """Resample the image region `box` (may extend past the border) to out_h x out_w pixels.

    One affine warp maps the box onto the output grid with bilinear interpolation and replicated
    borders, so a crop partly outside the image is well defined and sub-pixel positions are kept.
    `out`: optional (out_h, out_w) array of img's dtype written in place (no per-window allocation).
    """
    sx = box.w / out_w
    sy = box.h / out_h
    # output pixel (u, v) centre samples source point (x + (u + 0.5) * sx - 0.5, ...)
    x0 = box.x + 0.5 * sx - 0.5
    y0 = box.y + 0.5 * sy - 0.5
    interp = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
    ih, iw = img.shape[:2]
    # the pixels the warp reads (bilinear: one more on each side), clamped into the frame as the
    # replicated border does
    r0 = min(max(math.floor(y0) - 1, 0), ih - 1)
    r1 = min(max(math.ceil(y0 + out_h * sy) + 1, 0), ih - 1) + 1
    c0 = min(max(math.floor(x0) - 1, 0), iw - 1)
    c1 = min(max(math.ceil(x0 + out_w * sx) + 1, 0), iw - 1) + 1
    strong = sx > 2.0 or sy > 2.0  # strong shrink: pre-filter to limit aliasing
    sigma = 0.5 * max(sx, sy)
    if isinstance(img, SmoothedFrame):
        k = _blur_margin(sigma) + _BLUR_ALIGN if strong else 0  # blur_rect's reach below
        img = img.ensure(r0 - k, r1 + k, c0 - k, c1 + k)
    src = img
    if strong:
        src, s0, d0 = blur_rect(img, sigma, r0, r1, c0, c1)
        y0 -= s0
        x0 -= d0
    M = np.array([[sx, 0.0, x0], [0.0, sy, y0]], dtype=np.float64)
    return cv2.warpAffine(
        src, M, (out_w, out_h), dst=out, flags=interp, borderMode=cv2.BORDER_REPLICATE
    )


def sample_patches(img: np.ndarray, boxes: Sequence[Box], out_w: int, out_h: int) -> np.ndarray:
    """Stack of `sample_patch` results, shape (N, out_h, out_w) float32."""
    out = np.empty((len(boxes), out_h, out_w), dtype=np.float32)
    direct = img.dtype == np.float32 and img.ndim == 2
    for i, b in enumerate(boxes):  # one OpenCV call per window (N <= 9), never per pixel
        if direct:
            sample_patch(img, b, out_w, out_h, out=out[i])  # warped straight into the stack
        else:
            out[i] = sample_patch(img, b, out_w, out_h)
    return out


@lru_cache(maxsize=16)
def cosine_window(rows: int, cols: int) -> np.ndarray:
    """Hann window (outer product of two periodic-free Hann vectors), float32 (rows, cols)."""
    return np.outer(np.hanning(rows), np.hanning(cols)).astype(np.float32)


def feature_shape(kind: str, patch_h: int, patch_w: int, cell: int) -> tuple[int, int, int]:
    """(channels, rows, cols) of the feature map of a patch."""
    if kind in HOG_KINDS:
        return (N_CHANNELS, patch_h // cell, patch_w // cell)
    if kind in INTENSITY_BINS:
        return (N_CHANNELS + 1 + INTENSITY_BINS[kind], patch_h // cell, patch_w // cell)
    return (1, patch_h, patch_w)


def unwindowed_features(patches: np.ndarray, kind: str, cell: int) -> np.ndarray:
    """Feature maps (N, C, rows, cols) of patches (N, H, W) in [0, 1], before the cosine window.

    `hog`: 31-channel FHOG with `cell`-pixel cells, hard orientation bins; `hog_soft`: the same with
    soft orientation bins; `hog_gray`: soft FHOG plus the cell-mean intensity; `hog_ih`: that plus an
    8-bin intensity histogram per cell (core/channels.py); `gray`: the intensity minus 0.5 (KCF raw pixels).
    """
    if kind in HOG_KINDS:
        return fhog(patches, cell, soft=kind == "hog_soft")
    if kind in INTENSITY_BINS:
        extra = intensity_channels(patches, cell, INTENSITY_BINS[kind])
        return np.concatenate([fhog(patches, cell, soft=True), extra], axis=1)
    if kind == "gray":
        return (patches - np.float32(0.5))[:, None, :, :]
    raise ValueError(f"unknown feature kind {kind!r}; expected one of {FEATURE_KINDS}")


def extract_features(patches: np.ndarray, kind: str, cell: int) -> np.ndarray:
    """`unwindowed_features` multiplied by the cosine window (KCF `get_features`; FHOG applies it in its
    normalisation loop, the same float32 products)."""
    if kind in HOG_KINDS:
        win = cosine_window(patches.shape[-2] // cell, patches.shape[-1] // cell)
        return fhog(patches, cell, soft=kind == "hog_soft", window=win)
    feats = unwindowed_features(patches, kind, cell)
    feats *= cosine_window(feats.shape[2], feats.shape[3])
    return feats
