# SPDX-License-Identifier: Apache-2.0
"""The compiled loops of the core (numba): which are in use, loaded on first use.

core/fhog_jit.py (FHOG), core/corr_jit.py (correlation, window cuts, the conditioner's stretch) and
core/eco/kernels.py (the ECO filter's conjugate-gradient adjoint and intensity channels) are
imported only when numba is installed and `USE_JIT` is on; every caller keeps its numpy code for the other
case, with the same numbers.
"""

from __future__ import annotations

import importlib
from functools import lru_cache
from types import ModuleType

import numpy as np

USE_JIT = True
"""Use the compiled loops when numba is importable; False forces the numpy paths (tests compare both)."""


@lru_cache(maxsize=4)
def _compiled_module(name: str) -> ModuleType | None:
    """core/<name>.py (numba loops: fhog_jit, corr_jit), or None when numba is not installed (imported on
    first use: numba's import costs ~0.6 s, its first compile ~2 s a loop, then loaded from its on-disk
    cache)."""
    try:
        return importlib.import_module(f"swir_tracker_ros.core.{name}")
    except ImportError:
        return None


def fhog_jit() -> ModuleType | None:
    """The compiled FHOG loops (core/fhog_jit.py) when in use (numba importable and `USE_JIT`)."""
    return _compiled_module("fhog_jit") if USE_JIT else None


def eco_jit() -> ModuleType | None:
    """The ECO filter's compiled loops (core/eco/kernels.py) when in use (numba importable and `USE_JIT`)."""
    return _compiled_module("eco.kernels") if USE_JIT else None


def corr_jit() -> ModuleType | None:
    """The compiled correlation loops (core/corr_jit.py) when in use (numba importable and `USE_JIT`)."""
    return _compiled_module("corr_jit") if USE_JIT else None


def warm_up_correlation() -> bool:
    """Load (on a fresh install: compile) the correlation loops now, on tiny inputs of every signature the
    core calls them with; True if they are in use."""
    cj = corr_jit()
    if cj is None:
        return False
    spec = np.zeros((1, 1, 2, 2), np.complex64)
    cj.cross_spectrum_kernel(spec, spec[0], np.empty((1, 2, 2), np.complex64))
    one, win = np.zeros(1, dtype=np.intp), np.ones((2, 2), np.float32)
    cj.cut_windows_kernel(win[None], win, one, one, np.empty((1, 1, 2, 2), np.float32))
    for dtype in (np.uint8, np.uint16):  # the frame types the conditioner stretches
        cj.stretch_kernel(np.zeros((2, 2), dtype), np.float32(0.0), np.float32(1.0), win)
        ranks, values = np.zeros(4, np.intp), np.empty(4, np.int64)
        cj.order_statistics_kernel(np.zeros((2, 2), dtype), 1, ranks, values)
    return True
