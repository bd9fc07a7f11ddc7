# SPDX-License-Identifier: Apache-2.0
"""Long-term SWIR tracker: correlation filter + Kalman prediction + re-detection (paper 000, dissertation)."""

from __future__ import annotations

import contextlib
import math
from collections import deque
from collections.abc import Callable

import cv2
import numpy as np

from swir_tracker_ros.core.base import BaseFilter, Detection
from swir_tracker_ros.core.conditioning import ConditioningConfig, FrameConditioner
from swir_tracker_ros.core.features import SmoothedFrame
from swir_tracker_ros.core.filters import make_filter
from swir_tracker_ros.core.params import PIPELINES, VARIANTS, TrackerParams
from swir_tracker_ros.core.windows import scale_windows, search_window
from swir_tracker_ros.errors import KalmanError, TrackerError
from swir_tracker_ros.kalman import (
    AdaptiveNoise,
    Huber,
    KalmanFilter,
    RobustKalmanFilter,
    UpdateInfo,
)
from swir_tracker_ros.types import Box, SearchMode, TrackResult, TrackState

__all__ = ["PIPELINES", "VARIANTS", "Tracker", "TrackerParams"]

_RECOVERABLE = (TrackerError, KalmanError, cv2.error, ValueError, ArithmeticError, np.linalg.LinAlgError)


def _as_box(box: object) -> Box:
    if isinstance(box, Box):
        return box
    try:
        x, y, w, h = (float(v) for v in box)  # type: ignore[union-attr]
    except (TypeError, ValueError) as exc:
        raise TrackerError(f"init box must be a Box or (x, y, w, h), got {box!r}") from exc
    return Box(x, y, w, h)


LOOKALIKE_CHECKS = 2  # frames of a departure from the motion reference on which the look-alike guard looks
LOOKALIKE_GAP = 3.0  # frames: a longer break in the trail ends the look-alike guard's motion reference
SIZE_RATES = ("vs", "vw", "vh")  # state entries that change the box size (kalman/models.py names)
CENTRE_RATES = ("vx", "vy", "vxc", "vyc")  # state entries that move the box centre


