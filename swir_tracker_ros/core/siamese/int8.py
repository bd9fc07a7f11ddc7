# SPDX-License-Identifier: Apache-2.0
"""The int8 heads (`SiameseParams.precision` "int8"): their pins and how onnxruntime's quantisation tools make
them from the pinned float heads (`quantise_model`; the calibration frames and the making are
harness/quantise.py's, run by `make models`).

Only the heads are quantised: measured (benchmarks/network_speed.py, docs/siamese.md "Faster networks"), an
int8 backbone is not faster than the float one on this CPU for any of the three networks (onnxruntime's float
kernels fuse Conv + activation in the blocked NCHWc layout; the int8 graph keeps the swish / SE blocks as
separate QLinear ops) and its maps are far from float's, where the int8 heads shorten the search (LightTrack-M
by 1.5 ms of 16.4, v3 0.7 of 4.2, v2 0.2 of 3.0) with their maps close to float's.

Recipe: static QDQ, per-channel int8 weights, uint8 activations, MinMax ranges. `quant_pre_process` (onnx
shape inference, onnxruntime's basic graph optimisation: LightTrack-M's fp16 weights folded to float32),
onnxruntime's MinMax calibration on the calibration feeds, each range widened outward to 7 significant bits
(`rounded_range`: a last-bit difference of the float features on another CPU leaves the ranges, and so the
file's bytes, unchanged), then `quantize_static` from those ranges. With the same frames and onnxruntime
1.32.0 (requirements.txt) the bytes are the same on every run (made twice, compared; `MADE_PINNED` holds
their sha256).
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np

from swir_tracker_ros.core.siamese.weights import LIGHTTRACK_IR, NANOTRACK, PinnedFile

MADE_PINNED: tuple[PinnedFile, ...] = (
    PinnedFile("v2/nanotrack_head_sim_int8.onnx", "",
               "b16a2de7196e7b099e3eabd6e25b48a3b7d9ed9814b3078cec45dc9dded464c5", NANOTRACK),
    PinnedFile("v3/nanotrack_head_int8.onnx", "",
               "c5c38a20b5825127d0c82282d4d91b75bcc44cbde64bbc1e93200d0eae90b725", NANOTRACK),
    PinnedFile("lighttrack/lighttrack_head_16_int8.onnx", "",
               "6486d94a8fd49e4a5c16b89dbf48fca8c9298b79c22474d6ef073b7677bd297b", LIGHTTRACK_IR),
    PinnedFile("lighttrack/lighttrack_head_18_int8.onnx", "",
               "912bd25a0b6de914a36ab7a974161e1d5ceef1aed522ca524ccb673520cc302b", LIGHTTRACK_IR),
)
"""The int8 heads, made (not downloaded) from the verified float heads of the same upstream."""
MAKER = "python -m swir_tracker_ros.harness.quantise"  # what `make models` runs to make them
SIGNIFICANT_BITS = 7
"""Bits kept of each calibrated range end (`rounded_range`)."""


def made_pin(path: str) -> PinnedFile:
    """The pin of made file `path`; KeyError if it is not one."""
    for f in MADE_PINNED:
        if f.path == path:
            return f
    raise KeyError(path)


def rounded_range(lo: float, hi: float, bits: int = SIGNIFICANT_BITS) -> tuple[float, float]:
    """(lo, hi) widened outward to the nearest values with `bits` significant bits (0 stays 0)."""
    def out(v: float, up: bool) -> float:
        if v == 0.0 or not math.isfinite(v):
            return v
        step = 2.0 ** (math.floor(math.log2(abs(v))) - bits + 1)
        return (math.ceil(v / step) if up else math.floor(v / step)) * step
    return out(float(lo), False), out(float(hi), True)


class _Feeds:
    """onnxruntime's CalibrationDataReader over a list of feeds."""

    def __init__(self, feeds: list[dict[str, np.ndarray]]) -> None:
        self._it = iter(feeds)

    def get_next(self) -> dict[str, np.ndarray] | None:
        return next(self._it, None)


def quantise_model(src: Path | bytes, feeds: list[dict[str, np.ndarray]], out: Path, per_channel: bool = True,
                   dynamic: bool = False) -> None:
    """The int8 model of `src` (a file or serialised model) written to `out`: static QDQ (uint8
    activations, int8 weights per channel or per tensor, the MinMax ranges of `feeds` rounded as
    `rounded_range`; module docstring, step 3) or, `dynamic`, onnxruntime's dynamic quantisation (int8
    weights, activations quantised at run time; `feeds` unused). The pinned heads are the static per-channel
    form; benchmarks/network_speed.py measures the others."""
    from onnxruntime.quantization import (
        CalibrationMethod,
        QuantFormat,
        QuantType,
        quantize_dynamic,
        quantize_static,
    )
    from onnxruntime.quantization.calibrate import (
        TensorData,
        TensorsData,
        load_tensors_data,
        save_tensors_data,
    )
    from onnxruntime.quantization.shape_inference import quant_pre_process

    opts = dict(quant_format=QuantFormat.QDQ, per_channel=per_channel, activation_type=QuantType.QUInt8,
                weight_type=QuantType.QInt8, calibrate_method=CalibrationMethod.MinMax)
    with tempfile.TemporaryDirectory(prefix="swir-int8-") as tmp:
        pre, cache = Path(tmp, "pre.onnx"), Path(tmp, "ranges.json")
        if isinstance(src, bytes):
            Path(tmp, "src.onnx").write_bytes(src)
            src = Path(tmp, "src.onnx")
        quant_pre_process(str(src), str(pre), skip_symbolic_shape=True)
        if dynamic:
            quantize_dynamic(str(pre), str(out), weight_type=QuantType.QInt8, per_channel=per_channel)
            return
        quantize_static(str(pre), str(Path(tmp, "first.onnx")), _Feeds(feeds), calibration_cache_path=cache,
                        **opts)
        ranges = load_tensors_data(cache)
        rounded = {}
        for name in ranges:  # TensorsData: tensor name -> TensorData
            td = ranges[name]
            lo, hi = rounded_range(np.asarray(td.lowest).item(), np.asarray(td.highest).item())
            rounded[name] = TensorData(lowest=np.float32(lo), highest=np.float32(hi))
        cache.unlink()
        save_tensors_data(TensorsData(CalibrationMethod.MinMax, rounded), cache)
        quantize_static(str(pre), str(out), None, calibration_cache_path=cache, **opts)
