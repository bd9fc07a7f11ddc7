# SPDX-License-Identifier: Apache-2.0
"""Tracker-node parameters and its small bookkeeping helpers (frame statistics, head-pose history)."""

from __future__ import annotations

import bisect
import itertools
import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from swir_tracker_ros import topics
from swir_tracker_ros.core.registry import filter_class
from swir_tracker_ros.core.siamese.network import require
from swir_tracker_ros.errors import ModelError, ParameterError
from swir_tracker_ros.paramfield import param, validate_params
from swir_tracker_ros.tracker_params import TrackerParams

CLICK_MSGS = ("point", "point_stamped", "off")


def missing_models(params: TrackerParams) -> str | None:
    """Why a configuration cannot run here: the first network weight file it needs (its base filter's, the
    fusion's network) that is missing or corrupt, as the ModelError's one line; None when it can run. The
    node refuses a parameter change with this reason and keeps its core (docs/siamese.md)."""
    try:
        filter_class(params.base).check_resources(params.base)
        if params.fusion is not None:
            require(params.fusion.network.constants, params.fusion.network.model_dir or None,
                    params.fusion.network.precision)
    except ModelError as exc:
        return str(exc)
    return None


@dataclass
class TrackerNodeParams:
    """Node-only parameters (the tracking core's own parameters are bound under `tracker.`)."""

    image_topic: str = param(
        topics.IMAGE, "Input image topic, the base name of image_transport (a relative name resolves in the "
        "node's namespace; sensor-data QoS, depth 1).", read_only=True)
    image_transport: str = param(
        "raw", "How images arrive (image_transport's names): raw (sensor_msgs/Image on image_topic) or "
        "compressed (sensor_msgs/CompressedImage, JPEG or PNG, on image_topic/compressed).",
        choices=topics.TRANSPORTS, read_only=True)
    camera_info_topic: str = param(
        "", "sensor_msgs/CameraInfo topic (K: focal lengths and principal point; D: plumb_bob distortion); "
        "'' = beside the image (image_transport's convention: <dirname(image_topic)>/camera_info).",
        read_only=True, empty_derived=True)
    camera_info_timeout_s: float = param(
        5.0, "Warn (throttled, and on /diagnostics) when no CameraInfo has arrived this long after the first "
        "frame while use_camera_info is true: the field-of-view fallback is in use.", 0.0, 3600.0)
    joint_states_topic: str = param(
        topics.JOINT_STATES, "sensor_msgs/JointState of the head (joints pan_joint, tilt_joint in rad, "
        "zoom_joint 0 wide .. 1 tele) for ego-motion and the zoom's focal length; bring-up: joint_states, "
        "where robot_state_publisher reads them.", read_only=True)
    pan_joint: str = param("pan", "Name of the pan joint in the joint states (bring-up's pan_joint).",
                           read_only=True)
    tilt_joint: str = param("tilt", "Name of the tilt joint in the joint states (bring-up's tilt_joint).",
                            read_only=True)
    zoom_joint: str = param("zoom", "Name of the zoom joint in the joint states (bring-up's zoom_joint).",
                            read_only=True)
    angles_frame_id: str = param(
        "pan_link", "header.frame_id of track/pan_tilt_error and track/target_rate: the frame whose z is the "
        "pan axis and y the tilt axis (the URDF's <prefix>pan_link; bring-up sets it), not the optical "
        "frame: the vectors hold joint angles and rates.", read_only=True)
    use_camera_info: bool = param(
        True, "Use CameraInfo intrinsics when received; otherwise (or when false) the FOV fallback.")
    fov_h_deg: float = param(
        8.0, "Horizontal field of view (deg) for the pinhole fallback without CameraInfo.", 0.1, 179.0)
    zoom_focal_scale: list[float] = param(
        [], "Zoom -> focal length table: pairs zoom, scale (zoom 0 wide .. 1 tele, as the zoom joint reports "
        "it; scale multiplies fx and fy of the CameraInfo or the FOV fallback, which describe zoom 0), "
        "ascending in zoom, linear in between, held beyond the ends; [] = the focal length does not follow "
        "the zoom. E.g. a 1x-10x lens: [0.0, 1.0, 0.5, 3.2, 1.0, 10.0].")
    fov_v_deg: float = param(
        0.0, "Vertical field of view (deg) for the fallback; 0 means square pixels (fy = fx).", 0.0, 179.0)
    init_box: list[float] = param(
        [], "Box x, y, w, h (full-resolution pixels) that starts tracking on the next frame; [] = none.")
    click_msg: str = param(
        "point", "Clicks on image_topic_mouse_left and track/debug_image_mouse_left select the target: point "
        "(geometry_msgs/Point, what rqt_image_view publishes; the newest frame), point_stamped "
        "(geometry_msgs/PointStamped; the frame with its stamp) or off.", choices=CLICK_MSGS, read_only=True)
    click_box_size: float = param(
        32.0, "Side (pixels) of the box a click starts when the object under it does not stand out; also "
        "the scale of the search for one.", 4.0, 1024.0)
    select_min_size: float = param(
        4.0, "A selected box smaller than this (pixels) on a side is rejected (too small).", 1.0, 1000.0)
    select_stamp_tolerance_s: float = param(
        0.1, "A selection's stamp names the stored frame nearest to it within this (s); 0 stamp: the newest "
        "frame.", 0.0, 10.0)
    history_max_age_s: float = param(
        2.0, "Recent frames kept for stamped selection (s): a selection older than this is rejected (stamp "
        "too old); 0 keeps only the newest frame.", 0.0, 60.0)
    history_max_mb: float = param(
        128.0, "Memory bound of the kept frames (MiB); the oldest go first.", 0.0, 65536.0)
    bit_depth: int = param(
        0, "Significant bits of 16-bit images (10, 12, 14); 0 = the full 16-bit container.", 0, 16)
    ego_motion_compensation: bool = param(
        True, "Shift the core's prediction by the image motion the head caused since the previous frame.")
    max_frame_age_s: float = param(
        0.0,
        "Drop frames whose header stamp is older than this against the node clock; 0 = no limit.", 0.0, 60.0)
    debug_jpeg_quality: int = param(
        80, "JPEG quality of track/debug_image/compressed (published only while subscribed).", 1, 100)
    diagnostics_period_s: float = param(
        1.0, "Period of the /diagnostics report (rate, latency, drops).", 0.1, 60.0)
    warn_throttle_s: float = param(
        5.0, "Minimum interval between repeated warnings about bad input.", 0.0, 3600.0)
    threads: int = param(
        1, "OpenCV threads of the tracker (cv2.setNumThreads, read at start-up): the Siamese network's "
        "inference and OpenCV's resampling; 0 = OpenCV's default (every core).", 0, 64, read_only=True)

    def validate(self) -> None:
        """Raise `ParameterError` naming the first bad field (`paramfield.validate_params`)."""
        validate_params(self)

    def check(self) -> None:
        """Cross-field rules (run by `validate_params` after the fields)."""
        if self.init_box:
            if len(self.init_box) != 4:
                raise ParameterError(f"parameter init_box must be [] or x, y, w, h; got {self.init_box}")
            if not (self.init_box[2] > 0 and self.init_box[3] > 0):
                raise ParameterError(f"parameter init_box needs a positive w and h; got {self.init_box}")
        if len({self.pan_joint, self.tilt_joint, self.zoom_joint}) != 3 or not all(
                (self.pan_joint, self.tilt_joint, self.zoom_joint)):
            raise ParameterError(f"parameters pan_joint, tilt_joint and zoom_joint must be distinct, "
                                 f"non-empty names; got {self.pan_joint!r}, {self.tilt_joint!r}, "
                                 f"{self.zoom_joint!r}")
        table = self.zoom_focal_scale
        zooms, scales = table[0::2], table[1::2]
        if table and (len(table) % 2 or len(table) < 4 or any(b <= a for a, b in itertools.pairwise(zooms))
                      or not all(s > 0 for s in scales)):
            raise ParameterError(f"parameter zoom_focal_scale must be [] or at least 2 pairs zoom, scale "
                                 f"with ascending zoom and positive scales; got {table}")
        if self.bit_depth not in (0, 8, 10, 12, 14, 16):
            raise ParameterError(f"parameter bit_depth must be 0, 8, 10, 12, 14 or 16; got {self.bit_depth}")


