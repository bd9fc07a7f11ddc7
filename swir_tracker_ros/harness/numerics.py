# SPDX-License-Identifier: Apache-2.0
"""Numeric environments: the same machine with other floating-point kernels (issue 32).

A tracking run is chaotic: one rounding difference in a BLAS, OpenCV or compiled kernel can move a whole
run. These environments select other kernels on one machine, so that a threshold can be set against how
far an averaged score moves between them, and a test can be checked to hold in each. They are settings for
the checks that `harness regress --calibrate` and `benchmarks/numerics.py` run in subprocesses, never for
the tests or CI themselves.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Sequence

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.store import NUMERIC_VARS

_NO_AVX = "AVX512_SKX,AVX512_COMMON,AVX512_CLX,AVX512_ICL,AVX512_CNL,AVX2,FMA3"
ENVIRONMENTS: dict[str, dict[str, str]] = {
    "default": {},  # the machine's own choice (every variable of store.NUMERIC_VARS unset)
    "openblas-haswell": {"OPENBLAS_CORETYPE": "Haswell"},
    "openblas-sandybridge": {"OPENBLAS_CORETYPE": "Sandybridge"},
    "opencv-no-avx2": {"OPENCV_CPU_DISABLE": _NO_AVX},
    "numba-generic": {"NUMBA_CPU_NAME": "generic"},
}


def check_names(names: Sequence[str]) -> list[str]:
    """`names` (or every environment for ["all"]); HarnessError naming the known ones otherwise."""
    if list(names) == ["all"]:
        return list(ENVIRONMENTS)
    bad = [n for n in names if n not in ENVIRONMENTS]
    if bad:
        raise HarnessError(f"unknown numeric environment {bad[0]!r}; known: {', '.join(ENVIRONMENTS)}, all")
    return list(names)


def environ(name: str) -> dict[str, str]:
    """This process's environment with the numeric variables of environment `name` only."""
    env = {k: v for k, v in os.environ.items() if k not in NUMERIC_VARS}
    env.update(ENVIRONMENTS[name])
    return env


def describe(name: str) -> str:
    return " ".join(f"{k}={v}" for k, v in ENVIRONMENTS[name].items()) or "(machine default)"


def run_in(name: str, argv: Sequence[str], capture: bool = True, timeout: float | None = None,
           cwd: str | None = None) -> subprocess.CompletedProcess:
    """`python argv...` (this interpreter) in numeric environment `name`."""
    return subprocess.run([sys.executable, *argv], env=environ(name), capture_output=capture, text=True,
                          timeout=timeout, cwd=cwd)
