# SPDX-License-Identifier: Apache-2.0
"""Shared fixtures: paths to ../shared, per-run DDS isolation, installed executables as processes."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from swir_tracker_ros.tracker import Tracker, TrackerParams

REPO = Path(__file__).resolve().parent.parent
SHARED = REPO.parent / "shared"
SEQUENCES = SHARED / "data" / "sequences"
BIN = Path(sys.prefix) / "bin"

# Keep DDS traffic on this host and apart from other runs (set before any rclpy import in a test).
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", str(1 + os.getpid() % 100))


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    assert SHARED.is_dir(), f"../shared not found next to the repository at {SHARED}"
    return SHARED


@pytest.fixture(scope="session")
def sequences_dir(shared_dir: Path) -> Path:
    return shared_dir / "data" / "sequences"


CROSSING_FRAMES = 30  # otb_crossing frames the Siamese and fusion tests track


def _weights(versions: tuple[str, ...], what: str) -> None:
    """Skip, with the ModelError's one line as the reason, unless every file of `versions` is installed."""
    from swir_tracker_ros.core.siamese.network import require
    from swir_tracker_ros.core.siamese.params import VERSIONS
    from swir_tracker_ros.errors import ModelError

    try:
        for v in versions:
            require(VERSIONS[v])
    except ModelError as exc:
        pytest.skip(f"{what} weights not installed ({exc})")


@pytest.fixture(scope="session")
def nanotrack_weights() -> None:
    """Skip (with the reason) when the pinned NanoTrack weights are not installed (`make models`)."""
    _weights(("v2", "v3"), "NanoTrack")


@pytest.fixture(scope="session")
def lighttrack_weights() -> None:
    """Skip (with the reason) when the pinned LightTrack-M weights are not installed (`make models`)."""
    _weights(("lighttrack",), "LightTrack-M")


def skip_without_models(params) -> None:
    """Skip (with the reason) a test of a configuration that needs network weights that are not installed."""
    from swir_tracker_ros.nodes.tracker_node_params import missing_models

    reason = missing_models(params)
    if reason:
        pytest.skip(f"network weights not installed ({reason})")


@pytest.fixture(scope="session")
def crossing_frames(sequences_dir: Path) -> tuple[list, list]:
    """The first CROSSING_FRAMES frames of otb_crossing and their ground-truth boxes."""
    from swir_tracker_ros.harness.sources import frame_files, read_frame, read_gt

    d = sequences_dir / "otb_crossing"
    n = CROSSING_FRAMES
    return [read_frame(f) for f in frame_files(d)[:n]], read_gt(d)[:n]


def executable(name: str) -> str:
    """Path of an installed console script (the venv's bin, as `ros2 run` would find lib/<pkg>/<name>)."""
    path = BIN / name
    assert path.exists(), f"console script {name!r} is not installed in {BIN}; run `make venv`"
    return str(path)


class ProcessSet:
    """Starts installed executables and guarantees they are stopped (SIGINT, then SIGKILL)."""

    def __init__(self, tmp: Path) -> None:
        self.tmp = tmp
        self.procs: list[tuple[subprocess.Popen, Path]] = []

    def start(self, name: str, *args: str, env: dict[str, str] | None = None) -> subprocess.Popen:
        log = self.tmp / f"{name}-{len(self.procs)}.log"
        full_env = dict(os.environ)
        full_env["PYTHONUNBUFFERED"] = "1"
        if env:
            full_env.update(env)
        fh = log.open("wb")
        proc = subprocess.Popen(
            [executable(name), *args], stdout=fh, stderr=subprocess.STDOUT, env=full_env,
            start_new_session=True,
        )
        self.procs.append((proc, log))
        return proc

    def log(self, proc: subprocess.Popen) -> str:
        for p, log in self.procs:
            if p is proc:
                return log.read_text(errors="replace")
        raise KeyError(proc)

    def stop(self, proc: subprocess.Popen, sig: int = signal.SIGINT, timeout: float = 10.0) -> int:
        if proc.poll() is None:
            proc.send_signal(sig)
            try:
                proc.wait(timeout)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(5)
        return proc.returncode

    def stop_all(self) -> None:
        for proc, _ in reversed(self.procs):
            self.stop(proc)


@pytest.fixture
def processes(tmp_path: Path) -> Iterator[ProcessSet]:
    ps = ProcessSet(tmp_path)
    try:
        yield ps
    finally:
        ps.stop_all()


def wait_for(predicate, timeout: float, interval: float = 0.05) -> bool:
    """Poll predicate() until it is truthy or timeout seconds pass."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(interval)
    return bool(predicate())


@contextlib.contextmanager
def ros_probe(probe_cls):
    """Build `probe_cls(context)` in a private rclpy context; tear down its executor, node and context.

    A probe is the test's side of the ROS graph: it owns `node` and `executor` attributes.
    """
    import rclpy
    from rclpy.context import Context

    ctx = Context()
    rclpy.init(context=ctx)
    probe = probe_cls(ctx)
    try:
        yield probe
    finally:
        probe.executor.shutdown()
        probe.node.destroy_node()
        rclpy.try_shutdown(context=ctx)


class SpinningProbe:
    """Base of the process tests' probes: `spin_until` drives the probe's own executor."""

    executor: object

    def spin_until(self, predicate, timeout: float) -> bool:
        """Spin until predicate() is truthy or timeout seconds pass; returns the last predicate value."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if predicate():
                return True
            self.executor.spin_once(timeout_sec=0.02)
        return bool(predicate())


@pytest.fixture
def context():
    """An rclpy context of its own for an in-process node test, shut down afterwards."""
    import rclpy
    from rclpy.context import Context

    ctx = Context()
    rclpy.init(context=ctx)
    try:
        yield ctx
    finally:
        rclpy.try_shutdown(context=ctx)



class RecordingTracker(Tracker):
    """A Tracker that keeps every TrackResult it returned (`results`)."""

    def __init__(self, params: TrackerParams) -> None:
        super().__init__(params)
        self.results: list = []

    def update(self, *args, **kwargs):
        res = super().update(*args, **kwargs)
        self.results.append(res)
        return res
