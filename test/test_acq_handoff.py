# SPDX-License-Identifier: Apache-2.0
"""Hand-off: selection by ID, automatic confirmation (dissertation 003 Section 3.3.2.1), lost candidates."""

from __future__ import annotations

import numpy as np

from swir_tracker_ros.acquisition.association import CostWeights
from swir_tracker_ros.acquisition.descriptors import describe
from swir_tracker_ros.acquisition.handoff import (
    AutoInitialiser,
    AutoInitParams,
    TrackView,
    lost_candidates,
    select,
)
from swir_tracker_ros.scene import crowd
from swir_tracker_ros.types import Box


def test_select_returns_the_box_of_the_chosen_id() -> None:
    views = [TrackView(3, Box(1, 2, 3, 4)), TrackView(7, Box(10, 20, 30, 40))]
    assert select(views, 7) == Box(10, 20, 30, 40)
    assert select(views, 5) is None


def test_auto_confirms_a_steady_mover_after_five_updates() -> None:
    auto = AutoInitialiser()
    out = []
    for k in range(8):
        out.append(auto.step([Box(100 + 3 * k, 50, 30, 80)]))
    first = next(k for k, b in enumerate(out) if b is not None)
    assert first == 5  # birth on frame 0, updates on frames 1..5
    assert out[first].iou(Box(115, 50, 30, 80)) > 0.8


def test_auto_confirms_a_person_entering_the_view_under_a_moving_head() -> None:
    """The head pans: the scene moves 20 px a frame across the image while a person walks 2 px a frame
    into the view. Given the head's image shift the temporary track follows and is confirmed after five
    updates; without it every prediction misses (IoU 0.2) and nothing is confirmed."""
    def boxes(k: int) -> list[Box]:
        return [Box(600 - 18 * k, 50, 30, 80)]

    for shift, confirmed in (((-20.0, 0.0), True), ((0.0, 0.0), False)):
        auto = AutoInitialiser()
        out = [auto.step(boxes(k), shift if k else (0.0, 0.0)) for k in range(8)]
        assert (next((k for k, b in enumerate(out) if b is not None), None) == 5) is confirmed
        if confirmed:
            assert out[5].iou(boxes(5)[0]) > 0.8


def test_auto_does_not_confirm_jumping_boxes_and_restarts_after_the_window() -> None:
    rng = np.random.default_rng(0)
    auto = AutoInitialiser()
    for _ in range(30):
        assert auto.step([Box(*rng.uniform(0, 500, 2), 30, 80)]) is None
    # intermittent: updated only every third frame -> never 5 updates within 10 frames
    auto = AutoInitialiser(AutoInitParams())
    for k in range(30):
        assert auto.step([Box(100, 50, 30, 80)] if k % 3 == 0 else []) is None


def test_lost_candidates_rank_the_same_identity_first() -> None:
    scene = crowd.random_crowd(5, n=4)
    img0, gts0 = crowd.render(scene, 0)
    target = max(gts0, key=lambda g: g.visible_fraction * g.box.h)
    target_app = describe(img0, target.box)
    img, gts = crowd.render(scene, 30)
    views = [TrackView(10 + g.id, g.box, describe(img, g.box)) for g in gts if g.visible_fraction > 0.8]
    assert any(v.id == 10 + target.id for v in views)
    ranked = lost_candidates(target_app, views, CostWeights(use_siamese=False), k=2)
    assert len(ranked) == 2 and ranked[0][1] <= ranked[1][1]
    assert ranked[0][0] == 10 + target.id
