# SPDX-License-Identifier: Apache-2.0
"""Pluggable detectors: adaptive background subtraction with head-motion compensation, OpenCV HOG people."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import cv2
import numpy as np

from swir_tracker_ros.acquisition.association import Detection
from swir_tracker_ros.acquisition.descriptors import to_gray8
from swir_tracker_ros.errors import AcquisitionError
from swir_tracker_ros.types import Box


class Detector(Protocol):
    """Anything that turns a frame into boxes; ego_shift is the image shift (px) since the previous frame."""

    def detect(self, frame: np.ndarray, ego_shift: tuple[float, float] = (0.0, 0.0)) -> list[Detection]: ...

    def reset(self) -> None: ...


@dataclass(frozen=True)
class MotionParams:
    """Moving-object detection (dissertation 003 Section 3.3.2.1); values are project choices."""

    learning_rate: float = 0.02  # running mean / variance update rate of the background model
    threshold_sigma: float = 3.0  # foreground if |I - mean| > threshold_sigma * std
    min_std: float = 4.0  # floor of the per-pixel std (8-bit levels)
    open_size: int = 3  # opening kernel (px), removes speckle
    close_size: int = 9  # closing kernel (px), fills holes in a body
    min_area: float = 150.0  # discard contour boxes smaller than this (px^2)
    warmup: int = 5  # frames used to build the background before detections are reported


class MotionDetector:
    """Adaptive per-pixel Gaussian background, morphological opening then closing, contour boxes.

    The background mean and variance are warped by the known image shift (from the head's joint states)
    before each comparison, so a panning camera does not turn the whole scene into foreground.
    """

    def __init__(self, params: MotionParams | None = None) -> None:
        self.params = params or MotionParams()
        self.mean: np.ndarray | None = None
        self.var: np.ndarray | None = None
        self.valid: np.ndarray | None = None
        self.count = 0

    def reset(self) -> None:
        self.mean = self.var = self.valid = None
        self.count = 0

    @staticmethod
    def _shift(img: np.ndarray, dx: float, dy: float, border: float) -> np.ndarray:
        M = np.array([[1.0, 0.0, dx], [0.0, 1.0, dy]], np.float32)
        return cv2.warpAffine(img, M, (img.shape[1], img.shape[0]), flags=cv2.INTER_LINEAR,
                              borderMode=cv2.BORDER_CONSTANT, borderValue=border)

    def foreground(self, frame: np.ndarray, ego_shift: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
        """Binary (uint8 0/255) foreground mask after opening and closing; updates the background model."""
        p = self.params
        g = to_gray8(frame).astype(np.float32)
        if self.mean is None or self.mean.shape != g.shape:
            self.mean, self.var = g.copy(), np.full_like(g, p.min_std**2)
            self.valid = np.ones_like(g)
            self.count = 1
            return np.zeros(g.shape, np.uint8)
        assert self.var is not None and self.valid is not None
        dx, dy = ego_shift
        if dx or dy:
            self.mean = self._shift(self.mean, dx, dy, 0.0)
            self.var = self._shift(self.var, dx, dy, p.min_std**2)
            self.valid = self._shift(self.valid, dx, dy, 0.0)
        fresh = self.valid < 0.5  # uncovered by the shift: adopt the current frame
        self.mean[fresh] = g[fresh]
        self.valid[fresh] = 1.0
        diff = g - self.mean
        std = np.sqrt(np.maximum(self.var, p.min_std**2))
        fg = (np.abs(diff) > p.threshold_sigma * std).astype(np.uint8) * 255
        a = p.learning_rate
        bgmask = fg == 0
        self.mean[bgmask] += a * diff[bgmask]
        self.var[bgmask] = (1 - a) * self.var[bgmask] + a * diff[bgmask] ** 2
        self.count += 1
        k_open = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (p.open_size, p.open_size))
        k_close = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (p.close_size, p.close_size))
        fg = cv2.morphologyEx(fg, cv2.MORPH_OPEN, k_open)
        return cv2.morphologyEx(fg, cv2.MORPH_CLOSE, k_close)

    def detect(self, frame: np.ndarray, ego_shift: tuple[float, float] = (0.0, 0.0)) -> list[Detection]:
        fg = self.foreground(frame, ego_shift)
        if self.count <= self.params.warmup:
            return []
        contours, _ = cv2.findContours(fg, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        dets = []
        for c in contours:
            x, y, w, h = cv2.boundingRect(c)
            if w * h >= self.params.min_area:
                fill = cv2.contourArea(c) / float(w * h)
                box = Box(float(x), float(y), float(w), float(h))
                dets.append(Detection(box, float(min(1.0, 0.5 + fill / 2))))
        return dets


@dataclass(frozen=True)
class HogParams:
    """OpenCV's default people detector (Dalal-Triggs 64x128 HOG + linear SVM)."""

    hit_threshold: float = 0.0
    win_stride: int = 8
    scale: float = 1.05
    upscale: float = 1.0  # resize the frame by this factor first (people smaller than 128 px need > 1)
    nms_iou: float = 0.4
    shrink_w: float = 0.7  # the 64x128 window has margins around the person: keep this fraction of its width
    shrink_h: float = 0.85  # ... and of its height (centred); fitted on TUD-Campus frames (IoU with gt)


class HogPeopleDetector:
    """cv2.HOGDescriptor with getDefaultPeopleDetector, for static scenes; scores squashed to (0, 1)."""

    def __init__(self, params: HogParams | None = None) -> None:
        self.params = params or HogParams()
        self.hog = cv2.HOGDescriptor()
        self.hog.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())

    def reset(self) -> None:
        pass

    def detect(self, frame: np.ndarray, ego_shift: tuple[float, float] = (0.0, 0.0)) -> list[Detection]:
        p = self.params
        g = to_gray8(frame)
        if p.upscale != 1.0:
            g = cv2.resize(g, None, fx=p.upscale, fy=p.upscale, interpolation=cv2.INTER_LINEAR)
        rects, weights = self.hog.detectMultiScale(g, hitThreshold=p.hit_threshold,
                                                   winStride=(p.win_stride, p.win_stride), scale=p.scale)
        if len(rects) == 0:
            return []
        boxes = [[float(v) / p.upscale for v in r] for r in rects]
        scores = [float(1.0 / (1.0 + np.exp(-s))) for s in np.ravel(weights)]  # SVM margin squashed to (0, 1)
        keep = cv2.dnn.NMSBoxes(boxes, scores, 0.0, p.nms_iou)
        out = []
        for k in np.ravel(keep):
            x, y, w, h = boxes[int(k)]
            box = Box.from_center(x + w / 2.0, y + h / 2.0, w * p.shrink_w, h * p.shrink_h)
            out.append(Detection(box, scores[int(k)]))
        return out


class MotDetFile:
    """Replays a MOTChallenge det.txt (frame,-1,x,y,w,h,score,...): public detections as a Detector."""

    def __init__(self, path: Path | str, min_score: float = -np.inf, score_scale: float = 100.0) -> None:
        path = Path(path)
        if not path.is_file():
            raise AcquisitionError(f"detection file {path} does not exist")
        rows = np.loadtxt(path, delimiter=",", ndmin=2)
        self.by_frame: dict[int, list[Detection]] = {}
        for r in rows:
            if r[6] < min_score:
                continue
            # MOT boxes are 1-based; score squashed to (0, 1) for the class term of eq. (1).
            score = float(min(1.0, max(0.0, r[6] / score_scale)))
            det = Detection(Box(r[2] - 1.0, r[3] - 1.0, r[4], r[5]), score)
            self.by_frame.setdefault(int(r[0]), []).append(det)
        self.frame = 0

    def reset(self) -> None:
        self.frame = 0

    def detect(self, frame: np.ndarray, ego_shift: tuple[float, float] = (0.0, 0.0)) -> list[Detection]:
        self.frame += 1
        return list(self.by_frame.get(self.frame, []))
