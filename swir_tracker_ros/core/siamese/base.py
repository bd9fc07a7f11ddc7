# SPDX-License-Identifier: Apache-2.0
"""`SiameseBase`: the Siamese network tracker (core/siamese/tracker.py, any version) as a base filter of the
long-term tracker.

The policies hand a base filter windows of (1 + `padding`) x the target; the network searches its own
255 px crop (SiamFC: 255 / 127 x the exemplar's context side, about 4 x a square target) around a window's
centre for a target of the window's size over (1 + `padding`). Its box regression gives the size, so one
search answers the scale search (`own_scale`, as ECO and the DSST option do); re-detection windows are
searched one by one at the current size. The template is the first frame's and is never trained (as the
authors keep it), so it is also the long-term memory. Failure: the PSR of the score map (the
foreground probability over the S x S grid, before the change penalty and cosine window) below paper
000's threshold 7 (eq. 10): the network's own score stays near 1 after the target is lost, its map's
peak does not stand out of the sidelobe any more.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Sequence

import numpy as np

from swir_tracker_ros.core.base import BaseFilter
from swir_tracker_ros.core.confidence import PSR_FAILURE, apce, psr
from swir_tracker_ros.core.detection import Detection
from swir_tracker_ros.core.features import SmoothedFrame
from swir_tracker_ros.core.siamese.network import require
from swir_tracker_ros.core.siamese.params import SiameseParams
from swir_tracker_ros.core.siamese.tracker import SiameseDetection, SiameseTracker
from swir_tracker_ros.kalman import PAPER000_KCF, BoxModel, ThresholdMap, kcf_box_model
from swir_tracker_ros.types import Box

PSR_EXCLUSION = 5
"""Points of the score map left out of the sidelobe around the peak: the 5 x 5 points (80 x 80 crop px,
about the target's own extent in the 255 px crop) that a target's response covers."""


class SiameseBase(BaseFilter):
    """NanoTrack behind the base-filter interface (module docstring)."""

    name = "siamese"
    Params = SiameseParams
    robust_method = "A4"
    threshold_map: ThresholdMap = PAPER000_KCF
    own_scale = True
    can_lead = True  # the network tracks from its own state (policies/lead.py)
    learning_rate = 1.0  # the template is not trained: `train` only follows the posterior box

    def __init__(self, fp: SiameseParams, w: float, h: float) -> None:
        self.fp = fp
        self.net = SiameseTracker(fp)
        # a window's side over the target's: the search crop 255 / 127 x the context side
        # sqrt((w + p)(h + p)), p = context (w + h), for a square target
        self.padding = self.net.instance_size / self.net.exemplar_size * (1.0 + 2.0 * fp.context_amount) - 1.0
        self._frame: tuple[object, np.ndarray] | None = None  # (the frame it was made of, 8-bit image)
        self._found: list[SiameseDetection] = []

    @classmethod
    def check_resources(cls, fp: SiameseParams) -> None:
        """The network's weights, verified now (ModelError naming the file and the fix): a configuration on
        this filter refuses to start without them instead of failing when a target is picked."""
        require(fp.constants, fp.model_dir or None, fp.precision)

    # ------------------------------------------------------------------ frames
    def _image(self, img: np.ndarray) -> np.ndarray:
        """The 8-bit image the network sees, from the tracker's conditioned [0, 1] frame (once a frame; a
        pre-smoothed frame's raw pixels: the network's crops are resampled to its own scale already)."""
        if self._frame is None or self._frame[0] is not img:  # the frame is held: no id reuse
            gray = img.raw if isinstance(img, SmoothedFrame) else np.asarray(img)
            self._frame = (img, np.clip(gray * 255.0 + 0.5, 0.0, 255.0).astype(np.uint8))
        return self._frame[1]

    def _target(self, window: Box) -> tuple[float, float, float, float]:
        """Centre and target size of a policy's window ((1 + padding) x the target)."""
        f = 1.0 + self.padding
        return window.cx, window.cy, window.w / f, window.h / f

    def _detection(self, d: SiameseDetection, scale: float, window: Box, aspect: float = 1.0) -> Detection:
        r, c = d.index
        m = d.score_map
        return Detection(d.box.cx, d.box.cy, d.score, psr(m, r, c, PSR_EXCLUSION), apce(m), scale, window,
                         aspect)

    # ------------------------------------------------------------------ model
    def initialise(self, img: np.ndarray, box: Box) -> None:
        """The exemplar (127 px, context 0.5) of the start box: the template for the whole track."""
        self.net.set_exemplar(self._image(img), box)
        self.net.center, self.net.size = box.center, (box.w, box.h)

    def train(self, img: np.ndarray, box: Box, rate: float) -> None:
        """The template is not trained (NanoTrack keeps the first one); the state follows `box`."""
        self.net.center, self.net.size = box.center, (box.w, box.h)

    def failed(self, det: Detection) -> bool:
        """The score map's PSR below paper 000's 7 (module docstring); no state, so other windows can be
        tested too."""
        return det.psr < PSR_FAILURE

    def confident(self, det: Detection) -> bool:
        return True

    def box_model(self, w: float, h: float) -> BoxModel:
        return kcf_box_model()

    # ------------------------------------------------------------------ detection
    def detect_scales(self, img: np.ndarray, windows: Sequence[Box], scales: Sequence[float], penalty: float,
                      climb: bool, floor: float = 0.0) -> tuple[list[Detection], int, int]:
        """One search at the middle window; its regressed size (smoothed by the authors' size rate) over the
        window's target size is the scale and the aspect change, answering for every window (the middle
        one wins)."""
        mid = len(windows) // 2
        cx, cy, w, h = self._target(windows[mid])
        d = self.net.search(self._image(img), cx, cy, w, h)
        self._found = [d] * len(windows)
        size = math.sqrt(d.smoothed.w * d.smoothed.h / (w * h))
        aspect = (d.smoothed.w / d.smoothed.h) / (w / h)
        det = self._detection(d, scales[mid] * size, windows[mid], aspect)
        return [det] * len(windows), mid, 0

    def detect(self, img: np.ndarray, windows: Sequence[Box],
               scales: Sequence[float] | None = None) -> list[Detection]:
        """One search per window at its centre and target size (translation only)."""
        image = self._image(img)
        factors = scales if scales is not None else [1.0] * len(windows)
        self._found = [self.net.search(image, *self._target(win)) for win in windows]
        return [self._detection(d, s, win) for d, s, win in zip(self._found, factors, windows)]

    # ------------------------------------------------------------------ long-term memory
    def start_memory(self) -> None:
        """The template is fixed: it is the long-term memory already."""

    def memory_score(self, index: int) -> float:
        """The template's (the memory's) score on window `index` of the last detection call."""
        return self._found[index].score

    def train_memory(self, img: np.ndarray, box: Box, rate: float) -> None:
        """The template is fixed (module docstring): nothing to blend."""

    @contextlib.contextmanager
    def memory_as_filter(self) -> Iterator[None]:
        """The memory is the template itself: detections are unchanged."""
        yield

    def __repr__(self) -> str:
        w, h = self.net.size
        return f"SiameseBase({w:.1f}x{h:.1f})"
