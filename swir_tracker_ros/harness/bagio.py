# SPDX-License-Identifier: Apache-2.0
"""rosbag2 reading and writing with `rosbags`: sqlite3 and mcap, directories or single files, zstd."""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

from msg_adapters import bag as mb
from msg_adapters.backend import ROSBAGS
from msg_adapters.camera_info import camera_info_from_intrinsics, intrinsics_from_matrix
from msg_adapters.errors import MessageError
from msg_adapters.geometry import box_from_polygon, box_to_polygon
from msg_adapters.ground_truth import occluded_from_msg, occluded_msg
from msg_adapters.image import image_to_numpy, numpy_to_image
from msg_adapters.stamps import header, msg_ns, ns_to_stamp
from swir_tracker_ros import topics
from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.bagreader import BagReader
from swir_tracker_ros.types import Box

# The topics of a harness bag; /ground_truth/occluded (std_msgs/Bool per frame) only for synthetic scenarios.
# A bag holds fully qualified names: a head's relative names in the root namespace (topics.absolute).
IMAGE_TOPIC, INFO_TOPIC = topics.absolute(topics.IMAGE), topics.absolute(topics.CAMERA_INFO)
GT_TOPIC = topics.absolute(topics.GROUND_TRUTH_BOX)
OCCLUDED_TOPIC = topics.absolute(topics.GROUND_TRUTH_OCCLUDED)


@dataclass(frozen=True)
class FrameRecord:
    """One frame to write or one frame read back: image, ground truth (None = absent), occlusion flag."""

    stamp_ns: int
    image: np.ndarray
    gt: Box | None
    occluded: bool | None = None
    index: int = 0


@dataclass(frozen=True)
class TopicCount:
    topic: str
    msgtype: str
    declared: int | None  # from metadata.yaml / storage statistics; None when the storage gives none
    read: int


@dataclass
class BagInfo:
    path: Path
    storage: str
    files: list[str]
    version: int | None
    compression: str | None
    start_ns: int
    end_ns: int
    topics: list[TopicCount]
    read_mode: str  # "directory" or "storage files"
    custom: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def duration_s(self) -> float:
        return max(0, self.end_ns - self.start_ns) / 1e9

    def count(self, topic: str) -> int:
        return next((t.read for t in self.topics if t.topic == topic), 0)


def write_bag(out: Path, frames: Iterable[FrameRecord], *, storage: str = "sqlite3",
              compress: str | None = None, camera_info: dict[str, Any] | None = None,
              custom: dict[str, str] | None = None, frame_id: str = "camera", version: int = 9) -> int:
    """Write frames to a new rosbag2 directory `out` (version 9); returns the number of frames written.

    Topics: /camera/image_raw (mono8/mono16), /camera/camera_info (if given: width, height, k, d),
    /ground_truth/box (PolygonStamped, empty = absent) and /ground_truth/occluded (Bool, when known).
    Messages are logged at their header stamps. `version`: rosbag2 metadata version, 8 or 9.
    """
    out = Path(out)
    plugin = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}.get(storage)
    if plugin is None:
        raise HarnessError(f"{out}: storage must be sqlite3 or mcap, got {storage!r}")
    if out.exists():
        raise HarnessError(f"{out} exists already; rosbag2 writers never overwrite a bag")
    ts = mb.typestore()
    n = 0
    try:
        with _open_writer(out, plugin, compress, version) as w:
            for key, value in (custom or {}).items():
                w.set_custom_data(key, value)
            img_c = w.add_connection(IMAGE_TOPIC, topics.TYPES[IMAGE_TOPIC], typestore=ts)
            gt_c = w.add_connection(GT_TOPIC, topics.TYPES[GT_TOPIC], typestore=ts)
            info_c = (w.add_connection(INFO_TOPIC, topics.TYPES[INFO_TOPIC], typestore=ts) if camera_info
                      else None)
            intr = d = None
            if camera_info:
                ci = camera_info
                intr = intrinsics_from_matrix(list(ci["k"]), int(ci["width"]), int(ci["height"]))
                d = ci.get("d") or (0.0,) * 5
            occ_c = None
            for fr in frames:
                t = fr.stamp_ns
                hdr = header(ns_to_stamp(t, ROSBAGS), frame_id, ROSBAGS)
                w.write(img_c, t, mb.serialize(numpy_to_image(fr.image, hdr, backend=ROSBAGS)))
                if info_c is not None:
                    info = camera_info_from_intrinsics(intr, hdr, d=d, backend=ROSBAGS)
                    w.write(info_c, t, mb.serialize(info))
                w.write(gt_c, t, mb.serialize(box_to_polygon(fr.gt, hdr, ROSBAGS)))
                if fr.occluded is not None:
                    if occ_c is None:
                        occ_c = w.add_connection(OCCLUDED_TOPIC, topics.TYPES[OCCLUDED_TOPIC], typestore=ts)
                    w.write(occ_c, t, mb.serialize(occluded_msg(fr.occluded, ROSBAGS)))
                n += 1
    except MessageError as exc:
        raise HarnessError(f"{out}: frame {n} cannot be written: {exc}") from None
    return n


