# SPDX-License-Identifier: Apache-2.0
"""One closed-loop run: start the graph (pelco_sim, positioner_bridge, scene_camera, tracker, supervisor),
record the scene, stop every process, score the records."""

from __future__ import annotations

import os
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from swir_tracker_ros.demo.analysis import RunSummary, summarise
from swir_tracker_ros.demo.config import DemoParams, dds_profile, params_dir
from swir_tracker_ros.demo.processes import ProcessGroup, find_executable, ros_environment, tail
from swir_tracker_ros.demo.recording import RunRecords
from swir_tracker_ros.errors import DemoError
from swir_tracker_ros.scene.demo_scene import build_scene, target_visibility

RUN_DIRS = {True: "ego_on", False: "ego_off"}


@dataclass(frozen=True)
class RunResult:
    """One finished run: its records, scores, folder and how each process ended."""

    records: RunRecords
    summary: RunSummary
    folder: Path
    exits: dict[str, dict[str, object]]


def pty_url(first_line: str) -> str:
    """pelco_sim's first stdout line ('PTY /dev/pts/N' or 'TCP 127.0.0.1:PORT') -> a pyserial port URL."""
    parts = first_line.split()
    if len(parts) == 2 and parts[0] == "PTY":
        return parts[1]
    if len(parts) == 2 and parts[0] == "TCP":
        return f"socket://{parts[1]}"
    raise DemoError(f"pelco_sim announced {first_line!r}, expected 'PTY <path>' or 'TCP <host:port>'")


def domain_for(run_index: int) -> int:
    """A DDS domain per run, away from the 1..100 the test suite uses (ports stay below 65535)."""
    return 101 + (os.getpid() * 2 + run_index) % 120


def _ros_args(params_file: Path | None, overrides: dict[str, object]) -> list[str]:
    args = ["--ros-args"]
    if params_file is not None and params_file.is_file():
        args += ["--params-file", str(params_file)]
    for key, value in overrides.items():
        if isinstance(value, bool):
            text = "true" if value else "false"
        elif isinstance(value, (list, tuple)):
            text = "[" + ", ".join(str(v) for v in value) + "]"
        else:
            text = str(value)
        args += ["-p", f"{key}:={text}"]
    return args


def run_once(p: DemoParams, out: Path, ego: bool, run_index: int, log=print, video: bool = True
             ) -> RunResult:
    """Start the graph, let the supervisor initialise, start and record the scene, stop everything.

    video=False (the sweep): no debug video or stills, so the tracker renders no debug images either.
    """
    folder = out / RUN_DIRS[ego]
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    pdir = params_dir()
    env = ros_environment(domain_for(run_index))
    profile = dds_profile()
    if profile is not None:  # full frames through a large shared-memory segment, not UDP fragments
        env.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(profile))
    group = ProcessGroup(folder / "logs", env)
    tag = f"ego-motion compensation {'ON' if ego else 'OFF'}"
    log(f"[demo] run {run_index + 1}: scene {p.scene} seed {p.seed}, {tag}, "
        f"ROS_DOMAIN_ID={env['ROS_DOMAIN_ID']}, folder {folder}")
    supervisor = None
    try:
        trace = folder / "head_trace.csv"
        sim = group.start("pelco_sim", [find_executable("pelco_sim"), "--trace", str(trace),
                                        *p.pelco_sim_args], capture_first_line=True)
        port = pty_url(group.first_line(sim, timeout=20.0))
        group.start("positioner_bridge", [find_executable("positioner_bridge"),
                                          *_ros_args(pdir / "positioner.yaml",
                                                     {**p.positioner_overrides, "port": port})])
        group.start("scene_camera", [find_executable("scene_camera"), *_ros_args(
            pdir / "scene_camera.yaml", {**p.scene_camera_overrides, "autostart": False, "scene": p.scene,
                                         "seed": p.seed, "duration_s": p.duration_s + 5.0})],
                    nice=p.sim_nice)
        group.start("tracker", [find_executable("tracker"), *_ros_args(
            pdir / "tracker.yaml", {**p.tracker_overrides, "ego_motion_compensation": ego})])
        supervisor = group.start("demo_supervisor", [
            sys.executable, "-m", "swir_tracker_ros.demo.supervisor_node", "--out", str(folder),
            "--duration", str(p.duration_s), "--label", p.scene, "--ego", str(int(ego)),
            "--storage", p.storage, "--bag-images", str(int(p.bag_images)),
            "--startup-timeout", str(p.startup_timeout_s), "--video", str(int(video)),
            "--snapshots", *([str(s) for s in p.snapshots] if video else [])], nice=p.sim_nice)
        deadline = time.monotonic() + p.startup_timeout_s + p.duration_s + 30.0
        while supervisor.proc.poll() is None:
            dead = [m for m in group.dead() if m is not supervisor]
            if dead:
                raise DemoError(f"{dead[0].name} exited early with code {dead[0].proc.returncode}:\n"
                                f"{tail(dead[0].log)}")
            if time.monotonic() > deadline:
                raise DemoError(f"the run did not finish in time; see {supervisor.log}")
            time.sleep(0.2)
        if supervisor.proc.returncode != 0:
            raise DemoError(f"demo_supervisor exited with code {supervisor.proc.returncode}:\n"
                            f"{tail(supervisor.log)}")
    finally:
        exits = group.stop_all()  # the supervisor first: it writes its records when interrupted
    records = RunRecords.load(folder / "records.json")
    exits.get("demo_supervisor", {})["cpu_s"] = round(records.supervisor_cpu_s, 2)
    unclean = {n: e for n, e in exits.items() if e["how"] not in ("exited", "sigint") or e["returncode"] != 0}
    if unclean:
        log(f"[demo] processes that did not exit cleanly on SIGINT: {unclean}")
    scene = build_scene(p.scene, p.seed)
    return RunResult(records, summarise(records, lambda times: target_visibility(scene, list(times))), folder,
                     exits)
