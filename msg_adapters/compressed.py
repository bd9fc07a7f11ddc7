# SPDX-License-Identifier: Apache-2.0
"""sensor_msgs/CompressedImage <-> numpy: image_transport's `compressed` transport (JPEG and PNG).

image_transport's compressed publisher writes `format` as `<encoding>; <jpeg|png> compressed <target>`
(`mono8; jpeg compressed mono8`, `mono16; png compressed mono16`, `rgb8; jpeg compressed bgr8`); older
publishers and other tools write just `jpeg` or `png`. The data is a complete JPEG or PNG file: 8-bit
JPEG (grey or colour), 8- or 16-bit PNG (grey, colour, with or without alpha). `compressedDepth` (a PNG
behind a depth-quantisation header) is not an intensity image and is refused.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import cv2
import numpy as np

from msg_adapters.backend import RCLPY, Backend
from msg_adapters.errors import MessageError
from msg_adapters.image import Frame

if TYPE_CHECKING:
    from sensor_msgs.msg import CompressedImage
    from std_msgs.msg import Header

COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
CODECS = ("jpeg", "png")
_MAGIC = {"jpeg": b"\xff\xd8\xff", "png": b"\x89PNG\r\n\x1a\n"}


def codec_of(fmt: str) -> str:
    """`jpeg` or `png` from a CompressedImage.format; `MessageError` naming the format otherwise."""
    text = fmt.strip().lower()
    if "compresseddepth" in text.replace(" ", ""):
        raise MessageError(f"CompressedImage.format {fmt!r} is compressedDepth, not an intensity image")
    words = text.replace(";", " ").split()
    found = [c for c in CODECS if c in words or (c == "jpeg" and "jpg" in words)]
    if len(found) != 1:
        raise MessageError(f"CompressedImage.format {fmt!r} names neither jpeg nor png")
    return found[0]


def compressed_to_numpy(msg: CompressedImage) -> Frame:
    """Decode a CompressedImage into 2-D mono (uint8 / uint16) or HxWx3 BGR uint8 pixels.

    Raises `MessageError` for an unknown format, data that is not a complete file of that codec, or an
    image that decodes to something the tracker does not take (alpha is dropped, 16-bit colour becomes
    8-bit).
    """
    try:
        fmt = str(msg.format)
        data = np.frombuffer(msg.data, dtype=np.uint8) if len(msg.data) else np.zeros(0, np.uint8)
    except (AttributeError, TypeError, ValueError, BufferError) as exc:
        raise MessageError(f"CompressedImage fields are not readable ({exc})") from exc
    codec = codec_of(fmt)
    if data[:len(_MAGIC[codec])].tobytes() != _MAGIC[codec]:
        raise MessageError(f"CompressedImage.data ({data.size} bytes) does not start like a {codec} file")
    try:
        pixels = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:
        raise MessageError(f"CompressedImage {codec} data cannot be decoded ({exc})") from exc
    if pixels is None or pixels.size == 0:
        raise MessageError(f"CompressedImage.data ({data.size} bytes) is not a decodable {codec} image")
    if pixels.ndim == 3 and pixels.shape[2] == 4:
        pixels = cv2.cvtColor(pixels, cv2.COLOR_BGRA2BGR)
    if pixels.ndim == 3 and pixels.dtype != np.uint8:
        pixels = (pixels >> 8).astype(np.uint8)  # 16-bit colour: the tracker takes colour as 8-bit BGR
    if pixels.dtype not in (np.uint8, np.uint16) or pixels.ndim not in (2, 3):
        raise MessageError(f"CompressedImage decodes to {pixels.dtype} {pixels.shape}, not mono8/16 or bgr8")
    return Frame(np.ascontiguousarray(pixels), 16 if pixels.dtype == np.uint16 else 8)


def numpy_to_compressed(pixels: np.ndarray, header: Header, codec: str = "jpeg", quality: int = 80,
                        backend: Backend = RCLPY) -> CompressedImage:
    """Encode 2-D uint8 / uint16 (PNG only) or HxWx3 BGR uint8 pixels as image_transport would."""
    pixels = np.asarray(pixels)
    if codec not in CODECS:
        raise MessageError(f"codec {codec!r} is not one of {CODECS}")
    if pixels.ndim == 3 and pixels.shape[2] == 3 and pixels.dtype == np.uint8:
        encoding = "bgr8"
    elif pixels.ndim == 2 and pixels.dtype in (np.uint8, np.uint16):
        encoding = "mono8" if pixels.dtype == np.uint8 else "mono16"
    else:
        raise MessageError(f"array of shape {pixels.shape} and dtype {pixels.dtype} cannot be compressed")
    if codec == "jpeg" and encoding == "mono16":
        raise MessageError("JPEG holds 8-bit images; compress mono16 as png")
    params = ([cv2.IMWRITE_JPEG_QUALITY, int(quality)] if codec == "jpeg"
              else [cv2.IMWRITE_PNG_COMPRESSION, 3])
    ok, buf = cv2.imencode(".jpg" if codec == "jpeg" else ".png", pixels, params)
    if not ok:
        raise MessageError(f"OpenCV could not encode {encoding} as {codec}")
    return backend.cls(COMPRESSED_IMAGE)(header=header, format=f"{encoding}; {codec} compressed {encoding}",
                                         data=backend.u8(buf.reshape(-1)))
