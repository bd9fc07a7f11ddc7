# SPDX-License-Identifier: Apache-2.0
"""The fast FHOG, patch sampling and conditioning (issue 17) give the numbers of the code they replaced.

The reference FHOG is test/fhog_reference.py (the numpy bincount version kept verbatim); the reference
sampling blurs the whole frame before a strong shrink. Real frames from ../shared/data/sequences, patches
cut where the tracker cuts them (around the ground-truth box, 5 scales, template sizes of whole cells and
the grid-union sizes), both feature kinds.

Tolerance: none. The new FHOG sums every cell in float64 in the reference's order and keeps every other
float32 operation's order, so features and histograms are bit-identical (a speed change must not move a
score: a float32 accumulator, ~1e-7 off, moved the ci regression set's t3 robust_adaptive AUC by 0.006).
Both FHOG paths are pinned: the compiled loops (core/fhog_jit.py, numba) and the numpy fallback.
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from swir_tracker_ros.core import features, fhog, kernels
from swir_tracker_ros.core.conditioning import ConditioningConfig, FrameConditioner
from swir_tracker_ros.core.windows import SCALE_FACTORS, scale_windows, template_size
from swir_tracker_ros.types import Box

sys.path.insert(0, str(Path(__file__).resolve().parent))
import fhog_reference as ref

SEQS = ("otb_jogging-1", "ptbtir_airplane", "otb_crossing", "vottir2015_horse")


@pytest.fixture(params=["jit", "numpy"])
def path(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run the test on the compiled FHOG loops and on the numpy fallback."""
    monkeypatch.setattr(kernels, "USE_JIT", request.param == "jit")
    return request.param


def test_the_compiled_path_is_installed_and_used() -> None:
    """numba is pinned in requirements.txt: the tracker must not silently run the numpy fallback."""
    assert kernels.USE_JIT and kernels.fhog_jit() is not None
    assert fhog.warm_up()
    loops = (kernels.fhog_jit().cell_histograms_kernel, kernels.fhog_jit().normalise_kernel)
    assert all(k.signatures for k in loops)  # compiled (or loaded from the cache) by warm_up


def frames_and_boxes(seq: Path, picks: tuple[int, ...] = (0, 40, 80)) -> list[tuple[np.ndarray, Box]]:
    pngs = sorted(seq.glob("*.png"))
    gts = [Box(*map(float, line.split(","))) for line in (seq / "gt.txt").read_text().split()]
    out = []
    for k in picks:
        img = cv2.imread(str(pngs[k]), cv2.IMREAD_GRAYSCALE).astype(np.float32) / np.float32(255.0)
        out.append((img, gts[k]))
    return out


def tracker_patches(img: np.ndarray, box: Box, padding: float = 1.5, cell: int = 4) -> list[np.ndarray]:
    """The 5 scale windows at the template size, and one grid-union-like larger patch (odd cell counts)."""
    tw, th = template_size(box.w, box.h, padding, cell, 1.0)
    wins = scale_windows(box.cx, box.cy, box.w, box.h, padding, SCALE_FACTORS)
    union = Box.from_center(box.cx, box.cy, wins[2].w * 7 / 3, wins[2].h * 7 / 3)
    uw, uh = tw + 2 * cell * round(tw / cell / 1.5), th + 2 * cell * round(th / cell / 1.5)
    return [features.sample_patches(img, wins, tw, th), features.sample_patches(img, [union], uw, uh)]


@pytest.mark.parametrize("seq", SEQS)
@pytest.mark.parametrize("soft", [False, True], ids=["hog", "hog_soft"])
def test_fhog_equals_reference_on_real_frames(sequences_dir: Path, seq: str, soft: bool, path: str) -> None:
    for img, box in frames_and_boxes(sequences_dir / seq):
        for patches in tracker_patches(img, box):
            got = fhog.fhog(patches, 4, soft=soft)
            want = ref.fhog(patches, 4, soft=soft)
            assert got.shape == want.shape and got.dtype == np.float32
            assert np.abs(want).max() > 0.05  # real texture, not a flat patch
            np.testing.assert_array_equal(got, want)
            h_got = fhog.cell_histograms(patches, 4, soft=soft)
            np.testing.assert_array_equal(h_got, ref.cell_histograms(patches, 4, soft=soft))


@pytest.mark.parametrize("shape", [(1, 83, 57), (3, 33, 18), (2, 16, 16)])
def test_fhog_equals_reference_off_the_cell_grid(
    sequences_dir: Path, shape: tuple[int, int, int], path: str
) -> None:
    """Sizes that are not whole cells (extra columns feed the last cell, extra rows are dropped)."""
    img, _ = frames_and_boxes(sequences_dir / "otb_crossing", (5,))[0]
    n, h, w = shape
    patches = np.stack([img[7 * i : 7 * i + h, 11 * i : 11 * i + w] for i in range(n)])
    for soft in (False, True):
        np.testing.assert_array_equal(fhog.fhog(patches, 4, soft), ref.fhog(patches, 4, soft))


