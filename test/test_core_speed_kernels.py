# SPDX-License-Identifier: Apache-2.0
"""The fast correlation path (issue 17: batched peak analysis, compiled cross-power spectrum and window
cuts, core/corr_jit.py) gives the numbers of the code it replaced, bit for bit.

References: `confidence.analyse` per window (the loop `TemplateFilter._detections` ran),
`np.einsum("nchw,chw->nhw", zf, np.conj(xf))` (the old `gaussian_correlation`), the per-window `np.multiply`
slices (the old `_union_maps`). Real data: a KCF trained on a real sequence, the re-detection lattice forced
on every frame (PSR threshold no peak reaches), so the responses, spectra and union maps are the ones the
tracker uses in a long occlusion. Tolerance: none (a speed change must not move a score).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from swir_tracker_ros.core import confidence, fhog, kcf, kernels, template
from swir_tracker_ros.core.conditioning import presmooth
from swir_tracker_ros.core.features import SmoothedFrame
from swir_tracker_ros.tracker import Tracker, TrackerParams
from swir_tracker_ros.types import Box

SEQ = "otb_jogging-1"  # a full occlusion by a pole around frame 70


def test_the_compiled_correlation_loops_are_installed_and_used() -> None:
    assert kernels.corr_jit() is not None
    assert fhog.warm_up()
    cj = kernels.corr_jit()
    assert cj.channel_sum_kernel.signatures and cj.cut_windows_kernel.signatures


def _frames(sequences_dir: Path, n: int) -> tuple[list[np.ndarray], Box]:
    seq = sequences_dir / SEQ
    pngs = sorted(seq.glob("*.png"))[:n]
    gt = Box(*map(float, (seq / "gt.txt").read_text().split()[0].split(",")))
    return [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in pngs], gt


def _run(frames: list[np.ndarray], box: Box) -> list[tuple]:
    """Track with the lattice on every frame from frame 20; per frame the whole TrackResult as a tuple. The
    whole lattice in full every frame (no checkerboard, no principal-channel screen): the most windows."""
    params = TrackerParams()
    params.redetection.lattice_alternate = params.redetection.lattice_channels = 0
    trk = Tracker(params)
    trk.init(frames[0], box)
    out = []
    for k, f in enumerate(frames[1:]):
        if k == 20:
            params.base.psr_threshold = 100.0  # every frame fails: re-detection lattice (rings widen)
        r = trk.update(f)
        out.append((r.box, r.state, r.peak, r.psr, r.apce, r.huber_threshold, r.search_mode))
        out.append(r.search_windows)
    return out


@pytest.fixture(scope="module")
def recorded(sequences_dir: Path) -> dict:
    """Inputs and outputs of KCF.respond, analyse_batch and _union_maps on 45 real frames."""
    frames, box = _frames(sequences_dir, 45)
    rec: dict = {"respond": [], "union": []}
    mp = pytest.MonkeyPatch()
    orig_respond, orig_union = kcf.KCF.respond, template.TemplateFilter._union_maps

    def respond(self, z):
        r = orig_respond(self, z)
        rec["respond"].append((self.model_xf.copy(), np.array(z), r.copy()))
        return r

    def union(self, img, window, sx, sy, offsets, bounds, name, out=None):
        r = orig_union(self, img, window, sx, sy, offsets, bounds, name, out)
        # the pre-smoothed frame as a whole-frame blur: bit for bit what the tracker's windows read
        frame = presmooth(img.raw, img.sigma) if isinstance(img, SmoothedFrame) else img.copy()
        rec["union"].append((self, frame, window, sx, sy, list(offsets), bounds, r.copy()))
        return r

    mp.setattr(kcf.KCF, "respond", respond)
    mp.setattr(template.TemplateFilter, "_union_maps", union)
    try:
        rec["results"] = _run(frames, box)
    finally:
        mp.undo()
    rec["frames"], rec["box"] = frames, box
    assert max(len(z) for _, z, _ in rec["respond"]) >= 14  # the lattice ran, many windows
    return rec


def test_analyse_batch_equals_analyse_per_window_on_real_responses(recorded: dict) -> None:
    n = 0
    for _, _, resp in recorded["respond"]:
        for excl in (1, 3, 10):
            got = confidence.analyse_batch(resp, excl)
            want = [confidence.analyse(r, excl) for r in resp]
            assert got == want  # dataclass equality: every float equal
            n += len(want)
    assert n > 1000


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape", [(7, 62, 25), (3, 2, 9), (4, 1, 1), (2, 5, 3), (5, 40, 41)])
def test_analyse_batch_equals_analyse_on_random_responses(dtype: type, shape: tuple[int, ...]) -> None:
    rng = np.random.default_rng(sum(shape))
    resp = (rng.standard_normal(shape) * rng.random((shape[0], 1, 1))).astype(dtype)
    resp[0] = 0.25  # flat: zero sidelobe spread, zero energy
    for excl in (1, 2, 3, 10):
        assert confidence.analyse_batch(resp, excl) == [confidence.analyse(r, excl) for r in resp]
    assert confidence.analyse_batch(resp[:0], 3) == []


def test_cross_spectrum_kernel_equals_einsum(recorded: dict) -> None:
    cj = kernels.corr_jit()
    for xf, z, _ in recorded["respond"][::5]:
        zf = kcf.rfft2(z)
        assert zf.dtype == xf.dtype == np.complex64
        got = np.empty((zf.shape[0], *zf.shape[2:]), dtype=np.complex64)
        cj.cross_spectrum_kernel(zf, xf, got)
        np.testing.assert_array_equal(got, np.einsum("nchw,chw->nhw", zf, np.conj(xf)))
        # strided (not C-contiguous) arrays take the row-by-row loop: the same bits
        pad = np.zeros((*zf.shape[:-1], zf.shape[-1] + 2), dtype=np.complex64)
        pad[..., : zf.shape[-1]] = zf
        strided = np.zeros((got.shape[0], got.shape[1], 2 * got.shape[2]), dtype=np.complex64)
        cj.cross_spectrum_kernel(pad[..., : zf.shape[-1]], xf, strided[..., ::2])
        assert strided[..., ::2].tobytes() == got.tobytes()


def test_cut_windows_kernel_equals_numpy_slices(recorded: dict) -> None:
    for filt, img, window, sx, sy, offsets, bounds, want in recorded["union"][::4]:
        for jit in (True, False):
            kernels.USE_JIT = jit
            try:
                got = filt._union_maps(img, window, sx, sy, offsets, bounds, "test")
            finally:
                kernels.USE_JIT = True
            np.testing.assert_array_equal(got, want)


def test_respond_equals_the_numpy_path(recorded: dict, monkeypatch: pytest.MonkeyPatch) -> None:
    k = kcf.KCF(kcf.KCFParams(), recorded["respond"][0][1].shape[1:], 10.0)
    for _, z, _ in recorded["respond"][::7]:
        k.train(z[0], 1.0)
        fast = k.respond(z)
        monkeypatch.setattr(kernels, "USE_JIT", False)
        slow = k.respond(z)
        monkeypatch.setattr(kernels, "USE_JIT", True)
        np.testing.assert_array_equal(fast, slow)


def test_tracker_results_equal_on_the_numpy_path(recorded: dict, monkeypatch: pytest.MonkeyPatch) -> None:
    """Whole tracker, lattice included: the compiled loops (FHOG and correlation) against numpy only."""
    monkeypatch.setattr(kernels, "USE_JIT", False)
    assert _run(recorded["frames"], recorded["box"]) == recorded["results"]


def test_subpixel_offset_equals_the_np_clip_version() -> None:
    """The clamp without np.clip (its per-call overhead was most of the batched analysis) is np.clip's."""
    rng = np.random.default_rng(3)
    triples = [tuple(v) for v in rng.standard_normal((2000, 3)) * rng.choice([1e-6, 1.0, 1e3], (2000, 1))]
    triples += [(0.0, 1.0, 0.0), (1.0, 1.0, 1.0), (-0.0, 0.0, -0.0), (np.inf, 1.0, 0.0), (np.nan, 1.0, 0.0)]
    triples += [(0.0, 0.5, 1.0), (1.0, 0.5, 0.0), (-1e300, 1e300, 1e300)]
    for left, centre, right in triples:
        denom = 2.0 * centre - left - right
        want = 0.0 if denom <= 1e-12 else float(np.clip(0.5 * (right - left) / denom, -0.5, 0.5))
        got = confidence.subpixel_offset(left, centre, right)
        assert (got == want and np.signbit(got) == np.signbit(want)) or (np.isnan(got) and np.isnan(want))


