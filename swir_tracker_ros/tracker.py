# SPDX-License-Identifier: Apache-2.0
"""Long-term SWIR tracker: correlation filter + Kalman prediction + re-detection (paper 000, dissertation)."""

from __future__ import annotations

import math

import cv2
import numpy as np

from swir_tracker_ros.configs import DEFAULT_CONFIGURATION, configuration
from swir_tracker_ros.core import fhog
from swir_tracker_ros.core.base import Detection
from swir_tracker_ros.core.conditioning import FrameConditioner
from swir_tracker_ros.core.features import SmoothedFrame
from swir_tracker_ros.core.registry import filter_class, make_filter
from swir_tracker_ros.core.windows import search_window
from swir_tracker_ros.errors import KalmanError, TrackerError
from swir_tracker_ros.policies.fusion import NetworkFusion
from swir_tracker_ros.track import Frame, Track
from swir_tracker_ros.tracker_params import TrackerParams
from swir_tracker_ros.types import Box, SearchMode, TrackResult, TrackState

__all__ = ["Tracker", "TrackerParams"]

_RECOVERABLE = (TrackerError, KalmanError, cv2.error, ValueError, ArithmeticError, np.linalg.LinAlgError)


def _as_box(box: object) -> Box:
    if isinstance(box, Box):
        return box
    try:
        x, y, w, h = (float(v) for v in box)  # type: ignore[union-attr]
    except (TypeError, ValueError) as exc:
        raise TrackerError(f"init box must be a Box or (x, y, w, h), got {box!r}") from exc
    return Box(x, y, w, h)