def test_fhog_results_survive_the_reused_buffers(sequences_dir: Path, path: str) -> None:
    """The per-shape work buffers are reused: an earlier result must not change on a later call."""
    (a_img, a_box), (b_img, _) = frames_and_boxes(sequences_dir / "otb_jogging-1", (0, 120))
    pa = tracker_patches(a_img, a_box)[0]
    pb = tracker_patches(b_img, a_box)[0]
    fa = fhog.fhog(pa, 4, soft=True)
    ha = fhog.cell_histograms(pa, 4, soft=True)
    keep_f, keep_h = fa.copy(), ha.copy()
    fb = fhog.fhog(pb, 4, soft=True)
    fhog.cell_histograms(pb, 4, soft=True)
    assert not np.allclose(fa, fb)
    np.testing.assert_array_equal(fa, keep_f)
    np.testing.assert_array_equal(ha, keep_h)


def test_window_inside_fhog_equals_windowing_the_result(sequences_dir: Path, path: str) -> None:
    """`fhog(..., window=)` (the compiled path multiplies inside its loop) and `extract_features` give the
    numbers of multiplying the finished features by the cosine window."""
    img, box = frames_and_boxes(sequences_dir / "otb_crossing", (20,))[0]
    patches = tracker_patches(img, box)[0]
    for kind in features.HOG_KINDS:
        plain = fhog.fhog(patches, 4, soft=kind == "hog_soft")
        win = features.cosine_window(plain.shape[2], plain.shape[3])
        want = plain * win
        got = fhog.fhog(patches, 4, soft=kind == "hog_soft", window=win)
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(features.extract_features(patches, kind, 4), want)
        np.testing.assert_array_equal(
            features.extract_features(patches, kind, 4),
            ref.fhog(patches, 4, soft=kind == "hog_soft") * win,
        )
    if path == "jit":  # a window of the wrong size is refused, not read out of bounds
        with pytest.raises(ValueError):
            fhog.fhog(patches, 4, window=np.ones((3, 3), np.float32))


def test_gradients_match_the_reference_exactly(sequences_dir: Path, path: str) -> None:
    img, box = frames_and_boxes(sequences_dir / "ptbtir_airplane", (10,))[0]
    patches = tracker_patches(img, box)[0]
    mag, ang = fhog.gradients(patches)
    rmag, rang = ref.gradients(patches)
    np.testing.assert_array_equal(mag, rmag)
    np.testing.assert_array_equal(ang, rang)


def reference_sample_patch(img: np.ndarray, box: Box, out_w: int, out_h: int) -> np.ndarray:
    """The sampling before issue 17: a strong shrink blurs the WHOLE frame, then one warp."""
    sx, sy = box.w / out_w, box.h / out_h
    M = np.array([[sx, 0.0, box.x + 0.5 * sx - 0.5], [0.0, sy, box.y + 0.5 * sy - 0.5]])
    src = img
    if sx > 2.0 or sy > 2.0:
        src = cv2.GaussianBlur(img, (0, 0), sigmaX=0.5 * max(sx, sy), borderType=cv2.BORDER_REPLICATE)
    flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
    return cv2.warpAffine(src, M, (out_w, out_h), flags=flags, borderMode=cv2.BORDER_REPLICATE)


def test_sample_patch_blurs_only_the_read_region_with_the_same_result(sequences_dir: Path) -> None:
    """Windows inside, across and wholly outside the frame, shrinks from 0.2x to 6x: the blurred row band
    and SIMD-aligned column band give the whole-frame blur's values exactly."""
    img, _ = frames_and_boxes(sequences_dir / "otb_jogging-1", (30,))[0]
    ih, iw = img.shape
    rng = np.random.default_rng(17)
    shrunk = 0
    for _ in range(400):
        w, h = rng.uniform(10, 500, 2)
        box = Box(rng.uniform(-w - 50, iw + 50), rng.uniform(-h - 50, ih + 50), w, h)
        ow, oh = (int(v) for v in rng.integers(8, 130, 2))
        shrunk += box.w / ow > 2 or box.h / oh > 2
        got = features.sample_patch(img, box, ow, oh)
        np.testing.assert_array_equal(got, reference_sample_patch(img, box, ow, oh))
    assert shrunk > 100


def test_sample_patches_stack_equals_single_patches(sequences_dir: Path) -> None:
    img, box = frames_and_boxes(sequences_dir / "otb_crossing", (3,))[0]
    wins = scale_windows(box.cx, box.cy, box.w, box.h, 1.5)
    stack = features.sample_patches(img, wins, 40, 96)
    for i, b in enumerate(wins):
        np.testing.assert_array_equal(stack[i], features.sample_patch(img, b, 40, 96))
    as64 = features.sample_patches(img.astype(np.float64), wins, 40, 96)  # not float32: copied path
    np.testing.assert_allclose(as64, stack, atol=1e-6)


def test_conditioning_never_writes_into_the_callers_frame() -> None:
    """In-place stretch steps only touch arrays the conditioner allocated itself."""
    rng = np.random.default_rng(3)
    for frame in (rng.random((40, 50)).astype(np.float32) * 3.0, rng.random((40, 50)).astype(np.float32)):
        keep = frame.copy()
        for stretch in ("auto", "always", "off"):
            out = FrameConditioner(ConditioningConfig(stretch=stretch))(frame)
            np.testing.assert_array_equal(frame, keep)
            assert out.dtype == np.float32 and out.min() >= 0.0 and out.max() <= 1.0 + 1e-6
