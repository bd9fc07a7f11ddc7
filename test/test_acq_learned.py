# SPDX-License-Identifier: Apache-2.0
"""The learned person detector (acquisition/learned.py): letterbox, anchor grid, decoding, NMS on known
inputs; the detector on a tiny synthetic ONNX graph; its pinned file (weights.py `DETECTOR_PINNED`, taken
from a local git mirror); the node's refusal without the file; the real model on TUD-Campus when installed."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import cv2
import numpy as np
import pytest

from swir_tracker_ros.acquisition import learned
from swir_tracker_ros.acquisition.detectors import greedy_matches
from swir_tracker_ros.acquisition.params import AcquisitionParams
from swir_tracker_ros.core.siamese import locator, weights
from swir_tracker_ros.errors import AcquisitionError
from swir_tracker_ros.types import Box

SIZE = 416
ROWS = 52 * 52 + 26 * 26 + 13 * 13  # 3549 anchor points at 416


def _row(stride: int, gx: int, gy: int) -> int:
    """The head row of cell (gx, gy) of a stride."""
    start = {8: 0, 16: 52 * 52, 32: 52 * 52 + 26 * 26}[stride]
    return start + gy * (SIZE // stride) + gx


def _raw_with_person_and_car() -> np.ndarray:
    """A raw head with one person in stride-16 cell (10, 5) (centre (168, 88), 64x128 input px, score
    0.9 x 0.95) and a confident car (class 2) elsewhere."""
    raw = np.zeros((ROWS, 85), np.float32)
    p = raw[_row(16, 10, 5)]
    p[:4] = (0.5, 0.5, np.log(4.0), np.log(8.0))
    p[4], p[5] = 0.9, 0.95
    c = raw[_row(8, 3, 3)]
    c[:4] = (0.5, 0.5, 1.0, 1.0)
    c[4], c[5 + 2] = 0.99, 0.99
    return raw


def test_letterbox_is_yolox_preproc_of_a_mono_frame() -> None:
    """640x512 -> scale 0.65: the frame resized into the top-left 416x332, the rest 114, three equal
    planes."""
    g = (np.arange(512 * 640) % 251).astype(np.uint8).reshape(512, 640)
    x, r = learned.letterbox(g, SIZE)
    assert x.shape == (1, 3, SIZE, SIZE) and x.dtype == np.float32 and r == pytest.approx(0.65)
    assert np.array_equal(x[0, 0], x[0, 1]) and np.array_equal(x[0, 0], x[0, 2])
    resized = cv2.resize(g, (416, 332), interpolation=cv2.INTER_LINEAR)
    assert np.array_equal(x[0, 0, :332, :416], resized.astype(np.float32))
    assert (x[0, 0, 332:] == 114).all()


def test_anchor_grid_follows_the_head_rows() -> None:
    points, strides = learned.anchor_grid(SIZE)
    assert len(points) == ROWS and strides[0] == 8 and strides[-1] == 32
    k = _row(16, 10, 5)
    assert tuple(points[k]) == (10, 5) and strides[k] == 16


def test_decode_and_people_find_the_planted_person_in_frame_pixels() -> None:
    """Centre (grid + offset) x stride, size exp x stride, undone letterbox: (168 - 32, 88 - 64) / 0.5."""
    raw = _raw_with_person_and_car()
    xyxy = learned.decode(raw, SIZE)
    assert xyxy[_row(16, 10, 5)] == pytest.approx([136.0, 24.0, 200.0, 152.0])
    dets = learned.people(raw, SIZE, 0.5, 832, 832, score=0.3, nms_iou=0.45)
    assert len(dets) == 1  # the car is not a person
    assert dets[0].box.as_tuple() == pytest.approx((272.0, 48.0, 128.0, 256.0))
    assert dets[0].score == pytest.approx(0.855)
    assert learned.people(raw, SIZE, 0.5, 832, 832, score=0.9, nms_iou=0.45) == []
    # clipped to the image: a frame narrower than the box's right edge
    assert learned.people(raw, SIZE, 0.5, 300, 832, 0.3, 0.45)[0].box.as_tuple() == pytest.approx(
        (272.0, 48.0, 28.0, 256.0))
    with pytest.raises(AcquisitionError, match="3549 expected"):
        learned.decode(raw[:100], SIZE)


def test_nms_keeps_the_best_of_overlapping_boxes_and_separate_ones() -> None:
    boxes = np.array([[0, 0, 10, 20], [1, 0, 11, 20], [50, 0, 60, 20], [0, 0, 10, 20]], np.float64)
    scores = np.array([0.5, 0.9, 0.7, 0.4])
    assert learned.nms(boxes, scores, 0.45) == [1, 2]
    assert learned.nms(boxes, scores, 0.95) == [1, 2, 0]  # the exact duplicate (IoU 1) still goes


def _synthetic_model(path: Path, raw: np.ndarray) -> Path:
    """An ONNX graph with YOLOX-Nano's interface (images [1, 3, 416, 416] -> output [1, 3549, 85]) whose
    output is `raw` (plus 0 x the input's mean, so the input is used)."""
    onnx = pytest.importorskip("onnx")
    from onnx import TensorProto, helper, numpy_helper

    nodes = [helper.make_node("ReduceMean", ["images"], ["m"], axes=[1, 2, 3], keepdims=0),
             helper.make_node("Mul", ["m", "zero"], ["z"]),
             helper.make_node("Add", ["raw", "z"], ["output"])]
    graph = helper.make_graph(
        nodes, "yolox_stand_in",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, SIZE, SIZE])],
        [helper.make_tensor_value_info("output", TensorProto.FLOAT, [1, ROWS, 85])],
        [numpy_helper.from_array(raw[None], "raw"), numpy_helper.from_array(np.zeros(1, np.float32), "zero")])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    onnx.save(model, str(path))
    return path


