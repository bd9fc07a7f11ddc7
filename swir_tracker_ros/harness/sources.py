# SPDX-License-Identifier: Apache-2.0
"""Frame sources the harness scores: rosbag2 bags, sequence folders (PNG or JPEG frames + gt.txt) and
synthetic scenarios."""

from __future__ import annotations

import hashlib
import json
import math
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from itertools import islice
from pathlib import Path

import cv2
import numpy as np

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.bagio import FrameRecord, read_frames, sequence_meta
from swir_tracker_ros.types import Box

SYNTH_PREFIX = "synth:"
T0_NS = 1_000_000_000  # stamp of frame 0 in bags we write (1 s after the epoch, never 0)
FRAME_SUFFIXES = (".png", ".jpg", ".jpeg")  # sequence folders: 8/16-bit PNG or 8-bit gray JPEG frames
SCENE_DIR = Path(__file__).resolve().parents[1] / "scene"


@dataclass(frozen=True)
class SynthFrame(FrameRecord):
    """A synthetic frame: also the covered share of the target's in-image silhouette (None: not in view)."""

    occlusion: float | None = None


@dataclass
class Source:
    """A re-iterable sequence: `frames()` streams FrameRecords (image, ground truth, occlusion flag)."""

    name: str
    kind: str  # "bag", "sequence" or "synth"
    location: str
    fps: float = 25.0
    bits: int | None = None  # significant bits of the pixel values (12 in a uint16 container, ...)
    max_frames: int | None = None
    meta: dict = field(default_factory=dict)
    image_topic: str | None = None
    gt_topic: str | None = None

    @property
    def key(self) -> str:
        """The name runs of this source are stored under: the name, plus `@N` when only N frames are used."""
        return self.name if not self.max_frames else f"{self.name}@{self.max_frames}"

    def frames(self) -> Iterator[FrameRecord]:
        if self.kind == "bag":
            it = read_frames(self.location, self.image_topic, self.gt_topic)
        elif self.kind == "sequence":
            it = _sequence_frames(Path(self.location), self.fps, self.meta)
        else:
            it = _synth_frames(self.location, self.fps)
        return islice(it, self.max_frames) if self.max_frames else it


def open_source(spec: str | Path, max_frames: int | None = None, image_topic: str | None = None,
                gt_topic: str | None = None) -> Source:
    """`synth:NAME` (or a bare scenario name), a sequence folder with gt.txt, or a bag directory/file."""
    text = str(spec)
    from swir_tracker_ros.scene import scenarios

    if text.startswith(SYNTH_PREFIX) or (not Path(text).exists() and text in scenarios()):
        name = text.removeprefix(SYNTH_PREFIX)
        if name not in scenarios():
            raise HarnessError(f"unknown synthetic scenario {name!r}; `harness synth --list` names them")
        from swir_tracker_ros.scene.scenarios import make_scenario

        bits = make_scenario(name).world.sensor.bits
        return Source(name, "synth", name, 25.0, bits, max_frames)
    path = Path(text)
    if not path.exists():
        raise HarnessError(f"{path}: no such bag, sequence folder or scenario")
    if path.is_dir() and (path / "gt.txt").exists():
        meta = read_meta_json(path / "meta.json")
        return Source(path.name, "sequence", str(path), _fps(meta, path / "meta.json"), 8, max_frames, meta)
    meta = sequence_meta(path)
    where = f"{path}: custom data swir_sequence"
    name = str(meta.get("name") or (path.name if path.is_dir() else path.stem))
    bits = meta.get("bits")
    if bits is not None and (isinstance(bits, bool) or not isinstance(bits, int) or not 1 <= bits <= 16):
        raise HarnessError(f'{where}: "bits" must be an integer from 1 to 16, got {bits!r}')
    return Source(name, "bag", str(path), _fps(meta, where), bits, max_frames, meta, image_topic, gt_topic)


