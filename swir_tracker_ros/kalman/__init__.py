# SPDX-License-Identifier: Apache-2.0
"""Kalman filter family: standard, M-robust (A1-A4, six psi functions), adaptive threshold, adaptive R.

Usage in the tracking core (copy this)::

    from swir_tracker_ros.kalman import (
        DISSERTATION_DCFCA, PAPER000_KCF, AdaptiveNoise, Huber, KalmanFilter, RobustKalmanFilter,
        dcfca_box_model, kcf_box_model)

    model = kcf_box_model()                        # or dcfca_box_model(box.w, box.h)
    kf = RobustKalmanFilter(model, influence=Huber(), robust_components=(0, 1), method="A2")
    # configuration "kalman": kf = KalmanFilter(model)  (same surface; threshold is ignored)
    kf.initialize(model.state_from_box(box), model.P0)

    # every frame
    kf.predict()
    kf.x[0] += ego_dx; kf.x[1] += ego_dy           # ego-motion shift of the prediction
    search_box = model.box_from_state(kf.x)
    ...                                            # correlate, get measured_box and peak
    k = PAPER000_KCF(peak)                         # adaptive threshold (DISSERTATION_DCFCA for dcf_ca)
    info = kf.update(model.measurement_from_box(measured_box), threshold=k)   # threshold=None: fixed k
    # occluded with no usable measurement: info = kf.update(None)  -> info.coasted is True
    # non-finite values in z are skipped as missed measurements: info.nonfinite is True, state untouched
    out_box = model.box_from_state(kf.x)
    info.weights, info.normalized, info.threshold, info.coasted   # diagnostics per component

    # configuration "robust_adaptive_r": adapt R from post-fit residuals of the position components
    noise = AdaptiveNoise(model.R, components=(0, 1))
    info = kf.update(z, threshold=k)
    if not info.coasted:
        kf.R = noise.push(z, kf.x, kf.P, kf.H, used=info.used)

`method="A4"` is exactly paper 000 eq. 31-35 (clipped innovation, gain w P h'/d^2); `"A2"` is the
dissertation's final filter (paper 001 eq. 28). See docs/kalman.md.
"""

from __future__ import annotations

from swir_tracker_ros.kalman.adaptive import (
    DISSERTATION_DCFCA,
    PAPER000_KCF,
    AdaptiveNoise,
    AdaptiveNoiseParams,
    ThresholdMap,
)
from swir_tracker_ros.kalman.influence import (
    HUBER_K,
    Andrews,
    Clipping,
    Hampel,
    Huber,
    Influence,
    Smith,
    Tukey,
    make_influence,
)
from swir_tracker_ros.kalman.models import BoxModel, dcfca_box_model, kcf_box_model
from swir_tracker_ros.kalman.robust import RobustKalmanFilter, robust_update
from swir_tracker_ros.kalman.sequential import UpdateInfo
from swir_tracker_ros.kalman.standard import KalmanFilter, predict, update
from swir_tracker_ros.kalman.statlin import METHODS, alpha_fixed

__all__ = [
    "DISSERTATION_DCFCA",
    "HUBER_K",
    "METHODS",
    "PAPER000_KCF",
    "AdaptiveNoise",
    "AdaptiveNoiseParams",
    "Andrews",
    "BoxModel",
    "Clipping",
    "Hampel",
    "Huber",
    "Influence",
    "KalmanFilter",
    "RobustKalmanFilter",
    "Smith",
    "ThresholdMap",
    "Tukey",
    "UpdateInfo",
    "alpha_fixed",
    "dcfca_box_model",
    "kcf_box_model",
    "make_influence",
    "predict",
    "robust_update",
    "update",
]
