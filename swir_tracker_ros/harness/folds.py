# SPDX-License-Identifier: Apache-2.0
"""Two fixed folds of the real sequences, and the verdict that compares two stored configurations on both.

The fold rule: sort the names of the sequence folders (those with a gt.txt) of the data directory; the
folders at even indices (0, 2, 4, ...) are fold 1, those at odd indices fold 2. It depends on the folder
names only, never on which sequences a command evaluates, so a sequence keeps its fold.

The team's rule for a default (issue 31): a change is kept only when the SRE mean AUC improves on both
folds, or improves on one and costs the other less than that fold's run-to-run noise. `verdict` gives
per fold the two means, the change and its noise: the standard error of the fold's mean change over the
starts and sequences (`protocol.standard_error` of the per-run paired changes).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.metrics import SRE_PERTURBATIONS
from swir_tracker_ros.harness.protocol import Results, standard_error

FOLDS = ("fold 1", "fold 2")
SYNTHETIC = "synthetic"
OTHER = "other"
GROUP_ORDER = (*FOLDS, SYNTHETIC, OTHER)


def fold_of_names(names: list[str]) -> dict[str, str]:
    """The fold of each name by the rule of the module docstring."""
    return {n: FOLDS[i % 2] for i, n in enumerate(sorted(names))}


def folds(data_dir: Path) -> dict[str, str]:
    """sequence folder name -> "fold 1" or "fold 2" for the sequence folders of `data_dir` ({} when the
    directory does not exist)."""
    if not data_dir.is_dir():
        return {}
    return fold_of_names([p.name for p in data_dir.iterdir() if (p / "gt.txt").is_file()])


def group_of(sequence: str, kind: str, fold: dict[str, str]) -> str:
    """The group a sequence key is shown in: its fold, "synthetic" or "other" (bags, foreign folders)."""
    if kind == "synth":
        return SYNTHETIC
    return fold.get(sequence.split("@", 1)[0], OTHER)


@dataclass(frozen=True)
class FoldChange:
    """SRE mean AUC of a baseline (a) and a candidate (b) on one fold."""

    fold: str
    sequences: int
    a: float
    b: float
    a_noise: float  # standard error of a's fold mean over its starts
    b_noise: float
    noise: float  # standard error of the change b - a (paired over sequence and start)

    @property
    def delta(self) -> float:
        return self.b - self.a


def fold_changes(results: Results, base: str, candidate: str, groups: tuple[str, ...] = FOLDS,
                 metric: str = "success_auc") -> list[FoldChange]:
    """Per fold the SRE means of `base` and `candidate` and the noise of their change. Both need all 12
    SRE starts on every sequence of the fold (HarnessError naming the first gap)."""
    by_group = results.by_group()
    out = []
    for g in groups:
        seqs = by_group.get(g, [])
        if not seqs:
            raise HarnessError(f"no sequence of {g} in the results (the fold rule reads the data directory)")
        a_runs, b_runs, d_runs = [], [], []
        for s in seqs:
            ra, rb = results.runs(s, base), results.runs(s, candidate)
            for label, runs in ((base, ra), (candidate, rb)):
                missing = [p for p in SRE_PERTURBATIONS if p not in runs]
                if missing:
                    raise HarnessError(f"{label} has no stored SRE run on {s} from {', '.join(missing)}: "
                                       "run the SRE protocol for it first (`harness run ... --protocol sre`)")
            a_runs.append([getattr(ra[p], metric) for p in SRE_PERTURBATIONS])
            b_runs.append([getattr(rb[p], metric) for p in SRE_PERTURBATIONS])
            d_runs.append([y - x for x, y in zip(a_runs[-1], b_runs[-1])])
        mean = lambda runs: sum(sum(v) / len(v) for v in runs) / len(runs)  # noqa: E731
        out.append(FoldChange(g, len(seqs), mean(a_runs), mean(b_runs), standard_error(a_runs),
                              standard_error(b_runs), standard_error(d_runs)))
    return out


def decide(changes: list[FoldChange]) -> tuple[bool, str]:
    """(keep, reason) by the team's rule (module docstring)."""
    better = [c for c in changes if c.delta > 0]
    if len(better) == len(changes):
        return True, "improves on every fold"
    if len(better) == len(changes) - 1:
        worse = next(c for c in changes if c.delta <= 0)
        if -worse.delta < worse.noise:
            return True, (f"improves on {', '.join(c.fold for c in better)}; costs {worse.fold} "
                          f"{-worse.delta:.4f}, less than its noise {worse.noise:.4f}")
        return False, (f"improves on {', '.join(c.fold for c in better)} but costs {worse.fold} "
                       f"{-worse.delta:.4f}, more than its noise {worse.noise:.4f}")
    return False, f"improves on {len(better)} of {len(changes)} folds"


def format_verdict(base: str, candidate: str, changes: list[FoldChange], metric: str = "success_auc") -> str:
    head = (f"{'SRE ' + metric:<18}{'seqs':>5}{base:>16}{'+-se':>8}{candidate:>16}{'+-se':>8}"
            f"{'change':>10}{'noise':>8}")
    lines = [head, "-" * len(head)]
    for c in changes:
        lines.append(f"{c.fold:<18}{c.sequences:>5}{c.a:>16.4f}{c.a_noise:>8.4f}{c.b:>16.4f}{c.b_noise:>8.4f}"
                     f"{c.delta:>+10.4f}{c.noise:>8.4f}")
    keep, why = decide(changes)
    lines += ["", f"verdict: {'KEEP' if keep else 'REJECT'} {candidate} over {base}: {why}",
              "(rule: SRE improves on both folds, or improves on one and costs the other less than its "
              "noise; "
              "noise = standard error of the fold's mean change over its starts and sequences)"]
    return "\n".join(lines)
