# SPDX-License-Identifier: Apache-2.0
"""Re-detection of the default configuration (issue 12 item 4, issue 13): lattice and re-acquisition rules."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import RecordingTracker

from swir_tracker_ros.core.kcf import KCFParams
from swir_tracker_ros.core.registry import make_filter
from swir_tracker_ros.core.windows import search_window
from swir_tracker_ros.harness.evaluate import run_starts
from swir_tracker_ros.harness.metrics import sre_box
from swir_tracker_ros.harness.protocol import RunStats
from swir_tracker_ros.harness.sources import open_source
from swir_tracker_ros.policies.redetection import Redetection, RedetectionParams
from swir_tracker_ros.scene.camera import CameraView
from swir_tracker_ros.scene.demo_scene import build_scene
from swir_tracker_ros.scene.demo_world import CROSSER_ID
from swir_tracker_ros.tracker import Tracker, TrackerParams
from swir_tracker_ros.types import Box, SearchMode, TrackState

FPS = 25.0


def papers_redetection() -> TrackerParams:
    """The default with the papers' re-detection: the 3x3 grid (no lattice, so no sweep), no peak rule."""
    p = TrackerParams(sweep=None)
    p.redetection.lattice_step, p.occlusion.reacquire_peak_ratio = 0.0, 0.0
    return p


def demo_follow(seed: int, start: int, stop: int, params: TrackerParams, scene: str = "demo",
                other: int | None = None) -> list[tuple[int, object, Box]]:
    """The demo scene seen by a head that follows the pedestrian with a 0.8 s lag (exact ego shift given
    to the tracker), tracked from frame `start` on its true box; (frame, result, true box) per frame, or
    (frame, result, true box, box of actor `other` or None) with `other`."""
    built = build_scene(scene, seed)
    world, actor = built.world, built.world.actor(built.target_id)
    gain = 1.0 - math.exp(-1.0 / (FPS * 0.8))
    x, y = actor.path.position(start / FPS)
    pan = math.atan2(x, y)
    trk, out = Tracker(params), []
    for k in range(start, stop):
        x, y = actor.path.position(k / FPS)
        new = pan + gain * (math.atan2(x, y) - pan)
        view = CameraView(new, 0.0, 8.0)
        img, truths = world.render(k / FPS, view)
        truth = next(tr for tr in truths if tr.id == built.target_id)
        if k == start:
            trk.init(img, truth.box, bit_depth=16)
        else:
            res = trk.update(img, ego_shift=(view.fx * math.tan(new - pan), 0.0), bit_depth=16)
            if other is None:
                out.append((k, res, truth.box))
            else:
                o = next((tr.box for tr in truths if tr.id == other and tr.in_view), None)
                out.append((k, res, truth.box, o))
        pan = new
    return out


@pytest.mark.parametrize("seed", [1, 2])
def test_demo_pedestrian_is_reacquired_after_stopping_behind_the_wall(seed: int) -> None:
    """The demo's first occlusion (~9.2-10.9 s): the pedestrian stops behind the wall, then walks on
    faster. It reappears between two windows of the papers' 3x3 grid, whose steps of 2/3 of a window
    leave it a third of a window off both centres, where the cosine window has faded it out; meanwhile
    weak peaks on the background (0.3 against the target's 0.7) pull the prediction away. The default
    (lattice + peak rule) is `tracking` on the pedestrian within 0.5 s of its reappearance, also on the
    papers' FHOG features (with the default's extra intensity channel the 3x3 grid alone re-acquires seed 2
    at frame 272 and seed 1 at frame 293). The contrast is pinned as its mechanism: the papers' re-detection
    searches the 3x3 grid (9 windows a frame), the default a lattice of more, finer-spaced windows; that
    the grid misses a target between its windows where the lattice has one is pinned on a frame by
    `test_lattice_finds_a_target_midway_between_grid_windows`. (Measured here: the grid did not re-acquire
    before the run's end at 12 s; whether it does is the chaotic search's outcome, not pinned.)"""
    def reacquired(params: TrackerParams, fhog_only: bool = False) -> tuple[list[int], set[int]]:
        """The frames `tracking` on the pedestrian after his reappearance; the window counts of the
        re-detecting frames."""
        if fhog_only:
            params.base.feature = "hog_soft"
        run = demo_follow(seed, 175, 300, params)
        on = [k for k, r, gt in run if k > 250 and r.state is TrackState.TRACKING
              and abs(r.box.cx - gt.cx) < 0.3 * gt.w and abs(r.box.cy - gt.cy) < 0.3 * gt.h]
        counts = {len(r.search_windows) for _, r, _ in run if r.search_mode is SearchMode.MULTI_WINDOW}
        return on, counts

    got, default_windows = reacquired(TrackerParams())
    assert got and got[0] <= 285, got[:3]
    lattice, lattice_windows = reacquired(TrackerParams(), fhog_only=True)
    assert lattice and lattice[0] <= 285, lattice[:3]
    _, grid_windows = reacquired(papers_redetection(), fhog_only=True)
    assert grid_windows == {9}, grid_windows  # the papers' 3x3 grid on every re-detecting frame
    assert min(default_windows) > 9 and min(lattice_windows) > 9, (default_windows, lattice_windows)