def test_detector_runs_a_graph_on_mono8_and_mono16_frames(tmp_path: Path) -> None:
    """The Detector protocol around onnxruntime: a 832x832 mono8 or mono16 frame (letterbox 0.5) gives the
    planted person in frame pixels; a frame of the wrong shape is one AcquisitionError."""
    path = _synthetic_model(tmp_path / "m.onnx", _raw_with_person_and_car())
    det = learned.YoloxDetector(model_path=str(path))
    assert det.size == SIZE
    rng = np.random.default_rng(0)
    for frame in (rng.integers(0, 255, (832, 832), dtype=np.uint8),
                  rng.integers(0, 16383, (832, 832), dtype=np.uint16)):
        dets = det.detect(frame)
        assert [d.box.as_tuple() for d in dets] == [pytest.approx((272.0, 48.0, 128.0, 256.0))]
    with pytest.raises(AcquisitionError):
        det.detect(np.zeros((4, 4, 4, 4), np.uint16))


def test_mono16_is_stretched_to_the_8_bit_range() -> None:
    """A 16-bit frame using 1000 of its levels reaches the full 8-bit range (the conditioning's stretch),
    as a mono8 frame is passed through."""
    det = learned.YoloxDetector.__new__(learned.YoloxDetector)
    from swir_tracker_ros.core.conditioning import ConditioningConfig, FrameConditioner

    det.conditioner = FrameConditioner(ConditioningConfig())
    g16 = (np.tile(np.linspace(5000, 6000, 200), (100, 1))).astype(np.uint16)
    g8 = det.gray8(g16)
    assert g8.dtype == np.uint8 and g8.min() <= 2 and g8.max() >= 253
    m8 = np.full((10, 10), 77, np.uint8)
    assert det.gray8(m8) is m8


def _git_mirror(root: Path, repo: str, files: dict[str, bytes]) -> str:
    """A git repository under root/owner+name holding `files` at one commit; its commit id."""
    work = root / repo.replace("/", "+")
    work.mkdir(parents=True)
    env = {**os.environ, "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t",
           "GIT_COMMITTER_EMAIL": "t@t"}
    subprocess.run(["git", "init", "-q", str(work)], check=True, env=env)
    for rel, data in files.items():
        (work / rel).parent.mkdir(parents=True, exist_ok=True)
        (work / rel).write_bytes(data)
    subprocess.run(["git", "-C", str(work), "add", "-A"], check=True, env=env)
    subprocess.run(["git", "-C", str(work), "commit", "-qm", "x"], check=True, env=env)
    return subprocess.run(["git", "-C", str(work), "rev-parse", "HEAD"], check=True, capture_output=True,
                          text=True, env=env).stdout.strip()


