# SPDX-License-Identifier: Apache-2.0
"""TrackResult <-> `track/state` (diagnostic_msgs/DiagnosticArray, status `swir_tracker/track`) and
`track/state_typed` (swir_tracker_interfaces/msg/TrackState)."""

from __future__ import annotations

from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Header

from msg_adapters.backend import RCLPY, Backend
from msg_adapters.errors import MessageError
from msg_adapters.geometry import box_from_roi, box_to_roi
from swir_tracker_ros.types import Box, SearchMode, TrackResult, TrackState

STATUS_NAME = "swir_tracker/track"
HARDWARE_ID = "swir_tracker"
VALUE_KEYS = ("state", "peak", "psr", "apce", "huber_threshold", "search_mode", "measured", "scale")

# Diagnostic level per state: tracking and idle are nominal, occlusion is a warning, a lost target an error.
LEVELS = {
    TrackState.IDLE: DiagnosticStatus.OK,
    TrackState.TRACKING: DiagnosticStatus.OK,
    TrackState.OCCLUDED: DiagnosticStatus.WARN,
    TrackState.LOST: DiagnosticStatus.ERROR,
}


def _fmt(value: float) -> str:
    return repr(float(value))


def track_result_to_msg(result: TrackResult, header: Header) -> DiagnosticArray:
    """One `swir_tracker/track` status: message = state, values in the order of `VALUE_KEYS`."""
    values = {
        "state": result.state.value,
        "peak": _fmt(result.peak),
        "psr": _fmt(result.psr),
        "apce": _fmt(result.apce),
        "huber_threshold": _fmt(result.huber_threshold),
        "search_mode": result.search_mode.value,
        "measured": "true" if result.measured else "false",
        "scale": _fmt(result.scale),
    }
    status = DiagnosticStatus(
        level=LEVELS[result.state], name=STATUS_NAME, message=result.state.value, hardware_id=HARDWARE_ID,
        values=[KeyValue(key=k, value=values[k]) for k in VALUE_KEYS],
    )
    return DiagnosticArray(header=header, status=[status])


def idle_state_msg(header: Header) -> DiagnosticArray:
    """The /track/state message published while no target is selected."""
    return track_result_to_msg(TrackResult(box=Box(0.0, 0.0, 0.0, 0.0), state=TrackState.IDLE), header)


def _track_values(msg: DiagnosticArray) -> dict[str, str]:
    statuses = getattr(msg, "status", None)
    if statuses is None:
        raise MessageError("DiagnosticArray.status is missing")
    for status in statuses:
        if getattr(status, "name", None) == STATUS_NAME:
            return {kv.key: kv.value for kv in status.values}
    names = [getattr(s, "name", "?") for s in statuses]
    raise MessageError(f"DiagnosticArray.status has no {STATUS_NAME!r} entry (names: {names})")


def _float(values: dict[str, str], key: str) -> float:
    if key not in values:
        raise MessageError(f"{STATUS_NAME} values lack key {key!r}")
    try:
        out = float(values[key])
    except ValueError as exc:
        raise MessageError(f"{STATUS_NAME} value {key}={values[key]!r} is not a number") from exc
    return out


def track_state_from_msg(msg: DiagnosticArray) -> TrackState:
    """The `TrackState` carried by a /track/state message; `MessageError` if absent or unknown."""
    values = _track_values(msg)
    raw = values.get("state")
    try:
        return TrackState(raw)
    except ValueError as exc:
        known = [s.value for s in TrackState]
        raise MessageError(f"{STATUS_NAME} value state={raw!r} is not one of {known}") from exc


def track_result_from_msg(msg: DiagnosticArray, box: Box | None = None) -> TrackResult:
    """Rebuild a `TrackResult` from /track/state (the box travels on /track/box; pass it to attach it)."""
    values = _track_values(msg)
    state = track_state_from_msg(msg)
    raw_mode = values.get("search_mode")
    try:
        mode = SearchMode(raw_mode)
    except ValueError as exc:
        raise MessageError(f"{STATUS_NAME} value search_mode={raw_mode!r} is unknown") from exc
    measured = values.get("measured")
    if measured not in ("true", "false"):
        raise MessageError(f"{STATUS_NAME} value measured={measured!r} is not 'true' or 'false'")
    return TrackResult(
        box=box if box is not None else Box(0.0, 0.0, 0.0, 0.0), state=state,
        peak=_float(values, "peak"), psr=_float(values, "psr"), apce=_float(values, "apce"),
        huber_threshold=_float(values, "huber_threshold"), search_mode=mode, measured=measured == "true",
        scale=_float(values, "scale"),
    )


# ---------------------------------------------------------------- swir_tracker_interfaces/msg/TrackState
TYPED_STATE = "swir_tracker_interfaces/msg/TrackState"
_STATE_CODES = {TrackState.IDLE: "IDLE", TrackState.TRACKING: "TRACKING", TrackState.OCCLUDED: "OCCLUDED",
                TrackState.LOST: "LOST"}
_MODE_CODES = {SearchMode.NORMAL: "SEARCH_NORMAL", SearchMode.MULTI_WINDOW: "SEARCH_MULTI_WINDOW"}


def typed_state_msg(result: TrackResult, header: Header, frames_occluded: int, width: int, height: int,
                    backend: Backend = RCLPY) -> Any:
    """`track/state_typed`: the frame's state as typed fields; the box (outward to whole pixels, clipped to
    the width x height image) only while tracking or occluded, all zero otherwise."""
    cls = backend.cls(TYPED_STATE)
    active = result.state in (TrackState.TRACKING, TrackState.OCCLUDED) and result.box.is_finite()
    roi = box_to_roi(result.box if active else Box(0.0, 0.0, 0.0, 0.0), width, height, backend)
    return cls(header=header, state=getattr(cls, _STATE_CODES[result.state]), box=roi,
               peak=float(result.peak), psr=float(result.psr), apce=float(result.apce),
               huber_threshold=float(result.huber_threshold),
               search_mode=getattr(cls, _MODE_CODES[result.search_mode]), measured=bool(result.measured),
               scale=float(result.scale), frames_occluded=max(int(frames_occluded), 0))


def typed_state_from_msg(msg: Any) -> tuple[TrackState, Box | None]:
    """(state, box or None when absent) of a `track/state_typed` message; `MessageError` if unreadable."""
    names = {getattr(type(msg), code, None): state for state, code in _STATE_CODES.items()}
    try:
        state = names[int(msg.state)]
        box = box_from_roi(msg.box) if msg.box.width and msg.box.height else None
    except (AttributeError, KeyError, TypeError, ValueError) as exc:
        raise MessageError(f"TrackState is not readable ({exc})") from exc
    return state, box
