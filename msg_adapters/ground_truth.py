# SPDX-License-Identifier: Apache-2.0
"""/ground_truth/state <-> plain values: the simulated camera's exact target state per frame.

One `diagnostic_msgs/DiagnosticArray` with a single status named `GROUND_TRUTH_STATUS` whose values are the
`GT_KEYS` written with `repr(float)`, so that angles survive the text round trip bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Header

from msg_adapters.errors import MessageError

GROUND_TRUTH_STATUS = "swir_tracker/ground_truth"
GT_KEYS = ("scene_time", "in_view", "visible", "occlusion", "occluded", "pan_error", "tilt_error",
           "head_pan", "head_tilt", "running")
NAN_ALLOWED = ("pan_error", "tilt_error")  # NaN when the target is not in the scene at all


def ground_truth_state_msg(header: Header, values: Mapping[str, float],
                           hardware_id: str = "") -> DiagnosticArray:
    """The message of one frame's `GT_KEYS` values (NaN allowed: pan/tilt error of an absent target)."""
    missing = [k for k in GT_KEYS if k not in values]
    if missing:
        raise MessageError(f"{GROUND_TRUTH_STATUS} needs values for {missing}")
    in_view = float(values["in_view"]) > 0.5
    status = DiagnosticStatus(level=DiagnosticStatus.OK, name=GROUND_TRUTH_STATUS,
                              message="in view" if in_view else "absent", hardware_id=hardware_id,
                              values=[KeyValue(key=k, value=repr(float(values[k]))) for k in GT_KEYS])
    return DiagnosticArray(header=header, status=[status])


def ground_truth_state_values(msg: DiagnosticArray) -> dict[str, float] | None:
    """The `GT_KEYS` values of a /ground_truth/state message; None when it has no ground-truth status."""
    for status in getattr(msg, "status", []):
        if status.name == GROUND_TRUTH_STATUS:
            raw = {kv.key: kv.value for kv in status.values}
            try:
                values = {k: float(raw[k]) for k in GT_KEYS}
            except (KeyError, ValueError) as exc:
                raise MessageError(f"{GROUND_TRUTH_STATUS} values are incomplete or not numbers ({exc})"
                                   ) from exc
            bad = [k for k, v in values.items() if not math.isfinite(v) and k not in NAN_ALLOWED]
            if bad:
                raise MessageError(f"{GROUND_TRUTH_STATUS} values {bad} are not finite")
            return values
    return None