def read_meta_json(path: Path) -> dict:
    """A sequence folder's meta.json as a dict ({} when absent); HarnessError naming the file when it is
    not a readable JSON object, or its "fps" / "occlusion_frames" have the wrong type."""
    if not path.exists():
        return {}
    if not path.is_file():
        raise HarnessError(f"{path}: not a regular file")
    try:
        meta = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError) as exc:
        raise HarnessError(f"{path}: cannot be read: {exc}") from None
    except json.JSONDecodeError as exc:
        raise HarnessError(f"{path}: not valid JSON: {exc}") from None
    if not isinstance(meta, dict):
        kind = {list: "an array", str: "a string"}.get(type(meta), f"a {type(meta).__name__}")
        raise HarnessError(f'{path}: must be a JSON object such as {{"fps": 25}}, got {kind}')
    _fps(meta, path)
    occ = meta.get("occlusion_frames")
    if occ is not None and (not isinstance(occ, list)
                            or not all(isinstance(f, int) and not isinstance(f, bool) for f in occ)):
        raise HarnessError(f'{path}: "occlusion_frames" must be a list of frame numbers, got {occ!r}')
    _check_corpus_meta(meta, path)
    return meta


def absent_frames(meta: dict) -> tuple[int, ...]:
    """The 1-based frames meta.json lists as absent (target not visible); () when it gives only a count."""
    frames = meta.get("absent_frames")
    return tuple(frames) if isinstance(frames, list) else ()


def _is_int(v: object) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _check_corpus_meta(meta: dict, path: Path) -> None:
    """The development corpus's keys (../shared/corpus/README.md), when present: "video" a non-empty string,
    "window" [first, last] source frames, "absent_frames" a list of 1-based frame numbers."""
    video = meta.get("video")
    if video is not None and (not isinstance(video, str) or not video):
        raise HarnessError(f'{path}: "video" must be a non-empty string, got {video!r}')
    window = meta.get("window")
    if window is not None and (not isinstance(window, list) or len(window) != 2
                               or not all(map(_is_int, window)) or window[0] > window[1]):
        raise HarnessError(f'{path}: "window" must be [first, last] frame numbers, got {window!r}')
    absent = meta.get("absent_frames")  # a list of frames; the shared sequences' meta gives a count
    if absent is not None and not (_is_int(absent) and absent >= 0) and (
            not isinstance(absent, list) or not all(_is_int(f) and f >= 1 for f in absent)):
        raise HarnessError(f'{path}: "absent_frames" must be a list of frame numbers from 1 (or a count), '
                           f'got {absent!r}')


def _fps(meta: dict, where: object) -> float:
    """meta["fps"] (25 when absent) as a positive finite float; HarnessError naming `where` otherwise."""
    fps = meta.get("fps", 25.0)
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not math.isfinite(fps) or fps <= 0:
        raise HarnessError(f'{where}: "fps" must be a positive number, got {fps!r}')
    return float(fps)


def _occluded_set(meta: dict) -> set[int] | None:
    frames = meta.get("occlusion_frames")
    return {int(f) for f in frames} if frames is not None else None


def frame_files(path: Path) -> list[Path]:
    """The frames of a sequence folder in name order: `*.png`, `*.jpg` or `*.jpeg` (one kind per folder)."""
    return sorted(f for f in path.iterdir() if f.suffix.lower() in FRAME_SUFFIXES)


def parse_gt_line(line: str, where: Path, number: int) -> Box | None:
    """One gt.txt line, `x,y,w,h` separated by commas, tabs or spaces; None for a box without area."""
    parts = [v for v in re.split(r"[,\s]+", line.strip()) if v]
    try:
        x, y, w, h = (float(v) for v in parts[:4])
    except ValueError:
        raise HarnessError(f"{where}: line {number} is not x,y,w,h: {line!r}") from None
    return Box(x, y, w, h) if w > 0 and h > 0 else None


