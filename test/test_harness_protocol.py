# SPDX-License-Identifier: Apache-2.0
"""Issue-12 protocol: SRE start boxes, false tracking, occlusions survived, peer cache, OPE+SRE end to end."""

from __future__ import annotations

import json
import math

import pytest

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness import cli
from swir_tracker_ros.harness.compare import BENCH, PeerCache, bench_python, run_worker, source_fingerprint
from swir_tracker_ros.harness.evaluate import Run
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
from swir_tracker_ros.harness.protocol import ProtocolResult, RunStats, run_protocol
from swir_tracker_ros.harness.sources import open_source
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


def test_peer_cache_key_path_and_round_trip(tmp_path, sequences_dir):
    src = open_source(sequences_dir / "otb_crossing", max_frames=10)
    k = PeerCache.key("4.14.0", "CSRT", src, "left")
    assert k["opencv"] == "4.14.0" and k["tracker"] == "CSRT" and k["sequence"] == "otb_crossing"
    assert k["start"] == "left" and k["style"] == "otb" and k["frames"] == 10
    longer = open_source(sequences_dir / "otb_crossing", max_frames=11)
    girl = open_source(sequences_dir / "otb_girl", max_frames=10)
    others = [PeerCache.key("4.12.0", "CSRT", src, "left"), PeerCache.key("4.14.0", "KCF", src, "left"),
              PeerCache.key("4.14.0", "CSRT", src, "right"),
              PeerCache.key("4.14.0", "CSRT", src, "left", "shift"),
              PeerCache.key("4.14.0", "CSRT", longer, "left"), PeerCache.key("4.14.0", "CSRT", girl, "left")]
    cache = PeerCache(tmp_path)
    paths = {cache.path(x) for x in [k, *others]}
    assert len(paths) == 7  # every component of the key changes the file
    ope = PeerCache.key("4.14.0", "CSRT", src, "none")
    assert PeerCache.key("4.14.0", "CSRT", src, "none", "shift") == ope  # OPE is the same in both styles
    p = cache.path(k)
    assert p.relative_to(tmp_path).parts[:3] == ("opencv-4.14.0", "CSRT", "otb_crossing")
    assert p.name.startswith("left-")
    assert source_fingerprint(src) == source_fingerprint(open_source(sequences_dir / "otb_crossing",
                                                                     max_frames=10))
    data = {"name": "otb_crossing", "tracker": "CSRT", "opencv": "4.14.0", "worker": 2,
            "gt": [[1, 2, 3, 4], [1, 2, 3, 4]], "occluded": [None, None], "occlusion": [None, None],
            "runs": [{"perturbation": "left", "init": [0, 2, 3, 4], "pred": [[0, 2, 3, 4], [1, 2, 3, 4]],
                      "ok": [False, True], "seconds": 0.5}]}
    assert cache.load(k) is None
    cache.store(k, data, "left")
    run = cache.load(k)
    assert run is not None and run.states == ["init", "tracking"] and run.init == Box(0, 2, 3, 4)
    stored = json.loads(p.read_text())
    stored["key"]["opencv"] = "4.12.0"  # a file whose stored key differs is not used
    p.write_text(json.dumps(stored))
    assert cache.load(k) is None


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
    res = ProtocolResult(("sre",), {"s": {"t": runs}}, {"s": "real"}, ["t"])
    sre = res.sre("s", "t")
    assert sre["carried_spread"] == pytest.approx(0.0) and sre["floor_spread"] == pytest.approx(4 / 21)
    summ = res.summary("t", ["s"])
    assert summ["sre_floor_spread"] == pytest.approx(4 / 21)
    assert summ["sre_carried_mean"] == pytest.approx(20 / 21)
    old = ProtocolResult.from_json({"protocols": ["sre"], "trackers": ["t"], "sequences": {"s": {
        "kind": "real", "t": {"ope": None, "sre": {p: {"success_auc": 0.5, "precision_20": 1.0,
                                                       "false_tracking": 0, "zero_iou": 0, "frames": 5,
                                                       "fps": 1.0} for p in SRE_PERTURBATIONS}}}}})
    assert "sre_carried_spread" not in old.summary("t", ["s"])  # JSON written before the field existed


