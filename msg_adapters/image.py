# SPDX-License-Identifier: Apache-2.0
"""sensor_msgs/Image <-> numpy: mono/float/colour/Bayer/YUV422 decoding with row padding and byte order."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import cv2
import numpy as np

from msg_adapters.backend import IMAGE, RCLPY, Backend
from msg_adapters.errors import MessageError

if TYPE_CHECKING:
    from sensor_msgs.msg import Image
    from std_msgs.msg import Header


@dataclass(frozen=True)
class Layout:
    """How one encoding is stored: bytes per pixel, element type, channels and the conversion to BGR."""

    bytes_per_pixel: int
    dtype: str  # numpy element type, little-endian form
    channels: int
    to_bgr: int | None  # cv2 colour conversion code; None: keep as stored
    bit_depth: int


_MONO8 = Layout(1, "u1", 1, None, 8)
_MONO16 = Layout(2, "<u2", 1, None, 16)
_BAYER = {"rggb": cv2.COLOR_BayerBG2BGR, "bggr": cv2.COLOR_BayerRG2BGR,  # OpenCV names the pattern
          "gbrg": cv2.COLOR_BayerGR2BGR, "grbg": cv2.COLOR_BayerGB2BGR}  # one pixel diagonally on
_UYVY = Layout(2, "u1", 2, cv2.COLOR_YUV2BGR_UYVY, 8)
_YUYV = Layout(2, "u1", 2, cv2.COLOR_YUV2BGR_YUYV, 8)

LAYOUTS: dict[str, Layout] = {
    "mono8": _MONO8,
    "8uc1": _MONO8,
    "mono16": _MONO16,
    "16uc1": _MONO16,
    "32fc1": Layout(4, "<f4", 1, None, 32),
    "bgr8": Layout(3, "u1", 3, None, 8),
    "8uc3": Layout(3, "u1", 3, None, 8),
    "rgb8": Layout(3, "u1", 3, cv2.COLOR_RGB2BGR, 8),
    "bgra8": Layout(4, "u1", 4, cv2.COLOR_BGRA2BGR, 8),
    "rgba8": Layout(4, "u1", 4, cv2.COLOR_RGBA2BGR, 8),
    **{f"bayer_{p}8": Layout(1, "u1", 1, code, 8) for p, code in _BAYER.items()},
    "yuv422": _UYVY,  # ROS: yuv422 is UYVY byte order
    "uyvy": _UYVY,
    "yuv422_yuy2": _YUYV,
    "yuyv": _YUYV,
}
SUPPORTED_ENCODINGS = tuple(LAYOUTS)


class Frame(NamedTuple):
    """A decoded image: 2-D mono (uint8/uint16/float32) or HxWx3 BGR uint8, and its container bit depth."""

    pixels: np.ndarray
    bit_depth: int


def _fields(msg: Image) -> tuple[str, int, int, int, bool, np.ndarray]:
    try:
        encoding = str(msg.encoding)
        height, width, step = int(msg.height), int(msg.width), int(msg.step)
        big = bool(msg.is_bigendian)
        data = np.frombuffer(msg.data, dtype=np.uint8) if len(msg.data) else np.zeros(0, np.uint8)
    except (AttributeError, TypeError, ValueError, BufferError) as exc:
        raise MessageError(f"Image fields are not readable as an image ({exc})") from exc
    return encoding, height, width, step, big, data


def layout_of(encoding: str) -> Layout:
    """The storage layout of a ROS image encoding; `MessageError` naming it when unsupported."""
    layout = LAYOUTS.get(encoding.lower())
    if layout is None:
        raise MessageError(f"Image.encoding {encoding!r} is not supported; supported: {list(LAYOUTS)}")
    return layout


def image_to_numpy(msg: Image) -> Frame:
    """Decode an Image into a contiguous, native-endian array plus its bit depth.

    Honours `step` (row padding beyond width * bytes per pixel) and `is_bigendian` for 16-bit and float
    data. Colour, Bayer and YUV422 encodings become HxWx3 BGR uint8. Raises `MessageError` (naming the
    field and the numbers) for an unknown encoding, a zero size, `step < width * bytes_per_pixel`,
    `data` shorter than `step * height`, or an odd width in a YUV422 image.
    """
    encoding, height, width, step, big, data = _fields(msg)
    layout = layout_of(encoding)
    if height <= 0 or width <= 0:
        raise MessageError(f"Image.height x width must be positive, got {height}x{width}")
    row = width * layout.bytes_per_pixel
    if step < row:
        raise MessageError(f"Image.step {step} is less than width * bytes per pixel = {width} * "
                           f"{layout.bytes_per_pixel} = {row} for {encoding}")
    if data.size < step * height:
        raise MessageError(f"Image.data has {data.size} bytes, less than step * height = {step} * {height} "
                           f"= {step * height}")
    if layout.to_bgr in (cv2.COLOR_YUV2BGR_UYVY, cv2.COLOR_YUV2BGR_YUYV) and width % 2:
        raise MessageError(f"Image.width {width} must be even for {encoding} (two pixels share U and V)")
    if layout.to_bgr in _BAYER.values() and (width < 2 or height < 2):
        raise MessageError(f"Image.height x width {height}x{width} is too small to demosaic {encoding}")
    dtype = np.dtype(layout.dtype)
    if big and dtype.itemsize > 1:
        dtype = dtype.newbyteorder(">")
    esize = dtype.itemsize
    shape = (height, width) if layout.channels == 1 else (height, width, layout.channels)
    strides = (step, esize) if layout.channels == 1 else (step, layout.channels * esize, esize)
    # Zero-copy strided view over the padded rows, then one contiguous native-endian copy.
    view = np.ndarray(shape, dtype=dtype, buffer=data, offset=0, strides=strides)
    pixels = np.ascontiguousarray(view, dtype=dtype.newbyteorder("="))
    if layout.to_bgr is not None:
        try:
            pixels = cv2.cvtColor(pixels, layout.to_bgr)
        except cv2.error as exc:
            raise MessageError(f"Image {encoding} {height}x{width} cannot become BGR ({exc})") from exc
    elif np.may_share_memory(pixels, data):
        pixels = pixels.copy()  # never alias the message buffer
    return Frame(pixels, layout.bit_depth)


def numpy_to_image(pixels: np.ndarray, header: Header, encoding: str | None = None,
                   backend: Backend = RCLPY) -> Image:
    """Encode a 2-D uint8/uint16/float32 or HxWx3 BGR uint8 array as an Image (no row padding)."""
    pixels = np.asarray(pixels)
    what = f"array of shape {pixels.shape} and dtype {pixels.dtype}"
    if encoding is None:
        if pixels.ndim == 3 and pixels.shape[2] == 3 and pixels.dtype == np.uint8:
            encoding = "bgr8"
        elif pixels.ndim == 2:
            encoding = {np.dtype(np.uint8): "mono8", np.dtype(np.uint16): "mono16",
                        np.dtype(np.float32): "32FC1"}.get(pixels.dtype, "")
        if not encoding:
            raise MessageError(f"{what} has no Image encoding")
    layout = layout_of(encoding)
    if pixels.ndim not in (2, 3) or pixels.shape[0] == 0 or pixels.shape[1] == 0:
        raise MessageError(f"{what} is not a non-empty image")
    channels = 1 if pixels.ndim == 2 else pixels.shape[2]
    if channels != layout.channels or pixels.dtype.itemsize * channels != layout.bytes_per_pixel:
        raise MessageError(f"{what} does not match encoding {encoding}")
    height, width = pixels.shape[:2]
    data = np.ascontiguousarray(pixels, dtype=pixels.dtype.newbyteorder("="))
    return backend.cls(IMAGE)(header=header, height=height, width=width, encoding=encoding,
                              is_bigendian=int(sys.byteorder == "big"), step=width * layout.bytes_per_pixel,
                              data=backend.u8(data.view(np.uint8)))
