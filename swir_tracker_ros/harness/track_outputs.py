# SPDX-License-Identifier: Apache-2.0
"""What `harness track` writes and shows (harness/track.py): the CSV row of a frame, the annotated video
(the node's debug picture, `msg_adapters.debug_image`, with the frame number and a mark while the target is
gone), the plot of state and score over time, the progress bar."""

from __future__ import annotations

import csv
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.types import Box, TrackResult, TrackState

CSV_COLUMNS = ("frame", "x", "y", "w", "h", "state", "score", "ms", "psr")
GONE = (TrackState.OCCLUDED, TrackState.LOST)  # the tracker says its target is not in view
START_COLOUR = (255, 255, 255)
PROGRESS_PERIOD_S = 0.2


@dataclass
class Row:
    """One tracked frame: the box and state the tracker reported, its score and PSR, its time."""

    frame: int
    box: Box
    state: str  # "init" on the start frame, else the TrackState's value
    score: float | None
    psr: float | None
    ms: float

    def csv(self) -> list[str]:
        nums = [repr(float(v)) for v in self.box.as_tuple()]  # exact: the boxes compare with `harness eval`
        opt = ["" if v is None else f"{v:.4f}" for v in (self.score, self.psr)]
        return [str(self.frame), *nums, self.state, opt[0], f"{self.ms:.2f}", opt[1]]


