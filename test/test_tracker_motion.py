# SPDX-License-Identifier: Apache-2.0
"""Motion and size handling of the default variant: coasting through a loss (on the trail's velocity), a long
occlusion searched to its end, the scale penalty, a shrunken size that grows back while re-detecting, the
size of a weak frame measured but not extrapolated."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import RecordingTracker

from swir_tracker_ros.core.registry import make_filter
from swir_tracker_ros.core.windows import scale_windows
from swir_tracker_ros.harness.evaluate import run_source
from swir_tracker_ros.harness.metrics import occlusion_episodes
from swir_tracker_ros.harness.protocol import RunStats
from swir_tracker_ros.harness.sources import open_source
from swir_tracker_ros.policies.scale_search import ScaleSearch
from swir_tracker_ros.tracker import Tracker, TrackerParams
from swir_tracker_ros.types import Box, TrackState


def _background(h: int, w: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 3.0)
    return 0.3 + 0.2 * (img - img.min()) / (img.max() - img.min())


def _frame(bg: np.ndarray, cx: float | None, cy: float) -> np.ndarray:
    """8-bit frame: `bg` plus a bright 16x32 figure with a dark stripe centred at (cx, cy) (None: hidden)."""
    img = bg.copy()
    if cx is not None:
        x0, y0 = round(cx) - 8, round(cy) - 16
        img[y0 : y0 + 32, x0 : x0 + 16] = 0.9
        img[y0 + 10 : y0 + 14, x0 : x0 + 16] = 0.15
    return (img * 255).astype(np.uint8)


def _moved_after_loss(coast: int) -> float:
    """A figure walks right at 3 px/frame for 40 frames, then vanishes for 60 frames: how far the box
    moves on from where it was when the figure vanished."""
    bg = _background(240, 480, 5)
    p = TrackerParams()
    p.coast.frames = coast
    trk = Tracker(p)
    trk.init(_frame(bg, 60.0, 120.0), Box(52.0, 104.0, 16.0, 32.0))
    for k in range(1, 40):
        res = trk.update(_frame(bg, 60.0 + 3.0 * k, 120.0))
        assert res.state is TrackState.TRACKING
    lost_at = res.box.cx
    for _ in range(60):
        res = trk.update(_frame(bg, None, 120.0))
    assert res.state is not TrackState.TRACKING
    return res.box.cx - lost_at


def test_the_prediction_stops_after_coast_frames_of_loss() -> None:
    """With the papers' constant-velocity coast the prediction walks on into empty background (measured:
    123-128 px in the 60 frames, at 2.1-2.3 px/frame); with `coast_frames` 8 the centre velocity is dropped
    after 8 frames of re-detection and the search stays near where the figure was lost (21 px)."""
    free, held = _moved_after_loss(0), _moved_after_loss(8)
    assert held < 3.0 * 8 + 8.0 and held < free - 15.0, (free, held)


def _track_sequence(seq_dir: Path, params: TrackerParams, n: int) -> tuple[list[Box], list[Box]]:
    """(boxes, ground truth) of frames 2..n of a real sequence tracked from frame 1's box."""
    pngs = sorted(seq_dir.glob("*.png"))[:n]
    gts = [Box(*(float(v) for v in line.split(",")[:4]))
           for line in (seq_dir / "gt.txt").read_text().split()]
    trk, boxes = Tracker(params), []
    for k, png in enumerate(pngs):
        img = cv2.imread(str(png), cv2.IMREAD_GRAYSCALE)
        if k == 0:
            trk.init(img, gts[0])
        else:
            boxes.append(trk.update(img).box)
    return boxes, gts[1:n]


def test_scale_penalty_keeps_the_box_from_growing_onto_the_surroundings(sequences_dir: Path) -> None:
    """PTB-TIR airplane (thermal pedestrian, constant size ~40x118 px): with the paper's largest-peak
    scale pick the box creeps up in size (measured: 74x181 px at frame 241, 99x243 px at the end) because
    a larger window that takes in more of the warm surroundings scores a slightly higher peak every few
    frames; the KCFcpp scale weight 0.95 on the non-unit scales slows that down (58x143 px at frame 241)."""
    def growth(penalty: float) -> float:
        p = TrackerParams()
        p.scale.penalty = penalty
        boxes, gts = _track_sequence(sequences_dir / "ptbtir_airplane", p, 250)
        return float(np.mean([b.h / g.h for b, g in zip(boxes[-50:], gts[-50:])]))

    free, weighted = growth(1.0), growth(0.95)
    assert free > 1.35 and weighted < 1.25, (free, weighted)


