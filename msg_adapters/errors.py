# SPDX-License-Identifier: Apache-2.0
"""The one error type of the message-adapter layer."""

from __future__ import annotations


class MessageError(ValueError):
    """A ROS message cannot be converted; the text names the field and the numbers that were wrong."""