# A frame smaller than this on either side cannot hold a search window: a driver glitch, never tracked.
MIN_FRAME_SIDE = 16
# Consecutive frames of a new size / pixel format before an active track is re-initialised on it; until
# then such frames are skipped, so that one odd frame never ends a track (issue 14).
FORMAT_CHANGE_FRAMES = 3


def frame_problem(pixels: np.ndarray) -> str | None:
    """Why a decoded frame cannot be tracked (too small, non-finite pixels), or None when it can."""
    height, width = pixels.shape[:2]
    if min(height, width) < MIN_FRAME_SIDE:
        return f"{height}x{width} is smaller than {MIN_FRAME_SIDE} pixels on a side"
    if pixels.dtype.kind == "f" and not np.isfinite(pixels).all():
        return f"{height}x{width} {pixels.dtype} frame has NaN or infinite pixels"
    return None


def fmt_key(key: tuple) -> str:
    """`240x320 uint16` for a (shape, dtype string) format key."""
    shape, dtype = key
    return "x".join(map(str, shape)) + f" {np.dtype(dtype).name}"


class FormatWatch:
    """The (shape, dtype) of the frames being tracked. A frame of another format is taken at once while
    nothing is held (no track, no pending selection); otherwise frames of it are skipped until
    FORMAT_CHANGE_FRAMES arrive in a row, so that one odd frame (a driver glitch) never ends a track and a
    genuine, persistent change re-initialises it."""

    def __init__(self) -> None:
        self.key: tuple | None = None
        self._new: tuple | None = None  # a different format seen while holding, and how often in a row
        self._count = 0

    def check(self, pixels: np.ndarray, holding: bool) -> tuple[str | None, tuple | None]:
        """(why this frame is skipped, or None; the previous format when this frame changes it, or None)."""
        key = (pixels.shape, pixels.dtype.str)
        old = self.key
        if old is None or old == key:
            self.key, self._new, self._count = key, None, 0
            return None, None
        if holding:
            self._count = self._count + 1 if key == self._new else 1
            self._new = key
            if self._count < FORMAT_CHANGE_FRAMES:
                return (f"format {fmt_key(key)} differs from the tracked {fmt_key(old)} ({self._count} of "
                        f"{FORMAT_CHANGE_FRAMES} in a row before re-initialising)"), None
        self.key, self._new, self._count = key, None, 0
        return None, old


