# SPDX-License-Identifier: Apache-2.0
"""Box, pan/tilt error, camera intrinsics and /track/state adapters: round trips, signs, typed errors."""

from __future__ import annotations

import contextlib
import math

import cv2
import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point32, PolygonStamped
from hypothesis import given, settings
from hypothesis import strategies as st
from sensor_msgs.msg import CameraInfo, RegionOfInterest

from msg_adapters.camera_info import (
    Intrinsics,
    camera_info_from_intrinsics,
    intrinsics_from_camera_info,
    intrinsics_from_fov,
)
from msg_adapters.errors import MessageError
from msg_adapters.geometry import (
    box_from_polygon,
    box_from_roi,
    box_to_polygon,
    box_to_roi,
    ego_shift,
    pan_tilt_error,
    pan_tilt_error_from_msg,
    pan_tilt_to_msg,
)
from msg_adapters.stamps import header, stamp_to_seconds
from msg_adapters.track_state import (
    STATUS_NAME,
    idle_state_msg,
    track_result_from_msg,
    track_result_to_msg,
    track_state_from_msg,
)
from swir_tracker_ros.types import Box, SearchMode, TrackResult, TrackState

INTR = Intrinsics(fx=800.0, fy=800.0, cx=320.0, cy=256.0, width=640, height=512)


def test_polygon_corners_order_and_round_trip() -> None:
    msg = box_to_polygon(Box(10.0, 20.0, 30.0, 40.0), header(12.5, "cam"))
    pts = [(p.x, p.y, p.z) for p in msg.polygon.points]
    assert pts == [(10.0, 20.0, 0.0), (40.0, 20.0, 0.0), (40.0, 60.0, 0.0), (10.0, 60.0, 0.0)]
    assert msg.header.frame_id == "cam" and stamp_to_seconds(msg.header.stamp) == 12.5
    assert box_from_polygon(msg) == Box(10.0, 20.0, 30.0, 40.0)
    assert box_from_polygon(box_to_polygon(None, header(0.0))) is None


def test_polygon_with_nan_is_a_message_error() -> None:
    msg = PolygonStamped()
    msg.polygon.points = [Point32(x=float("nan"), y=1.0, z=0.0)]
    with pytest.raises(MessageError, match="non-finite"):
        box_from_polygon(msg)


def test_roi_round_trip_clips_and_rejects_zero_size() -> None:
    assert box_from_roi(RegionOfInterest(x_offset=5, y_offset=6, width=7, height=8)) == Box(5, 6, 7, 8)
    roi = box_to_roi(Box(-3.2, 500.5, 20.0, 30.0), 640, 512)
    assert (roi.x_offset, roi.y_offset, roi.width, roi.height) == (0, 500, 17, 12)
    with pytest.raises(MessageError, match="width x height must be positive, got 0x8"):
        box_from_roi(RegionOfInterest(x_offset=5, y_offset=6, width=0, height=8))


def test_pan_tilt_sign_convention_rep103() -> None:
    # Target left of and above the optical axis: positive pan (turn left) and positive tilt (up).
    pan, tilt = pan_tilt_error(100.0, 50.0, INTR)
    assert pan > 0 and tilt > 0
    assert pan == pytest.approx(math.atan2(220.0, 800.0)) and tilt == pytest.approx(math.atan2(206.0, 800.0))
    pan, tilt = pan_tilt_error(600.0, 500.0, INTR)
    assert pan < 0 and tilt < 0
    assert pan_tilt_error(320.0, 256.0, INTR) == (0.0, 0.0)


def test_ego_shift_inverts_pan_tilt_error_on_axis() -> None:
    # Head turns left by the angle of a target left of the axis: that target moves onto the axis (+x).
    pan, tilt = pan_tilt_error(100.0, 50.0, INTR)
    dx, dy = ego_shift(pan, tilt, INTR)
    assert dx == pytest.approx(220.0) and dy == pytest.approx(206.0)