def _open_writer(out: Path, plugin: StoragePlugin, compress: str | None, version: int) -> Writer:
    if version not in (8, 9):
        raise HarnessError(f"{out}: rosbags writes metadata version 8 or 9, not {version}")
    w = Writer(out, version=version, storage_plugin=plugin)
    if compress:
        if compress != "zstd":
            raise HarnessError(f"{out}: only zstd compression is supported, got {compress!r}")
        mode = CompressionMode.STORAGE if plugin == StoragePlugin.MCAP else CompressionMode.MESSAGE
        w.set_compression(mode, CompressionFormat.ZSTD)
    return w


def bag_info(path: Path | str) -> BagInfo:
    """Storage, duration, topics with types and message counts as declared and as actually read."""
    br = BagReader(path)
    read: dict[str, int] = {}
    types = br.topics()
    t0, t1 = None, None
    for topic, msgtype, t, _ in br.messages():
        read[topic] = read.get(topic, 0) + 1
        types.setdefault(topic, msgtype)
        t0 = t if t0 is None else min(t0, t)
        t1 = t if t1 is None else max(t1, t)
    declared = br.declared()
    topics = [TopicCount(tp, types[tp], declared.get(tp), read.get(tp, 0)) for tp in sorted(types)]
    notes = list(br.notes)
    for tc in topics:
        if tc.declared is not None and tc.declared != tc.read:
            notes.append(f"{tc.topic}: {tc.declared} messages declared but {tc.read} read")
    return BagInfo(br.path, br.storage, [str(f) for f in br.files], br.version, br.compression,
                   t0 if t0 is not None else 0, t1 if t1 is not None else 0, topics, br.read_mode,
                   br.custom, notes)


def pick_topic(br: BagReader, wanted: str | None, default: str, msgtype: str) -> str | None:
    """The flag's topic, else the default name, else the only topic of that type (None if there is none)."""
    topics = br.topics()
    if wanted:
        if wanted not in topics:
            raise HarnessError(f"{br.path}: topic {wanted} not in the bag (topics: {', '.join(topics)})")
        return wanted
    if topics.get(default) == msgtype:
        return default
    typed = [t for t, m in topics.items() if m == msgtype]
    return typed[0] if len(typed) == 1 else None


def read_frames(path: Path | str, image_topic: str | None = None, gt_topic: str | None = None
                ) -> Iterator[FrameRecord]:
    """Stream frames with their ground truth (matched by header stamp) from a bag.

    Topics are taken from the flags, else /camera/image_raw and /ground_truth/box, else discovered by type.
    Raises HarnessError when the bag has no image topic, is corrupt, or yields fewer images than declared.
    """
    br = BagReader(path)
    img_t = pick_topic(br, image_topic, IMAGE_TOPIC, topics.TYPES[IMAGE_TOPIC])
    if img_t is None:
        raise HarnessError(f"{br.path}: no sensor_msgs/msg/Image topic (topics: {', '.join(br.topics())})")
    box_t = pick_topic(br, gt_topic, GT_TOPIC, topics.TYPES[GT_TOPIC])
    gts: dict[int, Box | None] = {}
    occ: dict[int, bool] = {}
    side = {t for t in (box_t, OCCLUDED_TOPIC) if t}
    for topic, msgtype, t, raw in br.messages(side):
        msg = br.deserialize(raw, msgtype, f"{topic} at {t} ns")
        try:
            if topic == box_t:
                gts[msg_ns(msg)] = box_from_polygon(msg)
            else:
                occ[t] = occluded_from_msg(msg)
        except MessageError as exc:
            raise HarnessError(f"{br.path}: {topic} at {t} ns: {exc}") from None
    k, last = 0, "none"
    for _topic, msgtype, t, raw in br.messages({img_t}):
        msg = br.deserialize(raw, msgtype, f"image #{k + 1} at {t} ns (last good image: {last})")
        try:
            stamp = msg_ns(msg)
            image = image_to_numpy(msg).pixels
        except MessageError as exc:
            raise HarnessError(f"{br.path}: image #{k + 1} at {t} ns: {exc}") from None
        yield FrameRecord(stamp, image, gts.get(stamp), occ.get(t), k)
        k += 1
        last = f"#{k} at {t} ns"
    declared = br.declared().get(img_t)
    if declared is not None and k < declared:
        raise HarnessError(f"{br.path}: {declared} images declared but only {k} read; the bag is truncated")


def sequence_meta(path: Path | str) -> dict[str, Any]:
    """The `swir_sequence` custom-data entry written by make-bag (name, fps, source); {} if absent."""
    custom = BagReader(path).custom
    try:
        meta = json.loads(custom.get("swir_sequence", "{}"))
    except json.JSONDecodeError:
        return {}
    return meta if isinstance(meta, dict) else {}
