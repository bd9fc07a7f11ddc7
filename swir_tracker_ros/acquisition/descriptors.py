# SPDX-License-Identifier: Apache-2.0
"""Engineered appearance: base score (paper 004 eq. 1) and edge-orientation uniform LBP (eq. 8-10)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from swir_tracker_ros.acquisition.lbp import N_BINS, lbp_codes, uniform_histogram, uniform_lbp_histogram
from swir_tracker_ros.errors import AcquisitionError
from swir_tracker_ros.types import Box

ORIENTATION_BINS = 9  # unsigned orientation, 20 degrees per bin (paper 004 Section 3.2.2)


@dataclass(frozen=True)
class Appearance:
    """Per-box features; embeddings are None when the Siamese nets are off or the box is too small."""

    lbp: np.ndarray  # 59-bin uniform LBP of the gray-level crop (hL)
    mean: float  # mean intensity, 8-bit scale (mu_s)
    std: float  # standard deviation of intensity (sigma_s)
    edge: np.ndarray  # 59-bin edge-orientation uniform LBP (theta_LBP, eq. 9)
    embedding: np.ndarray | None = None  # whole-box Siamese embedding phi(x) (eq. 3)
    parts: np.ndarray | None = None  # (4, d) quadrant embeddings phi_p(x_p), TL, TR, BL, BR (eq. 5)


@dataclass(frozen=True)
class BaseWeights:
    """Weights of the base appearance cost, eq. (1); each term is normalised to about [0, 1] first."""

    lbp: float = 20.0
    mean: float = 20.0
    std: float = 10.0
    height: float = 10.0
    width: float = 10.0
    score: float = 5.0
    overlap: float = 20.0


def to_gray8(frame: np.ndarray, bit_depth: int | None = None) -> np.ndarray:
    """2-D uint8 view of a frame: BGR is converted to luma, 16-bit scaled by its bit depth, float clipped."""
    img = np.asarray(frame)
    if img.ndim == 3 and img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.dtype == np.uint8 else img.mean(axis=2)
    if img.ndim != 2 or img.size == 0:
        raise AcquisitionError(f"expected a 2-D or HxWx3 frame, got shape {img.shape}")
    if img.dtype == np.uint8:
        return img
    if img.dtype == np.uint16:
        depth = bit_depth or 16
        return np.clip(img.astype(np.float32) * (255.0 / (2**depth - 1)), 0, 255).astype(np.uint8)
    return np.clip(np.nan_to_num(img.astype(np.float32)), 0, 255).astype(np.uint8)


def crop(gray: np.ndarray, box: Box) -> np.ndarray | None:
    """Pixels of box clipped to the image, or None when less than 2x2 pixels remain."""
    h, w = gray.shape[:2]
    x0, y0 = max(0, round(box.x)), max(0, round(box.y))
    x1, y1 = min(w, round(box.x + box.w)), min(h, round(box.y + box.h))
    if x1 - x0 < 2 or y1 - y0 < 2:
        return None
    return gray[y0:y1, x0:x1]


def dominant_orientation_cells(image: np.ndarray, cell: int = 10) -> np.ndarray:
    """Per-cell dominant orientation bin (0..8), paper 004 eq. (8) and the cell voting of Section 3.2.2.

    Centred differences give I_X, I_Y; theta = arctan(I_X / I_Y) taken modulo pi (unsigned), 9 bins of 20
    degrees; each pixel votes with |G| into its cell's histogram and the argmax bin is kept. A flat cell
    (no gradient) gets bin 0. Returns an (H // cell, W // cell) integer array.
    """
    g = np.asarray(image, dtype=np.float32)
    ix = cv2.filter2D(g, -1, np.array([[-1.0, 0.0, 1.0]], np.float32), borderType=cv2.BORDER_REPLICATE)
    iy = cv2.filter2D(g, -1, np.array([[-1.0], [0.0], [1.0]], np.float32), borderType=cv2.BORDER_REPLICATE)
    mag, ang = cv2.cartToPolar(iy, ix)  # ang = atan2(I_X, I_Y) in [0, 2 pi): arctan(I_X / I_Y) of eq. (8)
    theta = np.mod(ang, np.pi)  # unsigned orientation
    bins = np.minimum((theta * (ORIENTATION_BINS / np.pi)).astype(np.int64), ORIENTATION_BINS - 1)
    ch, cw = g.shape[0] // cell, g.shape[1] // cell
    if ch == 0 or cw == 0:
        raise AcquisitionError(f"image {g.shape} is smaller than one {cell}x{cell} cell")
    cy = np.arange(ch * cell) // cell
    cx = np.arange(cw * cell) // cell
    cell_id = (cy[:, None] * cw + cx[None, :]) * ORIENTATION_BINS + bins[: ch * cell, : cw * cell]
    votes = np.bincount(
        cell_id.ravel(), weights=mag[: ch * cell, : cw * cell].ravel(), minlength=ch * cw * ORIENTATION_BINS
    ).reshape(ch, cw, ORIENTATION_BINS)
    return votes.argmax(axis=2)


def edge_lbp_histogram(patch: np.ndarray, size: tuple[int, int] = (100, 200), cell: int = 10) -> np.ndarray:
    """Edge descriptor theta_LBP (eq. 8-9): resize to size (w, h), dominant orientation per cell, LBP with the
    paper's step function on the cell grid, L1-normalised 59-bin uniform histogram."""
    resized = cv2.resize(np.asarray(patch, dtype=np.float32), size, interpolation=cv2.INTER_LINEAR)
    cells = dominant_orientation_cells(resized, cell)
    return uniform_histogram(lbp_codes(cells, paper_sign=True))


def rms_distance(a: np.ndarray, b: np.ndarray) -> float:
    """tau = sqrt(1/59 * sum_k (a_k - b_k)^2), paper 004 eq. (10)."""
    d = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
    return float(np.sqrt(np.mean(d * d)))


LBP_SIZE = (48, 96)  # (w, h) the gray-level crop is resized to before its uniform LBP (project choice)


def describe(gray: np.ndarray, box: Box, *, edge_size: tuple[int, int] = (100, 200),
             cell: int = 10) -> Appearance:
    """Engineered features of one box in a uint8 gray frame (AcquisitionError when the box is off the image).

    The gray-level LBP runs on the crop resized to LBP_SIZE so that its cost and its histogram do not
    depend on the pedestrian's apparent size; the edge descriptor on edge_size (100 x 200: 10 x 20 cells).
    """
    patch = crop(gray, box)
    if patch is None:
        raise AcquisitionError(f"box {box.as_tuple()} has no pixels inside the {gray.shape} image")
    return Appearance(
        lbp=uniform_lbp_histogram(cv2.resize(patch, LBP_SIZE, interpolation=cv2.INTER_AREA)),
        mean=float(patch.mean()),
        std=float(patch.std()),
        edge=edge_lbp_histogram(patch, edge_size, cell),
    )


def base_appearance_cost(
    a_i: Appearance, box_i: Box, a_j: Appearance, box_j: Box, score_j: float, w: BaseWeights
) -> float:
    """theta(i, j) of paper 004 eq. (1): weighted LBP, mean, variance, height, width, class and overlap terms.

    Normalisation (project choice): hL = half the L1 distance of the histograms (in [0, 1]),
    mu_s = |dmean|/255, sigma_s = |dstd|/128, hs and ws relative to the larger size,
    cs = 1 - detection score, os = 1 - IoU.
    """
    h_l = 0.5 * float(np.abs(a_i.lbp - a_j.lbp).sum())
    mu_s = abs(a_i.mean - a_j.mean) / 255.0
    sigma_s = min(1.0, abs(a_i.std - a_j.std) / 128.0)
    hs = abs(box_i.h - box_j.h) / max(box_i.h, box_j.h, 1e-9)
    ws = abs(box_i.w - box_j.w) / max(box_i.w, box_j.w, 1e-9)
    cs = 1.0 - min(1.0, max(0.0, score_j))
    os_ = 1.0 - box_i.iou(box_j)
    return (
        w.lbp * h_l + w.mean * mu_s + w.std * sigma_s + w.height * hs + w.width * ws + w.score * cs
        + w.overlap * os_
    )


def siamese_distance(a_i: Appearance, a_j: Appearance, w1: float = 100.0, w2: float = 25.0) -> float | None:
    """gamma = w1 * alpha + w2 * beta (eq. 7): alpha = ||phi(x) - phi(y)|| (eq. 3), beta = sum over the four
    quadrants of ||phi_p(x_p) - phi_p(y_p)|| (eq. 5-6). None when either side has no embeddings."""
    if a_i.embedding is None or a_j.embedding is None or a_i.parts is None or a_j.parts is None:
        return None
    alpha = float(np.linalg.norm(a_i.embedding - a_j.embedding))
    beta = float(np.linalg.norm(a_i.parts - a_j.parts, axis=1).sum())
    return w1 * alpha + w2 * beta


def edge_bound() -> float:
    """Upper bound of tau for L1-normalised histograms, sqrt(2 / 59)."""
    return math.sqrt(2.0 / N_BINS)
