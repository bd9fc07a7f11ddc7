# SPDX-License-Identifier: Apache-2.0
"""Recordings `harness track` reads: a video file, a folder of frames (8/16-bit PNG, TIFF, JPEG), a rosbag2
bag with an image topic, or a sequence folder. Bags and sequence folders are the harness's own `Source`s
(`sources.open_source`, `bagio.read_frames`); videos and frame folders are read here, with the same frame
reader (`sources.read_frame`) and the core's gray conversion (`conditioning.to_gray`). Every refusal is a
HarnessError naming the file and the reason, raised before anything is tracked or written."""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from itertools import islice
from pathlib import Path

import cv2
import numpy as np

from swir_tracker_ros import topics
from swir_tracker_ros.core.conditioning import to_gray
from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.bagio import GT_TOPIC, IMAGE_TOPIC, FrameRecord, pick_topic
from swir_tracker_ros.harness.bagreader import BagReader
from swir_tracker_ros.harness.sources import (
    FRAME_SUFFIXES,
    T0_NS,
    Source,
    frame_files,
    open_source,
    read_frame,
)

FOLDER_SUFFIXES = (*FRAME_SUFFIXES, ".tif", ".tiff")  # frame folders: PNG, JPEG and TIFF (8 or 16 bit)
BAG_SUFFIXES = (".db3", ".mcap")
DEFAULT_FPS = 25.0  # a video or folder that does not say its rate


@dataclass
class Recording:
    """A re-iterable stream of frames (`FrameRecord`s; ground truth where the source has it)."""

    name: str
    kind: str  # "video", "frames", "sequence" or "bag"
    location: str
    fps: float
    bits: int | None  # significant bits of 16-bit pixel values, when the source says (bag meta, video)
    total: int | None  # frames, when known before reading them (the progress bar)
    frames: Callable[[], Iterator[FrameRecord]]
    has_truth: bool = False  # ground-truth boxes come with the frames (a sequence folder, a harness bag)

    @property
    def what(self) -> str:
        return {"video": "video", "frames": "frame folder", "sequence": "sequence folder", "bag": "bag"}[
            self.kind]


def open_recording(spec: str | Path, max_frames: int | None = None,
                   image_topic: str | None = None) -> Recording:
    """The recording at `spec`: a sequence folder (gt.txt), a bag (a directory with metadata.yaml or
    storage files, a .db3 / .mcap file), any other folder (frames), or a video file. `max_frames`: only
    the first N frames."""
    path = Path(spec)
    if not path.exists():
        raise HarnessError(f"{path}: no such file or folder")
    if path.is_dir():
        if (path / "gt.txt").exists():
            return _from_source(open_source(path, max_frames), len(frame_files(path)), True)
        if (path / "metadata.yaml").exists() or any(f.suffix in BAG_SUFFIXES for f in path.iterdir()):
            return _bag(path, max_frames, image_topic)
        return _folder(path, max_frames)
    if not path.is_file():
        raise HarnessError(f"{path}: not a regular file (a FIFO, socket or device)")
    if path.suffix.lower() in BAG_SUFFIXES:
        return _bag(path, max_frames, image_topic)
    if path.suffix.lower() in FOLDER_SUFFIXES:
        raise HarnessError(f"{path}: one image; give the folder of the frames (or a video, a bag, a "
                           "sequence folder)")
    return _video(path, max_frames)


def _limit(total: int | None, max_frames: int | None) -> int | None:
    return total if not max_frames or total is None else min(total, max_frames)


def _from_source(src: Source, total: int | None, has_truth: bool) -> Recording:
    kind = "sequence" if src.kind == "sequence" else "bag"
    return Recording(src.name, kind, src.location, src.fps, src.bits, _limit(total, src.max_frames),
                     src.frames, has_truth)


def _bag(path: Path, max_frames: int | None, image_topic: str | None) -> Recording:
    """A bag with an image topic (the flag's, /camera/image_raw, else the only sensor_msgs/Image topic)."""
    reader = BagReader(path)
    topic = pick_topic(reader, image_topic, IMAGE_TOPIC, topics.TYPES[IMAGE_TOPIC])
    if topic is None:
        found = ", ".join(f"{t} ({m})" for t, m in reader.topics().items()) or "none"
        raise HarnessError(f"{path}: no sensor_msgs/msg/Image topic to track in (topics: {found}); "
                           "--image-topic names one")
    truth = pick_topic(reader, None, GT_TOPIC, topics.TYPES[GT_TOPIC]) is not None
    return _from_source(open_source(path, max_frames, topic), reader.declared().get(topic), truth)


# --- frame folders ----------------------------------------------------------------------------------------

