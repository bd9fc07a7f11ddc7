# SPDX-License-Identifier: Apache-2.0
"""Synthetic thermal crowds with identity ground truth: textured warm pedestrians crossing and occluding."""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from swir_tracker_ros.acquisition.association import Detection
from swir_tracker_ros.types import Box


@dataclass(frozen=True)
class Identity:
    """Per-identity thermal signature: temperatures (8-bit gray) of head, torso, legs and a fixed texture."""

    id: int
    head: float
    torso: float
    legs: float
    texture: np.ndarray  # (8, 4) pattern in [-1, 1], upsampled over the body
    texture_gain: float
    aspect: float  # width / height


@dataclass
class Walker:
    """A pedestrian on a straight path: position of the foot point at frame k = start + k * velocity."""

    identity: Identity
    start: tuple[float, float]  # foot point (x, y) at frame 0
    velocity: tuple[float, float]  # px per frame
    height: float  # px at frame 0
    growth: float = 0.0  # height change per frame (approach / recede)
    depth: float = 0.0  # draw order: larger is nearer (drawn later)
    turn_at: int | None = None  # frame after which the walker turns back (velocity reversed)

    def box(self, k: int) -> Box:
        h = max(8.0, self.height + self.growth * k)
        t = k if self.turn_at is None or k <= self.turn_at else 2 * self.turn_at - k
        fx = self.start[0] + self.velocity[0] * t
        fy = self.start[1] + self.velocity[1] * t
        w = h * self.identity.aspect
        return Box(fx - w / 2.0, fy - h, w, h)


@dataclass(frozen=True)
class Occluder:
    box: Box
    level: float  # 8-bit gray level


@dataclass(frozen=True)
class GroundTruth:
    """One visible pedestrian in one frame: full box, visible fraction after occlusion by others/occluders."""

    id: int
    box: Box
    visibility: float


@dataclass
class CrowdScene:
    width: int = 640
    height: int = 480
    walkers: list[Walker] = field(default_factory=list)
    occluders: list[Occluder] = field(default_factory=list)
    noise_std: float = 3.0
    seed: int = 0


def make_identity(ident: int, rng: np.random.Generator) -> Identity:
    """Random but distinct clothing temperatures and texture (a fixed low-resolution random pattern)."""
    return Identity(
        id=ident,
        head=float(rng.uniform(200, 245)),
        torso=float(rng.uniform(120, 215)),
        legs=float(rng.uniform(100, 200)),
        texture=rng.uniform(-1.0, 1.0, size=(8, 4)),
        texture_gain=float(rng.uniform(10, 35)),
        aspect=float(rng.uniform(0.33, 0.45)),
    )


