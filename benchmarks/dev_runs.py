# SPDX-License-Identifier: Apache-2.0
"""Store the OPE runs of the development set that the tables and verdicts read (`make dev-runs`).

Plays, on every sequence of the development set (../shared/data/sequences and the built corpus, `harness
--data`; docs/harness.md "Development set"), one tracker after the other, each stored under its label in the
results directory: the network alone (`siamese_v2`, `siamese_v3`, and `siamese_lighttrack` once that
version exists), OpenCV's TrackerNano and CSRT (`opencv_nano`, `opencv_csrt`, in .venv-bench), and our
configurations `measured` (the default), `eco`, `fused`, `siamese`. A run already stored with the same
provenance is taken, not played again; one stored by other code stops the command (`--rerun` replaces it).
Then `harness table` and `harness verdict` score them without playing anything:

    make dev-runs                                   # or: .venv/bin/python benchmarks/dev_runs.py --jobs 1
    .venv/bin/harness table measured siamese_v2 siamese_v3 opencv_nano opencv_csrt eco fused siamese \
        --protocol ope
    .venv/bin/harness verdict measured siamese_v2
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENCV_FOR_THREADS_NUM", "1")  # one OpenCV thread per run (inherited by workers)

import argparse
import sys
import time
from dataclasses import dataclass

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.commands import DEFAULT_RESULTS
from swir_tracker_ros.harness.devset import DEV, data_dirs, sequence_folders
from swir_tracker_ros.harness.evaluate import OPE
from swir_tracker_ros.harness.runner import Player, play
from swir_tracker_ros.harness.sources import open_source
from swir_tracker_ros.harness.store import RunStore


@dataclass(frozen=True)
class Entry:
    """One tracker of the stored set: its label and how to build its player (kind, name)."""

    label: str
    kind: str  # "network" (Player.siamese), "opencv" (Player.opencv) or "ours" (Player.ours)
    name: str
    optional: bool = False  # skipped, with a note, when it cannot be built (a version not there yet)
    precision: str = "float32"  # a network's heads (SiameseParams.precision)
    requested: bool = False  # played only when `--only` names it

    def player(self) -> Player:
        if self.kind == "network":
            return Player.siamese(self.name, precision=self.precision)
        if self.kind == "opencv":
            return Player.opencv(self.name)
        return Player.ours(self.name)


# The verdict's pair first (the network alone v2 and the default), then the rest.
ENTRIES = (
    Entry("siamese_v2", "network", "v2"),
    Entry("measured", "ours", "measured"),
    Entry("siamese_v3", "network", "v3"),
    Entry("siamese_lighttrack", "network", "lighttrack", optional=True),
    Entry("opencv_nano", "opencv", "Nano"),
    Entry("opencv_csrt", "opencv", "CSRT"),
    Entry("eco", "ours", "eco"),
    Entry("fused", "ours", "fused"),
    Entry("siamese", "ours", "siamese"),
    # the int8 heads (issue 53 item 1, docs/siamese.md "Faster networks"): `--only` them
    Entry("siamese_lighttrack_int8", "network", "lighttrack", precision="int8", requested=True),
    Entry("siamese_v3_int8", "network", "v3", precision="int8", requested=True),
)


def players(only: list[str] | None, say) -> list[Player]:
    """The players of `ENTRIES` (or of the labels in `only`), optional ones left out when unavailable."""
    known = [e.label for e in ENTRIES]
    bad = [t for t in only or () if t not in known]
    if bad:
        raise HarnessError(f"unknown label {bad[0]!r}; the stored set is {', '.join(known)}")
    out = []
    for e in ENTRIES:
        if (only and e.label not in only) or (e.requested and not only):
            continue
        try:
            out.append(e.player())
        except HarnessError as exc:
            if not e.optional:
                raise
            say(f"{e.label}: left out ({exc})")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", nargs="+", action="extend", default=None, metavar="DIR",
                    help=f"data folders (default: `{DEV}`, the development set)")
    ap.add_argument("--only", nargs="+", default=None, metavar="LABEL", help="only these labels")
    ap.add_argument("--results", default=None,
                    help=f"results directory (default: $SWIR_RESULTS or {DEFAULT_RESULTS})")
    ap.add_argument("--jobs", type=int, default=1, help="parallel (tracker, sequence) tasks")
    ap.add_argument("--rerun", action="store_true", help="replace stored runs that other code made")
    ap.add_argument("--list", action="store_true", help="print the labels and exit")
    a = ap.parse_args(argv)

    def say(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    if a.list:
        print("\n".join(e.label + (" (when available)" if e.optional else "")
                         + (" (with --only)" if e.requested else "") for e in ENTRIES))
        return 0
    try:
        dirs = data_dirs(a.data or [DEV])
        sources = [open_source(f) for f in sequence_folders(dirs).values()]
        store = RunStore(a.results or os.environ.get("SWIR_RESULTS") or DEFAULT_RESULTS)
        chosen = players(a.only, say)
        say(f"{len(sources)} sequences from {', '.join(map(str, dirs))}; {len(chosen)} trackers into "
            f"{store.root}")
    except HarnessError as exc:
        print(f"dev_runs: error: {exc}", file=sys.stderr)
        return 2
    failed = []
    for p in chosen:  # one label after the other; a label whose stored runs are stale does not stop the rest
        t0 = time.perf_counter()
        try:
            rep = play(sources, [p], (OPE,), "otb", store, a.jobs, a.rerun, say)
        except HarnessError as exc:
            failed.append(p.label)
            print(f"dev_runs: error: {p.label}: {exc}", file=sys.stderr)
            continue
        say(f"== {p.label}: {rep.computed} run(s) played, {rep.reused} reused, {rep.replaced} replaced "
            f"({time.perf_counter() - t0:.0f} s)")
    labels = " ".join(p.label for p in chosen if p.label not in failed)
    if labels:
        print(f"stored: {labels}\n  .venv/bin/harness table {labels} --protocol ope")
    if failed:
        print(f"dev_runs: not stored: {' '.join(failed)} (errors above)", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