def folder_frames(path: Path) -> list[Path]:
    """The frames of a folder in name order: one kind of file (PNG, TIFF or JPEG), one size and pixel
    type; HarnessError for an empty folder, mixed kinds or mixed sizes (read from the file headers)."""
    files = sorted(f for f in path.iterdir() if f.is_file() and f.suffix.lower() in FOLDER_SUFFIXES)
    if not files:
        nested = any((d / "gt.txt").exists() for d in path.iterdir() if d.is_dir())
        raise HarnessError(f"{path}: no frames (PNG, TIFF or JPEG files) in the folder"
                           + ("; it holds sequence folders: give one of them" if nested else ""))
    kinds = sorted({_kind(f) for f in files})
    if len(kinds) > 1:
        raise HarnessError(f"{path}: the folder mixes {' and '.join(kinds)} frames; keep one kind")
    from PIL import Image, UnidentifiedImageError

    first = None
    for f in files:
        try:
            with Image.open(f) as im:
                fmt = (im.size, im.mode)
        except (OSError, UnidentifiedImageError) as exc:
            raise HarnessError(f"{f}: not a readable image ({exc})") from None
        if first is None:
            first = (f, fmt)
        elif fmt != first[1]:
            (w0, h0), m0 = first[1]
            (w, h), m = fmt
            what = "sizes" if (w, h) != (w0, h0) else "pixel types"
            raise HarnessError(f"{path}: frames of mixed {what}: {f.name} is {w}x{h} {m}, {first[0].name} "
                               f"{w0}x{h0} {m0} (PIL modes); one size and type per folder")
    return files


def _kind(f: Path) -> str:
    s = f.suffix.lower()
    return {".jpg": "JPEG", ".jpeg": "JPEG", ".tif": "TIFF", ".tiff": "TIFF"}.get(s, s[1:].upper())


def _folder(path: Path, max_frames: int | None) -> Recording:
    files = folder_frames(path)[:max_frames] if max_frames else folder_frames(path)

    def frames() -> Iterator[FrameRecord]:
        for k, f in enumerate(files):
            yield FrameRecord(T0_NS + round(k * 1e9 / DEFAULT_FPS), read_frame(f), None, None, k)

    return Recording(path.name, "frames", str(path), DEFAULT_FPS, None, len(files), frames)


# --- video files ------------------------------------------------------------------------------------------

def _fourcc(value: float) -> str:
    v = int(value)
    return "".join(chr((v >> 8 * i) & 0xFF) for i in range(4))


def gray16_bits(cap: cv2.VideoCapture) -> int | None:
    """Significant bits of a video stored as 16-bit little-endian gray (FFmpeg's gray16le, gray12le ...:
    codec tag `Y1\\0<bits>`, e.g. FFV1 in Matroska), else None (8-bit video, read as BGR)."""
    tag = _fourcc(cap.get(cv2.CAP_PROP_CODEC_PIXEL_FORMAT))
    return ord(tag[3]) if tag[:2] == "Y1" and 9 <= ord(tag[3]) <= 16 else None


def _capture(path: Path, raw: bool) -> cv2.VideoCapture:
    """OpenCV's FFmpeg capture of `path`; `raw`: frames as decoded (16-bit gray stays 16-bit)."""
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # FFmpeg's own log lines: the error says why
    params = [cv2.CAP_PROP_CONVERT_RGB, 0] if raw else []
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)  # the raw mode's warning
    try:
        return cv2.VideoCapture(str(path), cv2.CAP_FFMPEG, params)
    finally:
        cv2.utils.logging.setLogLevel(level)


def _video(path: Path, max_frames: int | None) -> Recording:
    cap = _capture(path, False)
    try:
        if not cap.isOpened():
            raise HarnessError(f"{path}: not a video OpenCV's FFmpeg can read (nor a bag, a folder of frames "
                               "or a sequence folder)")
        ok, first = cap.read()
        if not ok or first is None:
            raise HarnessError(f"{path}: a video without a readable frame")
        bits = gray16_bits(cap)
        fps = cap.get(cv2.CAP_PROP_FPS)
        count = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
    finally:
        cap.release()
    fps = fps if math.isfinite(fps) and 0 < fps < 10_000 else DEFAULT_FPS

    def frames() -> Iterator[FrameRecord]:
        capture = _capture(path, bits is not None)
        try:
            k = 0
            while True:
                ok, image = capture.read()
                if not ok or image is None:
                    return
                if bits is not None and not (image.ndim == 2 and image.dtype == np.uint16):
                    raise HarnessError(f"{path}: frame {k} decoded as {image.dtype} {image.shape}, not the "
                                       "16-bit gray the stream declares")
                yield FrameRecord(T0_NS + round(k * 1e9 / fps), to_gray(image), None, None, k)
                k += 1
        finally:
            capture.release()

    def limited() -> Iterator[FrameRecord]:
        return islice(frames(), max_frames) if max_frames else frames()

    return Recording(path.stem, "video", str(path), fps, bits, _limit(count or None, max_frames), limited)
