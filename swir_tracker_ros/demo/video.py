# SPDX-License-Identifier: Apache-2.0
"""Debug-image video of a demo run: MP4 through cv2.VideoWriter, an animated GIF when no encoder exists."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from swir_tracker_ros.errors import DemoError


def caption(frame: np.ndarray, text: str) -> np.ndarray:
    """A copy of a BGR frame with one line of text on a dark band at the bottom."""
    out = frame.copy()
    h = out.shape[0]
    cv2.rectangle(out, (0, h - 22), (out.shape[1], h), (0, 0, 0), thickness=-1)
    cv2.putText(out, text, (6, h - 7), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 255), 1, cv2.LINE_AA)
    return out


class VideoSink:
    """Writes BGR frames of a fixed size as they arrive.

    MP4 (`mp4v` fourcc) when OpenCV's FFmpeg backend can encode it; otherwise frames are decimated
    (every `gif_stride`-th, half size) and written as an animated GIF on `close()`.
    """

    def __init__(self, stem: Path, fps: float, gif_stride: int = 3) -> None:
        if fps <= 0:
            raise DemoError(f"video frame rate must be positive, got {fps}")
        self.stem = stem
        self.fps = fps
        self.gif_stride = max(1, gif_stride)
        self.path: Path | None = None
        self.frames = 0
        self._writer: cv2.VideoWriter | None = None
        self._gif: list[np.ndarray] = []
        self._size: tuple[int, int] | None = None

    def write(self, frame: np.ndarray, repeat: int = 1) -> None:
        """Append a frame `repeat` times (repeat > 1 keeps playback in real time when frames were skipped)."""
        for _ in range(max(1, repeat)):
            self._write(frame)

    def _write(self, frame: np.ndarray) -> None:
        if frame.ndim == 2:
            frame = cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR)
        size = (frame.shape[1], frame.shape[0])
        if self._size is None:
            self._open(size)
        elif size != self._size:
            frame = cv2.resize(frame, self._size, interpolation=cv2.INTER_AREA)
        if self._writer is not None:
            self._writer.write(np.ascontiguousarray(frame))
        elif self.frames % self.gif_stride == 0:
            small = cv2.resize(frame, (self._size[0] // 2, self._size[1] // 2), interpolation=cv2.INTER_AREA)
            self._gif.append(cv2.cvtColor(small, cv2.COLOR_BGR2RGB))
        self.frames += 1

    def _open(self, size: tuple[int, int]) -> None:
        self._size = size
        path = self.stem.with_suffix(".mp4")
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), self.fps, size)
        if writer.isOpened():
            self._writer, self.path = writer, path
        else:
            writer.release()
            path.unlink(missing_ok=True)
            self.path = self.stem.with_suffix(".gif")

    def close(self) -> Path | None:
        """Finish the file; returns its path, or None when no frame was written."""
        if self._writer is not None:
            self._writer.release()
            self._writer = None
        elif self._gif and self.path is not None:
            from PIL import Image

            images = [Image.fromarray(f) for f in self._gif]
            duration_ms = int(1000.0 * self.gif_stride / self.fps)
            images[0].save(self.path, save_all=True, append_images=images[1:], duration=duration_ms, loop=0)
            self._gif = []
        return self.path if self.frames else None
