# SPDX-License-Identifier: Apache-2.0
"""SWIR frame conditioning (bit depths, stretch, dead pixels, fields, downscale) and TrackerParams."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from swir_tracker_ros.core.conditioning import (
    ConditioningConfig,
    ConditioningError,
    FrameConditioner,
    presmooth,
    single_field,
    to_gray,
)
from swir_tracker_ros.core.features import SmoothedFrame, sample_patch
from swir_tracker_ros.errors import ParameterError, TrackerError
from swir_tracker_ros.paramfield import flat_fields
from swir_tracker_ros.tracker import TrackerParams
from swir_tracker_ros.types import Box


def test_16bit_stretch_uses_the_robust_range_without_overflow() -> None:
    rng = np.random.default_rng(0)
    frame = rng.integers(30000, 30400, (64, 80)).astype(np.uint16)  # low-contrast SWIR-like
    frame[0, 0], frame[1, 1] = 65535, 0  # single hot / cold pixels must not set the range
    out = FrameConditioner(ConditioningConfig(stretch_smoothing=0.0))(frame)
    assert out.dtype == np.float32 and out.min() >= 0.0 and out.max() <= 1.0
    assert np.percentile(out, 95) - np.percentile(out, 5) > 0.8  # contrast spread over the range


def test_8bit_passthrough_and_bit_depth_hint() -> None:
    frame = np.arange(256, dtype=np.uint8).reshape(16, 16)
    out = FrameConditioner(ConditioningConfig())(frame)
    assert out[0, 0] == 0.0 and out[-1, -1] == pytest.approx(1.0)
    twelve = (np.arange(256, dtype=np.uint16) * 16).reshape(16, 16)
    off = FrameConditioner(ConditioningConfig(stretch="off"))
    assert off(twelve, bit_depth=12).max() == pytest.approx(4080 / 4095)
    assert off(twelve).max() == pytest.approx(4080 / 65535)


def test_colour_and_bad_frames() -> None:
    bgr = np.zeros((20, 30, 3), np.uint8)
    bgr[..., 2] = 255
    assert to_gray(bgr).shape == (20, 30)
    cond = FrameConditioner(ConditioningConfig())
    for bad in (np.zeros((20, 30, 2)), np.zeros((4, 4)), np.zeros((20, 30), bool), np.full((20, 30), np.nan)):
        with pytest.raises(ConditioningError):
            cond(bad)
    assert issubclass(ConditioningError, TrackerError)


def test_dead_pixels_fields_and_downscale() -> None:
    img = np.full((40, 60), 0.4, np.float32)
    img[10, 10] = 1.0  # salt
    img[20, 30] = 0.0  # pepper
    out = FrameConditioner(ConditioningConfig(stretch="off", dead_pixel_threshold=0.2))(img)
    assert np.allclose(out, 0.4)
    inter = np.zeros((8, 6), np.float32)
    inter[1::2] = 1.0  # odd field bright (combing)
    assert np.allclose(single_field(inter, "even"), 0.0) and np.allclose(single_field(inter, "odd"), 1.0)
    small = FrameConditioner(ConditioningConfig(stretch="off", downscale=0.5))(np.zeros((100, 80), np.uint8))
    assert small.shape == (50, 40)


def test_tracker_params_are_documented_and_validated() -> None:
    from swir_tracker_ros.configs import configuration
    from swir_tracker_ros.core.bacf import BACFParams
    from swir_tracker_ros.core.dcf_ca import DCFCAParams
    from swir_tracker_ros.core.kcf import KCFParams
    from swir_tracker_ros.policies.scale_search import ScaleSearch, ScaleSearchParams

    p = TrackerParams()
    p.validate()
    for base in (KCFParams(), DCFCAParams(), BACFParams()):
        for name, f, value in flat_fields(TrackerParams(base=base)):
            assert f.metadata.get("doc"), name
            if isinstance(value, str):
                assert value in f.metadata["choices"], name
    assert ScaleSearch(p.scale).normal == pytest.approx((0.90, 0.95, 1.0, 1.05, 1.10))
    k, d = configuration("robust_adaptive").base, DCFCAParams()
    assert (k.padding, k.lambda_, k.kernel_sigma, k.interp_factor) == (1.5, 1e-4, 0.5, 0.02)
    assert (d.lambda1, d.lambda2, d.padding, d.interp_factor) == (1e-4, 25.0, 2.0, 0.015)
    assert (k.psr_threshold, k.update_peak_threshold, d.apce_occlusion_ratio) == (7.0, 0.5, 0.6)
    for bad in (
        dict(base=KCFParams(psr_threshold=-1.0)),
        dict(scale=ScaleSearchParams(n=4)),
        dict(base=KCFParams(padding="2")),
        dict(base=DCFCAParams(lambda2=math.nan)),
        dict(conditioning=ConditioningConfig(low_percentile=40.0, high_percentile=39.0)),
        dict(trail_frames=1.5),
    ):
        with pytest.raises(ParameterError):
            TrackerParams(**bad).validate()
    with pytest.raises(ParameterError, match=r"base\.psr_threshold"):
        TrackerParams(base=KCFParams(psr_threshold=-1.0)).validate()


def test_percentiles_equal_np_percentile() -> None:
    """The conditioner's own percentile (issue 17: less per-call overhead) gives np.percentile's numbers."""
    from swir_tracker_ros.core.conditioning import _percentiles

    rng = np.random.default_rng(5)
    for k in range(2000):
        n = int(rng.integers(1, 15000))
        sample = (rng.random(n) * rng.choice([1.0, 255.0, 65535.0])).astype(np.float32)
        if k % 3 == 0:
            sample = np.round(sample)  # ties, as in integer frames
        low, high = (0.5, 99.5) if k % 4 == 0 else (5.0 * rng.random(), 95.0 + 5.0 * rng.random())
        want = tuple(float(v) for v in np.percentile(sample, [low, high]))
        assert _percentiles(sample, low, high) == want


def test_counted_percentile_limits_equal_np_percentile() -> None:
    """8/16-bit frames take counted order statistics (core/corr_jit.py, no partition of a float32 copy):
    np.percentile's numbers of the float32 subsample, bit for bit (ties, contiguous or not, full range)."""
    from swir_tracker_ros.core.conditioning import percentile_limits

    rng = np.random.default_rng(11)
    for k in range(600):
        dtype = np.uint8 if k % 2 else np.uint16
        rows, cols = (int(v) for v in rng.integers(1, 200, 2))
        top = 256 if dtype == np.uint8 else int(rng.choice([2, 300, 4096, 65536]))
        frame = rng.integers(0, top, (rows, cols)).astype(dtype)
        if k % 5 == 0:
            frame = frame[:, ::2]  # a strided view
        low, high = (0.5, 99.5) if k % 4 == 0 else (100 * rng.random(), 100 * rng.random())
        if k % 9 == 0:
            low, high = float(rng.choice([0.0, 100.0])), float(rng.choice([0.0, 100.0]))
        max_samples = int(rng.choice([10000, 50, 1]))
        step = max(1, int(np.sqrt(frame.size / max_samples)))
        sample = frame[::step, ::step].ravel().astype(np.float32)
        want = tuple(float(v) for v in np.percentile(sample, [low, high]))
        assert percentile_limits(frame, low, high, max_samples) == want


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("stretch", ["auto", "always", "off"])
def test_fused_stretch_equals_the_numpy_passes(
    sequences_dir, dtype: type, stretch: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The compiled one-pass stretch (core/corr_jit.py) gives the numpy passes' frames bit for bit, on real
    frames (8 bit, and widened to 16 bit as a SWIR camera would give them) over several frames (EMA)."""
    import cv2

    from swir_tracker_ros.core import kernels

    pngs = sorted((sequences_dir / "ptbtir_airplane").glob("*.png"))[:6]
    frames = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in pngs]
    if dtype == np.uint16:
        frames = [(f.astype(np.uint16) * 37 + 20000).astype(np.uint16) for f in frames]
    outs = {}
    for jit in (True, False):
        monkeypatch.setattr(kernels, "USE_JIT", jit)
        cond = FrameConditioner(ConditioningConfig(stretch=stretch))
        outs[jit] = [cond(f) for f in frames]
    for a, b in zip(outs[True], outs[False]):
        assert a.dtype == b.dtype == np.float32
        np.testing.assert_array_equal(a.view(np.uint32), b.view(np.uint32))  # every bit, sign of zero too


def _detail(patch: np.ndarray) -> float:
    """High-frequency energy of a patch: mean squared 4-neighbour Laplacian."""
    lap = 4 * patch[1:-1, 1:-1] - patch[:-2, 1:-1] - patch[2:, 1:-1] - patch[1:-1, :-2] - patch[1:-1, 2:]
    return float(np.mean(lap**2))


def test_a_presmoothed_frame_samples_alike_at_any_sub_pixel_offset(sequences_dir) -> None:
    """`presmooth`: a window sampled half a pixel off the pixel grid is averaged by the bilinear
    interpolation, one on the grid is not, so two start boxes a pixel apart learn templates of different
    sharpness (on VOT-TIR horse's first frame the window half a pixel off keeps 0.28 of the on-grid
    window's high-frequency energy, measured). After a blur with presmooth 0.02 (0.02 x sqrt(w h) of the
    56x60 px horse: 1.16 px) the interpolation's own averaging matters much less: 0.81."""
    img = FrameConditioner(ConditioningConfig())(cv2.imread(
        str(sequences_dir / "vottir2015_horse" / "000001.png"), cv2.IMREAD_UNCHANGED))
    box = Box(229.0, 129.0, 112.0, 120.0)  # a window about the horse (56x60 px), sampled at 1:1

    def ratio(frame: np.ndarray) -> float:
        on = sample_patch(frame, box, 112, 120)
        off = sample_patch(frame, box.shifted(0.5, 0.5), 112, 120)
        return _detail(off) / _detail(on)

    sigma = 0.02 * math.sqrt(56.0 * 60.0)  # presmooth 0.02 (the default)
    raw, smooth = ratio(img), ratio(presmooth(img, sigma))
    assert raw < 0.4 and smooth > 0.75, (raw, smooth)
    assert presmooth(img, 0.0) is img


def test_a_frame_smoothed_where_it_is_read_samples_as_the_whole_frame_smoothed() -> None:
    """`SmoothedFrame` (the tracker's per-frame `presmooth`) blurs only the tiles the windows read: every
    window, inside the frame or past its border, shrunk strongly (the anti-aliasing blur on top) or not,
    samples bit for bit what it samples from the whole frame blurred, read after read in any order."""
    rng = np.random.default_rng(5)
    for _ in range(60):
        h, w = (int(v) for v in rng.integers(40, 400, 2))
        raw = rng.random((h, w)).astype(np.float32)
        sigma = float(rng.uniform(0.3, 3.0))
        full, lazy = presmooth(raw, sigma), SmoothedFrame(raw, sigma)
        for _ in range(6):
            bw, bh = rng.uniform(4.0, 300.0, 2)
            box = Box(float(rng.uniform(-bw, w)), float(rng.uniform(-bh, h)), float(bw), float(bh))
            ow, oh = (int(v) for v in rng.integers(4, 100, 2))
            assert np.array_equal(sample_patch(lazy, box, ow, oh), sample_patch(full, box, ow, oh)), box
    lazy = SmoothedFrame(np.zeros((504, 576), np.float32), 1.2)
    sample_patch(lazy, Box(200.0, 150.0, 100.0, 250.0), 40, 100)  # a 40x100 target's window
    assert 0.1 < lazy._done.mean() < 0.5  # the tiles about it, not the frame