class Tracker:
    """Single-object tracker; `init(frame, box)` then `update(frame)` once per frame (docs/tracking_core.md).

    A configuration (configs/) names the base filter and the policies (policies/) around it: the papers'
    loop (paper 000 Fig. 2, dissertation §1.7: Kalman prediction, scale search, PSR / APCE failure test,
    re-detection around the prediction, robust Kalman update, gated model update; `_step`), the bare
    correlation filter (`cf`, `_step_cf`), or the Siamese network leading with its own state (`lead`).
    """

    def __init__(self, params: TrackerParams | None = None) -> None:
        self.params = params if params is not None else configuration(DEFAULT_CONFIGURATION)
        self.params.validate()
        filter_class(self.params.base).check_resources(self.params.base)  # ModelError without its weights
        self._conditioner = FrameConditioner(self.params.conditioning)
        self._fusion = NetworkFusion(self.params.fusion) if self.params.fusion is not None else None
        self.reset()

    @staticmethod
    def warm_up() -> bool:
        """Load (on a fresh install: compile) the core's compiled loops now rather than on the first
        frame (~1 s with numba's on-disk cache); for a node to call at start-up. True if they are in use."""
        return fhog.warm_up()

    # ------------------------------------------------------------------ public API
    @property
    def state(self) -> TrackState:
        return self._state

    def reset(self) -> None:
        """Forget the target (state idle)."""
        self._state = TrackState.IDLE
        self._conditioner.reset()
        self._track: Track | None = None
        self._sigma = 0.0  # `presmooth` blur of the conditioned frames, pixels

    def init(self, frame: np.ndarray, box: Box | tuple, bit_depth: int | None = None) -> None:
        """Start tracking `box` (input pixels) in `frame`; TrackerError with a reason if unusable."""
        self.reset()
        box = _as_box(box)
        if not box.is_valid() or box.w < 1.0 or box.h < 1.0:
            raise TrackerError(
                f"init box {box.as_tuple()} must be finite with width and height of at least 1 pixel"
            )
        if not isinstance(frame, np.ndarray):
            raise TrackerError(f"frame must be a numpy array, got {type(frame).__name__}")
        if bit_depth is not None and not (1 <= int(bit_depth) <= 16):
            raise TrackerError(f"bit_depth={bit_depth!r} must be between 1 and 16")
        p = self.params
        if p.lead is None:
            img = self._conditioner(frame, bit_depth)  # ConditioningError is a TrackerError
        ih, iw = frame.shape[:2]
        if not (0.0 <= box.cx < iw and 0.0 <= box.cy < ih):
            raise TrackerError(f"init box {box.as_tuple()} has its centre outside the {iw}x{ih} image")
        ds = p.conditioning.downscale
        b = Box(box.x * ds, box.y * ds, box.w * ds, box.h * ds)
        self._sigma = p.presmooth * math.sqrt(b.w * b.h)
        base = make_filter(p.base, b.w, b.h)  # the configuration's base filter, selected once
        if p.lead is None:
            base.initialise(self._smoothed(img), b)
        self._track = Track(p, base, b, frame.shape)
        if self._track.lead is not None:  # the network leads from the raw frame (policies/lead.py)
            self._track.lead.start(frame, box, bit_depth)
        if self._fusion is not None:
            self._fusion.start(frame, box, bit_depth)
        self._state = TrackState.TRACKING

    def update(
        self,
        frame: np.ndarray,
        ego_shift: tuple[float, float] = (0.0, 0.0),
        bit_depth: int | None = None,
        frames: float = 1.0,
    ) -> TrackResult:
        """Track one frame. Never raises on an ndarray: unusable input gives a `lost` result.

        `frames`: time since the previous update in frame periods (> 1 when frames were skipped); the
        Kalman prediction advances by that many periods. A non-finite or non-positive value counts as 1.
        """
        t = self._track
        if self._state is TrackState.IDLE or t is None:
            return TrackResult(box=Box(0.0, 0.0, 0.0, 0.0), state=TrackState.IDLE)
        if self._state is TrackState.LOST and t.lead is None:
            return self._result(t.box, TrackState.LOST)
        try:
            if not isinstance(frame, np.ndarray) or frame.shape[:2] != t.frame_shape[:2]:
                raise TrackerError("frame size differs from the init frame")
            if bit_depth is not None and not (1 <= int(bit_depth) <= 16):
                raise TrackerError(f"bit_depth={bit_depth!r} must be between 1 and 16")
            dx, dy = (float(v) for v in ego_shift)
            if not (math.isfinite(dx) and math.isfinite(dy)):
                dx = dy = 0.0
            frames = float(frames)
            if not (math.isfinite(frames) and frames > 0.0):
                frames = 1.0
            if t.lead is not None:  # the network leads (policies/lead.py); a bad frame keeps its track
                assert t.motion is not None
                f = t.lead.step(frame, bit_depth, (dx, dy), frames, t.motion, t.coast, t.trail, t.lookalike)
                self._state = f.state
                c = f.cues
                det = Detection(f.box.cx, f.box.cy, c.score, c.psr, c.apce, 1.0, f.box)
                return self._result(f.box, f.state, det=det, mode=f.mode, measured=f.aim is None,
                                    windows=f.shown, aim=f.aim)
            img = self._smoothed(self._conditioner(frame, bit_depth))
        except (*_RECOVERABLE, TypeError):
            return self._result(t.lead.box if t.lead else t.box, TrackState.LOST)  # transient: track kept
        try:
            if t.motion is None:
                return self._step_cf(t, img)
            ds = self.params.conditioning.downscale
            res = self._step(t, img, dx * ds, dy * ds, frames)
            return res if self._fusion is None else self._fusion.result(frame, bit_depth, res, (dx, dy))
        except _RECOVERABLE:
            self._state = TrackState.LOST
            return self._result(t.box, TrackState.LOST)

    def _smoothed(self, img: np.ndarray) -> np.ndarray | SmoothedFrame:
        """The conditioned frame as the windows sample it: blurred by `presmooth` (where they read it)."""
        return SmoothedFrame(img, self._sigma) if self._sigma > 0.0 else img

    # ------------------------------------------------------------------ per-frame steps
    def _step_cf(self, t: Track, img: np.ndarray) -> TrackResult:
        """Bare correlation filter: one window at the last position, fixed size, update every frame."""
        base, box = t.base, t.box
        win = search_window(box.cx, box.cy, box.w, box.h, base.padding)
        det = base.detect(img, [win])[0]
        t.box = Box.from_center(det.cx, det.cy, box.w, box.h)
        base.train(img, t.box, base.learning_rate)
        return self._result(t.box, TrackState.TRACKING, det=det, measured=True, updated=True, windows=(win,))

    def _step(self, t: Track, img: np.ndarray, dx: float, dy: float, frames: float) -> TrackResult:
        """One frame, stage by stage (docs/tracking_core.md "Per-frame loop")."""
        pred = self._predict(t, img, dx, dy, frames)
        if pred is None:
            return self._result(t.box, TrackState.LOST)
        f = self._search_scales(t, img, pred)
        f.failed = t.verdict.failed(f.det)
        self._guard_lookalike(t, f)
        self._redetect(t, f)
        self._reacquire(t, f)
        self._sweep(t, f)
        self._update_motion(t, f)
        self._update_model(t, f)
        return self._finish(t, f)

    def _predict(self, t: Track, img: np.ndarray, dx: float, dy: float, frames: float) -> Box | None:
        """1. The Kalman prediction over `frames` periods plus the ego shift; None: it left the image and
        the track is lost (the sweep holds it at the border while re-detecting)."""
        motion = t.motion
        assert motion is not None
        pred = motion.predict(frames, dx, dy)
        t.trail.advance(frames, dx, dy)
        ih, iw = img.shape
        if not pred.is_valid() or not pred.intersects_image(iw, ih):
            if not (pred.is_valid() and t.sweep is not None and t.verdict.occluded > 0):
                self._state = TrackState.LOST
                t.box = pred if pred.is_finite() else t.box
                return None
            motion.hold_in(iw, ih)
            pred = motion.box()
        return t.clamp_size(pred)

    @staticmethod
    def _search_scales(t: Track, img: np.ndarray, pred: Box) -> Frame:
        """2. The scale search at the prediction (3. the failure test follows on its pick)."""
        scales = t.scales.search(t.base, img, pred, t.verdict)
        window = scales.wins[scales.mid]
        return Frame(img, pred, scales, scales.dets[scales.best], scales.best, window, (window,))

    @staticmethod
    def _guard_lookalike(t: Track, f: Frame) -> None:
        """4. A tracked frame whose peak left the trail's motion: the window at the motion reference may
        take the box back."""
        if f.failed or t.verdict.occluded > 0 or t.lookalike is None:
            return
        scales = f.scales
        f.takeback = t.lookalike.check(t.base, f.img, f.det, f.pred, scales.wins, scales.factors, t.verdict)
        if f.takeback is not None:
            f.best = f.takeback.best
            f.det = f.takeback.dets[f.best]
            f.shown = (f.window, f.takeback.window)

    @staticmethod
    def _redetect(t: Track, f: Frame) -> None:
        """5. A failed frame searches around the prediction; (ours) a weak tracked frame holds the size."""
        motion = t.motion
        assert motion is not None
        if f.failed:
            f.mode = SearchMode.MULTI_WINDOW
            t.coast.redetecting(motion, t.verdict.occluded)
            found = t.redetection.search(t.base, f.img, f.pred, f.scales, t.verdict.occluded)
            f.det, f.shown = found.det, found.windows
        elif t.verdict.weak(f.det.peak, t.coast.p.size_hold_peak_ratio):
            motion.hold_size()  # (ours) a weak frame's size is measured, not extrapolated

    @staticmethod
    def _reacquire(t: Track, f: Frame) -> None:
        """6. (ours) A non-failed frame must look like the tracked target (after an occlusion) and be known
        to the memory, else it is rejected; a rejected frame's size is one of the recent tracked ones."""
        f.scale = f.det.scale
        if f.failed:
            return
        f.weak = f.rejected = t.verdict.rejects(f.det)
        if not f.rejected and t.memory is not None:
            f.rejected, f.learn = t.memory.verdict(f.best)
        if f.rejected and t.rejected is not None:
            f.scale = t.rejected.scale(f.pred, f.det.scale, t.trail)
            if f.scale != f.det.scale and t.motion is not None:
                t.motion.hold_size()

    @staticmethod
    def _sweep(t: Track, f: Frame) -> None:
        """7. (ours) A failed or rejected frame after a long loss searches one tile of the whole image; a
        find makes the state jump there."""
        if not (f.failed or f.rejected) or t.sweep is None:
            return
        f.jump = t.sweep.search(t.base, f.img, f.pred, f.window, f.det, t.verdict, t.memory, t.scales)
        if f.jump is not None:
            f.det, f.mode, f.shown = f.jump.det, SearchMode.MULTI_WINDOW, (*f.shown, f.jump.window)

    def _update_motion(self, t: Track, f: Frame) -> None:
        """8. The Kalman update: robust with k from the peak on a tracked frame, the motion held while
        re-detecting (and on a held rejected frame), a restart at the sweep's find; adaptive R."""
        motion, verdict, det, pred = t.motion, t.verdict, f.det, f.pred
        assert motion is not None
        if f.jump is not None:
            size = f.jump.size
        elif not f.failed or self.params.redetection.grid_scale_search:
            stretch = math.sqrt(det.aspect)  # 1 but for a filter that measures the aspect ratio too
            size = (pred.w * f.scale * stretch, pred.h * f.scale / stretch)
        else:
            size = (pred.w, pred.h)
        k = f.threshold = motion.threshold(det.peak)
        z = motion.measurement(det.cx, det.cy, *size)
        if f.jump is not None:  # (ours) the sweep found the target away from the prediction: start there
            info = motion.jump(z, k)
        elif f.failed:  # the winner may still be a window at the prediction (the normal-mode search)
            outer = not any(det is d for d in f.scales.dets)
            info = motion.redetection_update(z, k, det.peak, outer, outer and verdict.weak(det.peak))
        elif f.rejected and t.rejected is not None and t.rejected.held(verdict.occluded, f.weak, f.best,
                                                                         t.memory):
            # (ours) a frame that is not `tracking` does not steer the state like a confident one
            info = motion.redetection_update(z, k, det.peak, False, False)
        else:
            info = motion.update(z, k)
        if f.takeback is not None and not f.rejected and t.lookalike is not None:
            t.lookalike.taken_back()
            motion.set_velocity(*f.takeback.velocity)
        motion.adapt_noise(z, info)
        t.box = t.clamp_size(motion.posterior())

    @staticmethod
    def _update_model(t: Track, f: Frame) -> None:
        """9. The memory learns on the frames it verified above its mean; the base filter on the frames
        its gate passes (UpdateGate)."""
        if f.learn and t.memory is not None:
            t.memory.learn(f.img, t.box)
        f.rate = t.gate.rate(t.base, f.det, f.failed or f.rejected)
        if f.rate is not None:
            t.base.train(f.img, t.box, f.rate)

    def _finish(self, t: Track, f: Frame) -> TrackResult:
        """10. The state: `tracking`, or `occluded` (`lost` after `occlusion.max_frames`); the coast model
        starts on the first missed frame, the trail records the tracked ones."""
        if f.failed or f.rejected:
            if t.verdict.occluded == 0 and t.motion is not None:
                t.coast.start(t.motion, t.trail)
            state = t.verdict.missed()
        else:
            t.verdict.tracked(f.det.peak)
            if t.sweep is not None:
                t.sweep.restart()  # the next loss sweeps from its own prediction outwards
            t.trail.remember(t.box)
            state = TrackState.TRACKING
        self._state = state
        return self._result(t.box, state, det=f.det, mode=f.mode, measured=not f.failed,
                            updated=f.rate is not None, windows=f.shown,
                            threshold=f.threshold if f.threshold is not None else 0.0)

    def _result(self, box: Box, state: TrackState, det: Detection | None = None,
                mode: SearchMode = SearchMode.NORMAL, measured: bool = False, updated: bool = False,
                windows: tuple[Box, ...] = (), threshold: float = 0.0, aim: Box | None = None) -> TrackResult:
        """A frame's TrackResult in input pixels (the track's box `box`, its velocity, the frame's `det`)."""
        inv = 1.0 / self.params.conditioning.downscale

        def up(b: Box) -> Box:
            return Box(b.x * inv, b.y * inv, b.w * inv, b.h * inv)

        t = self._track
        w0, h0 = t.init_size if t is not None else (0.0, 0.0)
        scale = math.sqrt(box.w * box.h / (w0 * h0)) if w0 > 0 and h0 > 0 and box.is_valid() else 1.0
        velocity = (0.0, 0.0)
        if t is not None and t.motion is not None:
            vx, vy = (v * inv for v in t.motion.velocity())
            velocity = (vx, vy) if math.isfinite(vx) and math.isfinite(vy) else velocity
        return TrackResult(box=up(box), state=state, peak=det.peak if det else 0.0,
                           psr=det.psr if det else 0.0, apce=det.apce if det else 0.0,
                           huber_threshold=float(threshold), search_mode=mode, measured=measured, scale=scale,
                           model_updated=updated,
                           search_windows=tuple(up(b) for b in windows), velocity=velocity,
                           aim=None if aim is None else up(aim))