class Tracker:
    """Single-object tracker; `init(frame, box)` then `update(frame)` once per frame.

    Per frame (paper 000 Fig. 2, dissertation §1.7 pseudo-code): Kalman prediction (+ ego shift),
    5-scale search at the prediction, failure detection (PSR < 7 for KCF, APCE <= 0.6 mean for DCF-CA),
    3x3 re-detection grid on failure, robust Kalman update with a peak-adaptive Huber threshold (the
    motion held while re-detecting, `_redetection_update`), and a model update only on confident frames.
    Variant `cf` is the bare correlation filter. Variant `measured` (ours, the default) is
    `robust_adaptive` whose confident frames report the correlation peak itself and whose `tracking`
    frames are verified by a long-term memory: on the real sequences the clipped robust update (eq. 33-35
    with eq. 38's k = 0.1-0.4 at the low peaks of a changing target) lags fast true motion until the window
    loses the target (surfer, skating1), while the occlusion handling (robust adaptive update, coasting on
    floor-band grid peaks) is what survives full occlusions (synthetic scenarios, closed-loop demo).
    """

    def __init__(self, params: TrackerParams | None = None) -> None:
        self.params = params if params is not None else TrackerParams()
        self.params.validate()
        p = self.params
        self._conditioner = FrameConditioner(
            ConditioningConfig(
                stretch=p.stretch,
                low_percentile=p.stretch_low_percentile,
                high_percentile=p.stretch_high_percentile,
                stretch_smoothing=p.stretch_smoothing,
                dead_pixel_threshold=p.dead_pixel_threshold,
                deinterlace=p.deinterlace,
                downscale=p.downscale,
            )
        )
        self.reset()

    # ------------------------------------------------------------------ public API
    @property
    def state(self) -> TrackState:
        return self._state

    def reset(self) -> None:
        """Forget the target (state idle)."""
        self._state = TrackState.IDLE
        self._conditioner.reset()
        self._bank: BaseFilter | None = None
        self._kf: KalmanFilter | None = None
        self._model = None
        self._size_rates: list[int] = []
        self._centre_rates: list[int] = []
        self._noise: AdaptiveNoise | None = None
        self._box: Box | None = None  # current estimate, conditioned-image pixels
        self._init_size = (0.0, 0.0)
        self._sigma = 0.0  # `presmooth` blur of the conditioned frames, pixels
        self._frame_shape: tuple[int, ...] = ()
        self._occluded = 0
        self._clock = 0.0  # frame periods since init
        self._ego = (0.0, 0.0)  # summed ego shifts since init
        self._trail: deque[tuple[float, float, float]] = deque()  # (clock, x - ego x, y - ego y), tracked
        self._sizes: deque[tuple[float, float]] = deque()  # (clock, sqrt(w h)) of the tracked frames
        self._departed = 0  # tracked frames since the box left the look-alike guard's motion reference
        self._peak_sum, self._peak_n = 0.0, 0  # peaks of the tracked (non-failed) frames
        self._mem_sum, self._mem_n = 0.0, 0  # memory peaks of the verified frames
        self._refused = 0  # tracked frames the update gate refused since it last passed one
        self._memory = False
        self._lattice = False
        self._tiles: list[tuple[float, float]] = []  # centres of the sweep's tiles still to search

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
        ds = p.downscale
        b = Box(box.x * ds, box.y * ds, box.w * ds, box.h * ds)
        self._frame_shape = frame.shape
        self._init_size = (b.w, b.h)
        self._sigma = p.presmooth * math.sqrt(b.w * b.h) if p.variant == "measured" else 0.0
        img = self._smoothed(img)
        self._bank = make_filter(p, b.w, b.h)  # the pipeline's base tracker, selected once
        self._bank.initialise(img, b)
        self._memory = p.memory_ratio > 0.0 and p.variant == "measured"  # the papers' variants: none
        self._lattice = p.lattice_step > 0.0 and p.variant == "measured"
        if self._memory:
            self._bank.start_memory()
        self._box = b
        self._remember_size()
        if p.variant != "cf":
            self._model = self._bank.box_model(b.w, b.h)
            self._size_rates = [i for i, n in enumerate(self._model.names) if n in SIZE_RATES]
            self._centre_rates = [i for i, n in enumerate(self._model.names) if n in CENTRE_RATES]
            if p.variant == "kalman":
                self._kf = KalmanFilter(self._model)
            else:
                method = p.robust_method if p.robust_method != "auto" else self._bank.robust_method
                self._kf = RobustKalmanFilter(
                    self._model,
                    influence=Huber(p.fixed_huber_threshold),
                    robust_components=(0, 1),
                    method=method,
                )
            self._kf.initialize(self._model.state_from_box(b), self._model.P0)
            if p.variant == "robust_adaptive_r":
                self._noise = AdaptiveNoise(self._model.R, components=(0, 1))
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
        if self._state is TrackState.IDLE or self._bank is None or self._box is None:
            return TrackResult(box=Box(0.0, 0.0, 0.0, 0.0), state=TrackState.IDLE)
        if self._state is TrackState.LOST:
            return self._result(self._box, TrackState.LOST)
        try:
            if not isinstance(frame, np.ndarray) or frame.shape[:2] != self._frame_shape[:2]:
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
            return self._result(self._box, TrackState.LOST)  # transient: the track itself is kept
        try:
            if self.params.variant == "cf":
                return self._step_cf(img)
            return self._step(img, dx * self.params.downscale, dy * self.params.downscale, frames)
        except _RECOVERABLE:
            self._state = TrackState.LOST
            return self._result(self._box, TrackState.LOST)

    def _smoothed(self, img: np.ndarray) -> np.ndarray | SmoothedFrame:
        """The conditioned frame as the windows sample it: blurred by `presmooth` (where they read it)."""
        return SmoothedFrame(img, self._sigma) if self._sigma > 0.0 else img

    # ------------------------------------------------------------------ per-frame steps
    def _step_cf(self, img: np.ndarray) -> TrackResult:
        """Bare correlation filter: one window at the last position, fixed size, update every frame."""
        bank, box = self._bank, self._box
        win = search_window(box.cx, box.cy, box.w, box.h, bank.padding)
        det = bank.detect(img, [win])[0]
        self._box = Box.from_center(det.cx, det.cy, box.w, box.h)
        bank.train(img, self._box, bank.learning_rate)
        return self._result(
            self._box, TrackState.TRACKING, det=det, measured=True, updated=True, windows=(win,)
        )

    def _step(self, img: np.ndarray, dx: float, dy: float, frames: float = 1.0) -> TrackResult:
        p, bank, kf, model = self.params, self._bank, self._kf, self._model
        self._predict(frames)
        kf.x[0] += dx
        kf.x[1] += dy
        self._clock += frames
        self._ego = (self._ego[0] + dx, self._ego[1] + dy)
        pred = model.box_from_state(kf.x)
        ih, iw = img.shape
        if not pred.is_valid() or not pred.intersects_image(iw, ih):
            if not (pred.is_valid() and self._hold_in_image(iw, ih)):
                self._state = TrackState.LOST
                self._box = pred if pred.is_finite() else self._box
                return self._result(self._box, TrackState.LOST)
            pred = model.box_from_state(kf.x)
        pred = self._clamp_size(pred)
        factors = self._scale_factors()
        wins = scale_windows(pred.cx, pred.cy, pred.w, pred.h, bank.padding, factors)
        penalty = p.scale_penalty if p.variant == "measured" else 1.0
        climb = p.scale_climb and p.variant == "measured" and self._occluded == 0
        floor = p.scale_climb_ratio * self._peak_sum / self._peak_n if self._peak_n else math.inf
        dets, best, lo = bank.detect_scales(img, wins, factors, penalty, climb, floor)
        mid = len(wins) // 2 - lo  # below: the run of windows correlated
        wins, factors = wins[lo : lo + len(dets)], factors[lo : lo + len(dets)]
        det = dets[best]
        failed = self._failure(det)
        guard = None
        if not failed and self._occluded == 0:
            guard = self._lookalike(img, det, pred, wins, factors)
            if guard is not None:
                dets, best, extra, ref_velocity = guard
                det = dets[best]
        # (ours) while re-detecting, a weak peak at the prediction is not the target coming back: keep
        # searching the lattice rather than letting the background next to the occluder steer the filter
        rescan = p.redetect_rescan and not failed and self._occluded > 0 and self._weak(det.peak)
        failed = failed or rescan
        mode = SearchMode.NORMAL
        shown: tuple[Box, ...] = (wins[mid],) if guard is None else (wins[mid], extra)
        if failed:
            mode = SearchMode.MULTI_WINDOW
            # Re-detection measures no size (it is taken from the prediction), so nothing could correct
            # a size velocity: hold the size instead of extrapolating it through the whole occlusion.
            kf.x[self._size_rates] = 0.0
            if p.variant == "measured":
                kf.x[self._centre_rates] *= p.coast_velocity_decay
                if 0 < p.coast_frames <= self._occluded:
                    kf.x[self._centre_rates] = 0.0
            # one feature computation on the union of the 9 windows (per scale with grid_scale_search)
            rings = self._rings() if self._lattice else 0
            if self._lattice:
                half = (p.lattice_alternate, self._occluded % 2) if p.lattice_alternate > 0 else None
                cand, grid = bank.detect_lattice(img, wins[mid], p.lattice_step, rings, half=half)
                grid = [wins[mid], *grid]
            else:
                cand, grid = bank.detect_grid(img, wins[mid], p.grid_overlap)
            if p.grid_scale_search:
                cand = [*dets, *cand]
                for i, f in enumerate(factors):
                    if i != mid:
                        cand += bank.detect_grid(img, wins[i], p.grid_overlap, scale=f)[0]
            else:
                cand = [dets[mid], *cand]
            det = max(cand, key=self._redetection_score(pred, wins[mid], rings))
            shown = tuple(grid)
        if not failed and self._weak(det.peak, p.size_rate_peak_ratio):
            kf.x[self._size_rates] = 0.0  # (ours) a weak frame's size is measured, not extrapolated
        rejected, learn, weak = False, False, False
        scale = det.scale
        if not failed:
            # (ours) back from an occlusion takes a peak like the tracked target's, and the memory's word
            weak = rejected = self._occluded > 0 and (self._weak(det.peak) or self._low_psr(det.psr))
            if not rejected:
                rejected, learn = self._memory_verdict(best)
            if rejected and p.variant == "measured" and p.rejected_size != "measured":
                scale = self._rejected_scale(pred, det.scale)
                if scale != det.scale:
                    kf.x[self._size_rates] = 0.0
        size = (pred.w * scale, pred.h * scale) if not failed or p.grid_scale_search else (pred.w, pred.h)
        k = self._threshold(det.peak)
        z = model.measurement_from_box(Box.from_center(det.cx, det.cy, *size))
        jump = self._sweep_tile(img, pred, wins[mid], det) if failed or rejected else None
        if jump is not None:  # (ours) the sweep found the target away from the prediction: start there
            det, mode, shown = jump[0], SearchMode.MULTI_WINDOW, (*shown, jump[1])
            k = self._threshold(det.peak)
            z = model.measurement_from_box(Box.from_center(det.cx, det.cy, *jump[2]))
            info = kf.update(None, threshold=k)  # no innovation: the jump is not a measurement error
            kf.x[:4] = z
            kf.x[self._centre_rates] = 0.0
            kf.x[self._size_rates] = 0.0
        elif failed:  # the winner may still be a window at the prediction (the normal-mode search)
            outer = not any(det is d for d in dets)
            info = self._redetection_update(z, k, det.peak, outer)
        elif rejected and self._rejected_held(weak, best):
            # (ours) a frame that is not `tracking` does not steer the state like a confident one
            if p.rejected_update == "coast":
                info = kf.update(None, threshold=k)
            else:
                info = self._redetection_update(z, k, det.peak, outer=False)
        elif not failed:
            info = kf.update(z, threshold=k)
            if p.variant == "measured":
                kf.x[:2] = z[:2]  # the confident correlation peak is the centre (no posterior lag)
        if guard is not None and not rejected:
            self._back_to_reference(ref_velocity)
        if self._noise is not None and not info.coasted:
            kf.R = self._noise.push(z, kf.x, kf.P, kf.H, used=info.used)
        out = model.box_from_state(kf.x)
        if not out.is_valid():
            raise TrackerError("Kalman posterior box has a non-positive size")
        self._box = self._clamp_size(out)
        if learn:
            self._bank.train_memory(img, self._box, p.memory_rate)
        updated = self._maybe_train(img, det, failed or rejected)
        if failed or rejected:
            if self._occluded == 0:
                self._set_coast_velocity()
            self._occluded += 1
            state = TrackState.LOST if self._occluded > p.max_occluded_frames else TrackState.OCCLUDED
        else:
            self._occluded = 0
            self._tiles.clear()  # the next loss sweeps from its own prediction outwards
            self._remember_centre()
            self._remember_size()
            state = TrackState.TRACKING
            self._peak_sum += det.peak
            self._peak_n += 1
        self._state = state
        return self._result(
            self._box,
            state,
            det=det,
            mode=mode,
            measured=not failed,
            updated=updated,
            windows=shown,
            threshold=k if k is not None else 0.0,
        )

    # ------------------------------------------------------------------ pieces
    def _predict(self, frames: float) -> None:
        """Kalman time update over `frames` frame periods (paper 000 eq. 14-15 with T = frames).

        The box models are constant-velocity models with T = 1 frame (eq. 36, eq. 6.2), F = I + T A; for
        T frames F_T = I + T A and, the process noise being a random walk per period, Q_T = T Q.
        """
        kf = self._kf
        if frames == 1.0:
            kf.predict()
            return
        F1, Q1 = kf.F, kf.Q
        eye = np.eye(F1.shape[0])
        kf.F, kf.Q = eye + frames * (F1 - eye), frames * Q1
        try:
            kf.predict()
        finally:
            kf.F, kf.Q = F1, Q1

    def _scale_factors(self) -> tuple[float, ...]:
        """Sizes searched at the prediction: `scale_factors`, and while re-detecting (variant measured, the
        scale search) 1 / redetect_scales and redetect_scales at either end (ours).

        A target that turns or is partly hidden is no longer recognised at its size, and the 5-scale
        search (+-10 %, each step penalised) lets the size drift down with the weaker peaks: on OTB girl
        the box shrank to half the girl while she turned away, and a filter correlating a window of that
        size never found her again. The two wide windows let one re-detection frame recover 20 %.
        """
        p = self.params
        factors = p.scale_factors()
        wide = p.redetect_scales > 0.0 and p.variant == "measured" and len(factors) > 1
        if wide and self._occluded > 0 and self._bank.scale_filter is None:
            factors = (1.0 / p.redetect_scales, *factors, p.redetect_scales)
        return factors

    def _redetection_update(self, z: np.ndarray, k: float | None, peak: float, outer: bool) -> UpdateInfo:
        """Kalman update while re-detecting: the motion is held, outliers cannot steer it (ours).

        During re-detection every measurement is suspect (paper 000: "the errors caused by ...
        occlusions, when the multiple search windows are activated, present the outliers and need to
        be removed"), and a long occlusion feeds the filter nothing but outliers, past the 25 %
        breakdown point of the Huber filter the paper cites. Each clipped outlier still moves the
        state by up to k d (eq. 33-34), and their bias piles up in the velocity, so the prediction
        that places the grid drifts away from where the target re-appears (the paper's premise is that
        the target keeps its pre-occlusion velocity: "the Kalman filter predicts the area for object
        re-detection"). Therefore, while re-detecting:

        - the best peak of an *outer* grid window (`outer`: not one of the windows at the prediction)
          that lies in the floor band of the adaptive threshold map (eq. 38: PV < 0.25, eq. 6.9:
          g_max < 0.125; "the detection may not actually represent the response of the tracked
          object") is no measurement: the filter coasts (`update(None)`); variants with a
          peak-adaptive threshold only. A floor-band peak at the prediction is kept, as in normal mode
          (partly hidden or turned targets give such peaks near the prediction: OTB jogging-1,
          PTB-TIR airplane);
        - any other measurement corrects the centre (robust update with k from the peak) but not the
          centre velocity, which is restored after the update (the size velocity is already held at
          zero while re-detecting). Normal tracking updates the velocity again.
        """
        kf, p = self._kf, self.params
        adaptive = p.variant in ("robust_adaptive", "robust_adaptive_r", "measured")
        if adaptive and outer and self._bank.threshold_map.at_floor(peak):
            return kf.update(None, threshold=k)
        # (ours) a jump to another window must look like the target did when it was tracked
        if outer and self._weak(peak):
            return kf.update(None, threshold=k)
        held = kf.x[self._centre_rates].copy()
        info = kf.update(z, threshold=k)
        kf.x[self._centre_rates] = held
        return info

    def _rejected_held(self, weak: bool, index: int) -> bool:
        """(ours, `rejected_update`) Is a rejected frame (`weak`: its peak, else the memory's veto) kept from
        steering the state like a confident one? Only after `rejected_update_after` frames of re-detection;
        mode 'memory' lets a weak peak in window `index` steer when the memory finds the target there."""
        p = self.params
        if p.rejected_update == "normal" or self._occluded < p.rejected_update_after:
            return False
        return not (p.rejected_update == "memory" and weak and self._memory_knows(index))

    def _memory_knows(self, index: int) -> bool:
        """Does the memory find the target in window `index` (peak >= memory_ratio x its mean)? No side
        effects; without a memory, yes."""
        if not self._memory or not self._mem_n:
            return True
        return self._bank.memory_score(index) >= self.params.memory_ratio * self._mem_sum / self._mem_n

    def _memory_verdict(self, index: int) -> tuple[bool, bool]:
        """Long-term memory check of a non-failed frame (LCT, Ma et al. CVPR 2015 Sec. 3.3; ours here):
        (rejected, learn).

        The memory filter (first-frame model, then learnt at `memory_rate` only from frames it scores
        above its own mean: `learn`, done on the posterior box by the caller) must find the target in the
        winning window with a peak of at least `memory_ratio` x its mean over the verified frames;
        otherwise the box is on something the memory does not know (background, a distractor) and the
        frame is `occluded`, not `tracking`.
        """
        p = self.params
        if not self._memory:
            return False, False
        m = self._bank.memory_score(index)
        mean = self._mem_sum / self._mem_n if self._mem_n else m
        if m < p.memory_ratio * mean:
            return True, False
        self._mem_sum += m
        self._mem_n += 1
        return False, m >= mean and p.memory_rate > 0.0

    def _remember_centre(self) -> None:
        """Append the tracked centre (ego shifts removed) to the trail of the last coast_velocity_window."""
        n = self.params.coast_velocity_window
        if n <= 0 or self.params.variant != "measured":  # only `_set_coast_velocity` reads the trail
            return
        b, (ex, ey) = self._box, self._ego
        self._keep_recent(self._trail, (self._clock, b.cx - ex, b.cy - ey))

    def _remember_size(self) -> None:
        """Append the tracked size (sqrt(w h)) to the sizes of the last coast_velocity_window frames."""
        self._keep_recent(self._sizes, (self._clock, math.sqrt(self._box.w * self._box.h)))

    def _keep_recent(self, entries: deque, entry: tuple[float, ...]) -> None:
        """Append `entry` (its clock first) and drop the entries older than coast_velocity_window frames."""
        entries.append(entry)
        while entries and entries[0][0] < self._clock - self.params.coast_velocity_window:
            entries.popleft()

    def _rejected_scale(self, pred: Box, scale: float) -> float:
        """(ours, `rejected_size`) The size factor that a rejected (non-failed, not `tracking`) frame
        measures, from its winning `scale`: 1 ('held'), or ('recent') the scale kept within the sizes
        (sqrt(w h)) of the tracked frames of the last coast_velocity_window frames and the prediction's.
        A box that the checks do not take for the target may grow back to a size the target had, not
        beyond it: the frame's peak may be an occluder crossing in front (synthetic t9)."""
        if self.params.rejected_size == "held":
            return 1.0
        s = math.sqrt(pred.w * pred.h)
        seen = [v for _, v in self._sizes] or [s]
        lo, hi = min(min(seen), s), max(max(seen), s)
        return min(max(s * scale, lo), hi) / s

    def _motion_reference(self) -> tuple[float, float, float, float] | None:
        """(ours, look-alike guard) Centre and velocity (image pixels, per frame) that the trail's motion
        before its last `lookalike_frames` frames gives for now: None without that much unbroken history
        (a gap of more than LOOKALIKE_GAP frames: an occlusion, whose motion before it is stale)."""
        m = self.params.lookalike_frames
        trail = list(self._trail)
        if not trail or self._clock - trail[-1][0] > LOOKALIKE_GAP:
            return None
        start = next((i for i in range(len(trail) - 1, 0, -1)
                      if trail[i][0] - trail[i - 1][0] > LOOKALIKE_GAP), 0)
        old = [e for e in trail[start:] if e[0] <= self._clock - m]
        if len(old) < 2 or old[-1][0] - old[0][0] < m:
            return None
        (t0, x0, y0), (t1, x1, y1) = old[0], old[-1]
        vx, vy = (x1 - x0) / (t1 - t0), (y1 - y0) / (t1 - t0)
        dt = self._clock - t1
        return x1 + vx * dt + self._ego[0], y1 + vy * dt + self._ego[1], vx, vy

    def _lookalike(
        self, img: np.ndarray, det: Detection, pred: Box, wins: list[Box], factors: tuple[float, ...]
    ) -> tuple[list[Detection], int, Box, tuple[float, float]] | None:
        """(ours, variant measured) Look-alike guard of a tracked frame.

        A same-looking object that passes in front of the target covers it and takes the correlation peak
        along; every frame's step is small and confident, so neither the failure test, the Kalman gate
        nor the memory notices. The motion does: the peak leaves where the trail's earlier motion puts
        the target (`_motion_reference`). When it is further than `lookalike_distance` from there, one
        more window is correlated at the reference; its peak wins when it lies near the reference and
        apart from the first, at `lookalike_ratio` of its height or more, and passes the re-acquisition
        bars (`redetect_peak_ratio`, `redetect_psr`): a distractor-aware choice by motion, as multi-target
        trackers gate by a motion model, the motion being the one from before the mix-up. A fast skater
        whose turn the reference cannot know leaves background there, with PSRs of 5-10 (OTB skating1).
        Only the first LOOKALIKE_CHECKS frames of a departure are checked: when a look-alike takes the
        box away, the target is at the reference the moment the box leaves it; when nothing is there
        then, the target moved off the reference itself, and the reference, extrapolated on, would only
        pass over background (a stage light took a skater's box 10 frames into her start: OTB skating1
        from the 0.8 start, measured).
        Filters with `psr_reacquisition` only (KCF), as the PSR bar: DCF-CA's failure test keeps a running
        APCE mean that a second call would move. The extra detection (the windows the scale search
        correlated, again, so that the winner's index still names its features) costs one more frame's
        search on at most LOOKALIKE_CHECKS frames per departure.
        Returns the detections of the windows plus that one, the index of the winner, the window and the
        reference's velocity; None when the guard is off, not triggered or the first peak stays.
        """
        p = self.params
        # filters with the PSR bar for re-acquisition (KCF): their failure test has no state to disturb
        if p.variant != "measured" or p.lookalike_frames <= 0 or not self._bank.psr_reacquisition:
            return None
        ref = self._motion_reference()
        if ref is None:
            self._departed = 0
            return None
        rx, ry, vx, vy = ref
        w, h = pred.w * det.scale, pred.h * det.scale
        d = p.lookalike_distance

        def apart(ax: float, ay: float, bx: float, by: float) -> float:
            return max(abs(ax - bx) / w, abs(ay - by) / h)

        if apart(det.cx, det.cy, rx, ry) <= d:
            self._departed = 0
            return None
        self._departed += 1
        if self._departed > LOOKALIKE_CHECKS:  # the target moved off the reference itself (see above)
            return None
        extra = scale_windows(rx, ry, pred.w, pred.h, self._bank.padding, (1.0,))[0]
        dets = self._bank.detect(img, [*wins, extra], [*factors, 1.0])
        alt = dets[-1]
        # taking the box back is a re-acquisition: the peak there also passes its bars (peak, PSR)
        if (apart(alt.cx, alt.cy, rx, ry) <= d / 2 and apart(alt.cx, alt.cy, det.cx, det.cy) >= d / 2
                and alt.peak >= p.lookalike_ratio * det.peak and not self._failure(alt)
                and not self._weak(alt.peak) and not self._low_psr(alt.psr)):
            return dets, len(dets) - 1, extra, (vx, vy)
        return None

    def _back_to_reference(self, velocity: tuple[float, float]) -> None:
        """(ours, look-alike guard) After the guard moved the box back: the trail forgets the frames that
        followed the look-alike and the centre velocity is the reference motion's (`velocity`)."""
        m = self.params.lookalike_frames
        self._departed = 0
        while self._trail and self._trail[-1][0] > self._clock - m:
            self._trail.pop()
        vx, vy = self._centre_rates[:2]
        self._kf.x[vx], self._kf.x[vy] = velocity

    def _sweeping(self) -> bool:
        """Is the long-loss sweep on (`sweep_after`; variant measured, filters with the PSR bar: KCF)?"""
        p = self.params
        return self._lattice and p.sweep_after > 0 and self._bank.psr_reacquisition

    def _hold_in_image(self, iw: int, ih: int) -> bool:
        """(ours, `sweep_after`) While re-detecting, a prediction that left the image is held at its border
        (centre clamped, centre velocity zeroed) instead of ending the track: the target may have turned
        back while hidden, and the sweep searches the whole image. False (the track ends) otherwise."""
        if not (self._sweeping() and self._occluded > 0):
            return False
        kf = self._kf
        kf.x[0] = min(max(float(kf.x[0]), 0.0), iw - 1.0)
        kf.x[1] = min(max(float(kf.x[1]), 0.0), ih - 1.0)
        kf.x[self._centre_rates] = 0.0
        return True

    def _sweep_tile(
        self, img: np.ndarray, pred: Box, window: Box, best: Detection
    ) -> tuple[Detection, Box, tuple[float, float]] | None:
        """(ours, `sweep_after`) One tile of the long-loss sweep over the whole image.

        The lattice around the prediction widens to lattice_max_rings and no further; a target that
        turned back or stopped while hidden comes out where the pre-occlusion motion cannot put it (the
        synthetic t2 walker turns back behind the occluder and the prediction walks on out of the image).
        From `sweep_after` frames of re-detection on, every frame that is not `tracking` also correlates
        one tile of a raster over the image: a lattice of lattice_rings rings (its centre included) of
        windows of the predicted size, one tile a frame, each pass over the image from the tile nearest
        the prediction outwards (a target that stopped or turned back is usually near). With
        `sweep_filter` 'memory' the tile is correlated with the long-term memory (LCT re-detection, Ma et
        al. CVPR 2015 Sec. 3.4, which re-detects with a detector trained on confident frames only), the
        bars relative to the memory's mean peak; with 'filter', with the tracking filter, the bars
        relative to its tracked mean.
        The tile's best peak is a candidate when it lies more than half the box from the prediction (the
        lattice and the normal search looked there), is not failed and reaches redetect_peak_ratio x the
        mean ('filter': and beats the lattice's pick `best`). Windows centred on it at the sizes of the
        re-detection's scale search (redetect_scales: a size that drifted while the target was hidden)
        are correlated; the best must pass the bars again and redetect_psr ('filter': and the memory must
        find the target there, memory_ratio). Returns that detection, its window and its size. Filters
        with the PSR bar only (KCF), as the look-alike guard: DCF-CA's failure test has state.
        """
        p, bank = self.params, self._bank
        if not self._sweeping() or self._occluded < p.sweep_after:
            return None
        if not self._tiles:  # a new pass over the image, the tiles nearest the prediction first
            ih, iw = img.shape
            span = (2 * p.lattice_rings + 1) * p.lattice_step
            nx = max(1, math.ceil(iw / (span * window.w)))
            ny = max(1, math.ceil(ih / (span * window.h)))
            tiles = [((i + 0.5) * iw / nx, (j + 0.5) * ih / ny) for j in range(ny) for i in range(nx)]
            self._tiles = sorted(tiles, key=lambda c: -math.hypot(c[0] - pred.cx, c[1] - pred.cy))
        cx, cy = self._tiles.pop()
        tile = window.shifted(cx - window.cx, cy - window.cy)
        memory = p.sweep_filter == "memory" and self._memory and self._mem_n > 0
        if memory:
            bar = p.redetect_peak_ratio * self._mem_sum / self._mem_n
        else:
            bar = p.redetect_peak_ratio * self._peak_sum / max(self._peak_n, 1)
        with bank.memory_as_filter() if memory else contextlib.nullcontext():
            dets, _ = bank.detect_lattice(img, tile, p.lattice_step, p.lattice_rings, centre=True)
            if not dets:
                return None
            cand = max(dets, key=lambda d: d.peak)
            near = abs(cand.cx - pred.cx) <= pred.w / 2 and abs(cand.cy - pred.cy) <= pred.h / 2
            if near or self._failure(cand) or cand.peak < bar or (not memory and cand.peak <= best.peak):
                return None
            factors = self._scale_factors()
            wins = scale_windows(cand.cx, cand.cy, pred.w, pred.h, bank.padding, factors)
            dets, i, _ = bank.detect_scales(img, wins, factors, p.scale_penalty, climb=False)
            det = dets[i]
            if self._failure(det) or det.peak < bar or self._low_psr(det.psr):
                return None
        if not memory and not self._memory_knows(i):
            return None
        return det, wins[i], (pred.w * det.scale, pred.h * det.scale)

    def _set_coast_velocity(self) -> None:
        """(ours, `coast_velocity_window`) The centre velocity for re-detection: the trail's mean velocity."""
        trail = self._trail
        if self.params.variant != "measured" or self.params.coast_velocity_window <= 0 or len(trail) < 2:
            return
        (t0, x0, y0), (t1, x1, y1) = trail[0], trail[-1]
        # over the whole window: a trail shorter than the window (a track just started) counts the rest
        # as standing still, so a few frames' motion does not carry the prediction through an occlusion
        span = max(t1 - t0, float(self.params.coast_velocity_window))
        vx, vy = self._centre_rates[:2]
        self._kf.x[vx] = (x1 - x0) / span
        self._kf.x[vy] = (y1 - y0) / span

    def _redetection_score(self, pred: Box, window: Box, rings: int) -> Callable[[Detection], float]:
        """Ranking of the re-detection candidates: the peak, times a Gaussian motion prior (ours, measured).

        The prior's sigma is `redetect_prior` x the lattice's half-width along each axis (`rings` x step x
        window), so it widens with the lattice; `redetect_prior` 0 (and the papers' variants): the peak.
        """
        p = self.params
        if not (self._lattice and p.redetect_prior > 0.0):
            return lambda d: d.peak
        half = p.redetect_prior * rings * p.lattice_step
        sx, sy = half * window.w, half * window.h

        def score(d: Detection) -> float:
            return d.peak * math.exp(-0.5 * (((d.cx - pred.cx) / sx) ** 2 + ((d.cy - pred.cy) / sy) ** 2))

        return score

    def _weak(self, peak: float, ratio: float | None = None) -> bool:
        """(ours, variant measured) Is `peak` below `ratio` (default `redetect_peak_ratio`: too weak to
        re-acquire the target) x the mean peak of the tracked frames?"""
        p = self.params
        if p.variant != "measured" or not self._peak_n:
            return False
        bar = p.redetect_peak_ratio if ratio is None else ratio
        return peak < bar * self._peak_sum / self._peak_n

    def _low_psr(self, psr: float) -> bool:
        """(ours, variant measured; filters with `psr_reacquisition`) Is `psr` below the re-acquisition bar
        `redetect_psr`?"""
        p = self.params
        return p.variant == "measured" and self._bank.psr_reacquisition and psr < p.redetect_psr

    def _rings(self) -> int:
        """Rings of the re-detection lattice: they widen with the frames since the last confident frame."""
        p = self.params
        grow = self._occluded // p.lattice_widen_frames if p.lattice_widen_frames > 0 else 0
        return max(p.lattice_rings, min(p.lattice_rings + grow, p.lattice_max_rings))

    def _failure(self, det: Detection) -> bool:
        """Failure detection of the pipeline: PSR < 7 (paper 000) or APCE <= 0.6 x mean APCE (eq. 4.96)."""
        return self._bank.failed(det)

    def _threshold(self, peak: float) -> float | None:
        v = self.params.variant
        if v == "kalman":
            return None
        if v == "robust":
            return self.params.fixed_huber_threshold
        return self._bank.threshold_map(peak)

    def _maybe_train(self, img: np.ndarray, det: Detection, failed: bool) -> bool:
        """Confident-only update (peak > 0.5, paper 000; APCE > 0.583 x mean, eq. 4.97); frozen on failure.
        (ours, `unconfident_rate` > 0) a tracked frame the gate refuses learns at that fraction of it."""
        if failed:
            return False
        rate = self._bank.learning_rate
        if not self._bank.confident(det):
            p = self.params
            self._refused += 1
            if p.unconfident_rate <= 0.0 or p.variant != "measured" or self._refused <= p.unconfident_after:
                return False
            rate *= p.unconfident_rate
        else:
            self._refused = 0
        self._bank.train(img, self._box, rate)
        return True

    def _clamp_size(self, box: Box) -> Box:
        """Keep the size within [1/4, 4] x the initial size so one bad scale step cannot run away."""
        w0, h0 = self._init_size
        w = min(max(box.w, 0.25 * w0), 4.0 * w0)
        h = min(max(box.h, 0.25 * h0), 4.0 * h0)
        return Box.from_center(box.cx, box.cy, w, h)

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
        inv = 1.0 / self.params.downscale

        def up(b: Box) -> Box:
            return Box(b.x * inv, b.y * inv, b.w * inv, b.h * inv)

        w0, h0 = self._init_size
        scale = math.sqrt(box.w * box.h / (w0 * h0)) if w0 > 0 and h0 > 0 and box.is_valid() else 1.0
        velocity = (0.0, 0.0)
        if self._kf is not None and self._centre_rates:
            vx, vy = (float(self._kf.x[i]) * inv for i in self._centre_rates[:2])
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