def _lunge_then_hide(window: int) -> tuple[float, float, float, float, bool]:
    """A figure stands for 50 frames, lunges left at 4 px/frame for its last 6 frames in view, is hidden for
    30 frames and shows again where it vanished: (the Kalman's centre velocity on the last tracked frame,
    the trail's mean velocity over its `window` frames there (px/frame), the centre velocity the first
    hidden frame coasts on, how far the box moved on while the figure was hidden, whether it is `tracking`
    with the figure inside the box 20 frames after it showed again)."""
    bg = _background(240, 480, 11)
    p = TrackerParams(trail_frames=window)
    p.coast.trail_velocity = window > 0
    trk = Tracker(p)
    trk.init(_frame(bg, 240.0, 120.0), Box(232.0, 104.0, 16.0, 32.0))
    cx, centres = 240.0, []
    for k in range(1, 56):
        if k > 49:
            cx -= 4.0
        res = trk.update(_frame(bg, cx, 120.0))
        centres.append(res.box.cx)
    assert res.state is TrackState.TRACKING
    lost_at, kalman = res.box.cx, res.velocity[0]
    trail = (centres[-1] - centres[-window]) / window if window else math.nan  # a full window: its span
    res = trk.update(_frame(bg, None, 120.0))
    assert res.state is not TrackState.TRACKING
    coast = res.velocity[0]
    for _ in range(29):
        res = trk.update(_frame(bg, None, 120.0))
    moved = abs(res.box.cx - lost_at)
    for _ in range(20):
        res = trk.update(_frame(bg, cx, 120.0))
    back = res.state is TrackState.TRACKING and abs(res.box.cx - cx) < 8.0
    return kalman, trail, coast, moved, back


def test_coast_velocity_is_the_trails_not_the_last_frames() -> None:
    """The Kalman velocity at the moment of loss follows the last frames (a lunge, a turn: OTB girl, where
    the prediction walked out of the image at 1 px/frame while the girl stayed). `coast.trail_velocity`
    with a 50-frame trail coasts on the mean velocity of the last 50 tracked frames instead (24 px / 50
    frames here), so the search stays near where the figure vanished and finds it there again. The
    mechanism is pinned: which velocity each variant coasts on (measured: -0.48 px/frame from the trail,
    -2.67 the Kalman's) and how far each coasts (15 px; 82 px), and the trail's variant finds the figure
    again. Whether the Kalman's variant, 82 px away, still finds it by the re-detection's chaotic search is
    not pinned: it did not on this machine, it did under OpenCV without AVX2/FMA3 on another (issue 50)."""
    k_kalman, _, k_coast, k_moved, _ = _lunge_then_hide(0)
    t_kalman, t_trail, t_coast, t_moved, t_back = _lunge_then_hide(50)
    # the lunge: the Kalman has taken up most of its 4 px/frame; the trail averages it over 50 frames
    assert k_kalman < -2.0 and t_kalman < -2.0 and -0.6 < t_trail < -0.4, (k_kalman, t_kalman, t_trail)
    assert k_coast == pytest.approx(k_kalman, abs=1e-6), (k_coast, k_kalman)
    assert t_coast == pytest.approx(t_trail, abs=0.005), (t_coast, t_trail)
    assert t_back and t_moved < 20.0, (t_moved, t_back)
    assert k_moved > t_moved + 30.0, (k_moved, t_moved)


def test_a_long_occlusion_is_searched_until_the_target_shows_again() -> None:
    """Synthetic t3 (paper 000 Table 1 row 3): the walker is hidden behind a wall for 6.7 s (167 frames) and
    stops there for 2 s. With `max_occluded_frames` 150 the track was declared `lost` (terminal) 15 frames
    before the walker showed again; the default keeps re-detecting for 10 s and re-acquires it."""
    src = open_source("synth:t3_long_full_dynamics")
    run = run_source(src, lambda: Tracker(TrackerParams()))
    episodes = occlusion_episodes(run.occlusion, src.fps)
    assert max(b - a + 1 for a, b in episodes) > 150, episodes  # longer than the old limit
    stats = RunStats.of(run, src.fps)
    assert stats.occlusions == len(episodes) and stats.survived == stats.occlusions, stats
    assert stats.false_tracking == 0, stats


