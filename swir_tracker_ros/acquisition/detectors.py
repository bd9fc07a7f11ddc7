# SPDX-License-Identifier: Apache-2.0
"""Pluggable detectors: adaptive background subtraction with head-motion compensation, OpenCV HOG people."""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import cv2
import numpy as np
from scipy.signal import find_peaks

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
    close_size: int = 9  # closing kernel (px), joins the limbs and body of one person into one region ...
    close_rel: float = 0.05  # ... until people are found; then this times their running median height
    # (a fixed kernel that joins a near person's parts also joins far people side by side); 0 = close_size
    min_area: float = 1000.0  # discard foreground regions with fewer pixels than this
    warmup: int = 1  # frames used to build the background before detections are reported
    aspect: float = 0.4  # width / height of a standing person (MOT ground truth boxes: 0.39 median)
    split_factor: float = 1.2  # a region wider than split_factor * aspect * height may hold several people
    trim: float = 0.02  # box = the central 1 - 2 trim of the region's pixels across (swinging arms, legs)
    trim_v: float = 0.01  # ... and along the height (a stray pixel row)
    scale: float = 0.5  # the frame is resized by this factor first (speed; sizes above: full-resolution px)
    ghost_lag: int = 1  # the motion check of a region compares the frame with the one this many frames back
    ghost_speed: float = 0.5  # a region moving less than this (px per frame) is a ghost (the background still
    # holds someone who has left): absorbed, not reported; 0 = off. Its speed is estimated from the pixels
    # that changed over ghost_lag frames: an object moving v px changes about 2 v px per row, whatever its
    # texture (its leading and trailing edges)
    head_prominence: float = 0.05  # a head is a top of the region's upper outline standing out by this
    # fraction of the region's height above the outline between it and the next head
    head_spacing: float = 0.5  # two heads are at least this times a person's width (aspect * height) apart
    band_factor: float = 1.0  # a region wider than this times a person's width (aspect * its height) that
    # shows a head gets a box per head, aspect times its height wide, and its columns outside the central
    # band_core of those boxes are searched for people partly behind them ("bands")
    band_core: float = 0.8  # the central fraction of a head's box taken as that person's columns
    band_min_w: float = 0.2  # a band is a run of free columns at least this times a person's width wide ...
    band_min_h: float = 0.4  # ... whose pixels, each column's run down from its top, span at least this
    # fraction of the region's height; 0 = no bands
    band_feet: float = 0.1  # a band whose lowest pixel lies within this fraction of a neighbouring box's
    # height of that box's bottom stands as near as that person (ground plane), so it must span band_same
    # of that box's height to be someone else (otherwise it is their leg in stride, arm or bag)
    band_same: float = 0.9


def greedy_matches(boxes: list[Box], truth: list[Box], min_iou: float = 0.5) -> tuple[set[int], set[int]]:
    """Greedy one-to-one matching of detections to ground truth by decreasing IoU (>= `min_iou`), the
    per-frame rule of the detector's recall / precision (docs/acquisition.md): matched indices of `boxes`
    and of `truth`."""
    pairs = sorted(((b.iou(g), i, j) for i, b in enumerate(boxes) for j, g in enumerate(truth)), reverse=True)
    used_b: set[int] = set()
    used_g: set[int] = set()
    for iou, i, j in pairs:
        if iou >= min_iou and i not in used_b and j not in used_g:
            used_b.add(i)
            used_g.add(j)
    return used_b, used_g


def _extent(counts: np.ndarray, trim: float) -> tuple[int, int]:
    """[start, stop) holding the central 1 - 2 trim of the mass of a 1-D histogram."""
    c = np.cumsum(counts, dtype=np.float64)
    lo = int(np.searchsorted(c, trim * c[-1], side="right"))
    return lo, int(np.searchsorted(c, (1 - trim) * c[-1])) + 1


