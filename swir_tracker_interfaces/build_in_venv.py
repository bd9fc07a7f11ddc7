# SPDX-License-Identifier: Apache-2.0
"""Build swir_tracker_interfaces, or vision_msgs, with colcon into a venv's own prefix (`make venv`).

The ROS 2 Jazzy wheels install into the venv as an ament prefix, but their CMake export files name the wheel
builder's Python and numpy include folders; CMake refuses to configure until those point at this venv's
(../shared/reference/notes/ros2-interfaces-from-wheels.md). The replacement is repeated on every run, as a
reinstalled message wheel undoes it. The package is then built with `--merge-install --install-base <venv>`,
so the generated Python types import from the venv with nothing sourced.

vision_msgs (Detection2DArray, issue 39) has no PyPI wheel. Its source is the pinned upstream release, tag
4.1.1 (ROS 2 Jazzy's), never a copy in this repository: taken from ../shared/deps/vision_msgs-4.1.1 beside the
repository when that exists (machines without network), else downloaded from GitHub into the build folder.
Either way the files the build reads (CMakeLists.txt, package.xml, msg/*.msg) must hash to VISION_MSGS_DIGEST
before anything is built. On a ROS install vision_msgs is the rosdep key of the same name (package.xml).

usage: <venv>/bin/python swir_tracker_interfaces/build_in_venv.py [vision_msgs] [--build-base DIR]
"""

from __future__ import annotations

import argparse
import hashlib
import io
import os
import re
import subprocess
import sys
import sysconfig
import tarfile
import urllib.request
from pathlib import Path

import numpy

HERE = Path(__file__).resolve().parent
BUILDER_PYTHON = re.compile(r"/opt/python/cp3\d+-cp3\d+/include/python3\.\d+")
BUILDER_NUMPY = re.compile(r"/opt/python/cp3\d+-cp3\d+/lib/python3\.\d+/site-packages/numpy/_core/include")

VISION_MSGS_TAG = "4.1.1"
VISION_MSGS_COMMIT = "e77fa2d97d69abaaa546592892d2d5d16cec9977"  # the tag's commit upstream
VISION_MSGS_URL = f"https://github.com/ros-perception/vision_msgs/archive/{VISION_MSGS_COMMIT}.tar.gz"
VISION_MSGS_LOCAL = HERE.parent.parent / "shared" / "deps" / f"vision_msgs-{VISION_MSGS_TAG}" / "vision_msgs"
# sha256 over "<path>\0<sha256 of the file>\n" of the files the build reads, in `_build_files` order: pins the
# content whatever the archive's compression (GitHub's tarballs of a commit are not byte-stable).
VISION_MSGS_DIGEST = "f910d046fee9822ffafb58f5cb6a05d9452a8d167276d6ce93b6087d68c577b3"


class SourceError(RuntimeError):
    """The vision_msgs source is missing, unreachable or not the pinned release."""


def _build_files(package: Path) -> list[str]:
    return ["CMakeLists.txt", "package.xml", *sorted(p.relative_to(package).as_posix()
                                                     for p in (package / "msg").glob("*.msg"))]


def source_digest(package: Path) -> str:
    """The content digest of an interface package's build files (see VISION_MSGS_DIGEST)."""
    h = hashlib.sha256()
    for name in _build_files(package):
        h.update(name.encode() + b"\0" + hashlib.sha256((package / name).read_bytes()).hexdigest().encode()
                 + b"\n")
    return h.hexdigest()


def vision_msgs_source(build: Path, local: Path = VISION_MSGS_LOCAL, url: str = VISION_MSGS_URL) -> Path:
    """The pinned vision_msgs package folder: `local` when it exists, else `url` extracted under `build`;
    `SourceError` unless its build files match VISION_MSGS_DIGEST."""
    if local.is_dir():
        package = local
    else:
        package = build / "src" / f"vision_msgs-{VISION_MSGS_COMMIT}" / "vision_msgs"
        if not package.is_dir():
            try:
                with urllib.request.urlopen(url, timeout=60) as response:
                    data = response.read()
            except OSError as exc:
                raise SourceError(f"vision_msgs: no {local}, and {url} is unreachable: {exc}") from exc
            with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
                tar.extractall(build / "src", filter="data")
    digest = source_digest(package)
    if digest != VISION_MSGS_DIGEST:
        raise SourceError(f"vision_msgs source {package} is not release {VISION_MSGS_TAG}: content digest "
                          f"{digest}, pinned {VISION_MSGS_DIGEST}")
    return package


def fix_cmake_exports(prefix: Path) -> int:
    """Point the wheels' CMake exports at this interpreter's include folders; returns the files changed."""
    py_inc, np_inc = sysconfig.get_paths()["include"], numpy.get_include()
    changed = 0
    for path in (prefix / "share").glob("*/cmake/*.cmake"):
        text = path.read_text()
        new = BUILDER_NUMPY.sub(np_inc, BUILDER_PYTHON.sub(py_inc, text))
        if new != text:
            path.write_text(new)
            changed += 1
    return changed


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("package", nargs="?", default="swir_tracker_interfaces",
                    choices=("swir_tracker_interfaces", "vision_msgs"))
    ap.add_argument("--build-base", default=None, help="default: build/interfaces (or build/vision_msgs)")
    a = ap.parse_args()
    prefix = Path(sys.prefix)
    vision = a.package == "vision_msgs"
    build = Path(a.build_base or HERE.parent / "build" / ("vision_msgs" if vision else "interfaces"))
    try:
        source = vision_msgs_source(build) if vision else HERE
    except SourceError as exc:
        sys.stderr.write(f"{exc}\n")
        return 1
    fix_cmake_exports(prefix)
    env = dict(os.environ)
    env["AMENT_PREFIX_PATH"] = str(prefix)
    env["CMAKE_PREFIX_PATH"] = str(prefix)
    env["PATH"] = f"{prefix / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    cmd = [str(prefix / "bin" / "colcon"), "--log-base", str(build / "log"), "build", "--merge-install",
           "--paths", str(source), "--build-base", str(build / "build"), "--install-base", str(prefix),
           "--cmake-args", f"-DPython3_EXECUTABLE={sys.executable}", "-DBUILD_TESTING=OFF"]
    proc = subprocess.run(cmd, env=env, cwd=HERE.parent, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.stderr.write(proc.stdout[-4000:] + proc.stderr[-4000:])
        sys.stderr.write(f"\n{a.package}: colcon build failed (logs in {build / 'log'})\n")
    return proc.returncode


if __name__ == "__main__":
    raise SystemExit(main())
