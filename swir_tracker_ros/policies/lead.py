# SPDX-License-Identifier: Apache-2.0
"""`NetworkLead`: the Siamese network (core/siamese/, the base filter) leads the track with its own state; a
failure verdict (policies/gone.py) says when its answer is not the target, and a re-detection search that
widens with time finds the target again (issue 46).

Per frame: one search around the network's state (SiamFC / SiamRPN++ as the authors track:
`SiameseTracker`), judged by `GoneVerdict`; the state moves to the network's box (size smoothed by the
authors' rate). A frame the verdict accepts is `tracking` and its box the head's aim; one it rejects is
`occluded` (`lost` after `lost_after` frames) and the head keeps aiming at the last accepted box.

While the target is gone (re-detection mode): the network goes on following its own answer (as it tracks
alone: it often comes back by itself, and the frame's box is its answer, the state `occluded`, while the
head aims at the last accepted box: `TrackResult.aim`); each frame also searches the native-scale crop
around the last accepted box, then up to `tiles_per_frame - 1` crops of a lattice around it, nearest rings
first, the rings widening with time until the lattice covers the whole frame, then starting again from the
centre. The networks are fully convolutional but their heads take a fixed search size, so a larger area is
covered by more crops of the same size (each ~3-8 ms) rather than by one larger crop. The network's own
answer, else the best crop that passes the verdict's stricter resume bar (`GoneVerdict.resume_bar`),
restarts the track.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.siamese.crops import context_side
from swir_tracker_ros.core.siamese.tracker import SiameseDetection, SiameseTracker
from swir_tracker_ros.paramfield import nested, param
from swir_tracker_ros.policies.gone import GoneCues, GoneParams, GoneVerdict, cues
from swir_tracker_ros.types import Box, SearchMode, TrackResult, TrackState


@dataclass
class LeadParams:
    """(ours) The network leads: its failure verdict and its re-detection search (policies/lead.py)."""

    gone: GoneParams = nested(GoneParams, "the failure verdict of a network search (policies/gone.py)")
    lost_after: int = param(
        250, "frames in re-detection before the state becomes `lost` (the search goes on)", 1, 100000)
    tiles_per_frame: int = param(
        4, "crops searched per frame in re-detection mode besides the network's own search (the first at "
           "the last accepted box, the others on the lattice): sets its cost; 1 + 4 searches ran NanoTrack "
           "v3 at 31 CPU frames/s at 640x512 on one core (benchmarks/core_speed.py)", 1, 64)
    tile_overlap: float = param(
        0.25, "share of a crop's score-map coverage that neighbouring lattice crops overlap", 0.0, 0.9)
    velocity_rate: float = param(
        0.3, "weight of the newest accepted frame's displacement (ego shift removed) in the box velocity "
             "(exponential mean; TrackResult.velocity, the head's feed-forward)", 0.0, 1.0)


def coverage(w: float, h: float, tracker: SiameseTracker) -> float:
    """Image pixels spanned by the score map of one search for a target of w x h: (S - 1) stride points of
    the search crop, over the crop's scale exemplar / s_z (SiamFC's context side s_z)."""
    ex = tracker.exemplar_size
    side = tracker.instance_size - ex  # the map's span in crop pixels ((S - 1) * stride, +-1 point)
    return side * context_side(w, h, tracker.params.context_amount) / ex


def lattice(cx: float, cy: float, step: float, width: int, height: int) -> list[tuple[float, float]]:
    """Centres of a square lattice of spacing `step` around (cx, cy) that lie in the image (within half a
    step of it), ring by ring outwards (ring 0: the centre itself); the rings stop when one has no centre
    in the image, i.e. the lattice covers the whole frame."""
    out: list[tuple[float, float]] = [(cx, cy)]
    ring = 1
    while True:
        found = []
        for i in range(-ring, ring + 1):
            for j in range(-ring, ring + 1):
                if max(abs(i), abs(j)) != ring:
                    continue
                x, y = cx + i * step, cy + j * step
                if -0.5 * step <= x <= width + 0.5 * step and -0.5 * step <= y <= height + 0.5 * step:
                    found.append((math.hypot(i, j), x, y))
        if not found:
            return out
        out += [(x, y) for _, x, y in sorted(found)]
        ring += 1


def _crop(det: SiameseDetection) -> Box:
    """The image area a search's crop covered (TrackResult.search_windows)."""
    w = det.window
    return Box(float(w.x0), float(w.y0), float(w.side), float(w.side))