def test_pan_tilt_message_round_trip_and_nan() -> None:
    msg = pan_tilt_to_msg(0.1, -0.2, header(3.25))
    assert pan_tilt_error_from_msg(msg) == pytest.approx((0.1, -0.2, 3.25))
    msg.vector.x = float("nan")
    with pytest.raises(MessageError, match="non-finite"):
        pan_tilt_error_from_msg(msg)


def test_fov_fallback() -> None:
    intr = intrinsics_from_fov(640, 512, 90.0)
    assert intr.fx == pytest.approx(320.0) and intr.fy == intr.fx
    assert (intr.cx, intr.cy) == (320.0, 256.0)
    # A box at the right edge of the image sits half the horizontal FOV to the right (negative pan).
    assert pan_tilt_error(640.0, 256.0, intr)[0] == pytest.approx(-math.radians(45.0))
    assert intrinsics_from_fov(640, 512, 90.0, 60.0).fy == pytest.approx(256.0 / math.tan(math.radians(30)))
    with pytest.raises(MessageError, match="horizontal field of view"):
        intrinsics_from_fov(640, 512, 0.0)


def test_camera_info_with_binning_and_roi() -> None:
    msg = CameraInfo(width=1280, height=1024, k=[1600.0, 0.0, 640.0, 0.0, 1610.0, 512.0, 0.0, 0.0, 1.0])
    intr = intrinsics_from_camera_info(msg)
    assert (intr.fx, intr.fy, intr.cx, intr.cy, intr.width, intr.height) == (1600, 1610, 640, 512, 1280, 1024)
    msg.binning_x = msg.binning_y = 2
    intr = intrinsics_from_camera_info(msg)
    assert (intr.fx, intr.cx, intr.width, intr.height) == (800, 320, 640, 512)
    assert intr.scaled_to(320, 256).fx == 400
    with pytest.raises(MessageError, match="uncalibrated"):
        intrinsics_from_camera_info(CameraInfo(width=640, height=512))


def test_camera_info_builder_inverts_the_parser_with_binning_and_roi() -> None:
    image = Intrinsics(800.0, 805.0, 300.25, 250.5, 640, 512)
    plain = camera_info_from_intrinsics(image, header(2.0), d=[0.1, -0.01, 0.0, 0.0, 0.002])
    assert (plain.width, plain.height, plain.binning_x, plain.roi.width) == (640, 512, 0, 0)
    assert list(plain.k) == [800.0, 0.0, 300.25, 0.0, 805.0, 250.5, 0.0, 0.0, 1.0]
    assert list(plain.p) == [800.0, 0.0, 300.25, 0.0, 0.0, 805.0, 250.5, 0.0, 0.0, 0.0, 1.0, 0.0]
    assert list(plain.d) == [0.1, -0.01, 0.0, 0.0, 0.002] and plain.distortion_model == "plumb_bob"
    assert stamp_to_seconds(plain.header.stamp) == 2.0
    assert intrinsics_from_camera_info(plain) == Intrinsics(800.0, 805.0, 300.25, 250.5, 640, 512,
                                                            (0.1, -0.01, 0.0, 0.0, 0.002))
    assert list(camera_info_from_intrinsics(intrinsics_from_camera_info(plain)).d) == list(plain.d)
    # A 2x2-binned 640x512 window at (100, 40) of a 1920x1200 sensor: K and the ROI are in sensor pixels.
    cut = camera_info_from_intrinsics(image, binning=(2, 2), roi_offset=(100, 40), sensor_size=(1920, 1200))
    assert (cut.width, cut.height, cut.binning_x, cut.binning_y) == (1920, 1200, 2, 2)
    assert (cut.roi.x_offset, cut.roi.y_offset, cut.roi.width, cut.roi.height) == (100, 40, 1280, 1024)
    assert list(cut.k) == [1600.0, 0.0, 700.5, 0.0, 1610.0, 541.0, 0.0, 0.0, 1.0]
    assert intrinsics_from_camera_info(cut) == image
    # The other way round: a binned, windowed message parsed and rebuilt gives the same calibration.
    msg = CameraInfo(width=1280, height=1024, k=[1600.0, 0.0, 640.0, 0.0, 1610.0, 512.0, 0.0, 0.0, 1.0],
                     binning_x=2, binning_y=2)
    msg.roi = RegionOfInterest(x_offset=64, y_offset=32, width=1024, height=960)
    again = camera_info_from_intrinsics(intrinsics_from_camera_info(msg), binning=(2, 2), roi_offset=(64, 32),
                                        sensor_size=(1280, 1024))
    assert list(again.k) == list(msg.k) and again.roi == msg.roi
    for bad in ({"binning": (0, 1)}, {"roi_offset": (-1, 0)}, {"sensor_size": (639, 512)}):
        with pytest.raises(MessageError):
            camera_info_from_intrinsics(image, **bad)
    with pytest.raises(MessageError, match="intrinsics are invalid"):
        camera_info_from_intrinsics(Intrinsics(0.0, 805.0, 320.0, 256.0, 640, 512))