def _taken_back(r) -> bool:
    """A frame on which the look-alike guard took the box back: a normal-mode frame that shows, beside its
    search window, the guard's window at the motion reference (`Tracker._guard_lookalike`)."""
    return r.search_mode is SearchMode.NORMAL and len(r.search_windows) == 2


@pytest.mark.parametrize("seed", [4, 6])
def test_a_lookalike_crossing_in_front_does_not_take_the_box(seed: int) -> None:
    """demo_crossing, tracked from its first frame: a second dark-clothed pedestrian of the target's size
    strolls the other way in front of it at ~5 s and covers up to 70 % of it. Its peak stays as high as the
    target's (0.5-0.65, PSR 12-17), so every frame is confident and the box walks off with it (measured,
    guard off: on the crosser from frame ~131 and the last 30 frames `tracking` on it; in `demo sweep
    --scenes demo_crossing --seeds 4,5,6,7` 3 of 4 runs failed so). The look-alike guard correlates a
    window where the motion before the crossing puts the target once the box has left it by half a box,
    and the target's peak there (0.58-0.61 against the crosser's 0.51-0.54, PSR 15-16) takes the box back
    (measured: frame 133, ~5.3 s). The mechanism is pinned: with the guard the crosser takes the box (the
    situation), the guard takes it back, and the box stays on the target to the end, never `tracking` off
    it; without the guard the crosser takes the box the same way and nothing takes it back. Where the
    unguarded box ends up (on the crosser, here) is that run's outcome, not pinned."""
    def run(guard: bool) -> list:
        p = TrackerParams() if guard else TrackerParams(lookalike=None)
        return demo_follow(seed, 0, 165, p, "demo_crossing", CROSSER_ID)

    def on_crosser(r, gt: Box, other: Box | None) -> bool:
        return other is not None and r.box.iou(other) > 0.5 and r.box.iou(gt) < 0.5

    guarded = run(True)
    took = [k for k, r, gt, c in guarded if on_crosser(r, gt, c)]
    back = [k for k, r, _, _ in guarded if _taken_back(r)]
    assert took and back and took[0] < back[0], (took, back)
    assert all(r.box.iou(gt) > 0.5 and r.state is TrackState.TRACKING for _, r, gt, _ in guarded[-30:])
    assert not any(r.state is TrackState.TRACKING and r.box.iou(gt) == 0.0 for _, r, gt, _ in guarded)
    off = run(False)
    assert [k for k, r, gt, c in off if on_crosser(r, gt, c)][:1] == took[:1]  # the same situation
    assert not any(_taken_back(r) for _, r, _, _ in off)