def test_protocol_end_to_end_with_opencv_kcf(tmp_path, sequences_dir):
    src = open_source(sequences_dir / "otb_crossing", max_frames=12)
    first = next(iter(src.frames()))
    res = run_protocol([src], ["robust_adaptive"], ["KCF"], ("ope", "sre"), cache_root=tmp_path)
    assert res.trackers == ["robust_adaptive", "opencv_kcf"]
    for t in res.trackers:
        runs = res.stats["otb_crossing"][t]
        assert set(runs) == {"none", *SRE_PERTURBATIONS}
        assert all(r.frames == 11 for r in runs.values())  # frames 2..12 scored
    sre = res.sre("otb_crossing", "robust_adaptive")
    assert sre["runs"] == 12 and sre["min"] <= sre["mean"] <= sre["max"]
    # the worker started from the same perturbed boxes as ours
    h, w = first.image.shape[:2]
    opencv = res.meta["opencv"]
    for p in ("none", "top_left", "scale_1.2"):
        run = PeerCache(tmp_path).load(PeerCache.key(opencv, "KCF", src, p))
        assert run is not None and run.init == sre_box(first.gt, p, w, h)
    box = Box(30.4, 80.0, 20.0, 40.6)  # an explicit start box (bench_worker --init)
    explicit = run_worker(src, "KCF", bench_python(build=False), init=box)["init"]
    assert explicit.init == box and explicit.init_index == 0 and len(explicit.pred) == 12
    again = run_protocol([src], [], ["KCF"], ("ope", "sre"), cache_root=tmp_path)
    assert again.stats["otb_crossing"]["opencv_kcf"] == res.stats["otb_crossing"]["opencv_kcf"]
    back = ProtocolResult.from_json(json.loads(json.dumps(res.to_json())))
    assert back.stats == res.stats and back.kinds == {"otb_crossing": "real"}
    said: list[str] = []
    reused = run_protocol([src], ["robust_adaptive"], [], ("ope", "sre"), progress=said.append, reuse=back)
    assert said == ["1 (sequence, tracker) results reused"]
    assert reused.stats["otb_crossing"]["robust_adaptive"] == res.stats["otb_crossing"]["robust_adaptive"]


@needs_bench
def test_compare_protocol_cli_json(tmp_path, sequences_dir, capsys):
    js = tmp_path / "p.json"
    rc = cli.main(["compare", str(sequences_dir / "otb_crossing"), "--frames", "8", "--protocol", "ope",
                   "--tracker", "cf", "--opencv", "KCF", "--peer-cache", str(tmp_path / "cache"),
                   "--json", str(js), "--markdown", str(tmp_path / "p.md"), "--quiet"])
    assert rc == 0
    md = (tmp_path / "p.md").read_text()
    assert "| sequence | cf | opencv_kcf |" in md and "| otb_crossing | " in md
    out = capsys.readouterr().out
    assert "OPE real sequences" in out and "opencv_kcf" in out and "SRE" not in out.split("MEAN")[0]
    data = json.loads(js.read_text())
    assert set(data["summary"]["real"]) == {"cf", "opencv_kcf"} and data["meta"]["complete"] is True
    assert data["sequences"]["otb_crossing"]["cf"]["ope"]["frames"] == 7
    assert any((tmp_path / "cache").rglob("none-*.json"))


def test_set_overrides_tracker_parameters():
    from dataclasses import dataclass, field

    from swir_tracker_ros.errors import HarnessError
    from swir_tracker_ros.harness.evaluate import _set_path, tracker_params

    p = tracker_params("robust_adaptive", None, ["base.padding=2.0", "occlusion.max_frames=9"])
    assert p.base.padding == 2.0 and p.occlusion.max_frames == 9
    for bad in (["base.padding=-1"], ["no_such=1"], ["base.padding"], ["base.padding=[1"]):
        with pytest.raises(HarnessError):
            tracker_params("robust_adaptive", None, bad)

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
    """bench_worker v3: a frame whose `update` returns ok False is scored with the last box the tracker gave
    (as an application shows it, and as our tracker's box is scored in every state), not as no box."""
    from swir_tracker_ros.harness import bench_worker

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
