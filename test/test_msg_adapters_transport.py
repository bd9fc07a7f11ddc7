# SPDX-License-Identifier: Apache-2.0
"""Adapters of issue 33: CompressedImage (image_transport's compressed), ImageMarker, the typed TrackState,
SelectTarget and clicks, the pixel frame_id; topics' relative names and image_transport naming."""

from __future__ import annotations

import array
import contextlib

import numpy as np
import pytest
from geometry_msgs.msg import Point, PointStamped
from hypothesis import given, settings
from hypothesis import strategies as st
from sensor_msgs.msg import CompressedImage, RegionOfInterest
from visualization_msgs.msg import ImageMarker

from msg_adapters.compressed import codec_of, compressed_to_numpy, numpy_to_compressed
from msg_adapters.errors import MessageError
from msg_adapters.geometry import pixel_frame_id, pixel_header
from msg_adapters.image_marker import BOX_ID, SEARCH_ID, marker_box, track_markers
from msg_adapters.selection import (
    selection_from_click,
    selection_from_request,
    selection_reply,
    selection_result,
)
from msg_adapters.stamps import header, stamp_to_seconds
from msg_adapters.track_state import typed_state_from_msg, typed_state_msg
from swir_tracker_interfaces.msg import TrackState as TrackStateMsg
from swir_tracker_interfaces.srv import SelectTarget
from swir_tracker_ros import topics
from swir_tracker_ros.types import Box, SearchMode, TrackResult, TrackState

RNG = np.random.default_rng(5)


def smooth(shape: tuple[int, ...], dtype) -> np.ndarray:
    """A smooth gradient image (compresses well, JPEG error small)."""
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    base = (xx * 3 + yy * 2).astype(np.float64)
    img = base[..., None].repeat(shape[2], 2) * [1, 0.5, 0.25] if len(shape) == 3 else base
    top = 255 if dtype == np.uint8 else 65535
    return (img / img.max() * top).astype(dtype)


@pytest.mark.parametrize(("codec", "shape", "dtype", "tolerance"), [
    ("jpeg", (48, 64), np.uint8, 4), ("jpeg", (48, 64, 3), np.uint8, 6),
    ("png", (48, 64), np.uint8, 0), ("png", (48, 64), np.uint16, 0), ("png", (48, 64, 3), np.uint8, 0)])
def test_compressed_round_trip(codec: str, shape, dtype, tolerance: int) -> None:
    pixels = smooth(shape, dtype)
    msg = numpy_to_compressed(pixels, header(3.5, "cam"), codec, quality=95)
    enc = "mono16" if dtype == np.uint16 else "bgr8" if len(shape) == 3 else "mono8"
    assert msg.format == f"{enc}; {codec} compressed {enc}" and stamp_to_seconds(msg.header.stamp) == 3.5
    frame = compressed_to_numpy(msg)
    assert frame.pixels.shape == shape and frame.pixels.dtype == dtype
    assert frame.bit_depth == (16 if dtype == np.uint16 else 8)
    assert np.abs(frame.pixels.astype(int) - pixels.astype(int)).max() <= tolerance


@pytest.mark.parametrize(("fmt", "codec"), [
    ("jpeg", "jpeg"), ("png", "png"), ("mono8; jpeg compressed mono8", "jpeg"),
    ("rgb8; jpeg compressed bgr8", "jpeg"), ("mono16; png compressed mono16", "png"), ("JPG", "jpeg")])
def test_format_names(fmt: str, codec: str) -> None:
    assert codec_of(fmt) == codec


def test_bad_compressed_images_are_message_errors() -> None:
    good = numpy_to_compressed(smooth((32, 32), np.uint8), header(1.0), "jpeg")
    cases = [
        CompressedImage(format="theora", data=good.data),
        CompressedImage(format="16UC1; compressedDepth png", data=good.data),
        CompressedImage(format="png", data=good.data),  # JPEG bytes labelled png
        CompressedImage(format="jpeg", data=good.data[:50]),  # truncated
        CompressedImage(format="jpeg", data=array.array("B", b"")),
        CompressedImage(format="jpeg", data=array.array("B", b"\xff\xd8\xff" + bytes(100))),
    ]
    for msg in cases:
        with pytest.raises(MessageError):
            compressed_to_numpy(msg)
    rgba = numpy_to_compressed(smooth((32, 32, 3), np.uint8), header(1.0), "png")
    assert compressed_to_numpy(rgba).pixels.shape == (32, 32, 3)
    with pytest.raises(MessageError, match="mono16"):
        numpy_to_compressed(smooth((8, 8), np.uint16), header(1.0), "jpeg")


@settings(max_examples=60, deadline=None)
@given(st.binary(max_size=300), st.sampled_from(["jpeg", "png", "bgr8; jpeg compressed bgr8"]))
def test_random_bytes_never_raise_anything_but_message_error(data: bytes, fmt: str) -> None:
    with contextlib.suppress(MessageError):
        compressed_to_numpy(CompressedImage(format=fmt, data=array.array("B", data)))


