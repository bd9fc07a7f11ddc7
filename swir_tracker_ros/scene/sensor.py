# SPDX-License-Identifier: Apache-2.0
"""SWIR sensor effects: vignetting, contrast, temporal and fixed-pattern noise, dead pixels, quantisation."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class SensorModel:
    """Turns scene radiance in [0, 1] into raw counts. Defaults model a clean 12-bit SWIR camera."""

    bits: int = field(default=12, metadata={"doc": "output bit depth (8 -> uint8, else uint16)",
                                            "choices": (8, 10, 12, 14, 16)})
    noise: float = field(default=0.008, metadata={"doc": "temporal noise std, fraction of full scale",
                                                  "min": 0.0, "max": 0.5})
    fpn: float = field(default=0.004, metadata={"doc": "fixed-pattern noise std (pixel offsets and column "
                                                       "stripes), fraction of full scale",
                                                "min": 0.0, "max": 0.5})
    dead_pixels: float = field(default=0.0, metadata={"doc": "fraction of stuck pixels (half dark, half hot)",
                                                      "min": 0.0, "max": 0.05})
    contrast: float = field(default=1.0, metadata={"doc": "gain around mid-grey; < 1 washes the scene out",
                                                   "min": 0.01, "max": 4.0})
    offset: float = field(default=0.0, metadata={"doc": "added to the radiance after the gain",
                                                 "min": -1.0, "max": 1.0})
    vignetting: float = field(default=0.15, metadata={"doc": "relative fall-off at the image corners",
                                                      "min": 0.0, "max": 0.9})
    interlaced: bool = field(default=False, metadata={"doc": "odd rows are exposed half a frame later"})
    shake_px: float = field(default=0.0, metadata={"doc": "camera shake amplitude in pixels (random walk "
                                                          "plus vibration)", "min": 0.0, "max": 50.0})
    fps: float = field(default=25.0, metadata={"doc": "frame rate (interlace field delay = 0.5/fps)",
                                               "min": 1.0, "max": 1000.0})

    @property
    def max_value(self) -> int:
        return (1 << self.bits) - 1

    @property
    def dtype(self) -> type:
        return np.uint8 if self.bits <= 8 else np.uint16


@dataclass(frozen=True)
class SensorPattern:
    """The time-invariant part of the sensor for one image size: vignetting gain, FPN, dead pixels."""

    gain: np.ndarray  # float32 (H, W): vignetting
    fpn: np.ndarray  # float32 (H, W): additive fixed pattern
    dead_idx: np.ndarray  # flat indices of stuck pixels
    dead_val: np.ndarray  # float32 stuck value (0 or 1)
    noise_bank: np.ndarray  # float32 (K, H + M, W + M) unit normal noise; each frame adds a random crop


_NOISE_MARGIN = 61  # odd, so crops at different offsets do not line up with the column pattern


def make_pattern(model: SensorModel, width: int, height: int, seed: int) -> SensorPattern:
    rng = np.random.default_rng([seed, 7101, width, height])
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float32)
    r2 = ((xx + 0.5 - width / 2) ** 2 + (yy + 0.5 - height / 2) ** 2) / ((width / 2) ** 2 + (height / 2) ** 2)
    gain = (1.0 - model.vignetting * r2).astype(np.float32)
    fpn = (model.fpn * (0.6 * rng.standard_normal((height, width))
                        + 0.8 * rng.standard_normal((1, width)))).astype(np.float32)
    n_dead = round(model.dead_pixels * width * height)
    dead_idx = rng.choice(width * height, size=n_dead, replace=False) if n_dead else np.zeros(0, np.int64)
    dead_val = (rng.random(n_dead) < 0.5).astype(np.float32)
    bank = rng.standard_normal((3, height + _NOISE_MARGIN, width + _NOISE_MARGIN), dtype=np.float32)
    return SensorPattern(gain, fpn, dead_idx, dead_val, bank)


def apply_sensor(radiance: np.ndarray, model: SensorModel, pattern: SensorPattern,
                 rng: np.random.Generator) -> np.ndarray:
    """Radiance (float32 HxW) -> raw frame (uint8/uint16 at `model.bits`); modifies `radiance` in place."""
    img = radiance
    img *= pattern.gain
    if model.contrast != 1.0 or model.offset != 0.0:
        img -= 0.5
        img *= model.contrast
        img += 0.5 + model.offset
    img += pattern.fpn
    if model.noise > 0:
        k, dy, dx = (int(v) for v in rng.integers(0, (pattern.noise_bank.shape[0], _NOISE_MARGIN + 1,
                                                       _NOISE_MARGIN + 1)))
        h, w = img.shape
        sign = 1.0 if rng.random() < 0.5 else -1.0
        img += (sign * model.noise) * pattern.noise_bank[k, dy:dy + h, dx:dx + w]
    if pattern.dead_idx.size:
        img.reshape(-1)[pattern.dead_idx] = pattern.dead_val
    np.clip(img, 0.0, 1.0, out=img)
    img *= model.max_value
    img += 0.5
    return img.astype(model.dtype)


def shake_offset(t: float, amplitude_px: float, seed: int) -> tuple[float, float]:
    """Deterministic camera shake (pixels): a sum of incommensurate sines, bounded by about `amplitude_px`."""
    if amplitude_px <= 0:
        return 0.0, 0.0
    rng = np.random.default_rng([seed, 7102])
    f = rng.uniform(0.7, 9.0, size=(2, 4))
    ph = rng.uniform(0, 2 * np.pi, size=(2, 4))
    w = np.array([0.45, 0.3, 0.15, 0.1])
    dx = float(np.sum(w * np.sin(2 * np.pi * f[0] * t + ph[0])))
    dy = float(np.sum(w * np.sin(2 * np.pi * f[1] * t + ph[1])))
    return amplitude_px * dx, amplitude_px * dy
