# SPDX-License-Identifier: Apache-2.0
"""Stored runs: a run round-trips through its file, scoring from storage equals scoring the run directly,
stale runs are named instead of reused or mixed, and one scoring rule (failure keeps the last box) for all."""

from __future__ import annotations

import json

import pytest

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.analysis import load_results
from swir_tracker_ros.harness.evaluate import OPE, Run, make_tracker_factory, run_starts
from swir_tracker_ros.harness.metrics import scored_boxes
from swir_tracker_ros.harness.protocol import RunStats
from swir_tracker_ros.harness.runner import Player, play, truth_of
from swir_tracker_ros.harness.sources import open_source
from swir_tracker_ros.harness.store import RunRecord, RunStore, parse_tag, start_tag
from swir_tracker_ros.types import Box

GT = Box(100, 100, 20, 40)


def test_failure_keeps_the_last_box_whoever_reports_it():
    far, near = GT.shifted(200, 0), GT.shifted(4, 0)
    pred = [None, GT, near, Box(0, 0, 0, 0), far, None, near]
    states = ["idle", "init", "tracking", "lost", "occluded", "unanswered", "tracking"]
    # lost: the last scored box (near) is kept; occluded: its own box; unanswered: no box
    assert scored_boxes(pred, states) == [None, GT, near, near, far, None, near]
    ours = RunStats.of(Run(pred, [GT] * 7, [None] * 7, 1.0, states, [None] * 7, GT, 1), 25.0)
    blanked = [None if s == "lost" else b for b, s in zip(pred, states)]
    as_none = RunStats.of(Run(blanked, [GT] * 7, [None] * 7, 1.0, states, [None] * 7, GT, 1), 25.0)
    assert ours == as_none  # the box of a failure frame does not matter: the last one is scored
    assert ours.frames == 5 and ours.zero_iou == 2  # frames 2..7: far and the unanswered frame miss


def test_start_tags_round_trip():
    for start, style in ((OPE, None), ("left", "otb"), ("scale_0.8", "pixel"), ("top_left", "shift")):
        assert parse_tag(start_tag(start, style)) == (start, style)
    assert start_tag(OPE, "pixel") == "ope" and start_tag("left", "otb") == "left"


@pytest.fixture(scope="module")
def crossing(sequences_dir):
    return open_source(sequences_dir / "otb_crossing", max_frames=20)


@pytest.fixture(scope="module")
def stored(tmp_path_factory, crossing):
    store = RunStore(tmp_path_factory.mktemp("results"))
    play([crossing], [Player.ours("cf")], (OPE, "left", "scale_1.2"), "otb", store)
    return store


def test_a_stored_run_round_trips(stored, crossing):
    rec = stored.load("cf", "otb_crossing@20", "left", "otb")
    assert rec is not None and rec.label == "cf" and rec.sequence == "otb_crossing@20"
    assert len(rec.boxes) == len(rec.states) == 20 and rec.states[0] == "init"
    assert rec.provenance["tracker"] == "swir" and rec.provenance["configuration"] == "cf"
    assert rec.provenance["code"] and rec.provenance["fingerprint"] and rec.provenance["style"] == "otb"
    again = RunRecord.from_json(json.loads(json.dumps(rec.to_json())))
    assert again == rec
    path = stored.run_path("cf", "otb_crossing@20", "left", "otb")
    assert path.relative_to(stored.root).parts == ("runs", "cf", "otb_crossing@20", "left.json")
    truth = stored.load_truth("otb_crossing@20")
    assert truth is not None and truth.kind == "real" and (truth.width, truth.height) == (360, 240)
    assert truth.gt == [f.gt for f in crossing.frames()]


def test_scoring_from_storage_equals_scoring_the_run(stored, crossing):
    direct = run_starts(crossing, make_tracker_factory("cf"), (OPE, "left", "scale_1.2"))
    results = load_results(stored, ["cf"], ["otb_crossing@20"], (OPE, "left", "scale_1.2"))
    for start, run in direct.items():
        # the same boxes and states, scored the same; only the tracker's timing differs between two plays
        run.seconds = stored.load("cf", "otb_crossing@20", start, None if start == OPE else "otb").seconds
        assert results.runs("otb_crossing@20", "cf")[start] == RunStats.of(run, crossing.fps), start
    assert results.groups == {"otb_crossing@20": "sequences"}


def test_a_stored_run_is_taken_not_played_again(stored, crossing):
    said: list[str] = []
    before = stored.run_path("cf", "otb_crossing@20", OPE, None).stat().st_mtime_ns
    report = play([crossing], [Player.ours("cf")], (OPE,), "otb", stored, progress=said.append)
    assert (report.computed, report.reused) == (0, 1) and said == [f"1 run(s) taken from {stored.root}"]
    assert stored.run_path("cf", "otb_crossing@20", OPE, None).stat().st_mtime_ns == before


def test_a_stale_run_is_named_and_replaced_only_on_request(tmp_path, crossing):
    store = RunStore(tmp_path)
    play([crossing], [Player.ours("cf")], (OPE,), "otb", store)
    path = store.run_path("cf", "otb_crossing@20", OPE, None)
    data = json.loads(path.read_text())
    data["provenance"]["code"] = "older"  # as if the core had changed since
    path.write_text(json.dumps(data))
    with pytest.raises(HarnessError, match=r"code: 'older' -> .*--rerun"):
        play([crossing], [Player.ours("cf")], (OPE,), "otb", store)
    report = play([crossing], [Player.ours("cf")], (OPE,), "otb", store, rerun=True)
    assert (report.computed, report.replaced) == (1, 1)
    assert json.loads(path.read_text())["provenance"]["code"] != "older"


def test_runs_of_one_label_made_differently_are_not_mixed(tmp_path, crossing):
    store = RunStore(tmp_path)
    play([crossing], [Player.ours("cf")], (OPE, "left"), "otb", store)
    path = store.run_path("cf", "otb_crossing@20", "left", "otb")
    data = json.loads(path.read_text())
    data["provenance"]["numerics"] = {"cpu": "another machine"}
    path.write_text(json.dumps(data))
    with pytest.raises(HarnessError, match=r"made differently \(numerics differ"):
        load_results(store, ["cf"], starts=(OPE, "left"))
    mixed = load_results(store, ["cf"], starts=(OPE, "left"), allow_mixed=True)
    assert set(mixed.runs("otb_crossing@20", "cf")) == {OPE, "left"}


def test_overrides_are_stored_under_a_label_of_their_own(tmp_path, crossing):
    store = RunStore(tmp_path)
    player = Player.ours("cf", ["base.padding=2.0"])
    assert player.label.startswith("cf+") and player.overrides == ("base.padding=2.0",)
    assert Player.ours("cf", ["base.padding=2.0"], label="wide").label == "wide"
    play([crossing], [player], (OPE,), "otb", store)
    assert store.labels() == [player.label]
    rec = store.load(player.label, "otb_crossing@20", OPE, None)
    assert rec.provenance["overrides"] == ["base.padding=2.0"]


def test_truth_of_a_synthetic_source_keeps_the_occlusion_share():
    src = open_source("synth:t1_full_static_size", max_frames=5)
    run = run_starts(src, make_tracker_factory("cf"))[OPE]
    truth = truth_of(src, run)
    assert truth.kind == "synth" and len(truth.occlusion) == 5 and truth.sequence == "t1_full_static_size@5"
    assert all(o is not None for o in truth.occlusion)
