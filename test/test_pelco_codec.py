# SPDX-License-Identifier: Apache-2.0
"""Pelco-D codec: the byte-exact reference vectors, encoder guards, and the streaming decoder."""

from __future__ import annotations

import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swir_tracker_ros.errors import PelcoError
from swir_tracker_ros.pelco import codec

# Each row meaning of shared/reference/pelco_d_vectors.md -> the encoder calls that must produce its frames.
ENCODERS = {
    "right, pan speed 0x20": [lambda: codec.right(1, 0x20)],
    "left, pan speed 0x23": [lambda: codec.left(1, 0x23)],
    "up, tilt speed 0x23": [lambda: codec.up(1, 0x23)],
    "down, tilt speed 0x23": [lambda: codec.down(1, 0x23)],
    "iris open / close": [lambda: codec.lens(1, iris=1), lambda: codec.lens(1, iris=-1)],
    "focus near / far": [lambda: codec.lens(1, focus=-1), lambda: codec.lens(1, focus=1)],
    "stop": [lambda: codec.stop(1)],
    "zoom tele / wide": [lambda: codec.lens(1, zoom=1), lambda: codec.lens(1, zoom=-1)],
    "up-right, 0x3F / 0x3F": [lambda: codec.pan_tilt(1, 1, 0x3F, 1, 0x3F)],
    "right, pan turbo": [lambda: codec.right(1, codec.TURBO)],
    "up-left, pan 0x20 tilt 0x0A": [lambda: codec.pan_tilt(1, -1, 0x20, 1, 0x0A)],
    "up-right, pan 0x20 tilt 0x0A": [lambda: codec.pan_tilt(1, 1, 0x20, 1, 0x0A)],
    "down-left, pan 0x20 tilt 0x0A": [lambda: codec.pan_tilt(1, -1, 0x20, -1, 0x0A)],
    "down-right, pan 0x20 tilt 0x0A": [lambda: codec.pan_tilt(1, 1, 0x20, -1, 0x0A)],
    "set / clear / go to preset 1": [lambda: codec.set_preset(1, 1), lambda: codec.clear_preset(1, 1),
                                     lambda: codec.goto_preset(1, 1)],
    "query pan / tilt / zoom": [lambda: codec.query(1, "pan"), lambda: codec.query(1, "tilt"),
                                lambda: codec.query(1, "zoom")],
    "set pan 90.00 deg (9000 = 0x2328)": [lambda: codec.set_pan_position(1, 9000)],
    "set pan 359.99 deg": [lambda: codec.set_pan_position(1, 35999)],
    "set tilt 0": [lambda: codec.set_tilt_position(1, 0)],
    "pan position reply 123.45 deg": [lambda: codec.position_reply(1, "pan", 12345)],
    "stop, address 255": [lambda: codec.stop(255)],
    "left, pan speed 0x20, address 2": [lambda: codec.left(2, 0x20)],
    "stop, address 2": [lambda: codec.stop(2)],
    "clear preset 15, address 12": [lambda: codec.clear_preset(12, 15)],
    "go to preset 255, address 255": [lambda: codec.goto_preset(255, 255)],
    "camera on / off (with sense bit)": [lambda: codec.camera(1, True), lambda: codec.camera(1, False)],
}


def reference_rows(shared_dir) -> list[tuple[str, list[bytes]]]:
    text = (shared_dir / "reference" / "pelco_d_vectors.md").read_text()
    rows = []
    row = r"^\| ([^|]+?) \| ((?:[0-9A-F]{2} ?)+(?:/ (?:[0-9A-F]{2} ?)+)*)\|$"
    for meaning, frames in re.findall(row, text, flags=re.M):
        rows.append((meaning, [bytes.fromhex(f) for f in frames.split("/")]))
    return rows


def test_reference_vectors_byte_exact(shared_dir) -> None:
    rows = reference_rows(shared_dir)
    assert len(rows) == 26, "the reference table changed: update ENCODERS"
    for meaning, frames in rows:
        assert meaning in ENCODERS, f"no encoder mapped for reference row {meaning!r}"
        got = [enc() for enc in ENCODERS[meaning]]
        assert got == frames, f"{meaning}: {[g.hex(' ') for g in got]} != {[f.hex(' ') for f in frames]}"
        for f in frames:
            assert codec.decode(f).to_bytes() == f


