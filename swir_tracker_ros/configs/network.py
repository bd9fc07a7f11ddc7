# SPDX-License-Identifier: Apache-2.0
"""`network` (ours): the Siamese network leads (policies/lead.py, issue 46): NanoTrack tracks with its own
state as its authors track, a failure verdict (policies/gone.py) says when its answer is not the target,
and a re-detection search widening from the last accepted box to the whole frame finds it again. No Kalman
filter, memory or correlation filter around it: each such layer joins only with a measured paired gain
(docs/experiments.md)."""

from __future__ import annotations

from swir_tracker_ros.configs.bases import base_params
from swir_tracker_ros.policies.lead import LeadParams
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    return TrackerParams(base=base_params(base, default="siamese"), motion=None, memory=None, lookalike=None,
                         sweep=None, rejected=None, lead=LeadParams(), presmooth=0.0)
