# SPDX-License-Identifier: Apache-2.0
"""The field helper of the flat parameter dataclasses (metadata contract: docs/interfaces.md "Parameters")."""

from __future__ import annotations

from dataclasses import field
from typing import Any


def param(default: Any, doc: str, lo: float | None = None, hi: float | None = None, **extra: Any) -> Any:
    """A dataclass field with `metadata={"doc": doc, "min": lo, "max": hi, **extra}` (None bounds left out).

    `extra` carries the other contract keys, e.g. `choices=(...)` or `read_only=True`. A list default is
    copied per instance.
    """
    meta: dict[str, Any] = {"doc": doc, **extra}
    if lo is not None:
        meta["min"] = lo
    if hi is not None:
        meta["max"] = hi
    if isinstance(default, list):
        return field(default_factory=lambda: list(default), metadata=meta)
    return field(default=default, metadata=meta)
