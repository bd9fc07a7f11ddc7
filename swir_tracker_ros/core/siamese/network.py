# SPDX-License-Identifier: Apache-2.0
"""The Siamese networks in onnxruntime (CPU): a shared backbone and the correlation head, per family.

One runtime for every model, chosen by measurement (benchmarks/runtime_speed.py, docs/siamese.md): onnxruntime
runs NanoTrack's search 2-3x faster than OpenCV's DNN module on one thread, and OpenCV's DNN module returns a
wrong result for LightTrack-M's backbone. No PyTorch at run time.

- NanoTrack (HonglinChu/SiamTrackers) follows SiamRPN++'s depthwise cross-correlation (Li et al., CVPR 2019,
  Sec. 3.4) and SiamBAN's anchor-free head (Chen et al., CVPR 2020): the backbone (MobileNetV3) maps the
  127 px exemplar to 8x8 and the 255 px search crop to 16x16 features; the head gives `output1` (2 x S x S
  class logits, turned into the foreground probability by a softmax here) and `output2` (4 x S x S side
  distances).
  Input: float32 1x3xSxS, BGR 0-255. The published backbone declares a fixed 255 px input; its spatial size is
  made free when the session is built (the file on disk stays the verified one).
- LightTrack-Mobile (Yan et al., CVPR 2021): a NAS-found backbone (96 x H/16 x W/16 features) whose
  published file takes the uint8 1xHxWx3 BGR crop and normalises it itself (Cast, Gather BGR -> RGB, Sub the
  ImageNet mean, Div its deviation, Transpose to NCHW), a pixel-wise correlation head per search-map size (16
  for the 256 px crop, 18 for 288) giving `cls` (S x S, sigmoid applied) and `reg` (4 x S x S side
  distances). Those five input nodes are cut when the session is built (`_numpy_input`) and done here in
  numpy with the same float32 operations (`lighttrack_input`): the features are bit for bit the file's, the
  search about 2 ms (11-14 %) faster at 256 px (benchmarks/network_speed.py; onnxruntime runs them on the
  plain NHWC layout, outside its fused blocked-layout graph).

Graph optimisation: onnxruntime's default level (all) is used; it measured fastest for every model (2-3x
faster than the disabled/basic/extended levels, docs/siamese.md "Faster networks"). Precision: the heads in
float32 or int8 (`SiameseParams.precision`; the int8 heads made from the float ones, core/siamese/int8.py).

The exemplar features are computed once per template (`set_exemplar`), the search features on every search.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from pathlib import Path

import numpy as np
import onnxruntime as ort

from swir_tracker_ros.core.siamese.crops import blob
from swir_tracker_ros.core.siamese.locator import locate
from swir_tracker_ros.core.siamese.maps import softmax_score
from swir_tracker_ros.core.siamese.params import VersionConstants
from swir_tracker_ros.errors import ModelError, TrackerError


def _free_spatial(path: Path) -> bytes:
    """The model of `path` with the spatial sizes of its inputs and outputs left free (and the stored shapes
    of its inner tensors dropped), so that one backbone serves the exemplar and the search crop."""
    import onnx

    model = onnx.load(str(path))
    for vi in (*model.graph.input, *model.graph.output):
        dims = vi.type.tensor_type.shape.dim
        for k, name in ((2, "height"), (3, "width")):
            if len(dims) == 4:
                dims[k].dim_param = name
    del model.graph.value_info[:]
    return model.SerializeToString()


LIGHTTRACK_MEAN = np.array([123.675, 116.28, 103.53], np.float32)  # RGB, the published backbone's constants
LIGHTTRACK_STD = np.array([58.395, 57.12, 57.375], np.float32)
_LIGHTTRACK_INPUT_OPS = ("Cast", "Gather", "Sub", "Div", "Transpose")


def _numpy_input(path: Path) -> bytes:
    """LightTrack-M's backbone of `path` without its five input nodes (Cast, Gather, Sub, Div, Transpose):
    its input becomes the normalised float32 1x3xHxW crop (`lighttrack_input`). ModelError when the file's
    first nodes are not those (another file than the pinned one)."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    model = onnx.load(str(path))
    g = model.graph
    first = g.node[:len(_LIGHTTRACK_INPUT_OPS)]
    consts = {i.name: numpy_helper.to_array(i) for i in g.initializer}
    ok = (tuple(n.op_type for n in first) == _LIGHTTRACK_INPUT_OPS
          and np.array_equal(consts.get(first[1].input[1]), [2, 1, 0])
          and np.array_equal(consts.get(first[2].input[1], np.zeros(0)).ravel(), LIGHTTRACK_MEAN)
          and np.array_equal(consts.get(first[3].input[1], np.zeros(0)).ravel(), LIGHTTRACK_STD))
    if not ok:
        raise ModelError(f"model file {path} does not start with LightTrack-M's input normalisation "
                         f"({', '.join(_LIGHTTRACK_INPUT_OPS)}); not the pinned backbone")
    used = {n.input[1] for n in first[1:4]}
    rest = list(g.node[len(_LIGHTTRACK_INPUT_OPS):])
    del g.node[:]
    g.node.extend(rest)
    keep = [i for i in g.initializer if i.name not in used]
    del g.initializer[:]
    g.initializer.extend(keep)
    del g.input[:]
    g.input.extend([helper.make_tensor_value_info(first[4].output[0], TensorProto.FLOAT, [1, 3, "H", "W"])])
    return model.SerializeToString()