def test_lattice_finds_a_target_midway_between_grid_windows() -> None:
    """A window a third of a window to the side of the pedestrian: the 3x3 grid's neighbours sit a third
    of a window off it on the other side, the lattice has one within a sixth (issue 12 item 4)."""
    built = build_scene("demo", 1)
    view = CameraView(0.0, 0.0, 8.0)
    img, truths = built.world.render(0.0, view)
    box = next(tr for tr in truths if tr.id == built.target_id).box
    img = img.astype("float32") / 65535.0
    p = TrackerParams()
    r = p.redetection
    base = make_filter(p.base, box.w, box.h)
    base.initialise(img, box)
    at = base.detect(img, [search_window(box.cx, box.cy, box.w, box.h, base.padding)])[0].peak
    off = search_window(box.cx + box.w * (1.0 + base.padding) / 3.0, box.cy, box.w, box.h, base.padding)
    grid = max(d.peak for d in base.detect_grid(img, off, r.grid_overlap)[0])
    lattice, wins = base.detect_lattice(img, off, r.lattice_step, r.lattice_rings,
                                        channels=r.lattice_channels)
    best = max(lattice, key=lambda d: d.peak)
    assert best.peak > 0.75 * at > grid
    assert abs(best.cx - box.cx) < 0.25 * box.w
    assert len(wins) == (2 * r.lattice_rings + 1) ** 2 - 1


def test_lattice_widens_with_the_frames_since_the_last_confident_frame() -> None:
    widening = Redetection(RedetectionParams(lattice_rings=2, lattice_widen_frames=10, lattice_max_rings=4))
    assert [widening.rings(occluded) for occluded in (0, 9, 10, 25, 1000)] == [2, 2, 3, 4, 4]
    fixed = Redetection(RedetectionParams(lattice_widen_frames=0))
    assert fixed.rings(1000) == fixed.p.lattice_rings


def test_lattice_leaves_out_windows_centred_outside_the_image() -> None:
    base = make_filter(TrackerParams().base, 20.0, 40.0)
    win = search_window(5.0, 5.0, 20.0, 40.0, base.padding)
    _sx, _sy, offsets, wins = base.lattice_geometry(win, 0.35, 2, (320, 240))
    assert (0, 0) not in offsets
    assert all(0.0 <= w.cx < 320 and 0.0 <= w.cy < 240 for w in wins)
    assert len(wins) == 8  # the quarter of the 5x5 lattice to the right of and below the corner


def test_lattice_checkerboard_halves_cover_the_outer_rings_on_alternate_frames() -> None:
    """`lattice_alternate` 2: ring 1 in both halves, rings 2-3 split into two disjoint checkerboards."""
    base = make_filter(TrackerParams().base, 20.0, 40.0)
    win = search_window(400.0, 400.0, 20.0, 40.0, base.padding)
    full = base.lattice_geometry(win, 0.35, 3)[2]
    halves = [base.lattice_geometry(win, 0.35, 3, half=(2, parity))[2] for parity in (0, 1)]
    inner = {o for o in full if max(abs(o[0]), abs(o[1])) <= 1}
    assert inner <= set(halves[0]) and inner <= set(halves[1])
    assert (set(halves[0]) - inner).isdisjoint(set(halves[1]) - inner)
    assert set(halves[0]) | set(halves[1]) == set(full)
    assert len(halves[0]) + len(halves[1]) == len(full) + len(inner)  # 28 + 28 = 48 + 8


def test_a_target_two_lattice_steps_away_is_found_by_the_half_that_holds_its_window() -> None:
    """The pedestrian sits under the ring-2 window (2, 0) of a lattice around a displaced window: the half
    with that window finds it at a peak like the centred one's, the other half's nearest windows are a
    whole lattice step off it (a frame later the first half is searched again)."""
    built = build_scene("demo", 1)
    img, truths = built.world.render(0.0, CameraView(0.0, 0.0, 8.0))
    box = next(tr for tr in truths if tr.id == built.target_id).box
    img = img.astype("float32") / 65535.0
    p = TrackerParams()
    step, channels = p.redetection.lattice_step, p.redetection.lattice_channels
    base = make_filter(p.base, box.w, box.h)
    base.initialise(img, box)
    centred = search_window(box.cx, box.cy, box.w, box.h, base.padding)
    at = base.detect(img, [centred])[0].peak
    sx = base.lattice_geometry(centred, step, 2)[0]
    off = centred.shifted(-2 * sx * base.cell * centred.w / base.tw, 0.0)
    found = [max(base.detect_lattice(img, off, step, 2, half=(2, k), channels=channels)[0],
                 key=lambda d: d.peak) for k in (0, 1)]
    assert found[0].peak > 0.9 * at
    assert abs(found[0].cx - box.cx) < 0.1 * box.w
    assert found[1].peak < found[0].peak