def test_checksum_is_mod_256_not_mod_100() -> None:
    # 0x01 + 0x0A + 0x3F + 0x3F = 137: mod 256 gives 0x89, the mod-100 bug would give 37.
    assert codec.checksum(0x01, 0x00, 0x0A, 0x3F, 0x3F) == 0x89
    assert codec.decode(bytes.fromhex("FF 01 00 59 30 39 C3")).word == 12345


@pytest.mark.parametrize("call", [
    lambda: codec.set_preset(1, 0),  # preset 0 is invalid on most heads
    lambda: codec.right(1, 0x40),
    lambda: codec.up(1, codec.TURBO),  # the spec has pan turbo only
    lambda: codec.stop(0),
    lambda: codec.set_pan_position(1, 36000),
    lambda: codec.pan_tilt(1, 2, 1, 0, 0),
    lambda: codec.query(1, "iris"),
    lambda: codec.aux(1, 9, True),
    lambda: codec.decode(bytes.fromhex("FF 01 00 02 20 00 24")),
    lambda: codec.decode(b"\xff\x01\x00"),
])
def test_encoder_and_decoder_reject_invalid_input(call) -> None:
    with pytest.raises(PelcoError):
        call()


def test_goto_and_clear_preset_are_not_swapped() -> None:
    assert codec.clear_preset(1, 3)[3] == 0x05
    assert codec.goto_preset(1, 3)[3] == 0x07


def test_motion_reports_pelco_directions() -> None:
    assert codec.decode(codec.pan_tilt(1, -1, 0x20, 1, 0x0A)).motion() == (-1, 0x20, 1, 0x0A)
    assert codec.decode(codec.stop(1)).motion() == (0, 0, 0, 0)
    assert codec.decode(codec.query(1, "pan")).motion() is None


def test_stream_resyncs_after_garbage_and_split_reads() -> None:
    frames = [codec.right(1, 0x20), codec.stop(255), codec.right(1, codec.TURBO), codec.query(1, "tilt")]
    stream = b"\x00\x13\xff\x00garbage" + frames[0] + b"\x01\x02" + b"".join(frames[1:])
    dec = codec.StreamDecoder()
    got = []
    for i in range(len(stream)):  # one byte at a time
        got += dec.feed(stream[i:i + 1])
    assert [f.to_bytes() for f in got] == frames
    assert dec.checksum_errors == 0
    assert dec.discarded > 0


def test_bad_checksum_is_counted_and_the_next_frame_survives() -> None:
    bad = bytearray(codec.left(1, 0x23))
    bad[4] ^= 0x04
    dec = codec.StreamDecoder()
    out = dec.feed(bytes(bad) + codec.stop(1))
    assert [f.to_bytes() for f in out] == [codec.stop(1)]
    assert dec.checksum_errors == 1


@settings(max_examples=300, deadline=None)
@given(st.lists(st.binary(max_size=40), max_size=20))
def test_random_streams_never_raise_and_yield_only_valid_frames(chunks) -> None:
    dec = codec.StreamDecoder()
    for chunk in chunks:
        for frame in dec.feed(chunk):
            raw = frame.to_bytes()
            assert codec.decode(raw) == frame
    assert len(dec._buf) < codec.FRAME_LEN


frame_st = st.builds(lambda a, c1, c2, d1, d2: codec.Frame(a, c1, c2, d1, d2).to_bytes(),
                     st.integers(1, 255), st.integers(0, 255), st.integers(0, 255), st.integers(0, 255),
                     st.integers(0, 255))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.binary(max_size=12).map(lambda b: b.replace(b"\xff", b"")), frame_st),
                max_size=10))
def test_frames_between_sync_free_garbage_are_all_recovered(parts) -> None:
    # Garbage without 0xFF cannot start a candidate, so every frame after it must come out intact.
    dec = codec.StreamDecoder()
    stream = b"".join(g + f for g, f in parts)
    got = [f.to_bytes() for f in dec.feed(stream)]
    assert got == [f for _, f in parts]