class HeadPoseHistory:
    """Recent (stamp, pan, tilt) samples; `at(t)` interpolates linearly between samples.

    Before the first sample the pose is held. After the last one it is extrapolated with the velocity of
    the last two samples for at most `max_extrapolation` seconds, then held: joint states arrive later
    than the frames they belong to, and holding the last pose would make the ego-motion shift lag
    whenever the head accelerates.
    """

    def __init__(self, maxlen: int = 64, max_extrapolation: float = 0.2) -> None:
        self.samples: deque[tuple[float, float, float]] = deque(maxlen=maxlen)
        self.max_extrapolation = max_extrapolation

    def add(self, stamp: float, pan: float, tilt: float) -> None:
        if self.samples and stamp < self.samples[-1][0]:
            self.samples.clear()  # time went backwards (bag loop, restart): start over
        self.samples.append((stamp, pan, tilt))

    def at(self, stamp: float) -> tuple[float, float] | None:
        if not self.samples:
            return None
        times = [s[0] for s in self.samples]
        i = bisect.bisect_left(times, stamp)
        if i == 0:
            return self.samples[0][1:]
        if i >= len(times):
            t1, p1, q1 = self.samples[-1]
            if len(times) < 2 or times[-2] >= t1:
                return p1, q1
            t0, p0, q0 = self.samples[-2]
            dt = min(stamp - t1, self.max_extrapolation) / (t1 - t0)
            return p1 + dt * (p1 - p0), q1 + dt * (q1 - q0)
        (t0, p0, q0), (t1, p1, q1) = self.samples[i - 1], self.samples[i]
        a = (stamp - t0) / (t1 - t0) if t1 > t0 else 1.0
        return p0 + a * (p1 - p0), q0 + a * (q1 - q0)


