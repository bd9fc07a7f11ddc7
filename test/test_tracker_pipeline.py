# SPDX-License-Identifier: Apache-2.0
"""The full Tracker: scale, occlusion, re-detection, gated updates, configurations, bad input, real data."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from swir_tracker_ros.configs import configuration
from swir_tracker_ros.core.conditioning import ConditioningConfig
from swir_tracker_ros.core.filters import KCFFilter
from swir_tracker_ros.core.registry import make_filter
from swir_tracker_ros.errors import TrackerError
from swir_tracker_ros.kalman import PAPER000_KCF
from swir_tracker_ros.policies.motion import MotionFilter
from swir_tracker_ros.tracker import Tracker, TrackerParams
from swir_tracker_ros.types import Box, SearchMode, TrackState


def occlusion_scene(n: int = 55, seed: int = 3) -> tuple[list[np.ndarray], list[Box], list[bool]]:
    """A 20x40 target walks right at 2 px/frame behind a textured bar (x 100..130) and, while hidden,
    turns to move diagonally (2, 1.5) px/frame; noisy textured background, 8-bit frames."""
    rng = np.random.default_rng(seed)
    h, w = 240, 320
    bg = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 3)
    bg = 0.3 + 0.25 * (bg - bg.min()) / (bg.max() - bg.min())
    occ = cv2.GaussianBlur(rng.random((h, 30)).astype(np.float32), (0, 0), 2)
    occ = 0.45 + 0.2 * (occ - occ.min()) / (occ.max() - occ.min())
    tgt = 0.1 + 0.9 * cv2.resize(
        rng.random((8, 4)).astype(np.float32), (20, 40), interpolation=cv2.INTER_NEAREST
    )
    frames, gts, hidden = [], [], []
    x, y = 50.0, 70.0
    for k in range(n):
        if k:
            vx, vy = (2.0, 0.0) if x < 100.0 else (2.0, 1.5)
            x, y = x + vx, y + vy
        f = bg.copy()
        xi, yi = round(x), round(y)
        f[yi : yi + 40, xi : xi + 20] = tgt
        f[:, 100:130] = occ
        f = f + rng.normal(0, 0.015, f.shape).astype(np.float32)
        frames.append(np.clip(f * 255, 0, 255).astype(np.uint8))
        gts.append(Box(xi, yi, 20, 40))
        hidden.append(xi + 20 > 100 and xi < 130)
    return frames, gts, hidden


def zoom_scene(n: int = 25, rate: float = 1.02) -> tuple[list[np.ndarray], list[Box]]:
    rng = np.random.default_rng(3)
    bg = cv2.GaussianBlur(rng.random((240, 320)).astype(np.float32), (0, 0), 3)
    bg = 0.3 + 0.2 * (bg - bg.min()) / (bg.max() - bg.min())
    tgt = 0.1 + 0.9 * cv2.resize(
        rng.random((8, 4)).astype(np.float32), (24, 48), interpolation=cv2.INTER_NEAREST
    )
    frames, gts = [], []
    for k in range(n):
        s = rate**k
        t = cv2.resize(tgt, (round(24 * s), round(48 * s)), interpolation=cv2.INTER_LINEAR)
        f = bg.copy()
        x0, y0 = round(160 - t.shape[1] / 2), round(120 - t.shape[0] / 2)
        f[y0 : y0 + t.shape[0], x0 : x0 + t.shape[1]] = t
        frames.append((f * 255).astype(np.uint8))
        gts.append(Box(x0, y0, t.shape[1], t.shape[0]))
    return frames, gts


def run(name: str, frames: list[np.ndarray], box: Box, base: str | None = None,
        edit: Callable[[TrackerParams], None] | None = None) -> list:
    """Results of configuration `name` (on `base`), its params changed by `edit`, over `frames`."""
    params = configuration(name, base)
    if edit is not None:
        edit(params)
    trk = Tracker(params)
    trk.init(frames[0], box)
    return [trk.update(f) for f in frames[1:]]


@pytest.fixture(scope="module")
def scene() -> tuple[list[np.ndarray], list[Box], list[bool]]:
    return occlusion_scene()


@pytest.mark.parametrize("pipeline", ["kcf", "dcf_ca"])
def test_scale_recovery_on_synthetic_zoom(pipeline: str) -> None:
    frames, gts = zoom_scene()
    res = run("robust_adaptive", frames, gts[0], base=pipeline)
    assert res[-1].scale == pytest.approx(1.02**24, rel=0.06)
    assert res[-1].box.iou(gts[-1]) > 0.8


def test_redetection_after_occlusion_with_direction_change(scene) -> None:
    frames, gts, hidden = scene
    res = run("robust_adaptive", frames, gts[0])
    states = [r.state for r in res]
    assert TrackState.OCCLUDED in states[10:40]  # failure detected behind the bar
    occluded = [r for r in res if r.state is TrackState.OCCLUDED]
    assert all(r.search_mode is SearchMode.MULTI_WINDOW and len(r.search_windows) == 9 for r in occluded)
    assert all(not r.measured and not r.model_updated for r in occluded)
    tail = range(len(res) - 10, len(res))  # target visible again, moving diagonally
    assert not any(hidden[i + 1] for i in tail)
    assert all(res[i].state is TrackState.TRACKING and res[i].box.iou(gts[i + 1]) > 0.6 for i in tail)
    cf = run("cf", frames, gts[0])  # the bare filter stays behind at the occluder
    assert max(cf[i].box.iou(gts[i + 1]) for i in tail) < 0.2


def test_model_is_frozen_while_occluded(scene, monkeypatch: pytest.MonkeyPatch) -> None:
    """The filter learns (`BaseFilter.train`, not the memory's `train_memory`) exactly on the frames that
    report `model_updated`: confident tracked ones, never occluded ones."""
    frames, gts, _ = scene
    trained, in_memory = [0], [False]
    train, train_memory = KCFFilter.train, KCFFilter.train_memory

    def counting_train(self, img, box, rate):
        trained[0] += not in_memory[0]
        return train(self, img, box, rate)

    def flagged_train_memory(self, img, box, rate):
        in_memory[0] = True
        try:
            return train_memory(self, img, box, rate)
        finally:
            in_memory[0] = False

    monkeypatch.setattr(KCFFilter, "train", counting_train)
    monkeypatch.setattr(KCFFilter, "train_memory", flagged_train_memory)
    trk = Tracker(TrackerParams())
    trk.init(frames[0], gts[0])
    frozen_checked = updated_seen = False
    for f in frames[1:40]:
        trained[0] = 0
        r = trk.update(f)
        same = trained[0] == 0
        assert same != r.model_updated
        if r.model_updated:
            updated_seen = True
            assert r.peak > 0.5 and r.state is TrackState.TRACKING
        if r.state is TrackState.OCCLUDED:
            frozen_checked = True
    assert frozen_checked and updated_seen


def test_variants_behave_as_specified(scene) -> None:
    frames, gts, _ = scene
    cf = run("cf", frames[:30], gts[0])
    assert all(r.search_mode is SearchMode.NORMAL and r.huber_threshold == 0.0 for r in cf)
    assert all(r.state is TrackState.TRACKING and r.scale == pytest.approx(1.0) for r in cf)
    kal = run("kalman", frames[:30], gts[0])
    assert all(r.huber_threshold == 0.0 for r in kal)
    assert any(r.search_mode is SearchMode.MULTI_WINDOW for r in kal)
    rob = run("robust", frames[:30], gts[0])
    assert all(r.huber_threshold == 1.5 for r in rob)
    ada = run("robust_adaptive", frames[:30], gts[0])
    assert all(r.huber_threshold == pytest.approx(PAPER000_KCF(r.peak)) for r in ada)
    assert len({round(r.huber_threshold, 3) for r in ada}) > 2
    # adaptive R: the same frames as robust_adaptive until its residual window is full, then other boxes
    long = frames[1:] + frames[::-1]
    fixed_r, adapted = run("robust_adaptive", long, gts[0]), run("robust_adaptive_r", long, gts[0])
    differ = [a.box != b.box for a, b in zip(fixed_r, adapted)]
    assert not differ[0] and any(differ)


def test_adaptive_r_adapts_the_position_noise_only(scene) -> None:
    """Dissertation eq. 5.95 in the motion filter: R's position block follows the post-fit residuals after
    the warm-up, its size block stays nominal; without adaptive_r R never changes."""
    _, gts, _ = scene
    box = gts[0]
    base = make_filter(configuration("robust_adaptive_r").base, box.w, box.h)
    for name, adapts in (("robust_adaptive_r", True), ("robust", False)):
        motion = MotionFilter(configuration(name).motion, base, box)
        R0 = motion.kf.R.copy()
        rng = np.random.default_rng(1)
        for _ in range(60):
            pred = motion.predict(1.0, 0.0, 0.0)
            dx, dy = 2.0 + rng.normal(0, 3.0), rng.normal(0, 3.0)
            z = motion.measurement(pred.cx + dx, pred.cy + dy, box.w, box.h)
            motion.adapt_noise(z, motion.update(z, motion.threshold(0.6)))
        assert (not np.array_equal(motion.kf.R[:2, :2], R0[:2, :2])) == adapts
        assert np.array_equal(motion.kf.R[2:, 2:], R0[2:, 2:])  # size noise stays nominal


def test_dcf_ca_pipeline_detects_occlusion_by_apce(scene) -> None:
    frames, gts, _ = scene
    res = run("robust_adaptive", frames, gts[0], base="dcf_ca")
    assert res[0].state is TrackState.TRACKING and res[0].box.iou(gts[1]) > 0.7
    assert any(r.state is TrackState.OCCLUDED for r in res[15:40])


def test_ego_shift_moves_the_prediction() -> None:
    frames, gts = zoom_scene(n=3, rate=1.0)
    moved = [np.roll(f, 6, axis=1) for f in frames]  # the head turned: image content moved 6 px right
    trk = Tracker(TrackerParams())
    trk.init(frames[0], gts[0])
    r = trk.update(moved[1], ego_shift=(6.0, 0.0))
    assert r.search_windows[0].cx == pytest.approx(gts[0].cx + 6.0)
    assert r.box.cx == pytest.approx(gts[0].cx + 6.0, abs=1.0)


def test_bad_input_is_reported_cleanly(scene) -> None:
    frames, gts, _ = scene
    trk = Tracker(TrackerParams())
    assert trk.update(frames[0]).state is TrackState.IDLE
    for box in [Box(400, 10, 20, 20), Box(10, 10, 0, 20), Box(float("nan"), 0, 5, 5), (1, 2, 3)]:
        with pytest.raises(TrackerError):
            trk.init(frames[0], box)
    with pytest.raises(TrackerError):
        trk.init(np.zeros((3, 3), np.uint8), Box(0, 0, 2, 2))
    with pytest.raises(TrackerError):
        trk.init([[0]], Box(0, 0, 1, 1))
    trk.init(frames[0], gts[0])
    for bad in (
        np.zeros((10, 10), np.uint8),
        np.full(frames[0].shape, np.nan, np.float32),
        np.zeros(frames[0].shape, bool),
        np.zeros((*frames[0].shape, 2)),
        np.zeros(0),
    ):
        r = trk.update(bad)
        assert r.state is TrackState.LOST and not r.measured
    r = trk.update(frames[1])  # a bad frame is transient: the track continues
    assert r.state is TrackState.TRACKING and r.box.iou(gts[1]) > 0.7
    tiny = Tracker(TrackerParams())  # frame smaller than the search window: replicated borders
    tiny.init(frames[0][60:120, 40:80], Box(10, 10, 20, 40))
    assert tiny.update(frames[1][60:120, 40:80]).state in (TrackState.TRACKING, TrackState.OCCLUDED)
    trk.reset()
    assert trk.state is TrackState.IDLE


def test_16bit_and_colour_frames_track(scene) -> None:
    frames, gts, _ = scene
    f16 = [f.astype(np.uint16) * 16 + 20000 for f in frames[:8]]
    res = run("robust_adaptive", f16, gts[0],
              edit=lambda p: setattr(p, "conditioning", ConditioningConfig(dead_pixel_threshold=0.2)))
    assert res[-1].box.iou(gts[7]) > 0.7
    bgr = [cv2.cvtColor(f, cv2.COLOR_GRAY2BGR) for f in frames[:8]]
    assert run("robust_adaptive", bgr, gts[0])[-1].box.iou(gts[7]) > 0.7


def test_deterministic(scene) -> None:
    frames, gts, _ = scene
    a = run("robust_adaptive_r", frames[:30], gts[0])
    b = run("robust_adaptive_r", frames[:30], gts[0])
    assert a == b


def load_sequence(path: Path) -> tuple[list[np.ndarray], list[Box]]:
    frames = [cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in sorted(path.glob("*.png"))]
    gts = [Box(*map(float, line.split(","))) for line in (path / "gt.txt").read_text().split()]
    return frames, gts


def success_auc(boxes: list[Box], gts: list[Box]) -> float:
    ious = np.array([b.iou(g) for b, g in zip(boxes, gts)])
    return float(np.mean([(ious > t).mean() for t in np.arange(0, 1.0001, 0.05)]))


def test_real_sequence_crossing_is_tracked(sequences_dir: Path) -> None:
    """OTB crossing, the papers' full pipeline from the first frame: AUC > 0.7 (measured 0.78-0.79 in the
    default, OpenBLAS Sandybridge and OpenCV-without-AVX2 environments of issue 50; the bare filter `cf`
    0.71, a comparison of two whole runs that is not pinned: which of two close chaotic runs scores higher
    is an outcome, not a mechanism)."""
    frames, gts = load_sequence(sequences_dir / "otb_crossing")
    full = run("robust_adaptive", frames, gts[0])
    assert success_auc([gts[0]] + [r.box for r in full], gts) > 0.7


def test_lost_after_long_occlusion_and_grid_scale_search(scene) -> None:
    frames, gts, _ = scene
    def edit(p: TrackerParams) -> None:
        p.occlusion.max_frames, p.redetection.grid_scale_search = 3, True

    res = run("robust_adaptive", frames[:45], gts[0], edit=edit)
    states = [r.state for r in res]
    first_lost = states.index(TrackState.LOST)
    assert states[first_lost - 3 : first_lost] == [TrackState.OCCLUDED] * 3
    assert all(s is TrackState.LOST for s in states[first_lost:])  # terminal until init
    assert all(len(r.search_windows) == 9 for r in res[first_lost - 3 : first_lost])


def test_target_leaving_the_image_is_lost() -> None:
    frames, gts = zoom_scene(n=2, rate=1.0)
    trk = Tracker(TrackerParams())
    trk.init(frames[0], gts[0])
    assert trk.update(frames[1], ego_shift=(-400.0, 0.0)).state is TrackState.LOST
    assert trk.state is TrackState.LOST


def trace(name: str, frames: list[np.ndarray], box: Box) -> list[tuple]:
    """(result, centre velocity before the update, after it) per frame (`TrackResult.velocity`)."""
    trk = Tracker(configuration(name))
    trk.init(frames[0], box)
    out, v0 = [], (0.0, 0.0)  # velocity entering the frame (the prediction keeps it)
    for f in frames[1:]:
        r = trk.update(f)
        out.append((r, v0, r.velocity))
        v0 = r.velocity
    return out


@pytest.mark.parametrize("name", ["kalman", "robust", "robust_adaptive", "robust_adaptive_r"])
def test_redetection_holds_the_centre_velocity(scene, name: str) -> None:
    """While re-detecting, grid measurements move the centre but never the centre velocity
    (an occlusion feeds only outliers; their clipped updates used to drag the prediction away)."""
    frames, gts, _ = scene
    steps = trace(name, frames, gts[0])
    occluded = [(r, v0, v1) for r, v0, v1 in steps if r.state is TrackState.OCCLUDED]
    tracking = [(r, v0, v1) for r, v0, v1 in steps if r.state is TrackState.TRACKING]
    assert len(occluded) >= 5
    assert all(v0 == v1 for _, v0, v1 in occluded)
    assert sum(v0 != v1 for _, v0, v1 in tracking) > len(tracking) // 2


def test_floor_band_outer_grid_peak_is_no_measurement(scene) -> None:
    """While re-detecting, robust_adaptive takes an outer grid window's peak below eq. 38's first
    breakpoint (PV < 0.25, k at its floor) as no measurement (the filter coasts); the same peak in
    the window at the prediction, or any peak for a fixed threshold (`robust`), moves the centre.
    The centre velocity is held in every case (`MotionFilter.redetection_update`)."""
    _, gts, _ = scene
    box = gts[0]
    z_off = np.array([12.0, -9.0, 0.0, 0.0])  # a detection 12 px right and 9 px up of the prediction
    for name, outer, coasts in (("robust_adaptive", True, True), ("robust_adaptive", False, False),
                                ("robust_adaptive_r", True, True), ("robust", True, False)):
        p = configuration(name)
        motion = MotionFilter(p.motion, make_filter(p.base, box.w, box.h), box)
        for k in range(1, 8):  # a walker at 2 px/frame
            pred = motion.predict(1.0, 0.0, 0.0)
            z = motion.measurement(box.cx + 2.0 * k, box.cy, box.w, box.h)
            motion.update(z, motion.threshold(0.6))
        motion.predict(1.0, 0.0, 0.0)
        kf = motion.kf
        x0 = kf.x.copy()
        z = kf.H @ x0 + z_off
        peak = 0.2
        assert PAPER000_KCF.at_floor(peak)
        info = motion.redetection_update(z, motion.threshold(peak), peak, outer, weak=False)
        assert info.coasted == coasts
        moved = kf.x[:2] - x0[:2]
        assert np.allclose(moved, 0.0) if coasts else (moved[0] > 0.05 and moved[1] < -0.05)
        assert np.array_equal(kf.x[4:6], x0[4:6]) and kf.x[4] > 1.0  # centre velocity held (walking)
    assert pred.is_valid()


def test_clutter_scenario_reacquires_the_target_not_the_look_alike() -> None:
    """Synthetic t4 (a look-alike walks 1.5 m behind, the target crosses a pole at frames ~124-142):
    with the motion held through the occlusion the prediction stays on the target's path and the
    target, not the look-alike 40-50 px away, is re-acquired (before: IoU 0 from frame 139 on)."""
    from swir_tracker_ros.scene.scenarios import make_scenario

    run_ = make_scenario("t4_clutter_shake")
    frames, gts = [], []
    for k, fr in enumerate(run_):
        if k > 175:
            break
        frames.append(fr.image)
        gts.append(fr.target.box)
    bits = run_.world.sensor.bits
    trk = Tracker(configuration("robust_adaptive"))
    trk.init(frames[0], gts[0], bit_depth=bits)
    res = [trk.update(f, bit_depth=bits) for f in frames[1:]]
    assert any(r.state is TrackState.OCCLUDED for r in res[120:140])  # the pole is detected
    after = [res[k - 1].box.iou(gts[k]) for k in range(150, len(frames))]
    assert min(after) > 0.5


def test_frames_argument_advances_the_prediction_over_skipped_frames() -> None:
    """`update(..., frames=k)` (core_contract.md item 3): after frames were skipped the search starts at the
    position the velocity reaches in k periods, not one period ahead."""
    frames, gts, _ = occlusion_scene(40)
    starts = {}
    for k in (1.0, 4.0):
        trk = Tracker(configuration("kalman"))
        trk.init(frames[0], gts[0])
        for f in frames[1:20]:  # 2 px/frame to the right, velocity learnt
            trk.update(f)
        res = trk.update(frames[23], frames=k)  # frames 20..22 skipped
        starts[k] = res.search_windows[0].cx if res.search_mode is SearchMode.NORMAL else res.box.cx
    truth = gts[23].cx
    assert abs(starts[4.0] - truth) < 2.0 < abs(starts[1.0] - truth)


def leaving_scene(seed: int, n: int = 80, gone: int = 30) -> tuple[list[np.ndarray], list[Box]]:
    """A 20x40 textured target walks right at 2 px/frame over a textured background and is gone (left
    the scene) from frame `gone` on; the background stays."""
    rng = np.random.default_rng(seed)
    bg = cv2.GaussianBlur(rng.random((240, 320)).astype(np.float32), (0, 0), 2)
    bg = 0.3 + 0.4 * (bg - bg.min()) / (bg.max() - bg.min())
    tgt = 0.1 + 0.9 * cv2.resize(
        rng.random((8, 4)).astype(np.float32), (20, 40), interpolation=cv2.INTER_NEAREST
    )
    frames, gts = [], []
    x, y = 60.0, 90.0
    for k in range(n):
        f = bg.copy()
        if k < gone:
            x += 2.0
            f[round(y) : round(y) + 40, round(x) : round(x) + 20] = tgt
        f = f + rng.normal(0, 0.01, f.shape).astype(np.float32)
        frames.append(np.clip(f * 255, 0, 255).astype(np.uint8))
        gts.append(Box(round(x), round(y), 20, 40))
    return frames, gts


@pytest.mark.parametrize("seed", [5, 6, 7])
def test_default_never_reports_tracking_on_background_after_the_target_left(seed: int) -> None:
    """Issue 12 "no false lock": once the target has left, the tracker's box sits on background; the
    long-term memory (LCT style) of the default configuration `measured` rejects it, so no frame is
    `tracking`. The papers' robust_adaptive reports `tracking` on background here (3-9 of the 49 frames for
    these seeds)."""
    frames, gts = leaving_scene(seed)
    trk = Tracker(TrackerParams())
    trk.init(frames[0], gts[0])
    states = [trk.update(f).state for f in frames[1:]]
    assert all(s is TrackState.TRACKING for s in states[:28])  # followed while visible
    assert not any(s is TrackState.TRACKING for s in states[30:])
