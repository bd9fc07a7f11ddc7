# SPDX-License-Identifier: Apache-2.0
"""Boxes <-> vision_msgs/Detection2DArray (vision_msgs 4.1.1, ROS 2 Jazzy): `track/detections` of the tracker,
`acquisition/detections` and `acquisition/track_detections` of the acquisition node (issue 39).

The layout, per Detection2D: `bbox.center.position` the box centre and `bbox.size_x/size_y` its width and
height in the image's pixels (theta 0: the boxes are axis-aligned), one `results` entry whose
`hypothesis.class_id` names what the box is and `hypothesis.score` how sure the producer is (in [0, 1]), `id`
the object's identity across messages. The header is the image's header (vision_msgs: "this message's header
should match the header of the source data"), the array's and each detection's alike: the pixels are the image
plane of that camera frame. The hypothesis pose is left at zero (no 3D pose is estimated).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from vision_msgs.msg import BoundingBox2D, Detection2D, Detection2DArray, ObjectHypothesisWithPose

from msg_adapters.errors import MessageError
from swir_tracker_ros.types import Box, TrackResult, TrackState

if TYPE_CHECKING:
    from std_msgs.msg import Header

ACTIVE = (TrackState.TRACKING, TrackState.OCCLUDED)


@dataclass(frozen=True)
class Detected:
    """One Detection2D: box (pixels), class_id (what it is / the track state), score in [0, 1], id."""

    box: Box
    class_id: str
    score: float
    id: str = ""


def detections_msg(items: Sequence[Detected], header: Header) -> Detection2DArray:
    """A Detection2DArray of `items` with the image's `header` (on the array and on every detection)."""
    out = Detection2DArray(header=header)
    for item in items:
        b = item.box
        if not (b.is_finite() and b.w >= 0 and b.h >= 0 and math.isfinite(item.score)):
            raise MessageError(f"detection {item} has a non-finite or negative box or score")
        bbox = BoundingBox2D(size_x=float(b.w), size_y=float(b.h))
        bbox.center.position.x, bbox.center.position.y, bbox.center.theta = float(b.cx), float(b.cy), 0.0
        hypothesis = ObjectHypothesisWithPose()
        hypothesis.hypothesis.class_id = str(item.class_id)
        hypothesis.hypothesis.score = float(min(max(item.score, 0.0), 1.0))
        hypothesis.pose.pose.orientation.w = 1.0
        out.detections.append(Detection2D(header=header, results=[hypothesis], bbox=bbox, id=str(item.id)))
    return out


def track_detections(result: TrackResult | None, header: Header, track_id: str) -> Detection2DArray:
    """`track/detections`: the tracked box while `tracking` / `occluded` (class_id the state, score the
    correlation peak clipped to [0, 1], id `track_id`), no detection while `idle` / `lost` (as `track/box`
    is then the empty polygon)."""
    if result is None or result.state not in ACTIVE or not result.box.is_finite():
        return detections_msg((), header)
    return detections_msg((Detected(result.box, result.state.value, result.peak, track_id),), header)


def detections_from_msg(msg: Detection2DArray) -> list[Detected]:
    """The Detected list of a Detection2DArray, in message order (first hypothesis of each)."""
    out = []
    try:
        for d in msg.detections:
            cx, cy = float(d.bbox.center.position.x), float(d.bbox.center.position.y)
            w, h = float(d.bbox.size_x), float(d.bbox.size_y)
            first = d.results[0].hypothesis if len(d.results) else None
            box = Box(cx - w / 2.0, cy - h / 2.0, w, h)
            class_id, score = (str(first.class_id), float(first.score)) if first else ("", 0.0)
            out.append(Detected(box, class_id, score, str(d.id)))
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"Detection2DArray is not readable ({exc})") from exc
    return out