def annotate(image: np.ndarray, result: TrackResult | None, start: Box | None, index: int) -> np.ndarray:
    """The node's debug picture (box, search windows, state line) with the frame number; the start box in
    white on the start frame; while the target is gone (occluded or lost) the box crossed out and `GONE`."""
    from msg_adapters.debug_image import COLOURS, debug_picture, to_bgr8  # sensor_msgs: `track` only

    if start is not None:
        img = to_bgr8(image)
        p0, p1 = (round(start.x), round(start.y)), (round(start.x + start.w), round(start.y + start.h))
        cv2.rectangle(img, p0, p1, START_COLOUR, 2)
        cv2.putText(img, "start", (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, START_COLOUR, 1, cv2.LINE_AA)
    else:
        img = debug_picture(image, result)
    h = img.shape[0]
    cv2.putText(img, f"frame {index}", (4, h - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.4, START_COLOUR, 1,
                cv2.LINE_AA)
    if result is not None and result.state in GONE and result.aim_box.is_finite():
        b, colour = result.aim_box, COLOURS[result.state]
        p0, p1 = (round(b.x), round(b.y)), (round(b.x + b.w), round(b.y + b.h))
        cv2.line(img, p0, p1, colour, 2)
        cv2.line(img, (p0[0], p1[1]), (p1[0], p0[1]), colour, 2)
        cv2.putText(img, "GONE", (p0[0], max(p0[1] - 4, 12)), cv2.FONT_HERSHEY_SIMPLEX, 0.5, colour, 2,
                    cv2.LINE_AA)
    return img


class Outputs:
    """The CSV and the annotated video, written frame by frame (flushed: an abrupt end keeps them), and
    the plot at `close`."""

    def __init__(self, out_dir: Path, name: str, fps: float, size: tuple[int, int], video: bool) -> None:
        try:
            out_dir.mkdir(parents=True, exist_ok=True)
            self._file = (out_dir / f"{name}.csv").open("w", newline="")
        except OSError as exc:
            raise HarnessError(f"--out {out_dir}: cannot write there: {exc.strerror or exc}") from None
        self.csv_path = out_dir / f"{name}.csv"
        self.plot_path = out_dir / f"{name}.png"
        self.video_path: Path | None = None
        self._writer: cv2.VideoWriter | None = None
        if video:
            self.video_path = out_dir / f"{name}.mp4"
            self._writer = cv2.VideoWriter(str(self.video_path), cv2.VideoWriter_fourcc(*"mp4v"), fps, size)
            if not self._writer.isOpened():
                self._file.close()
                raise HarnessError(f"{self.video_path}: OpenCV cannot write an MP4 (mp4v) video here; "
                                   "--no-video leaves it out")
        self._csv = csv.writer(self._file)
        self._csv.writerow(CSV_COLUMNS)
        self.rows: list[Row] = []

    def add(self, image: np.ndarray, row: Row, result: TrackResult | None, start: Box | None) -> None:
        self.rows.append(row)
        self._csv.writerow(row.csv())
        self._file.flush()
        if self._writer is not None:
            self._writer.write(annotate(image, result, start, row.frame))

    def close(self, title: str) -> list[Path]:
        """Finish the video and the CSV, draw the plot; the paths written."""
        if self._writer is not None:
            self._writer.release()
        self._file.close()
        plot_track(self.rows, self.plot_path, title)
        return [p for p in (self.video_path, self.csv_path, self.plot_path) if p is not None]


def _rgb(state: TrackState) -> tuple[float, float, float]:
    """The annotated video's colour of a state, for matplotlib."""
    from msg_adapters.debug_image import COLOURS

    b, g, r = COLOURS[state]
    return (r / 255, g / 255, b / 255)


def _runs(frames: list[int], states: list[TrackState]) -> list[tuple[int, int, TrackState]]:
    """(first frame, last frame, state) of each run of consecutive frames in one state."""
    out: list[tuple[int, int, TrackState]] = []
    for f, st in zip(frames, states):
        if out and out[-1][2] is st:
            out[-1] = (out[-1][0], f, st)
        else:
            out.append((f, f, st))
    return out


def plot_track(rows: list[Row], path: Path, title: str) -> None:
    """Score (the peak; PSR beside it) over the frames, and the state as a coloured band (matplotlib
    Agg; the colours of the annotated video)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    frames = [r.frame for r in rows]
    fig, (ax, bx) = plt.subplots(2, 1, sharex=True, figsize=(8, 4), dpi=100,
                                 gridspec_kw={"height_ratios": [3, 1]})
    ax.plot(frames, [math.nan if r.score is None else r.score for r in rows], color="tab:blue", lw=1)
    ax.set(ylabel="score (peak)", title=title)
    ax.grid(alpha=0.3)
    if any(r.psr for r in rows):
        px = ax.twinx()
        px.plot(frames, [math.nan if r.psr is None else r.psr for r in rows], color="tab:gray", lw=0.8)
        px.set_ylabel("PSR", color="tab:gray")
    states = [TrackState.TRACKING if r.state == "init" else TrackState(r.state) for r in rows]
    for first, last, state in _runs(frames, states):  # one bar a run of frames in one state
        bx.broken_barh([(first - 0.5, last - first + 1)], (0, 1), color=_rgb(state))
    shown = (TrackState.TRACKING, *GONE)
    bx.legend([plt.Rectangle((0, 0), 1, 1, color=_rgb(st)) for st in shown], [st.value for st in shown],
              loc="upper right", fontsize=7, ncol=3)
    bx.set(yticks=[], xlabel="frame", ylabel="state", ylim=(0, 1.6))
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


class Progress:
    """A one-line progress bar on stderr while it is a terminal (nothing otherwise)."""

    def __init__(self, total: int | None, enabled: bool) -> None:
        self.total, self.enabled = total, enabled and sys.stderr.isatty()
        self._last = 0.0
        self._t0 = time.perf_counter()

    def __call__(self, done: int, force: bool = False) -> None:
        now = time.perf_counter()
        if not self.enabled or (not force and now - self._last < PROGRESS_PERIOD_S):
            return
        self._last = now
        rate = done / max(now - self._t0, 1e-9)
        if self.total:
            share = min(done / self.total, 1.0)
            bar = "#" * round(30 * share) + "-" * (30 - round(30 * share))
            text = f"[{bar}] {done}/{self.total} frames, {rate:.1f} fps"
        else:
            text = f"{done} frames, {rate:.1f} fps"
        print(f"\r{text}", end="", file=sys.stderr, flush=True)

    def end(self) -> None:
        if self.enabled:
            print("\r\033[K", end="", file=sys.stderr, flush=True)
