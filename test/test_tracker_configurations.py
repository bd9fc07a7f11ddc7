# SPDX-License-Identifier: Apache-2.0
"""Every named configuration on every base filter: built, validated, tracking a real target a few frames."""

from __future__ import annotations

from pathlib import Path

import cv2
import pytest
from conftest import skip_without_models

from swir_tracker_ros.configs import BASES, CONFIGURATIONS, configuration
from swir_tracker_ros.core.registry import BASE_FILTERS
from swir_tracker_ros.harness.sources import read_gt
from swir_tracker_ros.tracker import Tracker
from swir_tracker_ros.types import TrackState

FRAMES = 6


@pytest.fixture(scope="module")
def jogging(sequences_dir: Path) -> tuple[list, list]:
    """The first frames and boxes of OTB jogging-1 (a runner, before the pole hides her)."""
    folder = sequences_dir / "otb_jogging-1"
    files = sorted(folder.glob("*.png"))[:FRAMES]
    return [cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) for f in files], read_gt(folder)[:FRAMES]


@pytest.mark.parametrize("base", BASES)
@pytest.mark.parametrize("name", CONFIGURATIONS)
def test_every_configuration_tracks_on_every_base_filter(name: str, base: str, jogging: tuple) -> None:
    frames, gts = jogging
    if name in ("lead", "judged") and base != "siamese":
        pytest.skip("only the network leads (test_network_lead.py pins the refusal)")
    params = configuration(name, base)
    assert isinstance(params.base, BASE_FILTERS[base].Params)
    skip_without_models(params)  # a network's configuration without its weights: skipped with the reason
    trk = Tracker(params)
    trk.init(frames[0], gts[0])
    for frame, gt in zip(frames[1:], gts[1:]):
        res = trk.update(frame)
        assert res.state is TrackState.TRACKING, (name, base, res)
        assert abs(res.box.cx - gt.cx) < 0.5 * gt.w and abs(res.box.cy - gt.cy) < 0.5 * gt.h, (res.box, gt)