def lighttrack_input(patch: np.ndarray) -> np.ndarray:
    """The normalised float32 1x3xSxS input of LightTrack-M's backbone (`_numpy_input`) of an SxS gray or
    BGR uint8 crop: channels in RGB order, (x - mean) / std in float32, as the published file's nodes."""
    x = patch.astype(np.float32)
    if x.ndim == 2:
        chans = [(x - m) / s for m, s in zip(LIGHTTRACK_MEAN, LIGHTTRACK_STD)]
    else:
        chans = [(x[:, :, 2 - c] - LIGHTTRACK_MEAN[c]) / LIGHTTRACK_STD[c] for c in range(3)]
    return np.stack(chans)[None]


LEVELS = {"disabled": ort.GraphOptimizationLevel.ORT_DISABLE_ALL,
          "basic": ort.GraphOptimizationLevel.ORT_ENABLE_BASIC,
          "extended": ort.GraphOptimizationLevel.ORT_ENABLE_EXTENDED,
          "all": ort.GraphOptimizationLevel.ORT_ENABLE_ALL}
"""onnxruntime's graph optimisation levels (benchmarks/network_speed.py measures them; "all" is used)."""


def session(path: Path, threads: int = 1, free_spatial: bool = False, level: str = "all",
            numpy_input: bool = False, spinning: bool = True) -> ort.InferenceSession:
    """An onnxruntime CPU session of the model at `path` with `threads` intra-op threads (one inter-op,
    sequential), graph optimisation `level` (LEVELS) and the intra-op threads' spin-waiting on or off;
    `free_spatial`: NanoTrack's backbone with free input sizes, `numpy_input`: LightTrack-M's backbone without
    its input nodes. ModelError if onnxruntime cannot load it."""
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = threads
    opts.inter_op_num_threads = 1
    opts.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    opts.graph_optimization_level = LEVELS[level]
    opts.log_severity_level = 3  # errors only: no per-run shape warnings on stderr
    if not spinning:
        opts.add_session_config_entry("session.intra_op.allow_spinning", "0")
    try:
        model = (_free_spatial(path) if free_spatial else _numpy_input(path) if numpy_input else str(path))
        return ort.InferenceSession(model, sess_options=opts, providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime's and onnx's own error types: the file is not a usable model
        raise ModelError(f"model file {path} cannot be loaded by onnxruntime "
                         f"({str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__})"
                         ) from None


def require(constants: VersionConstants, model_dir: str | Path | None = None,
            precision: str = "float32") -> list[Path]:
    """The verified paths of every file the version needs at `precision`; ModelError naming the first
    missing one and the fix (for a configuration to check at start-up, before any target)."""
    return [locate(rel, model_dir) for rel in constants.files_for(precision)]


class SiameseNet(ABC):
    """What both families share: the exemplar's features kept as the template (`set_exemplar`), a search
    against it (`search`: the family's backbone features of the crop through its head, `_head_maps`)."""

    def __init__(self) -> None:
        self._z: np.ndarray | None = None

    @abstractmethod
    def features(self, patch: np.ndarray) -> np.ndarray:
        """Backbone features of a uint8 crop."""

    @abstractmethod
    def _head_maps(self, x: np.ndarray, patch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The head's score and side-distance maps of search features `x` against the template."""

    def set_exemplar(self, patch: np.ndarray) -> None:
        """Compute and keep the exemplar's features (the template)."""
        self._z = self.features(patch)

    @property
    def has_exemplar(self) -> bool:
        return self._z is not None

    def search(self, patch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(foreground score S x S, side distances 4 x S x S) of a search crop against the exemplar."""
        if self._z is None:
            raise TrackerError("the Siamese network has no exemplar yet: call init() first")
        return self._head_maps(self.features(patch), patch)


class NanoNet(SiameseNet):
    """The backbone and head of one NanoTrack version, loaded from their verified ONNX files."""

    def __init__(self, constants: VersionConstants, model_dir: str | Path | None = None,
                 threads: int = 1, precision: str = "float32") -> None:
        super().__init__()
        self.backbone_path, self.head_path = require(constants, model_dir, precision)
        self._backbone = session(self.backbone_path, threads, free_spatial=True)
        self._head = session(self.head_path, threads)
        self._input = self._backbone.get_inputs()[0].name

    def features(self, patch: np.ndarray) -> np.ndarray:
        """Backbone features of an SxS (x3) uint8 crop."""
        return self._backbone.run(None, {self._input: blob(patch)})[0]

    def _head_maps(self, x: np.ndarray, patch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Softmax foreground probability and side distances of the head's `output1` / `output2`."""
        cls, loc = self._head.run(["output1", "output2"], {"input1": self._z, "input2": x})
        return softmax_score(cls[0]), loc[0]


def bgr_batch(patch: np.ndarray) -> np.ndarray:
    """1xSxSx3 uint8 input of LightTrack-M's backbone: a one-channel crop replicated to three (BGR)."""
    if patch.ndim == 2:
        patch = np.repeat(patch[:, :, None], 3, axis=2)
    return np.ascontiguousarray(patch, dtype=np.uint8)[None]


class LightNet(SiameseNet):
    """LightTrack-M's backbone (its input normalisation done in numpy, module docstring) and its two heads
    (16 x 16 and 18 x 18 search maps), from verified files."""

    def __init__(self, constants: VersionConstants, model_dir: str | Path | None = None,
                 threads: int = 1, precision: str = "float32") -> None:
        super().__init__()
        paths = require(constants, model_dir, precision)
        self.backbone_path, self.head_path = paths[0], paths[1]
        self._backbone = session(paths[0], threads, numpy_input=True)
        self._input = self._backbone.get_inputs()[0].name
        self._heads = {}
        for path in paths[1:]:
            head = session(path, threads)
            self._heads[int(head.get_inputs()[1].shape[-1])] = head  # xf's side: 16 or 18

    def features(self, patch: np.ndarray) -> np.ndarray:
        """Backbone features (1 x 96 x S/16 x S/16) of an SxS (x3) uint8 crop."""
        return self._backbone.run(None, {self._input: lighttrack_input(patch)})[0]

    def _head_maps(self, x: np.ndarray, patch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sigmoid score and side distances of the head for this crop's map size."""
        head = self._heads.get(int(x.shape[-1]))
        if head is None:
            raise TrackerError(f"no LightTrack head for a {x.shape[-1]}x{x.shape[-1]} search map (crop "
                               f"{patch.shape[0]} px; heads: {sorted(self._heads)})")
        cls, reg = head.run(["cls", "reg"], {"zf": self._z, "xf": x})
        return cls.reshape(cls.shape[-2:]).astype(np.float64), reg.reshape(4, *reg.shape[-2:])


NETWORKS = {"nanotrack": NanoNet, "lighttrack": LightNet}
"""The network class of each family (VersionConstants.family)."""


def network(constants: VersionConstants, model_dir: str | Path | None = None,
            threads: int = 1, precision: str = "float32") -> SiameseNet:
    """The verified, loaded network of a version at `precision` (ModelError without its files)."""
    return NETWORKS[constants.family](constants, model_dir, threads, precision)
