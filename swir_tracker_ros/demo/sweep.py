# SPDX-License-Identifier: Apache-2.0
"""`demo sweep`: the closed loop over seeds x scenes, headless, optionally on a loaded machine; one table."""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from dataclasses import asdict
from pathlib import Path

from swir_tracker_ros.demo.analysis import summarise
from swir_tracker_ros.demo.config import load_demo_params
from swir_tracker_ros.demo.recording import RunRecords
from swir_tracker_ros.demo.runner import run_once
from swir_tracker_ros.demo.table import (
    SUCCESS_IN_VIEW,
    SweepRow,
    exit_status,
    markdown,
    row_from,
    run_name,
    text,
)
from swir_tracker_ros.errors import DemoError
from swir_tracker_ros.scene.demo_scene import VARIANTS, build_scene, target_visibility


class BackgroundLoad:
    """One busy process per CPU (a Python spin loop), started on entry and stopped by its pid on exit."""

    def __init__(self, processes: int) -> None:
        self.n = processes
        self.procs: list[subprocess.Popen] = []

    def __enter__(self) -> BackgroundLoad:
        for _ in range(self.n):
            self.procs.append(subprocess.Popen([sys.executable, "-c", "while True: pass"],
                                               stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL))
        return self

    def __exit__(self, *_exc) -> None:
        for p in self.procs:
            p.kill()
        for p in self.procs:
            p.wait(5.0)
        self.procs = []


def parse_seeds(text_: str) -> list[int]:
    """'10' -> seeds 1..10; '7,11,23' -> those seeds."""
    parts = [p for p in text_.split(",") if p.strip()]
    try:
        values = [int(p) for p in parts]
    except ValueError as exc:
        raise DemoError(f"--seeds wants a count or a comma-separated list of seeds, got {text_!r}") from exc
    if len(values) == 1 and "," not in text_:
        return list(range(1, values[0] + 1))
    return values


