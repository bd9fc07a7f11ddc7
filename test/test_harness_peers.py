# SPDX-License-Identifier: Apache-2.0
"""Stored peers (../shared/peers): the ECO-HC port's boxes read as a tracker beside ours and OpenCV's."""

from __future__ import annotations

import shutil

import pytest

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.analysis import folder_truth, load_results
from swir_tracker_ros.harness.evaluate import OPE
from swir_tracker_ros.harness.metrics import SRE_PERTURBATIONS, sre_box
from swir_tracker_ros.harness.peers import PeerDirectory
from swir_tracker_ros.harness.sources import read_gt
from swir_tracker_ros.harness.store import RunStore


@pytest.fixture(scope="module")
def peers(shared_dir):
    return PeerDirectory(shared_dir / "peers")


def test_the_ecohc_reader_on_a_real_file(peers, sequences_dir):
    truth = folder_truth(sequences_dir / "otb_bolt")  # JPEG frames
    rec = peers.load("ecohc_py", truth, "scale_0.8")
    assert rec is not None and rec.label == "ecohc_py" and rec.style == "otb"
    lines = (peers.root / "ecohc_py" / "otb_bolt" / "scale_0.8.txt").read_text().split()
    assert len(rec.boxes) == len(lines) == len(truth.gt) == 77
    assert rec.boxes[5].as_tuple() == tuple(float(v) for v in lines[5].split(","))
    assert rec.init == sre_box(truth.gt[0], "scale_0.8", 640, 360) == rec.boxes[0]
    assert rec.states == ["init"] + ["tracking"] * 76 and rec.init_index == 0
    assert peers.load("ecohc_py", truth, "left", style="pixel") is None  # only the OTB starts are stored
    assert "ecohc_py" in peers.labels()


def test_a_peer_file_with_another_start_box_is_refused(tmp_path, peers, sequences_dir):
    truth = folder_truth(sequences_dir / "otb_crossing")
    (tmp_path / "p" / "otb_crossing").mkdir(parents=True)
    src = peers.root / "ecohc_py" / "otb_crossing" / "left.txt"
    shutil.copy(src, tmp_path / "p" / "otb_crossing" / "right.txt")  # the left start's boxes named right
    with pytest.raises(HarnessError, match=r"right\.txt: line 1 is the start box"):
        PeerDirectory(tmp_path).load("p", truth, "right")
    (tmp_path / "p" / "otb_crossing" / "ope.txt").write_text("204,150,17,50\n1,2,3,4\n")
    with pytest.raises(HarnessError, match=r"ope\.txt: 2 boxes for the 120 frames"):
        PeerDirectory(tmp_path).load("p", truth, OPE)


def test_the_peers_scores_are_those_its_readme_gives(tmp_path, shared_dir, sequences_dir):
    """../shared/peers/README.md: OPE mean 0.605 over the 24 sequences (0.672 on the 10 earlier ones),
    SRE mean 0.565, scored by the same convention (frames 2..N, AUC over IoU 0:0.05:1)."""
    res = load_results(RunStore(tmp_path), ["ecohc_py"], sorted(p.name for p in sequences_dir.iterdir()
                                                                  if (p / "gt.txt").exists()))
    seqs = list(res.stats)
    assert len(seqs) == 24 and all(len(res.runs(s, "ecohc_py")) == 13 for s in seqs)
    summ = res.summary("ecohc_py", seqs)
    assert summ["ope_auc"] == pytest.approx(0.605, abs=5e-4)
    assert summ["sre_auc"] == pytest.approx(0.565, abs=5e-4)
    png = [s for s in seqs if any((sequences_dir / s).glob("*.png"))]
    assert len(png) == 10 and res.summary("ecohc_py", png)["ope_auc"] == pytest.approx(0.672, abs=5e-4)
    assert {res.groups[s] for s in seqs} == {"sequences"}  # the data folder's name
    assert all(res.videos[s] == s for s in seqs)  # no meta.json "video": each is its own video
    # frames 2..N of every run are scored
    assert all(r.frames == len(read_gt(sequences_dir / "otb_bolt")) - 1
               for r in res.runs("otb_bolt", "ecohc_py").values())
    assert set(res.runs("otb_bolt", "ecohc_py")) == {OPE, *SRE_PERTURBATIONS}