def test_gaussian_correlation_equals_the_einsum_path(recorded: dict, monkeypatch: pytest.MonkeyPatch) -> None:
    """`gaussian_correlation` (training: the sample against itself) with the compiled channel sum."""
    for xf, z, _ in recorded["respond"][::9]:
        zf = kcf.rfft2(z)
        zz = np.einsum("nchw,nchw->n", z, z)
        args = (zf, zz, xf, float(zz[0]), 0.5, z.shape[-2:])
        fast = kcf.gaussian_correlation(*args)
        monkeypatch.setattr(kernels, "USE_JIT", False)
        slow = kcf.gaussian_correlation(*args)
        monkeypatch.setattr(kernels, "USE_JIT", True)
        np.testing.assert_array_equal(fast, slow)


def test_memory_score_reuses_the_detection_spectra_with_the_same_results(
    recorded: dict, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`memory_score` takes the winning window's FFT from the filter's `respond` (KCF.spectrum) instead of
    a second rfft2: equal to a fresh respond, and the whole tracker equal with the reuse switched off."""
    for _, z, _ in recorded["respond"][:40]:
        if len(z) > kcf._KEEP_SPECTRA:
            continue
        k = kcf.KCF(kcf.KCFParams(), z.shape[1:], 10.0)
        k.train(z[0], 1.0)
        k.respond(z)
        kept = [k.spectrum(z, i) for i in range(len(z))]
        assert k.spectrum(z.copy(), 0) is None  # another batch: no reuse
        for i, zf in enumerate(kept):
            np.testing.assert_array_equal(zf, kcf.rfft2(z[i : i + 1]))
            np.testing.assert_array_equal(k.respond_spectra(z[i : i + 1], zf), k.respond(z[i : i + 1]))
    hits = []
    orig = kcf.KCF.respond_spectra

    def counting(self, z, zf):
        hits.append(zf is not None)
        return orig(self, z, zf)

    monkeypatch.setattr(kcf.KCF, "respond_spectra", counting)
    assert _run(recorded["frames"], recorded["box"]) == recorded["results"]
    assert sum(hits) >= 15  # the memory scored the winner from the kept spectra on the tracked frames
    monkeypatch.setattr(kcf.KCF, "spectrum", lambda self, z, index: None)
    assert _run(recorded["frames"], recorded["box"]) == recorded["results"]
