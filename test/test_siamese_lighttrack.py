# SPDX-License-Identifier: Apache-2.0
"""LightTrack-Mobile as a network of core/siamese (version "lighttrack"): its authors' procedure reproduces
the stored reference run `lighttrack_m` box by box (whole-pixel crops), the 288 px crop and 18 x 18 head
serve a target under 0.4 % of the frame, the default sub-pixel crops follow the target, and the procedure's
own maths (the twice-blended size, the authors' crop window)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import CROSSING_FRAMES

from swir_tracker_ros.core.siamese.crops import lighttrack_window, round_half_away
from swir_tracker_ros.core.siamese.maps import size_update_twice
from swir_tracker_ros.core.siamese.params import VERSIONS, SiameseParams
from swir_tracker_ros.core.siamese.tracker import SiameseTracker
from swir_tracker_ros.harness.sources import frame_files, read_frame
from swir_tracker_ros.types import Box

N = CROSSING_FRAMES
NEEDS_WEIGHTS = pytest.mark.usefixtures("lighttrack_weights")  # conftest: skip without them, with the reason


def peer_boxes(shared_dir: Path, sequence: str) -> np.ndarray:
    f = shared_dir / "peers" / "lighttrack_m" / sequence / "ope.txt"
    if not f.is_file():
        pytest.skip(f"{f} not there")
    return np.loadtxt(f, delimiter=",")


def authors_run(sequences_dir: Path, sequence: str, start: np.ndarray, n: int) -> tuple[SiameseTracker, list]:
    """The authors' procedure (whole-pixel crops) from `start`; boxes written as their test script writes
    them (x, y clipped at 0)."""
    files = frame_files(sequences_dir / sequence)
    trk = SiameseTracker(SiameseParams(version="lighttrack", subpixel_crops=False))
    trk.init(read_frame(files[0]), Box(*start))
    out, maps = [start], []
    for f in files[1:n]:
        res = trk.update(read_frame(f))
        b = res.box
        out.append([max(b.x, 0.0), max(b.y, 0.0), b.w, b.h])
        maps.append(res.score_map.shape)
    return trk, [np.array(out), maps]


@NEEDS_WEIGHTS
@pytest.mark.parametrize(("sequence", "crop", "side"),
                         [("otb_crossing", 256, 16), ("antiuav_irclip04", 288, 18)])
def test_the_authors_procedure_gives_the_stored_reference_boxes(sequence: str, crop: int, side: int,
                                                               shared_dir: Path, sequences_dir: Path) -> None:
    """Frame by frame to the reference file's 0.01 px rounding; a tiny drone (< 0.4 % of the frame) gets the
    288 px crop and the 18 x 18 head, as the authors choose at init."""
    ref = peer_boxes(shared_dir, sequence)
    trk, (got, maps) = authors_run(sequences_dir, sequence, ref[0], N)
    assert trk.instance_size == crop and set(maps) == {(side, side)}
    assert np.abs(got - ref[:N]).max() < 0.006


@NEEDS_WEIGHTS
def test_sub_pixel_crops_follow_otb_crossing(crossing_frames) -> None:
    frames, gt = crossing_frames
    trk = SiameseTracker(SiameseParams(version="lighttrack"))
    assert (trk.exemplar_size, trk.instance_size) == (128, 256)
    trk.init(frames[0], gt[0])
    for k in range(1, N):
        res = trk.update(frames[k])
        assert res.box.iou(gt[k]) > 0.5, (k, res.box, gt[k])
        assert res.score_map.shape == (16, 16) and 0.0 <= res.score_map.min() <= res.score_map.max() <= 1.0
        assert res.score == pytest.approx(res.score_map[res.detection.index])


def test_the_versions_constants_are_the_authors() -> None:
    c = VERSIONS["lighttrack"]
    assert (c.penalty_k, c.window_influence, c.size_lr) == (0.007, 0.225, 0.616)  # LightTrack.yaml, VOT2019
    assert (c.exemplar_size, c.instance_size, c.big_instance_size, c.small_target) == (128, 256, 288, 0.004)
    assert c.instance_for(0.0039 * 1000, 1000) == 288 and c.instance_for(0.004 * 1000, 1000) == 256
    assert VERSIONS["v2"].instance_for(1.0, 1e6) == 255  # NanoTrack has one search crop
    assert SiameseParams(version="lighttrack", instance_size=320).constants.instance_for(1.0, 1e6) == 320


def test_the_size_is_blended_twice() -> None:
    """res = lr new + (1 - lr) old; size = (1 - lr) old + lr res = (1 - lr^2) old + lr^2 new."""
    lr = 0.3
    w, h = size_update_twice(10.0, 20.0, 20.0, 40.0, lr)
    assert (w, h) == pytest.approx((10.0 * (1 - lr**2) + 20.0 * lr**2, 20.0 * (1 - lr**2) + 40.0 * lr**2))


def test_the_authors_crop_window() -> None:
    """get_subwindow_tracking: top-left round(pos - (side + 1)/2), pos the box centre; python2round sides."""
    win = lighttrack_window(100.3, 50.0, 41, 256)
    assert (win.x0, win.y0, win.side, win.out) == (round(100.3 - 21.0), round(50.0 - 21.0), 41, 256)
    assert (round_half_away(2.5), round_half_away(3.5), round_half_away(-2.5), round_half_away(2.4)) == \
        (3, 4, -3, 2)
