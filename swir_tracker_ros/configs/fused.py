# SPDX-License-Identifier: Apache-2.0
"""`fused` (ours): configuration `eco` with a Siamese network (NanoTrack, core/siamese/) tracking beside the
ECO filter, one box from both per frame (policies/fusion.py; issue 38)."""

from __future__ import annotations

from swir_tracker_ros.configs import eco
from swir_tracker_ros.policies.fusion import FusionParams
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    p = eco.params(base)
    p.fusion = FusionParams()
    return p
