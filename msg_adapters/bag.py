# SPDX-License-Identifier: Apache-2.0
"""rosbags-typed messages <-> numpy frames and Boxes: the harness's only knowledge of message layouts."""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_typestore

from msg_adapters.errors import MessageError
from swir_tracker_ros.types import Box

IMAGE = "sensor_msgs/msg/Image"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
POLYGON_STAMPED = "geometry_msgs/msg/PolygonStamped"
ROI = "sensor_msgs/msg/RegionOfInterest"
DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"
VECTOR3_STAMPED = "geometry_msgs/msg/Vector3Stamped"
CLOCK = "rosgraph_msgs/msg/Clock"

# encoding -> (numpy dtype, channels); 16-bit data is little-endian unless is_bigendian is set.
_ENCODINGS: dict[str, tuple[str, int]] = {
    "mono8": ("u1", 1), "8UC1": ("u1", 1), "mono16": ("u2", 1), "16UC1": ("u2", 1), "32FC1": ("f4", 1),
    "bgr8": ("u1", 3), "rgb8": ("u1", 3), "8UC3": ("u1", 3),
}


@lru_cache(maxsize=1)
def typestore() -> Any:
    """The ROS 2 Jazzy type store (common_interfaces)."""
    return get_typestore(Stores.ROS2_JAZZY)


def stamp_to_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def header(stamp_ns: int, frame_id: str = "camera") -> Any:
    ts = typestore()
    if stamp_ns < 0:
        raise MessageError(f"header stamp must be >= 0 ns, got {stamp_ns}")
    Time = ts.types["builtin_interfaces/msg/Time"]
    return ts.types["std_msgs/msg/Header"](stamp=Time(sec=stamp_ns // 1_000_000_000,
                                                      nanosec=stamp_ns % 1_000_000_000), frame_id=frame_id)


def image_msg(frame: np.ndarray, stamp_ns: int, frame_id: str = "camera") -> Any:
    """uint8 (mono8), uint16 (mono16, little-endian) or HxWx3 uint8 (bgr8) array -> sensor_msgs/Image."""
    if frame.ndim == 2 and frame.dtype == np.uint8:
        encoding, bpp = "mono8", 1
    elif frame.ndim == 2 and frame.dtype == np.uint16:
        encoding, bpp = "mono16", 2
    elif frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8:
        encoding, bpp = "bgr8", 3
    else:
        raise MessageError(f"image frame must be HxW uint8/uint16 or HxWx3 uint8, got {frame.dtype} "
                           f"{frame.shape}")
    h, w = frame.shape[:2]
    data = np.ascontiguousarray(frame.astype(frame.dtype.newbyteorder("<"), copy=False)).view(np.uint8)
    return typestore().types[IMAGE](header=header(stamp_ns, frame_id), height=h, width=w, encoding=encoding,
                                    is_bigendian=0, step=w * bpp, data=data.reshape(-1))


def image_to_array(msg: Any) -> np.ndarray:
    """sensor_msgs/Image -> HxW (or HxWx3) array; honours `step` row padding and `is_bigendian`."""
    if msg.encoding not in _ENCODINGS:
        known = ", ".join(_ENCODINGS)
        raise MessageError(f"image encoding {msg.encoding!r} is not supported (known: {known})")
    kind, ch = _ENCODINGS[msg.encoding]
    dt = np.dtype(kind).newbyteorder(">" if msg.is_bigendian else "<")
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    row = w * ch * dt.itemsize
    data = np.asarray(msg.data, dtype=np.uint8)
    if step < row or data.size < step * h:
        raise MessageError(f"image {w}x{h} {msg.encoding}: step {step} (row needs {row}) and data size "
                           f"{data.size} (needs {step * h}) do not fit")
    rows = data[: step * h].reshape(h, step)[:, :row]
    arr = np.ascontiguousarray(rows).view(dt).reshape((h, w, ch) if ch > 1 else (h, w))
    out = arr.astype(dt.newbyteorder("="), copy=False)
    if msg.encoding == "rgb8":
        out = out[..., ::-1]
    return np.ascontiguousarray(out)


def camera_info_msg(width: int, height: int, k: list[float], stamp_ns: int, frame_id: str = "camera",
                    d: list[float] | None = None, distortion_model: str = "plumb_bob") -> Any:
    ts = typestore()
    if len(k) != 9:
        raise MessageError(f"camera matrix k needs 9 values, got {len(k)}")
    kk = np.asarray(k, np.float64)
    p = np.array([kk[0], kk[1], kk[2], 0.0, kk[3], kk[4], kk[5], 0.0, 0.0, 0.0, 1.0, 0.0])
    roi = ts.types[ROI](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    return ts.types[CAMERA_INFO](header=header(stamp_ns, frame_id), height=height, width=width,
                                 distortion_model=distortion_model,
                                 d=np.asarray(d if d is not None else [0.0] * 5, np.float64), k=kk,
                                 r=np.eye(3).reshape(-1), p=p, binning_x=0, binning_y=0, roi=roi)


def box_to_polygon(box: Box | None, stamp_ns: int, frame_id: str = "camera") -> Any:
    """Box -> PolygonStamped, corners TL, TR, BR, BL (x = column, y = row, z = 0); None -> empty polygon."""
    ts = typestore()
    P = ts.types["geometry_msgs/msg/Point32"]
    pts = [] if box is None else [P(x=float(x), y=float(y), z=0.0) for x, y in (
        (box.x, box.y), (box.x + box.w, box.y), (box.x + box.w, box.y + box.h), (box.x, box.y + box.h))]
    return ts.types[POLYGON_STAMPED](header=header(stamp_ns, frame_id),
                                     polygon=ts.types["geometry_msgs/msg/Polygon"](points=pts))


def polygon_to_box(msg: Any) -> Box | None:
    """PolygonStamped -> axis-aligned Box of its corners; an empty polygon (target absent) -> None."""
    pts = msg.polygon.points
    if not pts:
        return None
    xs = [float(p.x) for p in pts]
    ys = [float(p.y) for p in pts]
    box = Box(min(xs), min(ys), max(xs) - min(xs), max(ys) - min(ys))
    if not box.is_finite():
        raise MessageError(f"polygon has non-finite corners: {list(zip(xs, ys))}")
    return box


def roi_msg(box: Box) -> Any:
    """Box -> sensor_msgs/RegionOfInterest (rounded to whole pixels, clipped at 0)."""
    x, y = max(0, round(box.x)), max(0, round(box.y))
    return typestore().types[ROI](x_offset=x, y_offset=y, width=max(1, round(box.w)),
                                  height=max(1, round(box.h)), do_rectify=False)


def clock_msg(stamp_ns: int) -> Any:
    return typestore().types[CLOCK](clock=header(stamp_ns).stamp)


def serialize(msg: Any) -> bytes:
    return bytes(typestore().serialize_cdr(msg, msg.__msgtype__))


def deserialize(raw: bytes, msgtype: str) -> Any:
    return typestore().deserialize_cdr(raw, msgtype)
