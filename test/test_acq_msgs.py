# SPDX-License-Identifier: Apache-2.0
"""/acquisition/tracks MarkerArray layout, /acquisition/select and the debug image."""

from __future__ import annotations

import numpy as np
import pytest
from std_msgs.msg import Header, UInt32
from visualization_msgs.msg import Marker

from msg_adapters.acquisition import (
    CANDIDATES_NS,
    TrackBox,
    render_tracks_debug,
    select_msg,
    selected_id,
    tracks_from_markers,
    tracks_to_markers,
)
from msg_adapters.errors import MessageError
from swir_tracker_ros.types import Box


def test_tracks_round_trip_through_marker_array() -> None:
    header = Header(frame_id="camera")
    tracks = [TrackBox(4, Box(10.5, 20.0, 30.0, 60.0), "confirmed"),
              TrackBox(9, Box(0, 0, 5, 8), "confirmed")]
    msg = tracks_to_markers(tracks, header)
    assert msg.markers[0].action == Marker.DELETEALL
    m = msg.markers[1]
    assert (m.id, m.type, m.header.frame_id, len(m.points)) == (4, Marker.LINE_STRIP, "camera", 5)
    assert (m.points[2].x, m.points[2].y) == (40.5, 80.0)  # bottom-right corner
    assert tracks_from_markers(msg) == tracks
    cands = tracks_to_markers([TrackBox(9, Box(1, 2, 3, 4), "1", 12.5)], header, CANDIDATES_NS)
    assert tracks_from_markers(cands, CANDIDATES_NS) == [TrackBox(9, Box(1, 2, 3, 4), "1", 12.5)]
    assert tracks_from_markers(cands) == []


def test_bad_markers_and_ids_raise_message_error() -> None:
    msg = tracks_to_markers([TrackBox(1, Box(0, 0, 1, 1))], Header())
    msg.markers[1].points = msg.markers[1].points[:2]
    with pytest.raises(MessageError, match="points"):
        tracks_from_markers(msg)
    with pytest.raises(MessageError):
        tracks_to_markers([TrackBox(2**31, Box(0, 0, 1, 1))], Header())
    assert selected_id(UInt32(data=17)) == 17
    assert select_msg(17).data == 17


def test_debug_image_is_bgr8_with_drawn_boxes() -> None:
    frame = np.full((60, 80), 50, np.uint8)
    img = render_tracks_debug(frame, [TrackBox(1, Box(10, 10, 20, 30))], Header(), selected=1)
    assert (img.encoding, img.width, img.height) == ("bgr8", 80, 60)
    px = np.frombuffer(bytes(img.data), np.uint8).reshape(60, 80, 3)
    assert not np.all(px[10, 10:30] == 50)  # the top edge of the box is drawn
