# SPDX-License-Identifier: Apache-2.0
"""One conversion per concept for both message families: rclpy's (nodes) and rosbags' (bag harness).

The same adapter call with `backend=RCLPY` and `backend=ROSBAGS` must give byte-identical CDR, readers
must read both, and the bag harness must work without any ROS package installed.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from conftest import REPO
from rclpy.serialization import deserialize_message, serialize_message

from msg_adapters import bag as mb
from msg_adapters.backend import (
    BOOL,
    CAMERA_INFO,
    CLOCK,
    IMAGE,
    POLYGON_STAMPED,
    RCLPY,
    ROI,
    ROSBAGS,
    VECTOR3_STAMPED,
    Backend,
)
from msg_adapters.camera_info import Intrinsics, camera_info_from_intrinsics, intrinsics_from_camera_info
from msg_adapters.errors import MessageError
from msg_adapters.geometry import box_from_polygon, box_from_roi, box_to_polygon, box_to_roi, pan_tilt_to_msg
from msg_adapters.ground_truth import occluded_from_msg, occluded_msg
from msg_adapters.image import image_to_numpy, numpy_to_image
from msg_adapters.stamps import clock_msg, header, msg_ns, ns_to_stamp, serialized_seconds
from swir_tracker_ros.types import Box

STAMP_NS = 1_700_000_123_456_789_012


def _header(backend: Backend):
    return header(ns_to_stamp(STAMP_NS, backend), "camera_optical_frame", backend)


def _build(kind: str, backend: Backend):
    hdr = _header(backend)
    rng = np.random.default_rng(3)
    intr = Intrinsics(800.0, 801.5, 319.5, 255.5, 640, 512)
    return {
        "mono8": lambda: numpy_to_image(rng.integers(0, 256, (5, 7), dtype=np.uint8), hdr, backend=backend),
        "mono16": lambda: numpy_to_image(rng.integers(0, 4096, (4, 6)).astype(np.uint16), hdr,
                                         backend=backend),
        "bgr8": lambda: numpy_to_image(rng.integers(0, 256, (3, 4, 3), dtype=np.uint8), hdr, backend=backend),
        "polygon": lambda: box_to_polygon(Box(1.5, 2.25, 30.0, 40.5), hdr, backend),
        "empty_polygon": lambda: box_to_polygon(None, hdr, backend),
        "roi": lambda: box_to_roi(Box(10.6, 5.4, 20.2, 8.3), 64, 48, backend),
        "camera_info": lambda: camera_info_from_intrinsics(intr, hdr, binning=(2, 2), roi_offset=(4, 6),
                                                           sensor_size=(1288, 1040), backend=backend),
        "pan_tilt": lambda: pan_tilt_to_msg(0.01, -0.02, hdr, backend),
        "clock": lambda: clock_msg(ns_to_stamp(STAMP_NS, backend), backend),
        "occluded": lambda: occluded_msg(True, backend),
    }[kind]()


TYPES = {"mono8": IMAGE, "mono16": IMAGE, "bgr8": IMAGE, "polygon": POLYGON_STAMPED,
         "empty_polygon": POLYGON_STAMPED, "roi": ROI, "camera_info": CAMERA_INFO,
         "pan_tilt": VECTOR3_STAMPED, "clock": CLOCK, "occluded": BOOL}


@pytest.mark.parametrize("kind", sorted(TYPES))
def test_both_backends_build_the_same_message(kind: str) -> None:
    """Field for field: rclpy's bytes decoded by rosbags re-serialize to rosbags' own bytes (rosbags writes
    zero CDR padding where rclpy leaves whatever was in the buffer, so the raw bytes are not compared)."""
    ours = mb.deserialize(serialize_message(_build(kind, RCLPY)), TYPES[kind])
    assert mb.serialize(ours) == mb.serialize(_build(kind, ROSBAGS))


@pytest.mark.parametrize("kind", ["mono16", "bgr8", "polygon", "camera_info"])
def test_readers_read_both_families_alike(kind: str) -> None:
    ours = _build(kind, RCLPY)
    theirs = mb.deserialize(serialize_message(ours), TYPES[kind])
    read = {"mono16": lambda m: image_to_numpy(m).pixels, "bgr8": lambda m: image_to_numpy(m).pixels,
            "polygon": box_from_polygon, "camera_info": intrinsics_from_camera_info}[kind]
    a, b = read(ours), read(theirs)
    if isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b)
    else:
        assert a == b
    assert msg_ns(ours) == msg_ns(theirs) == STAMP_NS


def test_serialized_stamp_is_read_without_decoding() -> None:
    raw = serialize_message(_build("mono16", RCLPY))
    assert serialized_seconds(raw) == pytest.approx(STAMP_NS * 1e-9, abs=1e-6)
    with pytest.raises(MessageError):
        serialized_seconds(b"\x00\x01")


BOXES = [Box(10.6, 5.4, 20.2, 8.3), Box(-3.2, -1.0, 12.0, 9.9), Box(60.5, 40.2, 9.0, 9.0),
         Box(0.0, 0.0, 64.0, 48.0), Box(3.0, 4.0, 0.4, 0.4)]


@pytest.mark.parametrize("box", BOXES)
def test_box_to_roi_covers_the_box_clipped_to_the_image_for_both_backends(box: Box) -> None:
    """The harness replay's /track/init goes through the same Box -> ROI as the demo supervisor's and the
    acquisition node's: outward to whole pixels, clipped to the image (it used to round and clip at 0 only,
    e.g. (10.6, 5.4, 20.2, 8.3) -> (11, 5, 20, 8), which cuts 0.6 px off the left of the target)."""
    w, h = 64, 48
    ours, theirs = box_to_roi(box, w, h, RCLPY), box_to_roi(box, w, h, ROSBAGS)
    fields = ("x_offset", "y_offset", "width", "height", "do_rectify")
    assert [getattr(ours, f) for f in fields] == [getattr(theirs, f) for f in fields]
    x0, y0 = min(max(box.x, 0.0), w), min(max(box.y, 0.0), h)
    x1, y1 = min(max(box.x + box.w, 0.0), w), min(max(box.y + box.h, 0.0), h)
    assert ours.x_offset == math.floor(x0) and ours.y_offset == math.floor(y0)
    assert ours.x_offset + ours.width == math.ceil(x1) and ours.y_offset + ours.height == math.ceil(y1)
    back = box_from_roi(deserialize_message(mb.serialize(theirs), type(ours)))
    assert back.x <= x0 and back.y <= y0 and back.x + back.w >= x1 and back.y + back.h >= y1


def test_occluded_flag_round_trip() -> None:
    for flag in (True, False):
        assert occluded_from_msg(mb.deserialize(mb.serialize(occluded_msg(flag, ROSBAGS)), BOOL)) is flag


def test_bag_harness_needs_no_ros_package(tmp_path) -> None:
    """bagio (and the OpenCV benchmark worker's interpreter, which has rosbags but no rclpy) uses the
    adapters: none of them may import a ROS package on the way."""
    code = f"""
import sys
for name in {sorted(['rclpy', 'builtin_interfaces', 'std_msgs', 'sensor_msgs', 'geometry_msgs',
                     'diagnostic_msgs', 'rosgraph_msgs', 'std_srvs', 'visualization_msgs'])!r}:
    sys.modules[name] = None  # any import of it raises ImportError
import numpy as np
from swir_tracker_ros.harness.bagio import FrameRecord, read_frames, write_bag
import swir_tracker_ros.harness.bench_worker  # noqa: F401
from swir_tracker_ros.types import Box
frames = [FrameRecord(10**9 + k, np.full((6, 8), k, np.uint16), Box(1, 2, 3, 4) if k else None, bool(k))
          for k in range(3)]
cam = {{"width": 8, "height": 6, "k": [10.0, 0.0, 4.0, 0.0, 10.0, 3.0, 0.0, 0.0, 1.0]}}
assert write_bag(sys.argv[1], frames, camera_info=cam) == 3
back = list(read_frames(sys.argv[1]))
assert [f.gt for f in back] == [None, Box(1, 2, 3, 4), Box(1, 2, 3, 4)], back
assert [f.occluded for f in back] == [False, True, True]
assert all(np.array_equal(a.image, b.image) for a, b in zip(frames, back))
print("ok")
"""
    out = subprocess.run([sys.executable, "-c", code, str(tmp_path / "bag")], capture_output=True, text=True,
                         cwd=REPO, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr
