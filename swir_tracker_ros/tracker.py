# SPDX-License-Identifier: Apache-2.0
"""Long-term SWIR tracker: correlation filter + Kalman prediction + re-detection (paper 000, dissertation)."""

from __future__ import annotations

import math

import cv2
import numpy as np

from swir_tracker_ros.configs import DEFAULT_CONFIGURATION, configuration
from swir_tracker_ros.core import fhog
from swir_tracker_ros.core.base import BaseFilter, Detection
from swir_tracker_ros.core.conditioning import FrameConditioner
from swir_tracker_ros.core.features import SmoothedFrame
from swir_tracker_ros.core.registry import make_filter
from swir_tracker_ros.core.windows import search_window
from swir_tracker_ros.errors import KalmanError, TrackerError
from swir_tracker_ros.policies.coast import CoastModel
from swir_tracker_ros.policies.lookalike import LookalikeGuard
from swir_tracker_ros.policies.memory import AppearanceMemory
from swir_tracker_ros.policies.motion import MotionFilter
from swir_tracker_ros.policies.occlusion import OcclusionVerdict
from swir_tracker_ros.policies.redetection import Redetection
from swir_tracker_ros.policies.rejected import RejectedFrames
from swir_tracker_ros.policies.scale_search import ScaleSearch
from swir_tracker_ros.policies.sweep import LongLossSweep
from swir_tracker_ros.policies.trail import Trail
from swir_tracker_ros.policies.update_gate import UpdateGate
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


class _Track:
    """The per-track state: the base filter and the policies of one target (built by `Tracker.init`)."""

    def __init__(self, p: TrackerParams, base: BaseFilter, box: Box, frame_shape: tuple[int, ...]) -> None:
        self.base = base
        self.frame_shape = frame_shape
        self.init_size = (box.w, box.h)
        self.box = box  # the current estimate, conditioned-image pixels
        self.trail = Trail(p.trail_frames)
        self.trail.remember_size(box)
        self.verdict = OcclusionVerdict(p.occlusion, base.failed, base.psr_reacquisition)
        self.gate = UpdateGate(p.update)
        self.scales = ScaleSearch(p.scale)
        self.redetection = Redetection(p.redetection)
        self.coast = CoastModel(p.coast)
        remembers = p.memory is not None and p.memory.ratio > 0
        self.memory = AppearanceMemory(p.memory, base) if remembers else None
        self.motion = MotionFilter(p.motion, base, box) if p.motion is not None else None
        wraps = base.window_policies  # the guard and the sweep test other windows with the failure test
        self.lookalike = (LookalikeGuard(p.lookalike, self.trail)
                          if p.lookalike is not None and p.lookalike.frames > 0 and wraps else None)
        self.sweep = (LongLossSweep(p.sweep, p.redetection)
                      if p.sweep is not None and p.sweep.after > 0 and self.redetection.lattice and wraps
                      else None)
        self.rejected = RejectedFrames(p.rejected) if p.rejected is not None else None

    def clamp_size(self, box: Box) -> Box:
        """Keep the size within [1/4, 4] x the initial size so one bad scale step cannot run away."""
        w0, h0 = self.init_size
        w = min(max(box.w, 0.25 * w0), 4.0 * w0)
        h = min(max(box.h, 0.25 * h0), 4.0 * h0)
        return Box.from_center(box.cx, box.cy, w, h)


