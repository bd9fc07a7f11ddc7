# SPDX-License-Identifier: Apache-2.0
"""`colcon build` of the package into a temporary prefix: ament index, share files, executables that start."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import REPO, wait_for

PKG = "swir_tracker_ros"
COLCON = Path(sys.prefix) / "bin" / "colcon"


IFACES = "swir_tracker_interfaces"


@pytest.fixture(scope="module")
def prefix(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Install prefix of the package after an isolated (default) colcon build outside the source tree, of
    both packages as the README says (the nested interface package is a base path of its own: colcon's crawl
    stops at the repository root's package.xml). The venv stands in for /opt/ros/jazzy (`make venv` fixed
    its CMake exports, swir_tracker_interfaces/build_in_venv.py)."""
    assert COLCON.exists(), f"colcon is not installed in {sys.prefix}; run `make venv`"
    ws = tmp_path_factory.mktemp("colcon")
    env = dict(os.environ, AMENT_PREFIX_PATH=sys.prefix, CMAKE_PREFIX_PATH=sys.prefix,
               PATH=f"{Path(sys.prefix) / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}")
    proc = subprocess.run(
        [str(COLCON), "--log-base", str(ws / "log"), "build", "--base-paths", str(REPO), str(REPO / IFACES),
         "--build-base", str(ws / "build"), "--install-base", str(ws / "install"),
         "--cmake-args", f"-DPython3_EXECUTABLE={sys.executable}", "-DBUILD_TESTING=OFF"],
        cwd=ws, capture_output=True, text=True, timeout=600, env=env)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert f"Finished <<< {IFACES}" in proc.stdout and f"Finished <<< {PKG}" in proc.stdout, proc.stdout
    return ws / "install" / PKG


def installed_env(prefix: Path) -> dict[str, str]:
    """What `source install/setup.bash` provides for both packages: their site-packages first on the path,
    the interface package's type-support libraries on the library path."""
    env = dict(os.environ)
    ifaces = prefix.parent / IFACES
    sites = [str(next((p / "lib").glob("python3*/site-packages"))) for p in (prefix, ifaces)]
    env["PYTHONPATH"] = os.pathsep.join([*sites, env.get("PYTHONPATH", "")])
    env["LD_LIBRARY_PATH"] = os.pathsep.join([str(ifaces / "lib"), env.get("LD_LIBRARY_PATH", "")])
    env["AMENT_PREFIX_PATH"] = os.pathsep.join([str(prefix), str(ifaces)])
    env["PYTHONUNBUFFERED"] = "1"
    return env


def test_install_layout(prefix: Path) -> None:
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / PKG).is_file()
    assert (prefix / "share" / PKG / "package.xml").read_text() == (REPO / "package.xml").read_text()
    params = sorted(p.name for p in (prefix / "share" / PKG / "params").glob("*.yaml"))
    assert "tracker.yaml" in params
    assert params == sorted(p.name for p in (REPO / "params").glob("*.yaml"))
    for exe in ("tracker", "positioner_bridge"):
        path = prefix / "lib" / PKG / exe
        assert path.is_file() and os.access(path, os.X_OK), path
    assert (prefix / "share" / PKG / "launch" / "bringup.launch.py").is_file()
    assert (prefix / "share" / PKG / "urdf" / "swir_head.urdf.template").is_file()  # bring-up fills it
    assert (prefix / "share" / PKG / "config" / "fastdds_shm_udp.xml").is_file()
    ifaces = prefix.parent / IFACES
    assert (ifaces / "share" / IFACES / "srv" / "SelectTarget.srv").is_file()
    assert (ifaces / "share" / "ament_index" / "resource_index" / "packages" / IFACES).is_file()


def test_installed_interfaces_import_from_the_install(prefix: Path) -> None:
    code = ("import swir_tracker_interfaces; from swir_tracker_interfaces.srv import SelectTarget; "
            "from swir_tracker_interfaces.msg import TrackState; "
            "print(swir_tracker_interfaces.__file__, SelectTarget.Response.STAMP_TOO_OLD, TrackState.LOST)")
    out = subprocess.run([sys.executable, "-c", code], env=installed_env(prefix), capture_output=True,
                         text=True, timeout=60, cwd=prefix)
    assert out.returncode == 0, out.stderr
    where, too_old, lost = out.stdout.split()
    assert where.startswith(str(prefix.parent / IFACES)) and (too_old, lost) == ("2", "3"), out.stdout


def test_installed_tracker_prints_help_from_the_install(prefix: Path) -> None:
    env = installed_env(prefix)
    out = subprocess.run([str(prefix / "lib" / PKG / "tracker"), "--help"], env=env, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert "tracker.configuration" in out.stdout and "image_topic" in out.stdout
    code = "import swir_tracker_ros; print(swir_tracker_ros.__file__)"
    where = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60,
                           cwd=prefix)  # not the source tree, which `python -c` would put first on sys.path
    assert where.stdout.strip().startswith(str(prefix)), where.stdout


def test_installed_tracker_starts_with_its_params_and_stops_on_sigint(prefix: Path, tmp_path: Path) -> None:
    log = tmp_path / "tracker.log"
    params = prefix / "share" / PKG / "params" / "tracker.yaml"
    with log.open("wb") as fh:
        cmd = [str(prefix / "lib" / PKG / "tracker"), "--ros-args", "--params-file", str(params)]
        proc = subprocess.Popen(cmd, env=installed_env(prefix), stdout=fh, stderr=subprocess.STDOUT,
                                start_new_session=True, cwd=tmp_path)
    try:
        assert wait_for(lambda: "tracking /camera/image_raw" in log.read_text(errors="replace")
                        or proc.poll() is not None, 60.0)
        assert proc.poll() is None, log.read_text(errors="replace")
        proc.send_signal(signal.SIGINT)
        assert proc.wait(20) == 0, log.read_text(errors="replace")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(5)