@settings(max_examples=200, deadline=None)
@given(st.floats(1.0, 1e5), st.floats(1.0, 1e5), st.floats(-1e4, 1e4), st.floats(-1e4, 1e4),
       st.integers(1, 4000), st.integers(1, 4000), st.integers(1, 8), st.integers(1, 8), st.integers(0, 3000),
       st.integers(0, 3000))
def test_camera_info_round_trip(fx, fy, cx, cy, w, h, bx, by, x0, y0) -> None:
    intr = Intrinsics(fx, fy, cx, cy, w, h)
    msg = camera_info_from_intrinsics(intr, binning=(bx, by), roi_offset=(x0, y0))
    back = intrinsics_from_camera_info(msg)
    assert (back.width, back.height) == (w, h)
    assert (back.fx, back.fy, back.cx, back.cy) == pytest.approx((fx, fy, cx, cy), rel=1e-12, abs=1e-9)


def test_track_state_round_trip() -> None:
    res = TrackResult(box=Box(1, 2, 3, 4), state=TrackState.OCCLUDED, peak=0.31, psr=7.5, apce=12.25,
                      huber_threshold=1.5, search_mode=SearchMode.MULTI_WINDOW, measured=False, scale=1.1)
    msg = track_result_to_msg(res, header(1.0))
    assert msg.status[0].name == STATUS_NAME and msg.status[0].message == "occluded"
    assert msg.status[0].level == DiagnosticStatus.WARN
    assert track_state_from_msg(msg) is TrackState.OCCLUDED
    back = track_result_from_msg(msg, box=res.box)
    assert back == TrackResult(box=res.box, state=res.state, peak=0.31, psr=7.5, apce=12.25,
                               huber_threshold=1.5, search_mode=SearchMode.MULTI_WINDOW, measured=False,
                               scale=1.1)
    assert track_state_from_msg(idle_state_msg(header(0.0))) is TrackState.IDLE


def test_track_state_errors_are_typed() -> None:
    with pytest.raises(MessageError, match="no 'swir_tracker/track'"):
        track_state_from_msg(DiagnosticArray(status=[DiagnosticStatus(name="other")]))
    status = DiagnosticStatus(name=STATUS_NAME, values=[KeyValue(key="state", value="x")])
    bad = DiagnosticArray(status=[status])
    with pytest.raises(MessageError, match="state='x'"):
        track_state_from_msg(bad)
    with pytest.raises(MessageError):
        track_result_from_msg(bad)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.text(max_size=12), st.text(max_size=12)), max_size=10),
       st.sampled_from([STATUS_NAME, "other", ""]))
