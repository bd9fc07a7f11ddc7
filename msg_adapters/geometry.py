# SPDX-License-Identifier: Apache-2.0
"""Box <-> PolygonStamped / RegionOfInterest, pan/tilt error <-> Vector3Stamped and the angle maths."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import cv2
import numpy as np

from msg_adapters.backend import (
    HEADER,
    POINT32,
    POLYGON,
    POLYGON_STAMPED,
    RCLPY,
    ROI,
    VECTOR3,
    VECTOR3_STAMPED,
    Backend,
)
from msg_adapters.camera_info import Intrinsics
from msg_adapters.errors import MessageError
from msg_adapters.stamps import msg_seconds
from swir_tracker_ros.types import Box

if TYPE_CHECKING:
    from geometry_msgs.msg import PolygonStamped, Vector3Stamped
    from sensor_msgs.msg import RegionOfInterest
    from std_msgs.msg import Header


# A frame_id for pixel coordinates: `geometry_msgs` values are metres in their frame, so a box in pixels must
# not carry the camera's (TF) frame, where RViz would draw a pixel as a metre. `<image frame_id>_pixels` names
# the image plane of that camera and is no TF frame (nothing can transform it).
PIXEL_FRAME_SUFFIX = "_pixels"
PIXEL_FRAME_DEFAULT = "image_pixels"  # for an image without a frame_id


def pixel_frame_id(image_frame_id: str) -> str:
    """The frame_id of pixel-coordinate outputs of the image with `image_frame_id` (see above)."""
    return f"{image_frame_id}{PIXEL_FRAME_SUFFIX}" if image_frame_id else PIXEL_FRAME_DEFAULT


def pixel_header(image_header: Header, backend: Backend = RCLPY) -> Header:
    """The image's stamp with `pixel_frame_id` of its frame_id: the header of `track/box`."""
    try:
        stamp, frame_id = image_header.stamp, str(image_header.frame_id)
    except AttributeError as exc:
        raise MessageError(f"{type(image_header).__name__} is not a std_msgs/Header") from exc
    return backend.cls(HEADER)(stamp=stamp, frame_id=pixel_frame_id(frame_id))


def box_to_polygon(box: Box | None, header: Header, backend: Backend = RCLPY) -> PolygonStamped:
    """Four corners TL, TR, BR, BL (x = column, y = row, z = 0, pixels); None gives the empty polygon
    (absent). Give it a `pixel_header`: the coordinates are pixels, not metres."""
    points = []
    if box is not None:
        x0, y0, x1, y1 = box.x, box.y, box.x + box.w, box.y + box.h
        point = backend.cls(POINT32)
        points = [point(x=float(x), y=float(y), z=0.0) for x, y in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))]
    return backend.cls(POLYGON_STAMPED)(header=header, polygon=backend.cls(POLYGON)(points=points))


def box_from_polygon(msg: PolygonStamped) -> Box | None:
    """The axis-aligned bounding box of the polygon's points; None for the empty polygon (target absent)."""
    try:
        pts = [(float(p.x), float(p.y)) for p in msg.polygon.points]
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"PolygonStamped.polygon.points are not readable ({exc})") from exc
    if not pts:
        return None
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    if not all(math.isfinite(v) for v in xs + ys):
        raise MessageError(f"PolygonStamped.polygon.points contain non-finite coordinates: {pts}")
    return Box(min(xs), min(ys), max(xs) - min(xs), max(ys) - min(ys))


def box_to_roi(box: Box, width: int, height: int, backend: Backend = RCLPY) -> RegionOfInterest:
    """The integer RegionOfInterest covering `box` (outward to whole pixels), clipped to a width x height
    image; the one Box -> ROI conversion (/track/init from the demo supervisor, the harness replay)."""
    x0 = min(max(math.floor(box.x), 0), width)
    y0 = min(max(math.floor(box.y), 0), height)
    x1 = min(max(math.ceil(box.x + box.w), x0), width)
    y1 = min(max(math.ceil(box.y + box.h), y0), height)
    return backend.cls(ROI)(x_offset=x0, y_offset=y0, width=x1 - x0, height=y1 - y0, do_rectify=False)


def box_from_roi(msg: RegionOfInterest) -> Box:
    """A `Box` from a RegionOfInterest (full-resolution pixels); zero width or height is a `MessageError`."""
    try:
        x, y, w, h = int(msg.x_offset), int(msg.y_offset), int(msg.width), int(msg.height)
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"RegionOfInterest fields are not readable ({exc})") from exc
    if w <= 0 or h <= 0:
        raise MessageError(f"RegionOfInterest.width x height must be positive, got {w}x{h}")
    return Box(float(x), float(y), float(w), float(h))


def pan_tilt_error(u: float, v: float, intr: Intrinsics) -> tuple[float, float]:
    """Angular error (rad) of pixel (u, v) from the optical axis, REP-103 head frame.

    pan_error = atan2(cx - u, fx) (positive: target left of the axis, turn left / counter-clockwise),
    tilt_error = atan2(cy - v, fy) (positive: target above the axis, tilt up). With a lens distortion D the
    pixel is first undistorted (cv2.undistortPoints: the normalised ray (x, y) of the pixel), and
    pan_error = atan(-x), tilt_error = atan(-y): the same formulas for an ideal pinhole.
    """
    if intr.distorted:
        k = np.array([[intr.fx, 0.0, intr.cx], [0.0, intr.fy, intr.cy], [0.0, 0.0, 1.0]])
        ray = cv2.undistortPoints(np.array([[[u, v]]], dtype=np.float64), k, np.array(intr.distortion))
        x, y = float(ray[0, 0, 0]), float(ray[0, 0, 1])
        return math.atan(-x), math.atan(-y)
    return math.atan2(intr.cx - u, intr.fx), math.atan2(intr.cy - v, intr.fy)


def ego_shift(d_pan: float, d_tilt: float, intr: Intrinsics) -> tuple[float, float]:
    """Image shift (pixels, +x right, +y down) of the scene at the optical axis when the head turns.

    A pan increase d_pan > 0 (turn left) moves the scene right: dx = fx * tan(d_pan); a tilt increase
    (up) moves it down: dy = fy * tan(d_tilt). Inverse of `pan_tilt_error` for a point on the axis.
    """
    return intr.fx * math.tan(d_pan), intr.fy * math.tan(d_tilt)


def pan_tilt_to_msg(pan: float, tilt: float, header: Header, backend: Backend = RCLPY) -> Vector3Stamped:
    """/track/pan_tilt_error: x = pan error, y = tilt error (rad), z = 0."""
    return backend.cls(VECTOR3_STAMPED)(header=header,
                                        vector=backend.cls(VECTOR3)(x=float(pan), y=float(tilt), z=0.0))


def pan_tilt_error_from_msg(msg: Vector3Stamped) -> tuple[float, float, float]:
    """(pan error, tilt error, header stamp in seconds) from /track/pan_tilt_error."""
    try:
        pan, tilt = float(msg.vector.x), float(msg.vector.y)
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"Vector3Stamped.vector is not readable ({exc})") from exc
    if not (math.isfinite(pan) and math.isfinite(tilt)):
        raise MessageError(f"Vector3Stamped.vector has non-finite pan/tilt error: x={pan}, y={tilt}")
    return pan, tilt, msg_seconds(msg)
