# SPDX-License-Identifier: Apache-2.0
"""SWIR frame conditioning: 8/16-bit to float, robust stretch, dead pixels, de-interlacing, downscale."""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from swir_tracker_ros.core.kernels import corr_jit
from swir_tracker_ros.errors import ParameterError, TrackerError
from swir_tracker_ros.paramfield import param


class ConditioningError(TrackerError):
    """A frame cannot be turned into a float image (wrong shape, dtype, non-finite values)."""


@dataclass(frozen=True)
class ConditioningConfig:
    """How raw frames become the float32 [0, 1] gray image the filters see (the `conditioning` parameters of
    the tracker)."""

    stretch: str = param(
        "auto",
        "intensity stretch: auto (16-bit and float by percentiles, 8-bit divided by 255), always (8-bit "
        "too), off (divided by the full scale of the bit depth)",
        choices=("auto", "always", "off"),
    )
    low_percentile: float = param(0.5, "black level percentile of the stretch", 0.0, 49.0)
    high_percentile: float = param(99.5, "white level percentile of the stretch", 51.0, 100.0)
    stretch_smoothing: float = param(0.8, "(ours) EMA weight of the previous stretch limits", 0.0, 0.99)
    dead_pixel_threshold: float = param(
        0.0, "replace pixels further than this (0..1) from their 3x3 median; 0: off", 0.0, 1.0
    )
    deinterlace: str = param(
        "off", "use one field of interlaced frames, line-doubled", choices=("off", "even", "odd")
    )
    downscale: float = param(
        1.0, "resize frames by this factor before tracking (boxes stay in input pixels)", 0.1, 1.0
    )

    def check(self) -> None:
        """Cross-field rules (run by `validate_params` after the fields)."""
        if self.low_percentile >= self.high_percentile:
            raise ParameterError("parameter low_percentile must be below high_percentile")


