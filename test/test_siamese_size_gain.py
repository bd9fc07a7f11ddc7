# SPDX-License-Identifier: Apache-2.0
"""The size rule of issue 52 (docs/siamese.md "Size from a low-gain regression"): the regression gain g
measured on the template's frame, and the size learning rate scaled by g^p. The maths on known numbers; the
tracker on a synthetic point-like thermal target (a small hot blob on a flat sky, whose regressed size
mostly echoes the searched size): its g is the gain of its own two test searches, its lr is the authors'
rate times min(1, g / g_ref)^p, and p = 0 runs no test and keeps the authors' rate."""

from __future__ import annotations

import math

import numpy as np
import pytest

from swir_tracker_ros.core.siamese.maps import gain_factor, regression_gain
from swir_tracker_ros.core.siamese.params import SiameseParams
from swir_tracker_ros.core.siamese.tracker import SiameseTracker
from swir_tracker_ros.types import Box


def test_gain_is_one_minus_the_echo_slope() -> None:
    # a regression that returns the searched size whatever the target: g = 0
    assert regression_gain((10.0, 20.0), (10.0, 20.0)) == pytest.approx(0.0)
    # one that returns the target's size whatever was searched: g = 1
    assert regression_gain((10.0, 20.0), (14.0, 14.0)) == pytest.approx(1.0)
    # halfway in log size: r = sqrt(a T) -> slope 1/2
    t = 14.0
    assert regression_gain((10.0, 20.0), (math.sqrt(10 * t), math.sqrt(20 * t))) == pytest.approx(0.5)
    # kept in [0, 1]: an overshooting echo and an inverted response
    assert regression_gain((10.0, 20.0), (8.0, 25.0)) == 0.0
    assert regression_gain((10.0, 20.0), (16.0, 12.0)) == 1.0
    with pytest.raises(ValueError):
        regression_gain((20.0, 10.0), (10.0, 20.0))
    with pytest.raises(ValueError):
        regression_gain((10.0, 20.0), (0.0, 20.0))


def test_gain_factor_damps_only_below_the_reference() -> None:
    assert gain_factor(0.1, 0.5, 2.0) == pytest.approx(0.04)  # (0.1 / 0.5)^2
    assert gain_factor(0.7, 0.5, 2.0) == 1.0  # at or above the reference: the authors' rate
    assert gain_factor(0.1, 1.0, 1.0) == pytest.approx(0.1)  # reference 1: g^p
    assert gain_factor(0.0, 0.5, 0.0) == 1.0  # power 0: off, whatever the gain


def _sky(cx: float, cy: float) -> np.ndarray:
    """A 320x256 8-bit frame: flat sky, a little noise, a hot Gaussian blob (sigma 2 px) at (cx, cy)."""
    rng = np.random.default_rng(7)
    y, x = np.mgrid[0:256, 0:320].astype(np.float64)
    img = 90.0 + rng.normal(0.0, 2.0, (256, 320)) + 120.0 * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / 8.0)
    return np.clip(img, 0, 255).astype(np.uint8)


@pytest.mark.usefixtures("nanotrack_weights")  # conftest: skip without the weights
def test_small_target_gain_scales_the_size_rate() -> None:
    box = Box.from_center(160.0, 128.0, 14.0, 14.0)  # a loose 14 px box around a ~5 px core
    frame = _sky(160.0, 128.0)
    trk = SiameseTracker(SiameseParams(version="v3", size_gain_power=2.0, size_gain_ref=0.5))
    trk.init(frame, box)
    f = trk.params.size_test
    lo, hi = (trk.search(frame, box.cx, box.cy, box.w * k, box.h * k).box for k in (1.0 / f, f))
    g = regression_gain((14.0 / f, 14.0 * f), (math.sqrt(lo.w * lo.h), math.sqrt(hi.w * hi.h)))
    assert trk.size_gain == pytest.approx(g)
    assert 0.0 <= g < 0.5  # the point-like target's regression mostly echoes the searched size
    nxt = _sky(161.0, 128.5)
    det = trk.search(nxt, *trk.center, *trk.size)
    c = trk.constants
    assert det.lr == pytest.approx(det.penalty * det.score * c.size_lr * min(1.0, g / 0.5) ** 2)
    w = trk.size[0]
    assert det.smoothed.w == pytest.approx(w + det.lr * (det.box.w - w))  # size moves by that rate
    # p = 0 (the default): no test, g = 1, the authors' rate on the same search
    plain = SiameseTracker(SiameseParams(version="v3"))
    plain.init(frame, box)
    assert plain.size_gain == 1.0
    ref = plain.search(nxt, *plain.center, *plain.size)
    assert ref.lr == pytest.approx(ref.penalty * ref.score * c.size_lr)
    assert ref.box.w == pytest.approx(det.box.w)  # the rule changes the rate only, not the regression


@pytest.mark.usefixtures("nanotrack_weights")
def test_every_template_is_tested_again() -> None:
    frame = _sky(160.0, 128.0)
    trk = SiameseTracker(SiameseParams(version="v3", size_gain_power=1.0))
    trk.init(frame, Box.from_center(160.0, 128.0, 14.0, 14.0))
    g_small = trk.size_gain
    trk.set_exemplar(frame, Box.from_center(160.0, 128.0, 40.0, 40.0))  # mostly sky: another gain
    assert trk.size_gain != pytest.approx(g_small)
    assert trk.center == (160.0, 128.0) and trk.size == (14.0, 14.0)  # the state is not touched
