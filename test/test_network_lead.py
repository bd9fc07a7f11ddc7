# SPDX-License-Identifier: Apache-2.0
"""The network leads (policies/lead.py, configuration `lead`): its boxes are the network's own while the
verdicts accept them; a rejected frame's box and the head's aim follow the motion's prediction; a candidate
resumes the track only where the motion allows (ego shifts applied), or anywhere after a long loss when it is
a strong match."""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from swir_tracker_ros.configs import BASES, configuration
from swir_tracker_ros.core.siamese.tracker import SiameseTracker
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.policies.gone import GoneCues, GoneParams
from swir_tracker_ros.policies.lead import LeadParams, NetworkLead, coverage, lattice, off_path
from swir_tracker_ros.tracker import Tracker
from swir_tracker_ros.types import Box, SearchMode, TrackState


class _AlwaysGone:
    """A verdict that rejects every search and every candidate (the lead's own mechanics alone)."""

    p = GoneParams()
    gone = True
    typical = None

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


def _candidate(cx: float, cy: float, w: float, h: float) -> SimpleNamespace:
    """The parts of a SiameseDetection that the resume test reads: the smoothed and the regressed box."""
    b = Box.from_center(cx, cy, w, h)
    return SimpleNamespace(smoothed=b, box=b)


def _cues(psr: float, score: float = 1.0) -> GoneCues:
    return GoneCues(score, score, 1.0, score, psr, 10.0, 0.1, 0.1, 0.0)


def test_off_path_is_the_centre_distance_in_target_sizes() -> None:
    pred = Box.from_center(100.0, 100.0, 20.0, 20.0)
    assert off_path(Box.from_center(130.0, 140.0, 10.0, 10.0), pred, 25.0) == pytest.approx(2.0)
    assert off_path(pred, pred, 25.0) == 0.0


def test_a_candidate_resumes_only_where_the_motion_allows_or_strongly_after_a_long_loss() -> None:
    p = LeadParams(resume_radius=0.5, resume_growth=0.05, resume_speed=0.0, resume_size=1.5, long_loss=20,
                   strong_ratio=0.1)
    lead = NetworkLead(p, None)  # the resume rule reads no network
    lead.verdict.gone, lead.verdict.typical = True, math.log(1000.0)  # typical tracked PSR 1000
    pred, size = Box.from_center(100.0, 100.0, 20.0, 20.0), 20.0  # `size`: the gates' unit
    lead.box = pred  # the last accepted box (the size check's reference)
    lead.missed = 10  # radius 0.5 + 10 x 0.05 = 1 target size: 20 px
    bar = lead.verdict.resume_bar()
    assert lead._resumes(_candidate(115.0, 100.0, 20.0, 20.0), _cues(bar), pred, size)
    assert not lead._resumes(_candidate(115.0, 100.0, 20.0, 20.0), _cues(0.9 * bar), pred, size)  # appearance
    assert not lead._resumes(_candidate(115.0, 100.0, 20.0, 20.0), _cues(bar, 0.5), pred, size)  # score floor
    assert not lead._resumes(_candidate(125.0, 100.0, 20.0, 20.0), _cues(5000.0), pred, size)  # too far
    assert not lead._resumes(_candidate(110.0, 100.0, 40.0, 40.0), _cues(5000.0), pred, size)  # grown 2 x
    lead.missed = 20  # a long loss: a strong match (PSR >= 0.1 x 1000 and the bar) anywhere
    far = _candidate(400.0, 300.0, 20.0, 20.0)
    assert lead._resumes(far, _cues(max(bar, 100.0)), pred, size)
    assert bar < 90.0 and not lead._resumes(far, _cues(90.0), pred, size)  # not a strong one


@pytest.mark.usefixtures("nanotrack_weights")
def test_a_rejected_frame_follows_the_prediction_and_the_head_aims_there(crossing_frames) -> None:
    frames, gts = crossing_frames
    params = configuration("lead")
    params = replace(params, lead=replace(params.lead, lost_after=3, tiles_per_frame=3))
    trk, net = Tracker(params), SiameseTracker(params.base)
    trk.init(frames[0], gts[0])
    net.init(frames[0], gts[0])
    trk._track.lead.verdict = _AlwaysGone()
    states, size = [], math.sqrt(gts[0].w * gts[0].h)
    for frame in frames[1:8]:
        res = trk.update(frame)
        states.append(res.state)
        own = net.update(frame).box  # the network's own answer (its size held at the last accepted one)
        pred = res.aim  # no accepted motion yet: the prediction stands at the start box
        assert pred is not None and not res.measured
        assert (pred.cx, pred.cy, pred.w, pred.h) == pytest.approx((gts[0].cx, gts[0].cy, gts[0].w, gts[0].h))
        on_path = off_path(own, pred, size) <= params.lead.resume_radius
        assert res.box.center == pytest.approx(own.center if on_path else pred.center)
        assert 2 <= len(res.search_windows) <= 1 + 3  # its own search, the prediction's crop, lattice crops
        assert res.search_mode is SearchMode.MULTI_WINDOW and res.velocity == (0.0, 0.0)
        net.size = (gts[0].w, gts[0].h)
    assert states[:3] == [TrackState.OCCLUDED] * 3 and set(states[3:]) == {TrackState.LOST}


