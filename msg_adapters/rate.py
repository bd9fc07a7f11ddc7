# SPDX-License-Identifier: Apache-2.0
"""track/target_rate: the target's image velocity (pixels per frame) -> its angular rate (rad/s), REP-103.

The message layout is /track/pan_tilt_error's (`geometry.pan_tilt_to_msg`: x pan, y tilt, the frame's
header); this module is the maths that fills it and reads it back.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from msg_adapters.camera_info import Intrinsics
from msg_adapters.geometry import pan_tilt_error_from_msg

if TYPE_CHECKING:
    from geometry_msgs.msg import Vector3Stamped


def image_rate(u: float, v: float, du: float, dv: float, intr: Intrinsics) -> tuple[float, float]:
    """d/dt of `geometry.pan_tilt_error` at pixel (u, v) moving at (du, dv) pixels per unit time.

    pan = atan2(cx - u, fx)  ->  d pan / dt = -fx du / (fx^2 + (cx - u)^2), and likewise for tilt with
    (fy, cy, v): a target moving right in the image (du > 0) turns clockwise, a negative pan rate.
    """
    ox, oy = intr.cx - u, intr.cy - v
    return -intr.fx * du / (intr.fx ** 2 + ox ** 2), -intr.fy * dv / (intr.fy ** 2 + oy ** 2)


def target_rate(u: float, v: float, velocity: tuple[float, float], frame_period: float, intr: Intrinsics,
                head_rate: tuple[float, float] = (0.0, 0.0)) -> tuple[float, float]:
    """The target's angular rate in the head's base frame (rad/s): what the joints must do to hold it.

    `velocity` is the tracker's box-centre velocity in pixels per frame (`TrackResult.velocity`) at
    (u, v), `frame_period` the camera's frame period (s). With ego-motion compensation the velocity is
    the target's own motion and `head_rate` is (0, 0); without it the velocity is the motion in the image,
    target minus head, and `head_rate` (the joints' rate at the frame, rad/s) is added back.
    """
    pan, tilt = image_rate(u, v, velocity[0] / frame_period, velocity[1] / frame_period, intr)
    return pan + head_rate[0], tilt + head_rate[1]


def head_rate(pose_at: Callable[[float], tuple[float, float] | None], stamp: float, period: float
              ) -> tuple[float, float] | None:
    """The head's joint rates (rad/s) over the frame period before `stamp`, from `pose_at(t) -> (pan,
    tilt)` (the tracker's joint-state history); None while the pose or the period is unknown."""
    now, before = pose_at(stamp), pose_at(stamp - period) if period > 0 else None
    if now is None or before is None:
        return None
    return (now[0] - before[0]) / period, (now[1] - before[1]) / period


def target_rate_from_msg(msg: Vector3Stamped) -> tuple[float, float, float]:
    """(pan rate, tilt rate in rad/s, header stamp in seconds) of a track/target_rate message."""
    return pan_tilt_error_from_msg(msg)
