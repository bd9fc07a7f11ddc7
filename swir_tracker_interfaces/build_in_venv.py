# SPDX-License-Identifier: Apache-2.0
"""Build swir_tracker_interfaces with colcon into a venv's own prefix (`make venv` runs this).

The ROS 2 Jazzy wheels install into the venv as an ament prefix, but their CMake export files name the wheel
builder's Python and numpy include folders; CMake refuses to configure until those point at this venv's
(../shared/reference/notes/ros2-interfaces-from-wheels.md). The replacement is repeated on every run, as a
reinstalled message wheel undoes it. The package is then built with `--merge-install --install-base <venv>`,
so the generated Python types import from the venv with nothing sourced.

usage: <venv>/bin/python swir_tracker_interfaces/build_in_venv.py [--build-base DIR]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import sysconfig
from pathlib import Path

import numpy

HERE = Path(__file__).resolve().parent
BUILDER_PYTHON = re.compile(r"/opt/python/cp3\d+-cp3\d+/include/python3\.\d+")
BUILDER_NUMPY = re.compile(r"/opt/python/cp3\d+-cp3\d+/lib/python3\.\d+/site-packages/numpy/_core/include")


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
    ap.add_argument("--build-base", default=str(HERE.parent / "build" / "interfaces"))
    a = ap.parse_args()
    prefix = Path(sys.prefix)
    fix_cmake_exports(prefix)
    env = dict(os.environ)
    env["AMENT_PREFIX_PATH"] = str(prefix)
    env["CMAKE_PREFIX_PATH"] = str(prefix)
    env["PATH"] = f"{prefix / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    build = Path(a.build_base)
    cmd = [str(prefix / "bin" / "colcon"), "--log-base", str(build / "log"), "build", "--merge-install",
           "--paths", str(HERE), "--build-base", str(build / "build"), "--install-base", str(prefix),
           "--cmake-args", f"-DPython3_EXECUTABLE={sys.executable}", "-DBUILD_TESTING=OFF"]
    proc = subprocess.run(cmd, env=env, cwd=HERE.parent, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.stderr.write(proc.stdout[-4000:] + proc.stderr[-4000:])
        sys.stderr.write(f"\nswir_tracker_interfaces: colcon build failed (logs in {build / 'log'})\n")
    return proc.returncode


if __name__ == "__main__":
    raise SystemExit(main())
