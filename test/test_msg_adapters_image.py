# SPDX-License-Identifier: Apache-2.0
"""sensor_msgs/Image decoding: every encoding, row padding, byte order, typed errors, fuzzing."""

from __future__ import annotations

import array

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from sensor_msgs.msg import Image

from msg_adapters.errors import MessageError
from msg_adapters.image import SUPPORTED_ENCODINGS, image_to_numpy, numpy_to_image
from msg_adapters.stamps import header

RNG = np.random.default_rng(7)


def raw_image(buf: bytes, encoding: str, height: int, width: int, step: int, big: bool = False) -> Image:
    return Image(height=height, width=width, encoding=encoding, is_bigendian=int(big), step=step,
                 data=array.array("B", buf))


def padded(rows: np.ndarray, pad: int) -> tuple[bytes, int]:
    """Raw bytes of a (H, row_bytes) uint8 array with `pad` junk bytes after each row, and the step."""
    junk = np.full((rows.shape[0], pad), 0xAB, np.uint8)
    out = np.hstack([rows, junk])
    return out.tobytes(), out.shape[1]


@pytest.mark.parametrize("pad", [0, 5])
@pytest.mark.parametrize(("encoding", "dtype", "depth"), [
    ("mono8", np.uint8, 8), ("8UC1", np.uint8, 8), ("mono16", np.uint16, 16), ("16UC1", np.uint16, 16),
    ("32FC1", np.float32, 32)])
@pytest.mark.parametrize("big", [False, True])
def test_mono_with_padding_and_byte_order(encoding: str, dtype, depth: int, pad: int, big: bool) -> None:
    ref = (RNG.random((7, 9)) * 1000).astype(dtype)
    stored = ref.astype(ref.dtype.newbyteorder(">" if big else "<"))
    buf, step = padded(stored.view(np.uint8).reshape(7, -1), pad)
    frame = image_to_numpy(raw_image(buf, encoding, 7, 9, step, big))
    assert frame.bit_depth == depth
    assert frame.pixels.dtype == np.dtype(dtype) and frame.pixels.dtype.isnative
    np.testing.assert_array_equal(frame.pixels, ref)
    assert frame.pixels.flags["C_CONTIGUOUS"] and frame.pixels.flags["OWNDATA"]


@pytest.mark.parametrize(("encoding", "order"), [
    ("bgr8", [0, 1, 2]), ("rgb8", [2, 1, 0]), ("bgra8", [0, 1, 2, None]), ("rgba8", [2, 1, 0, None])])
def test_colour_encodings_become_bgr(encoding: str, order: list[int | None]) -> None:
    bgr = RNG.integers(0, 256, (5, 6, 3), dtype=np.uint8)
    stored = np.stack([bgr[..., c] if c is not None else np.full((5, 6), 255, np.uint8) for c in order], -1)
    buf, step = padded(stored.reshape(5, -1), 3)
    frame = image_to_numpy(raw_image(buf, encoding, 5, 6, step))
    assert frame.bit_depth == 8
    np.testing.assert_array_equal(frame.pixels, bgr)


@pytest.mark.parametrize(("pattern", "red_at"), [
    ("rggb", (0, 0)), ("bggr", (1, 1)), ("gbrg", (1, 0)), ("grbg", (0, 1))])
def test_bayer_demosaics_to_the_right_colour(pattern: str, red_at: tuple[int, int]) -> None:
    # A pure red scene: only the red sites of the mosaic are lit.
    mosaic = np.zeros((8, 8), np.uint8)
    mosaic[red_at[0]::2, red_at[1]::2] = 200
    frame = image_to_numpy(raw_image(mosaic.tobytes(), f"bayer_{pattern}8", 8, 8, 8))
    centre = frame.pixels[2:6, 2:6].reshape(-1, 3).mean(axis=0)
    assert frame.pixels.shape == (8, 8, 3)
    assert centre[2] > 150 and centre[0] < 30 and centre[1] < 30  # BGR: red channel lit


