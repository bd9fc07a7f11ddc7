# SPDX-License-Identifier: Apache-2.0
"""Procedural textures: the background panorama and the object sprites (radiance in [0, 1], float32)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from swir_tracker_ros.errors import SceneError


def fractal_noise(rng: np.random.Generator, height: int, width: int, octaves: int = 5,
                  base_cells: int = 4, persistence: float = 0.55) -> np.ndarray:
    """Sum of bilinearly upsampled random grids (value noise), zero mean, unit-ish std, float32."""
    out = np.zeros((height, width), np.float32)
    amp, total = 1.0, 0.0
    for o in range(octaves):
        cells = base_cells * (2 ** o)
        gh = max(2, round(cells * height / max(width, height)) + 1)
        gw = max(2, round(cells * width / max(width, height)) + 1)
        grid = rng.standard_normal((gh, gw)).astype(np.float32)
        out += amp * cv2.resize(grid, (width, height), interpolation=cv2.INTER_CUBIC)
        total += amp
        amp *= persistence
    return out / total


@dataclass(frozen=True)
class Panorama:
    """Background radiance on an azimuth/elevation grid: column 0 is `az_max` (left), row 0 `el_max` (up)."""

    image: np.ndarray  # float32 (rows, cols) radiance in [0, 1]
    az_max: float  # radians, left edge
    el_max: float  # radians, top edge
    res: float  # radians per panorama pixel (both axes)

    @property
    def az_min(self) -> float:
        return self.az_max - self.image.shape[1] * self.res

    @property
    def el_min(self) -> float:
        return self.el_max - self.image.shape[0] * self.res


def make_panorama(seed: int, az_span_deg: float = 50.0, el_min_deg: float = -9.0, el_max_deg: float = 5.0,
                  res_deg: float = 0.014, brightness: float = 0.42, contrast: float = 1.0,
                  horizon_deg: float = 0.0) -> Panorama:
    """A SWIR-looking landscape: bright hazy sky, a treeline and buildings on the horizon, textured ground.

    `contrast` scales every deviation from `brightness` (0.3 gives a washed-out low-contrast scene).
    """
    rng = np.random.default_rng([seed, 7001])
    res = math.radians(res_deg)
    cols = round(az_span_deg / res_deg)
    rows = round((el_max_deg - el_min_deg) / res_deg)
    el = math.radians(el_max_deg) - (np.arange(rows) + 0.5) * res  # row elevations
    horizon_row = round((el_max_deg - horizon_deg) / res_deg)

    img = np.empty((rows, cols), np.float32)
    sky_grad = np.clip(0.72 - 4.0 * np.maximum(el - math.radians(horizon_deg), 0.0), 0.45, 0.8)
    img[:] = sky_grad[:, None].astype(np.float32)
    img += 0.03 * fractal_noise(rng, rows, cols, octaves=4, base_cells=6)  # haze / clouds
    # Horizon skyline: treeline (noisy) and blocky buildings, darker than the sky.
    skyline = horizon_row - (18 + 14 * fractal_noise(rng, 1, cols, octaves=5, base_cells=30)[0]).astype(int)
    x = 0
    while x < cols:
        bw = int(rng.integers(40, 220))
        if rng.random() < 0.35:
            skyline[x:x + bw] = horizon_row - int(rng.integers(30, 120))
        x += bw + int(rng.integers(20, 300))
    row_idx = np.arange(rows)[:, None]
    above_ground = (row_idx >= np.maximum(skyline, 0)[None, :]) & (row_idx < horizon_row)
    struct = 0.30 + 0.06 * fractal_noise(rng, rows, cols, octaves=5, base_cells=40)
    img = np.where(above_ground, struct, img)
    # Ground: brighter near the horizon (haze), darker and more textured towards the camera, a few roads.
    g = np.clip((row_idx - horizon_row) / max(rows - horizon_row, 1), 0.0, 1.0).astype(np.float32)
    ground = 0.46 - 0.12 * g + (0.05 + 0.05 * g) * fractal_noise(rng, rows, cols, octaves=6, base_cells=24)
    for _ in range(3):
        r0 = int(rng.integers(horizon_row + 5, rows - 10))
        ground[r0:r0 + int(rng.integers(4, 14))] += float(rng.uniform(-0.08, 0.08))
    img = np.where(row_idx >= horizon_row, ground, img)
    img = brightness + contrast * (img - 0.42)
    img = cv2.GaussianBlur(img.astype(np.float32), (0, 0), 0.7)
    return Panorama(np.clip(img, 0.0, 1.0).astype(np.float32), math.radians(az_span_deg) / 2.0,
                    math.radians(el_max_deg), res)


@dataclass(frozen=True)
class Sprite:
    """Radiance and coverage (alpha) of one object pose at a nominal resolution, with smaller mip levels."""

    levels: tuple[np.ndarray, ...]  # float32 (h, w, 2): radiance and alpha, halving in size per level

    def level_for(self, height_px: float) -> np.ndarray:
        """The smallest stored level still at least `height_px` tall (avoids aliasing when shrinking)."""
        best = self.levels[0]
        for lvl in self.levels:
            if lvl.shape[0] >= height_px:
                best = lvl
        return best


def _mip(rad: np.ndarray, alpha: np.ndarray, min_h: int = 12) -> Sprite:
    levels = [np.dstack([rad, alpha]).astype(np.float32)]
    while levels[-1].shape[0] // 2 >= min_h:
        r = levels[-1]
        size = (max(1, r.shape[1] // 2), r.shape[0] // 2)
        levels.append(cv2.resize(r, size, interpolation=cv2.INTER_AREA))
    return Sprite(tuple(levels))


@dataclass(frozen=True)
class Look:
    """Radiance of an object's parts in [0, 1]; `texture` is the amplitude of the cloth/surface pattern."""

    head: float = 0.62
    upper: float = 0.22
    lower: float = 0.16
    texture: float = 0.05


