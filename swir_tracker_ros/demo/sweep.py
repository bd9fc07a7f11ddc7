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
from dataclasses import asdict, dataclass, field
from pathlib import Path

from swir_tracker_ros.demo.analysis import RunSummary
from swir_tracker_ros.demo.config import load_demo_params
from swir_tracker_ros.errors import DemoError
from swir_tracker_ros.scene.demo_scene import VARIANTS

# A run succeeds when the target is in view at the end and for at least this share of the run, and the
# tracker never reported `tracking` off the target (issue 13's "done when").
SUCCESS_IN_VIEW = 0.95


def succeeded(s: RunSummary) -> bool:
    """In view at the end and >= SUCCESS_IN_VIEW of the time, 0 false-tracking frames, run completed."""
    return (s.outcome == "completed" and s.in_view_at_end and s.in_view_fraction >= SUCCESS_IN_VIEW
            and s.false_tracking_frames == 0)


@dataclass
class SweepRow:
    """One run of the sweep: which scene and seed, its scores, the machine's load while it ran."""

    scene: str
    seed: int
    ego: bool
    repeat: int
    summary: dict
    success: bool
    load_average: float  # 1-minute load average at the end of the run
    folder: str
    cpu_s: dict = field(default_factory=dict)  # CPU seconds of each process of the run


COLUMNS = (
    ("scene", lambda r: r.scene),
    ("seed", lambda r: str(r.seed)),
    ("ego", lambda r: "on" if r.ego else "off"),
    ("in view", lambda r: f"{r.summary['in_view_fraction']:.1%}"),
    ("at end", lambda r: "yes" if r.summary["in_view_at_end"] else "NO"),
    ("centring err mean/p95 deg", lambda r: f"{r.summary['centring_error_mean_deg']:.2f} / "
                                            f"{r.summary['centring_error_p95_deg']:.2f}"),
    ("occl. survived", lambda r: f"{r.summary['occlusions_survived']}/{r.summary['occlusions']}"),
    ("false-tracking frames", lambda r: str(r.summary["false_tracking_frames"])),
    ("lost frames", lambda r: str(r.summary["lost_frames"])),
    ("camera / tracker fps", lambda r: f"{r.summary['camera_fps']:.1f} / {r.summary['tracker_fps']:.1f}"),
    ("frames skipped", lambda r: f"{r.summary['frames_skipped']}/{r.summary['frames']}"),
    ("final state", lambda r: r.summary["final_state"]),
    ("load", lambda r: f"{r.load_average:.1f}"),
    ("success", lambda r: "yes" if r.success else "NO"),
)


def table_rows(rows: list[SweepRow]) -> list[list[str]]:
    """Header plus one row per run (the sweep table)."""
    return [[c for c, _ in COLUMNS], *[[fn(r) for _, fn in COLUMNS] for r in rows]]


def success_lines(rows: list[SweepRow]) -> list[str]:
    """Success rate per scene and over all runs."""
    lines = []
    for scene in dict.fromkeys(r.scene for r in rows):
        mine = [r for r in rows if r.scene == scene]
        lines.append(f"{scene}: {sum(r.success for r in mine)} of {len(mine)} runs succeeded")
    if len({r.scene for r in rows}) > 1:
        lines.append(f"all: {sum(r.success for r in rows)} of {len(rows)} runs succeeded")
    return lines


def markdown(rows: list[SweepRow]) -> str:
    t = table_rows(rows)
    out = ["| " + " | ".join(t[0]) + " |", "|" + "---|" * len(t[0])]
    out += ["| " + " | ".join(r) + " |" for r in t[1:]]
    return "\n".join(out + [""] + [f"- {line}" for line in success_lines(rows)])


def text(rows: list[SweepRow]) -> str:
    t = table_rows(rows)
    widths = [max(len(r[i]) for r in t) for i in range(len(t[0]))]
    body = "\n".join("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in t)
    return body + "\n" + "\n".join(success_lines(rows))


def row_from(scene: str, seed: int, ego: bool, repeat: int, summary: RunSummary, folder: Path,
             exits: dict | None = None) -> SweepRow:
    cpu = {name: e.get("cpu_s") for name, e in (exits or {}).items()}
    return SweepRow(scene, seed, ego, repeat, summary.as_dict(), succeeded(summary), os.getloadavg()[0],
                    str(folder), cpu)


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
    from swir_tracker_ros.demo.analysis import summarise
    from swir_tracker_ros.demo.run import run_once
    from swir_tracker_ros.scene.demo_scene import build_scene, target_visibility

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
                    continue
                from swir_tracker_ros.demo.recording import RunRecords

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
        print("demo sweep: interrupted", file=sys.stderr)
    finally:
        if load is not None:
            load.__exit__(None, None, None)
    if not rows:
        print("demo sweep: no run finished", file=sys.stderr)
        return 1
    paths = _write(out, rows, load_before, args.load, time.monotonic() - started)
    print(text(rows))
    print(f"\n[sweep] {len(rows)} runs in {time.monotonic() - started:.0f} s; load average "
          f"{load_before:.1f} at the start, {os.getloadavg()[0]:.1f} at the end, on {os.cpu_count()} CPUs"
          + (" (plus the sweep's own background load)" if args.load else ""))
    print(f"[sweep] table: {paths[0]}, data: {paths[1]}")
    return 0 if all(r.success for r in rows) else 1


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
