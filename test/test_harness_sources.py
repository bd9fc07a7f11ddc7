# SPDX-License-Identifier: Apache-2.0
"""Sequence folders: PNG and 8-bit gray JPEG frames, gt.txt separated by commas, tabs or spaces."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.sources import frame_files, open_source, read_gt, source_fingerprint
from swir_tracker_ros.types import Box


def test_a_jpeg_sequence_reads_as_gray_frames(sequences_dir):
    src = open_source(sequences_dir / "antiuav_irclip04")
    frames = list(src.frames())
    assert len(frames) == len(frame_files(sequences_dir / "antiuav_irclip04")) == 149
    assert frames[0].image.dtype == np.uint8 and frames[0].image.shape == (512, 640)
    assert frames[0].gt == Box(227.16, 185.16, 13.68, 6.01)
    assert frames[0].image.mean() > 0


def test_png_jpeg_and_separators(tmp_path):
    rng = np.random.default_rng(1)
    img = (rng.random((40, 60)) * 255).astype(np.uint8)
    for name, ext in (("pngs", ".png"), ("jpgs", ".jpg")):
        d = tmp_path / name
        d.mkdir()
        for k in range(3):
            cv2.imwrite(str(d / f"{k + 1:06d}{ext}"), img)
        (d / "gt.txt").write_text("1,2,10,12\n1\t2\t10\t12\n1 2  10 12\n\n")
        frames = list(open_source(d).frames())
        assert [f.gt for f in frames] == [Box(1, 2, 10, 12)] * 3
        assert all(f.image.shape == (40, 60) and f.image.ndim == 2 for f in frames)
    np.testing.assert_array_equal(next(iter(open_source(tmp_path / "pngs").frames())).image, img)
    colour = tmp_path / "colour"
    colour.mkdir()
    cv2.imwrite(str(colour / "000001.jpg"), np.dstack([img, img, img]))
    (colour / "gt.txt").write_text("1,2,10,12\n")
    assert next(open_source(colour).frames()).image.ndim == 2  # a colour JPEG is read as gray
    pngs, jpgs = open_source(tmp_path / "pngs"), open_source(tmp_path / "jpgs")
    assert source_fingerprint(pngs) != source_fingerprint(jpgs)


def test_a_bad_gt_line_names_the_file_and_line(tmp_path):
    (tmp_path / "gt.txt").write_text("1,2,3,4\n1,2,x,4\n")
    with pytest.raises(HarnessError, match=r"gt\.txt: line 2 is not x,y,w,h"):
        read_gt(tmp_path)
