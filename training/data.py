# SPDX-License-Identifier: Apache-2.0
"""Identity-labelled pedestrian crops for the Siamese nets: MOT gt, thermal re-id, sequences, synthetic."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from crowd_sprites import background, make_identity, render_sprite

from swir_tracker_ros.acquisition.siamese import INPUT_SIZE, crop_resized
from swir_tracker_ros.types import Box

MARGIN = 1.125  # crops are cut 12.5 % larger so random 64x64 windows give box jitter
RAW = round(INPUT_SIZE * MARGIN)
HELD_OUT_TUD = (3, 7)  # TUD-Campus identities never used for training (the runtime test uses them)
SEQUENCES = ("otb_crossing", "otb_jogging-1", "otb_walking2", "ptbtir_airplane")


def _load(path: Path) -> np.ndarray:
    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise FileNotFoundError(path)
    return img


def _cut(img: np.ndarray, box: Box) -> np.ndarray:
    return crop_resized(img, box.scaled(MARGIN), RAW).astype(np.uint8)


def mot_crops(seq_dir: Path, ids: tuple[int, ...] | None = None, exclude: tuple[int, ...] = (),
              step: int = 1) -> dict[str, list[np.ndarray]]:
    """Crops per identity from a MOTChallenge gt.txt (1-based boxes)."""
    rows = np.loadtxt(seq_dir / "gt.txt", delimiter=",", ndmin=2)
    frames: dict[int, np.ndarray] = {}
    out: dict[str, list[np.ndarray]] = {}
    for r in rows:
        f, ident = int(r[0]), int(r[1])
        if (ids is not None and ident not in ids) or ident in exclude or (f - 1) % step:
            continue
        if f not in frames:
            frames[f] = _load(seq_dir / f"{f:06d}.png")
        box = Box(r[2] - 1.0, r[3] - 1.0, r[4], r[5])
        out.setdefault(f"{seq_dir.name}/{ident}", []).append(_cut(frames[f], box))
    return out


def sequence_crops(seq_dir: Path, step: int = 4) -> dict[str, list[np.ndarray]]:
    """Crops of the single target of a tracking sequence (gt.txt lines x,y,w,h, 0-based)."""
    rows = np.loadtxt(seq_dir / "gt.txt", delimiter=",", ndmin=2)
    crops = [_cut(_load(seq_dir / f"{k + 1:06d}.png"), Box(*r[:4]))
             for k, r in enumerate(rows) if k % step == 0]
    return {seq_dir.name: crops}


def synthetic_crops(n_ids: int, per_id: int, seed: int) -> dict[str, list[np.ndarray]]:
    """Rendered pedestrians (crowd_sprites) at random sizes, phases and backgrounds, with noise."""
    rng = np.random.default_rng(seed)
    bg = background(seed)
    out: dict[str, list[np.ndarray]] = {}
    for i in range(n_ids):
        ident = make_identity(i, rng)
        crops = []
        for _ in range(per_id):
            h = int(rng.uniform(50, 160))
            w = int(h * ident.aspect)
            sprite, mask = render_sprite(ident, w, h, float(rng.uniform(0, 2 * np.pi)))
            H, W = int(h * MARGIN) + 2, int(w * MARGIN) + 2
            y0, x0 = int(rng.uniform(0, bg.shape[0] - H)), int(rng.uniform(0, bg.shape[1] - W))
            canvas = bg[y0 : y0 + H, x0 : x0 + W].copy()
            oy, ox = (H - h) // 2, (W - w) // 2
            sub = canvas[oy : oy + h, ox : ox + w]
            sub[mask > 0] = sprite[mask > 0]
            canvas = cv2.GaussianBlur(canvas, (3, 3), 0.7) + rng.normal(0, 3.0, canvas.shape)
            crops.append(cv2.resize(np.clip(canvas, 0, 255).astype(np.float32), (RAW, RAW),
                                    interpolation=cv2.INTER_AREA).astype(np.uint8))
        out[f"synthetic/{i}"] = crops
    return out


def training_set(shared: Path, seed: int) -> dict[str, list[np.ndarray]]:
    """All training identities (real + synthetic), TUD identities HELD_OUT_TUD excluded."""
    data = mot_crops(shared / "data" / "mot" / "tud_campus", exclude=HELD_OUT_TUD)
    data.update(mot_crops(shared / "data" / "reid" / "vottir2016_crowd"))
    for name in SEQUENCES:
        data.update(sequence_crops(shared / "data" / "sequences" / name))
    data.update(synthetic_crops(48, 16, seed))
    return data


def validation_set(shared: Path, seed: int) -> dict[str, list[np.ndarray]]:
    """Held-out identities: TUD HELD_OUT_TUD plus unseen synthetic identities."""
    data = mot_crops(shared / "data" / "mot" / "tud_campus", ids=HELD_OUT_TUD)
    data.update(synthetic_crops(12, 10, seed + 1))
    return data
