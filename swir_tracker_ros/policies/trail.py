# SPDX-License-Identifier: Apache-2.0
"""`Trail`: the tracked frames' recent history (centres with ego shifts removed, sizes) and the clock."""

from __future__ import annotations

import math
from collections import deque

from swir_tracker_ros.types import Box


class Trail:
    """Centres and sizes of the tracked frames of the last `window` frame periods (ours).

    The clock counts frame periods since init; `ego` sums the ego shifts given since init, so that a
    centre stored as (x - ego x, y - ego y) is where the target was in a frame that did not move. The
    coast model (mean velocity), the look-alike guard (motion reference) and the rejected-frame policy
    (recent sizes) read it.
    """

    def __init__(self, window: int) -> None:
        self.window = window
        self.clock = 0.0
        self.ego = (0.0, 0.0)
        self.centres: deque[tuple[float, float, float]] = deque()  # (clock, x - ego x, y - ego y)
        self.sizes: deque[tuple[float, float]] = deque()  # (clock, sqrt(w h))

    def advance(self, frames: float, dx: float, dy: float) -> None:
        """A new frame, `frames` periods after the previous one, the image shifted by (dx, dy) by the head."""
        self.clock += frames
        self.ego = (self.ego[0] + dx, self.ego[1] + dy)

    def remember_size(self, box: Box) -> None:
        """Append the size sqrt(w h) of `box` (the first box, or a tracked frame's)."""
        self._keep_recent(self.sizes, (self.clock, math.sqrt(box.w * box.h)))

    def remember(self, box: Box) -> None:
        """Append a tracked frame's centre (ego shifts removed) and size."""
        if self.window > 0:
            ex, ey = self.ego
            self._keep_recent(self.centres, (self.clock, box.cx - ex, box.cy - ey))
        self.remember_size(box)

    def forget_after(self, clock: float) -> None:
        """Drop the centres newer than `clock` (the frames that followed a look-alike)."""
        while self.centres and self.centres[-1][0] > clock:
            self.centres.pop()

    def _keep_recent(self, entries: deque, entry: tuple[float, ...]) -> None:
        """Append `entry` (its clock first) and drop the entries older than `window` frames."""
        entries.append(entry)
        while entries and entries[0][0] < self.clock - self.window:
            entries.popleft()
