# SPDX-License-Identifier: Apache-2.0
"""The learned person detector: YOLOX-Nano (Ge et al., "YOLOX: Exceeding YOLO Series in 2021",
arXiv:2107.08430; Megvii's Apache-2.0 COCO checkpoint, 0.91 M parameters, 416x416 input), run by onnxruntime.

The pinned ONNX (core/siamese/weights.py `DETECTOR_PINNED`, installed by `make models`) outputs the raw head:
one row per anchor point of the three strides (8, 16, 32), [x, y, log w, log h, objectness, 80 class
scores] (objectness and classes already sigmoided). The decoding is the authors' (their demo's
`demo_postprocess` and `multiclass_nms`): centre = (grid + offset) * stride, size = exp(log size) * stride,
score = objectness * class, here for class 0 (person) alone, greedy NMS. The input is their `preproc`: the
frame resized by r = min(S / h, S / w) into the top-left of an S x S canvas of value 114, as float32
0..255 (no normalisation), BGR planes; a mono frame is replicated to the three planes.

Preprocessing, decoding and NMS are pure functions, tested without the model (test_acq_learned.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from swir_tracker_ros.acquisition.association import Detection
from swir_tracker_ros.core.conditioning import ConditioningConfig, FrameConditioner
from swir_tracker_ros.core.siamese.locator import locate
from swir_tracker_ros.core.siamese.network import session
from swir_tracker_ros.errors import AcquisitionError, ModelError
from swir_tracker_ros.types import Box

MODEL = "detector/yolox_nano.onnx"  # pinned path under the model directory (core/siamese/weights.py)
STRIDES = (8, 16, 32)
PAD_VALUE = 114  # the letterbox fill of YOLOX's preproc
PERSON = 0  # COCO class index
CLASSES = 80


@dataclass(frozen=True)
class YoloxParams:
    """Settings of the learned detector (values: ours unless said)."""

    score: float = 0.3  # keep a person whose objectness x class score reaches this (the authors' demo: 0.3)
    nms_iou: float = 0.45  # greedy NMS overlap (the authors' demo: 0.45)
    threads: int = 1  # onnxruntime intra-op threads (one core: acquisition shares the machine)
    model_dir: str = ""  # '' = the locator's search order (SWIR_TRACKER_MODELS, the installed share dir)


def letterbox(gray: np.ndarray, size: int) -> tuple[np.ndarray, float]:
    """YOLOX's preproc of a 2-D uint8 frame: (float32 [1, 3, size, size] input, scale r). The frame is
    resized by r = min(size / h, size / w) (bilinear) into the top-left corner of a canvas of PAD_VALUE and
    replicated to the three colour planes (a mono frame is its own B, G and R)."""
    h, w = gray.shape[:2]
    r = min(size / h, size / w)
    nw, nh = max(1, int(w * r)), max(1, int(h * r))
    canvas = np.full((size, size), PAD_VALUE, np.uint8)
    canvas[:nh, :nw] = cv2.resize(gray, (nw, nh), interpolation=cv2.INTER_LINEAR)
    plane = canvas.astype(np.float32)
    return np.ascontiguousarray(np.broadcast_to(plane, (1, 3, size, size))), r


def anchor_grid(size: int, strides: tuple[int, ...] = STRIDES) -> tuple[np.ndarray, np.ndarray]:
    """Anchor points (N x 2, cells (x, y)) and their strides (N,), in the order of the head's rows: stride by
    stride, row-major within a stride."""
    points, scales = [], []
    for s in strides:
        n = size // s
        ys, xs = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        points.append(np.stack([xs.ravel(), ys.ravel()], axis=1))
        scales.append(np.full(n * n, s))
    return np.concatenate(points).astype(np.float32), np.concatenate(scales).astype(np.float32)


def decode(raw: np.ndarray, size: int, strides: tuple[int, ...] = STRIDES) -> np.ndarray:
    """Raw head rows (N x (5 + classes)) -> (N x 4) boxes x0, y0, x1, y1 in input pixels: centre
    (grid + offset) * stride, size exp(log size) * stride (the authors' demo_postprocess)."""
    points, scales = anchor_grid(size, strides)
    if raw.shape[0] != len(points):
        raise AcquisitionError(f"detector output has {raw.shape[0]} rows, {len(points)} expected for a "
                               f"{size}x{size} input")
    centre = (raw[:, :2] + points) * scales[:, None]
    half = np.exp(np.minimum(raw[:, 2:4], 20.0)) * scales[:, None] / 2.0  # clamp: no overflow on garbage
    return np.concatenate([centre - half, centre + half], axis=1)


def nms(boxes: np.ndarray, scores: np.ndarray, iou: float) -> list[int]:
    """Greedy non-maximum suppression of x0, y0, x1, y1 boxes: indices kept, best first (a box is dropped
    when its IoU with a kept one exceeds `iou`)."""
    order = np.argsort(-scores, kind="stable")
    area = np.maximum(0.0, boxes[:, 2] - boxes[:, 0]) * np.maximum(0.0, boxes[:, 3] - boxes[:, 1])
    keep: list[int] = []
    while order.size:
        i = int(order[0])
        keep.append(i)
        rest = order[1:]
        lo = np.maximum(boxes[i, :2], boxes[rest, :2])
        hi = np.minimum(boxes[i, 2:], boxes[rest, 2:])
        inter = np.prod(np.maximum(0.0, hi - lo), axis=1)
        union = area[i] + area[rest] - inter
        overlap = np.where(union > 0, inter / np.maximum(union, 1e-12), 0.0)
        order = rest[overlap <= iou]
    return keep


def people(raw: np.ndarray, size: int, ratio: float, width: int, height: int, score: float,
           nms_iou: float) -> list[Detection]:
    """The persons of one raw output (N x 85): decoded, scored objectness x person, kept at `score` or more,
    NMS, mapped back to the frame (divided by the letterbox scale, clipped to the width x height image)."""
    s = raw[:, 4] * raw[:, 5 + PERSON]
    sel = np.flatnonzero(s >= score)
    if sel.size == 0:
        return []
    boxes = decode(raw, size)[sel] / ratio
    boxes[:, [0, 2]] = np.clip(boxes[:, [0, 2]], 0.0, float(width))
    boxes[:, [1, 3]] = np.clip(boxes[:, [1, 3]], 0.0, float(height))
    out = []
    for k in nms(boxes, s[sel], nms_iou):
        x0, y0, x1, y1 = (float(v) for v in boxes[k])
        if x1 - x0 >= 1.0 and y1 - y0 >= 1.0:
            out.append(Detection(Box(x0, y0, x1 - x0, y1 - y0), float(s[sel][k])))
    return out


class YoloxDetector:
    """YOLOX-Nano persons in mono8 / mono16 frames (the `Detector` protocol). A 16-bit frame is made 8-bit
    by the project's conditioning (percentile stretch, core/conditioning.py); an 8-bit frame is used as is.
    Stateless between frames but for the stretch's running limits (`reset`)."""

    def __init__(self, params: YoloxParams | None = None, model_path: str | None = None) -> None:
        self.params = params or YoloxParams()
        if model_path is None:
            model_path = str(locate_model(self.params.model_dir))
        try:
            self.session = session(Path(model_path), self.params.threads)
        except ModelError as exc:
            raise AcquisitionError(f"detector yolox: {exc}") from None
        inp = self.session.get_inputs()[0]
        self.input_name = inp.name
        shape = inp.shape
        if len(shape) != 4 or not isinstance(shape[2], int) or shape[2] != shape[3]:
            raise AcquisitionError(f"detector model {model_path} has input shape {shape}, expected "
                                   f"[1, 3, S, S]")
        self.size = int(shape[2])
        self.conditioner = FrameConditioner(ConditioningConfig())

    def reset(self) -> None:
        self.conditioner.reset()

    def gray8(self, frame: np.ndarray) -> np.ndarray:
        """The 8-bit gray image the network sees."""
        img = np.asarray(frame)
        if img.ndim == 2 and img.dtype == np.uint8:
            return img
        if img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8:
            return cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        try:
            f = self.conditioner(img)
        except Exception as exc:  # ConditioningError (a TrackerError) on an unusable frame
            raise AcquisitionError(f"frame cannot be made 8-bit for the detector: {exc}") from None
        return np.rint(f * 255.0).astype(np.uint8)

    def detect(self, frame: np.ndarray, ego_shift: tuple[float, float] = (0.0, 0.0)) -> list[Detection]:
        g = self.gray8(frame)
        x, r = letterbox(g, self.size)
        raw = self.session.run(None, {self.input_name: x})[0]
        raw = np.asarray(raw, np.float32).reshape(-1, raw.shape[-1])
        if raw.shape[1] < 5 + CLASSES:
            raise AcquisitionError(f"detector output rows have {raw.shape[1]} values, {5 + CLASSES} expected")
        return people(raw, self.size, r, g.shape[1], g.shape[0], self.params.score, self.params.nms_iou)


def locate_model(model_dir: str = "") -> Path:
    """The verified pinned detector file (core/siamese/locator.py), or AcquisitionError with its one-line
    reason naming `make models`."""
    try:
        return locate(MODEL, model_dir or None)
    except ModelError as exc:
        raise AcquisitionError(f"detector yolox: {exc}") from None


def model_problem(model_dir: str = "") -> str | None:
    """None when the pinned detector file is there and intact, else the reason (one line)."""
    try:
        locate_model(model_dir)
    except AcquisitionError as exc:
        return str(exc)
    return None