def render_sprite(identity: Identity, w: int, h: int, phase: float) -> tuple[np.ndarray, np.ndarray]:
    """Gray sprite and alpha mask (h x w) of a pedestrian: head, textured torso, two swinging legs."""
    w, h = max(w, 3), max(h, 8)
    img = np.zeros((h, w), np.float32)
    mask = np.zeros((h, w), np.uint8)
    tex = cv2.resize(identity.texture.astype(np.float32), (w, h), interpolation=cv2.INTER_LINEAR)
    head_r = max(1, int(0.09 * h))
    cv2.circle(mask, (w // 2, head_r + 1), head_r, 1, -1)
    img[mask > 0] = identity.head
    torso = np.zeros_like(mask)
    t0, t1 = int(0.19 * h), int(0.58 * h)
    cv2.rectangle(torso, (int(0.12 * w), t0), (int(0.88 * w), t1), 1, -1)
    img[torso > 0] = identity.torso
    legs = np.zeros_like(mask)
    swing = int(0.12 * w * np.sin(phase))
    lw = max(1, int(0.18 * w))
    for side in (-1, 1):
        top = (w // 2 + side * int(0.16 * w), t1)
        bottom = (w // 2 + side * int(0.16 * w) + side * swing, h - 1)
        cv2.line(legs, top, bottom, 1, lw)
    legs[torso > 0] = 0
    img[legs > 0] = identity.legs
    body = (torso > 0) | (legs > 0)
    img[body] += identity.texture_gain * tex[body]
    mask = ((mask > 0) | body).astype(np.uint8)
    return np.clip(img, 0, 255), mask


def background(scene: CrowdScene) -> np.ndarray:
    """Cool, smooth background with fixed low-frequency structure (deterministic by seed)."""
    rng = np.random.default_rng(scene.seed + 7919)
    low = cv2.resize(rng.uniform(40, 95, size=(6, 8)).astype(np.float32), (scene.width, scene.height),
                     interpolation=cv2.INTER_CUBIC)
    ramp = np.linspace(0, 20, scene.height, dtype=np.float32)[:, None]
    return low + ramp


def render(scene: CrowdScene, k: int, bg: np.ndarray | None = None) -> tuple[np.ndarray, list[GroundTruth]]:
    """Frame k (uint8) and the ground truth of every pedestrian at least partly inside the image."""
    img = (background(scene) if bg is None else bg).copy()
    owner = np.full((scene.height, scene.width), -1, np.int32)
    areas: dict[int, float] = {}
    order = sorted(scene.walkers, key=lambda wk: (wk.depth, wk.box(k).y + wk.box(k).h))
    for wk in order:
        b = wk.box(k)
        x0, y0 = round(b.x), round(b.y)
        sw, sh = round(b.w), round(b.h)
        sprite, mask = render_sprite(wk.identity, sw, sh, 0.35 * k * np.hypot(*wk.velocity))
        xs0, ys0 = max(0, x0), max(0, y0)
        xs1, ys1 = min(scene.width, x0 + sw), min(scene.height, y0 + sh)
        areas[wk.identity.id] = float(mask.sum())
        if xs1 <= xs0 or ys1 <= ys0:
            continue
        sub_m = mask[ys0 - y0 : ys1 - y0, xs0 - x0 : xs1 - x0] > 0
        img[ys0:ys1, xs0:xs1][sub_m] = sprite[ys0 - y0 : ys1 - y0, xs0 - x0 : xs1 - x0][sub_m]
        owner[ys0:ys1, xs0:xs1][sub_m] = wk.identity.id
    for oc in scene.occluders:
        x0, y0 = round(oc.box.x), round(oc.box.y)
        x1, y1 = round(oc.box.x + oc.box.w), round(oc.box.y + oc.box.h)
        img[max(0, y0):y1, max(0, x0):x1] = oc.level
        owner[max(0, y0):y1, max(0, x0):x1] = -1
    rng = np.random.default_rng(scene.seed * 100003 + k)
    img = cv2.GaussianBlur(img, (3, 3), 0.7) + rng.normal(0.0, scene.noise_std, img.shape).astype(np.float32)
    ids, counts = np.unique(owner[owner >= 0], return_counts=True)
    visible = dict(zip(ids.tolist(), counts.tolist()))
    gts = []
    for wk in scene.walkers:
        b = wk.box(k)
        if b.intersects_image(scene.width, scene.height):
            vis = visible.get(wk.identity.id, 0) / max(areas.get(wk.identity.id, 1.0), 1.0)
            gts.append(GroundTruth(wk.identity.id, b, float(min(1.0, vis))))
    return np.clip(img, 0, 255).astype(np.uint8), gts


def simulated_detections(gts: list[GroundTruth], rng: np.random.Generator, *, min_visibility: float = 0.5,
                         miss_rate: float = 0.05, jitter: float = 0.04, fp_rate: float = 0.05,
                         size: tuple[int, int] = (640, 480)) -> list[Detection]:
    """Detector stand-in (notes seed-004 Section 6): visible GT boxes, misses, jitter, false positives."""
    dets = []
    for g in gts:
        if g.visibility < min_visibility or rng.random() < miss_rate:
            continue
        b = g.box
        j = rng.normal(0.0, jitter, 4) * np.array([b.w, b.h, b.w, b.h])
        box = Box(b.x + j[0], b.y + j[1], b.w + j[2], b.h + j[3])
        dets.append(Detection(box, float(rng.uniform(0.6, 1.0))))
    if rng.random() < fp_rate:
        h = float(rng.uniform(40, 120))
        dets.append(Detection(Box(float(rng.uniform(0, size[0] - h / 2)), float(rng.uniform(0, size[1] - h)),
                                  h * 0.4, h), float(rng.uniform(0.3, 0.6))))
    return dets


def crossing_scene(seed: int = 0, frames: int = 80) -> CrowdScene:
    """Two pedestrians walking towards each other on the same line; they overlap fully mid-way (Fig. 6)."""
    rng = np.random.default_rng(seed)
    a, b = make_identity(1, rng), make_identity(2, rng)
    y = 360.0 + rng.uniform(-20, 20)
    v = 500.0 / frames
    return CrowdScene(walkers=[Walker(a, (70.0, y), (v, 0.0), 120.0, depth=1.0),
                               Walker(b, (570.0, y + 6.0), (-v, 0.0), 116.0, depth=0.0)], seed=seed)


def meeting_scene(seed: int = 0, frames: int = 80) -> CrowdScene:
    """Two pedestrians walk towards each other, overlap and both turn back where they meet: the motion
    model predicts that they pass, so only appearance can keep the identities."""
    rng = np.random.default_rng(seed)
    a, b = make_identity(1, rng), make_identity(2, rng)
    y = 360.0 + rng.uniform(-20, 20)
    v = 4.0
    meet = frames // 2
    x_meet = 320.0
    left = Walker(a, (x_meet - 8.0 - v * meet, y), (v, 0.0), 120.0, depth=1.0, turn_at=meet)
    right = Walker(b, (x_meet + 8.0 + v * meet, y + 6.0), (-v, 0.0), 116.0, depth=0.0, turn_at=meet)
    return CrowdScene(walkers=[left, right], seed=seed)


def occlusion_scene(seed: int = 0, occluded_frames: int = 10) -> CrowdScene:
    """One pedestrian walking behind a pole wide enough to hide it fully for occluded_frames frames."""
    rng = np.random.default_rng(seed)
    ident = make_identity(1, rng)
    h = 110.0
    w = h * ident.aspect
    v = 4.0
    pole_w = w + v * occluded_frames
    pole = Occluder(Box(320.0 - pole_w / 2.0, 150.0, pole_w, 300.0), 70.0)
    return CrowdScene(walkers=[Walker(ident, (100.0, 400.0), (v, 0.0), h)], occluders=[pole], seed=seed)


def random_crowd(seed: int = 0, n: int = 6, frames: int = 120) -> CrowdScene:
    """n pedestrians on random straight paths across the image (several crossings), one pole occluder."""
    rng = np.random.default_rng(seed)
    walkers = []
    for i in range(n):
        ident = make_identity(i + 1, rng)
        y = float(rng.uniform(230, 470))
        h = 60.0 + (y - 230.0) * 0.45 + float(rng.uniform(-8, 8))
        left = rng.random() < 0.5
        x0 = float(rng.uniform(-20, 200)) if left else float(rng.uniform(440, 660))
        vx = float(rng.uniform(2.0, 5.0)) * (1 if left else -1)
        walkers.append(Walker(ident, (x0, y), (vx, float(rng.uniform(-0.4, 0.4))), h, depth=y))
    pole = Occluder(Box(float(rng.uniform(200, 420)), 120.0, 18.0, 360.0), 65.0)
    return CrowdScene(walkers=walkers, occluders=[pole], seed=seed)
