# SPDX-License-Identifier: Apache-2.0
"""Where the pinned network weights are at run time, checked once per process against their sha256.

Search order: an explicit `model_dir`, else `$SWIR_TRACKER_MODELS`, else `<sys.prefix>/share/swir_tracker_ros/
models` (what `make models` fills in the venv), else the package's share directory of a colcon install
(ament_index, when importable). A missing or corrupt file is one `ModelError` naming the file, `make models`,
the variable and the upstream URL, raised when the tracker (or a configuration that needs a network) is
built, never mid-run.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from swir_tracker_ros.core.siamese.int8 import MADE_PINNED, MAKER, made_pin
from swir_tracker_ros.core.siamese.weights import DETECTOR_PINNED, SHARE_SUBDIR, PinnedFile, sha256_of
from swir_tracker_ros.core.siamese.weights import pinned as upstream_pinned
from swir_tracker_ros.errors import ModelError

ENV_VAR = "SWIR_TRACKER_MODELS"


def pinned(rel: str) -> PinnedFile:
    """The pin of `rel`: an upstream file (weights.py) or a made one (int8.py); KeyError if neither."""
    try:
        return upstream_pinned(rel)
    except KeyError:
        return made_pin(rel)


def fix(pin: PinnedFile) -> str:
    """The one fix sentence of a missing or corrupt file: `make models`, the variable, the upstream URL."""
    if pin in MADE_PINNED:
        return (f"run `make models` (makes it from the float head and ../shared/data/sequences: {MAKER}), or "
                f"set {ENV_VAR} to a directory holding it, or use precision float32 (docs/siamese.md)")
    holding, doc = (("detector/", "docs/acquisition.md") if pin in DETECTOR_PINNED
                    else ("v2/, v3/ and lighttrack/", "docs/siamese.md"))
    return (f"run `make models` (copies ../shared/models or fetches the pinned upstream {pin.source.page}), "
            f"or set {ENV_VAR} to a directory holding {holding} ({doc})")

_verified: dict[Path, str] = {}  # resolved file -> sha256 seen (a file is hashed once per process)


def _ament_dir() -> Path | None:
    try:
        from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
    except ImportError:
        return None
    try:
        return Path(get_package_share_directory("swir_tracker_ros")).joinpath(*SHARE_SUBDIR[2:])
    except (PackageNotFoundError, OSError, ValueError, LookupError):  # no ament environment
        return None


def candidate_dirs(model_dir: str | Path | None = None) -> list[Path]:
    """The directories searched, in order (module docstring); an explicit `model_dir` is the only one."""
    if model_dir:
        return [Path(model_dir)]
    env = os.environ.get(ENV_VAR)
    if env:
        return [Path(env)]
    out = [Path(sys.prefix).joinpath(*SHARE_SUBDIR)]
    ament = _ament_dir()
    if ament is not None and ament not in out:
        out.append(ament)
    return out


def verify(path: Path, rel: str) -> Path:
    """`path` if it holds the pinned content of `rel` (hashed once per process), else ModelError."""
    try:
        pin = pinned(rel)
    except KeyError:
        raise ModelError(f"{rel} is not a pinned model file (core/siamese/weights.py)") from None
    if not path.is_file():
        raise ModelError(f"model file {path} is missing: {fix(pin)}")
    key = path.resolve()
    stamp = f"{key.stat().st_size}:{key.stat().st_mtime_ns}"
    if _verified.get(key) == stamp:
        return path
    got = sha256_of(path)
    if got != pin.sha256:
        raise ModelError(f"model file {path} is corrupt (sha256 {got[:12]}..., pinned {pin.sha256[:12]}...): "
                         f"{fix(pin)}")
    _verified[key] = stamp
    return path


def locate(rel: str, model_dir: str | Path | None = None) -> Path:
    """The verified path of pinned file `rel` (e.g. "v2/nanotrack_head_sim.onnx"): in the first candidate
    directory that has it (`candidate_dirs`); ModelError naming the file and the fix otherwise."""
    dirs = candidate_dirs(model_dir)
    for d in dirs:
        if (d / rel).is_file():
            return verify(d / rel, rel)
    looked = ", ".join(str(d) for d in dirs)
    try:
        pin = pinned(rel)
    except KeyError:
        raise ModelError(f"{rel} is not a pinned model file (core/siamese/weights.py)") from None
    raise ModelError(f"model file {rel} is missing (looked in {looked}): {fix(pin)}")