class MotionDetector:
    """Temporal-median background of a buffer of past frames, threshold, opening then closing, connected
    regions; regions without motion are ghosts; a region wider than a person is split at its heads (or, with
    fewer than two heads, at the emptiest columns) into people, each box the trimmed extent of its pixels
    or, from a head, aspect times its height wide; people partly behind them come from the region's columns
    left over (`_bands`).

    A median over frames spanning history * sample_every frames holds the scene without the people who walk
    through it (a pixel is background in most of them), so people present from the first frame do not
    leave "ghosts" as a running average does once the buffer is full. Until then (and for people who stood
    still for a while) the median still holds them: a region of the difference to the background where the
    frame did not change over the last ghost_lag frames is the place someone has left, not someone moving.
    It is not reported and its pixels are written into the buffered frames (the ghost test and selective
    update of Cucchiara et al., "Detecting moving objects, ghosts, and shadows in video streams", IEEE PAMI
    25(10), 2003, Section 3, with frame differencing in place of their optical flow). This lets the detector
    report from the second frame on.

    The buffered frames and the background are shifted by the known image shift (from the head's joint
    states) before each comparison, so a panning camera does not turn the whole scene into foreground;
    pixels uncovered by the shift take the current frame. The ghost test's previous frame is shifted alike.
    """

    def __init__(self, params: MotionParams | None = None) -> None:
        self.params = params or MotionParams()
        self.reset()

    def reset(self) -> None:
        self.buffer: list[np.ndarray] = []
        self.background: np.ndarray | None = None
        self.recent: list[np.ndarray] = []  # the last ghost_lag + 1 frames (working resolution), oldest first
        self.count = 0
        self.person_h: float | None = None  # running median height of the boxes reported (full-resolution px)

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
            self.recent = [self._shift(b, dx, dy) for b in self.recent]
            if self.background is not None:
                self.background = self._shift(self.background, dx, dy)
        self.recent = [*self.recent, g][-(p.ghost_lag + 1):]
        bg = self._background(g)
        self.count += 1
        fg = (np.abs(g - bg) > p.threshold).astype(np.uint8) * 255
        close = p.close_size if p.close_rel <= 0 or self.person_h is None else p.close_rel * self.person_h
        ko, kc = (max(1, round(k * p.scale)) for k in (p.open_size, close))
        fg = cv2.morphologyEx(fg, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (ko, ko)))
        fg = cv2.morphologyEx(fg, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (kc, kc)))
        return fg

    def _background(self, g: np.ndarray) -> np.ndarray:
        """Enter g into the buffer (every sample_every frames) and return the background for g."""
        p = self.params
        if self.count % p.sample_every == 0 or not self.buffer:
            self.buffer = [*self.buffer, g][-p.history:]
            self.background = np.median(np.stack(self.buffer), axis=0)  # NaN where a shift uncovered a pixel
        assert self.background is not None
        return np.where(np.isnan(self.background), g, self.background)

    def _absorb(self, region: np.ndarray) -> None:
        """Write the current frame into the background buffer at a ghost's pixels (selective update)."""
        g = self.recent[-1]
        for b in self.buffer:
            b[region] = g[region]
        assert self.background is not None
        self.background[region] = g[region]

    def detect(self, frame: np.ndarray, ego_shift: tuple[float, float] = (0.0, 0.0)) -> list[Detection]:
        p = self.params
        fg = self.foreground(frame, ego_shift)
        if self.count <= p.warmup:
            return []
        n, labels, stats, _ = cv2.connectedComponentsWithStats(fg)
        changed = None
        if p.ghost_speed > 0 and len(self.recent) > p.ghost_lag:
            old = self.recent[0]
            changed = np.abs(self.recent[-1] - np.where(np.isnan(old), self.recent[-1], old)) > p.threshold
        min_area = p.min_area * p.scale**2
        dets = []
        for i in range(1, n):
            x, y, w, h, area = (int(v) for v in stats[i])
            if area < min_area:
                continue
            mask = labels[y:y + h, x:x + w] == i
            speed = None if changed is None else (
                changed[y:y + h, x:x + w][mask].sum() / (2.0 * h * p.scale * p.ghost_lag))
            if speed is not None and speed < p.ghost_speed:
                self._absorb(labels == i)
                continue
            for bx, by, bw, bh, fill in self._people(mask):
                box = Box((x + bx) / p.scale, (y + by) / p.scale, bw / p.scale, bh / p.scale)
                dets.append(Detection(box, float(min(1.0, 0.5 + fill / 2))))
        if dets:
            h = float(np.median([d.box.h for d in dets]))
            self.person_h = h if self.person_h is None else 0.9 * self.person_h + 0.1 * h
        return dets

    def _people(self, mask: np.ndarray) -> list[tuple[float, float, float, float, float]]:
        """Boxes (x, y, w, h, fill) in the region's frame: one per head when the region is wider than
        split_factor people and shows at least two heads, plus the people partly behind them (`_bands`);
        one per head plus those behind when a region wider than band_factor people has a band; else the
        emptiest-column split."""
        p = self.params
        h, w = mask.shape
        if w > p.split_factor * p.aspect * h:
            heads = self._heads(mask)
            if len(heads) >= 2:
                return heads + self._bands(mask, heads)
        if p.band_min_h > 0 and w > p.band_factor * p.aspect * h:
            heads = self._heads(mask)
            if heads:
                bands = self._bands(mask, heads)
                if bands:
                    return heads + bands
        cols = mask.sum(axis=0)
        parts = max(1, round(w / (p.aspect * h))) if w > p.split_factor * p.aspect * h else 1
        cuts = [0]
        for c in range(1, parts):  # cut at the emptiest column near each equal division
            c0, r = int(c * w / parts), max(1, int(w / (2 * parts)))
            lo, hi = max(cuts[-1] + 1, c0 - r), min(w - 1, c0 + r)
            cuts.append(lo + int(np.argmin(cols[lo:hi])) if hi > lo else c0)
        cuts.append(w)
        out = []
        for a0, a1 in itertools.pairwise(cuts):
            sub = mask[:, a0:a1]
            px = int(sub.sum())
            if px < p.min_area * p.scale**2 / 2:
                continue
            x0, x1 = _extent(sub.sum(axis=0), p.trim)
            y0, y1 = _extent(sub.sum(axis=1), p.trim_v)
            out.append((float(a0 + x0), float(y0), float(x1 - x0), float(y1 - y0), px / float(sub.size)))
        return out

    def _bands(self, mask: np.ndarray, boxes: list[tuple[float, float, float, float, float]]
               ) -> list[tuple[float, float, float, float, float]]:
        """People partly behind the boxes found ("bands"; ours): a run of the region's columns outside the
        central band_core of every box, band_min_w person widths wide, whose pixels span band_min_h of the
        region's height, is a person aspect times that span wide, reaching from the run's free edge behind
        the neighbouring box (boxes overlap, as the ground truth's of people one behind the other do).

        The span runs from the band's top to the lowest end of each column's run of pixels down from its
        top: a farther person's feet lie higher in the image (ground plane), and the nearer person's feet
        below them, separated by a gap, do not belong to it. A band whose feet are level with a
        neighbouring box's stands as near as that person, so it is another person only if about as tall
        (band_same); else it is that person's leg in stride, arm or bag. Splitting a foreground region that
        holds several people by its silhouette follows W4 (Haritaoglu, Harwood, Davis, "W4: real-time
        surveillance of people and their activities", IEEE PAMI 22(8), 2000); the band test is ours."""
        p = self.params
        if p.band_min_h <= 0:
            return []
        h, w = mask.shape
        free = mask.any(axis=0)
        for bx, _, bw, _, _ in boxes:
            m = (1 - p.band_core) * bw / 2
            free[max(0, int(bx + m)):min(w, int(np.ceil(bx + bw - m)))] = False
        out = []
        edges = np.flatnonzero(np.diff(np.concatenate([[0], free.astype(np.int8), [0]])))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            if b - a < p.band_min_w * p.aspect * h:
                continue
            sub = mask[:, a:b]
            tops = sub.argmax(axis=0)
            t = int(tops.min())
            # each column's run of pixels down from its top (below a gap: someone nearer, e.g. their feet)
            ends = [c0 + int(np.argmin(np.append(sub[c0:, j], False))) for j, c0 in enumerate(tops)]
            bt = max(ends)
            if bt - t < p.band_min_h * h:
                continue
            near = [bb for bb in boxes if bb[0] <= b + 1 and bb[0] + bb[2] >= a - 1]  # the boxes it touches
            if any(bt > by + bh - p.band_feet * bh and bt - t < p.band_same * bh for _, by, _, bh, _ in near):
                continue  # feet level with a neighbour's (as near as it) but much shorter: its legs or arm
            wb = p.aspect * (bt - t)
            left, right = a > 0 and mask[:, a - 1].any(), b < w and mask[:, b].any()
            if right and not left:
                x0 = float(a)
            elif left and not right:
                x0 = float(b) - wb
            else:
                x0 = (a + b) / 2 - wb / 2
            x0, x1 = max(0.0, x0), min(float(w), x0 + wb)
            fill = float(mask[t:bt, int(x0):int(np.ceil(x1))].mean())
            out.append((x0, float(t), x1 - x0, float(bt - t), fill))
        return out

    def _heads(self, mask: np.ndarray) -> list[tuple[float, float, float, float, float]]:
        """People of a merged region, one per head: the heads are the tops of the region's upper outline
        (one row per column, smoothed over 0.1 of the region's height) that stand out by head_prominence of
        the height and lie head_spacing person widths apart; each person spans from its head to the lowest
        region pixel under it (within a quarter person width) and is aspect times that tall. Boxes of
        people one behind the other overlap, as their ground truth does."""
        p = self.params
        h, w = mask.shape
        width = p.aspect * h
        filled = mask.any(axis=0)
        top = np.where(filled, mask.argmax(axis=0), h).astype(np.float64)
        bottom = np.where(filled, h - 1 - mask[::-1].argmax(axis=0), -1)
        k = max(1, int(0.05 * h))
        smooth = np.convolve(np.pad(top, k, mode="edge"), np.ones(2 * k + 1) / (2 * k + 1), mode="valid")
        peaks, _ = find_peaks(np.concatenate([[-h], -smooth, [-h]]),  # padded: a head at the region's edge
                              distance=max(1.0, p.head_spacing * width), prominence=p.head_prominence * h)
        out = []
        half = max(1, int(0.25 * width))
        for c in peaks - 1:
            lo, hi = max(0, c - half), min(w, c + half + 1)
            t, b = int(top[lo:hi].min()), int(bottom[lo:hi].max()) + 1
            wi = p.aspect * (b - t)
            x0, x1 = max(0.0, c - wi / 2), min(float(w), c + wi / 2)
            if x1 <= x0 or b <= t:
                continue
            fill = float(mask[t:b, int(x0):int(np.ceil(x1))].mean())
            out.append((x0, float(t), x1 - x0, float(b - t), fill))
        return out


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