@dataclass
class FrameStats:
    """Per-window counters for /diagnostics; `report()` returns the window's figures and starts a new one."""

    received: int = 0
    processed: int = 0
    malformed: int = 0
    unusable: int = 0  # decoded but not trackable (too small, non-finite) or of an unconfirmed new format
    stale: int = 0
    skipped: int = 0  # frames missing between consecutive stamps (overwritten in the depth-1 queue, or lost)
    lost: int = 0  # samples DDS reported lost on the way (the image reader's sample-lost status): transport
    errors: int = 0
    latency_ms: list[float] = field(default_factory=list)  # receive -> last publish, in the node
    core_ms: list[float] = field(default_factory=list)
    overhead_ms: list[float] = field(default_factory=list)  # in-node latency minus the core's time
    age_ms: list[float] = field(default_factory=list)  # header stamp -> publish, on the node clock
    totals: dict[str, int] = field(default_factory=dict)
    _last_stamp: float = 0.0
    _periods: deque = field(default_factory=lambda: deque(maxlen=50))

    def frame_stamp(self, stamp: float) -> None:
        """Count frames skipped between stamps, from the source's frame period (10th percentile of the
        recent intervals, so that the estimate holds while every other frame is being skipped).

        A gap of more than 1.5 periods counts round(gap / period) - 1 skipped frames; a gap beyond
        10 periods is a pause of the source, not skipping, and is neither counted nor learnt.
        """
        if self._last_stamp > 0 and stamp > self._last_stamp:
            dt = stamp - self._last_stamp
            period = self.period()
            if period > 0 and dt > 10 * period:
                dt = 0.0
            elif period > 0 and dt > 1.5 * period:
                self.skipped += round(dt / period) - 1
            if dt > 0:
                self._periods.append(dt)
        self._last_stamp = stamp

    def period(self, q: float = 10.0) -> float:
        """The source's frame period (s): q-th percentile of the recent intervals; 0 until 5 are known."""
        return float(np.percentile(self._periods, q)) if len(self._periods) >= 5 else 0.0

    def report(self, window_s: float) -> tuple[dict[str, object], bool]:
        """(values, trouble) for the window just ended; trouble means drops or errors happened in it."""
        def pct(xs: list[float], q: float) -> float:
            return float(np.percentile(xs, q)) if xs else math.nan

        counts = {"received": self.received, "processed": self.processed,
                  "dropped_malformed": self.malformed, "dropped_unusable": self.unusable,
                  "dropped_stale": self.stale,
                  "dropped_skipped": self.skipped, "dropped_lost": self.lost, "callback_errors": self.errors}
        for k, v in counts.items():
            self.totals[k] = self.totals.get(k, 0) + v
        values: dict[str, object] = {
            "frame_rate_hz": self.processed / window_s if window_s > 0 else 0.0,
            "latency_ms_p50": pct(self.latency_ms, 50), "latency_ms_p99": pct(self.latency_ms, 99),
            "latency_ms_max": max(self.latency_ms, default=math.nan),
            "core_ms_mean": float(np.mean(self.core_ms)) if self.core_ms else math.nan,
            "core_ms_p50": pct(self.core_ms, 50), "core_ms_p99": pct(self.core_ms, 99),
            "overhead_ms_p50": pct(self.overhead_ms, 50), "overhead_ms_p99": pct(self.overhead_ms, 99),
            "core_ms_max": max(self.core_ms, default=math.nan),
            "stamp_age_ms_p50": pct(self.age_ms, 50),
            **{f"window_{k}": v for k, v in counts.items()},
            **{f"total_{k}": v for k, v in self.totals.items()},
        }
        trouble = bool(self.malformed or self.unusable or self.skipped or self.errors or self.stale
                       or self.lost)
        self.received = self.processed = self.malformed = self.unusable = self.stale = self.skipped = 0
        self.lost = 0
        self.errors = 0
        self.latency_ms, self.core_ms, self.age_ms, self.overhead_ms = [], [], [], []
        return values, trouble
