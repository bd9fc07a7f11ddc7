# SPDX-License-Identifier: Apache-2.0
"""What the demo supervisor keeps of a run: a rosbag2 of the graph's topics and per-message records."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import StoragePlugin, Writer

from msg_adapters.backend import typestore
from swir_tracker_ros import topics
from swir_tracker_ros.errors import DemoError

# Topics recorded into the bag and their ROS 2 types (docs/interfaces.md; /ground_truth/state: docs/demo.md).
RECORDED_TOPICS: dict[str, str] = {t: topics.TYPES[t] for t in (
    topics.IMAGE, topics.CAMERA_INFO, topics.GROUND_TRUTH_BOX, topics.GROUND_TRUTH_STATE, topics.TRACK_INIT,
    topics.TRACK_BOX, topics.PAN_TILT_ERROR, topics.TARGET_RATE, topics.TRACK_STATE, topics.JOINT_STATES,
    topics.DIAGNOSTICS)}


class BagRecorder:
    """rosbag2 writer (rosbags, Jazzy type store) that stores already-serialised CDR messages as received.

    Connections are created lazily, the first time a topic delivers a message, so a topic that never
    published does not appear with zero messages.
    """

    def __init__(self, path: Path, storage: str = "mcap") -> None:
        if path.exists():
            raise DemoError(f"bag {path} already exists; choose an empty output folder")
        plugin = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}.get(storage)
        if plugin is None:
            raise DemoError(f"bag storage {storage!r} is not 'mcap' or 'sqlite3'")
        self.path = path
        self._typestore = typestore()
        self._writer = Writer(path, version=9, storage_plugin=plugin)
        self._writer.open()
        self._connections: dict[str, Any] = {}
        self.counts: dict[str, int] = {}
        self._closed = False

    def write(self, topic: str, stamp_ns: int, data: bytes) -> None:
        """Append one serialised message of a topic in RECORDED_TOPICS, at receive time stamp_ns."""
        if self._closed:
            return
        conn = self._connections.get(topic)
        if conn is None:
            # a bag holds fully qualified names: the graph runs in the root namespace (topics.absolute)
            conn = self._writer.add_connection(topics.absolute(topic), RECORDED_TOPICS[topic],
                                               typestore=self._typestore)
            self._connections[topic] = conn
        self._writer.write(conn, stamp_ns, data)
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._writer.close()


@dataclass
class RunRecords:
    """Everything the report needs from one run, as plain lists (JSON-serialisable).

    Times are seconds: `stamp` is the header stamp (the camera frame the message belongs to), `recv` the
    wall-clock time the supervisor received it. Boxes are [x, y, w, h] pixels or None (absent).
    """

    label: str = ""
    ego_motion_compensation: bool = True
    duration_s: float = 0.0
    scene_start: float = math.nan  # wall-clock time the scene clock started
    init_time: float = math.nan
    init_box: list[float] | None = None
    camera: dict[str, float] = field(default_factory=dict)  # width, height, fx, fy, cx, cy
    gt: list[list[Any]] = field(default_factory=list)  # [stamp, box|None]
    # [stamp, scene_t, in_view, visible, pan_error, tilt_error, head_pan, head_tilt] (/ground_truth/state)
    truth: list[list[float]] = field(default_factory=list)
    track: list[list[Any]] = field(default_factory=list)  # [stamp, recv, box|None]
    error: list[list[float]] = field(default_factory=list)  # [stamp, recv, pan_err, tilt_err]
    rate: list[list[float]] = field(default_factory=list)  # [stamp, recv, pan, tilt] of track/target_rate
    state: list[list[Any]] = field(default_factory=list)  # [stamp, recv, state]
    joints: list[list[float]] = field(default_factory=list)  # [stamp, recv, pan, tilt]
    frames: list[list[float]] = field(default_factory=list)  # [stamp, recv] of /camera/image_raw
    diagnostics: list[dict[str, Any]] = field(default_factory=list)  # {"recv", "name", "values"}
    debug_frames: int = 0
    supervisor_cpu_s: float = math.nan  # CPU seconds of the recording supervisor itself
    video: str = ""
    bag: str = ""
    bag_counts: dict[str, int] = field(default_factory=dict)
    outcome: str = "running"  # "completed", "interrupted", or an error sentence

    def save(self, path: Path) -> None:
        path.write_text(json.dumps(asdict(self), allow_nan=True))

    @classmethod
    def load(cls, path: Path) -> RunRecords:
        try:
            raw = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise DemoError(f"cannot read run records {path}: {exc}") from exc
        known = {k: v for k, v in raw.items() if k in cls.__dataclass_fields__}
        return cls(**known)
