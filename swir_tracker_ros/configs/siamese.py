# SPDX-License-Identifier: Apache-2.0
"""`siamese` (ours): the Siamese network base filter (NanoTrack, core/siamese/) inside the long-term layers of
configuration `eco`: the robust Kalman filter of paper 000 (the size smoothed, not extrapolated: the network
regresses it), the failure test on its score map's PSR (paper 000's 7), the papers' 3x3 re-detection grid
searched by the network itself; the template is fixed."""

from __future__ import annotations

from swir_tracker_ros.configs import eco
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    return eco.params(base or "siamese")