@pytest.mark.parametrize("steps", [(1, 0), (-2, 1), (3, -2)])
def test_the_principal_channel_screen_keeps_the_full_lattice_winner(steps: tuple[int, int]) -> None:
    """`lattice_channels` 8: the lattice is screened on 8 of the 32 channels and its 3 best windows are
    correlated in full. The pedestrian under lattice window `steps` of a displaced search: the screened
    lattice returns the full lattice's best detection, the same numbers (it was correlated in full)."""
    built = build_scene("demo", 2)
    img, truths = built.world.render(0.0, CameraView(0.0, 0.0, 8.0))
    box = next(tr for tr in truths if tr.id == built.target_id).box
    img = img.astype("float32") / 65535.0
    full = make_filter(KCFParams(), box.w, box.h)
    screened = make_filter(KCFParams(), box.w, box.h)
    centred = search_window(box.cx, box.cy, box.w, box.h, full.padding)
    best, counts = [], []
    for base, channels in ((full, 0), (screened, 8)):
        base.initialise(img, box)
        sx, sy = base.lattice_geometry(centred, 0.35, 3)[:2]
        k = base.cell * centred.w / base.tw
        off = centred.shifted(-steps[0] * sx * k, -steps[1] * sy * base.cell * centred.h / base.th)
        dets, wins = base.detect_lattice(img, off, 0.35, 3, channels=channels)
        best.append(max(dets, key=lambda d: d.peak))
        counts.append(len(dets))
    assert counts == [len(wins), 3] and len(wins) > 3  # every window in full, then the 3 screened ones
    assert best[1] == best[0]
    assert abs(best[0].cx - box.cx) < 0.1 * box.w


def test_reacquisition_needs_a_psr_above_the_failure_bar() -> None:
    """Synthetic x_low_contrast_interlaced from the SRE start shifted to the top left: while the walker is
    hidden, the occluder's vertical edge gives a non-failed response (PSR 7-10, peak and memory score just
    over their bars), and without the bar it was taken back as the target (190 frames `tracking` on the
    wall on one machine, 75 on another CPU: the run is chaotic). The mechanism, whatever the run: without
    the bar some occluded frame is followed by a `tracking` one under PSR 12 (the edge taken back); with
    `reacquire_psr` 12 (the default; the failure test fires below 7) no `tracking` frame that follows an
    occluded one has a PSR under 12. (The long-loss sweep, on by default, finds the walker again from this
    start: `test_the_sweep_finds_the_walker_the_occluders_edge_held_the_box_from`.)"""
    src = open_source("synth:x_low_contrast_interlaced")
    depth = src.bits if src.bits not in (None, 8, 16) else None

    def returns(bar: float) -> list[float]:
        """PSRs of the frames that turned `tracking` after an occluded frame."""
        p = TrackerParams(sweep=None)
        p.occlusion.reacquire_psr = bar
        trk, out, before = Tracker(p), [], TrackState.TRACKING
        for k, fr in enumerate(src.frames()):
            if k == 0:
                h, w = fr.image.shape[:2]
                trk.init(fr.image, sre_box(fr.gt, "top_left", w, h, "otb"), bit_depth=depth)
                continue
            r = trk.update(fr.image, bit_depth=depth)
            if before is TrackState.OCCLUDED and r.state is TrackState.TRACKING:
                out.append(r.psr)
            before = r.state
        return out

    off, on = returns(0.0), returns(12.0)
    assert min(off, default=99.0) < 12.0, off
    assert all(psr >= 12.0 for psr in on), on


def sweep_run(name: str, start: str) -> tuple[RunStats, list]:
    """The default (long-loss sweep on) on synthetic `name` from SRE start `start`: scores, TrackResults."""
    src = open_source(f"synth:{name}")
    trk = RecordingTracker(TrackerParams())
    run = run_starts(src, lambda: trk, starts=(start,))[start]
    return RunStats.of(run, src.fps), trk.results


def _inside(b: Box, x: float, y: float) -> bool:
    return b.x <= x <= b.x + b.w and b.y <= y <= b.y + b.h


