# SPDX-License-Identifier: Apache-2.0
"""`demo`: the closed-loop pan-tilt simulation with and without ego-motion compensation, and its report;
`demo sweep`: the same loop over scenes and seeds (`demo.sweep`)."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from pathlib import Path

from swir_tracker_ros.demo import sweep, table
from swir_tracker_ros.demo.config import load_demo_params
from swir_tracker_ros.demo.report import make_plots, text_table, write_reports
from swir_tracker_ros.demo.runner import RUN_DIRS, run_once
from swir_tracker_ros.errors import DemoError
from swir_tracker_ros.scene.demo_scene import VARIANTS


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
        return sweep.main(argv[1:])
    args = parse_args(argv)
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        # Started in the background by a non-interactive shell: SIGINT is ignored and the children would
        # inherit that across exec; restore it so Ctrl-C and the SIGINT stop of every process work.
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        p = load_demo_params(args.params)
        p = p.with_overrides(duration_s=args.duration, scene=args.scene, seed=args.seed,
                             bag_images=True if args.bag_images else None)
    except DemoError as exc:  # bad input: nothing started
        print(f"demo: {exc}", file=sys.stderr)
        return 2
    try:
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
    files["plot: settled centring error"] = "plots/centring_error_settled.png"
    files["plot: head angles"] = "plots/head_angles.png"
    rows = [table.row_from(p.scene, p.seed, r.records.ego_motion_compensation, 1, r.summary, r.folder)
            for r in results]
    paths = write_reports(out, [r.summary for r in results], {
        "sweep_markdown": table.markdown(rows),
        "files": files, "processes": {RUN_DIRS[r.records.ego_motion_compensation]: r.exits for r in results},
        "wall_time_s": time.monotonic() - started, "scene": p.scene, "seed": p.seed,
        "machine": {"cpus": os.cpu_count(), "load_average_start": round(load_before, 2),
                    "load_average_end": round(os.getloadavg()[0], 2)}})
    print(text_table([r.summary for r in results]))
    print("\n" + table.text(rows))
    print(f"[demo] output folder {out}: {_folder_mb(out):.1f} MB")
    print(f"\n[demo] finished in {time.monotonic() - started:.0f} s; load average {load_before:.1f} at the "
          f"start, {os.getloadavg()[0]:.1f} at the end, on {os.cpu_count()} CPUs.")
    print(f"[demo] report: {paths['html']}  (open it in a browser, e.g. `xdg-open {paths['html']}`)")
    print(f"[demo] also: {paths['md']}, {paths['json']}, plots in {out / 'plots'}")
    status, why = table.exit_status(rows)
    if status:
        print(f"demo: {why}", file=sys.stderr)
    return status


if __name__ == "__main__":
    sys.exit(main())
