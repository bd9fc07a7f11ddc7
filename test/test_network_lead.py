# SPDX-License-Identifier: Apache-2.0
"""The network leads (policies/lead.py, configuration `lead`): its boxes are the network's own while the
verdict accepts them, a rejected frame holds the last accepted box, and the widening re-detection finds a
target that jumped out of the search crop."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from swir_tracker_ros.configs import BASES, configuration
from swir_tracker_ros.core.siamese.tracker import SiameseTracker
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.policies.gone import GoneCues, GoneParams
from swir_tracker_ros.policies.lead import coverage, lattice
from swir_tracker_ros.tracker import Tracker
from swir_tracker_ros.types import Box, SearchMode, TrackState


class _AlwaysGone:
    """A verdict that rejects every search and every candidate (the lead's own mechanics alone)."""

    p = GoneParams()

    def judge_cues(self, c: GoneCues) -> bool:
        return True

    def resume_bar(self) -> float:
        return math.inf


def test_the_lattice_grows_ring_by_ring_until_it_covers_the_frame() -> None:
    pts = lattice(50.0, 50.0, 40.0, 100, 100)
    assert pts[0] == (50.0, 50.0)
    assert set(pts[1:5]) == {(10.0, 50.0), (90.0, 50.0), (50.0, 10.0), (50.0, 90.0)}  # edges before corners
    assert set(pts[5:9]) == {(10.0, 10.0), (90.0, 10.0), (10.0, 90.0), (90.0, 90.0)}
    assert len(pts) == 9  # ring 2 (+-80 px) lies more than half a step outside the 100 px frame
    far = lattice(0.0, 0.0, 10.0, 100, 30)  # a corner start reaches the far corner
    assert (100.0, 30.0) in far and len(far) == len(set(far))


def test_the_lead_configuration_only_runs_on_the_network() -> None:
    for base in BASES:
        if base == "siamese":
            continue
        with pytest.raises(ParameterError, match="lead"):
            configuration("lead", base)


@pytest.mark.usefixtures("nanotrack_weights")
def test_an_accepting_verdict_gives_the_networks_own_boxes(crossing_frames) -> None:
    frames, gts = crossing_frames
    params = configuration("lead")
    params = replace(params, lead=replace(params.lead, gone=replace(params.lead.gone, psr_gone=0.0,
                                                                    score_gone=0.0)))  # never gone
    trk, net = Tracker(params), SiameseTracker(params.base)
    trk.init(frames[0], gts[0])
    net.init(frames[0], gts[0])
    for frame in frames[1:]:
        res = trk.update(frame)
        assert res.state is TrackState.TRACKING and res.measured and res.aim is None
        assert res.box.as_tuple() == net.update(frame).box.as_tuple()


@pytest.mark.usefixtures("nanotrack_weights")
def test_a_rejected_frame_is_the_networks_answer_while_the_head_aims_at_the_last_accepted_box(
        crossing_frames) -> None:
    frames, gts = crossing_frames
    params = configuration("lead")
    params = replace(params, lead=replace(params.lead, lost_after=3, tiles_per_frame=3))
    trk, net = Tracker(params), SiameseTracker(params.base)
    trk.init(frames[0], gts[0])
    net.init(frames[0], gts[0])
    trk._track.lead.verdict = _AlwaysGone()
    states = []
    for frame in frames[1:8]:
        res = trk.update(frame)
        states.append(res.state)
        assert res.box.as_tuple() == net.update(frame).box.as_tuple()  # the network follows its answer
        assert res.aim == gts[0] and res.aim_box == gts[0] and not res.measured  # the head holds
        assert len(res.search_windows) == 1 + 3  # its own search, the last box's crop, 2 lattice crops
        assert res.search_mode is SearchMode.MULTI_WINDOW and res.velocity == (0.0, 0.0)
    assert states[:3] == [TrackState.OCCLUDED] * 3 and set(states[3:]) == {TrackState.LOST}


@pytest.mark.usefixtures("nanotrack_weights")
def test_redetection_finds_a_target_that_jumped_out_of_the_crop(crossing_frames) -> None:
    frames, gts = crossing_frames
    params = configuration("lead")
    trk = Tracker(params)
    frame, box = frames[0], gts[0]
    trk.init(frame, box)
    net = SiameseTracker(params.base)
    span = coverage(box.w, box.h, net)
    w = frame.shape[1]
    # the whole picture moved by more than a search crop's span: the target is outside the first search
    dx = int(min(1.5 * span, w - box.x - box.w - 1)) if box.cx < w / 2 else -int(min(1.5 * span, box.x - 1))
    assert abs(dx) > 0.5 * span
    moved = np.roll(frame, dx, axis=1)
    target = Box(box.x + dx, box.y, box.w, box.h)
    blank = np.full_like(frame, int(frame.mean()))  # the target is gone: nothing but the mean grey
    for _ in range(2):
        assert trk.update(blank).state is TrackState.OCCLUDED
    found = None
    for k in range(12):
        res = trk.update(moved)
        if res.state is TrackState.TRACKING:
            found = (k, res.box)
            assert res.aim is None
            break
        assert res.aim == box  # the head holds at the last accepted box meanwhile
    assert found is not None, "re-detection never found the moved target"
    assert found[1].iou(target) > 0.5
