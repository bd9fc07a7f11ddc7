# SPDX-License-Identifier: Apache-2.0
"""The second opinion (policies/second.py, configuration `judged`): the judge is a logistic model of the named
features; the second looks on its schedule and moves with the track between its looks; a standing second box
is the frame's box (or, with `lead_follows`, the leader looks there and takes that answer); two boxes that
agree blend; the look-alike guard vetoes a second box off the motion reference; with `recentre_iou` a second
that disagrees with the standing leader is moved onto the leader's box; with `agree_resumes` two agreeing
opinions resume a lost track when the second is sure, the size is the target's and the place the motion's."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from swir_tracker_ros.configs import configuration
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.paramfield import validate_params
from swir_tracker_ros.policies.gone import GoneCues
from swir_tracker_ros.policies.lead import LeadParams, NetworkLead
from swir_tracker_ros.policies.lookalike import LookalikeGuard, LookalikeParams
from swir_tracker_ros.policies.second import (
    JUDGE_FEATURES,
    OFF_PATH_CAP,
    Opinion,
    SecondOpinion,
    SecondParams,
    blend,
    joined,
    judge,
    judge_features,
)
from swir_tracker_ros.tracker import Tracker
from swir_tracker_ros.types import Box, TrackState


def _cues(score: float, psr: float, second: float = 0.2, apce: float = 10.0) -> GoneCues:
    return GoneCues(score, score, 1.0, score, psr, apce, second, 0.1, 0.0)


def test_the_features_are_named_in_order_and_the_off_path_is_capped() -> None:
    f = judge_features(_cues(0.5, 9.0, 0.3, 4.0), _cues(1.0, 0.0, 0.7, 0.0), 0.25, 1.5, 99.0)
    assert len(f) == len(JUDGE_FEATURES)
    got = dict(zip(JUDGE_FEATURES, f))
    assert got["log_score_lead"] == pytest.approx(math.log(0.5)) and got["log_score_second"] == 0.0
    assert got["log_psr_lead"] == pytest.approx(math.log(10.0)) and got["log_psr_second"] == 0.0
    assert got["second_peak_lead"] == 0.3 and got["second_peak_second"] == 0.7
    assert got["log_apce_lead"] == pytest.approx(math.log(5.0))
    assert got["off_path_lead"] == 1.5 and got["off_path_second"] == OFF_PATH_CAP
    assert got["agreement"] == 0.25


def test_the_judge_is_the_logistic_of_the_weighted_features() -> None:
    f = np.arange(len(JUDGE_FEATURES), dtype=float)
    w = [0.0] * len(JUDGE_FEATURES) + [0.0]
    assert judge(w, f) == 0.5
    w[3], w[-1] = 2.0, -1.0  # z = 2 * f[3] - 1 = 5
    assert judge(w, f) == pytest.approx(1.0 / (1.0 + math.exp(-5.0)))
    assert judge([0.0] * len(JUDGE_FEATURES) + [1e9], f) == pytest.approx(1.0)  # no overflow


def test_weights_of_the_wrong_length_are_refused() -> None:
    with pytest.raises(ParameterError, match="weights"):
        validate_params(SecondParams(weights=[1.0, 2.0]))
    with pytest.raises(ParameterError, match="weights"):
        validate_params(SecondParams(weights=[math.nan] * (len(JUDGE_FEATURES) + 1)))


def _judged(weights: list[float], every: int = 1, **kw):
    p = configuration("judged")
    return replace(p, lead=replace(p.lead, second=replace(p.lead.second, weights=weights, every=every, **kw)))


BIAS_ONLY = len(JUDGE_FEATURES) * [0.0]


@pytest.mark.usefixtures("nanotrack_weights", "lighttrack_weights")
def test_the_second_looks_on_its_schedule(crossing_frames) -> None:
    frames, gts = crossing_frames
    trk = Tracker(_judged([*BIAS_ONLY, -50.0], every=3))  # the leader always stands
    trk.init(frames[0], gts[0])
    looked = []
    for frame in frames[1:10]:
        trk.update(frame)
        looked.append(trk._track.lead.opinion is not None)
    assert looked == [False, False, True] * 3


@pytest.mark.usefixtures("nanotrack_weights", "lighttrack_weights")
@pytest.mark.parametrize("follows", [False, True])
def test_a_standing_second_box_is_the_frames_box(crossing_frames, follows: bool) -> None:
    """With a judge that always trusts the second, the frame's box is the second's and the leader keeps its
    own state; with `lead_follows` the leader searches again where the second answered and the frame's box is
    that answer (near the second's), its state too."""
    frames, gts = crossing_frames
    trk = Tracker(_judged([*BIAS_ONLY, 50.0], lead_follows=follows, blend=0.0))
    trk.init(frames[0], gts[0])
    for frame in frames[1:6]:
        res = trk.update(frame)
        lead = trk._track.lead
        assert lead.opinion is not None and lead.opinion.stands and res.state is TrackState.TRACKING
        second = lead.opinion.det.smoothed
        if follows:
            assert lead.net.center == pytest.approx(res.box.center)
            assert math.hypot(res.box.cx - second.cx, res.box.cy - second.cy) < max(second.w, second.h)
        else:
            assert res.box.as_tuple() == second.as_tuple()
            assert lead.net.center != pytest.approx(res.box.center)  # the leader follows its own answer

@pytest.mark.usefixtures("nanotrack_weights", "lighttrack_weights")
def test_a_disagreeing_second_is_moved_onto_the_standing_leader(crossing_frames) -> None:
    frames, gts = crossing_frames
    trk = Tracker(_judged([*BIAS_ONLY, -50.0], recentre_iou=0.3))
    trk.init(frames[0], gts[0])
    trk.update(frames[1])
    lead = trk._track.lead
    far = Box.from_center(gts[0].cx + 200.0, gts[0].cy, gts[0].w, gts[0].h)
    lead.second.move(far)  # the second wanders onto something else
    res = trk.update(frames[2])
    assert not lead.opinion.stands and lead.opinion.det.smoothed.iou(res.box) < 0.3
    assert lead.second.net.center == pytest.approx(res.box.center)  # it looks where the leader is


@pytest.mark.usefixtures("nanotrack_weights", "lighttrack_weights")
def test_between_its_looks_the_second_moves_with_the_track(crossing_frames) -> None:
    frames, gts = crossing_frames
    trk = Tracker(_judged([*BIAS_ONLY, -50.0], every=1000))  # it never looks after the start
    trk.init(frames[0], gts[0])
    for frame in frames[1:6]:
        res = trk.update(frame)
        assert res.state is TrackState.TRACKING
    second = trk._track.lead.second
    assert second.net.center == pytest.approx(res.box.center)  # shifted by every accepted displacement
    assert second.net.size == (gts[0].w, gts[0].h)  # its own size, untouched



def test_two_agreeing_boxes_blend_and_disagreeing_ones_do_not() -> None:
    a = Box.from_center(100.0, 100.0, 20.0, 40.0)
    near, far = Box.from_center(102.0, 100.0, 22.0, 40.0), Box.from_center(160.0, 100.0, 20.0, 40.0)
    mean = Box.from_center(101.0, 100.0, 21.0, 40.0).as_tuple()
    assert blend(a, near, 0.5).as_tuple() == pytest.approx(mean)
    p = SecondParams(blend=0.5, lead_follows=False)
    assert joined(p, a, near, False).as_tuple() == pytest.approx(mean)  # they agree: the blend
    assert joined(p, a, far, False) == a  # they disagree, the leader stands
    assert joined(p, a, far, True) == far  # the second stands
    assert joined(replace(p, lead_follows=True), a, far, True) == a  # the leader searched there already
    assert joined(replace(p, blend=0.0), a, near, False) == a


def test_the_look_alike_guard_vetoes_a_box_off_the_motion_reference() -> None:
    lead = NetworkLead.__new__(NetworkLead)  # the veto reads the last accepted box only
    lead.box = Box.from_center(100.0, 100.0, 20.0, 40.0)
    guard = SimpleNamespace(reference=lambda: (100.0, 100.0, 1.0, 0.0), p=LookalikeParams(distance=0.5),
                            apart=LookalikeGuard.apart)
    assert lead._departs(Box.from_center(112.0, 100.0, 20.0, 40.0), guard)  # 0.6 widths away
    assert not lead._departs(Box.from_center(108.0, 100.0, 20.0, 40.0), guard)  # 0.4 widths
    assert not lead._departs(Box.from_center(300.0, 100.0, 20.0, 40.0), None)  # no guard, no veto


def test_the_second_is_confident_at_its_typical_psr_or_above() -> None:
    second = SecondOpinion.__new__(SecondOpinion)  # the test reads its PSR history only
    second.p, second._psr = SecondParams(), (deque(), deque())
    assert not second.confident(_cues(1.0, 50.0))  # no history yet
    second._psr[1].extend([math.log1p(10.0)] * 5)
    assert second.confident(_cues(1.0, 10.0)) and not second.confident(_cues(1.0, 9.0))


def test_while_gone_two_agreeing_opinions_resume_only_at_the_targets_size() -> None:
    lead = NetworkLead.__new__(NetworkLead)  # `_agreed` reads the last box, the opinion and the second
    lead.p, lead.box = LeadParams(), Box.from_center(100.0, 100.0, 20.0, 40.0)
    lead.missed, lead._speed = 10, 0.0  # the resume radius: 0.5 + 10 x 0.02 = 0.7 target sizes
    second = SimpleNamespace(p=SecondParams(agree_resumes=True), confident=lambda c: c.psr >= 10.0)
    lead.second = second

    def agreed(own: Box, other: Box, psr: float = 20.0) -> bool:
        lead.opinion = Opinion(SimpleNamespace(smoothed=other), _cues(1.0, psr), 0.1, False)
        return lead._agreed(SimpleNamespace(smoothed=own), pred, 32.0)

    pred = Box.from_center(120.0, 100.0, 20.0, 40.0)
    here = Box.from_center(130.0, 100.0, 20.0, 40.0)  # 10 px = 0.31 sizes of 32 px from the prediction
    assert agreed(here, Box.from_center(131.0, 101.0, 20.0, 40.0))
    assert not agreed(here, Box.from_center(131.0, 101.0, 20.0, 40.0), psr=5.0)  # the second is unsure
    assert not agreed(here, Box.from_center(160.0, 100.0, 20.0, 40.0))  # they disagree
    big = Box.from_center(130.0, 100.0, 40.0, 80.0)
    assert not agreed(big, big)  # twice the target's side: not its size
    there = Box.from_center(150.0, 100.0, 20.0, 40.0)  # 30 px = 0.94 sizes: beyond the motion's reach
    assert not agreed(there, there)
    second.p = SecondParams(agree_resumes=False)
    assert not agreed(here, here)
