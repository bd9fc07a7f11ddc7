# SPDX-License-Identifier: Apache-2.0
"""`harness track SOURCE --box x,y,w,h`: our tracker over one recording of the user's own, from a start box,
without ground truth or a ROS graph (docs/harness.md "Trying it on a recording").

SOURCE is a video, a folder of frames, a bag or a sequence folder (`recording.open_recording`). The tracker
is built as `harness eval` builds it (`evaluate.make_tracker_factory`: the default configuration unless one
is named, `--set` overrides) and is given the frames as the tracker node gives them: the decoded pixels and,
for 16-bit frames, the bit depth (`--bit-depth`, else what the source says); de-interlacing is the core's
`conditioning.deinterlace` (`--deinterlace`). Written while tracking, so that an interruption (Ctrl-C) or a
bad frame keeps what was tracked: the CSV (one row a frame from the start) and the annotated video, and at
the end the plot of state and score over time (`track_outputs`). Exit 0, 2 for bad input (one line,
nothing tracked or written before the refusal), 130 after Ctrl-C (with the outputs written).
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from swir_tracker_ros.errors import HarnessError, SwirTrackerError
from swir_tracker_ros.harness.bagio import FrameRecord
from swir_tracker_ros.harness.evaluate import (
    DEFAULT,
    Run,
    TrackerLike,
    configurations,
    make_tracker_factory,
    resolve_configuration,
)
from swir_tracker_ros.harness.protocol import RunStats
from swir_tracker_ros.harness.recording import Recording, open_recording
from swir_tracker_ros.harness.sources import parse_gt_line
from swir_tracker_ros.harness.track_outputs import CSV_COLUMNS, Outputs, Progress, Row
from swir_tracker_ros.types import Box, TrackResult

DEFAULT_OUT = "out/track"


# --- the start box ----------------------------------------------------------------------------------------

def parse_box(text: str) -> Box:
    """`x,y,w,h` in pixels (top-left corner, width, height; commas or spaces) with a positive size."""
    parts = [p for p in re.split(r"[,\s]+", text.strip()) if p]
    try:
        x, y, w, h = (float(p) for p in parts)
    except ValueError:
        raise HarnessError(f"--box wants x,y,w,h in pixels, got {text!r}") from None
    box = Box(x, y, w, h)
    if not box.is_finite() or w < 1 or h < 1:
        raise HarnessError(f"--box {text}: width and height must be at least 1 pixel")
    return box


def check_box(box: Box, image: np.ndarray, index: int) -> None:
    """The box's centre must lie in the image (where the tracker can start on it)."""
    h, w = image.shape[:2]
    if not (0.0 <= box.cx < w and 0.0 <= box.cy < h):
        raise HarnessError(f"box {_fmt_box(box)} lies outside the {w}x{h} image of frame {index} (its centre "
                           "must be inside)")


def _fmt_box(box: Box) -> str:
    return ",".join(f"{v:g}" for v in box.as_tuple())


def gui_missing() -> str | None:
    """Why `--select` cannot open a window here (no display, OpenCV without a GUI), or None."""
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return "there is no display (DISPLAY is not set)"
    gui = re.search(r"GUI:\s*(\S+)", cv2.getBuildInformation())
    if gui is None or gui.group(1).upper() == "NONE":
        return "this OpenCV has no GUI (opencv-python-headless)"
    return None


def select_box(image: np.ndarray, index: int) -> Box:
    """The box the user draws on the frame (cv2.selectROI: drag, then Enter or Space; Esc cancels)."""
    why = gui_missing()
    if why:
        raise HarnessError(f"--select cannot open a window: {why}; give the box as --box x,y,w,h")
    from msg_adapters.debug_image import to_bgr8

    title = f"harness track: draw the target's box on frame {index}, then Enter"
    x, y, w, h = cv2.selectROI(title, to_bgr8(image), showCrosshair=True, fromCenter=False)
    cv2.destroyWindow(title)
    if w < 1 or h < 1:
        raise HarnessError("--select: no box was drawn")
    return Box(float(x), float(y), float(w), float(h))


def read_gt_file(path: Path) -> list[Box | None]:
    """A gt.txt-style file: one `x,y,w,h` a frame (blank lines skipped; 0,0,0,0: target absent)."""
    try:
        lines = [ln for ln in path.read_text().splitlines() if ln.strip()]
    except (OSError, UnicodeDecodeError) as exc:
        raise HarnessError(f"{path}: cannot be read: {exc}") from None
    return [parse_gt_line(ln, path, k + 1) for k, ln in enumerate(lines)]


