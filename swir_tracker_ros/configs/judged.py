# SPDX-License-Identifier: Apache-2.0
"""`judged` (ours, issue 53): `lead` (NanoTrack v3 leads, judged by its appearance and its motion) with a
second opinion: LightTrack-M looks where the leader looks, and a judge picks per frame whose box stands
(policies/second.py)."""

from __future__ import annotations

from dataclasses import replace

from swir_tracker_ros.configs import lead
from swir_tracker_ros.policies.second import SecondParams
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    p = lead.params(base)
    return replace(p, lead=replace(p.lead, second=SecondParams()))