def pedestrian_sprites(look: Look, seed: int, phases: int = 8, h: int = 160) -> tuple[Sprite, ...]:
    """Walking poses (index 0 standing, 1..phases a gait cycle) of one pedestrian; canvas aspect 0.34."""
    w = round(h * 0.34)
    rng = np.random.default_rng([seed, 7002])
    pattern_u = fractal_noise(rng, h, w, octaves=3, base_cells=5)
    pattern_l = fractal_noise(rng, h, w, octaves=3, base_cells=7)
    sprites = []
    for k in range(phases + 1):
        swing = 0.0 if k == 0 else math.sin(2 * math.pi * (k - 1) / phases)
        a_head = np.zeros((h, w), np.uint8)
        a_up = np.zeros((h, w), np.uint8)
        a_lo = np.zeros((h, w), np.uint8)
        cxp = w // 2
        cv2.ellipse(a_head, (cxp, int(0.075 * h)), (int(0.075 * h * 0.8), int(0.075 * h)), 0, 0, 360, 255,
                    -1, cv2.LINE_AA)
        torso = np.array([[cxp - 0.24 * w, 0.15 * h], [cxp + 0.24 * w, 0.15 * h], [cxp + 0.2 * w, 0.55 * h],
                          [cxp - 0.2 * w, 0.55 * h]], np.int32)
        cv2.fillConvexPoly(a_up, torso, 255, cv2.LINE_AA)
        for side in (-1, 1):  # arms swing opposite to the legs
            hand = (int(cxp + side * 0.36 * w - 0.18 * w * swing * side), int(0.5 * h))
            shoulder = (int(cxp + side * 0.22 * w), int(0.17 * h))
            cv2.line(a_up, shoulder, hand, 255, max(2, w // 9), cv2.LINE_AA)
            foot = (int(cxp + side * 0.08 * w + 0.38 * w * swing * side), int(0.99 * h))
            cv2.line(a_lo, (int(cxp + side * 0.1 * w), int(0.55 * h)), foot, 255, max(3, w // 6), cv2.LINE_AA)
        rad = np.zeros((h, w), np.float32)
        alpha = np.zeros((h, w), np.float32)
        for mask, val, pat in ((a_lo, look.lower, pattern_l), (a_up, look.upper, pattern_u),
                               (a_head, look.head, pattern_u)):
            m = mask.astype(np.float32) / 255.0
            part = val + look.texture * pat
            rad = rad * (1 - m) + part * m
            alpha = np.maximum(alpha, m)
        sprites.append(_mip(np.clip(rad, 0, 1), alpha))
    return tuple(sprites)


def vehicle_sprite(look: Look, seed: int, h: int = 80, aspect: float = 2.8) -> Sprite:
    """Side view of a car: body, cabin with darker windows, wheels; `look.upper` body, `look.lower` wheels."""
    w = round(h * aspect)
    rng = np.random.default_rng([seed, 7003])
    a = np.zeros((h, w), np.uint8)
    cv2.rectangle(a, (0, int(0.35 * h)), (w - 1, int(0.85 * h)), 255, -1)
    cab = np.array([[0.22 * w, 0.36 * h], [0.32 * w, 0.02 * h], [0.72 * w, 0.02 * h], [0.85 * w, 0.36 * h]],
                   np.int32)
    cv2.fillConvexPoly(a, cab, 255, cv2.LINE_AA)
    rad = look.upper + look.texture * fractal_noise(rng, h, w, octaves=3, base_cells=6)
    win = np.zeros((h, w), np.uint8)
    inset = np.array([[8, 6], [6, 6], [-6, 6], [-8, 6]])
    cv2.fillConvexPoly(win, (cab + inset).astype(np.int32), 255)
    rad = np.where(win > 0, look.head, rad)
    wheels = np.zeros((h, w), np.uint8)
    for xw in (0.2, 0.8):
        cv2.circle(wheels, (int(xw * w), int(0.82 * h)), int(0.18 * h), 255, -1, cv2.LINE_AA)
    m = wheels.astype(np.float32) / 255.0
    rad = rad * (1 - m) + look.lower * m
    alpha = np.maximum(a.astype(np.float32) / 255.0, m)
    return _mip(np.clip(rad, 0, 1).astype(np.float32), alpha)


def occluder_sprite(kind: str, look: Look, seed: int, aspect: float, h: int = 200) -> Sprite:
    """Pole (with lamp head), wall (brick-like texture), tree (trunk and porous canopy) or bush."""
    w = max(2, round(h * aspect))
    rng = np.random.default_rng([seed, 7004])
    tex = fractal_noise(rng, h, w, octaves=4, base_cells=8)
    alpha = np.zeros((h, w), np.float32)
    rad = look.upper + look.texture * tex
    if kind in ("pole", "wall"):
        alpha[:] = 1.0
        if kind == "wall":
            rows = (np.arange(h) // max(2, h // 12)) % 2
            rad = rad + 0.02 * rows[:, None]
    elif kind in ("tree", "bush"):
        trunk_top = 0.0 if kind == "bush" else 0.55
        canopy = fractal_noise(rng, h, w, octaves=4, base_cells=6)
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        cy_, ry = (0.3 * h, 0.32 * h) if kind == "tree" else (0.55 * h, 0.45 * h)
        ell = ((xx - w / 2) / (0.5 * w)) ** 2 + ((yy - cy_) / ry) ** 2
        dense = np.clip((1.0 - ell) * 3.0 + 0.8 * canopy, 0.0, 1.0)
        alpha = np.where(ell < 1.25, dense, 0.0).astype(np.float32)
        if kind == "tree":
            tw = max(1, int(0.09 * w))
            alpha[int(trunk_top * h):, w // 2 - tw:w // 2 + tw] = 1.0
        rad = np.where(alpha > 0, look.upper + look.texture * canopy, rad)
    else:
        raise SceneError(f"unknown occluder kind {kind!r}")
    return _mip(np.clip(rad, 0, 1).astype(np.float32), alpha)
