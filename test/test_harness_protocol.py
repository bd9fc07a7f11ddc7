# SPDX-License-Identifier: Apache-2.0
"""The protocol: SRE start boxes, false tracking, occlusions survived, stored OpenCV peers, OPE + SRE end to
end."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import pytest

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness import bench_worker, cli
from swir_tracker_ros.harness.analysis import load_results
from swir_tracker_ros.harness.compare import BENCH, bench_python, run_worker, runs_from_worker
from swir_tracker_ros.harness.evaluate import OPE, Run, _set_path, tracker_params
from swir_tracker_ros.harness.metrics import (
    SRE_PERTURBATIONS,
    carried_truth,
    carry,
    false_tracking,
    occlusion_episodes,
    occlusions_survived,
    sre_box,
    sre_boxes,
)
from swir_tracker_ros.harness.protocol import Results, RunStats
from swir_tracker_ros.harness.runner import Player, play, protocol_starts
from swir_tracker_ros.harness.sources import open_source
from swir_tracker_ros.harness.store import RunStore
from swir_tracker_ros.types import Box

# Hand-computed from the OTB toolkit's shiftInitBB for the 0-based box (100, 50, 40, 80) in a 640x480 image:
# centre shifts by ceil(0.1 * 40) = 4 and ceil(0.1 * 80) = 8; corner shifts move one corner by round(4),
# round(8) and keep the opposite corner (44 x 88); scales about the centre (120, 90), rounded.
OTB_EXPECTED = {
    "left": (96, 50, 40, 80), "right": (104, 50, 40, 80), "up": (100, 42, 40, 80), "down": (100, 58, 40, 80),
    "top_left": (96, 42, 44, 88), "top_right": (100, 42, 44, 88), "bottom_left": (96, 50, 44, 88),
    "bottom_right": (100, 50, 44, 88),
    "scale_0.8": (104, 58, 32, 64), "scale_0.9": (102, 54, 36, 72), "scale_1.1": (98, 46, 44, 88),
    "scale_1.2": (96, 42, 48, 96),
}


def test_sre_boxes_match_the_otb_toolkit_by_hand():
    boxes = sre_boxes(Box(100, 50, 40, 80), 640, 480)
    assert list(boxes) == list(SRE_PERTURBATIONS) and len(boxes) == 12
    assert {k: b.as_tuple() for k, b in boxes.items()} == OTB_EXPECTED


def test_sre_box_rounding_clipping_and_rigid_style():
    # w = 33, h = 21: centre shifts ceil(3.3) = 4, ceil(2.1) = 3; corner shifts round(3.3) = 3, round(2.1) = 2
    b = Box(10, 20, 33, 21)
    assert sre_box(b, "left", 640, 480).as_tuple() == (6, 20, 33, 21)
    assert sre_box(b, "down", 640, 480).as_tuple() == (10, 23, 33, 21)
    assert sre_box(b, "bottom_right", 640, 480).as_tuple() == (10, 20, 36, 23)
    assert sre_box(b, "top_left", 640, 480).as_tuple() == (7, 18, 36, 23)
    # clipped like the toolkit: a negative x / y is set to 0 with the size kept (the box moves: top_left
    # gives x = round(2 - 4) = -2, w = 44 -> (0, ..., 44)); a box past the right / bottom edge is cut
    assert sre_box(Box(2, 1, 40, 20), "top_left", 100, 100).as_tuple() == (0, 0, 44, 22)
    assert sre_box(Box(70, 0, 30, 20), "right", 100, 100).as_tuple() == (73, 0, 27, 20)
    # the literal paper reading: the whole box moves by 10 % of its size, size unchanged
    s = sre_box(Box(100, 50, 40, 80), "top_right", 640, 480, style="shift")
    assert s.as_tuple() == pytest.approx((104, 42, 40, 80))
    assert sre_box(b, "none", 640, 480) == b
    with pytest.raises(HarnessError):
        sre_box(b, "diagonal", 640, 480)


GT = Box(100, 100, 20, 40)
FAR = GT.shifted(200, 0)


def test_false_tracking_counts_only_tracking_frames_off_target():
    states = ["init", "tracking", "tracking", "occluded", "tracking", "lost", "tracking", "tracking"]
    pred = [GT, GT.shifted(5, 0), FAR, FAR, FAR, None, None, FAR]
    gt = [GT, GT, GT, GT, GT, GT, GT, None]
    # frame 2 and 4: tracking on background; frame 6: tracking without a box; frame 7: no ground truth
    assert false_tracking(states, pred, gt) == 3
    with pytest.raises(HarnessError):
        false_tracking(states[:-1], pred, gt)


def test_occlusion_episodes_and_survival():
    fps = 10.0  # 0.2 s = 2 frames, 1 s = 10 frames
    occ = [0.0] * 5 + [0.9] * 6 + [0.0] * 20 + [0.8] + [0.0] * 5 + [1.0] * 4 + [None] * 2
    eps = occlusion_episodes(occ, fps)
    assert eps == [(5, 10)]  # a one-frame dip is too short; the last run ends with the target out of view
    assert occlusion_episodes(occ[:-2], fps) == [(5, 10)]  # ... or is still going on at the end
    assert occlusion_episodes([*occ[:-2], 0.0], fps) == [(5, 10), (37, 40)]
    gt = [GT] * len(occ)
    states = ["tracking"] * len(occ)
    pred = [GT] * len(occ)
    assert occlusions_survived(eps, states, pred, gt, fps) == 1
    # on target again only 1.1 s after the target showed again: not survived
    late = ["occluded"] * 22 + ["tracking"] * (len(occ) - 22)
    assert occlusions_survived(eps, late, pred, gt, fps) == 0
    # claims tracking but on background: not survived
    assert occlusions_survived(eps, states, [FAR] * len(occ), gt, fps) == 0


def test_run_stats_score_frames_after_the_start():
    gt = [None, GT, GT, GT, GT]
    pred = [None, GT.shifted(3, 0), GT, FAR, None]
    run = Run(pred, gt, [None] * 5, 1.0, ["idle", "init", "tracking", "tracking", "lost"], [None] * 5,
              GT.shifted(3, 0), 1)
    st = RunStats.of(run, 25.0)
    assert st.frames == 3 and st.false_tracking == 1 and st.zero_iou == 2
    assert st.precision_20 == pytest.approx(1 / 3)


needs_bench = pytest.mark.skipif(not (BENCH / ".installed").exists(),
                                 reason=".venv-bench missing (`make bench-venv`)")


@needs_bench
def test_pixel_style_moves_the_start_box_by_a_pixel():
    boxes = sre_boxes(Box(100, 50, 40, 80), 640, 480, style="pixel")
    assert boxes["left"].as_tuple() == (99, 50, 40, 80)
    assert boxes["bottom_right"].as_tuple() == (101, 51, 40, 80)
    assert boxes["scale_0.8"].as_tuple() == (101, 51, 38, 78)
    assert boxes["scale_1.1"].as_tuple() == (99.5, 49.5, 41, 81)
    assert all(b.center_distance(Box(100, 50, 40, 80)) <= math.sqrt(2) for b in boxes.values())


def test_carried_truth_keeps_the_start_offset_and_scale():
    ref = Box(100, 50, 40, 80)
    start = sre_box(ref, "scale_0.8", 640, 480)  # (104, 58, 32, 64)
    later = Box(200, 100, 20, 40)  # the target moved and halved
    assert carry(start, ref, later).as_tuple() == pytest.approx((202, 104, 16, 32))
    left = sre_box(ref, "left", 640, 480)  # 4 px = 10 % of the width to the left
    assert carry(left, ref, later).as_tuple() == pytest.approx((198, 100, 20, 40))
    assert carried_truth(start, ref, [None, later])[0] is None


def test_run_stats_carried_and_floor_scores():
    """A tracker that follows the target exactly but keeps a 0.8 start's scale scores IoU 0.64 on every
    frame against the ground truth (the floor) and 1.0 against the carried truth (AUC 20/21: no IoU
    exceeds the last threshold, 1.0); the SRE summary's floor
    spread over the 12 OTB starts of a steady target is 0.826 - 0.64 (scale 1.1 against scale 0.8)."""
    gts = [Box(100 + 3 * k, 50, 40, 80) for k in range(6)]
    runs = {}
    for p in SRE_PERTURBATIONS:
        start = sre_box(gts[0], p, 640, 480)
        truth = carried_truth(start, gts[0], gts)
        runs[p] = RunStats.of(Run(truth, gts, [None] * 6, 1.0, ["init"] + ["tracking"] * 5, [None] * 6,
                                  start, 0), 25.0)
    assert runs["scale_0.8"].carried_auc == pytest.approx(20 / 21)
    # IoU 0.64 passes the thresholds 0, 0.05, ..., 0.6: 13 of 21
    assert runs["scale_0.8"].floor_auc == pytest.approx(13 / 21)
    res = Results()
    for p, r in runs.items():
        res.add("s", "t", p, r)
    sre = res.sre("s", "t")
    assert sre["carried_spread"] == pytest.approx(0.0) and sre["floor_spread"] == pytest.approx(4 / 21)
    summ = res.summary("t", ["s"])
    assert summ["sre_floor_spread"] == pytest.approx(4 / 21)
    assert summ["sre_carried_mean"] == pytest.approx(20 / 21)
    back = Results.from_json(json.loads(json.dumps(res.to_json(curves=True))))
    assert back.stats == res.stats and back.summary("t", ["s"]) == summ


@needs_bench
def test_protocol_end_to_end_with_opencv_kcf(tmp_path, sequences_dir):
    src = open_source(sequences_dir / "otb_crossing", max_frames=12)
    first = next(iter(src.frames()))
    store = RunStore(tmp_path)
    starts = protocol_starts(("ope", "sre"))
    play([src], [Player.ours("robust_adaptive"), Player.opencv("KCF")], starts, "otb", store)
    res = load_results(store, ["robust_adaptive", "opencv_kcf"], starts=starts)
    assert res.labels == ["robust_adaptive", "opencv_kcf"]
    for t in res.labels:
        runs = res.runs("otb_crossing@12", t)
        assert set(runs) == {OPE, *SRE_PERTURBATIONS}
        assert all(r.frames == 11 for r in runs.values())  # frames 2..12 scored
    sre = res.sre("otb_crossing@12", "robust_adaptive")
    assert sre["runs"] == 12 and sre["min"] <= sre["mean"] <= sre["max"]
    # the worker started from the same perturbed boxes as ours, and its runs are stored like ours
    h, w = first.image.shape[:2]
    for p in (OPE, "top_left", "scale_1.2"):
        ours = store.load("robust_adaptive", "otb_crossing@12", p, None if p == OPE else "otb")
        peer = store.load("opencv_kcf", "otb_crossing@12", p, None if p == OPE else "otb")
        assert peer.init == ours.init == sre_box(first.gt, p, w, h)
        assert peer.provenance["tracker"] == "opencv" and peer.provenance["configuration"] == "KCF"
    box = Box(30.4, 80.0, 20.0, 40.6)  # an explicit start box (bench_worker --init)
    explicit = run_worker(src, "KCF", bench_python(build=False), init=box)["init"]
    assert explicit.init == box and explicit.init_index == 0 and len(explicit.pred) == 12
    said: list[str] = []
    again = play([src], [Player.opencv("KCF")], starts, "otb", store, progress=said.append)
    assert again.computed == 0 and said == [f"13 run(s) taken from {store.root}"]


@needs_bench
def test_compare_protocol_cli_with_peers(tmp_path, sequences_dir, capsys):
    js = tmp_path / "p.json"
    rc = cli.main(["compare", str(sequences_dir / "otb_crossing"), "--frames", "8", "--protocol", "ope",
                   "--tracker", "cf", "--opencv", "KCF", "--peers", "ecohc_py",
                   "--results", str(tmp_path / "r"), "--json", str(js), "--markdown", str(tmp_path / "p.md"),
                   "--quiet"])
    assert rc == 0
    md = (tmp_path / "p.md").read_text()
    assert "| sequence | cf | opencv_kcf | ecohc_py |" in md and "| otb_crossing@8 | " in md
    out = capsys.readouterr().out
    assert "OPE sequences" in out and "opencv_kcf" in out and "SRE" not in out.split("MEAN")[0]
    data = json.loads(js.read_text())
    assert set(data["summary"]["sequences"]) == {"cf", "opencv_kcf", "ecohc_py"}
    assert data["sequences"]["otb_crossing@8"]["ecohc_py"][OPE]["frames"] == 7
    assert cli.main(["compare", str(sequences_dir / "otb_crossing"), "--protocol", "ope", "--peer-cache",
                     str(tmp_path)]) == 2
    assert "--peer-cache is gone" in capsys.readouterr().err


def test_set_overrides_tracker_parameters():
    p = tracker_params("robust_adaptive", ["base.padding=2.0", "occlusion.max_frames=9"])
    assert p.base.padding == 2.0 and p.occlusion.max_frames == 9
    assert type(tracker_params("measured", ["pipeline=dcf_ca"]).base).__name__ == "DCFCAParams"
    for bad in (["base.padding=-1"], ["no_such=1"], ["base.padding"], ["base.padding=[1"], ["pipeline=nope"]):
        with pytest.raises(HarnessError):
            tracker_params("robust_adaptive", bad)

    @dataclass
    class Inner:
        padding: float = 1.5

    @dataclass
    class Outer:
        kcf: Inner = field(default_factory=Inner)

    assert _set_path(Outer(), ["kcf", "padding"], 2.5, "kcf.padding=2.5").kcf.padding == 2.5  # nested groups
    with pytest.raises(HarnessError):
        _set_path(Outer(), ["kcf", "window"], 2.5, "kcf.window=2.5")


def test_opencv_failure_frames_keep_the_last_box(monkeypatch) -> None:
    """bench_worker v3: a frame whose `update` returns ok False is stored as state `lost` with the last box
    the tracker gave (the scoring rule keeps the last box on a failure frame for every tracker)."""
    class Flaky:
        def __init__(self) -> None:
            self.k = 0

        def init(self, img, rect) -> None:
            self.rect = rect

        def update(self, img):
            self.k += 1
            x, y, w, h = self.rect
            return self.k % 3 != 0, (x + self.k, y, w, h)  # every third update fails (box then junk)

    monkeypatch.setitem(bench_worker.FACTORIES, "FLAKY", Flaky)
    out = bench_worker.run("synth:control_no_occlusion", "FLAKY", max_frames=8)
    run = out["runs"][0]
    assert run["ok"][3] is False and run["ok"][4] is True
    assert run["pred"][3] == run["pred"][2]  # held, not None
    assert all(p is not None for p in run["pred"])
    out["gt"] = [[0.0, 0.0, 1.0, 1.0]] * 8
    stored = runs_from_worker(out)["none"]
    assert stored.states[3] == "lost" and stored.states[4] == "tracking"