def test_a_size_that_shrank_while_the_target_turned_grows_back(sequences_dir: Path) -> None:
    """OTB girl from the SRE start shifted left by 10 %: while the girl turns away (frames 60-100) her peaks
    weaken and the 5-scale search lets the box shrink to 14x21 px (the girl: 26x34); a window of that size
    never matched her again and the box stayed beside her, `occluded`, to the end (measured on the session-9
    machine: AUC 0.149; 0.607 with the option). `redetect_scales` 1.2 adds a window 1.2x and 1/1.2x the
    predicted size while re-detecting, so that the size can grow back. That whole run is one of the chaotic
    starts (on another CPU, whose float rounding differs, it survives without the option), so the mechanism
    is pinned on one real frame instead: a search at the size shrunk to 0.75 x the girl's, as a
    re-detecting frame runs it, measures her at the 1.2x window, so that the box grows towards her size;
    with the option off the largest window is 1.1x."""
    pngs = sorted((sequences_dir / "otb_girl").glob("*.png"))
    gt = Box(*map(float, (sequences_dir / "otb_girl" / "gt.txt").read_text().split()[10].split(",")))
    f10, f11 = (cv2.imread(str(pngs[k]), cv2.IMREAD_GRAYSCALE) for k in (10, 11))
    small = Box.from_center(gt.cx, gt.cy, 0.75 * gt.w, 0.75 * gt.h)

    def growth(factor: float) -> tuple[float, float]:
        """The size factor and peak a re-detecting frame measures around the shrunk box (the scale search
        of `ScaleSearch`, as the tracker runs it while re-detecting)."""
        p = TrackerParams()
        p.scale.redetect_scales = factor
        base = make_filter(p.base, gt.w, gt.h)
        base.initialise(f10, gt)
        search = ScaleSearch(p.scale)
        factors = search.factors(base, occluded=1)  # re-detecting
        wins = scale_windows(small.cx, small.cy, small.w, small.h, base.padding, factors)
        dets, best, _ = base.detect_scales(f11, wins, factors, p.scale.penalty, climb=False)
        assert not base.failed(dets[best]), dets[best]
        return dets[best].scale, dets[best].peak

    (off, off_peak), (on, on_peak) = growth(0.0), growth(1.2)
    # off: at most the 1.1x window; on: the 1.2x window's peak is the best
    assert off <= 1.1 + 1e-9 and on == pytest.approx(1.2) and on_peak > off_peak, (off, on, off_peak, on_peak)


def _zoomed(image: np.ndarray, centre: tuple[float, float], s: float, blur: float = 0.0) -> np.ndarray:
    """`image` magnified `s` times about `centre` (a camera zooming), blurred with sigma `blur` (a weak
    view)."""
    cx, cy = centre
    m = np.float32([[s, 0.0, cx - s * cx], [0.0, s, cy - s * cy]])
    out = cv2.warpAffine(image, m, (image.shape[1], image.shape[0]), flags=cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REFLECT)
    return cv2.GaussianBlur(out, (0, 0), blur) if blur > 0 else out


def _horse(sequences_dir: Path) -> tuple[np.ndarray, Box]:
    """VOT-TIR horse, frame 151 (where it turns side-on in the sequence), and its ground-truth box."""
    src = open_source(sequences_dir / "vottir2015_horse", max_frames=151)
    frame = list(src.frames())[-1]
    return frame.image, frame.gt


def test_a_crossing_occluder_does_not_grow_the_hidden_targets_box(sequences_dir: Path) -> None:
    """A frame the checks reject (not failed, but its peak too weak to be the target: `occluded`) measures a
    size that may belong to something in front of the target (synthetic t9: a pedestrian crossing in front,
    the box grew 1.16 x and followed him). With the rejected-frame policy (`policies/rejected.py`, on by
    default) such a frame's size stays within the sizes of the recently tracked frames (and the
    prediction's); without it (`rejected` None, 'measured' below) the frame takes its winning scale as a
    tracked frame does. Set up on a real frame: the horse is tracked still for 30 frames, then the view
    grows 2 % a frame while blurred (sigma 6): its peaks fall below half the tracked ones and every such
    frame is rejected while its scale search measures the larger extent. Measured: 'measured' grows to
    1.11 x the tracked size in 12 frames, 'recent' (the policy) stays at 1.00."""
    image, box = _horse(sequences_dir)
    centre = (box.cx, box.cy)

    def growth(mode: str) -> list[float]:
        trk = Tracker(TrackerParams(rejected=None) if mode == "measured" else TrackerParams())
        trk.init(image, box)
        tracked, peaks = [], []
        for _ in range(30):
            r = trk.update(image)
            assert r.state is TrackState.TRACKING, r
            tracked.append(math.sqrt(r.box.w * r.box.h))
            peaks.append(r.peak)
        out, s = [], 1.0
        for _ in range(12):
            s *= 1.02
            r = trk.update(_zoomed(image, centre, s, blur=6.0))
            assert r.state is TrackState.OCCLUDED and r.measured and r.peak < 0.6 * np.mean(peaks), r
            out.append(math.sqrt(r.box.w * r.box.h) / max(tracked))
        return out

    grown, held = growth("measured"), growth("recent")
    assert max(grown) > 1.08 and max(held) <= 1.0 + 1e-3, (grown, held)


