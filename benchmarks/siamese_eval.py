# SPDX-License-Identifier: Apache-2.0
"""Play the Siamese tracker (core/siamese: NanoTrack v2 / v3, LightTrack-M) over sequences and store its runs
in the harness's results directory under the labels `siamese_v2` / `siamese_v3` / `siamese_lighttrack`, beside
the other runs, so that `harness table` scores them with the peers (docs/siamese.md).

Run from the repository root (one OpenCV thread per run; `--jobs` runs sequences in parallel):

    .venv/bin/python benchmarks/siamese_eval.py --versions v2 v3 --protocol ope sre --jobs 2
    .venv/bin/harness table siamese_v2 siamese_v3 nanotrack_v2 nanotrack_v2_ref ecohc_py \
        --on /work/shared/data/sequences --protocol ope sre
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENCV_FOR_THREADS_NUM", "1")  # cv2.setNumThreads(1), inherited by pool workers

import argparse
import sys
from pathlib import Path

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.analysis import DEFAULT_SEQUENCES
from swir_tracker_ros.harness.commands import DEFAULT_RESULTS
from swir_tracker_ros.harness.runner import PROTOCOLS, Player, play, protocol_starts
from swir_tracker_ros.harness.sources import open_source
from swir_tracker_ros.harness.store import RunStore


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sequences", nargs="*", help="sequence folders (default: every one in --data)")
    ap.add_argument("--data", default=str(DEFAULT_SEQUENCES), help="folder of sequence folders")
    ap.add_argument("--versions", nargs="+", default=["v2"],
                    help="networks (core/siamese/params.py VERSIONS: v2, v3, lighttrack)")
    ap.add_argument("--whole-pixel", action="store_true",
                    help="the authors' whole-pixel crops (labels siamese_<v>_wholepixel)")
    ap.add_argument("--protocol", nargs="+", choices=PROTOCOLS, default=["ope"])
    ap.add_argument("--results", default=None,
                    help=f"results directory (default: $SWIR_RESULTS or {DEFAULT_RESULTS})")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--rerun", action="store_true", help="replace stored runs that other code made")
    a = ap.parse_args(argv)
    try:
        paths = [Path(s) for s in a.sequences] or sorted(
            p for p in Path(a.data).iterdir() if (p / "gt.txt").is_file())
        sources = [open_source(p) for p in paths]
        players = [Player.siamese(v, a.whole_pixel) for v in a.versions]
        store = RunStore(a.results or os.environ.get("SWIR_RESULTS") or DEFAULT_RESULTS)
        rep = play(sources, players, protocol_starts(a.protocol), "otb", store, a.jobs, a.rerun,
                   lambda line: print(line, file=sys.stderr, flush=True))
    except HarnessError as exc:
        print(f"siamese_eval: error: {exc}", file=sys.stderr)
        return 2
    print(f"{rep.computed} run(s) played, {rep.reused} reused, {rep.replaced} replaced; in {store.root}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
