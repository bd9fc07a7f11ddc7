# SPDX-License-Identifier: Apache-2.0
"""`python -m swir_tracker_ros.scene [NAME] [--frames N]`: render a scenario and print the time per frame."""

from __future__ import annotations

import argparse
import time

from swir_tracker_ros.scene.scenarios import make_scenario, scenarios


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("name", nargs="?", default="t5_partial_full_pan", choices=sorted(scenarios()))
    ap.add_argument("--frames", type=int, default=100)
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    run = make_scenario(a.name)
    build = time.perf_counter() - t0
    n = min(a.frames, run.n_frames)
    run.frame(0)  # sprites and sensor pattern are built lazily on the first frame
    t0 = time.perf_counter()
    for k in range(n):
        run.frame(k)
    per = (time.perf_counter() - t0) / n
    s = run.world.sensor
    print(f"{a.name}: world built in {build:.2f} s; {per * 1e3:.2f} ms per {run.views[0].width}x"
          f"{run.views[0].height} frame over {n} frames ({s.bits}-bit, interlaced={s.interlaced})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
