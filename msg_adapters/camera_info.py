# SPDX-License-Identifier: Apache-2.0
"""sensor_msgs/CameraInfo <-> pinhole intrinsics, and the field-of-view fallback used without one."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from msg_adapters.backend import CAMERA_INFO, HEADER, RCLPY, ROI, TIME, Backend
from msg_adapters.errors import MessageError

if TYPE_CHECKING:
    from sensor_msgs.msg import CameraInfo
    from std_msgs.msg import Header


# The distortion models whose D the error undoes (cv2.undistortPoints), with their number of coefficients.
DISTORTION_MODELS = {"plumb_bob": 5, "rational_polynomial": 8}


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics in pixels for an image of `width` x `height` (K = [fx 0 cx; 0 fy cy; 0 0 1]) and
    the lens distortion D of CameraInfo's `plumb_bob` (k1, k2, p1, p2, k3) or `rational_polynomial` (8
    coefficients) model, in normalised coordinates (so unchanged by resizing or zoom scaling); () = none."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    distortion: tuple[float, ...] = ()

    def scaled_to(self, width: int, height: int) -> Intrinsics:
        """The same optics for an image resized to width x height (binning, decimation)."""
        if (width, height) == (self.width, self.height):
            return self
        sx, sy = width / self.width, height / self.height
        return dataclasses.replace(self, fx=self.fx * sx, fy=self.fy * sy, cx=self.cx * sx, cy=self.cy * sy,
                                   width=width, height=height)

    def zoomed(self, scale: float) -> Intrinsics:
        """The focal lengths multiplied by `scale` (a zoom lens at another focal length; principal point and
        distortion kept)."""
        return self if scale == 1.0 else dataclasses.replace(self, fx=self.fx * scale, fy=self.fy * scale)

    @property
    def distorted(self) -> bool:
        return any(v != 0.0 for v in self.distortion)


def intrinsics_from_fov(width: int, height: int, hfov_deg: float, vfov_deg: float = 0.0) -> Intrinsics:
    """Intrinsics of an ideal pinhole with the given horizontal (and optional vertical) field of view.

    fx = (width / 2) / tan(hfov / 2); fy likewise from vfov, or fy = fx (square pixels) when
    vfov_deg <= 0. The principal point is the image centre (width / 2, height / 2) in the box
    coordinates of `swir_tracker_ros.types.Box` (a box (0, 0, width, height) is centred on it).
    """
    if width <= 0 or height <= 0:
        raise MessageError(f"image size must be positive for the FOV fallback, got {width}x{height}")
    if not 0.0 < hfov_deg < 180.0:
        raise MessageError(f"horizontal field of view must be in (0, 180) deg, got {hfov_deg}")
    if vfov_deg >= 180.0 or not math.isfinite(vfov_deg):
        raise MessageError(f"vertical field of view must be < 180 deg (<= 0: square pixels), got {vfov_deg}")
    fx = (width / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
    fy = (height / 2.0) / math.tan(math.radians(vfov_deg) / 2.0) if vfov_deg > 0 else fx
    return Intrinsics(fx, fy, width / 2.0, height / 2.0, int(width), int(height))


def intrinsics_from_matrix(k: Sequence[float], width: int, height: int) -> Intrinsics:
    """Intrinsics of a row-major 3x3 camera matrix K = [fx 0 cx; 0 fy cy; 0 0 1] (no skew)."""
    if len(k) != 9:
        raise MessageError(f"camera matrix K needs 9 values, got {len(k)}")
    kk = [float(v) for v in k]
    if (kk[1], kk[3], kk[6], kk[7], kk[8]) != (0.0, 0.0, 0.0, 0.0, 1.0):
        raise MessageError(f"camera matrix K must be [fx 0 cx; 0 fy cy; 0 0 1], got {kk}")
    return Intrinsics(kk[0], kk[4], kk[2], kk[5], int(width), int(height))


def intrinsics_from_camera_info(msg: CameraInfo) -> Intrinsics:
    """fx, fy, cx, cy from `CameraInfo.k`, corrected for `binning_x/y` and `roi` (REP-104), and the
    distortion D (plumb_bob or rational_polynomial; all-zero D: none).

    Raises `MessageError` for an uncalibrated (all-zero) K, non-finite or non-positive focal lengths
    or a zero image size.
    """
    try:
        k = [float(v) for v in msg.k]
        width, height = int(msg.width), int(msg.height)
        bx, by = max(int(msg.binning_x), 1), max(int(msg.binning_y), 1)
        roi_x, roi_y = int(msg.roi.x_offset), int(msg.roi.y_offset)
        roi_w, roi_h = int(msg.roi.width), int(msg.roi.height)
        model, d = str(msg.distortion_model), tuple(float(v) for v in msg.d)
    except (AttributeError, TypeError, ValueError) as exc:
        raise MessageError(f"CameraInfo fields are not readable ({exc})") from exc
    if len(k) != 9:
        raise MessageError(f"CameraInfo.k must have 9 elements, got {len(k)}")
    if width <= 0 or height <= 0:
        raise MessageError(f"CameraInfo.width x height must be positive, got {width}x{height}")
    fx, fy, cx, cy = k[0], k[4], k[2], k[5]
    if not all(math.isfinite(v) for v in (fx, fy, cx, cy)) or fx <= 0 or fy <= 0:
        raise MessageError(f"CameraInfo.k is uncalibrated or invalid: fx={fx}, fy={fy}, cx={cx}, cy={cy}")
    # REP-104: the image is the ROI of the full sensor, then binned.
    cx, cy = cx - roi_x, cy - roi_y
    out_w = (roi_w if roi_w > 0 else width) // bx
    out_h = (roi_h if roi_h > 0 else height) // by
    if out_w <= 0 or out_h <= 0:
        raise MessageError(f"CameraInfo roi/binning leave an empty image: {out_w}x{out_h}")
    fx_out, fy_out = fx / bx, fy / by
    if not (fx_out > 0 and fy_out > 0):  # a denormal focal length underflows to zero once binned
        raise MessageError(f"CameraInfo.k focal lengths vanish after binning {bx}x{by}: fx={fx}, fy={fy}")
    if any(v != 0.0 for v in d):
        if model not in DISTORTION_MODELS or len(d) != DISTORTION_MODELS[model]:
            raise MessageError(f"CameraInfo distortion model {model!r} with {len(d)} coefficients is not "
                               f"one of {DISTORTION_MODELS} (coefficients, by model)")
        if not all(math.isfinite(v) for v in d):
            raise MessageError(f"CameraInfo.d has non-finite coefficients: {d}")
    else:
        d = ()
    return Intrinsics(fx_out, fy_out, cx / bx, cy / by, out_w, out_h, d)


def camera_info_from_intrinsics(intr: Intrinsics, header: Header | None = None, *,
                                binning: tuple[int, int] = (1, 1), roi_offset: tuple[int, int] = (0, 0),
                                sensor_size: tuple[int, int] | None = None,
                                distortion_model: str = "plumb_bob",
                                d: Sequence[float] | None = None, backend: Backend = RCLPY) -> CameraInfo:
    """The CameraInfo of an image with intrinsics `intr`: the inverse of `intrinsics_from_camera_info`.

    REP-104: the message describes the full sensor (`sensor_size`, default: exactly the ROI) with
    K = [fx bx, 0, cx bx + x0; 0, fy by, cy by + y0; 0, 0, 1], the image being the ROI at `roi_offset`
    (x0, y0) of `intr.width * bx` x `intr.height * by` sensor pixels, binned `binning` = (bx, by).
    A ROI covering the whole sensor is written as the all-zero ROI, no binning as binning 0.
    R = I and P = [K | 0] (a monocular camera whose images need no rectification); `d` is copied (default:
    the intrinsics' own distortion, or five zeros).
    Raises `MessageError` for invalid intrinsics, binning < 1, a negative offset or a ROI off the sensor.
    """
    bx, by = (int(b) for b in binning)
    x0, y0 = (int(o) for o in roi_offset)
    if bx < 1 or by < 1 or x0 < 0 or y0 < 0:
        raise MessageError(f"binning must be >= 1 and the ROI offset >= 0, got {binning} and {roi_offset}")
    finite = all(math.isfinite(v) for v in (intr.fx, intr.fy, intr.cx, intr.cy))
    if not (finite and intr.fx > 0 and intr.fy > 0 and intr.width > 0 and intr.height > 0):
        raise MessageError(f"intrinsics are invalid: {intr}")
    roi_w, roi_h = int(intr.width) * bx, int(intr.height) * by
    full_w, full_h = (int(v) for v in sensor_size) if sensor_size is not None else (x0 + roi_w, y0 + roi_h)
    if x0 + roi_w > full_w or y0 + roi_h > full_h:
        raise MessageError(f"ROI {roi_w}x{roi_h} at ({x0}, {y0}) exceeds the {full_w}x{full_h} sensor")
    whole = (x0, y0, roi_w, roi_h) == (0, 0, full_w, full_h)  # written as the all-zero ROI
    roi = backend.cls(ROI)(x_offset=0 if whole else x0, y_offset=0 if whole else y0,
                           width=0 if whole else roi_w, height=0 if whole else roi_h, do_rectify=False)
    if header is None:
        header = backend.cls(HEADER)(stamp=backend.cls(TIME)(sec=0, nanosec=0), frame_id="")
    fx, fy, cx, cy = intr.fx * bx, intr.fy * by, intr.cx * bx + x0, intr.cy * by + y0
    if d is None:
        d = intr.distortion or (0.0,) * 5
    return backend.cls(CAMERA_INFO)(
        header=header, width=full_w, height=full_h, distortion_model=distortion_model, d=backend.f64(d),
        k=backend.f64([fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]),
        r=backend.f64([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]),
        p=backend.f64([fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]),
        binning_x=bx if bx > 1 else 0, binning_y=by if by > 1 else 0, roi=roi)
