# SPDX-License-Identifier: Apache-2.0
"""`NetworkLead`: the Siamese network (core/siamese/, the base filter) leads the track with its own state; two
judges say when its answer is not the target: its appearance (policies/gone.py) and its motion (the track's
robust Kalman filter, policies/motion.py), and a re-detection search around the motion's prediction, widening
with time to the whole frame, finds the target again (issues 46, 52).

One pipeline per frame (`step`), the stages of `Tracker._step` in the network's terms:

1. predict: the Kalman prediction (constant velocity, ego shifts applied: `MotionFilter.predict`);
2. search: one network search around its own state (SiamFC / SiamRPN++ as the authors track:
   `SiameseTracker`); while the target is gone, also the crop at the prediction and the next crops of a
   lattice around it (`_redetect`);
3. judge: while tracking, the appearance verdict (`GoneVerdict`) and the motion gate (`off_path`: the box
   left the predicted path by more than `jump_gate` target sizes) and the look-alike guard (a box that left
   the trail's motion reference is taken back by an answer at the reference: `_take_back`); while gone, a
   candidate resumes only when its appearance passes the stricter resume bar, its size is the target's
   (`resume_size`) and its place is one the motion allows (`resume_radius` plus, per missed frame,
   `resume_growth` and `resume_speed` x the target's speed, around the prediction), or, after `long_loss`
   frames, when it is a strong match (`strong_ratio` x the target's typical PSR) anywhere; one away from the
   prediction must show itself on two frames (`_confirmed`), and while the network's own answer holds the
   predicted place no other crop may take the track (`_holds`); distances are in target sizes of at least
   `gate_size` pixels;
4. update the motion: only an accepted box updates the Kalman filter (`MotionFilter.update`; a resume far
   from the prediction restarts it: `MotionFilter.jump`); a missed frame coasts it (`CoastModel`: the trail's
   velocity first, then held after `coast.frames`);
5. finish: an accepted frame is `tracking` and its box is the network's own (the Kalman filter predicts, it
   never smooths the box); a rejected one is `occluded` (`lost` after `lost_after` frames), its box the
   network's answer while that stays on the predicted path, else the prediction, and the head aims at the
   prediction (`TrackResult.aim`).

The network goes on following its own answer while the target is gone (as it tracks alone: it often comes
back by itself). The networks are fully convolutional but their heads take a fixed search size, so a larger
area is covered by more crops of the same size (each ~3-8 ms) rather than by one larger crop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from swir_tracker_ros.core.siamese.crops import context_side
from swir_tracker_ros.core.siamese.tracker import SiameseDetection, SiameseTracker
from swir_tracker_ros.paramfield import nested, param
from swir_tracker_ros.policies.coast import CoastModel
from swir_tracker_ros.policies.gone import GoneCues, GoneParams, GoneVerdict, cues
from swir_tracker_ros.policies.lookalike import LookalikeGuard
from swir_tracker_ros.policies.motion import MotionFilter
from swir_tracker_ros.policies.second import Opinion, SecondOpinion, SecondParams
from swir_tracker_ros.policies.trail import Trail
from swir_tracker_ros.types import Box, SearchMode, TrackState


@dataclass
class LeadParams:
    """(ours) The network leads: its failure verdicts (appearance and motion) and its re-detection search
    (policies/lead.py)."""

    gone: GoneParams = nested(GoneParams, "the appearance verdict of a network search (policies/gone.py)")
    lost_after: int = param(
        250, "frames in re-detection before the state becomes `lost` (the search goes on)", 1, 100000)
    tiles_per_frame: int = param(
        4, "crops searched per frame in re-detection mode besides the network's own search (the first at "
           "the prediction, the others on the lattice around it): sets its cost; 1 + 4 searches ran "
           "NanoTrack v3 at 31 CPU frames/s at 640x512 on one core (benchmarks/core_speed.py)", 1, 64)
    tile_overlap: float = param(
        0.25, "share of a crop's score-map coverage that neighbouring lattice crops overlap", 0.0, 0.9)
    jump_gate: float = param(
        2.0, "motion gate of a tracked frame: the box is rejected when its centre lies more than this many "
             "target sizes (sqrt(w h) of the last accepted box) from the Kalman prediction; 0: off",
        0.0, 100.0)
    resume_radius: float = param(
        0.5, "a candidate resumes the track only within this many target sizes of the prediction, plus "
             "`resume_growth` a missed frame", 0.0, 100.0)
    resume_growth: float = param(
        0.02, "target sizes the resume radius grows per missed frame, plus `resume_speed` x the target's "
              "speed (target sizes a frame) when it was lost: the prediction's uncertainty grows faster for "
              "a moving target than for a standing one", 0.0, 10.0)
    resume_speed: float = param(
        0.5, "share of the target's speed at the loss by which the resume radius grows per missed frame",
        0.0, 10.0)
    gate_size: float = param(
        32.0, "pixels: a target smaller than this counts as this size in the motion gates (distances in "
              "target sizes): a small target's box jitters, and the camera shakes, by more than its size",
        1.0, 10000.0)
    resume_size: float = param(
        1.5, "a candidate near the prediction resumes the track only when its regressed size lies within "
             "this factor of the last accepted size (either way): a box grown onto an occluder or shrunk "
             "onto a part is not the target", 1.0, 100.0)
    long_loss: int = param(
        50, "frames after which a strong match (`strong_ratio`) resumes the track anywhere in the frame",
        1, 100000)
    strong_ratio: float = param(
        0.1, "a strong match: PSR at least this x the target's typical tracked PSR (and the resume bar)",
        0.0, 10.0)
    second: SecondParams | None = nested(
        lambda: None, "(issue 53) a second network's opinion and the judge that picks whose box stands "
                      "(policies/second.py); none: the leader alone")


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


def off_path(box: Box, pred: Box, size: float) -> float:
    """The distance of `box`'s centre from the prediction's, in target sizes (`size` pixels); pure."""
    return math.hypot(box.cx - pred.cx, box.cy - pred.cy) / max(size, 1e-6)


@dataclass(frozen=True)
class LeadFrame:
    """What one frame of a network-led track decided (`NetworkLead.step`); `Tracker` makes the TrackResult."""

    box: Box  # the frame's box, input pixels
    state: TrackState
    cues: GoneCues  # of the chosen search
    mode: SearchMode
    shown: tuple[Box, ...]  # the crops searched
    aim: Box | None  # where the head aims when not at `box` (a rejected frame: the prediction)


def _crop(det: SiameseDetection) -> Box:
    """The image area a search's crop covered (TrackResult.search_windows)."""
    w = det.window
    return Box(float(w.x0), float(w.y0), float(w.side), float(w.side))