@pytest.mark.parametrize("encoding", ["yuv422", "uyvy", "yuyv", "yuv422_yuy2"])
def test_yuv422_grey_levels(encoding: str) -> None:
    # Grey (U = V = 128): every pixel decodes to its own Y in all three channels (byte order checked).
    y = RNG.integers(16, 236, (4, 6), dtype=np.uint8)
    chroma = np.full((4, 6), 128, np.uint8)
    uyvy = encoding in ("yuv422", "uyvy")
    stored = np.stack([chroma, y] if uyvy else [y, chroma], -1)
    buf, step = padded(stored.reshape(4, -1), 4)
    frame = image_to_numpy(raw_image(buf, encoding, 4, 6, step))
    assert frame.pixels.shape == (4, 6, 3)
    expected = np.clip((y.astype(float) - 16) * 255 / 219, 0, 255)
    assert np.abs(frame.pixels[..., 1].astype(float) - expected).max() <= 3
    assert np.abs(frame.pixels[..., 0].astype(int) - frame.pixels[..., 2]).max() <= 2


@pytest.mark.parametrize(("kwargs", "fragment"), [
    ({"encoding": "mono12"}, "Image.encoding 'mono12' is not supported"),
    ({"height": 0}, "must be positive, got 0x4"),
    ({"width": 0}, "must be positive, got 4x0"),
    ({"step": 7}, "Image.step 7 is less than width * bytes per pixel = 4 * 2 = 8"),
    ({"data": bytes(31)}, "Image.data has 31 bytes, less than step * height = 8 * 4 = 32"),
])
def test_malformed_images_raise_message_error(kwargs: dict, fragment: str) -> None:
    fields = {"encoding": "mono16", "height": 4, "width": 4, "step": 8, "data": bytes(32)}
    fields.update(kwargs)
    msg = raw_image(fields["data"], fields["encoding"], fields["height"], fields["width"], fields["step"])
    with pytest.raises(MessageError) as info:
        image_to_numpy(msg)
    assert fragment in str(info.value)


def test_odd_width_yuv_is_rejected() -> None:
    with pytest.raises(MessageError, match="must be even"):
        image_to_numpy(raw_image(bytes(30), "uyvy", 3, 5, 10))


@pytest.mark.parametrize(("pixels", "encoding"), [
    (np.arange(12, dtype=np.uint8).reshape(3, 4), "mono8"),
    (np.arange(12, dtype=np.uint16).reshape(3, 4) * 4000, "mono16"),
    (np.linspace(0, 1, 12, dtype=np.float32).reshape(3, 4), "32FC1"),
    (np.arange(36, dtype=np.uint8).reshape(3, 4, 3), "bgr8"),
])
def test_numpy_to_image_round_trip(pixels: np.ndarray, encoding: str) -> None:
    msg = numpy_to_image(pixels, header(5.0, "cam"))
    assert msg.encoding == encoding and msg.header.frame_id == "cam"
    np.testing.assert_array_equal(image_to_numpy(msg).pixels, pixels)
    with pytest.raises(MessageError):
        numpy_to_image(np.zeros((3, 4), np.int64), header(0.0))


ENCODINGS = st.sampled_from([*SUPPORTED_ENCODINGS, "MONO16", "mono12", "", "bgr16", "8UC3", "\x00"])


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(encoding=ENCODINGS, height=st.integers(0, 12), width=st.integers(0, 12), step=st.integers(0, 60),
       big=st.integers(0, 255), data=st.binary(max_size=700))
def test_fuzzed_images_only_raise_message_error(encoding: str, height: int, width: int, step: int,
                                                big: int, data: bytes) -> None:
    msg = Image(height=height, width=width, encoding=encoding, is_bigendian=big, step=step,
                data=array.array("B", data))
    try:
        frame = image_to_numpy(msg)
    except MessageError as exc:
        assert str(exc)
        return
    assert frame.pixels.shape[:2] == (height, width)
    assert frame.pixels.ndim == 2 or frame.pixels.shape[2] == 3
