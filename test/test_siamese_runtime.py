# SPDX-License-Identifier: Apache-2.0
"""One runtime for every network (issue 45): on real crops, NanoTrack's outputs in onnxruntime (the project's
runtime, core/siamese/network.py) equal OpenCV's DNN module's (the runtime before) within 1e-4 of each
output's scale, OpenCV's DNN module cannot run LightTrack-M, and the acquisition's embedding nets agree too
(benchmarks/runtime_speed.py prints the speeds)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from swir_tracker_ros.core.siamese.crops import blob, context_side, cut_subpixel
from swir_tracker_ros.core.siamese.maps import softmax_score
from swir_tracker_ros.core.siamese.network import LightNet, NanoNet, bgr_batch
from swir_tracker_ros.core.siamese.params import VERSIONS
from swir_tracker_ros.harness.sources import frame_files, read_frame, read_gt

TOLERANCE = 1e-4  # of max(1, the output's largest magnitude): features and distances reach ~100 px


def real_crops(sequences_dir: Path, name: str, exemplar: int, instance: int, frames=(5, 15)):
    """(exemplar crop of frame 1's box, search crops of `frames` around it) as uint8 arrays."""
    d = sequences_dir / name
    files, gt = frame_files(d), read_gt(d)
    b, first = gt[0], read_frame(files[0])
    s_z, fill = context_side(b.w, b.h, 0.5), np.mean(first, axis=(0, 1))
    z = cut_subpixel(first, b.cx, b.cy, s_z, exemplar, fill)
    xs = [cut_subpixel(read_frame(files[k]), gt[k].cx, gt[k].cy, s_z * instance / exemplar, instance, fill)
          for k in frames]
    return z, xs


def close(a: np.ndarray, b: np.ndarray) -> float:
    """Largest difference relative to max(1, |b|'s largest value)."""
    assert a.shape == b.shape
    return float(np.abs(a - b).max() / max(1.0, float(np.abs(b).max())))


@pytest.mark.usefixtures("nanotrack_weights")
@pytest.mark.parametrize("version", ["v2", "v3"])
@pytest.mark.parametrize("sequence", ["otb_crossing", "antiuav_irclip04"])
def test_nanotrack_outputs_equal_across_the_runtimes(version: str, sequence: str,
                                                     sequences_dir: Path) -> None:
    c = VERSIONS[version]
    ort_net = NanoNet(c)
    dnn_backbone = cv2.dnn.readNetFromONNX(str(ort_net.backbone_path))
    dnn_head = cv2.dnn.readNetFromONNX(str(ort_net.head_path))
    z, xs = real_crops(sequences_dir, sequence, c.exemplar_size, c.instance_size)
    ort_net.set_exemplar(z)
    dnn_backbone.setInput(blob(z))
    dnn_z = dnn_backbone.forward().copy()
    assert close(ort_net.features(z), dnn_z) < TOLERANCE
    for x in xs:
        dnn_backbone.setInput(blob(x))
        dnn_x = dnn_backbone.forward().copy()
        assert close(ort_net.features(x), dnn_x) < TOLERANCE
        dnn_head.setInput(dnn_z, "input1")
        dnn_head.setInput(dnn_x, "input2")
        cls, loc = dnn_head.forward(["output1", "output2"])
        score, dist = ort_net.search(x)
        assert close(score, softmax_score(cls[0])) < TOLERANCE and close(dist, loc[0]) < TOLERANCE


@pytest.mark.usefixtures("lighttrack_weights")
def test_opencv_cannot_run_lighttrack(sequences_dir: Path) -> None:
    """LightTrack-M's backbone in cv2.dnn gives 1x96x1x1 for a 256 px crop (onnxruntime: 1x96x16x16): the
    reason the project runs every network in onnxruntime."""
    c = VERSIONS["lighttrack"]
    net = LightNet(c)
    _, (x, *_) = real_crops(sequences_dir, "otb_crossing", c.exemplar_size, c.instance_size)
    assert net.features(x).shape == (1, 96, 16, 16)
    dnn = cv2.dnn.readNetFromONNX(str(net.backbone_path))
    dnn.setInput(bgr_batch(x))
    assert dnn.forward().shape != (1, 96, 16, 16)


def test_the_acquisition_nets_equal_across_the_runtimes(sequences_dir: Path) -> None:
    """The acquisition's five embedding nets (paper 004) run in onnxruntime too; their embeddings of real
    patches equal cv2.dnn's within 1e-4."""
    from swir_tracker_ros.acquisition.siamese import (
        MODELS_DIR,
        NET_NAMES,
        SiameseFamily,
        crop_resized,
        standardise,
    )

    d = sequences_dir / "otb_crossing"
    frame, box = read_frame(frame_files(d)[0]), read_gt(d)[0]
    patches = [crop_resized(frame, box.shifted(dx, 0.0), 64) for dx in (-5.0, 0.0, 5.0)]
    fam = SiameseFamily(MODELS_DIR)
    whole, parts = fam.embed_patches(patches)
    dnn = cv2.dnn.readNetFromONNX(str(MODELS_DIR / f"siamese_{NET_NAMES[0]}.onnx"))
    dnn.setInput(np.stack([standardise(p) for p in patches])[:, None].astype(np.float32))
    assert close(whole, dnn.forward().reshape(len(patches), -1)) < TOLERANCE
    assert parts.shape[:2] == (3, 4)