class NetworkLead:
    """The per-track state of a network-led track (module docstring); the motion policies are the track's
    (`Track`: `MotionFilter`, `CoastModel`, `Trail`), shared with the correlation-filter pipeline."""

    def __init__(self, p: LeadParams, tracker: SiameseTracker) -> None:
        self.p = p
        self.net = tracker
        self.verdict = GoneVerdict(p.gone)
        self.box = Box(0.0, 0.0, 0.0, 0.0)  # the last accepted box, input pixels
        self.missed = 0  # frames since the last accepted one
        self._tiles: list[tuple[float, float]] = []  # the re-detection lattice still to search
        self._speed = 0.0  # the target's speed when it was lost, target sizes a frame
        self._pending: Box | None = None  # a candidate away from the prediction, to be confirmed
        self.second = SecondOpinion(p.second, tracker) if p.second is not None else None
        self.opinion: Opinion | None = None  # what the second said on this frame (None: it did not look)

    def start(self, frame: np.ndarray, box: Box, bit_depth: int | None) -> None:
        """The network's template and state from the start box (input pixels)."""
        self.net.init(frame, box, bit_depth)
        if self.second is not None:
            self.second.start(frame, box, bit_depth)
        self.verdict.reset()
        self.box, self.missed, self._tiles = box, 0, []

    def step(self, frame: np.ndarray, bit_depth: int | None, ego_shift: tuple[float, float], frames: float,
             motion: MotionFilter, coast: CoastModel, trail: Trail,
             guard: LookalikeGuard | None = None) -> LeadFrame:
        """One frame (module docstring); TrackerError on an unusable frame (the caller keeps the track)."""
        image = self.net.prepare(frame, bit_depth)
        dx, dy = ego_shift
        pred = motion.predict(frames, dx, dy)  # 1. predict
        trail.advance(frames, dx, dy)
        self.box = Box(self.box.x + dx, self.box.y + dy, self.box.w, self.box.h)
        pred = Box.from_center(pred.cx, pred.cy, self.box.w, self.box.h)  # the size: the last accepted one
        cx, cy = self.net.center
        self.net.center = (cx + dx, cy + dy)
        det = self.net.search(image, *self.net.center, *self.net.size)  # 2. search: the network's own
        c = cues(det)
        size = max(math.sqrt(self.box.w * self.box.h), self.p.gate_size)  # the motion gates' unit
        shown: tuple[Box, ...] = (_crop(det),)
        self.opinion = None
        if self.second is not None:
            self.second.shift(dx, dy)
            looks = self.missed == 0 or self.second.p.while_gone
            if looks and self.second.due(c):  # 2b. the second opinion, and the judge
                self.opinion = self.second.look(image, det, c, lambda b: off_path(b, pred, size))
                shown += (_crop(self.opinion.det),)
                if self.opinion.stands and self._departs(self.opinion.det.smoothed, guard):
                    self.opinion = replace(self.opinion, stands=False)  # the motion vetoes a look-alike
                follows = self.missed == 0 and self.second.p.lead_follows
                if self.opinion.stands and follows:  # the leader looks there and takes that answer
                    b = self.opinion.det.smoothed
                    det = self.net.search(image, b.cx, b.cy, *self.net.size)
                    c = cues(det)
                    shown += (_crop(det),)
        mode = SearchMode.NORMAL
        resumed, gone, velocity = False, True, None
        if self.missed == 0:  # 3. judge a tracked frame: appearance, then motion
            gone = self.verdict.judge_cues(c)
            jumped = self.p.jump_gate > 0.0 and off_path(det.smoothed, pred, size) > self.p.jump_gate
            if jumped and not gone:
                gone = self.verdict.gone = True  # it jumped further than the motion allows
            if not gone and guard is not None:  # a look-alike takes the box along: the motion takes it back
                back = self._take_back(image, det, guard)
                if back is not None:
                    det, c, velocity = back
                    shown += (_crop(det),)
        if gone and self.missed > 0 and self._agreed(det, pred, size):  # two opinions agree: found again
            self.verdict.gone, resumed, gone = False, True, False
        if gone:  # 3. while gone: candidates must pass the resume bar where the motion allows
            found = [(det, c)] + [(d, cues(d)) for d in self._redetect(image, pred)]
            shown += tuple(_crop(d) for d, _ in found[1:])
            mode = SearchMode.MULTI_WINDOW
            ok = [(d, k) for d, k in found[:1] if self._resumes(d, k, pred, size)]
            if not ok and not self._holds(det, c, pred, size):  # other crops only when its own answer left
                ok = [(d, k) for d, k in found[1:] if self._resumes(d, k, pred, size)]
            if ok:  # the nearest to the prediction: the motion is the tie-break between look-alikes
                best, k = min(ok, key=lambda dk: off_path(dk[0].smoothed, pred, size))
                if self._confirmed(best.smoothed, pred, size):
                    det, c = best, k
                    self.verdict.judge_cues(c)  # the verdict's own state: found again
                    resumed, gone = True, False
            else:
                self._pending = None
        box = det.smoothed  # the network follows its answer, judged or not (as it tracks alone), but while
        self.net.center = box.center  # the target is gone its size stays the last accepted one (it would
        self.net.size = (box.w, box.h) if not gone else (self.box.w, self.box.h)  # grow onto an occluder)
        if not gone and self.opinion is not None:  # the standing box; two that agree: their blend
            box = self.second.joined(box, self.opinion)  # type: ignore[union-attr]
        if not gone:  # 4. an accepted box updates the motion; 5. finish
            z, k = motion.measurement(box.cx, box.cy, box.w, box.h), motion.threshold(c.score)
            if resumed and off_path(box, pred, size) > self._radius():
                motion.jump(z, k)  # found again away from the prediction: the motion restarts there
            else:
                motion.update(z, k)
            if velocity is not None:  # taken back: the reference's motion, from before the look-alike
                motion.set_velocity(*velocity)
            trail.remember(box)
            if resumed and self.second is not None:
                self.second.move(box)  # found again: the second looks there too
            elif self.second is not None and self.opinion is None:  # between looks: it moves with the track
                self.second.shift(box.cx - self.box.cx, box.cy - self.box.cy)
            self.box, self.missed, self._tiles, self._pending = box, 0, [], None
            return LeadFrame(box, TrackState.TRACKING, c, mode, shown, None)
        if self.missed == 0:
            coast.start(motion, trail)
            self._speed = math.hypot(*motion.velocity()) / max(size, 1e-6)
        self.missed += 1
        coast.redetecting(motion, self.missed)
        state = TrackState.OCCLUDED if self.missed <= self.p.lost_after else TrackState.LOST
        if self.opinion is not None and self.opinion.stands:  # the judge prefers the second's answer
            return LeadFrame(self.opinion.det.smoothed, state, c, mode, shown, pred)
        on_path = off_path(box, pred, size) <= self.p.resume_radius  # its answer, else the prediction
        return LeadFrame(box if on_path else pred, state, c, mode, shown, pred)

    def _take_back(self, image: np.ndarray, det: SiameseDetection, guard: LookalikeGuard
                   ) -> tuple[SiameseDetection, GoneCues, tuple[float, float]] | None:
        """The look-alike guard (policies/lookalike.py) in the network's terms: a tracked box that left the
        trail's motion reference is searched at the reference too; an answer there, apart from the first,
        that passes the resume bar and scores at least `ratio` x the first takes the box back, and the motion
        takes the reference's velocity."""
        b, (w, h) = det.smoothed, (self.box.w, self.box.h)
        ref = guard.departure(b.cx, b.cy, w, h)
        if ref is None:
            return None
        alt = self.net.search(image, ref[0], ref[1], w, h)
        a, k = alt.smoothed, cues(alt)
        if (guard.takes_back((a.cx, a.cy), (b.cx, b.cy), ref, w, h) and alt.score >= guard.p.ratio * det.score
                and k.psr >= self.verdict.resume_bar()):
            guard.taken_back()
            return alt, k, (ref[2], ref[3])
        return None

    def _agreed(self, det: SiameseDetection, pred: Box, size: float) -> bool:
        """While gone, the second opinion finds the target where the leader's own answer is: the two boxes
        agree (`agree_iou`), the second's PSR is at least its typical one, the leader's size is the
        target's (`resume_size`) and its place one the motion allows (the resume radius around the
        prediction) (`SecondParams.agree_resumes`)."""
        o, s = self.opinion, self.second
        if o is None or s is None or not s.p.agree_resumes or not s.confident(o.cues):
            return False
        a = det.smoothed
        if off_path(a, pred, size) > self._radius():
            return False
        return a.iou(o.det.smoothed) >= s.p.agree_iou and self._sized(a)

    def _sized(self, box: Box) -> bool:
        """`box` has the target's size: its side (sqrt(w h)) within `resume_size` of the last accepted
        box's, either way (a box grown onto an occluder or shrunk onto a part is not the target)."""
        grow = math.sqrt(box.w * box.h / max(self.box.w * self.box.h, 1e-12))
        return 1.0 / self.p.resume_size <= grow <= self.p.resume_size

    def _departs(self, box: Box, guard: LookalikeGuard | None) -> bool:
        """A box the look-alike guard would not let the track take: its centre lies further than the guard's
        `distance` from the trail's motion reference (box widths and heights of the last accepted box)."""
        ref = guard.reference() if guard is not None else None
        if ref is None:
            return False
        return guard.apart(box.cx, box.cy, ref[0], ref[1], self.box.w, self.box.h) > guard.p.distance

    def _radius(self) -> float:
        """The resume radius in target sizes after `missed` frames (LeadParams)."""
        p = self.p
        return p.resume_radius + (p.resume_growth + p.resume_speed * self._speed) * self.missed

    def _confirmed(self, box: Box, pred: Box, size: float) -> bool:
        """A candidate at the predicted place (within `resume_radius`) resumes at once; one away from it only
        when the frame before had a candidate within `resume_radius` target sizes of it too (a look-alike's
        one-frame peak is not the target coming back)."""
        near = off_path(box, pred, size) <= self.p.resume_radius
        seen = self._pending is not None and off_path(box, self._pending, size) <= self.p.resume_radius
        self._pending = None if near or seen else box
        return near or seen

    def _holds(self, det: SiameseDetection, c: GoneCues, pred: Box, size: float) -> bool:
        """The network's own answer still holds the predicted place: within `resume_radius` of the
        prediction, above the lower bars (a map made ambiguous by a look-alike beside the target, not a
        lost target): no other candidate may take the track then (the motion decides between look-alikes)."""
        g = self.verdict.p
        return (off_path(det.smoothed, pred, size) <= self.p.resume_radius and c.psr >= g.psr_gone
                and c.score >= g.score_gone)

    def _resumes(self, det: SiameseDetection, c: GoneCues, pred: Box, size: float) -> bool:
        """A candidate resumes the track: the appearance's resume bar, and a place the motion allows (or,
        after a long loss, a strong match anywhere)."""
        v = self.verdict
        if c.psr < v.resume_bar() or c.score < v.p.score_gone:
            return False
        if off_path(det.smoothed, pred, size) <= self._radius():
            return self._sized(det.box)
        typical = math.exp(v.typical) if v.typical is not None else 0.0
        return self.missed >= self.p.long_loss and c.psr >= self.p.strong_ratio * typical

    def _redetect(self, image: np.ndarray, pred: Box) -> list[SiameseDetection]:
        """The crop at the prediction, then the next crops of the widening lattice around it: the rings
        within reach of the resume radius before a long loss (farther candidates could not resume), the whole
        frame after it; an exhausted lattice starts again from the prediction."""
        b = self.box
        if not self._tiles:
            h, w = image.shape[:2]
            span = coverage(b.w, b.h, self.net)
            step = max((1.0 - self.p.tile_overlap) * span, 1.0)
            tiles = lattice(pred.cx, pred.cy, step, w, h)[1:]
            if self.missed < self.p.long_loss:
                reach = self._radius() * math.sqrt(b.w * b.h) + 0.5 * span
                tiles = [(x, y) for x, y in tiles if math.hypot(x - pred.cx, y - pred.cy) <= reach]
            self._tiles = tiles
        n = self.p.tiles_per_frame - 1
        again = [] if self._pending is None or n < 1 else [self._pending.center]  # to confirm: look again
        k = n - len(again)
        take, self._tiles = self._tiles[:k], self._tiles[k:]
        return [self.net.search(image, cx, cy, b.w, b.h) for cx, cy in [(pred.cx, pred.cy), *again, *take]]