def _swept(r) -> bool:
    """A frame whose box the sweep placed: a re-detecting frame that shows the sweep's window last
    (`Tracker._sweep`) and whose box lies in it, outside every window of the re-detection around the
    prediction (no other step moves the state out of those)."""
    w = r.search_windows
    return (r.search_mode is SearchMode.MULTI_WINDOW and len(w) > 1 and _inside(w[-1], r.box.cx, r.box.cy)
            and not any(_inside(v, r.box.cx, r.box.cy) for v in w[:-1]))


def _returns(results: list) -> list[int]:
    """Indices of the frames that are `tracking` after a frame that was not."""
    return [i for i in range(1, len(results)) if results[i].state is TrackState.TRACKING
            and results[i - 1].state is not TrackState.TRACKING]


def test_the_sweep_finds_a_target_that_turned_back_while_hidden() -> None:
    """Synthetic t2: the walker turns back behind the occluder. The prediction walks on at the
    pre-occlusion pace, the lattice around it widens to 7x7 windows and no further, and the prediction
    leaves the image: without the sweep the track ended `lost` on every SRE start (measured; from the left
    start: `lost` at frame 225, AUC 0.32). With the long-loss sweep (`sweep_after` 25, the default) a tile
    finds him walking back, the window centred there passes the re-acquisition bars and the memory, and he
    is `tracking` again within a second of reappearing (measured: the sweep's find on update 201, 163 px
    from the prediction, `tracking` from update 202, AUC 0.67); no `tracking` frame off him on the way. The
    mechanism is pinned (the re-acquisition is the sweep's find); the run without the sweep is not (its
    chaotic search is not what is tested)."""
    on, results = sweep_run("t2_partial_full_turn_back", "left")
    assert on.occlusions == on.survived == 1 and on.false_tracking == 0, on
    assert TrackState.LOST not in {r.state for r in results}
    returns = _returns(results)
    assert returns and _swept(results[returns[0] - 1]), returns


def test_the_sweep_finds_the_walker_the_occluders_edge_held_the_box_from() -> None:
    """Synthetic x_low_contrast_interlaced from the top-left start: while the walker is hidden the box is
    held on the occluder's edge by non-failed peaks too weak for re-acquisition (above), and it stays there
    after he walks on (measured without the sweep: never `tracking` again, AUC 0.30-0.32). The sweep's
    tiles also run on such rejected frames; his window, correlated at the re-detection's sizes (the box had
    grown to ~1.4x while held), passes the bars: re-acquired, no false-tracking frame (measured: the
    sweep's find on update 207, 88 px away, `tracking` from update 208, AUC 0.64). Pinned: the
    re-acquisition is the sweep's find."""
    on, results = sweep_run("x_low_contrast_interlaced", "top_left")
    assert on.survived == 1 and on.false_tracking == 0, on
    returns = _returns(results)
    assert returns and _swept(results[returns[0] - 1]), returns


@pytest.mark.parametrize("name", ["otb_jogging-1", "otb_skating1", "otb_walking2"])
def test_the_sweep_takes_nothing_when_the_target_is_gone(sequences_dir: Path, name: str) -> None:
    """No false lock from the long-loss sweep: the target tracked for 20 frames, then erased from every later
    frame (its true box inpainted). The image still holds the other jogger (jogging-1), the other skaters
    (skating1) and other walkers (walking2); the sweep searches the whole image for up to 250 frames and
    no frame is `tracking` again (measured on all 10 real sequences: none)."""
    src = open_source(sequences_dir / name)
    trk, states = Tracker(TrackerParams()), []
    for k, fr in enumerate(src.frames()):
        if k == 0:
            trk.init(fr.image, fr.gt)
            continue
        img = fr.image
        if k >= 20:
            g, mask = fr.gt, np.zeros(img.shape[:2], np.uint8)
            mask[max(0, int(g.y) - 4) : int(g.y + g.h) + 4, max(0, int(g.x) - 4) : int(g.x + g.w) + 4] = 255
            img = cv2.inpaint(img, mask, 5, cv2.INPAINT_TELEA)
        states.append(trk.update(img).state)
    assert states[18] is TrackState.TRACKING
    assert TrackState.TRACKING not in states[25:] and TrackState.OCCLUDED in states[25:]
