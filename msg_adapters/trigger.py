# SPDX-License-Identifier: Apache-2.0
"""std_srvs/Trigger responses (/track/cancel, /scene/start) <-> (success, message)."""

from __future__ import annotations

from typing import Any


def trigger_reply(response: Any, success: bool, message: str) -> Any:
    """Fill a Trigger response in place (the service callback returns it)."""
    response.success = bool(success)
    response.message = str(message)
    return response


def trigger_result(response: Any) -> tuple[bool, str]:
    """(success, message) of a Trigger response; (False, 'no response') when the call gave none."""
    if response is None:
        return False, "no response"
    return bool(getattr(response, "success", False)), str(getattr(response, "message", ""))
