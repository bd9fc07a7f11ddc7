# SPDX-License-Identifier: Apache-2.0
"""The pinned NanoTrack weights (upstream commit, paths, sha256) and the fetch/verify step of `make models`.

The ONNX files are a dependency like a wheel, never repository content: `make models` runs this file as a
script (standard library only, so it runs before anything is installed) to put them under
`<venv>/share/swir_tracker_ros/models/nanotrack/{v2,v3}/`, copied from a local mirror (`../shared/models/
nanotrack`) when there is one, else downloaded from the upstream repository at the pinned commit; both are
checked against the sha256 below. Weights: NanoTrack (HonglinChu/SiamTrackers, Apache-2.0).

    python swir_tracker_ros/core/siamese/weights.py --dest DIR [--mirror DIR] [--no-download]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import sys
import tempfile
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

UPSTREAM_REPO = "HonglinChu/SiamTrackers"
UPSTREAM_COMMIT = "248663fde6bf7c40190cf10ee396d5662919ecd3"
RAW_URL = "https://raw.githubusercontent.com/{repo}/{commit}/{path}"
LICENSE = "Apache-2.0 (NanoTrack/LICENSE of the upstream repository)"
SHARE_SUBDIR = ("share", "swir_tracker_ros", "models", "nanotrack")  # under a prefix (venv, colcon install)


@dataclass(frozen=True)
class PinnedFile:
    """One model file: its path under the model directory, its path upstream, its sha256."""

    path: str
    upstream: str
    sha256: str


PINNED: tuple[PinnedFile, ...] = (
    PinnedFile("v2/nanotrack_backbone_sim.onnx", "NanoTrack/models/nanotrackv2/nanotrack_backbone_sim.onnx",
               "530bdd0cd00f19afab79a863e71ba71e3312395a5dc9151af675082bdaaa2fc4"),
    PinnedFile("v2/nanotrack_head_sim.onnx", "NanoTrack/models/nanotrackv2/nanotrack_head_sim.onnx",
               "0d8c0637be849f092cc7236cae02e55c8b9455ebe37ba50601d6115db4247cd9"),
    PinnedFile("v3/nanotrack_backbone.onnx", "NanoTrack/models/nanotrackv3/nanotrack_backbone.onnx",
               "50be1320abf9384fd3479ea829f95e244cf3f3838190c5ab60c750fb8c1ce828"),
    PinnedFile("v3/nanotrack_head.onnx", "NanoTrack/models/nanotrackv3/nanotrack_head.onnx",
               "75357903be3f4817c965af16cb5a11fd32b1467f597a408405a98635ac63f61d"),
)


class FetchError(Exception):
    """A model file could not be copied or downloaded, or its content is not the pinned one."""


def pinned(path: str) -> PinnedFile:
    """The pin of `path` (e.g. "v2/nanotrack_head_sim.onnx"); KeyError if it is not pinned."""
    for f in PINNED:
        if f.path == path:
            return f
    raise KeyError(path)


def sha256_of(path: Path) -> str:
    """Hex sha256 of a file's bytes."""
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def url_of(f: PinnedFile) -> str:
    """The raw URL of a pinned file at the pinned commit."""
    return RAW_URL.format(repo=UPSTREAM_REPO, commit=UPSTREAM_COMMIT, path=f.upstream)


def download(url: str, out: Path, timeout: float = 60.0) -> None:
    """Write the bytes at `url` to `out` (the default fetcher)."""
    with urllib.request.urlopen(url, timeout=timeout) as resp, out.open("wb") as fh:
        shutil.copyfileobj(resp, fh)


def _place(f: PinnedFile, dest: Path, mirror: Path | None, fetch: Callable[[str, Path], None] | None) -> str:
    """Put one file in place (atomically, verified); returns where it came from."""
    target = dest / f.path
    if target.is_file() and sha256_of(target) == f.sha256:
        return "present"
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(dir=target.parent, suffix=".part")
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        src = mirror / f.path if mirror is not None else None
        if src is not None and src.is_file():
            shutil.copyfile(src, tmp)
            origin = str(src)
        elif fetch is not None:
            origin = url_of(f)
            try:
                fetch(origin, tmp)
            except OSError as exc:
                raise FetchError(f"{f.path}: download from {origin} failed: {exc}") from None
        else:
            where = f"{mirror} has no {f.path} and " if mirror is not None else ""
            raise FetchError(f"{f.path}: {where}downloading is off")
        got = sha256_of(tmp)
        if got != f.sha256:
            raise FetchError(f"{f.path} from {origin} has sha256 {got}, pinned {f.sha256}")
        os.chmod(tmp, 0o644)  # mkstemp makes it private; a model file is read by everyone
        os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)
    return origin


def fetch_models(dest: Path, mirror: Path | None = None,
                 fetch: Callable[[str, Path], None] | None = download) -> dict[str, str]:
    """Every pinned file under `dest`, verified: already there, else copied from `mirror` when it has the
    file, else fetched with `fetch(url, out)` (None: no download). Returns {path: origin}; FetchError on
    the first file that cannot be put in place with the pinned content."""
    return {f.path: _place(f, Path(dest), mirror, fetch) for f in PINNED}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dest", required=True, help="model directory to fill (…/share/swir_tracker_ros/models/"
                                                  "nanotrack)")
    ap.add_argument("--mirror", default=None, help="local copy to take the files from when present")
    ap.add_argument("--no-download", action="store_true", help="never download (mirror or nothing)")
    a = ap.parse_args(argv)
    mirror = Path(a.mirror) if a.mirror and Path(a.mirror).is_dir() else None
    try:
        done = fetch_models(Path(a.dest), mirror, None if a.no_download else download)
    except FetchError as exc:
        print(f"models: error: {exc}", file=sys.stderr)
        return 1
    for path, origin in done.items():
        print(f"models: {path}: {origin} (sha256 ok)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
