# SPDX-License-Identifier: Apache-2.0
"""`demo`: the closed-loop pan-tilt simulation with and without ego-motion compensation, and its report."""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from swir_tracker_ros.demo.analysis import RunSummary, summarise
from swir_tracker_ros.demo.config import DemoParams, dds_profile, load_demo_params, params_dir
from swir_tracker_ros.demo.processes import ProcessGroup, find_executable, ros_environment, tail
from swir_tracker_ros.demo.recording import RunRecords
from swir_tracker_ros.demo.report import make_plots, text_table, write_reports
from swir_tracker_ros.errors import DemoError
from swir_tracker_ros.scene.demo_scene import VARIANTS, build_scene, target_visibility

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


def _folder_mb(path: Path) -> float:
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file()) / 1e6


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="demo", description=__doc__)
    ap.add_argument("--out", type=Path, default=Path("out/demo"), help="output folder (default out/demo)")
    ap.add_argument("--duration", type=float, default=None, help="seconds of scene per run (default: "
                    "params/demo.yaml, the whole scene)")
    ap.add_argument("--no-ego-compare", action="store_true",
                    help="only the run with ego-motion compensation")
    ap.add_argument("--params", type=Path, default=None,
                    help="demo parameters YAML (default params/demo.yaml)")
    ap.add_argument("--scene", default=None, help=f"scene (default: params/demo.yaml): {', '.join(VARIANTS)} "
                    "or a harness scenario name")
    ap.add_argument("--seed", type=int, default=None, help="scene seed (default: params/demo.yaml)")
    ap.add_argument("--bag-images", action="store_true",
                    help="record /camera/image_raw in the bag (~14 MB/s; off by default)")
    return ap.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["sweep"]:
        from swir_tracker_ros.demo.sweep import main as sweep_main

        return sweep_main(argv[1:])
    args = parse_args(argv)
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        # Started in the background by a non-interactive shell: SIGINT is ignored and the children would
        # inherit that across exec; restore it so Ctrl-C and the SIGINT stop of every process work.
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        p = load_demo_params(args.params)
        p = p.with_overrides(duration_s=args.duration, scene=args.scene, seed=args.seed,
                             bag_images=True if args.bag_images else None)
        out = args.out.resolve()
        out.mkdir(parents=True, exist_ok=True)
        started = time.monotonic()
        load_before = os.getloadavg()[0]
        results = [run_once(p, out, ego, i) for i, ego in enumerate([True] if args.no_ego_compare else
                                                                    [True, False])]
    except DemoError as exc:
        print(f"demo: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("demo: interrupted; every process was stopped", file=sys.stderr)
        return 130
    runs = [(r.records, r.summary) for r in results]
    make_plots(out, runs, [r.folder / "head_trace.csv" for r in results])
    files: dict[str, str] = {}
    for r in results:
        name = RUN_DIRS[r.records.ego_motion_compensation]
        if r.records.video:
            files[f"debug video ({name})"] = os.path.relpath(r.records.video, out)
        if r.records.bag:
            files[f"rosbag2 ({name})"] = os.path.relpath(r.records.bag, out)
        for still in sorted(r.folder.glob("frame_*.png")):
            files[f"debug frame {still.stem} ({name})"] = os.path.relpath(still, out)
    files["plot: centring error"] = "plots/centring_error.png"
    files["plot: head angles"] = "plots/head_angles.png"
    from swir_tracker_ros.demo import sweep

    rows = [sweep.row_from(p.scene, p.seed, r.records.ego_motion_compensation, 1, r.summary, r.folder)
            for r in results]
    paths = write_reports(out, [r.summary for r in results], {
        "sweep_markdown": sweep.markdown(rows),
        "files": files, "processes": {RUN_DIRS[r.records.ego_motion_compensation]: r.exits for r in results},
        "wall_time_s": time.monotonic() - started, "scene": p.scene, "seed": p.seed,
        "machine": {"cpus": os.cpu_count(), "load_average_start": round(load_before, 2),
                    "load_average_end": round(os.getloadavg()[0], 2)}})
    print(text_table([r.summary for r in results]))
    print("\n" + sweep.text(rows))
    print(f"[demo] output folder {out}: {_folder_mb(out):.1f} MB")
    print(f"\n[demo] finished in {time.monotonic() - started:.0f} s; load average {load_before:.1f} at the "
          f"start, {os.getloadavg()[0]:.1f} at the end, on {os.cpu_count()} CPUs.")
    print(f"[demo] report: {paths['html']}  (open it in a browser, e.g. `xdg-open {paths['html']}`)")
    print(f"[demo] also: {paths['md']}, {paths['json']}, plots in {out / 'plots'}")
    ok = all(r.records.outcome == "completed" for r in results)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
