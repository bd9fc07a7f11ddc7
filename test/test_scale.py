# SPDX-License-Identifier: Apache-2.0
"""DSST scale filter (core/scale.py) and its `scale_estimator = "dsst"` option in the base filters.

Real frames from ../shared/data/sequences, zoomed about the ground-truth box centre by known factors, so
the true scale change is known exactly.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from swir_tracker_ros.configs import configuration
from swir_tracker_ros.core.dcf_ca import DCFCAParams
from swir_tracker_ros.core.registry import make_filter
from swir_tracker_ros.core.scale import DSSTParams, ScaleFilter, scale_patches
from swir_tracker_ros.core.template import TemplateFilter
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.policies.scale_search import ScaleSearch
from swir_tracker_ros.tracker import Tracker, TrackerParams
from swir_tracker_ros.types import Box, TrackState


def real_frame(sequences_dir: Path, seq: str, k: int) -> tuple[np.ndarray, Box]:
    pngs = sorted((sequences_dir / seq).glob("*.png"))
    gts = (sequences_dir / seq / "gt.txt").read_text().split()
    img = cv2.imread(str(pngs[k]), cv2.IMREAD_GRAYSCALE).astype(np.float32) / np.float32(255.0)
    return img, Box(*map(float, gts[k].split(",")))


def zoom(img: np.ndarray, cx: float, cy: float, z: float) -> np.ndarray:
    """The image magnified z times about (cx, cy) (a target there becomes z times larger)."""
    M = np.array([[z, 0.0, (1.0 - z) * cx], [0.0, z, (1.0 - z) * cy]])
    return cv2.warpAffine(img, M, img.shape[::-1], flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


@pytest.mark.parametrize("seq", ["otb_crossing", "otb_walking2", "vottir2015_horse"])
def test_scale_filter_recovers_a_known_zoom(sequences_dir: Path, seq: str) -> None:
    img, box = real_frame(sequences_dir, seq, 10)
    sf = ScaleFilter(DSSTParams(), box.w, box.h)
    sf.train(img, box.cx, box.cy, box.w, box.h, 1.0)
    step = DSSTParams().scale_step
    for z in (0.90, 0.95, 1.0, 1.04, 1.10):
        got = sf.estimate(zoom(img, box.cx, box.cy, z), box.cx, box.cy, box.w, box.h)
        # one sample, one frame: within two scale steps (~4 %), on the right side of 1
        assert abs(np.log(got / z)) <= 2.01 * np.log(step), (z, got)
        assert (got - 1.0) * (z - 1.0) > 0 or z == got == 1.0, (z, got)


def test_scale_patches_replicate_the_border_and_resample_to_the_model_size() -> None:
    img = np.tile(np.arange(60, dtype=np.float32), (40, 1))  # a horizontal ramp
    factors = np.array([0.5, 1.0, 2.0])
    out = scale_patches(img, 2.0, 20.0, 20.0, 10.0, factors, 8, 4)
    assert out.shape == (3, 4, 8) and out.dtype == np.float32
    assert out[2].min() == 0.0  # the crop reaches past the left edge: replicated column 0
    inside = scale_patches(img, 30.0, 20.0, 16.0, 8.0, np.array([1.0]), 8, 4)[0]
    np.testing.assert_allclose(inside[0], 22.5 + 2.0 * np.arange(8), atol=1e-4)  # ramp kept: centres


def test_even_scale_count_is_refused() -> None:
    p = TrackerParams()
    p.base.dsst.n_scales = 32
    with pytest.raises(ParameterError, match=r"dsst\.n_scales"):
        p.validate()


def test_default_is_the_scale_search(sequences_dir: Path) -> None:
    """The option changes nothing unless chosen: one detection per scaled window, no scale filter."""
    p = TrackerParams()
    assert p.base.scale_estimator == "search" and DCFCAParams().scale_estimator == "search"
    img, box = real_frame(sequences_dir, "otb_crossing", 10)
    base = make_filter(p.base, box.w, box.h)
    base.initialise(img, box)
    assert base.scale_filter is None
    wins = [Box.from_center(box.cx, box.cy, box.w * f * 2.5, box.h * f * 2.5) for f in (0.95, 1.0, 1.05)]
    dets = base.detect(img, wins, [0.95, 1.0, 1.05])
    assert [d.window for d in dets] == wins and [d.scale for d in dets] == [0.95, 1.0, 1.05]


def zoom_sequence(img: np.ndarray, box: Box, n: int, rate: float) -> list[np.ndarray]:
    return [zoom(img, box.cx, box.cy, rate**k) for k in range(n)]


@pytest.mark.parametrize("pipeline", ["kcf", "dcf_ca"])
def test_tracker_with_dsst_follows_a_zoom(sequences_dir: Path, pipeline: str) -> None:
    """Real frame zoomed 1.5 % a frame for 24 frames (1.43x): the DSST option ends within 5 % of the true
    size and reports `tracking`; each detect call returns one detection per window (the same one)."""
    img, box = real_frame(sequences_dir, "otb_crossing", 10)
    frames = zoom_sequence(img, box, 25, 1.015)
    p = configuration("measured", pipeline)
    p.base.scale_estimator = "dsst"
    trk = Tracker(p)
    trk.init(frames[0], box)
    for f in frames[1:]:
        r = trk.update(f)
    true = 1.015 ** (len(frames) - 1)
    assert r.state is TrackState.TRACKING
    assert abs(r.box.w / box.w / true - 1.0) < 0.05 and abs(r.box.h / box.h / true - 1.0) < 0.05, r.box
    assert abs(r.box.cx - box.cx) < 3.0 and abs(r.box.cy - box.cy) < 3.0
    base = make_filter(p.base, box.w, box.h)
    base.initialise(frames[0], box)
    base.start_memory()
    wins = [Box.from_center(box.cx, box.cy, box.w * f * 2.5, box.h * f * 2.5) for f in (0.95, 1.0, 1.05)]
    dets = base.detect(frames[-1], wins, [0.95, 1.0, 1.05])
    assert len(dets) == 3 and dets[0] is dets[1] is dets[2] and dets[0].window == wins[1]
    assert np.isfinite(base.memory_score(2))  # any window index reads the middle window's features


def test_interpolated_response_measures_changes_below_one_step(sequences_dir: Path) -> None:
    """A 1.5 % zoom (below the 2 % step): whole steps can only answer 1.0 or 1.02; the interpolated response
    (fDSST) lands between them and nearer the truth."""
    img, box = real_frame(sequences_dir, "otb_walking2", 10)
    coarse = ScaleFilter(DSSTParams(interpolation=1), box.w, box.h)
    fine = ScaleFilter(DSSTParams(), box.w, box.h)
    for sf in (coarse, fine):
        sf.train(img, box.cx, box.cy, box.w, box.h, 1.0)
    for z in (1.0 / 1.015, 1.015):
        zoomed = zoom(img, box.cx, box.cy, z)
        c = coarse.estimate(zoomed, box.cx, box.cy, box.w, box.h)
        f = fine.estimate(zoomed, box.cx, box.cy, box.w, box.h)
        assert min(abs(np.log(c) - k * np.log(1.02)) for k in (-1, 0, 1)) < 1e-9  # a whole step
        assert abs(np.log(f / z)) < 0.5 * np.log(1.02) and abs(np.log(f / z)) < abs(np.log(c / z)), (z, c, f)


@pytest.mark.parametrize("seq", ["otb_walking2", "vottir2015_horse"])
def test_the_scale_climb_picks_what_the_full_search_picks(sequences_dir: Path, seq: str) -> None:
    """`scale_climb`: the 3 middle windows, then outward while the edge wins, and every window when the best
    peak is below the floor. On a real target zoomed in and out (the best window at both ends and in the
    middle), the same winner, peak and memory score as the full search, from fewer windows when the
    predicted size is right."""
    img, box = real_frame(sequences_dir, seq, 10)
    p = TrackerParams()
    base = make_filter(p.base, box.w, box.h)
    base.initialise(img, box)
    base.start_memory()
    factors = ScaleSearch(p.scale).normal
    counted: list[int] = []
    orig = base.features
    base.features = lambda im, wins: counted.append(len(wins)) or orig(im, wins)  # type: ignore[method-assign]
    picked = set()
    for z in (0.86, 0.9, 0.95, 1.0, 1.05, 1.11, 1.16):
        frame = zoom(img, box.cx, box.cy, z)
        wins = [Box.from_center(box.cx, box.cy, box.w * f * 2.5, box.h * f * 2.5) for f in factors]
        full, best, first = base.detect_scales(frame, wins, factors, p.scale.penalty, climb=False)
        assert first == 0 and len(full) == 5
        full_memory = base.memory_score(best)
        counted.clear()
        dets, b, lo = base.detect_scales(frame, wins, factors, p.scale.penalty, climb=True)
        assert lo + b == best, z
        for d, f in zip(dets, full[lo : lo + len(dets)]):  # float32 sums of other batch sizes: rounding
            assert d.window == f.window and d.peak == pytest.approx(f.peak, rel=1e-4)
            assert (d.cx, d.cy) == pytest.approx((f.cx, f.cy), abs=1e-3)
        assert base.memory_score(b) == pytest.approx(full_memory, rel=1e-4)
        assert sum(counted) == len(dets) < 5 or best in (0, 4), (z, counted)
        # a best peak below the floor (a frame unlike the tracked ones): every window, the full search's pick
        dets, b, lo = base.detect_scales(frame, wins, factors, p.scale.penalty, climb=True, floor=math.inf)
        assert (len(dets), lo, b) == (5, 0, best) and [d.window for d in dets] == wins
        assert base.memory_score(b) == pytest.approx(full_memory, rel=1e-4)
        picked.add(best)
    assert {0, 2, 4} <= picked  # the zooms moved the winner to both ends


def test_the_scale_climb_tracks_a_real_sequence_as_the_full_search(sequences_dir: Path) -> None:
    """Whole tracker, OTB crossing (a walker who grows): the same per-frame results with the climb on
    and off up to float32 rounding (batches of other sizes sum in another order), with ~3.5 windows a
    frame instead of 5 in normal mode."""
    pngs = sorted((sequences_dir / "otb_crossing").glob("*.png"))
    gt = Box(*map(float, (sequences_dir / "otb_crossing" / "gt.txt").read_text().split()[0].split(",")))
    frames = [cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) for f in pngs]
    results, windows = {}, {}
    orig = TemplateFilter.features
    for climb in (True, False):
        p = TrackerParams()
        p.scale.climb = climb
        trk = Tracker(p)
        trk.init(frames[0], gt)
        n = [0]

        def counting(self, im, w, n=n):
            n[0] += len(w)
            return orig(self, im, w)

        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(TemplateFilter, "features", counting)
            results[climb] = [trk.update(f) for f in frames[1:]]
        windows[climb] = n[0] / (len(frames) - 1)
    for a, b in zip(results[True], results[False]):
        assert a.state == b.state and a.search_mode == b.search_mode
        assert np.allclose(a.box.as_tuple(), b.box.as_tuple(), atol=0.05), (a.box, b.box)
    # feature maps a frame: 5 scale windows + the training window, against ~3.5 + the same training window
    assert windows[False] >= 6.0 and windows[False] - windows[True] > 1.2, windows