def parse_args(argv: list[str]) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="demo sweep", description=__doc__)
    ap.add_argument("--out", type=Path, default=Path("out/sweep"), help="output folder (default out/sweep)")
    ap.add_argument("--scenes", default="demo", help="comma-separated scenes, or 'all' for the demo family "
                    f"({', '.join(VARIANTS)}); default demo")
    ap.add_argument("--seeds", default="10", help="a count N (seeds 1..N) or a list '7,11,23'; default 10")
    ap.add_argument("--repeat", type=int, default=1, help="runs of each (scene, seed); >1 measures how "
                    "repeatable the closed loop is")
    ap.add_argument("--load", action="store_true", help="one busy process per CPU while the sweep runs")
    ap.add_argument("--ego-off", action="store_true", help="also run each without ego-motion compensation")
    ap.add_argument("--duration", type=float, default=None, help="seconds of scene per run")
    ap.add_argument("--params", type=Path, default=None, help="demo parameters YAML")
    return ap.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    try:
        base = load_demo_params(args.params).with_overrides(duration_s=args.duration, bag_images=False)
        scenes = list(VARIANTS) if args.scenes == "all" else [s for s in args.scenes.split(",") if s]
        for scene in scenes:
            base.with_overrides(scene=scene)  # validates the name before anything starts
        seeds = parse_seeds(args.seeds)
    except DemoError as exc:
        print(f"demo sweep: {exc}", file=sys.stderr)
        return 2
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    started, load_before = time.monotonic(), os.getloadavg()[0]
    rows: list[SweepRow] = []
    unfinished: list[str] = []  # runs that left no records: failed, named with their error
    interrupted = False
    plan = [(scene, seed, k, ego) for scene in scenes for seed in seeds for k in range(args.repeat)
            for ego in ((True, False) if args.ego_off else (True,))]
    load = BackgroundLoad(os.cpu_count() or 1) if args.load else None
    try:
        if load is not None:
            load.__enter__()
            print(f"[sweep] background load: {load.n} busy processes (pids "
                  f"{', '.join(str(p.pid) for p in load.procs)})")
        for i, (scene, seed, k, ego) in enumerate(plan):
            p = base.with_overrides(scene=scene, seed=seed)
            folder = out / (f"{scene}_s{seed}" + (f"_r{k + 1}" if args.repeat > 1 else ""))
            try:
                result = run_once(p, folder, ego, i, video=False)
                summary, exits = result.summary, result.exits
            except DemoError as exc:
                print(f"[sweep] {scene} seed {seed}: {exc}", file=sys.stderr)
                rec_path = folder / ("ego_on" if ego else "ego_off") / "records.json"
                if not rec_path.is_file():
                    first = str(exc).splitlines()[0].rstrip(":") if str(exc) else type(exc).__name__
                    unfinished.append(f"{run_name(scene, seed, ego, k + 1)} (did not finish: {first})")
                    continue
                scene_built = build_scene(scene, seed)
                exits = {}
                summary = summarise(RunRecords.load(rec_path),
                                    lambda times, b=scene_built: target_visibility(b, list(times)))
            rows.append(row_from(scene, seed, ego, k + 1, summary, folder, exits))
            r = rows[-1].summary
            print(f"[sweep] {i + 1}/{len(plan)} {scene} seed {seed}: in view {r['in_view_fraction']:.1%}, "
                  f"at end {r['in_view_at_end']}, false tracking {r['false_tracking_frames']}, "
                  f"{'success' if rows[-1].success else 'FAILED'}", flush=True)
            _write(out, rows, load_before, args.load, time.monotonic() - started)
    except KeyboardInterrupt:
        interrupted = True
        print("demo sweep: interrupted", file=sys.stderr)
    finally:
        if load is not None:
            load.__exit__(None, None, None)
    if not rows:
        print("demo sweep: no run finished" + (f": {', '.join(unfinished)}" if unfinished else ""),
              file=sys.stderr)
        return 130 if interrupted else 1
    paths = _write(out, rows, load_before, args.load, time.monotonic() - started)
    print(text(rows))
    print(f"\n[sweep] {len(rows)} runs in {time.monotonic() - started:.0f} s; load average "
          f"{load_before:.1f} at the start, {os.getloadavg()[0]:.1f} at the end, on {os.cpu_count()} CPUs"
          + (" (plus the sweep's own background load)" if args.load else ""))
    print(f"[sweep] table: {paths[0]}, data: {paths[1]}")
    status, why = exit_status(rows, unfinished)
    if status:
        print(f"demo sweep: {why}", file=sys.stderr)
    return 130 if interrupted else status


def _write(out: Path, rows: list[SweepRow], load_before: float, loaded: bool, wall_s: float
           ) -> tuple[Path, Path]:
    """sweep.md (the table) and sweep.json (every run's full summary), rewritten after each run."""
    loads = [r.load_average for r in rows]
    machine = {"cpus": os.cpu_count(), "load_average_start": round(load_before, 2),
               "load_average_mean_end_of_runs": round(sum(loads) / len(loads), 2) if loads else math.nan,
               "background_load": loaded, "wall_time_s": round(wall_s, 1)}
    md = out / "sweep.md"
    md.write_text("# Closed-loop demo sweep\n\n" + markdown(rows) + "\n\n"
                  f"Machine: {machine['cpus']} CPUs, load average {machine['load_average_start']} at the "
                  "start, "
                  f"{machine['load_average_mean_end_of_runs']} on average at the end of the runs"
                  + ("; with one busy process per CPU" if loaded else "") + ".\n")
    js = out / "sweep.json"
    js.write_text(json.dumps({"machine": machine, "success_in_view": SUCCESS_IN_VIEW,
                              "runs": [asdict(r) for r in rows]}, indent=1, default=str))
    return md, js


if __name__ == "__main__":
    sys.exit(main())
