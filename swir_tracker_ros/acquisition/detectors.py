# SPDX-License-Identifier: Apache-2.0
"""Pluggable detectors: adaptive background subtraction with head-motion compensation, OpenCV HOG people."""

from __future__ import annotations

import itertools
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

    history: int = 21  # frames in the background buffer (temporal median)
    sample_every: int = 2  # a frame enters the buffer every this many frames (span = history * sample_every)
    threshold: float = 14.0  # foreground if |I - background| exceeds this (8-bit levels)
    open_size: int = 3  # opening kernel (px), removes speckle
    close_size: int = 9  # closing kernel (px), fills holes in a body
    min_area: float = 1000.0  # discard foreground regions with fewer pixels than this
    warmup: int = 5  # frames used to build the background before detections are reported
    aspect: float = 0.4  # width / height of a standing person (MOT ground truth boxes: 0.39 median)
    split_factor: float = 1.5  # a region wider than split_factor * aspect * height holds several people
    trim: float = 0.02  # box = the central 1 - 2 trim of the region's pixels across (swinging arms, legs)
    trim_v: float = 0.01  # ... and along the height (a stray pixel row)
    scale: float = 0.5  # the frame is resized by this factor first (speed; sizes above: full-resolution px)


def _extent(counts: np.ndarray, trim: float) -> tuple[int, int]:
    """[start, stop) holding the central 1 - 2 trim of the mass of a 1-D histogram."""
    c = np.cumsum(counts, dtype=np.float64)
    lo = int(np.searchsorted(c, trim * c[-1], side="right"))
    return lo, int(np.searchsorted(c, (1 - trim) * c[-1])) + 1


class MotionDetector:
    """Temporal-median background of a buffer of past frames, threshold, opening then closing, connected
    regions; a region wider than a person is split at the emptiest columns into person-wide parts, and each
    box is the trimmed extent of its pixels.

    A median over frames spanning history * sample_every frames holds the scene without the people who walk
    through it (a pixel is background in most of them), so people present from the first frame do not
    leave "ghosts" as a running average does. The buffered frames and the background are shifted by the
    known image shift (from the head's joint states) before each comparison, so a panning camera does not
    turn the whole scene into foreground; pixels uncovered by the shift take the current frame.
    """

    def __init__(self, params: MotionParams | None = None) -> None:
        self.params = params or MotionParams()
        self.reset()

    def reset(self) -> None:
        self.buffer: list[np.ndarray] = []
        self.background: np.ndarray | None = None
        self.count = 0

    @staticmethod
    def _shift(img: np.ndarray, dx: float, dy: float) -> np.ndarray:
        """img moved by (dx, dy) px; uncovered pixels are NaN."""
        M = np.array([[1.0, 0.0, dx], [0.0, 1.0, dy]], np.float32)
        return cv2.warpAffine(img, M, (img.shape[1], img.shape[0]), flags=cv2.INTER_LINEAR,
                              borderMode=cv2.BORDER_CONSTANT, borderValue=float("nan"))

    def foreground(self, frame: np.ndarray, ego_shift: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
        """Binary (uint8 0/255) foreground mask after opening and closing; updates the background buffer."""
        p = self.params
        g8 = to_gray8(frame)
        if p.scale != 1.0:
            g8 = cv2.resize(g8, None, fx=p.scale, fy=p.scale, interpolation=cv2.INTER_AREA)
        g = g8.astype(np.float32)
        if self.buffer and self.buffer[0].shape != g.shape:
            self.reset()
        dx, dy = ego_shift[0] * p.scale, ego_shift[1] * p.scale
        if dx or dy:
            self.buffer = [self._shift(b, dx, dy) for b in self.buffer]
            if self.background is not None:
                self.background = self._shift(self.background, dx, dy)
        if self.count % p.sample_every == 0 or not self.buffer:
            self.buffer = [*self.buffer, g][-p.history:]
            self.background = np.median(np.stack(self.buffer), axis=0)  # NaN where a shift uncovered a pixel
        self.count += 1
        assert self.background is not None
        bg = np.where(np.isnan(self.background), g, self.background)
        fg = (np.abs(g - bg) > p.threshold).astype(np.uint8) * 255
        ko, kc = (max(1, round(k * p.scale)) for k in (p.open_size, p.close_size))
        fg = cv2.morphologyEx(fg, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (ko, ko)))
        return cv2.morphologyEx(fg, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (kc, kc)))

    def detect(self, frame: np.ndarray, ego_shift: tuple[float, float] = (0.0, 0.0)) -> list[Detection]:
        p = self.params
        fg = self.foreground(frame, ego_shift)
        if self.count <= p.warmup:
            return []
        n, labels, stats, _ = cv2.connectedComponentsWithStats(fg)
        min_area = p.min_area * p.scale**2
        dets = []
        for i in range(1, n):
            x, y, w, h, area = (int(v) for v in stats[i])
            if area < min_area:
                continue
            mask = labels[y:y + h, x:x + w] == i
            cols = mask.sum(axis=0)
            parts = max(1, round(w / (p.aspect * h))) if w > p.split_factor * p.aspect * h else 1
            cuts = [0]
            for c in range(1, parts):  # cut at the emptiest column near each equal division
                c0, r = int(c * w / parts), max(1, int(w / (2 * parts)))
                lo, hi = max(cuts[-1] + 1, c0 - r), min(w - 1, c0 + r)
                cuts.append(lo + int(np.argmin(cols[lo:hi])) if hi > lo else c0)
            cuts.append(w)
            for a0, a1 in itertools.pairwise(cuts):
                sub = mask[:, a0:a1]
                px = int(sub.sum())
                if px < min_area / 2:
                    continue
                x0, x1 = _extent(sub.sum(axis=0), p.trim)
                y0, y1 = _extent(sub.sum(axis=1), p.trim_v)
                fill = px / float(sub.size)
                box = Box(float(x + a0 + x0) / p.scale, float(y + y0) / p.scale, float(x1 - x0) / p.scale,
                          float(y1 - y0) / p.scale)
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