def test_image_markers_draw_the_box_and_search_windows_and_remove_them_when_idle() -> None:
    result = TrackResult(Box(10, 20, 30, 40), TrackState.OCCLUDED,
                         search_windows=(Box(0, 0, 50, 50), Box(50, 0, 50, 50)))
    box, search = track_markers(result, header(2.0, "cam"))
    assert (box.ns, box.id) == ("swir_tracker", BOX_ID)
    assert (box.type, box.action) == (ImageMarker.POLYGON, ImageMarker.ADD)
    assert marker_box(box) == Box(10, 20, 30, 40) and box.header.frame_id == "cam"
    assert box.outline_color.r == 1.0 and box.outline_color.g == pytest.approx(0.78)  # amber: occluded
    assert search.type == ImageMarker.LINE_LIST and len(search.points) == 16 and search.id == SEARCH_ID
    assert box.lifetime.sec == 1
    lost = TrackResult(Box(0, 0, 0, 0), TrackState.LOST)
    for gone in (track_markers(None, header(2.0)), track_markers(lost, header(2.0))):
        assert [m.action for m in gone] == [ImageMarker.REMOVE, ImageMarker.REMOVE]
        assert marker_box(gone[0]) is None
    with pytest.raises(MessageError):
        marker_box(search)


def test_typed_state_round_trip() -> None:
    result = TrackResult(Box(10.4, 20.6, 30.0, 40.0), TrackState.OCCLUDED, peak=0.4, psr=6.5, apce=12.0,
                         huber_threshold=0.3, search_mode=SearchMode.MULTI_WINDOW, measured=False, scale=1.1)
    msg = typed_state_msg(result, header(4.0, "cam"), 7, 100, 100)
    assert isinstance(msg, TrackStateMsg) and msg.state == TrackStateMsg.OCCLUDED
    assert msg.search_mode == TrackStateMsg.SEARCH_MULTI_WINDOW and msg.frames_occluded == 7
    assert (msg.box.x_offset, msg.box.y_offset, msg.box.width, msg.box.height) == (10, 20, 31, 41)
    assert typed_state_from_msg(msg) == (TrackState.OCCLUDED, Box(10, 20, 31, 41))
    idle = typed_state_msg(TrackResult(Box(5, 5, 5, 5), TrackState.IDLE), header(4.0), 0, 100, 100)
    assert typed_state_from_msg(idle) == (TrackState.IDLE, None)
    bad = TrackStateMsg(state=9)
    with pytest.raises(MessageError):
        typed_state_from_msg(bad)


def test_selection_messages() -> None:
    req = SelectTarget.Request(header=header(12.5), box=RegionOfInterest(x_offset=3, y_offset=4, width=5,
                                                                         height=6))
    assert selection_from_request(req) == (12.5, Box(3, 4, 5, 6), None)
    req = SelectTarget.Request(header=header(12.5), point=Point(x=7.0, y=8.0))
    assert selection_from_request(req) == (12.5, None, (7.0, 8.0))
    with pytest.raises(MessageError, match="not finite"):
        selection_from_request(SelectTarget.Request(point=Point(x=float("nan"))))
    click = PointStamped(header=header(3.0), point=Point(x=1.0, y=2.0))
    assert selection_from_click(click) == (3.0, None, (1.0, 2.0))
    assert selection_from_click(Point(x=1.0, y=2.0)) == (0.0, None, (1.0, 2.0))  # rqt_image_view: newest
    reply = selection_reply(SelectTarget.Response(), "ACCEPTED", "ok", 9.25, Box(1.5, 2.5, 10, 10), 100, 100)
    assert reply.accepted and reply.code == SelectTarget.Response.ACCEPTED
    assert selection_result(reply) == (True, "ACCEPTED", "ok", 9.25, Box(1, 2, 11, 11))
    reply = selection_reply(SelectTarget.Response(), "STAMP_TOO_OLD", "too old")
    assert selection_result(reply)[:3] == (False, "STAMP_TOO_OLD", "too old")
    with pytest.raises(MessageError):
        selection_reply(SelectTarget.Response(), "MAYBE", "")


def test_pixel_frame_ids() -> None:
    assert pixel_frame_id("camera_optical_frame") == "camera_optical_frame_pixels"
    assert pixel_frame_id("") == "image_pixels"
    hdr = pixel_header(header(5.0, "cam"))
    assert hdr.frame_id == "cam_pixels" and stamp_to_seconds(hdr.stamp) == 5.0


def test_names_are_relative_and_transport_topics_follow_image_transport() -> None:
    names = [v for k, v in vars(topics).items() if k.isupper() and isinstance(v, str) and "/" in v
             and not k.endswith("SUFFIX")]
    assert [n for n in names if n.startswith("/")] == [topics.DIAGNOSTICS, topics.CLOCK]
    assert topics.absolute(topics.IMAGE) == "/camera/image_raw"
    assert topics.absolute(topics.IMAGE, "/head1") == "/head1/camera/image_raw"
    assert topics.absolute(topics.DIAGNOSTICS, "/head1") == "/diagnostics"
    assert topics.TYPES["/track/box"] == topics.TYPES["track/box"] == "geometry_msgs/msg/PolygonStamped"
    assert topics.transport_topic("camera/image_raw", "compressed") == "camera/image_raw/compressed"
    assert topics.transport_topic("camera/image_raw", "raw") == "camera/image_raw"
    assert topics.mouse_left_topic("camera/image_raw") == "camera/image_raw_mouse_left"
    with pytest.raises(ValueError):
        topics.transport_topic("x", "theora")