def presmooth(img: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur of a conditioned frame (sigma in pixels, replicated borders); sigma <= 0: the frame."""
    if sigma <= 0.0:
        return img
    return cv2.GaussianBlur(img, (0, 0), sigma, borderType=cv2.BORDER_REPLICATE)


def to_gray(frame: np.ndarray) -> np.ndarray:
    """2-D view of a frame: HxW as is, HxWx1 squeezed, HxWx3 BGR / HxWx4 BGRA converted to luma."""
    if not isinstance(frame, np.ndarray):
        raise ConditioningError(f"frame must be a numpy array, got {type(frame).__name__}")
    if frame.ndim == 3 and frame.shape[2] == 1:
        frame = frame[:, :, 0]
    if frame.ndim == 3 and frame.shape[2] in (3, 4):
        if frame.dtype not in (np.uint8, np.uint16, np.float32):
            frame = frame.astype(np.float32)
        code = cv2.COLOR_BGR2GRAY if frame.shape[2] == 3 else cv2.COLOR_BGRA2GRAY
        return cv2.cvtColor(np.ascontiguousarray(frame), code)
    if frame.ndim != 2:
        raise ConditioningError(f"frame must be HxW, HxWx1, HxWx3 or HxWx4, got shape {frame.shape}")
    return frame


def percentile_limits(
    gray: np.ndarray, low: float, high: float, max_samples: int = 10000
) -> tuple[float, float]:
    """Robust black/white levels from a regular subsample of the image (no allocation of the full sort)."""
    step = max(1, int(np.sqrt(gray.size / max_samples)))
    in_range = 0.0 <= low <= 100.0 and 0.0 <= high <= 100.0
    cj = corr_jit() if in_range and gray.dtype in (np.uint8, np.uint16) else None
    n = ((gray.shape[0] + step - 1) // step) * ((gray.shape[1] + step - 1) // step)
    if cj is not None and n:
        # counted order statistics of the integer subsample (no copies, no partition) and numpy's linear
        # interpolation between them, in Python floats (the same float64 operations)
        ranks, weights = [], []
        for q in (low, high):
            virtual = q / 100.0 * (n - 1)  # as np.percentile: q / 100 * (n - 1) in float64
            below = math.floor(virtual)
            ranks += [below, min(below + 1, n - 1)]
            weights.append(virtual - below)
        values = np.empty(4, dtype=np.int64)
        cj.order_statistics_kernel(gray, step, np.array(ranks, dtype=np.intp), values)
        v = values.tolist()
        return _lerp(v[0], v[1], weights[0]), _lerp(v[2], v[3], weights[1])
    sample = gray[::step, ::step].ravel().astype(np.float32, copy=False)
    return _percentiles(sample, low, high)


def _lerp(a: int, b: int, g: float) -> float:
    """numpy's percentile interpolation (`_lerp`) between the integer order statistics a <= b: b - a is
    exact in the float32 sample's dtype (|b - a| < 2^24), the rest is float64 as in numpy."""
    d = float(b - a)
    return b - d * (1.0 - g) if g >= 0.5 else a + d * g


def _percentiles(sample: np.ndarray, low: float, high: float) -> tuple[float, float]:
    """`np.percentile(sample, [low, high])` (method "linear"), the same numbers at less than half its
    per-call cost: one partition at the two bracketing order statistics of each quantile, then numpy's own
    interpolation (`_lerp`: a + (b - a) g, or b - (b - a)(1 - g) from g = 0.5 on, in the sample's dtype for
    b - a and float64 for the rest); test/test_core_conditioning.py compares it with np.percentile."""
    n = sample.size
    if n == 0:
        lo, hi = np.percentile(sample, [low, high])  # numpy's own error / warning
        return float(lo), float(hi)
    virtual = np.array([low, high], dtype=np.float64) / 100.0 * (n - 1)
    below = np.floor(virtual).astype(np.intp)
    above = np.minimum(below + 1, n - 1)
    part = np.partition(sample, np.unique(np.concatenate([below, above])))
    a, b = part[below], part[above]
    g = virtual - below
    d = b - a
    out = np.where(g >= 0.5, b - d * (1 - g), a + d * g)
    return float(out[0]), float(out[1])


def suppress_dead_pixels(img: np.ndarray, threshold: float) -> np.ndarray:
    """Replace isolated outliers (salt, stuck pixels) by the 3x3 median where |x - med| > threshold."""
    med = cv2.medianBlur(img, 3)
    return np.where(np.abs(img - med) > threshold, med, img)


def single_field(img: np.ndarray, field: str) -> np.ndarray:
    """Keep one field of an interlaced frame and line-double it back to full height (same coordinates)."""
    start = 0 if field == "even" else 1
    half = img[start::2]
    out = cv2.resize(half, (img.shape[1], half.shape[0] * 2), interpolation=cv2.INTER_LINEAR)
    if out.shape[0] < img.shape[0]:
        out = np.vstack([out, out[-1:]])
    return out[: img.shape[0]]


class FrameConditioner:
    """Stateful (EMA of stretch limits) but deterministic frame conditioning; `reset()` clears the state."""

    def __init__(self, config: ConditioningConfig) -> None:
        self.config = config
        self._limits: tuple[float, float] | None = None

    def reset(self) -> None:
        self._limits = None

    def __call__(self, frame: np.ndarray, bit_depth: int | None = None) -> np.ndarray:
        """Float32 image in [0, 1], downscaled by `config.downscale`; ConditioningError if unusable."""
        cfg = self.config
        gray = to_gray(frame)
        if gray.shape[0] < 8 or gray.shape[1] < 8:
            raise ConditioningError(
                f"frame of {gray.shape[1]}x{gray.shape[0]} pixels is too small to track in"
            )
        dtype = gray.dtype
        if dtype == np.bool_ or not (np.issubdtype(dtype, np.integer) or np.issubdtype(dtype, np.floating)):
            raise ConditioningError(f"frame dtype {dtype} is not an integer or float image type")
        fused, cj = False, None
        if np.issubdtype(dtype, np.floating):
            img = gray.astype(np.float32, copy=False)
            owned = img is not gray and not np.shares_memory(img, frame)
            if not np.isfinite(img).all():
                raise ConditioningError("frame contains NaN or infinite pixels")
            full_scale = 1.0 if float(img.max(initial=0.0)) <= 1.0 else None
        else:
            cj = corr_jit()
            fused = cj is not None and gray.dtype.itemsize <= 2  # 8/16-bit: exact in float32
            # a fresh array: the steps below work in place (the fused stretch fills it in one pass)
            img = np.empty(gray.shape, dtype=np.float32) if fused else gray.astype(np.float32)
            owned = True
            bits = bit_depth if bit_depth else (8 if dtype.itemsize == 1 else 8 * dtype.itemsize)
            full_scale = float(2 ** min(int(bits), 32) - 1)
        stretch = cfg.stretch == "always" or (cfg.stretch == "auto" and dtype != np.uint8)
        if stretch or full_scale is None:
            # the integer frame's own subsample gives the float copy's values (the conversion is exact)
            lo, hi = percentile_limits(gray if fused else img, cfg.low_percentile, cfg.high_percentile)
            if self._limits is not None and cfg.stretch_smoothing > 0:
                a = cfg.stretch_smoothing
                lo = a * self._limits[0] + (1 - a) * lo
                hi = a * self._limits[1] + (1 - a) * hi
            self._limits = (lo, hi)
            span = max(hi - lo, 1e-6 * max(abs(hi), 1.0), 1e-12)
            if fused:  # convert, subtract, scale and clip in one compiled pass (the same float32 steps)
                scale = np.float32(1.0 / span)
                cj.stretch_kernel(np.ascontiguousarray(gray), np.float32(lo), scale, img)
            else:
                img = np.subtract(img, np.float32(lo), out=img if owned else None)
                img *= np.float32(1.0 / span)
                np.clip(img, 0.0, 1.0, out=img)
        elif fused:
            img[...] = gray
            if full_scale != 1.0:
                img *= np.float32(1.0 / full_scale)
        elif full_scale != 1.0:
            img = np.multiply(img, np.float32(1.0 / full_scale), out=img if owned else None)
        if cfg.deinterlace in ("even", "odd"):
            img = single_field(img, cfg.deinterlace)
        if cfg.dead_pixel_threshold > 0:
            img = suppress_dead_pixels(img, cfg.dead_pixel_threshold)
        if cfg.downscale != 1.0:
            h = max(8, round(img.shape[0] * cfg.downscale))
            w = max(8, round(img.shape[1] * cfg.downscale))
            img = cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA)
        return np.ascontiguousarray(img, dtype=np.float32)
