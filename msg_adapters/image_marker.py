# SPDX-License-Identifier: Apache-2.0
"""TrackResult -> visualization_msgs/ImageMarker (`track/image_markers`): the track drawn over the camera
image by rqt_image_overlay, Foxglove's Image panel and other image-annotation viewers.

Per frame: marker `BOX_ID` (a POLYGON, the box's four corners, outlined in the state's colour) and
`SEARCH_ID` (a LINE_LIST, the search windows' edges in orange) in namespace `NS`, stamped with the image's
header (frame_id and stamp: the image they belong to); while idle or lost both are removed. They live
`LIFETIME_S`, so a stopped tracker leaves no stale box.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from msg_adapters.backend import RCLPY, Backend
from msg_adapters.errors import MessageError
from swir_tracker_ros.types import Box, TrackResult, TrackState

if TYPE_CHECKING:
    from std_msgs.msg import Header

IMAGE_MARKER = "visualization_msgs/msg/ImageMarker"
POINT = "geometry_msgs/msg/Point"
COLOR = "std_msgs/msg/ColorRGBA"
DURATION = "builtin_interfaces/msg/Duration"
NS = "swir_tracker"
BOX_ID, SEARCH_ID = 0, 1
LIFETIME_S = 1.0
LINE_WIDTH = 2.0  # pixels
# RGBA per state, as the debug image draws them: green tracking, amber occluded, red lost, grey idle.
STATE_RGBA = {TrackState.TRACKING: (0.0, 0.86, 0.0, 1.0), TrackState.OCCLUDED: (1.0, 0.78, 0.0, 1.0),
              TrackState.LOST: (1.0, 0.0, 0.0, 1.0), TrackState.IDLE: (0.8, 0.8, 0.8, 1.0)}
SEARCH_RGBA = (1.0, 0.63, 0.0, 0.8)


def _rgba(color: Any, rgba: tuple[float, float, float, float]) -> Any:
    r, g, b, a = (float(v) for v in rgba)
    return color(r=r, g=g, b=b, a=a)


def _corners(box: Box) -> list[tuple[float, float]]:
    x0, y0, x1, y1 = box.x, box.y, box.x + box.w, box.y + box.h
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def track_markers(result: TrackResult | None, header: Header, backend: Backend = RCLPY) -> list[Any]:
    """The ImageMarkers of one frame's result (None: nothing tracked): ADD while tracking or occluded,
    REMOVE otherwise."""
    cls = backend.cls(IMAGE_MARKER)
    point, color = backend.cls(POINT), backend.cls(COLOR)
    life = backend.cls(DURATION)(sec=int(LIFETIME_S), nanosec=round(LIFETIME_S % 1 * 1e9))
    state = result.state if result is not None else TrackState.IDLE
    active = state in (TrackState.TRACKING, TrackState.OCCLUDED)
    if result is None or not active or not result.box.is_finite():
        return [cls(header=header, ns=NS, id=i, action=cls.REMOVE) for i in (BOX_ID, SEARCH_ID)]
    box = cls(header=header, ns=NS, id=BOX_ID, type=cls.POLYGON, action=cls.ADD, scale=LINE_WIDTH,
              outline_color=_rgba(color, STATE_RGBA[state]), filled=0, lifetime=life,
              points=[point(x=float(x), y=float(y), z=0.0) for x, y in _corners(result.box)])
    edges = []
    for win in result.search_windows:
        if win.is_finite():
            c = _corners(win)
            for a, b in zip(c, c[1:] + c[:1]):
                edges += [point(x=float(u), y=float(v), z=0.0) for u, v in (a, b)]
    search = cls(header=header, ns=NS, id=SEARCH_ID, type=cls.LINE_LIST,
                 action=cls.ADD if edges else cls.REMOVE, scale=LINE_WIDTH / 2,
                 outline_color=_rgba(color, SEARCH_RGBA), filled=0, lifetime=life, points=edges)
    return [box, search]


def marker_box(msg: Any) -> Box | None:
    """The box of a `BOX_ID` marker (None when it is a REMOVE); `MessageError` for another marker."""
    try:
        if int(msg.id) != BOX_ID or str(msg.ns) != NS:
            raise MessageError(f"ImageMarker {msg.ns}/{msg.id} is not the track box ({NS}/{BOX_ID})")
        if int(msg.action) == int(type(msg).REMOVE):
            return None
        xs, ys = [float(p.x) for p in msg.points], [float(p.y) for p in msg.points]
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"ImageMarker is not readable ({exc})") from exc
    if len(xs) != 4:
        raise MessageError(f"the track box marker has {len(xs)} points, not 4")
    return Box(min(xs), min(ys), max(xs) - min(xs), max(ys) - min(ys))
