# SPDX-License-Identifier: Apache-2.0
"""`cf`: the bare correlation filter (paper 000's baseline): one window at the last position, fixed size,
model updated every frame; no Kalman filter, no occlusion handling."""

from __future__ import annotations

from swir_tracker_ros.configs._papers import papers
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    return papers(base, motion=None)