def _moved_scene(frames, gts):
    """The first frame and its box, and the same picture moved sideways by more than a search crop's span."""
    frame, box = frames[0], gts[0]
    span = coverage(box.w, box.h, SiameseTracker(configuration("lead").base))
    w = frame.shape[1]
    dx = int(min(1.5 * span, w - box.x - box.w - 1)) if box.cx < w / 2 else -int(min(1.5 * span, box.x - 1))
    assert abs(dx) > 0.5 * span
    return frame, box, dx, np.roll(frame, dx, axis=1), Box(box.x + dx, box.y, box.w, box.h)


@pytest.mark.usefixtures("nanotrack_weights")
def test_redetection_follows_the_ego_shift_to_a_target_that_left_the_crop(crossing_frames) -> None:
    frame, box, dx, moved, target = _moved_scene(*crossing_frames)
    trk = Tracker(configuration("lead"))
    trk.init(frame, box)
    blank = np.full_like(frame, int(frame.mean()))  # the target is gone: nothing but the mean grey
    assert trk.update(blank).state is TrackState.OCCLUDED
    res = trk.update(moved, ego_shift=(float(dx), 0.0))  # the head's own motion moved the picture
    for _ in range(3):
        if res.state is TrackState.TRACKING:
            break
        res = trk.update(moved)
    assert res.state is TrackState.TRACKING and res.aim is None and res.box.iou(target) > 0.5


@pytest.mark.usefixtures("nanotrack_weights")
def test_a_far_candidate_resumes_only_after_a_long_loss(crossing_frames) -> None:
    frame, box, _dx, moved, target = _moved_scene(*crossing_frames)
    params = configuration("lead")
    params = replace(params, lead=replace(params.lead, long_loss=6))
    trk = Tracker(params)
    trk.init(frame, box)
    blank = np.full_like(frame, int(frame.mean()))
    assert trk.update(blank).state is TrackState.OCCLUDED
    found = None
    for k in range(2, 40):  # k: frames since the last accepted one
        res = trk.update(moved)
        if res.state is TrackState.TRACKING:
            found = (k, res.box)
            break
        assert res.aim is not None and res.aim.center == pytest.approx(box.center)  # held: nothing moved
    assert found is not None, "the long-loss search never found the moved target"
    assert found[0] >= 6 and found[1].iou(target) > 0.5  # not before the long loss: the motion forbade it


def test_a_candidate_away_from_the_prediction_must_show_itself_on_two_frames() -> None:
    lead = NetworkLead(LeadParams(resume_radius=0.5), None)
    pred, size = Box.from_center(100.0, 100.0, 20.0, 20.0), 20.0
    assert lead._confirmed(Box.from_center(105.0, 100.0, 20.0, 20.0), pred, size)  # at the predicted place
    far = Box.from_center(200.0, 100.0, 20.0, 20.0)
    assert not lead._confirmed(far, pred, size) and lead._pending == far  # seen once: searched again
    assert not lead._confirmed(Box.from_center(300.0, 100.0, 20.0, 20.0), pred, size)  # elsewhere: not it
    assert lead._confirmed(Box.from_center(304.0, 100.0, 20.0, 20.0), pred, size)  # there again: it is
    assert lead._pending is None


def test_the_networks_own_answer_at_the_predicted_place_holds_it() -> None:
    lead = NetworkLead(LeadParams(resume_radius=0.5, long_loss=10), None)
    pred, size = Box.from_center(100.0, 100.0, 20.0, 20.0), 20.0
    here, away = _candidate(105.0, 100.0, 20.0, 20.0), _candidate(115.0, 100.0, 20.0, 20.0)
    lead.missed = 3
    assert lead._holds(here, _cues(5.0), pred, size)  # an ambiguous map (PSR 5) at the predicted place
    assert not lead._holds(away, _cues(5.0), pred, size)  # it left the place
    assert not lead._holds(here, _cues(2.0), pred, size)  # below the lower bar: nothing holds
    assert not lead._holds(here, _cues(5.0, 0.5), pred, size)
