# SPDX-License-Identifier: Apache-2.0
"""The head's maps to a box: point grid, softmax score, ltrb decoding, penalties, cosine window.

SiamBAN (Chen et al., CVPR 2020, Sec. 3.3-3.4) / NanoTrack: on an S x S grid of stride 16 over the 255 px
search crop, the classification branch gives 2 logits per point (background, foreground) and the regression
branch 4 distances (l, t, r, b) from the point to the box's sides. The box of point (p_x, p_y) is
(p_x - l, p_y - t, p_x + r, p_y + b) (SiamBAN eq. 3). The choice among the points follows SiamRPN
(Li et al., CVPR 2018, Sec. 4.3 eq. 13-14) and SiamRPN++ (Li et al., CVPR 2019): a scale-change and
aspect-ratio-change penalty, a cosine window, then the size learning rate lr = penalty * score * size_lr.
All maps are (S, S) arrays, row = y, column = x, in search-crop pixels relative to the crop's centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def point_grid(size: int, stride: int) -> tuple[np.ndarray, np.ndarray]:
    """(px, py): the (S, S) offsets from the crop centre of the grid points, p_k = (k - floor(S/2)) stride
    (the authors' generate_points; centred for odd S, half a stride left/up for even S)."""
    k = (np.arange(size, dtype=np.float32) - (size // 2)) * stride
    px, py = np.meshgrid(k, k)
    return px, py


def cosine_window(size: int) -> np.ndarray:
    """(S, S) outer product of Hanning windows (SiamFC's cosine window)."""
    h = np.hanning(size)
    return np.outer(h, h)


def softmax_score(cls: np.ndarray) -> np.ndarray:
    """Foreground probability (S, S) of the 2 x S x S logits (channel 1 = target), a softmax over the
    channel axis."""
    z = cls.reshape(2, *cls.shape[-2:]).astype(np.float64)
    z = z - z.max(axis=0, keepdims=True)
    e = np.exp(z)
    return e[1] / (e[0] + e[1])


@dataclass(frozen=True)
class Boxes:
    """Per-point boxes (S, S) each, centre offset (cx, cy) and size (w, h) in search-crop pixels."""

    cx: np.ndarray
    cy: np.ndarray
    w: np.ndarray
    h: np.ndarray


def decode_ltrb(loc: np.ndarray, px: np.ndarray, py: np.ndarray) -> Boxes:
    """Boxes of the 4 x S x S side distances (l, t, r, b) at the grid points (SiamBAN eq. 3):
    x1 = p_x - l, y1 = p_y - t, x2 = p_x + r, y2 = p_y + b, then centre and size."""
    l, t, r, b = (c.astype(np.float64) for c in loc.reshape(4, *loc.shape[-2:]))
    x1, y1, x2, y2 = px - l, py - t, px + r, py + b
    return Boxes((x1 + x2) / 2.0, (y1 + y2) / 2.0, x2 - x1, y2 - y1)


def _change(r: np.ndarray | float) -> np.ndarray:
    """max(r, 1/r): a change factor >= 1 whichever way it goes."""
    return np.maximum(r, 1.0 / r)


def _sz(w: np.ndarray | float, h: np.ndarray | float) -> np.ndarray:
    """sqrt((w + p)(h + p)), p = (w + h)/2: the size measure of the penalty (SiamRPN eq. 14)."""
    pad = (np.asarray(w) + h) * 0.5
    return np.sqrt((w + pad) * (h + pad))


def change_penalty(boxes: Boxes, w: float, h: float, k: float) -> np.ndarray:
    """penalty = exp(-(r_c s_c - 1) k) (SiamRPN eq. 13): s_c the change of size measure and r_c the change
    of aspect ratio of each point's box from the previous size (w, h), both in search-crop pixels."""
    with np.errstate(divide="ignore", invalid="ignore"):
        s_c = _change(_sz(boxes.w, boxes.h) / _sz(w, h))
        r_c = _change((w / h) / (boxes.w / boxes.h))
        pen = np.exp(-(r_c * s_c - 1.0) * k)
    return np.nan_to_num(pen, nan=0.0, posinf=0.0, neginf=0.0)


def window_mix(pscore: np.ndarray, window: np.ndarray, influence: float) -> np.ndarray:
    """(1 - influence) * penalised score + influence * cosine window (SiamFC / SiamRPN)."""
    return pscore * (1.0 - influence) + window * influence


def size_update(w: float, h: float, new_w: float, new_h: float, lr: float) -> tuple[float, float]:
    """Size smoothing (1 - lr) old + lr new, lr = penalty * score * size_lr (SiamRPN Sec. 4.3)."""
    return w * (1.0 - lr) + new_w * lr, h * (1.0 - lr) + new_h * lr


def size_update_twice(w: float, h: float, new_w: float, new_h: float, lr: float) -> tuple[float, float]:
    """LightTrack's size update (researchmm/LightTrack lib/tracker/lighttrack.py `update`): the blend
    res = lr new + (1 - lr) old, then old (1 - lr) + lr res, i.e. (1 - lr^2) old + lr^2 new: the regressed
    size enters with weight lr^2."""
    bw, bh = size_update(w, h, new_w, new_h, lr)
    return size_update(w, h, bw, bh, lr)


def regression_gain(searched: tuple[float, float], regressed: tuple[float, float]) -> float:
    """How much of a size mismatch the regression measures (ours, issue 52): the target of known size T
    searched at the wrong sizes a_1 < a_2 (`searched`, sqrt(w h) each) gives boxes of sizes r_1, r_2
    (`regressed`). In log size the regression is log r = s log a + (1 - s) log T + b: s = 1 echoes the
    searched size (the regressed box is the searched box, whatever the target), s = 0 measures the target.
    The gain is g = 1 - s = 1 - log(r_2 / r_1) / log(a_2 / a_1), kept in [0, 1]."""
    (a1, a2), (r1, r2) = searched, regressed
    if not (0.0 < a1 < a2 and r1 > 0.0 and r2 > 0.0):
        raise ValueError(f"sizes must be positive with searched[0] < searched[1], got {searched}, "
                         f"{regressed}")
    slope = math.log(r2 / r1) / math.log(a2 / a1)
    return min(1.0, max(0.0, 1.0 - slope))


def gain_factor(gain: float, ref: float, power: float) -> float:
    """The size learning rate's factor of a regression of gain g (issue 52): min(1, g / ref)^power; 1 for
    power 0 (the authors' rate)."""
    return 1.0 if power == 0.0 else min(1.0, gain / ref) ** power


def clip_state(cx: float, cy: float, w: float, h: float, width: int, height: int,
               min_size: float) -> tuple[float, float, float, float]:
    """Centre kept in the image, each side in [min_size, image side] (the authors' _bbox_clip)."""
    return (min(max(cx, 0.0), float(width)), min(max(cy, 0.0), float(height)),
            max(min_size, min(w, float(width))), max(min_size, min(h, float(height))))
