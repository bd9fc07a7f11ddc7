# SPDX-License-Identifier: Apache-2.0
"""Inference of the five Siamese embedding nets (paper 004 Section 3.2.1): ONNX run by onnxruntime (CPU), the
project's one runtime for every network (docs/siamese.md, "One runtime"; benchmarks/runtime_speed.py)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
import onnxruntime as ort

from swir_tracker_ros.errors import AcquisitionError
from swir_tracker_ros.types import Box

MODELS_DIR = Path(__file__).resolve().parent.parent / "models"
NET_NAMES = ("whole", "part_tl", "part_tr", "part_bl", "part_br")  # eq. 3 and the four quadrants of eq. 5
INPUT_SIZE = 64  # whole-box input (px, square); quadrants are INPUT_SIZE / 2 (notes seed-004 Section 6)


def crop_resized(gray: np.ndarray, box: Box, size: int = INPUT_SIZE) -> np.ndarray:
    """Box content resized to size x size (float32); pixels outside the image are edge-replicated."""
    h, w = gray.shape[:2]
    x0, y0 = int(np.floor(box.x)), int(np.floor(box.y))
    x1, y1 = int(np.ceil(box.x + box.w)), int(np.ceil(box.y + box.h))
    if x1 - x0 < 2 or y1 - y0 < 2:
        raise AcquisitionError(f"box {box.as_tuple()} is too small for an embedding")
    pad = max(0, -x0, -y0, x1 - w, y1 - h)
    src = gray
    if pad:
        src = cv2.copyMakeBorder(gray, pad, pad, pad, pad, cv2.BORDER_REPLICATE)
    patch = src[y0 + pad : y1 + pad, x0 + pad : x1 + pad]
    return cv2.resize(patch.astype(np.float32), (size, size), interpolation=cv2.INTER_AREA)


def standardise(patch: np.ndarray) -> np.ndarray:
    """Zero-mean, unit-variance intensities (the nets' input normalisation, training and inference alike)."""
    p = patch.astype(np.float32)
    return (p - p.mean()) / max(float(p.std()), 1.0)


def session(path: Path) -> ort.InferenceSession:
    """An onnxruntime CPU session of one net, one thread; AcquisitionError if it cannot be loaded."""
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = opts.inter_op_num_threads = 1
    opts.log_severity_level = 3  # errors only
    try:
        return ort.InferenceSession(str(path), sess_options=opts, providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime's own error types: not a usable model
        raise AcquisitionError(f"Siamese network {path} cannot be loaded by onnxruntime ({exc})") from None


def split_quadrants(patch: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """TL, TR, BL, BR quarters of a square patch (paper 004: "four equal parts")."""
    s = patch.shape[0] // 2
    return patch[:s, :s], patch[:s, s:], patch[s:, :s], patch[s:, s:]


class SiameseFamily:
    """The whole-box net phi and the four quadrant nets phi_p, each an ONNX file run by onnxruntime."""

    def __init__(self, model_dir: Path | str = MODELS_DIR) -> None:
        model_dir = Path(model_dir)
        meta_path = model_dir / "siamese.json"
        if not meta_path.is_file():
            raise AcquisitionError(f"Siamese model description {meta_path} is missing")
        self.meta = json.loads(meta_path.read_text())
        self.input_size = int(self.meta["input_size"])
        self.nets: list[ort.InferenceSession] = []
        for name in NET_NAMES:
            path = model_dir / f"siamese_{name}.onnx"
            if not path.is_file():
                raise AcquisitionError(f"Siamese network {path} is missing")
            self.nets.append(session(path))

    @classmethod
    def load_default(cls) -> SiameseFamily:
        return cls(MODELS_DIR)

    @staticmethod
    def _run(net: ort.InferenceSession, patches: list[np.ndarray]) -> np.ndarray:
        blob = np.stack(patches)[:, None, :, :].astype(np.float32)
        out = net.run(None, {net.get_inputs()[0].name: blob})[0]
        return np.asarray(out, dtype=np.float32).reshape(len(patches), -1)

    def embed_patches(self, patches: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """Embeddings of already resized (size x size) patches: (N, d_whole) and (N, 4, d_part)."""
        if not patches:
            return np.zeros((0, 0), np.float32), np.zeros((0, 4, 0), np.float32)
        std = [standardise(p) for p in patches]
        whole = self._run(self.nets[0], std)
        quads = [split_quadrants(p) for p in std]
        parts = [self._run(self.nets[1 + q], [qs[q] for qs in quads]) for q in range(4)]
        return whole, np.stack(parts, axis=1)

    def embed(self, gray: np.ndarray, boxes: Sequence[Box]) -> tuple[np.ndarray, np.ndarray]:
        """Embeddings of boxes in a gray frame: (N, d_whole) whole-box and (N, 4, d_part) quadrant vectors."""
        return self.embed_patches([crop_resized(gray, b, self.input_size) for b in boxes])