def read_gt(path: Path) -> list[Box | None]:
    """A sequence folder's gt.txt, one box per frame (blank lines skipped)."""
    gt_file = path / "gt.txt"
    try:
        lines = [ln for ln in gt_file.read_text().splitlines() if ln.strip()]
    except (OSError, UnicodeDecodeError) as exc:
        raise HarnessError(f"{gt_file}: cannot be read: {exc}") from None
    return [parse_gt_line(ln, gt_file, k + 1) for k, ln in enumerate(lines)]


def read_frame(img_path: Path) -> np.ndarray:
    """One frame as stored (8/16-bit PNG, 8-bit JPEG); a 3-channel file is turned to gray (BT.601)."""
    image = cv2.imread(str(img_path), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise HarnessError(f"{img_path}: unreadable image")
    if image.ndim == 3:
        image = cv2.cvtColor(image, cv2.COLOR_BGRA2GRAY if image.shape[2] == 4 else cv2.COLOR_BGR2GRAY)
    return image


def _sequence_frames(path: Path, fps: float, meta: dict) -> Iterator[FrameRecord]:
    gts = read_gt(path)
    images = frame_files(path)
    if len(images) != len(gts):
        raise HarnessError(f"{path}: {len(images)} frames (PNG/JPEG) but {len(gts)} boxes in gt.txt")
    occ = _occluded_set(meta)
    boxed = [f for f in absent_frames(meta) if f <= len(gts) and gts[f - 1] is not None]
    if boxed:
        raise HarnessError(f"{path}: meta.json lists frame {boxed[0]} as absent but gt.txt has a box there "
                           "(an absent frame's line is 0,0,0,0)")
    for k, (img_path, gt) in enumerate(zip(images, gts)):
        flag = (k + 1) in occ if occ is not None else None
        yield FrameRecord(T0_NS + round(k * 1e9 / fps), read_frame(img_path), gt, flag, k)


def _synth_frames(name: str, fps: float) -> Iterator[FrameRecord]:
    from swir_tracker_ros.scene.scenarios import make_scenario

    run = make_scenario(name, fps=fps)
    for fr in run:
        gt = fr.target.box if fr.target is not None else None
        occ = fr.target.occlusion if fr.target is not None else None
        yield SynthFrame(T0_NS + round(fr.index * 1e9 / fps), fr.image, gt, fr.occluded, fr.index, occ)


def convert_bits(image: np.ndarray, src_bits: int, dst_bits: int) -> np.ndarray:
    """Rescale pixel values from `src_bits` significant bits to an 8-bit (uint8) or 16-bit (uint16) image."""
    if dst_bits not in (8, 16):
        raise HarnessError(f"--bits must be 8 or 16, got {dst_bits}")
    if src_bits == dst_bits and image.dtype == (np.uint8 if dst_bits == 8 else np.uint16):
        return image
    scale = ((1 << dst_bits) - 1) / ((1 << src_bits) - 1)
    out = np.rint(image.astype(np.float64) * scale)
    return out.astype(np.uint8 if dst_bits == 8 else np.uint16)


def source_fingerprint(src: Source) -> str:
    """Content identity of a source (part of every stored run's provenance): gt.txt and the frame files'
    names and sizes of a folder, the scene code of a synthetic scenario, file names and sizes of a bag;
    plus the name, kind and --frames limit."""
    h = hashlib.sha1(f"{src.kind}:{src.name}:{src.max_frames}".encode())
    loc = Path(src.location)
    if src.kind == "sequence":
        lines = [ln for ln in (loc / "gt.txt").read_text().splitlines() if ln.strip()]
        h.update("\n".join(lines[:src.max_frames] if src.max_frames else lines).encode())
        files = frame_files(loc)
        for f in files[:src.max_frames] if src.max_frames else files:
            h.update(f"{f.name}:{f.stat().st_size}".encode())
    elif src.kind == "synth":
        for f in sorted(SCENE_DIR.glob("*.py")):
            h.update(f.read_bytes())
    else:
        files = sorted(loc.rglob("*")) if loc.is_dir() else [loc]
        for f in files:
            if f.is_file():
                h.update(f"{f.name}:{f.stat().st_size}".encode())
    return h.hexdigest()[:16]