# --- the frame loop ---------------------------------------------------------------------------------------

@dataclass
class Session:
    """What one `track` call did: every frame's box and state as `harness eval` stores them (None and
    `idle` before the start), the tracked rows, the ground truth where the source has it, and how it
    ended."""

    pred: list[Box | None] = field(default_factory=list)
    states: list[str] = field(default_factory=list)
    gt: list[Box | None] = field(default_factory=list)
    occluded: list[bool | None] = field(default_factory=list)
    seconds: float = 0.0  # tracker time (init and updates)
    wall: float = 0.0  # after the start frame: reading, tracking and writing the frames
    start: Box | None = None
    start_index: int = -1
    size: tuple[int, int] = (0, 0)
    interrupted: bool = False
    error: str | None = None  # why the loop stopped early (a bad frame), after writing what was tracked
    outputs: Outputs | None = None


@contextmanager
def _sigint_ignored() -> Iterator[None]:
    """A second Ctrl-C while the outputs are finished must not cut them short (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def _depth(image: np.ndarray, bits: int | None) -> int | None:
    """The bit-depth hint the core gets, as the node gives it: for 16-bit frames only, and only when it
    is not the full container (None and 16 condition alike)."""
    return bits if image.dtype.itemsize == 2 and bits not in (None, 8, 16) else None


def _row(index: int, result: TrackResult, seconds: float) -> Row:
    return Row(index, result.box, result.state.value, float(result.peak), float(result.psr), seconds * 1e3)


def track_frames(frames: Iterator[FrameRecord], tracker: TrackerLike, box: Box | None, start: int,
                 bits: int | None, select: bool, open_outputs: Callable[[tuple[int, int]], Outputs],
                 progress: Progress) -> Session:
    """Play `tracker` over `frames`: from frame `start` with `box` (None: drawn with `select`, else the
    frame's ground truth; without either, the first frame at or after `start` with ground truth). The
    outputs open once the start is accepted; a KeyboardInterrupt or a bad frame after that ends the loop
    with what was tracked kept (`Session.interrupted`, `Session.error`)."""
    s = Session()
    t_started = 0.0
    try:
        for fr in frames:
            progress(len(s.pred))
            s.gt.append(fr.gt)
            s.occluded.append(fr.occluded)
            if s.outputs is None:
                start_box = _start_box(fr, box, start, select)
                if start_box is None:
                    s.pred.append(None)
                    s.states.append("idle")
                    continue
                _start(s, tracker, fr, start_box, bits, open_outputs)
                t_started = time.perf_counter()
            else:
                _step(s, tracker, fr, bits)
    except KeyboardInterrupt:
        s.interrupted = True
        if s.outputs is None:
            raise
    except HarnessError as exc:
        if s.outputs is None:
            raise
        s.error = str(exc)
    s.wall = time.perf_counter() - t_started
    progress.end()
    if s.outputs is None:
        n = len(s.pred)
        if box is not None or select:
            raise HarnessError(f"--start {start}: the recording has only {n} frame(s)")
        raise HarnessError(f"no frame from {start} on has ground truth to start from ({n} frames read); "
                           "give the start box with --box x,y,w,h")
    return s


def _start_box(fr: FrameRecord, box: Box | None, start: int, select: bool) -> Box | None:
    """The box to start with on this frame, or None when the start is later."""
    if fr.index < start:
        return None
    if select:
        return select_box(fr.image, fr.index)
    if box is not None:
        return box
    return fr.gt


def _start(s: Session, tracker: TrackerLike, fr: FrameRecord, box: Box, bits: int | None,
           open_outputs: Callable[[tuple[int, int]], Outputs]) -> None:
    check_box(box, fr.image, fr.index)
    t0 = time.perf_counter()
    try:
        tracker.init(fr.image, box, bit_depth=_depth(fr.image, bits))
    except SwirTrackerError as exc:
        raise HarnessError(f"the tracker cannot start on frame {fr.index}: {exc}") from None
    dt = time.perf_counter() - t0
    s.seconds += dt
    s.start, s.start_index = box, fr.index
    s.size = (int(fr.image.shape[1]), int(fr.image.shape[0]))
    s.pred.append(box)
    s.states.append("init")
    s.outputs = open_outputs(s.size)
    s.outputs.add(fr.image, Row(fr.index, box, "init", None, None, dt * 1e3), None, box)


def _step(s: Session, tracker: TrackerLike, fr: FrameRecord, bits: int | None) -> None:
    size = (int(fr.image.shape[1]), int(fr.image.shape[0]))
    if size != s.size:
        raise HarnessError(f"frame {fr.index} is {size[0]}x{size[1]}, the frames before it "
                           f"{s.size[0]}x{s.size[1]}: stopped there")
    t0 = time.perf_counter()
    try:
        res = tracker.update(fr.image, bit_depth=_depth(fr.image, bits))
    except SwirTrackerError as exc:
        raise HarnessError(f"tracker update failed on frame {fr.index}: {exc}") from None
    dt = time.perf_counter() - t0
    s.seconds += dt
    s.pred.append(res.box)
    s.states.append(res.state.value)
    assert s.outputs is not None
    s.outputs.add(fr.image, _row(fr.index, res, dt), res, None)


# --- the command ------------------------------------------------------------------------------------------

def _scores(s: Session, gt: list[Box | None] | None, fps: float) -> RunStats | None:
    """OTB OPE scores of the session against `gt` (else the source's own ground truth), frames after the
    start, scored as `harness eval` scores them (`protocol.RunStats.of`); None without ground truth."""
    truth = gt if gt is not None else s.gt
    if not any(g is not None for g in truth):
        return None
    n = len(s.pred)
    truth = (list(truth) + [None] * n)[:n]
    run = Run(list(s.pred), truth, (list(s.occluded) + [None] * n)[:n], s.seconds, list(s.states),
              init=s.start, init_index=s.start_index)
    return RunStats.of(run, fps)


def summary(rec: Recording, conf: str, s: Session, paths: list[Path], stats: RunStats | None) -> str:
    """The one-screen report: frames, shares of the states, speed, scores (with ground truth), files."""
    rows = s.outputs.rows if s.outputs is not None else []
    tracked = rows[1:]  # the updates (the start frame is the given box)
    n = max(len(tracked), 1)
    share = {st: sum(r.state == st for r in tracked) / n * 100.0 for st in ("tracking", "occluded", "lost")}
    w, h = s.size
    lines = [f"{rec.name}: {rec.what} {rec.location}, {w}x{h}, {rec.fps:g} fps; configuration {conf}",
             f"  start        frame {s.start_index}, box {_fmt_box(s.start) if s.start else '-'}",
             f"  frames       {len(rows)} tracked (frames {rows[0].frame}-{rows[-1].frame})" if rows else
             "  frames       none",
             f"  states       tracking {share['tracking']:.1f} %, occluded {share['occluded']:.1f} %, "
             f"lost {share['lost']:.1f} % (of the {len(tracked)} frames after the start)"]
    ms = [r.ms for r in tracked]
    if ms:
        lines.append(f"  speed        {len(ms) / max(sum(ms) / 1e3, 1e-9):.1f} fps tracker alone (mean "
                     f"{np.mean(ms):.1f} ms, max {max(ms):.1f} ms a frame); "
                     f"{len(ms) / max(s.wall, 1e-9):.1f} fps with reading and writing")
    if stats is not None:
        lines.append(f"  ground truth success AUC {stats.success_auc:.3f}, precision@20 "
                     f"{stats.precision_20:.3f} over {stats.frames} frames after the start (OTB OPE, as "
                     "`harness eval`)")
    what = {".mp4": "annotated video", ".csv": "per frame: " + ", ".join(CSV_COLUMNS),
            ".png": "state and score over time"}
    for k, p in enumerate(paths):
        lines.append(f"  {'wrote' if k == 0 else '':<12} {p} ({what[p.suffix]})")
    if s.interrupted:
        lines.append(f"  interrupted  (Ctrl-C) after frame {rows[-1].frame}: the files hold what was tracked")
    return "\n".join(lines)


def cmd_track(a: argparse.Namespace) -> int:
    if a.box and a.select:
        raise HarnessError("--box and --select both give the start box; use one")
    if a.frames is not None and a.frames < 1:
        raise HarnessError(f"--frames must be at least 1, got {a.frames}")
    if a.start < 0:
        raise HarnessError(f"--start must be a frame number from 0, got {a.start}")
    box = parse_box(a.box) if a.box else None
    gt = read_gt_file(Path(a.gt)) if a.gt else None
    conf = resolve_configuration(a.configuration)
    overrides = [*(a.set or [])] + ([f"conditioning.deinterlace={a.deinterlace}"] if a.deinterlace else [])
    factory = make_tracker_factory(conf, overrides)
    rec = open_recording(a.source, a.frames, a.image_topic)
    if box is None and not a.select and not rec.has_truth:
        why = gui_missing()
        raise HarnessError("--box x,y,w,h is required" + (f" (--select cannot draw it: {why})" if why else
                                                          " (or --select to draw it)"))
    try:
        tracker = factory()
    except SwirTrackerError as exc:  # e.g. a ModelError: the configuration's network weights are missing
        raise HarnessError(f"configuration {conf}: {exc}") from None
    out_dir = Path(a.out)
    if out_dir.exists() and not out_dir.is_dir():
        raise HarnessError(f"--out {out_dir}: a file, not a folder")
    bits = a.bit_depth or rec.bits
    progress = Progress(rec.total, not a.quiet)

    def open_outputs(size: tuple[int, int]) -> Outputs:
        return Outputs(out_dir, rec.name, rec.fps, size, not a.no_video)

    s = track_frames(rec.frames(), tracker, box, a.start, bits, a.select, open_outputs, progress)
    with _sigint_ignored():
        assert s.outputs is not None
        paths = s.outputs.close(f"{rec.name}: {conf} from frame {s.start_index}")
    print(summary(rec, conf, s, paths, _scores(s, gt, rec.fps)))
    if s.error:
        raise HarnessError(f"{s.error}; wrote what was tracked before it ({len(s.outputs.rows)} frames)")
    return 130 if s.interrupted else 0


def add_track_parser(sub: argparse._SubParsersAction) -> None:
    """The `track` subcommand (registered by cli.build_parser)."""
    p = sub.add_parser("track", help="our tracker over your own recording (video, frame folder, bag) from a "
                                     "start box: annotated video, CSV, plot, summary")
    p.add_argument("source",
                   help="a video (MP4, AVI, MKV ...), a folder of frames (8/16-bit PNG, TIFF, JPEG; name "
                        "order), a rosbag2 bag with an image topic, or a sequence folder")
    p.add_argument("--box", default=None, metavar="x,y,w,h",
                   help="the target's box on the start frame, pixels (top-left corner, width, height); "
                        "a sequence folder or a bag with ground truth starts from its box without it")
    p.add_argument("--select", action="store_true",
                   help="draw the start box on the start frame (needs a display and OpenCV with a GUI)")
    p.add_argument("--config", "--configuration", dest="configuration", default=DEFAULT,
                   choices=(*configurations(), DEFAULT), metavar="NAME",
                   help=f"our configuration: {', '.join(configurations())} (default: the tracker's default, "
                        f"{resolve_configuration(DEFAULT)})")
    p.add_argument("--set", action="append", default=None, metavar="NAME=VALUE",
                   help="override a parameter of the configuration (as `harness eval --set`)")
    p.add_argument("--start", type=int, default=0, metavar="FRAME",
                   help="the frame (from 0) the box is on; earlier frames are skipped")
    p.add_argument("--frames", type=int, default=None, metavar="N",
                   help="only the first N frames of the recording")
    p.add_argument("--bit-depth", type=int, choices=(8, 10, 12, 14, 16), default=None,
                   help="significant bits of 16-bit frames, as the node's bit_depth (default: what the "
                        "source says, else the full 16-bit container)")
    p.add_argument("--deinterlace", choices=("even", "odd"), default=None,
                   help="track one field of interlaced frames (conditioning.deinterlace)")
    p.add_argument("--image-topic", default=None, metavar="TOPIC",
                   help="a bag's image topic (default: /camera/image_raw, else its only sensor_msgs/Image "
                        "topic)")
    p.add_argument("--gt", default=None, metavar="FILE",
                   help="ground truth to score against: x,y,w,h a line, a line a frame (a sequence folder's "
                        "or bag's own is used without it)")
    p.add_argument("--out", default=DEFAULT_OUT, metavar="DIR",
                   help="folder of the outputs, named after the source (default: %(default)s; files of the "
                        "same name are replaced)")
    p.add_argument("--no-video", action="store_true", help="leave the annotated video out")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_track)
