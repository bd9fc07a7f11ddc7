# SPDX-License-Identifier: Apache-2.0
"""The sweep table: one row per closed-loop run (scores, load, success), as text and Markdown."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from swir_tracker_ros.demo.analysis import RunSummary

# A run succeeds when the target is in view at the end and for at least this share of the run, and the
# tracker never reported `tracking` off the target (issue 13's "done when").
SUCCESS_IN_VIEW = 0.95


def missed(s: RunSummary) -> list[str]:
    """The success criteria run `s` missed, each as a short phrase (empty: the run succeeded): the run
    completed, the target in view at the end and for >= SUCCESS_IN_VIEW of the run, 0 false-tracking
    frames."""
    out = []
    if s.outcome != "completed":
        out.append(f"run not completed ({s.outcome})")
    if not s.in_view_at_end:
        out.append("target out of view at the end")
    if not s.in_view_fraction >= SUCCESS_IN_VIEW:  # also a NaN share (no frame scored)
        out.append(f"in view {s.in_view_fraction:.1%} < {SUCCESS_IN_VIEW:.0%}")
    if s.false_tracking_frames != 0:
        out.append(f"{s.false_tracking_frames} false-tracking frames")
    return out


def succeeded(s: RunSummary) -> bool:
    """In view at the end and >= SUCCESS_IN_VIEW of the time, 0 false-tracking frames, run completed."""
    return not missed(s)


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
    missed: list[str] = field(default_factory=list)  # the success criteria the run missed (`missed`)

    @property
    def name(self) -> str:
        return run_name(self.scene, self.seed, self.ego, self.repeat)


def run_name(scene: str, seed: int, ego: bool, repeat: int) -> str:
    """A run as the exit line names it: scene, seed, and the ego setting / repeat when not the usual."""
    return f"{scene} seed {seed}" + ("" if ego else " ego off") + (f" repeat {repeat}" if repeat > 1 else "")


COLUMNS = (
    ("scene", lambda r: r.scene),
    ("seed", lambda r: str(r.seed)),
    ("ego", lambda r: "on" if r.ego else "off"),
    ("in view", lambda r: f"{r.summary['in_view_fraction']:.1%}"),
    ("at end", lambda r: "yes" if r.summary["in_view_at_end"] else "NO"),
    ("centring err mean/p95 deg", lambda r: f"{r.summary['centring_error_mean_deg']:.2f} / "
                                            f"{r.summary['centring_error_p95_deg']:.2f}"),
    ("settled mean/p95 deg", lambda r: f"{r.summary.get('centring_error_settled_mean_deg', math.nan):.2f} / "
                                       f"{r.summary.get('centring_error_settled_p95_deg', math.nan):.2f}"),
    ("overshoot deg", lambda r: f"{r.summary.get('overshoot_deg', math.nan):.2f}"),
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
                    str(folder), cpu, missed(summary))


def exit_status(rows: Sequence[SweepRow], unfinished: Sequence[str] = ()) -> tuple[int, str]:
    """The exit status of `demo` / `demo sweep` from its runs: (0, "") when every run succeeded, else (1,
    one line naming each failed run and the criteria it missed). `unfinished`: runs that left no records
    (named with their error), failed too."""
    failed = [f"{r.name} ({'; '.join(r.missed)})" for r in rows if not r.success]
    failed += list(unfinished)
    if not failed:
        return 0, ""
    total = len(rows) + len(unfinished)
    return 1, f"{len(failed)} of {total} runs failed: " + ", ".join(failed)