def test_a_weak_frame_does_not_extrapolate_a_shrinking_size(sequences_dir: Path) -> None:
    """VOT-TIR horse from the SRE start shifted up by 10 %: while the horse turned side-on its peaks fell to
    half the tracked mean, the box shrank a little each frame and the Kalman size velocity carried the
    shrink on until the box lost the horse (measured on the session-9 machine). With
    `coast.size_hold_peak_ratio` 0.6 (the default) a frame whose peak is below 0.6 x the tracked mean zeroes
    the size velocity before its update: the size is still measured but not extrapolated. Set up on a real
    frame: the view of the horse shrinks 1 % a frame for 40 frames (the box follows, tracked, and learns
    the shrink as a size velocity), then stays at that size for 8 frames blurred (sigma 3.5: peaks about
    0.55 x the tracked ones, still `tracking`). Measured: with the option the box keeps its size (ratio
    1.000), without it the box shrinks on by about 1.5 % a frame (0.91 after 8 frames)."""
    image, box = _horse(sequences_dir)
    centre = (box.cx, box.cy)

    def weak_frames_size(ratio: float) -> float:
        params = TrackerParams()
        params.coast.size_hold_peak_ratio = ratio
        trk = Tracker(params)
        trk.init(image, box)
        s, peaks, heights = 1.0, [], []
        for _ in range(40):
            s *= 0.99
            r = trk.update(_zoomed(image, centre, s))
            assert r.state is TrackState.TRACKING, r
            peaks.append(r.peak)
            heights.append(r.box.h)
        assert heights[-1] < 0.8 * box.h  # the box followed the shrink
        weak = [trk.update(_zoomed(image, centre, s, blur=3.5)) for _ in range(8)]
        assert all(r.state is TrackState.TRACKING and r.peak < 0.6 * np.mean(peaks) for r in weak), weak
        return weak[-1].box.h / weak[0].box.h

    on, off = weak_frames_size(0.6), weak_frames_size(0.0)
    assert abs(on - 1.0) < 0.005 and off < 0.96, (on, off)


def test_a_gate_that_nothing_passes_freezes_the_model_unless_unconfident_frames_teach_it(
    sequences_dir: Path,
) -> None:
    """OTB skating1 (stage lighting): after the first 10 frames no peak reaches the LMCF gate's bar (0.7 x the
    mean peak of the updated frames, set by the bright first frames), the filter is never updated again and
    the skater is lost (measured: 10 updates, the last on frame 10, none on the 86 later `tracking` frames;
    AUC 0.236). With `unconfident_rate` 0.2 (the default), once the gate has refused `unconfident_after` (10)
    tracked frames, a refused tracked frame still teaches the filter at a fifth of its rate and the skater is
    kept (measured: updates on 197-205 of the 197-208 `tracking` frames after frame 20, AUC 0.71). The
    mechanism is pinned (which frames teach the filter in each variant) and the default's AUC; how badly the
    frozen variant's run goes is not (a chaotic run). Pinned to `size_rate_peak_ratio` 0, `redetect_psr` 0
    and no long-loss sweep, the setting of that measurement (with the ninth pass's PSR bar the frozen filter
    scores 0.362, with the long-loss sweep 0.628: the skater is re-acquired later, by other paths)."""
    src = open_source(sequences_dir / "otb_skating1")

    def run(rate: float) -> tuple[RunStats, int, int, int]:
        """(scores, updates in the first 10 frames, `tracking` frames after frame 20, of them updated)."""
        params = TrackerParams(sweep=None)
        params.update.unconfident_rate = rate
        params.coast.size_hold_peak_ratio, params.occlusion.reacquire_psr = 0.0, 0.0
        trk = RecordingTracker(params)
        stats = RunStats.of(run_source(src, lambda: trk), src.fps)
        later = [r for r in trk.results[20:] if r.state is TrackState.TRACKING]
        return (stats, sum(r.model_updated for r in trk.results[:10]), len(later),
                sum(r.model_updated for r in later))

    frozen, taught = run(0.0), run(0.2)
    # the same first frames teach both filters (the gate passes them), then the gate refuses the rest
    assert frozen[1] == taught[1] >= 5, (frozen, taught)
    assert frozen[2] > 20 and frozen[3] == 0, frozen  # tracked, refused, never taught
    assert taught[2] > 100 and taught[3] > 0.8 * taught[2], taught  # refused frames teach at 0.2
    assert taught[0].success_auc > 0.5, taught
