# SPDX-License-Identifier: Apache-2.0
"""`UpdateGate`: which frames teach the base filter, and at what rate (paper 000: confident frames only)."""

from __future__ import annotations

from dataclasses import dataclass

from swir_tracker_ros.core.base import BaseFilter, Detection
from swir_tracker_ros.paramfield import param


@dataclass
class UpdateGateParams:
    """The gate itself is the base filter's (`confident`: peak > 0.5, paper 000; APCE > 0.583 x mean,
    dissertation eq. 4.97; LMCF's, Wang et al. CVPR 2017 eq. 12); this adds what happens when it refuses."""

    unconfident_rate: float = param(
        0.2,
        "(ours) once the update gate has refused unconfident_after tracked frames since it last passed one, "
        "a refused `tracking` frame still teaches the filter at this fraction of its learning rate: the "
        "model follows a lasting appearance change (stage lighting, a turn) that keeps every peak under the "
        "bar the first frames set (LMCF's means never come down); 0: frozen until a frame passes the gate "
        "(the papers)",
        0.0,
        1.0,
    )
    unconfident_after: int = param(
        10,
        "(ours) tracked frames the update gate must refuse (since it last passed one) before "
        "unconfident_rate applies: from the first refused frame, the tracked frames of a partial occlusion "
        "would teach the filter the occluder",
        0,
        100000,
    )


class UpdateGate:
    """Confident-only model update, frozen on failure (paper 000 Sec. III-B.5; dissertation eq. 4.97)."""

    def __init__(self, p: UpdateGateParams) -> None:
        self.p = p
        self.refused = 0  # tracked frames the gate refused since it last passed one

    def rate(self, base: BaseFilter, det: Detection, rejected: bool) -> float | None:
        """The learning rate of this frame's update, None for no update. `rejected`: a failed or rejected
        frame, which never teaches; the gate (`base.confident`) is asked once per other frame."""
        if rejected:
            return None
        rate = base.learning_rate
        if not base.confident(det):
            self.refused += 1
            if self.p.unconfident_rate <= 0.0 or self.refused <= self.p.unconfident_after:
                return None
            rate *= self.p.unconfident_rate
        else:
            self.refused = 0
        return rate
