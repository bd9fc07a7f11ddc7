# SPDX-License-Identifier: Apache-2.0
"""Uniform local binary patterns (P = 8, R = 1, 59 bins), paper 004 eq. (9)."""

from __future__ import annotations

import cv2
import numpy as np

N_BINS = 59  # 58 uniform 8-bit codes + 1 catch-all bin (paper 004 Section 3.2.2)

# Neighbour offsets (dy, dx), clockwise from the top-left; bit p of the code belongs to offset p.
_OFFSETS = ((-1, -1), (-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1))


def _transitions(code: int) -> int:
    bits = [(code >> p) & 1 for p in range(8)]
    return sum(bits[p] != bits[(p + 1) % 8] for p in range(8))


def uniform_lut() -> np.ndarray:
    """256-entry table: uniform codes (<= 2 circular transitions) to 0..57 in code order, others to 58."""
    lut = np.full(256, N_BINS - 1, dtype=np.int64)
    nxt = 0
    for code in range(256):
        if _transitions(code) <= 2:
            lut[code] = nxt
            nxt += 1
    return lut


_LUT = uniform_lut()


def lbp_codes(image: np.ndarray, *, paper_sign: bool = False) -> np.ndarray:
    """8-neighbour LBP codes of a 2-D array (eq. 9), edge-replicated borders, same shape as the input.

    With ``paper_sign`` the step function is the one printed in paper 004, s(x) = 1 for x <= 0 (a bit is set
    when the neighbour is not greater than the centre); otherwise the usual Ojala s(x) = 1 for x >= 0.
    """
    g = np.asarray(image)
    if g.ndim != 2 or g.size == 0:
        raise ValueError(f"LBP needs a non-empty 2-D array, got shape {g.shape}")
    if g.dtype not in (np.uint8, np.float32):
        g = g.astype(np.float32)
    pad = cv2.copyMakeBorder(g, 1, 1, 1, 1, cv2.BORDER_REPLICATE)
    h, w = g.shape
    codes = np.zeros((h, w), dtype=np.uint8)
    for p, (dy, dx) in enumerate(_OFFSETS):
        gp = pad[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w]
        bit = (gp <= g) if paper_sign else (gp >= g)
        codes |= bit.view(np.uint8) << np.uint8(p)
    return codes


def uniform_histogram(codes: np.ndarray) -> np.ndarray:
    """L1-normalised 59-bin uniform-pattern histogram of LBP codes (all zeros for an empty input)."""
    hist = np.bincount(_LUT[np.asarray(codes).ravel()], minlength=N_BINS).astype(np.float64)
    total = hist.sum()
    return hist / total if total > 0 else hist


def uniform_lbp_histogram(image: np.ndarray, *, paper_sign: bool = False) -> np.ndarray:
    """Uniform-LBP histogram of a gray-level image (the hL term of paper 004 eq. 1)."""
    return uniform_histogram(lbp_codes(image, paper_sign=paper_sign))