class Tracker:
    """Single-object tracker; `init(frame, box)` then `update(frame)` once per frame.

    Per frame (paper 000 Fig. 2, dissertation §1.7 pseudo-code): Kalman prediction (+ ego shift), scale
    search at the prediction, failure detection (PSR < 7 for KCF, APCE <= 0.6 mean for DCF-CA),
    re-detection around the prediction on failure, robust Kalman update with a peak-adaptive Huber
    threshold (the motion held while re-detecting), and a model update only on confident frames. Each
    long-term mechanism is a policy (swir_tracker_ros/policies/); which ones, with which values, is a
    named configuration (swir_tracker_ros/configs/: the papers' `cf`, `kalman`, `robust`,
    `robust_adaptive`, `robust_adaptive_r`, and our default `measured`; docs/tracking_core.md). A
    configuration without a motion filter (`cf`) is the bare correlation filter.
    """

    def __init__(self, params: TrackerParams | None = None) -> None:
        self.params = params if params is not None else configuration(DEFAULT_CONFIGURATION)
        self.params.validate()
        self._conditioner = FrameConditioner(self.params.conditioning)
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
        self._track: _Track | None = None
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
        img = self._conditioner(frame, bit_depth)  # ConditioningError is a TrackerError
        ih, iw = frame.shape[:2]
        if not (0.0 <= box.cx < iw and 0.0 <= box.cy < ih):
            raise TrackerError(f"init box {box.as_tuple()} has its centre outside the {iw}x{ih} image")
        p = self.params
        ds = p.conditioning.downscale
        b = Box(box.x * ds, box.y * ds, box.w * ds, box.h * ds)
        self._sigma = p.presmooth * math.sqrt(b.w * b.h)
        img = self._smoothed(img)
        base = make_filter(p.base, b.w, b.h)  # the configuration's base filter, selected once
        base.initialise(img, b)
        self._track = _Track(p, base, b, frame.shape)
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
        if self._state is TrackState.LOST:
            return self._result(t.box, TrackState.LOST)
        try:
            if not isinstance(frame, np.ndarray) or frame.shape[:2] != t.frame_shape[:2]:
                raise TrackerError("frame size differs from the init frame")
            if bit_depth is not None and not (1 <= int(bit_depth) <= 16):
                raise TrackerError(f"bit_depth={bit_depth!r} must be between 1 and 16")
            img = self._smoothed(self._conditioner(frame, bit_depth))
            dx, dy = (float(v) for v in ego_shift)
            if not (math.isfinite(dx) and math.isfinite(dy)):
                dx = dy = 0.0
            frames = float(frames)
            if not (math.isfinite(frames) and frames > 0.0):
                frames = 1.0
        except (*_RECOVERABLE, TypeError):
            return self._result(t.box, TrackState.LOST)  # transient: the track itself is kept
        try:
            if t.motion is None:
                return self._step_cf(t, img)
            ds = self.params.conditioning.downscale
            return self._step(t, img, dx * ds, dy * ds, frames)
        except _RECOVERABLE:
            self._state = TrackState.LOST
            return self._result(t.box, TrackState.LOST)

    def _smoothed(self, img: np.ndarray) -> np.ndarray | SmoothedFrame:
        """The conditioned frame as the windows sample it: blurred by `presmooth` (where they read it)."""
        return SmoothedFrame(img, self._sigma) if self._sigma > 0.0 else img

    # ------------------------------------------------------------------ per-frame steps
    def _step_cf(self, t: _Track, img: np.ndarray) -> TrackResult:
        """Bare correlation filter: one window at the last position, fixed size, update every frame."""
        base, box = t.base, t.box
        win = search_window(box.cx, box.cy, box.w, box.h, base.padding)
        det = base.detect(img, [win])[0]
        t.box = Box.from_center(det.cx, det.cy, box.w, box.h)
        base.train(img, t.box, base.learning_rate)
        return self._result(t.box, TrackState.TRACKING, det=det, measured=True, updated=True, windows=(win,))

    def _step(self, t: _Track, img: np.ndarray, dx: float, dy: float, frames: float) -> TrackResult:
        base, motion, verdict = t.base, t.motion, t.verdict
        assert motion is not None
        pred = motion.predict(frames, dx, dy)
        t.trail.advance(frames, dx, dy)
        ih, iw = img.shape
        if not pred.is_valid() or not pred.intersects_image(iw, ih):
            # (sweep) a prediction that left the image while re-detecting is held at its border
            if not (pred.is_valid() and t.sweep is not None and verdict.occluded > 0):
                self._state = TrackState.LOST
                t.box = pred if pred.is_finite() else t.box
                return self._result(t.box, TrackState.LOST)
            motion.hold_in(iw, ih)
            pred = motion.box()
        pred = t.clamp_size(pred)
        scales = t.scales.search(base, img, pred, verdict)
        det, best, window = scales.dets[scales.best], scales.best, scales.wins[scales.mid]
        failed = verdict.failed(det)
        takeback = None
        if not failed and verdict.occluded == 0 and t.lookalike is not None:
            takeback = t.lookalike.check(base, img, det, pred, scales.wins, scales.factors, verdict)
            if takeback is not None:
                best = takeback.best
                det = takeback.dets[best]
        failed = failed or verdict.rescan(det)
        mode = SearchMode.NORMAL
        shown: tuple[Box, ...] = (window,) if takeback is None else (window, takeback.window)
        if failed:
            mode = SearchMode.MULTI_WINDOW
            t.coast.redetecting(motion, verdict.occluded)
            found = t.redetection.search(base, img, pred, scales, verdict.occluded)
            det, shown = found.det, found.windows
        if not failed and verdict.weak(det.peak, t.coast.p.size_hold_peak_ratio):
            motion.hold_size()  # (ours) a weak frame's size is measured, not extrapolated
        rejected, learn, weak = False, False, False
        scale = det.scale
        if not failed:
            # (ours) back from an occlusion takes a peak like the tracked target's, and the memory's word
            weak = rejected = verdict.rejects(det)
            if not rejected and t.memory is not None:
                rejected, learn = t.memory.verdict(best)
            if rejected and t.rejected is not None:
                scale = t.rejected.scale(pred, det.scale, t.trail)
                if scale != det.scale:
                    motion.hold_size()
        grid_sizes = self.params.redetection.grid_scale_search
        size = (pred.w * scale, pred.h * scale) if not failed or grid_sizes else (pred.w, pred.h)
        k = motion.threshold(det.peak)
        z = motion.measurement(det.cx, det.cy, *size)
        jump = None
        if (failed or rejected) and t.sweep is not None:
            jump = t.sweep.search(base, img, pred, window, det, verdict, t.memory, t.scales)
        if jump is not None:  # (ours) the sweep found the target away from the prediction: start there
            det, mode, shown = jump.det, SearchMode.MULTI_WINDOW, (*shown, jump.window)
            k = motion.threshold(det.peak)
            z = motion.measurement(det.cx, det.cy, *jump.size)
            info = motion.jump(z, k)
        elif failed:  # the winner may still be a window at the prediction (the normal-mode search)
            outer = not any(det is d for d in scales.dets)
            info = motion.redetection_update(z, k, det.peak, outer, outer and verdict.weak(det.peak))
        elif rejected and t.rejected is not None and t.rejected.held(verdict.occluded, weak, best, t.memory):
            # (ours) a frame that is not `tracking` does not steer the state like a confident one
            info = motion.redetection_update(z, k, det.peak, False, False)
        else:
            info = motion.update(z, k)
        if takeback is not None and not rejected:
            t.lookalike.taken_back()
            motion.set_velocity(*takeback.velocity)
        motion.adapt_noise(z, info)
        t.box = t.clamp_size(motion.posterior())
        if learn:
            t.memory.learn(img, t.box)
        rate = t.gate.rate(base, det, failed or rejected)
        if rate is not None:
            base.train(img, t.box, rate)
        if failed or rejected:
            if verdict.occluded == 0:
                t.coast.start(motion, t.trail)
            state = verdict.missed()
        else:
            verdict.tracked(det.peak)
            if t.sweep is not None:
                t.sweep.restart()  # the next loss sweeps from its own prediction outwards
            t.trail.remember(t.box)
            state = TrackState.TRACKING
        self._state = state
        return self._result(t.box, state, det=det, mode=mode, measured=not failed, updated=rate is not None,
                            windows=shown, threshold=k if k is not None else 0.0)

    def _result(
        self,
        box: Box,
        state: TrackState,
        det: Detection | None = None,
        mode: SearchMode = SearchMode.NORMAL,
        measured: bool = False,
        updated: bool = False,
        windows: tuple[Box, ...] = (),
        threshold: float = 0.0,
    ) -> TrackResult:
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
        return TrackResult(
            box=up(box),
            state=state,
            peak=det.peak if det else 0.0,
            psr=det.psr if det else 0.0,
            apce=det.apce if det else 0.0,
            huber_threshold=float(threshold),
            search_mode=mode,
            measured=measured,
            scale=scale,
            model_updated=updated,
            search_windows=tuple(up(b) for b in windows),
            velocity=velocity,
        )