def test_make_models_takes_the_detector_from_a_local_git_mirror_at_the_pinned_commit(tmp_path: Path) -> None:
    """fetch_optional: a git mirror holding the pinned commit gives the file, checked; a wrong content or
    no source is "missing" with the reason and `make models`, never an exception."""
    data = b"onnx bytes"
    commit = _git_mirror(tmp_path / "mirrors", "someone/detector", {"model/x.onnx": data})
    up = weights.Upstream("someone/detector", commit, "Apache-2.0", "model")
    good = weights.PinnedFile("detector/x.onnx", "detector/x.onnx", weights.hashlib.sha256(data).hexdigest(),
                              up, "model/x.onnx")
    done = weights.fetch_optional(tmp_path / "m", None, tmp_path / "mirrors", None, (good,))
    assert done[good.path].startswith(str(tmp_path / "mirrors"))
    assert (tmp_path / "m" / good.path).read_bytes() == data
    assert weights.fetch_optional(tmp_path / "m", None, None, None, (good,)) == {good.path: "present"}
    bad = weights.PinnedFile("detector/y.onnx", "detector/y.onnx", "0" * 64, up, "model/x.onnx")
    why = weights.fetch_optional(tmp_path / "m", None, tmp_path / "mirrors", None, (bad,))[bad.path]
    assert why.startswith("missing: ") and "sha256" in why and "make models" in why
    assert not (tmp_path / "m" / bad.path).exists()
    why = weights.fetch_optional(tmp_path / "m2", None, None, None, (good,))[good.path]
    assert "downloading is off" in why and up.page in why


def test_make_models_without_the_detector_says_so_and_succeeds(tmp_path: Path, monkeypatch, capsys) -> None:
    """The detector missing does not fail `make models` (no mirror holds it; CI has no network)."""
    monkeypatch.setattr(weights, "fetch_models", lambda *a, **k: {})
    monkeypatch.delenv(weights.GIT_MIRRORS_VAR, raising=False)
    assert weights.main(["--dest", str(tmp_path / "m"), "--no-download"]) == 0
    err = capsys.readouterr().err
    assert "detector/yolox_nano.onnx: not installed" in err and "detector: yolox" in err


