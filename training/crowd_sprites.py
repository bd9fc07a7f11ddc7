# SPDX-License-Identifier: Apache-2.0
"""The synthetic identities the shipped Siamese nets were trained on, frozen for `make train`.

This is the sprite recipe of the former self-contained `swir_tracker_ros/acquisition/crowd.py` (flat
head/torso/leg temperatures, an 8x4 texture, swinging legs), kept verbatim so that a rerun of
`training/train_siamese.py` reproduces `swir_tracker_ros/models/*` (their SHA-256 are in siamese.json).
The crowd scenes themselves now render through `swir_tracker_ros/scene/`; moving the training crops to
those sprites means re-training the nets and re-measuring every Siamese figure.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


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


def background(seed: int, width: int = 640, height: int = 480) -> np.ndarray:
    """Cool, smooth background with fixed low-frequency structure (deterministic by seed)."""
    rng = np.random.default_rng(seed + 7919)
    low = cv2.resize(rng.uniform(40, 95, size=(6, 8)).astype(np.float32), (width, height),
                     interpolation=cv2.INTER_CUBIC)
    ramp = np.linspace(0, 20, height, dtype=np.float32)[:, None]
    return low + ramp
