# SPDX-License-Identifier: Apache-2.0
"""`harness make-bag` / `eval` / `compare` end to end with the real tracker core, JSON and plots."""

from __future__ import annotations

import json

import numpy as np
import pytest

from swir_tracker_ros.harness import cli
from swir_tracker_ros.harness.bagio import read_frames
from swir_tracker_ros.harness.evaluate import evaluate
from swir_tracker_ros.harness.sources import open_source


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
    js, plots = tmp_path / "r.json", tmp_path / "plots"
    rc = cli.main(["eval", str(crossing_bag), "--tracker", "cf", "robust_adaptive", "--json", str(js),
                   "--plots", str(plots), "--quiet"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "otb_crossing" in out and "MEAN" in out
    data = json.loads(js.read_text())
    row = data["sequences"]["otb_crossing"]["robust_adaptive"]
    assert {"precision_20", "success_auc", "center_error", "lost_frames", "fps"} <= set(row)
    assert set(data["mean"]) == {"cf", "robust_adaptive"}
    assert row["precision_20"] > 0.9 and row["fps"] > 0  # an easy, unoccluded pedestrian
    pngs = sorted(p.name for p in plots.glob("*.png"))
    assert pngs == ["precision_mean.png", "precision_otb_crossing.png", "success_mean.png",
                    "success_otb_crossing.png"]
    assert (plots / "precision_mean.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bag_and_folder_give_identical_scores(crossing_bag, sequences_dir):
    a = evaluate([open_source(crossing_bag, max_frames=25)], ["cf"]).sequences["otb_crossing"]["cf"]
    b = evaluate([open_source(sequences_dir / "otb_crossing", max_frames=25)], ["cf"]) \
        .sequences["otb_crossing"]["cf"]
    assert a.precision_curve == b.precision_curve and a.success_curve == b.success_curve


def test_eval_errors_are_one_line(tmp_path, capsys):
    assert cli.main(["eval", str(tmp_path / "missing"), "--tracker", "cf"]) == 2
    assert "harness: error:" in capsys.readouterr().err


def test_compare_adds_opencv_rows(crossing_bag):
    from swir_tracker_ros.harness.compare import BENCH, add_opencv

    if not (BENCH / ".installed").exists():
        pytest.skip("`make bench-venv` has not been run (compare builds it on first use)")
    result = evaluate([open_source(crossing_bag, max_frames=20)], ["cf"])
    add_opencv(result, [open_source(crossing_bag, max_frames=20)], ["MOSSE", "KCF"])
    per = result.sequences["otb_crossing"]
    assert set(per) == {"cf", "opencv_mosse", "opencv_kcf"}
    assert per["opencv_kcf"].frames == 20 and per["opencv_kcf"].precision_20 > 0.5


def test_json_round_trip_for_reuse(crossing_bag):
    from swir_tracker_ros.harness.evaluate import EvalResult

    r = evaluate([open_source(crossing_bag, max_frames=10)], ["cf"])
    back = EvalResult.from_json(json.loads(json.dumps(r.to_json(curves=True))))
    assert back.sequences["otb_crossing"]["cf"] == r.sequences["otb_crossing"]["cf"]
    again = evaluate([open_source(crossing_bag, max_frames=10)], ["cf"], reuse=back)
    assert again.sequences["otb_crossing"]["cf"] is back.sequences["otb_crossing"]["cf"]  # not re-run
