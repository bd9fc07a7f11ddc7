# SPDX-License-Identifier: Apache-2.0
"""rosbags CDR (de)serialization for the bag harness.

Messages for bags are built and read by the same adapters as the nodes' (`stamps`, `image`, `geometry`,
`camera_info`, `ground_truth`), given `backend=ROSBAGS`; this module adds only the byte layer.
"""

from __future__ import annotations

from typing import Any

from msg_adapters.backend import typestore


def serialize(msg: Any) -> bytes:
    """CDR bytes of a rosbags message."""
    return bytes(typestore().serialize_cdr(msg, msg.__msgtype__))


def deserialize(raw: bytes, msgtype: str) -> Any:
    """The rosbags message of CDR bytes of type `msgtype` ("sensor_msgs/msg/Image")."""
    return typestore().deserialize_cdr(raw, msgtype)
