# SPDX-License-Identifier: Apache-2.0
"""Plain key/value health reports <-> diagnostic_msgs/DiagnosticArray (the /diagnostics topic)."""

from __future__ import annotations

from collections.abc import Mapping

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Header

from msg_adapters.errors import MessageError

OK, WARN, ERROR, STALE = (DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR,
                          DiagnosticStatus.STALE)


def _text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def status(name: str, level: int | bytes, message: str, values: Mapping[str, object],
           hardware_id: str = "") -> DiagnosticStatus:
    """One DiagnosticStatus; values are written as text (floats with 6 significant digits)."""
    lvl = level if isinstance(level, bytes) else bytes([int(level)])
    if lvl not in (OK, WARN, ERROR, STALE):
        raise MessageError(f"DiagnosticStatus.level {level!r} is not OK, WARN, ERROR or STALE")
    return DiagnosticStatus(level=lvl, name=name, message=message, hardware_id=hardware_id,
                            values=[KeyValue(key=str(k), value=_text(v)) for k, v in values.items()])


def node_status_name(node_name: str, task: str) -> str:
    """`<node's full name>: <task>`, e.g. `/head1/tracker: tracker_node`: diagnostic_updater's
    `<node>: <task>` with the namespace, so that the statuses of two heads differ (rqt_robot_monitor and
    the aggregator key on the name; issue 39)."""
    return f"{node_name}: {task}"


def diagnostic_array(header: Header, statuses: list[DiagnosticStatus]) -> DiagnosticArray:
    return DiagnosticArray(header=header, status=list(statuses))


def statuses(msg: DiagnosticArray) -> list[tuple[str, dict[str, str]]]:
    """(name, values) of every status in the array, in message order."""
    try:
        return [(str(st.name), {str(kv.key): str(kv.value) for kv in st.values}) for st in msg.status]
    except (AttributeError, TypeError) as exc:
        raise MessageError(f"DiagnosticArray.status is not readable ({exc})") from exc


def status_values(msg: DiagnosticArray, name: str) -> dict[str, str]:
    """The values of the status called `name`, or of the first whose name is `<node>: name` (a task of any
    node, `node_status_name`); `MessageError` if the array has no such status."""
    for st_name, values in statuses(msg):
        if st_name == name or st_name.endswith(f": {name}"):
            return values
    raise MessageError(f"DiagnosticArray.status has no entry named {name!r}")
