# SPDX-License-Identifier: Apache-2.0
"""`MotionFilter`: the Kalman filter of the box (paper 000 Sec. III-C; dissertation ch. 5-6) in the tracker.

The papers' pipelines differ here: a standard Kalman filter, an M-robust (Huber) one with a fixed
threshold, one whose threshold follows the correlation peak (paper 000 eq. 38, dissertation eq. 6.9), and
the dissertation's adaptive measurement noise R (eq. 5.95). A configuration without a motion filter is the
bare correlation filter (`cf`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.base import BaseFilter
from swir_tracker_ros.errors import TrackerError
from swir_tracker_ros.kalman import AdaptiveNoise, Huber, KalmanFilter, RobustKalmanFilter, UpdateInfo
from swir_tracker_ros.kalman.influence import HUBER_K
from swir_tracker_ros.paramfield import param
from swir_tracker_ros.types import Box

SIZE_RATES = ("vs", "vw", "vh")  # state entries that change the box size (kalman/models.py names)
CENTRE_RATES = ("vx", "vy", "vxc", "vyc")  # state entries that move the box centre


@dataclass
class MotionParams:
    """The Kalman filter of the box; its box model (state, F, H, Q, R) is the base filter's."""

    robust: bool = param(
        True, "M-robust (Huber) update (paper 000 eq. 33-35); false: the standard Kalman filter"
    )
    adaptive_threshold: bool = param(
        True,
        "the Huber threshold k follows the correlation peak (paper 000 eq. 38 / dissertation eq. 6.9, the "
        "base filter's map); false: fixed_threshold",
    )
    fixed_threshold: float = param(HUBER_K, "Huber threshold when adaptive_threshold is off", 0.05, 10.0)
    method: str = param(
        "auto",
        "statistical linearisation of the robust update; auto: the base filter's (A4 for kcf and bacf, "
        "paper 000 eq. 33-35; A2 for dcf_ca, dissertation eq. 5.52)",
        choices=("auto", "A2", "A4"),
    )
    adaptive_r: bool = param(
        False, "adapt the position measurement noise R from post-fit residuals (dissertation eq. 5.95)"
    )
    peak_centre: bool = param(
        True,
        "(ours) a confident (tracked) frame's centre is the correlation peak itself, not the Kalman "
        "posterior: the clipped robust update (eq. 33-35 with eq. 38's k = 0.1-0.4 at the low peaks of a "
        "changing target) lags fast true motion until the window loses the target",
    )
    size_velocity: bool = param(
        True,
        "the box model's size velocity is estimated and extrapolated (the papers); false (ours): held at "
        "zero after every update, the size smoothed but not extrapolated (its process noise is in pixels, so "
        "a small target's size velocity runs away from a few noisy measurements)",
    )


