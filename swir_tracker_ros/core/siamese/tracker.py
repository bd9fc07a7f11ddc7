# SPDX-License-Identifier: Apache-2.0
"""`SiameseTracker`: one-shot Siamese tracking (SiamFC / SiamRPN++ / SiamBAN) with NanoTrack v2 / v3 or
LightTrack-Mobile (Yan et al., CVPR 2021), each with its authors' procedure, OpenCV style.

`init(frame, box)` cuts the exemplar and keeps its features (the template stays fixed, as the authors
keep it; `set_exemplar` re-sets it from a box); `update(frame)` searches the region around the last
state (NanoTrack 255 px; LightTrack 256 px, or 288 px when the start box covers < 0.4 % of the frame) and
returns the box, the best score and the maps; `search(frame, cx, cy, w, h)` is the same search
around any centre and target size (re-detection windows), without touching the state. Per search (SiamRPN
Sec. 4.3 as NanoTrack's tracker does it): score = softmax foreground probability, per-point boxes from the
ltrb distances, penalty = exp(-(r_c s_c - 1) k), penalised map = (1 - w_i) penalty * score + w_i cosine,
best point = its argmax, lr = penalty * score * size_lr (ours: times min(1, g / size_gain_ref) to the
power size_gain_power, g the regression gain measured on the template's frame; power 0, the default, is the
authors' rate), new size = (1 - lr) old + lr regressed (LightTrack blends twice: (1 - lr^2) old + lr^2
regressed), clipped to the image. LightTrack's score is the sigmoid
its head applies, its whole-pixel crops those of its `get_subwindow_tracking` (exemplar side round(s_z)).
One-channel 8/16-bit frames go through the tracker's frame conditioning to 8 bits and are replicated to the
three channels of the network.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.conditioning import FrameConditioner, to_gray
from swir_tracker_ros.core.siamese.crops import (
    CropWindow,
    context_side,
    crop_window,
    cut,
    cut_subpixel,
    lighttrack_window,
    round_half_away,
)
from swir_tracker_ros.core.siamese.maps import (
    Boxes,
    change_penalty,
    clip_state,
    cosine_window,
    decode_ltrb,
    gain_factor,
    point_grid,
    regression_gain,
    size_update,
    size_update_twice,
    window_mix,
)
from swir_tracker_ros.core.siamese.network import network
from swir_tracker_ros.core.siamese.params import SiameseParams
from swir_tracker_ros.errors import TrackerError
from swir_tracker_ros.paramfield import validate_params
from swir_tracker_ros.types import Box, TrackState


@dataclass(frozen=True)
class SiameseDetection:
    """One search: the chosen point's box and scores, and the full maps for the layers above (PSR, peaks).

    Maps are (S, S), row = y, column = x; `score_map` is the foreground probability before any penalty,
    `penalised_map` the value the best point maximises (change penalty and cosine window applied)."""

    box: Box  # the chosen point's regressed box in image pixels (size not smoothed)
    smoothed: Box  # centre of `box`, size smoothed by lr from the searched size, clipped to the image
    score: float  # foreground probability at the chosen point
    pscore: float  # penalised map at the chosen point
    penalty: float  # change penalty at the chosen point
    lr: float  # penalty * score * size_lr
    index: tuple[int, int]  # (row, column) of the chosen point
    score_map: np.ndarray
    penalised_map: np.ndarray
    penalty_map: np.ndarray
    boxes: Boxes  # every point's box, search-crop pixels relative to the searched centre
    window: CropWindow  # the search crop in the image
    center: tuple[float, float]  # searched centre (image pixels)
    scale: float  # scale_z = exemplar / s_z: search-crop pixels per image pixel
    seconds: float  # cost of this search (crop, network, decoding)

    def point_box(self, row: int, col: int) -> Box:
        """The regressed box of grid point (row, col) in image pixels."""
        b, s = self.boxes, self.scale
        return Box.from_center(self.center[0] + b.cx[row, col] / s, self.center[1] + b.cy[row, col] / s,
                               b.w[row, col] / s, b.h[row, col] / s)


@dataclass(frozen=True)
class SiameseResult:
    """Outcome of `SiameseTracker.update`. The network never judges failure: `state` is always TRACKING
    (the layers above decide from the maps)."""

    box: Box
    score: float
    detection: SiameseDetection
    state: TrackState = TrackState.TRACKING

    @property
    def score_map(self) -> np.ndarray:
        return self.detection.score_map

    @property
    def penalised_map(self) -> np.ndarray:
        return self.detection.penalised_map


class SiameseTracker:
    """NanoTrack v2/v3 or LightTrack-M tracker (module docstring). Construction raises ParameterError on bad
    parameters and ModelError when the weights are missing or corrupt; init/update/search raise TrackerError
    on a bad box or frame."""

    def __init__(self, params: SiameseParams | None = None) -> None:
        params = SiameseParams() if params is None else params
        validate_params(params)  # ParameterError naming the parameter
        self.params = params
        self.constants = params.constants
        self.net = network(self.constants, params.model_dir or None, params.threads, params.precision)
        self.lighttrack = self.constants.family == "lighttrack"
        self.exemplar_size = self.constants.exemplar_size
        self.instance_size = self.constants.instance_size  # LightTrack: chosen with each template
        self._conditioner = FrameConditioner(params.conditioning)
        self._grid: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._fill: np.ndarray | None = None
        self.center: tuple[float, float] = (0.0, 0.0)
        self.size: tuple[float, float] = (0.0, 0.0)
        self.size_gain = 1.0  # regression gain g of the template's size test (1 without the test)

    # --- frames ------------------------------------------------------------------------------------------

    def prepare(self, frame: np.ndarray, bit_depth: int | None = None) -> np.ndarray:
        """The 8-bit image the network sees: an 8-bit gray or BGR frame as it is; any other frame (16-bit,
        float, or a conditioning that changes 8-bit frames) through the frame conditioning to 8-bit gray."""
        cfg = self.params.conditioning
        plain = cfg.stretch != "always" and cfg.dead_pixel_threshold == 0.0 and cfg.deinterlace == "off"
        if isinstance(frame, np.ndarray) and frame.dtype == np.uint8 and plain:
            img = frame[:, :, 0] if frame.ndim == 3 and frame.shape[2] == 1 else frame
            if img.ndim == 3 and img.shape[2] == 4:
                img = img[:, :, :3]
            if img.ndim == 2 or (img.ndim == 3 and img.shape[2] == 3):
                if min(img.shape[:2]) < 8:
                    raise TrackerError(f"frame of {img.shape[1]}x{img.shape[0]} pixels is too small to track")
                return img
            to_gray(img)  # raises the conditioning's error for a bad shape
        gray = self._conditioner(frame, bit_depth)
        return np.clip(gray * 255.0 + 0.5, 0, 255).astype(np.uint8)

    # --- template ----------------------------------------------------------------------------------------

    def set_exemplar(self, frame: np.ndarray, box: Box, bit_depth: int | None = None) -> None:
        """Cut the exemplar around `box` (127 / 128 px, context 0.5, mean padding) and keep its features; the
        padding colour becomes this frame's mean (LightTrack: the search crop's side follows the box's share
        of the frame). The tracking state is not changed."""
        if not isinstance(box, Box) or not box.is_valid():
            raise TrackerError(f"exemplar box must be finite with positive size, got {box}")
        img = self.prepare(frame, bit_depth)
        self._set_exemplar(img, box)

    def _set_exemplar(self, img: np.ndarray, box: Box) -> None:
        p, ex = self.params, self.exemplar_size
        self._fill = np.mean(img, axis=(0, 1))
        self.instance_size = self.constants.instance_for(box.w * box.h, img.shape[0] * img.shape[1])
        s_z = context_side(box.w, box.h, p.context_amount)
        if p.subpixel_crops:
            patch = cut_subpixel(img, box.cx, box.cy, s_z, ex, self._fill)
        elif self.lighttrack:  # the template side rounded (Python 3), as the authors' init
            patch = cut(img, lighttrack_window(box.cx, box.cy, max(1, round(s_z)), ex), self._fill)
        else:
            patch = cut(img, crop_window(box.cx, box.cy, s_z, ex), self._fill)
        self.net.set_exemplar(patch)
        self.size_gain = self._size_test(img, box) if p.size_gain_power > 0.0 else 1.0

    def _size_test(self, img: np.ndarray, box: Box) -> float:
        """The regression gain g on the template's own frame, where the target's size is known: the box
        searched at 1/size_test and size_test times its size (maps.regression_gain)."""
        f = self.params.size_test
        sizes = [self._search(img, box.cx, box.cy, box.w * k, box.h * k).box for k in (1.0 / f, f)]
        a = math.sqrt(box.w * box.h)
        return regression_gain((a / f, a * f), tuple(math.sqrt(b.w * b.h) for b in sizes))

    def init(self, frame: np.ndarray, box: Box, bit_depth: int | None = None) -> None:
        """Start tracking `box` in `frame`: exemplar features and state (centre, size)."""
        if not isinstance(box, Box) or not box.is_valid():
            raise TrackerError(f"initial box must be finite with positive size, got {box}")
        self._conditioner.reset()
        img = self.prepare(frame, bit_depth)
        self._set_exemplar(img, box)
        self.center, self.size = box.center, (box.w, box.h)

    # --- search ------------------------------------------------------------------------------------------

    def _maps(self, side: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(px, py, cosine window) of a score map of side S, made once per S (S comes from the model)."""
        if side not in self._grid:
            px, py = point_grid(side, self.params.stride)
            self._grid[side] = (px, py, cosine_window(side))
        return self._grid[side]

    def search(self, frame: np.ndarray, cx: float, cy: float, w: float, h: float,
               bit_depth: int | None = None) -> SiameseDetection:
        """Search the region (`instance_size` px) around (cx, cy) for the template, for a target of size
        (w, h); the state is not changed (module docstring)."""
        return self._search(self.prepare(frame, bit_depth), cx, cy, w, h)

    def _search(self, img: np.ndarray, cx: float, cy: float, w: float, h: float) -> SiameseDetection:
        if self._fill is None:
            raise TrackerError("the Siamese tracker has no template: call init() first")
        if not all(np.isfinite(v) for v in (cx, cy, w, h)) or w <= 0 or h <= 0:
            raise TrackerError(f"search around ({cx}, {cy}) for size {w}x{h}: not a finite positive size")
        t0 = time.perf_counter()
        p, c, inst = self.params, self.constants, self.instance_size
        s_z = context_side(w, h, p.context_amount)
        scale = self.exemplar_size / s_z
        s_x = s_z * inst / self.exemplar_size
        if self.lighttrack:
            win = lighttrack_window(cx, cy, max(1, round_half_away(s_x)), inst)
        else:
            win = crop_window(cx, cy, s_x, inst)
        if p.subpixel_crops:
            patch = cut_subpixel(img, cx, cy, s_x, inst, self._fill)
        else:
            patch = cut(img, win, self._fill)
        score, loc = self.net.search(patch)
        px, py, window = self._maps(score.shape[-1])
        boxes = decode_ltrb(loc, px, py)
        penalty = change_penalty(boxes, w * scale, h * scale, c.penalty_k)
        pmap = window_mix(penalty * score, window, c.window_influence)
        row, col = np.unravel_index(int(np.argmax(pmap)), pmap.shape)
        lr = float(penalty[row, col] * score[row, col] * c.size_lr
                   * gain_factor(self.size_gain, p.size_gain_ref, p.size_gain_power))
        bx, by = cx + boxes.cx[row, col] / scale, cy + boxes.cy[row, col] / scale
        bw, bh = boxes.w[row, col] / scale, boxes.h[row, col] / scale
        sw, sh = (size_update_twice if self.lighttrack else size_update)(w, h, bw, bh, lr)
        H, W = img.shape[:2]
        scx, scy, sw, sh = clip_state(bx, by, sw, sh, W, H, p.min_size)
        return SiameseDetection(
            Box.from_center(float(bx), float(by), float(bw), float(bh)),
            Box.from_center(scx, scy, sw, sh), float(score[row, col]), float(pmap[row, col]),
            float(penalty[row, col]), lr, (int(row), int(col)), score, pmap, penalty, boxes, win, (cx, cy),
            scale, time.perf_counter() - t0)

    def update(self, frame: np.ndarray, bit_depth: int | None = None) -> SiameseResult:
        """Track one frame: search around the last state, move to the chosen point, smooth the size."""
        det = self._search(self.prepare(frame, bit_depth), *self.center, *self.size)
        box = det.smoothed
        self.center, self.size = box.center, (box.w, box.h)
        return SiameseResult(box, det.score, det)