class NetworkLead:
    """The per-track state of a network-led track (module docstring)."""

    def __init__(self, p: LeadParams, tracker: SiameseTracker) -> None:
        self.p = p
        self.net = tracker
        self.verdict = GoneVerdict(p.gone)
        self.box = Box(0.0, 0.0, 0.0, 0.0)  # the last accepted box, input pixels
        self.missed = 0  # frames since the last accepted one
        self._tiles: list[tuple[float, float]] = []  # the re-detection lattice still to search
        self.init_size = (0.0, 0.0)
        self.velocity = (0.0, 0.0)  # input pixels per frame, ego shifts removed (accepted frames)

    def start(self, frame: np.ndarray, box: Box, bit_depth: int | None) -> None:
        """The network's template and state from the start box (input pixels)."""
        self.net.init(frame, box, bit_depth)
        self.verdict.reset()
        self.box, self.missed, self._tiles = box, 0, []
        self.init_size = (box.w, box.h)
        self.velocity = (0.0, 0.0)

    def step(self, frame: np.ndarray, bit_depth: int | None, ego_shift: tuple[float, float]) -> TrackResult:
        """One frame (module docstring); TrackerError on an unusable frame (the caller keeps the track)."""
        image = self.net.prepare(frame, bit_depth)
        dx, dy = ego_shift
        self.box = Box(self.box.x + dx, self.box.y + dy, self.box.w, self.box.h)
        cx, cy = self.net.center
        self.net.center = (cx + dx, cy + dy)
        det = self.net.search(image, *self.net.center, *self.net.size)  # the network's own search
        c = cues(det)
        gone = self.verdict.judge_cues(c)
        shown: tuple[Box, ...] = (_crop(det),)
        mode = SearchMode.NORMAL
        if gone:
            found = [(d, cues(d)) for d in self._redetect(image)]
            shown += tuple(_crop(d) for d, _ in found)
            mode = SearchMode.MULTI_WINDOW
            bar = self.verdict.resume_bar()  # the stricter bar of a target found again
            ok = [(d, k) for d, k in found if k.psr >= bar and k.score >= self.verdict.p.score_gone]
            if ok:
                det, c = max(ok, key=lambda dk: dk[0].score)
                gone = self.verdict.judge_cues(c)  # the verdict's own state: found again
        box = det.smoothed  # the network follows its answer, judged or not (as it tracks alone)
        self.net.center, self.net.size = box.center, (box.w, box.h)
        if not gone:
            if self.missed == 0:  # two accepted frames in a row: their displacement is the target's
                a, (vx, vy) = self.p.velocity_rate, self.velocity
                self.velocity = (vx + a * (box.cx - self.box.cx - vx), vy + a * (box.cy - self.box.cy - vy))
            self.box, self.missed, self._tiles = box, 0, []
            return self._result(box, TrackState.TRACKING, c, mode, shown)
        self.missed += 1
        state = TrackState.OCCLUDED if self.missed <= self.p.lost_after else TrackState.LOST
        return self._result(box, state, c, mode, shown, aim=self.box)

    def _redetect(self, image: np.ndarray) -> list[SiameseDetection]:
        """The centre crop at the last box, then the next crops of the widening lattice (module docstring)."""
        b = self.box
        if not self._tiles:
            h, w = image.shape[:2]
            step = (1.0 - self.p.tile_overlap) * coverage(b.w, b.h, self.net)
            self._tiles = lattice(b.cx, b.cy, max(step, 1.0), w, h)[1:]
        take, self._tiles = self._tiles[:self.p.tiles_per_frame - 1], self._tiles[self.p.tiles_per_frame - 1:]
        return [self.net.search(image, cx, cy, b.w, b.h) for cx, cy in [(b.cx, b.cy), *take]]

    def _result(self, box: Box, state: TrackState, c: GoneCues, mode: SearchMode, shown: tuple[Box, ...],
                aim: Box | None = None) -> TrackResult:
        w0, h0 = self.init_size
        scale = math.sqrt(box.w * box.h / (w0 * h0)) if w0 > 0 and h0 > 0 else 1.0
        return TrackResult(box=box, state=state, peak=c.score, psr=c.psr, apce=c.apce, search_mode=mode,
                           measured=aim is None, scale=scale, search_windows=shown,
                           velocity=self.velocity if aim is None else (0.0, 0.0), aim=aim)
