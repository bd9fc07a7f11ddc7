# SPDX-License-Identifier: Apache-2.0
"""Plain value types shared by the core, the nodes and the harness (no ROS, no numpy state)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum


@dataclass(frozen=True)
class Box:
    """Axis-aligned box in pixels: top-left corner (x, y), width w, height h; 0-based image coordinates."""

    x: float
    y: float
    w: float
    h: float

    @property
    def cx(self) -> float:
        return self.x + self.w / 2.0

    @property
    def cy(self) -> float:
        return self.y + self.h / 2.0

    @property
    def center(self) -> tuple[float, float]:
        return (self.cx, self.cy)

    @property
    def area(self) -> float:
        return max(self.w, 0.0) * max(self.h, 0.0)

    @classmethod
    def from_center(cls, cx: float, cy: float, w: float, h: float) -> Box:
        return cls(cx - w / 2.0, cy - h / 2.0, w, h)

    def is_finite(self) -> bool:
        return all(math.isfinite(v) for v in (self.x, self.y, self.w, self.h))

    def is_valid(self) -> bool:
        """Finite with a positive width and height."""
        return self.is_finite() and self.w > 0 and self.h > 0

    def iou(self, other: Box) -> float:
        """Intersection over union; 0 for disjoint or degenerate boxes."""
        ix = max(0.0, min(self.x + self.w, other.x + other.w) - max(self.x, other.x))
        iy = max(0.0, min(self.y + self.h, other.y + other.h) - max(self.y, other.y))
        inter = ix * iy
        union = self.area + other.area - inter
        return inter / union if union > 0 else 0.0

    def center_distance(self, other: Box) -> float:
        return math.hypot(self.cx - other.cx, self.cy - other.cy)

    def scaled(self, factor: float) -> Box:
        """Same centre, width and height multiplied by factor."""
        return Box.from_center(self.cx, self.cy, self.w * factor, self.h * factor)

    def shifted(self, dx: float, dy: float) -> Box:
        return Box(self.x + dx, self.y + dy, self.w, self.h)

    def intersects_image(self, width: int, height: int) -> bool:
        return self.x < width and self.y < height and self.x + self.w > 0 and self.y + self.h > 0

    def as_tuple(self) -> tuple[float, float, float, float]:
        return (self.x, self.y, self.w, self.h)


class TrackState(str, Enum):
    """What the tracker believes about its target."""

    IDLE = "idle"  # no target selected
    TRACKING = "tracking"  # confident measurement this frame
    OCCLUDED = "occluded"  # failure detected; coasting on the Kalman prediction, searching 3x3 windows
    LOST = "lost"  # gave up (occluded too long, target left the image, or unusable input)


class SearchMode(str, Enum):
    NORMAL = "normal"  # one search window centred on the Kalman prediction
    MULTI_WINDOW = "multi_window"  # 3x3 grid of windows around the prediction (re-detection)


@dataclass(frozen=True)
class TrackResult:
    """Outcome of one `Tracker.update` call."""

    box: Box
    state: TrackState
    peak: float = 0.0
    psr: float = 0.0
    apce: float = 0.0
    huber_threshold: float = 0.0
    search_mode: SearchMode = SearchMode.NORMAL
    measured: bool = False  # True: box comes from a correlation measurement; False: Kalman prediction only
    scale: float = 1.0  # size relative to the initial box
    model_updated: bool = False
    search_windows: tuple[Box, ...] = field(default_factory=tuple)
    # estimated image velocity of the box centre (input pixels per frame period; the Kalman state, ego
    # shifts excluded): the target's own motion when ego shifts are given, else its motion in the image
    velocity: tuple[float, float] = (0.0, 0.0)
    # the box a pan-tilt head points at when it is not `box` (None: `box`): while a network-led track's
    # verdict rejects the network's answer (`box`, state occluded or lost), its last accepted box
    # (policies/lead.py), so that the head never follows a box the verdict rejected
    aim: Box | None = None

    @property
    def aim_box(self) -> Box:
        """The box a head points at (`aim`, else `box`)."""
        return self.box if self.aim is None else self.aim
