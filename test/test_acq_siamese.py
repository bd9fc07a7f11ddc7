# SPDX-License-Identifier: Apache-2.0
"""The shipped Siamese ONNX nets (paper 004 Section 3.2.1) run by cv2.dnn and match the torch training."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import REPO

from swir_tracker_ros.acquisition.siamese import MODELS_DIR, NET_NAMES, SiameseFamily, crop_resized
from swir_tracker_ros.errors import AcquisitionError
from swir_tracker_ros.types import Box

HELD_OUT = (3, 7)  # TUD-Campus identities the training script never sees (training/data.py HELD_OUT_TUD)
TRAIN_PY = REPO / ".venv-train" / "bin" / "python"


def _held_out_patches(shared: Path) -> dict[int, list[np.ndarray]]:
    seq = shared / "data" / "mot" / "tud_campus"
    rows = np.loadtxt(seq / "gt.txt", delimiter=",")
    out: dict[int, list[np.ndarray]] = {}
    for r in rows:
        if int(r[1]) in HELD_OUT and r[4] >= 19 and r[5] >= 50:
            img = cv2.imread(str(seq / f"{int(r[0]):06d}.png"), cv2.IMREAD_GRAYSCALE)
            out.setdefault(int(r[1]), []).append(crop_resized(img, Box(r[2] - 1, r[3] - 1, r[4], r[5])))
    return out


def test_models_are_small_and_described() -> None:
    meta = json.loads((MODELS_DIR / "siamese.json").read_text())
    total = sum((MODELS_DIR / f"siamese_{n}.onnx").stat().st_size for n in NET_NAMES)
    assert total < 10 * 2**20
    assert meta["nets"] == list(NET_NAMES) and meta["input_size"] == 64
    assert set(meta["sha256"]) == {f"siamese_{n}.onnx" for n in NET_NAMES}


def test_cv2_dnn_embeddings_separate_unseen_real_identities(shared_dir: Path) -> None:
    fam = SiameseFamily()
    patches = _held_out_patches(shared_dir)
    a, b = patches[HELD_OUT[0]], patches[HELD_OUT[1]]
    whole, parts = fam.embed_patches(a + b)
    assert whole.shape == (len(a) + len(b), 50) and parts.shape == (len(a) + len(b), 4, 30)
    assert np.all(whole >= 0) and np.all(np.isfinite(parts))
    label = np.array([0] * len(a) + [1] * len(b))
    d = np.linalg.norm(whole[:, None] - whole[None], axis=2)
    iu = np.triu_indices(len(label), 1)
    same = (label[:, None] == label[None])[iu]
    dist = d[iu]
    # ROC AUC of "smaller distance = same identity": 0.5 is chance
    pos, neg = dist[same], dist[~same]
    auc = float(np.mean(pos[:, None] < neg[None, :]) + 0.5 * np.mean(pos[:, None] == neg[None, :]))
    assert auc > 0.6, auc


def test_missing_models_raise(tmp_path: Path) -> None:
    with pytest.raises(AcquisitionError, match=r"siamese\.json"):
        SiameseFamily(tmp_path)


@pytest.mark.skipif(not TRAIN_PY.exists(), reason=(
    "training venv .venv-train is absent (torch is a training-only extra: "
    "python3 -m venv .venv-train && .venv-train/bin/pip install -r requirements-train.txt)"))
def test_onnx_through_onnxruntime_matches_torch_embeddings(shared_dir: Path) -> None:
    proc = subprocess.run([str(TRAIN_PY), str(REPO / "training" / "train_siamese.py"), "--verify",
                           "--shared", str(shared_dir), "--tol", "1e-4"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "max |torch - onnxruntime|" in proc.stdout
