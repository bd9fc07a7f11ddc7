# SPDX-License-Identifier: Apache-2.0
"""Bag IO: bit-exact round trips (8/16 bit, sqlite3/mcap, zstd), image padding, corrupt and truncated bags."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from msg_adapters import bag as mb
from msg_adapters.backend import IMAGE, POLYGON_STAMPED, ROSBAGS
from msg_adapters.errors import MessageError
from msg_adapters.geometry import box_from_polygon, box_to_polygon
from msg_adapters.image import image_to_numpy
from msg_adapters.stamps import header, msg_ns, ns_to_stamp
from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness import cli
from swir_tracker_ros.harness.bagio import FrameRecord, bag_info, read_frames, write_bag
from swir_tracker_ros.types import Box


def frames(dtype, n: int = 6, shape=(48, 64)) -> list[FrameRecord]:
    rng = np.random.default_rng(7)
    top = np.iinfo(dtype).max
    out = []
    for k in range(n):
        img = rng.integers(0, top + 1, size=shape, dtype=np.int64).astype(dtype)
        img[0, 0], img[-1, -1] = 0, top  # extremes survive
        gt = None if k == 3 else Box(10.25 + k, 5.5, 20.0, 30.75)  # float32-exact values
        out.append(FrameRecord(1_000_000_000 + k * 40_000_000, img, gt, occluded=k in (2, 3)))
    return out


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("compress", [None, "zstd"])
def test_round_trip_bit_exact(tmp_path, storage, dtype, compress):
    src = frames(dtype)
    bag = tmp_path / "bag"
    assert write_bag(bag, src, storage=storage, compress=compress,
                     camera_info={"width": 64, "height": 48, "k": [100, 0, 32, 0, 100, 24, 0, 0, 1]}) == 6
    back = list(read_frames(bag))
    assert len(back) == len(src)
    for a, b in zip(src, back):
        assert b.image.dtype == dtype
        np.testing.assert_array_equal(a.image, b.image)
        assert b.gt == a.gt and b.occluded == a.occluded and b.stamp_ns == a.stamp_ns
    single = next(p for p in bag.iterdir() if p.suffix in (".db3", ".mcap"))
    if compress is None:  # a bare storage file opens too
        np.testing.assert_array_equal(next(iter(read_frames(single))).image, src[0].image)
    info = bag_info(bag)
    assert info.storage == storage and info.version == 9
    assert {t.topic: (t.declared, t.read) for t in info.topics}["/camera/image_raw"] == (6, 6)
    assert info.duration_s == pytest.approx(0.2)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_metadata_version_8(tmp_path, storage):
    bag = tmp_path / "v8"
    write_bag(bag, frames(np.uint8, n=3), storage=storage, version=8)
    assert bag_info(bag).version == 8
    np.testing.assert_array_equal(list(read_frames(bag))[2].image, frames(np.uint8, n=3)[2].image)


def test_image_adapter_honours_step_padding_and_endianness():
    # the nodes' image adapter reads rosbags' messages (numpy data) as it reads rclpy's
    image = ROSBAGS.cls(IMAGE)
    hdr = header(ns_to_stamp(0, ROSBAGS), "", ROSBAGS)
    img = np.arange(15, dtype=np.uint8).reshape(3, 5)
    padded = np.zeros((3, 8), np.uint8)
    padded[:, :5] = img
    msg = image(header=hdr, height=3, width=5, encoding="mono8", is_bigendian=0, step=8,
                data=padded.reshape(-1))
    np.testing.assert_array_equal(image_to_numpy(msg).pixels, img)
    big = np.array([[1, 4095]], dtype=">u2")
    msg = image(header=hdr, height=1, width=2, encoding="mono16", is_bigendian=1, step=4,
                data=big.view(np.uint8).reshape(-1))
    np.testing.assert_array_equal(image_to_numpy(msg).pixels, [[1, 4095]])
    msg = image(header=hdr, height=3, width=5, encoding="mono8", is_bigendian=0, step=4,
                data=padded.reshape(-1))
    with pytest.raises(MessageError, match="step 4"):
        image_to_numpy(msg)


def test_polygon_corners_and_empty_polygon():
    hdr = header(ns_to_stamp(5, ROSBAGS), "camera", ROSBAGS)
    msg = mb.deserialize(mb.serialize(box_to_polygon(Box(1, 2, 3, 4), hdr, ROSBAGS)), POLYGON_STAMPED)
    assert [(p.x, p.y) for p in msg.polygon.points] == [(1, 2), (4, 2), (4, 6), (1, 6)]  # TL TR BR BL
    assert box_from_polygon(msg) == Box(1, 2, 3, 4) and msg_ns(msg) == 5
    assert box_from_polygon(box_to_polygon(None, hdr, ROSBAGS)) is None


def make(tmp_path: Path, storage: str, n: int = 40) -> Path:
    bag = tmp_path / f"good_{storage}"
    write_bag(bag, frames(np.uint16, n=n, shape=(120, 160)), storage=storage)
    return bag


def test_truncated_mcap_names_file_and_last_good_message(tmp_path, capsys):
    bag = make(tmp_path, "mcap")
    f = next(bag.glob("*.mcap"))
    os.truncate(f, f.stat().st_size * 6 // 10)
    with pytest.raises(HarnessError) as e:
        list(read_frames(bag))
    text = str(e.value)
    assert str(f) in text and "last good message: #" in text and " on /" in text
    assert cli.main(["info", str(bag)]) == 2  # an error line, not a traceback
    err = capsys.readouterr().err
    assert err.startswith("harness: error:") and "Traceback" not in err


def test_truncated_sqlite_names_file(tmp_path):
    bag = make(tmp_path, "sqlite3")
    f = next(bag.glob("*.db3"))
    os.truncate(f, f.stat().st_size // 2)
    with pytest.raises(HarnessError) as e:
        list(read_frames(bag))
    assert str(f) in str(e.value) and "last good message" in str(e.value)


def test_flipped_bytes_in_a_real_mcap_are_caught(tmp_path, shared_dir):
    bag = tmp_path / "talker"
    shutil.copytree(shared_dir / "data/rosbag2_fixtures/mcap/talker", bag)
    f = bag / "talker.mcap"
    f.chmod(0o644)
    data = bytearray(f.read_bytes())
    for i in range(len(data) // 3, len(data) // 3 + 200, 7):
        data[i] ^= 0xFF
    f.write_bytes(bytes(data))
    with pytest.raises(HarnessError) as e:
        bag_info(bag)
    assert str(f) in str(e.value) and "last good message" in str(e.value)


def test_corrupt_image_record_in_sqlite_names_last_good_image(tmp_path):
    bag = make(tmp_path, "sqlite3", n=8)
    f = next(bag.glob("*.db3"))
    data = bytearray(f.read_bytes())
    hits = [i for i in range(len(data)) if data[i:i + 6] == b"mono16"]
    pos = sorted(hits)[len(hits) // 2]  # an image in the middle of the file
    data[pos - 4:pos] = (0x7FFFFFF0).to_bytes(4, "little")  # absurd CDR string length
    f.write_bytes(bytes(data))
    with pytest.raises(HarnessError) as e:
        list(read_frames(bag))
    assert "cannot decode sensor_msgs/msg/Image" in str(e.value) and "last good image: #" in str(e.value)


def test_fewer_messages_than_declared_is_an_error(tmp_path):
    bag = make(tmp_path, "sqlite3", n=5)
    meta = bag / "metadata.yaml"
    text = meta.read_text()
    # Claim 7 images where there are 5 (as a bag cut by a crash before its final flush would).
    meta.write_text(text.replace("message_count: 5\n    topic_metadata:\n      name: /camera/image_raw",
                                 "message_count: 7\n    topic_metadata:\n      name: /camera/image_raw"))
    assert "message_count: 7" in meta.read_text()
    with pytest.raises(HarnessError, match="7 images declared but only 5 read"):
        list(read_frames(bag))
    assert any("declared but 5 read" in n for n in bag_info(bag).notes)


def test_missing_bag_and_no_image_topic(tmp_path, shared_dir):
    with pytest.raises(HarnessError, match="no such bag"):
        read_frames(tmp_path / "nope").__next__()
    with pytest.raises(HarnessError, match="no sensor_msgs/msg/Image topic"):
        next(read_frames(shared_dir / "data/rosbag2_fixtures/sqlite3/talker"))
