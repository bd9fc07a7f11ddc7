# SPDX-License-Identifier: Apache-2.0
"""`harness make-bag` / `eval` / `compare` / `table` end to end with the real tracker core, JSON and plots."""

from __future__ import annotations

import json

import numpy as np
import pytest

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness import cli
from swir_tracker_ros.harness.analysis import load_results
from swir_tracker_ros.harness.bagio import read_frames
from swir_tracker_ros.harness.compare import BENCH
from swir_tracker_ros.harness.evaluate import OPE, default_configuration
from swir_tracker_ros.harness.runner import Player, play
from swir_tracker_ros.harness.sources import open_source
from swir_tracker_ros.harness.store import RunStore


@pytest.fixture(scope="module")
def crossing_bag(tmp_path_factory, sequences_dir):
    out = tmp_path_factory.mktemp("bags") / "crossing"
    assert cli.main(["make-bag", str(sequences_dir / "otb_crossing"), str(out), "--frames", "40"]) == 0
    return out


def test_make_bag_keeps_frames_gt_and_stamps(crossing_bag, sequences_dir):
    seq = list(open_source(sequences_dir / "otb_crossing", max_frames=40).frames())
    bag = list(read_frames(crossing_bag))
    assert len(bag) == 40
    for a, b in zip(seq, bag):
        np.testing.assert_array_equal(a.image, b.image)
        assert a.gt == b.gt
    assert bag[1].stamp_ns - bag[0].stamp_ns == 40_000_000  # 25 fps header stamps


def test_make_bag_16_bit_and_synth(tmp_path, sequences_dir):
    out = tmp_path / "wide"
    assert cli.main(["make-bag", str(sequences_dir / "otb_crossing"), str(out), "--frames", "3",
                     "--bits", "16", "--storage", "mcap"]) == 0
    src = next(iter(open_source(sequences_dir / "otb_crossing").frames())).image
    first = next(read_frames(out)).image
    assert first.dtype == np.uint16
    np.testing.assert_array_equal(first, src.astype(np.uint16) * 257)
    syn = tmp_path / "syn"
    assert cli.main(["synth", "t9_clutter_moving_full_pan", str(syn), "--frames", "3"]) == 0
    frames = list(read_frames(syn))
    assert len(frames) == 3 and frames[0].image.shape == (504, 576) and frames[0].occluded is False
    assert open_source(syn).bits == 16 and open_source(syn).name == "t9_clutter_moving_full_pan"


def test_eval_cli_json_and_plots(crossing_bag, tmp_path, capsys):
    js, plots, results = tmp_path / "r.json", tmp_path / "plots", tmp_path / "results"
    rc = cli.main(["eval", str(crossing_bag), "--tracker", "cf", "robust_adaptive", "--json", str(js),
                   "--plots", str(plots), "--results", str(results), "--quiet"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "otb_crossing" in out and "MEAN" in out
    data = json.loads(js.read_text())
    row = data["sequences"]["otb_crossing"]["robust_adaptive"][OPE]
    assert {"precision_20", "success_auc", "center_error", "zero_iou", "false_tracking", "fps"} <= set(row)
    assert data["labels"] == ["cf", "robust_adaptive"] and row["frames"] == 39  # frames 2..40
    assert (results / "runs" / "robust_adaptive" / "otb_crossing" / "ope.json").is_file()
    pngs = sorted(p.name for p in plots.glob("*.png"))
    assert pngs == ["precision_mean.png", "precision_otb_crossing.png", "success_mean.png",
                    "success_otb_crossing.png"]
    assert (plots / "precision_mean.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the stored runs are scored again without being played: `table` reads storage only
    assert cli.main(["table", "cf", "robust_adaptive", "--results", str(results), "--protocol", "ope",
                     "--json", str(tmp_path / "t.json")]) == 0
    again = json.loads((tmp_path / "t.json").read_text())
    assert again["sequences"]["otb_crossing"] == data["sequences"]["otb_crossing"]
    out = capsys.readouterr().out
    assert "OPE sequences: AUC / P@20 / FT" in out  # the group: the data folder it is in
    assert "OPE sequences: gone recall / false loss / false tracking" in out


def test_bag_and_folder_give_identical_scores(crossing_bag, sequences_dir, tmp_path):
    bag = open_source(crossing_bag, max_frames=25)
    folder = open_source(sequences_dir / "otb_crossing", max_frames=25)
    scores = []
    for src, store in ((bag, RunStore(tmp_path / "a")), (folder, RunStore(tmp_path / "b"))):
        play([src], [Player.ours("cf")], (OPE,), "otb", store)
        scores.append(load_results(store, ["cf"], starts=(OPE,)).ope("otb_crossing@25", "cf"))
    assert scores[0].precision_curve == scores[1].precision_curve
    assert scores[0].success_curve == scores[1].success_curve
    # one results directory holds one content per sequence name: the bag is refused beside the folder
    with pytest.raises(HarnessError, match=r"otb_crossing@25 .* other content"):
        play([bag], [Player.ours("cf", label="other")], (OPE,), "otb", RunStore(tmp_path / "b"))


def test_eval_errors_are_one_line(tmp_path, capsys):
    assert cli.main(["eval", str(tmp_path / "missing"), "--tracker", "cf"]) == 2
    assert "harness: error:" in capsys.readouterr().err
    assert cli.main(["eval", str(tmp_path), "--tracker", "cf", "--reuse", "x.json"]) == 2
    assert "--reuse is gone" in capsys.readouterr().err
    assert cli.main(["table", "nobody", "--results", str(tmp_path)]) == 2
    assert "no runs labelled 'nobody'" in capsys.readouterr().err


def test_the_default_configuration_has_its_own_name():
    assert Player.ours("default").label == default_configuration() != "default"
    with pytest.raises(Exception, match=r"unknown configuration 'nope'; known: cf, .*default"):
        Player.ours("nope")


def test_compare_adds_opencv_rows(crossing_bag, tmp_path, capsys):
    if not (BENCH / ".installed").exists():
        pytest.skip("`make bench-venv` has not been run (compare builds it on first use)")
    rc = cli.main(["compare", str(crossing_bag), "--frames", "20", "--tracker", "cf", "--opencv", "MOSSE",
                   "KCF", "--results", str(tmp_path), "--json", str(tmp_path / "c.json"), "--quiet"])
    assert rc == 0
    per = json.loads((tmp_path / "c.json").read_text())["sequences"]["otb_crossing@20"]
    assert set(per) == {"cf", "opencv_mosse", "opencv_kcf"}
    assert per["opencv_kcf"][OPE]["frames"] == 19 and per["opencv_kcf"][OPE]["precision_20"] > 0.5
    rec = RunStore(tmp_path).load("opencv_kcf", "otb_crossing@20", OPE, None)
    assert rec.provenance["tracker"] == "opencv" and rec.provenance["code"].startswith("opencv-")
