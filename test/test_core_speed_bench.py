# SPDX-License-Identifier: Apache-2.0
"""benchmarks/core_speed.py: the per-stage profile finds the core's functions (and removes its wrappers),
the OpenCV peers run in .venv-bench with the runtime's OpenCV version."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import cv2
import pytest

from swir_tracker_ros.core import features, fhog, kcf

BENCH = Path(__file__).resolve().parent.parent / "benchmarks" / "core_speed.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("core_speed", BENCH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize(("occlusion", "estimator"), [(False, None), (True, None), (False, "dsst")])
def test_profile_covers_the_stages_and_adds_up(bench, occlusion: bool, estimator: str | None) -> None:
    originals = (fhog.fhog, features.fhog, features.sample_patches, kcf.rfft2)
    frames, box = bench.make_frames(8, (24, 72))
    prof = bench.profile_ours(frames, box, occlusion=occlusion, estimator=estimator)
    wanted = ["conditioning", "sampling", "features", "fft/correlation", "peak/PSR analysis", "kalman"]
    wanted += ["phase: grid"] if occlusion else ["phase: scale search", "phase: model update"]
    wanted += ["dsst scale filter"] if estimator == "dsst" else []
    for stage in wanted:
        assert prof.get(stage, 0.0) > 0.0, f"stage {stage!r} not timed: {prof}"
    assert prof["other"] < 0.3 * prof["total"]  # the wrapped stages account for most of the frame
    assert prof["features"] > 0.1 * prof["total"]  # FHOG (compiled) is still one of the main stages
    assert (fhog.fhog, features.fhog, features.sample_patches, kcf.rfft2) == originals  # wrappers removed


def test_opencv_peers_and_primitives_run_in_the_bench_venv(bench) -> None:
    if not bench.BENCH_PY.exists():
        pytest.skip(".venv-bench missing (make bench-venv)")
    frames, box = bench.make_frames(6, (40, 100))
    res = bench.time_opencv(bench.to8bit(frames), box)
    for name in bench.OPENCV_TRACKERS:
        assert res[name]["fps"] > 0 and res[name]["p95_ms"] > 0, res
    prim = bench.run_bench_child("--opencv-primitives")
    assert prim["version"] == cv2.__version__ and prim["dft 128x128 complex"] > 0  # one pin everywhere