def test_without_the_model_file_the_detector_is_refused_with_one_line(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setenv(locator.ENV_VAR, str(tmp_path))
    p = AcquisitionParams(detector="yolox")
    reason = p.detector_problem()
    assert reason is not None and "make models" in reason and "detector/yolox_nano.onnx" in reason
    assert "\n" not in reason and AcquisitionParams().detector_problem() is None
    with pytest.raises(AcquisitionError, match="make models"):
        p.make_detector()


def test_the_node_refuses_the_learned_detector_without_its_file(tmp_path: Path, monkeypatch, context) -> None:
    """At start-up: AcquisitionError (the runner's one line, exit 2); at run time: the change is refused
    with that reason and the motion detector stays."""
    from rclpy.parameter import Parameter

    from swir_tracker_ros.acquisition.detectors import MotionDetector
    from swir_tracker_ros.nodes.acquisition_node import AcquisitionNode

    monkeypatch.setenv(locator.ENV_VAR, str(tmp_path))
    with pytest.raises(AcquisitionError, match="make models"):
        AcquisitionNode(context=context, parameter_overrides=[Parameter("detector", value="yolox")])
    node = AcquisitionNode(context=context)
    try:
        res = node.set_parameters([Parameter("detector", value="yolox")])[0]
        assert not res.successful and "make models" in res.reason
        assert isinstance(node.detector, MotionDetector)
    finally:
        node.destroy_node()


def test_the_node_detects_on_every_nth_frame(context) -> None:
    """detect_every 3: frames 1, 4, 7 reach the detector; the others are only counted."""
    from rclpy.parameter import Parameter

    from msg_adapters.image import numpy_to_image
    from msg_adapters.stamps import header
    from swir_tracker_ros.nodes.acquisition_node import AcquisitionNode

    node = AcquisitionNode(context=context, parameter_overrides=[Parameter("detect_every", value=3)])
    calls: list[int] = []

    class Counting:
        def detect(self, frame, ego_shift=(0.0, 0.0)):
            calls.append(node.frames)
            return []

        def reset(self) -> None:
            pass

    try:
        node.detector = Counting()
        for k in range(7):
            node._on_image(numpy_to_image(np.zeros((64, 80), np.uint8), header(1.0 + k, "swir")))
        assert calls == [1, 4, 7]
    finally:
        node.destroy_node()


@pytest.fixture(scope="module")
def model() -> Path:
    problem = learned.model_problem()
    if problem is not None:
        pytest.skip(f"the pinned detector is not installed ({problem})")
    return learned.locate_model()


def test_the_pinned_model_finds_the_people_of_a_tud_campus_frame(model: Path, shared_dir: Path) -> None:
    """The real YOLOX-Nano through our letterbox and decoding: most annotated people of TUD-Campus frame 1
    are found at IoU 0.5 (a wrong scale or offset of the letterbox inverse finds none)."""
    seq = shared_dir / "data" / "mot" / "tud_campus"
    rows = np.loadtxt(seq / "gt.txt", delimiter=",", ndmin=2)
    gt = [Box(r[2] - 1.0, r[3] - 1.0, r[4], r[5]) for r in rows[rows[:, 0] == 1]]
    g = cv2.imread(str(seq / "000001.png"), cv2.IMREAD_GRAYSCALE)
    dets = learned.YoloxDetector().detect(g)
    _, found = greedy_matches([d.box for d in dets], gt)
    assert len(found) >= len(gt) / 2, (len(found), len(gt))
    assert all(0.3 <= d.score <= 1.0 for d in dets)


def test_a_file_onnxruntime_cannot_load_is_one_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.onnx"
    bad.write_bytes(b"not a model")
    with pytest.raises(AcquisitionError, match=r"detector yolox: .*bad\.onnx"):
        learned.YoloxDetector(model_path=str(bad))


def test_auto_initialisation_picks_up_a_person_under_a_panning_head(model: Path, shared_dir: Path) -> None:
    """TUD-Campus seen through a 300x300 window that pans 40 px a frame to the right (the scene moves left):
    given the head's image shift, the learned detector's boxes confirm a person after five updates and the
    box handed off covers an annotated person; without the shift no temporary track follows anyone."""
    from swir_tracker_ros.acquisition.handoff import AutoInitialiser

    seq = shared_dir / "data" / "mot" / "tud_campus"
    rows = np.loadtxt(seq / "gt.txt", delimiter=",", ndmin=2)
    det, step = learned.YoloxDetector(), 40
    views = []
    for k in range(8):
        g = cv2.imread(str(seq / f"{k + 1:06d}.png"), cv2.IMREAD_GRAYSCALE)
        views.append([d.box for d in det.detect(g[100:400, step * k:step * k + 300])])
    for compensate in (True, False):
        auto = AutoInitialiser()
        shift = (-float(step), 0.0) if compensate else (0.0, 0.0)
        out = [auto.step(b, shift if k else (0.0, 0.0)) for k, b in enumerate(views)]
        first = next((k for k, b in enumerate(out) if b is not None), None)
        if not compensate:
            assert first is None
            continue
        assert first == 5
        gt = [Box(r[2] - 1.0 - step * first, r[3] - 101.0, r[4], r[5]) for r in rows[rows[:, 0] == first + 1]]
        assert max(out[first].iou(b) for b in gt) >= 0.5


def test_the_node_runs_the_learned_detector_on_a_mono16_image(model: Path, shared_dir: Path, context) -> None:
    """detector yolox in the node: a 16-bit frame (TUD-Campus frame 1 x 64) goes through the detector and the
    association; people are found and the detector is the learned one."""
    from rclpy.parameter import Parameter

    from msg_adapters.image import numpy_to_image
    from msg_adapters.stamps import header
    from swir_tracker_ros.nodes.acquisition_node import AcquisitionNode

    g = cv2.imread(str(shared_dir / "data" / "mot" / "tud_campus" / "000001.png"), cv2.IMREAD_GRAYSCALE)
    node = AcquisitionNode(context=context, parameter_overrides=[Parameter("detector", value="yolox")])
    seen: list[int] = []
    try:
        assert isinstance(node.detector, learned.YoloxDetector)
        detect = node.detector.detect

        def counted(frame: np.ndarray, shift: tuple[float, float] = (0.0, 0.0)) -> list:
            out = detect(frame, shift)
            seen.append(len(out))
            return out

        node.detector.detect = counted
        node._on_image(numpy_to_image(g.astype(np.uint16) * 64, header(1.0, "swir")))
        assert seen and seen[0] >= 3
    finally:
        node.destroy_node()
