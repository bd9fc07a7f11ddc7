# SPDX-License-Identifier: Apache-2.0
"""Acquisition tracks <-> visualization_msgs/MarkerArray (/acquisition/tracks, /acquisition/candidates)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from geometry_msgs.msg import Point
from sensor_msgs.msg import Image
from std_msgs.msg import ColorRGBA, Header, UInt32
from visualization_msgs.msg import Marker, MarkerArray

from msg_adapters.debug_image import to_bgr8
from msg_adapters.errors import MessageError
from msg_adapters.image import numpy_to_image
from swir_tracker_ros import topics
from swir_tracker_ros.types import Box

# Marker namespaces: the (relative) names of the topics the markers travel on.
TRACKS_NS = topics.ACQUISITION_TRACKS
CANDIDATES_NS = topics.ACQUISITION_CANDIDATES


@dataclass(frozen=True)
class TrackBox:
    """One entry of /acquisition/tracks: stable track ID, box in image pixels, a label, a score."""

    id: int
    box: Box
    label: str = "confirmed"  # life-cycle status for tracks; for candidates the rank ("1", "2", ...)
    score: float = 0.0  # candidates: appearance distance to the lost target; tracks: 0


def _color(track_id: int) -> ColorRGBA:
    hue = (track_id * 0.61803398875) % 1.0
    r, g, b = (0.5 + 0.5 * math.cos(2 * math.pi * (hue + k / 3.0)) for k in range(3))
    return ColorRGBA(r=float(r), g=float(g), b=float(b), a=1.0)


def tracks_to_markers(tracks: Sequence[TrackBox], header: Header, ns: str = TRACKS_NS) -> MarkerArray:
    """Marker 0 is DELETEALL (the array replaces the previous one); then one LINE_STRIP per track:
    id = track ID, points = TL, TR, BR, BL, TL corners (x = column, y = row, z = 0), text = label,
    scale.x = line width (1 px), scale.z = score, colour derived from the ID."""
    out = MarkerArray()
    out.markers.append(Marker(header=header, ns=ns, action=Marker.DELETEALL))
    for t in tracks:
        if t.id < 0 or t.id > 2**31 - 1:
            raise MessageError(f"track id {t.id} does not fit Marker.id (int32)")
        x0, y0, x1, y1 = t.box.x, t.box.y, t.box.x + t.box.w, t.box.y + t.box.h
        m = Marker(header=header, ns=ns, id=int(t.id), type=Marker.LINE_STRIP, action=Marker.ADD,
                   text=t.label, color=_color(t.id), frame_locked=False)
        m.pose.orientation.w = 1.0
        m.scale.x = 1.0
        m.scale.z = float(t.score)
        m.points = [Point(x=float(x), y=float(y), z=0.0) for x, y in ((x0, y0), (x1, y0), (x1, y1), (x0, y1),
                                                                       (x0, y0))]
        out.markers.append(m)
    return out


def tracks_from_markers(msg: MarkerArray, ns: str = TRACKS_NS) -> list[TrackBox]:
    """The TrackBox list of a /acquisition/tracks (or candidates) message, in message order."""
    out = []
    for m in msg.markers:
        if m.action != Marker.ADD or m.ns != ns:
            continue
        pts = [(float(p.x), float(p.y)) for p in m.points]
        if len(pts) < 4:
            raise MessageError(f"marker {m.ns}/{m.id} has {len(pts)} points, expected 5 box corners")
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
        if not all(math.isfinite(v) for v in xs + ys):
            raise MessageError(f"marker {m.ns}/{m.id} has non-finite corners {pts}")
        out.append(TrackBox(int(m.id), Box(min(xs), min(ys), max(xs) - min(xs), max(ys) - min(ys)), m.text,
                            float(m.scale.z)))
    return out


def selected_id(msg: UInt32) -> int:
    """Track ID requested on /acquisition/select."""
    try:
        return int(msg.data)
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"UInt32.data is not readable ({exc})") from exc


def select_msg(track_id: int) -> UInt32:
    if not 0 <= track_id < 2**32:
        raise MessageError(f"track id {track_id} does not fit UInt32")
    return UInt32(data=int(track_id))


def render_tracks_debug(frame: np.ndarray, tracks: Sequence[TrackBox], header: Header,
                        candidates: Sequence[TrackBox] = (), selected: int | None = None) -> Image:
    """bgr8 /acquisition/debug_image: tracks as ID-coloured boxes with their ID, the handed-off track thick,
    candidates for a lost target in red with their rank."""
    img = to_bgr8(frame).copy()
    for t in tracks:
        c = _color(t.id)
        bgr = (int(255 * c.b), int(255 * c.g), int(255 * c.r))
        p0 = (round(t.box.x), round(t.box.y))
        p1 = (round(t.box.x + t.box.w), round(t.box.y + t.box.h))
        cv2.rectangle(img, p0, p1, bgr, 3 if t.id == selected else 1)
        cv2.putText(img, str(t.id), (p0[0], max(10, p0[1] - 3)), cv2.FONT_HERSHEY_SIMPLEX, 0.45, bgr, 1)
    for rank, t in enumerate(candidates, 1):
        p0 = (round(t.box.x), round(t.box.y))
        p1 = (round(t.box.x + t.box.w), round(t.box.y + t.box.h))
        cv2.rectangle(img, p0, p1, (0, 0, 255), 2)
        cv2.putText(img, f"#{rank}", (p0[0], p1[1] + 12), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 255), 1)
    return numpy_to_image(img, header, "bgr8")
