# SPDX-License-Identifier: Apache-2.0
"""/ground_truth/state and /ground_truth/occluded <-> plain values: the exact target state per frame.

/ground_truth/state (the simulated camera): one `diagnostic_msgs/DiagnosticArray` with a single status
named `GROUND_TRUTH_STATUS` whose values are the `GT_KEYS` written with `repr(float)`, so that angles
survive the text round trip bit for bit. /ground_truth/occluded (bags of synthetic scenarios): one
`std_msgs/Bool` per frame. The /scene/start reply carries the scene clock's start time in its message.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from msg_adapters.backend import BOOL, RCLPY, Backend
from msg_adapters.errors import MessageError
from msg_adapters.trigger import trigger_reply, trigger_result

if TYPE_CHECKING:
    from diagnostic_msgs.msg import DiagnosticArray
    from std_msgs.msg import Header

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
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

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


def occluded_msg(occluded: bool, backend: Backend = RCLPY) -> Any:
    """/ground_truth/occluded: `std_msgs/Bool`, true while the target is occluded."""
    return backend.cls(BOOL)(data=bool(occluded))


def occluded_from_msg(msg: Any) -> bool:
    """The flag of a /ground_truth/occluded message."""
    value = getattr(msg, "data", None)
    if value is None:
        raise MessageError(f"{type(msg).__name__} has no std_msgs/Bool data field")
    return bool(value)


SCENE_STARTED = "scene clock started at"


def scene_start_reply(response: Any, started: float) -> Any:
    """Fill a /scene/start (std_srvs/Trigger) response: success, and the start time (epoch seconds)."""
    return trigger_reply(response, True, f"{SCENE_STARTED} {started:.6f}")


def scene_start_time(response: Any) -> float:
    """The scene clock's start time (epoch seconds) of a /scene/start response; `MessageError` if refused."""
    success, text = trigger_result(response)
    if not success:
        raise MessageError(f"/scene/start refused: {text}")
    if not text.startswith(SCENE_STARTED):
        raise MessageError(f"/scene/start reply {text!r} does not start with {SCENE_STARTED!r}")
    try:
        return float(text[len(SCENE_STARTED):])
    except ValueError as exc:
        raise MessageError(f"/scene/start reply {text!r} has no start time") from exc
