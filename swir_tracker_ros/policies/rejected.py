# SPDX-License-Identifier: Apache-2.0
"""`RejectedFrames`: a frame that is not failed but not accepted as `tracking` (ours)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from swir_tracker_ros.paramfield import param
from swir_tracker_ros.policies.memory import AppearanceMemory
from swir_tracker_ros.policies.trail import Trail
from swir_tracker_ros.types import Box


@dataclass
class RejectedParams:
    """A rejected frame: a weak peak after an occlusion, or the long-term memory's veto."""

    after: int = param(
        25,
        "(ours) frames of re-detection before a rejected frame stops steering the state like a confident "
        "one (it is then a re-detection at the prediction: robust update, motion held), unless its peak was "
        "only weak and the memory finds the target in its box; until then a rejected frame steers (a short "
        "loss: fast motion, a turn); a long occlusion must not drag the prediction onto the occluder or the "
        "background",
        0,
        100000,
    )


class RejectedFrames:
    """How a rejected frame moves the state: its update (`held`) and the size it may measure (`scale`).

    Size: the winning scale kept within the sizes the box had in the trail's tracked frames (and the
    prediction's). A turned or partly hidden target's box can grow back to a size it had (OTB girl), an
    occluder crossing in front cannot grow it beyond (synthetic t9: the box grew 1.16x on a pedestrian
    crossing in front and followed him; docs/experiments.md, thirteenth pass).
    """

    def __init__(self, p: RejectedParams) -> None:
        self.p = p

    def held(self, occluded: int, weak: bool, index: int, memory: AppearanceMemory | None) -> bool:
        """Is a rejected frame (`weak`: by its peak, else by the memory's veto) kept from steering the state
        like a confident one? After `after` frames of re-detection, unless weak and the memory knows the
        target in window `index`."""
        if occluded < self.p.after:
            return False
        return not (weak and (memory is None or memory.knows(index)))

    @staticmethod
    def scale(pred: Box, scale: float, trail: Trail) -> float:
        """The size factor a rejected frame measures from its winning `scale` (see the class)."""
        s = math.sqrt(pred.w * pred.h)
        seen = [v for _, v in trail.sizes] or [s]
        lo, hi = min(min(seen), s), max(max(seen), s)
        return min(max(s * scale, lo), hi) / s
