# SPDX-License-Identifier: Apache-2.0
"""Target selection messages <-> plain values: `track/select` (swir_tracker_interfaces/srv/SelectTarget)
and clicks on an image (`<image topic>_mouse_left`: geometry_msgs/PointStamped, or rqt_image_view's
unstamped geometry_msgs/Point)."""

from __future__ import annotations

import math
from typing import Any, NamedTuple

from msg_adapters.errors import MessageError
from msg_adapters.geometry import box_to_roi
from msg_adapters.stamps import seconds_to_stamp, stamp_to_seconds
from swir_tracker_ros.types import Box

SELECT_TARGET = "swir_tracker_interfaces/srv/SelectTarget"


class Selection(NamedTuple):
    """What an operator selected: on the frame stamped `stamp` (seconds; 0: the newest frame), a box or
    a point (x = column, y = row, full-resolution pixels); exactly one of them is set."""

    stamp: float
    box: Box | None
    point: tuple[float, float] | None


def _point(p: Any, what: str) -> tuple[float, float]:
    try:
        x, y = float(p.x), float(p.y)
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"{what} is not readable ({exc})") from exc
    if not (math.isfinite(x) and math.isfinite(y)):
        raise MessageError(f"{what} ({x}, {y}) is not finite")
    return x, y


def selection_from_request(req: Any) -> Selection:
    """A SelectTarget request: its box, or its point when the box is all zero (width and height 0)."""
    try:
        stamp = stamp_to_seconds(req.header.stamp)
        x, y, w, h = (int(v) for v in (req.box.x_offset, req.box.y_offset, req.box.width, req.box.height))
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"SelectTarget request is not readable ({exc})") from exc
    if w == 0 and h == 0:
        return Selection(stamp, None, _point(req.point, "SelectTarget.point"))
    return Selection(stamp, Box(float(x), float(y), float(w), float(h)), None)


def selection_from_click(msg: Any) -> Selection:
    """A click: a PointStamped (its header stamp: the frame it was made on) or an unstamped Point (what
    rqt_image_view publishes: the newest frame)."""
    hdr = getattr(msg, "header", None)
    if hdr is not None:
        return Selection(stamp_to_seconds(hdr.stamp), None, _point(msg.point, "PointStamped.point"))
    return Selection(0.0, None, _point(msg, "Point"))


def selection_reply(response: Any, code: str, reason: str, stamp: float = 0.0, box: Box | None = None,
                    width: int = 0, height: int = 0) -> Any:
    """Fill a SelectTarget response in place: `code` is the name of one of its constants (ACCEPTED,
    STAMP_TOO_OLD, ...); an accepted one carries the start frame's stamp and the start box (whole pixels,
    clipped to the width x height image)."""
    value = getattr(type(response), code, None)
    if not isinstance(value, int):
        raise MessageError(f"SelectTarget has no result code {code!r}")
    response.accepted = code == "ACCEPTED"
    response.code = value
    response.reason = str(reason)
    if box is not None and stamp > 0:
        response.stamp = seconds_to_stamp(stamp)
        response.box = box_to_roi(box, width, height)
    return response


def selection_result(response: Any) -> tuple[bool, str, str, float, Box | None]:
    """(accepted, code name, reason, start stamp, start box or None) of a SelectTarget response."""
    names = {getattr(type(response), n): n for n in dir(type(response))
             if n.isupper() and isinstance(getattr(type(response), n), int)}
    try:
        roi = response.box
        box = Box(float(roi.x_offset), float(roi.y_offset), float(roi.width), float(roi.height)) \
            if roi.width and roi.height else None
        code = names.get(int(response.code), str(response.code))
        return bool(response.accepted), code, str(response.reason), stamp_to_seconds(response.stamp), box
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"SelectTarget response is not readable ({exc})") from exc
