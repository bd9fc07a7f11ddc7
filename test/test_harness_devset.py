# SPDX-License-Identifier: Apache-2.0
"""Issue 44: the development set (data folders, videos and windows, absent frames), absent frames scored
apart, and the verdict paired over videos; numbers known by hand, no corpus needed."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness import cli
from swir_tracker_ros.harness.analysis import load_results
from swir_tracker_ros.harness.compare import BENCH
from swir_tracker_ros.harness.devset import CORPUS_ENV, DEV, catalogue, data_dirs, development_set, video_of
from swir_tracker_ros.harness.evaluate import OPE, Run
from swir_tracker_ros.harness.metrics import SRE_PERTURBATIONS, absence
from swir_tracker_ros.harness.protocol import Results, RunStats
from swir_tracker_ros.harness.runner import Player, play
from swir_tracker_ros.harness.sources import open_source, read_meta_json
from swir_tracker_ros.harness.store import RunStore
from swir_tracker_ros.harness.verdict import KEEP_SE, Pair, by_video, format_verdict, paired_verdict
from swir_tracker_ros.types import Box

GT = Box(10.0, 10.0, 10.0, 10.0)


def _hand_run() -> Run:
    """Frame 0 the start; 1-5 and 9 present, 6-8 absent (numbers worked out in the test below)."""
    far = Box(100.0, 100.0, 10.0, 10.0)
    pred = [GT, GT, Box(15.0, 10.0, 10.0, 10.0), far, GT, Box(19.0, 10.0, 10.0, 10.0),
            None, Box(50.0, 50.0, 10.0, 10.0), Box(60.0, 60.0, 10.0, 10.0), None]
    states = ["init", "tracking", "tracking", "tracking", "occluded", "tracking", "lost", "occluded",
              "tracking", "lost"]
    gt = [GT] * 6 + [None] * 3 + [GT]
    return Run(pred, gt, [None] * 10, 1.0, states, [None] * 10, GT, 0)


def test_absent_frames_are_scored_apart_numbers_by_hand():
    r = RunStats.of(_hand_run(), 25.0)
    # present frames 1-5 and 9: IoU 1, 1/3, 0, 1 (occluded frames score their box), 10/190, and frame 9
    # (lost) keeps the last box scored before it, (60, 60): IoU 0. Success counts over the 21 thresholds:
    # 20 + 7 + 0 + 20 + 2 + 0 = 49 -> AUC 49 / (6 * 21); the absent frames 6-8 are not IoU frames.
    assert r.frames == 6 and r.absent == 3
    assert r.success_auc == pytest.approx(49 / 126)
    assert r.precision_20 == pytest.approx(4 / 6)  # centre errors 0, 5, 127, 0, 9, 71
    assert r.gone == 2 and r.gone_recall == pytest.approx(2 / 3)  # frames 6 (lost), 7 (occluded); 8 not
    assert r.false_loss == 2 and r.false_loss_rate == pytest.approx(2 / 6)  # frames 4 and 9 said gone
    assert r.false_tracking_01 == 2 and r.false_tracking_rate == pytest.approx(2 / 6)  # frames 3 and 5
    assert r.false_tracking == 1  # the IoU-0 count stays as it was: frame 3 only
    d = r.to_json(curves=True)
    assert d["gone_recall"] == pytest.approx(2 / 3) and RunStats.from_json(d) == r
    a = absence(_hand_run().states, _hand_run().pred, _hand_run().gt)
    assert (a.absent, a.gone, a.present, a.false_loss) == (3, 2, 6, 2)
    # in the means: gone recall over the sequences that have absent frames, the rates over every sequence
    res = Results()
    res.add("a", "t", OPE, r)
    res.add("b", "t", OPE, RunStats(0.5, 1.0, 0, 0, 10, 0.0))
    m = res.summary("t", ["a", "b"])
    assert m["ope_gone_recall"] == pytest.approx(2 / 3) and m["ope_gone_sequences"] == 1
    assert m["ope_false_loss"] == pytest.approx(1 / 6) and m["ope_absent"] == 3
    assert m["ope_false_tracking_rate"] == pytest.approx(1 / 6)


def _results(per_seq: dict[str, tuple[float, float]], videos: dict[str, str]) -> Results:
    res = Results(videos=dict(videos))
    for seq, (a, b) in per_seq.items():
        res.add(seq, "base", OPE, RunStats(a, 0.5, 0, 0, 10, 0.0))
        res.add(seq, "cand", OPE, RunStats(b, 0.5, 0, 0, 10, 0.0))
    return res


def test_the_paired_statistic_on_known_numbers():
    # video v1 has two windows; per video: v1 (0.1 + 0.1) / 2 = +0.10, v2 -0.02, v3 (0.06 + 0.02) / 2 = +0.04
    per_seq = {"v1_w1": (0.40, 0.50), "v1_w2": (0.60, 0.70), "s2": (0.50, 0.48), "v3_w1": (0.30, 0.36),
               "v3_w2": (0.70, 0.72)}
    videos = {"v1_w1": "v1", "v1_w2": "v1", "v3_w1": "v3", "v3_w2": "v3"}
    v = paired_verdict(_results(per_seq, videos), "base", "cand")
    assert [p.name for p in v.videos.pairs] == ["v1", "s2", "v3"]
    assert [p.diff for p in v.videos.pairs] == pytest.approx([0.10, -0.02, 0.04])
    # mean 0.04; sd sqrt((0.06^2 + 0.06^2 + 0) / 2) = 0.06; SE 0.06 / sqrt(3)
    assert v.videos.mean_diff == pytest.approx(0.04) and v.videos.se == pytest.approx(0.06 / math.sqrt(3))
    assert (v.videos.wins, v.videos.losses) == (2, 1)
    assert not v.videos.keep  # 0.04 < 2 * 0.0346
    # an independent computation from the per-sequence AUCs
    diffs = {}
    for seq, (a, b) in per_seq.items():
        diffs.setdefault(videos.get(seq, seq), []).append(b - a)
    d = np.array([np.mean(x) for x in diffs.values()])
    assert v.videos.mean_diff == pytest.approx(d.mean())
    assert v.videos.se == pytest.approx(d.std(ddof=1) / np.sqrt(len(d)))
    text = format_verdict(v)
    assert "paired over 3 videos (5 sequences): mean diff +0.0400, SE 0.0346" in text
    assert "wins 2, losses 1" in text and "verdict: REJECT cand over base" in text
    js = v.to_json()
    assert (js["videos"], js["wins"], js["losses"]) == (3, 2, 1)
    assert js["mean_diff"] == pytest.approx(0.04) and js["se"] == pytest.approx(0.06 / math.sqrt(3))
    assert [p["diff"] for p in js["per_video"]] == pytest.approx([0.10, -0.02, 0.04])
    assert v.sre is None and js["sre"] is None  # no SRE runs stored: no second view
    # the SRE view: per sequence the mean and spread over the 12 starts, paired over videos like OPE
    res = _results(per_seq, videos)
    for seq, (a, b) in per_seq.items():
        if seq == "v3_w2":
            continue  # a sequence without every start is left out of the view
        for i, p in enumerate(SRE_PERTURBATIONS):
            res.add(seq, "base", p, RunStats(a + (0.1 if i == 0 else 0.0), 0.5, 0, 0, 10, 0.0))
            res.add(seq, "cand", p, RunStats(b, 0.5, 0, 0, 10, 0.0))
    sre = paired_verdict(res, "base", "cand")
    assert sre.videos.mean_diff == pytest.approx(0.04)  # the call stays on OPE
    assert sre.sre is not None and sre.sre.n == 3 and sre.sre_spread == pytest.approx((0.1, 0.0))
    # SRE means: base a + 0.1 / 12 on every sequence; per video v1 0.1, s2 -0.02, v3 (v3_w1 only) 0.06
    assert [p.diff for p in sre.sre.pairs] == pytest.approx([x - 0.1 / 12 for x in (0.10, -0.02, 0.06)])
    assert "SRE view (4 sequences with every start, 3 videos)" in format_verdict(sre)
    # a gain larger than 2 SE is kept
    up = by_video([Pair("a", 0.5, 0.6), Pair("b", 0.5, 0.62), Pair("c", 0.5, 0.58)], {})
    assert up.keep and up.mean_diff > KEEP_SE * up.se
    with pytest.raises(HarnessError, match="at least 2 videos"):
        by_video([Pair("a", 0.5, 0.6), Pair("b", 0.5, 0.6)], {"a": "v", "b": "v"})


def _write_sequence(folder, boxes, meta) -> None:
    """A corpus-layout sequence: 8-bit JPEG frames, gt.txt (0,0,0,0 where absent), meta.json."""
    folder.mkdir(parents=True)
    rng = np.random.default_rng(len(boxes))
    for k, b in enumerate(boxes):
        img = rng.integers(20, 60, (96, 128), dtype=np.uint8)
        if b != (0, 0, 0, 0):
            x, y, w, h = b
            img[y:y + h, x:x + w] = 220
            img[y + 4:y + h - 4, x + 4:x + w - 4] = 120
        cv2.imwrite(str(folder / f"{k + 1:06d}.jpg"), img)
    (folder / "gt.txt").write_text("".join(f"{x},{y},{w},{h}\n" for x, y, w, h in boxes))
    (folder / "meta.json").write_text(json.dumps(meta))


@pytest.fixture
def corpus(tmp_path):
    """Three sequences from two videos: vid/a cut into two windows, the second with two absent frames."""
    root = tmp_path / "corpus"
    moving = [(20 + 2 * k, 30, 20, 20) for k in range(8)]
    _write_sequence(root / "a_w1", moving, {"video": "vid/a", "window": [1, 8], "absent_frames": []})
    gone = moving[:4] + [(0, 0, 0, 0)] * 2 + moving[6:]
    _write_sequence(root / "a_w2", gone, {"video": "vid/a", "window": [9, 16], "absent_frames": [5, 6]})
    _write_sequence(root / "b", [(60 - 2 * k, 40, 18, 18) for k in range(8)], {"fps": 10})
    return root


def test_a_corpus_layout_is_read_end_to_end(corpus, tmp_path, capsys, monkeypatch):
    infos = catalogue(data_dirs([corpus]))
    assert {n: (i.group, i.video) for n, i in infos.items()} == {
        "a_w1": ("corpus", "vid/a"), "a_w2": ("corpus", "vid/a"), "b": ("corpus", "b")}
    assert infos["a_w2"].window == (9, 16) and infos["a_w2"].absent_frames == (5, 6)
    assert video_of("a_w2@4", infos) == "vid/a" and video_of("elsewhere", infos) == "elsewhere"
    frames = list(open_source(corpus / "a_w2").frames())
    assert [f.gt is None for f in frames] == [False] * 4 + [True] * 2 + [False] * 2
    monkeypatch.setenv(CORPUS_ENV, str(corpus))
    assert development_set()[1] == corpus and corpus in data_dirs([DEV])
    results = tmp_path / "r"
    common = ["--results", str(results), "--data", str(corpus), "--quiet"]
    assert cli.main(["eval", DEV, "--tracker", "cf", *common]) == 0
    assert cli.main(["eval", DEV, "--tracker", "cf", "--set", "scale.penalty=0.9", "--label", "cf2",
                     *common]) == 0
    prov = json.loads((results / "runs" / "cf2" / "a_w2" / "ope.json").read_text())["provenance"]
    assert prov["commit"] and prov["overrides"] == ["scale.penalty=0.9"]  # the store records commit and
    assert prov["parameters"]["scale"]["penalty"] == 0.9  # the parameters of every run
    js = tmp_path / "t.json"
    assert cli.main(["table", "cf", "cf2", "--protocol", "ope", "--json", str(js), *common]) == 0
    data = json.loads(js.read_text())
    assert data["groups"] == {"a_w1": "corpus", "a_w2": "corpus", "b": "corpus"}
    assert data["videos"] == {"a_w1": "vid/a", "a_w2": "vid/a", "b": "b"}
    row = data["sequences"]["a_w2"]["cf"][OPE]
    assert (row["frames"], row["absent"]) == (5, 2)  # frames 2..8: 5 present, 2 absent
    assert row["gone_recall"] is not None and 0.0 <= row["gone_recall"] <= 1.0
    out = capsys.readouterr().out
    assert "OPE corpus: gone recall / false loss / false tracking" in out and "OPE absent frames" in out
    vj = tmp_path / "v.json"
    assert cli.main(["verdict", "cf", "cf2", "--json", str(vj), *common]) == 0
    out = capsys.readouterr().out
    assert "paired over 2 videos (3 sequences)" in out and "verdict: " in out
    v = json.loads(vj.read_text())
    # the verdict agrees with an independent computation from the per-sequence AUCs of the table
    auc = {s: {t: data["sequences"][s][t][OPE]["success_auc"] for t in ("cf", "cf2")} for s in data["videos"]}
    per_video = [np.mean([auc[s]["cf2"] - auc[s]["cf"] for s in ("a_w1", "a_w2")]),
                 auc["b"]["cf2"] - auc["b"]["cf"]]
    assert v["videos"] == 2 and v["mean_diff"] == pytest.approx(np.mean(per_video))
    assert v["se"] == pytest.approx(np.std(per_video, ddof=1) / np.sqrt(2))
    assert [p["diff"] for p in v["per_video"]] == pytest.approx(per_video)
    assert v["wins"] + v["losses"] <= 2


def test_bad_corpus_meta_is_refused(tmp_path, corpus):
    meta = tmp_path / "meta.json"
    for bad, what in (({"video": 3}, "video"), ({"window": [5, 2]}, "window"),
                      ({"absent_frames": [0]}, "absent_frames")):
        meta.write_text(json.dumps(bad))
        with pytest.raises(HarnessError, match=what):
            read_meta_json(meta)
    meta.write_text(json.dumps({"absent_frames": 0}))  # the shared sequences give a count
    assert read_meta_json(meta) == {"absent_frames": 0}
    (corpus / "b" / "meta.json").write_text(json.dumps({"absent_frames": [2]}))
    with pytest.raises(HarnessError, match=r"lists frame 2 as absent but gt\.txt has a box"):
        list(open_source(corpus / "b").frames())
    with pytest.raises(HarnessError, match="no such data folder"):
        data_dirs([tmp_path / "nothing"])


@pytest.mark.skipif(not (BENCH / ".installed").exists(), reason=".venv-bench missing (`make bench-venv`)")
def test_opencv_nano_plays_beside_the_others(sequences_dir, tmp_path):
    """OpenCV's TrackerNano in .venv-bench, given the pinned NanoTrack v2 files, stored like CSRT."""
    try:
        player = Player.opencv("Nano")
    except HarnessError as exc:
        pytest.skip(str(exc))  # no weights (`make models`)
    assert player.label == "opencv_nano" and player.code().endswith("/nanotrack-v2")
    src = open_source(sequences_dir / "otb_crossing", max_frames=12)
    store = RunStore(tmp_path)
    play([src], [player], (OPE,), "otb", store)
    rec = store.load("opencv_nano", "otb_crossing@12", OPE, None)
    assert len(rec.boxes) == 12 and rec.states[0] == "init"
    assert set(rec.states[1:]) <= {"tracking", "lost"} and rec.provenance["parameters"]["nanotrack"] == "v2"
    stats = load_results(store, ["opencv_nano"]).ope("otb_crossing@12", "opencv_nano")
    assert stats.frames == 11 and stats.success_auc > 0.5
