# SPDX-License-Identifier: Apache-2.0
"""The angular world: projection signs, exact boxes, occlusion truth, determinism, sensor output formats."""

from __future__ import annotations

import math

import numpy as np
import pytest

from swir_tracker_ros.scene import (
    CameraView,
    Leg,
    Path,
    Pedestrian,
    SensorModel,
    World,
    make_panorama,
    pole,
    wall,
)


@pytest.fixture(scope="module")
def pano():
    return make_panorama(3, az_span_deg=30.0)


def walker(x: float, y: float, legs=((20.0, 1.0, 0.0),), pid: int = 1) -> Pedestrian:
    return Pedestrian(pid, Path((x, y), tuple(Leg(*leg) for leg in legs)))


def test_project_unproject_and_sign_convention():
    v = CameraView(pan=0.1, tilt=-0.02, hfov_deg=10.0)
    u, vv = v.project(0.1 + 0.01, -0.02 - 0.005)  # a bit left of and below the optical axis
    assert u < v.cx and vv > v.cy
    az, el = v.unproject(u, vv)
    assert az == pytest.approx(0.11, abs=1e-12) and el == pytest.approx(-0.025, abs=1e-12)
    # interfaces.md: pan_error = atan2(cx - u, fx) equals azimuth - pan
    assert math.atan2(v.cx - u, v.fx) == pytest.approx(0.01, abs=1e-12)


def test_box_follows_range_and_direction(pano):
    w = World(pano, [walker(0.0, 100.0, ((10.0, 1.0, 0.0),))], SensorModel(noise=0, fpn=0))
    view = CameraView(0.0, -0.01)
    b0 = w.render_radiance(0.0, view)[1][0].box
    b1 = w.render_radiance(2.0, view)[1][0].box
    assert b1.cx < b0.cx  # walking to +x (left) moves it to smaller columns
    near = World(pano, [walker(0.0, 50.0)])
    assert near.render_radiance(0.0, view)[1][0].box.h == pytest.approx(2 * b0.h, rel=0.02)


def test_box_is_where_the_pixels_are(pano):
    # A bright person on a flat-ish background: the changed pixels lie inside the truth box.
    w = World(pano, [walker(1.0, 60.0)])
    view = CameraView(0.0, -0.015)
    bg = w._background(view)
    img, truths = w.render_radiance(0.0, view)
    changed = np.argwhere(np.abs(img - bg) > 1e-3)
    b = truths[0].box
    assert changed.size
    assert changed[:, 1].min() >= math.floor(b.x) and changed[:, 1].max() <= math.ceil(b.x + b.w)
    assert changed[:, 0].min() >= math.floor(b.y) and changed[:, 0].max() <= math.ceil(b.y + b.h)
    assert changed[:, 0].max() - changed[:, 0].min() > 0.9 * b.h  # tight vertically


def test_occlusion_truth_partial_and_full(pano):
    view = CameraView(0.0, -0.012, hfov_deg=8.0)
    # A wide wall in front hides a person completely; a thin pole hides a part.
    full = World(pano, [walker(0.0, 100.0, ((1.0, 0.0, 0.0),)), wall(0.0, 50.0, width_m=4.0)])
    tr = full.render_radiance(0.0, view)[1][0]
    assert tr.occluded and tr.fully_occluded and tr.visible_fraction < 0.05
    part = World(pano, [walker(0.0, 100.0, ((1.0, 0.0, 0.0),)), pole(0.0, 50.0, width_m=0.12)])
    tr = part.render_radiance(0.0, view)[1][0]
    assert tr.occluded and not tr.fully_occluded and 0.1 < tr.visible_fraction < 0.9
    behind = World(pano, [walker(0.0, 40.0, ((1.0, 0.0, 0.0),)), wall(0.0, 80.0, width_m=4.0)])
    tr = behind.render_radiance(0.0, view)[1][0]
    assert not tr.occluded and tr.visible_fraction > 0.95  # the wall is behind the person


def test_out_of_view_truth(pano):
    w = World(pano, [walker(30.0, 100.0)])
    tr = w.render(0.0, CameraView())[1][0]
    assert not tr.in_view and tr.visible_fraction == 0.0


def test_deterministic_and_noise_changes_per_frame(pano):
    w = World(pano, [walker(0.0, 80.0)], SensorModel(noise=0.02), seed=5)
    view = CameraView(0.0, -0.012)
    a, _ = w.render(0.4, view)
    b, _ = w.render(0.4, view)
    c, _ = w.render(0.44, view)
    np.testing.assert_array_equal(a, b)
    assert np.mean(a != c) > 0.5
    w2 = World(pano, [walker(0.0, 80.0)], SensorModel(noise=0.02), seed=5)
    np.testing.assert_array_equal(a, w2.render(0.4, view)[0])


@pytest.mark.parametrize(("bits", "dtype", "top"), [(8, np.uint8, 255), (12, np.uint16, 4095),
                                                    (16, np.uint16, 65535)])
def test_sensor_bit_depths(pano, bits, dtype, top):
    w = World(pano, [walker(0.0, 80.0)], SensorModel(bits=bits, dead_pixels=0.01))
    img, _ = w.render(0.0, CameraView(0.0, -0.012))
    assert img.dtype == dtype and img.shape == (504, 576)
    assert img.max() == top and img.min() == 0  # hot and dark dead pixels


def test_interlacing_combs_a_moving_person(pano):
    fast = [walker(0.0, 60.0, ((5.0, 8.0, 0.0),))]
    progressive = World(pano, fast, SensorModel(noise=0, fpn=0, interlaced=False))
    interlaced = World(pano, fast, SensorModel(noise=0, fpn=0, interlaced=True))
    view = CameraView(0.0, -0.015)
    p, _ = progressive.render(0.2, view)
    i, _ = interlaced.render(0.2, view)
    np.testing.assert_array_equal(p[0::2], i[0::2])  # even field at t
    assert np.any(p[1::2] != i[1::2])  # odd field half a frame later


def test_shake_moves_the_truth_with_the_image(pano):
    w = World(pano, [walker(0.0, 80.0, ((1.0, 0.0, 0.0),))], SensorModel(shake_px=6.0))
    view = CameraView(0.0, -0.012)
    xs = [w.render(t, view)[1][0].box.x for t in np.arange(0, 2, 0.2)]
    assert np.ptp(xs) > 2.0