class MotionFilter:
    """The box's Kalman filter: prediction over frame periods, ego shifts, and the updates of the loop."""

    def __init__(self, p: MotionParams, base: BaseFilter, box: Box) -> None:
        self.p = p
        self.model = model = base.box_model(box.w, box.h)
        self.size_rates = [i for i, n in enumerate(model.names) if n in SIZE_RATES]
        self.centre_rates = [i for i, n in enumerate(model.names) if n in CENTRE_RATES]
        self.threshold_map = base.threshold_map
        if p.robust:
            method = p.method if p.method != "auto" else base.robust_method
            self.kf: KalmanFilter = RobustKalmanFilter(
                model, influence=Huber(p.fixed_threshold), robust_components=(0, 1), method=method
            )
        else:
            self.kf = KalmanFilter(model)
        self.kf.initialize(model.state_from_box(box), model.P0)
        self.noise = AdaptiveNoise(model.R, components=(0, 1)) if p.adaptive_r else None

    # ------------------------------------------------------------------ prediction
    def predict(self, frames: float, dx: float, dy: float) -> Box:
        """Time update over `frames` frame periods (paper 000 eq. 14-15 with T = frames), then the ego
        shift (dx, dy) of the image; returns the predicted box.

        The box models are constant-velocity models with T = 1 frame (eq. 36, eq. 6.2), F = I + T A; for
        T frames F_T = I + T A and, the process noise being a random walk per period, Q_T = T Q.
        """
        kf = self.kf
        if frames == 1.0:
            kf.predict()
        else:
            F1, Q1 = kf.F, kf.Q
            eye = np.eye(F1.shape[0])
            kf.F, kf.Q = eye + frames * (F1 - eye), frames * Q1
            try:
                kf.predict()
            finally:
                kf.F, kf.Q = F1, Q1
        kf.x[0] += dx
        kf.x[1] += dy
        return self.box()

    def box(self) -> Box:
        """The box of the current state."""
        return self.model.box_from_state(self.kf.x)

    def posterior(self) -> Box:
        """The box of the state after the update; TrackerError when its size is not positive."""
        out = self.box()
        if not out.is_valid():
            raise TrackerError("Kalman posterior box has a non-positive size")
        return out

    def velocity(self) -> tuple[float, float]:
        """The centre velocity (pixels per frame period)."""
        vx, vy = self.centre_rates[:2]
        return float(self.kf.x[vx]), float(self.kf.x[vy])

    # ------------------------------------------------------------------ state edits of the policies
    def hold_size(self) -> None:
        """Zero the size velocity: a size that is not measured is held, not extrapolated."""
        self.kf.x[self.size_rates] = 0.0

    def scale_velocity(self, factor: float) -> None:
        """Multiply the centre velocity by `factor` (the coast model's per-frame decay)."""
        self.kf.x[self.centre_rates] *= factor

    def stop(self) -> None:
        """Zero the centre velocity."""
        self.kf.x[self.centre_rates] = 0.0

    def set_velocity(self, vx: float, vy: float) -> None:
        """Set the centre velocity (pixels per frame period)."""
        ix, iy = self.centre_rates[:2]
        self.kf.x[ix], self.kf.x[iy] = vx, vy

    def hold_in(self, iw: int, ih: int) -> None:
        """Clamp the centre into the iw x ih image and stop it there."""
        kf = self.kf
        kf.x[0] = min(max(float(kf.x[0]), 0.0), iw - 1.0)
        kf.x[1] = min(max(float(kf.x[1]), 0.0), ih - 1.0)
        kf.x[self.centre_rates] = 0.0

    # ------------------------------------------------------------------ measurement updates
    def measurement(self, cx: float, cy: float, w: float, h: float) -> np.ndarray:
        """The measurement vector z of a box (eq. 36 / eq. 6.2's H)."""
        return self.model.measurement_from_box(Box.from_center(cx, cy, w, h))

    def threshold(self, peak: float) -> float | None:
        """Huber threshold of a measurement with this correlation peak (None: the standard filter)."""
        if not self.p.robust:
            return None
        if not self.p.adaptive_threshold:
            return self.p.fixed_threshold
        return self.threshold_map(peak)

    def update(self, z: np.ndarray, k: float | None) -> UpdateInfo:
        """A tracked frame's update; with `peak_centre` the centre is then the measurement's."""
        info = self.kf.update(z, threshold=k)
        if self.p.peak_centre:
            self.kf.x[:2] = z[:2]  # the confident correlation peak is the centre (no posterior lag)
        if not self.p.size_velocity:
            self.hold_size()
        return info

    def jump(self, z: np.ndarray, k: float | None) -> UpdateInfo:
        """Start again at z (the long-loss sweep found the target away from the prediction): no innovation,
        the jump is not a measurement error; the motion starts from rest."""
        info = self.kf.update(None, threshold=k)
        self.kf.x[:4] = z
        self.kf.x[self.centre_rates] = 0.0
        self.kf.x[self.size_rates] = 0.0
        return info

    def redetection_update(self, z: np.ndarray, k: float | None, peak: float, outer: bool,
                           weak: bool) -> UpdateInfo:
        """Kalman update while re-detecting: the motion is held, outliers cannot steer it (ours).

        During re-detection every measurement is suspect (paper 000: "the errors caused by ...
        occlusions, when the multiple search windows are activated, present the outliers and need to
        be removed"), and a long occlusion feeds the filter nothing but outliers, past the 25 %
        breakdown point of the Huber filter the paper cites. Each clipped outlier still moves the
        state by up to k d (eq. 33-34), and their bias piles up in the velocity, so the prediction
        that places the grid drifts away from where the target re-appears (the paper's premise is that
        the target keeps its pre-occlusion velocity: "the Kalman filter predicts the area for object
        re-detection"). Therefore, while re-detecting:

        - the best peak of an *outer* window (`outer`: not one of the windows at the prediction) that
          lies in the floor band of the adaptive threshold map (eq. 38: PV < 0.25, eq. 6.9:
          g_max < 0.125; "the detection may not actually represent the response of the tracked
          object") is no measurement: the filter coasts (`update(None)`); with a peak-adaptive threshold
          only. A floor-band peak at the prediction is kept, as in normal mode (partly hidden or turned
          targets give such peaks near the prediction: OTB jogging-1, PTB-TIR airplane);
        - (ours) a jump to an outer window whose peak is `weak` (it must look like the target did when it
          was tracked) is no measurement either;
        - any other measurement corrects the centre (robust update with k from the peak) but not the
          centre velocity, which is restored after the update (the size velocity is already held at
          zero while re-detecting). Normal tracking updates the velocity again.
        """
        kf = self.kf
        adaptive = self.p.robust and self.p.adaptive_threshold
        if adaptive and outer and self.threshold_map.at_floor(peak):
            return kf.update(None, threshold=k)
        if outer and weak:
            return kf.update(None, threshold=k)
        held = kf.x[self.centre_rates].copy()
        info = kf.update(z, threshold=k)
        kf.x[self.centre_rates] = held
        return info

    def adapt_noise(self, z: np.ndarray, info: UpdateInfo) -> None:
        """(`adaptive_r`) R from the post-fit residual of a frame that measured (dissertation eq. 5.95)."""
        if self.noise is not None and not info.coasted:
            kf = self.kf
            kf.R = self.noise.push(z, kf.x, kf.P, kf.H, used=info.used)