def test_fuzzed_track_state_only_message_error(pairs: list[tuple[str, str]], name: str) -> None:
    msg = DiagnosticArray(status=[DiagnosticStatus(name=name, values=[KeyValue(key=k, value=v)
                                                                      for k, v in pairs])])
    for fn in (track_state_from_msg, track_result_from_msg):
        with contextlib.suppress(MessageError):
            fn(msg)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.floats(width=32), st.floats(width=32)), max_size=6))
def test_fuzzed_polygon_only_message_error(pts: list[tuple[float, float]]) -> None:
    msg = PolygonStamped()
    msg.polygon.points = [Point32(x=x, y=y, z=0.0) for x, y in pts]
    try:
        box = box_from_polygon(msg)
    except MessageError:
        return
    assert box is None or (box.is_finite() and box.w >= 0 and box.h >= 0)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(width=64), min_size=9, max_size=9), st.integers(0, 5000), st.integers(0, 5000),
       st.integers(0, 8), st.integers(0, 8), st.integers(0, 6000), st.integers(0, 6000), st.integers(0, 6000),
       st.integers(0, 6000))
def test_fuzzed_camera_info_only_message_error(k, width, height, bx, by, rx, ry, rw, rh) -> None:
    msg = CameraInfo(width=width, height=height, k=k, binning_x=bx, binning_y=by)
    msg.roi = RegionOfInterest(x_offset=rx, y_offset=ry, width=rw, height=rh)
    try:
        intr = intrinsics_from_camera_info(msg)
    except MessageError:
        return
    assert intr.fx > 0 and intr.fy > 0 and intr.width > 0 and intr.height > 0
    assert all(math.isfinite(v) for v in (intr.fx, intr.fy, intr.cx, intr.cy))


@settings(max_examples=200, deadline=None)
@given(*[st.integers(0, 2**32 - 1)] * 4)
def test_fuzzed_roi_only_message_error(x: int, y: int, w: int, h: int) -> None:
    try:
        box = box_from_roi(RegionOfInterest(x_offset=x, y_offset=y, width=w, height=h))
    except MessageError:
        assert w == 0 or h == 0
        return
    assert box.is_valid()


def test_pan_tilt_error_undoes_the_lens_distortion() -> None:
    """Issue 39: a plumb_bob D is applied to the error. A ray at known angles is projected through a lens with
    barrel distortion (cv2.projectPoints); the error of that pixel is the ray's angles again, whereas the
    pinhole formula misses them by more than a pixel's angle at the image edge."""
    d = (-0.25, 0.08, 0.001, -0.0005, 0.0)
    ideal = Intrinsics(800.0, 805.0, 320.0, 256.0, 640, 512)
    lens = Intrinsics(800.0, 805.0, 320.0, 256.0, 640, 512, d)
    pan, tilt = 0.3, -0.2  # left and down of the axis: ray (x, y, 1) = (-tan pan, -tan tilt, 1) in optics
    k = np.array([[800.0, 0.0, 320.0], [0.0, 805.0, 256.0], [0.0, 0.0, 1.0]])
    pixel, _ = cv2.projectPoints(np.array([[-math.tan(pan), -math.tan(tilt), 1.0]]), np.zeros(3), np.zeros(3),
                                 k, np.array(d))
    u, v = pixel[0, 0]
    assert pan_tilt_error(u, v, lens) == pytest.approx((pan, tilt), abs=2e-4)
    naive = pan_tilt_error(u, v, ideal)
    assert abs(naive[0] - pan) > 5 / 800 and abs(naive[1] - tilt) > 1 / 805
    assert pan_tilt_error(400.0, 200.0, ideal) == (math.atan2(-80.0, 800.0), math.atan2(56.0, 805.0))
    assert lens.scaled_to(320, 256).distortion == d and lens.zoomed(2.0).fx == 1600.0
    msg = camera_info_from_intrinsics(lens)
    msg.distortion_model = "equidistant"  # a model whose D the error cannot undo: refused, not ignored
    with pytest.raises(MessageError, match="equidistant"):
        intrinsics_from_camera_info(msg)
