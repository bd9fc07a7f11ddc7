# SPDX-License-Identifier: Apache-2.0
"""Exemplar and search crops of SiamFC (Bertinetto et al., ECCV-W 2016, Sec. 2.4), as NanoTrack cuts them.

A target of size (w, h) gets the context margin p = c (w + h) (c = context amount, 0.5), and the square
crop side s_z = sqrt((w + p)(h + p)) (SiamFC: s(w + 2p) x s(h + 2p) = A with 2p = (w + h) / 2). The
exemplar is s_z resampled to 127 px; the search region is s_x = s_z * 255 / 127 resampled to 255 px, so
that both share one scale, scale_z = 127 / s_z. Pixels outside the frame are the frame's mean colour.

Box convention: (x, y, w, h) with pixel i covering [i, i + 1), so the centre is (x + w/2, y + h/2). Two
placements: `cut_subpixel` (the default) centres the crop exactly on the float centre at the exact scale;
`crop_window` + `cut` place it as the authors' `get_subwindow` does (whole pixels, side rounded, from the
centre in pixel-index coordinates cx - 1/2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np


def context_side(w: float, h: float, context_amount: float) -> float:
    """s_z = sqrt((w + p)(h + p)) with p = context_amount (w + h) (SiamFC Sec. 2.4)."""
    p = context_amount * (w + h)
    return math.sqrt((w + p) * (h + p))


@dataclass(frozen=True)
class CropWindow:
    """A square window of `side` whole pixels with top-left pixel (x0, y0), resampled to `out` px."""

    x0: int
    y0: int
    side: int
    out: int

    @property
    def scale(self) -> float:
        """Crop pixels per image pixel (SiamFC's s)."""
        return self.out / self.side

    @property
    def center(self) -> tuple[float, float]:
        """Centre of the window in image coordinates (pixel i covers [i, i + 1))."""
        return (self.x0 + self.side / 2.0, self.y0 + self.side / 2.0)


def crop_window(cx: float, cy: float, side: float, out: int) -> CropWindow:
    """The window the authors' `get_subwindow` cuts around the centre (cx, cy): side round(side) (Python
    rounding, at least 1), top-left floor(pos - (side + 1)/2 + 1/2) with pos = cx - 1/2 the pixel-index
    centre. Its centre lies 0.5 to 1.5 px left of and above (cx, cy) (`cut_subpixel` has no such offset)."""
    sz = max(1, round(side))
    c = (sz + 1) / 2.0
    x0 = math.floor((cx - 0.5) - c + 0.5)
    y0 = math.floor((cy - 0.5) - c + 0.5)
    return CropWindow(int(x0), int(y0), int(sz), int(out))


def round_half_away(x: float) -> int:
    """Python 2's round, half away from zero (LightTrack's `python2round`, which cuts its search crops)."""
    return int(math.copysign(math.floor(abs(x) + 0.5), x))


def lighttrack_window(cx: float, cy: float, side: int, out: int) -> CropWindow:
    """The window LightTrack's `get_subwindow_tracking` cuts (Yan et al., CVPR 2021, researchmm/LightTrack
    lib/utils/utils.py): `side` whole pixels, top-left round(pos - (side + 1)/2) with pos = (cx, cy) itself
    (Python 3 rounding); its centre lies about half a pixel left of and above (cx, cy)."""
    c = (side + 1) / 2.0
    return CropWindow(round(cx - c), round(cy - c), int(side), int(out))


def cut(image: np.ndarray, win: CropWindow, fill: np.ndarray | float) -> np.ndarray:
    """The window's pixels of `image` (HxW or HxWxC, uint8), `fill` outside the frame (truncated to the
    image type, as the authors' uint8 padding), resampled to out x out (bilinear, cv2.resize)."""
    h, w = image.shape[:2]
    shape = (win.side, win.side, *image.shape[2:])
    x1, y1 = win.x0 + win.side, win.y0 + win.side
    ix0, iy0, ix1, iy1 = max(win.x0, 0), max(win.y0, 0), min(x1, w), min(y1, h)
    if ix0 == win.x0 and iy0 == win.y0 and ix1 == x1 and iy1 == y1:
        patch = image[iy0:iy1, ix0:ix1]
    else:
        patch = np.empty(shape, dtype=image.dtype)
        patch[...] = np.asarray(fill, dtype=np.float64).astype(image.dtype)
        if ix1 > ix0 and iy1 > iy0:
            patch[iy0 - win.y0:iy1 - win.y0, ix0 - win.x0:ix1 - win.x0] = image[iy0:iy1, ix0:ix1]
    if win.side != win.out:
        patch = cv2.resize(patch, (win.out, win.out), interpolation=cv2.INTER_LINEAR)
    return patch


def blob(patch: np.ndarray) -> np.ndarray:
    """1x3xSxS float32 network input of a crop: a one-channel crop replicated to the three channels the
    network was trained on (BGR, 0-255, no normalisation, as the authors feed it)."""
    if patch.ndim == 2:
        patch = patch[:, :, None]
    chw = np.ascontiguousarray(np.transpose(patch, (2, 0, 1)), dtype=np.float32)
    if chw.shape[0] == 1:
        chw = np.repeat(chw, 3, axis=0)
    return chw[None]


def cut_subpixel(image: np.ndarray, cx: float, cy: float, side: float, out: int,
                 fill: np.ndarray | float) -> np.ndarray:
    """The square of side `side` (image pixels, not rounded) centred exactly on (cx, cy), resampled to
    out x out by one bilinear affine warp; `fill` outside the frame. Output pixel u (centre u + 1/2)
    samples the image at x = cx - side/2 + (u + 1/2) side/out, i.e. pixel index x - 1/2."""
    s = side / out
    tx, ty = cx - side / 2.0 + 0.5 * s - 0.5, cy - side / 2.0 + 0.5 * s - 0.5
    m = np.array([[s, 0.0, tx], [0.0, s, ty]], dtype=np.float64)
    value = np.broadcast_to(np.asarray(fill, dtype=np.float64), (image.shape[2] if image.ndim == 3 else 1,))
    border = tuple(float(v) for v in value) + (0.0,) * (4 - len(value))
    return cv2.warpAffine(image, m, (out, out), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                          borderMode=cv2.BORDER_CONSTANT, borderValue=border)
