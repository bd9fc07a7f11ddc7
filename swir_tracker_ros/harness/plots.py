# SPDX-License-Identifier: Apache-2.0
"""Precision and success plots as in the papers (matplotlib Agg, one line per tracker, PNG files)."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from swir_tracker_ros.harness.evaluate import OPE
from swir_tracker_ros.harness.metrics import PRECISION_THRESHOLDS, SUCCESS_THRESHOLDS
from swir_tracker_ros.harness.protocol import Results, RunStats


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def plot_pair(scores: dict[str, RunStats], title: str, out_dir: Path) -> list[Path]:
    """precision_<title>.png (legend: P@20) and success_<title>.png (legend: AUC), one line per tracker."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    order = sorted(scores, key=lambda v: -scores[v].precision_20)
    fig, ax = plt.subplots(figsize=(5.5, 4.2), dpi=100)
    for v in order:
        ax.plot(PRECISION_THRESHOLDS, scores[v].precision_curve, label=f"{v} [{scores[v].precision_20:.3f}]")
    ax.set(xlabel="Location error threshold (px)", ylabel="Precision", title=f"Precision plot: {title}",
           xlim=(0, 50), ylim=(0, 1.01))
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    paths.append(out_dir / f"precision_{_safe(title)}.png")
    fig.savefig(paths[-1], bbox_inches="tight")
    plt.close(fig)
    order = sorted(scores, key=lambda v: -scores[v].success_auc)
    fig, ax = plt.subplots(figsize=(5.5, 4.2), dpi=100)
    for v in order:
        ax.plot(SUCCESS_THRESHOLDS, scores[v].success_curve, label=f"{v} [{scores[v].success_auc:.3f}]")
    ax.set(xlabel="Overlap threshold", ylabel="Success rate", title=f"Success plot: {title}", xlim=(0, 1),
           ylim=(0, 1.01))
    ax.grid(alpha=0.3)
    ax.legend(loc="lower left", fontsize=8)
    paths.append(out_dir / f"success_{_safe(title)}.png")
    fig.savefig(paths[-1], bbox_inches="tight")
    plt.close(fig)
    return paths


def mean_curves(runs: list[RunStats]) -> RunStats:
    """The per-sequence mean of a tracker's curves (each sequence weighs the same)."""
    return RunStats(float(np.mean([r.success_auc for r in runs])),
                    float(np.mean([r.precision_20 for r in runs])),
                    0, 0, sum(r.frames for r in runs), 0.0,
                    precision_curve=list(np.mean([r.precision_curve for r in runs], axis=0)),
                    success_curve=list(np.mean([r.success_curve for r in runs], axis=0)))


def plot_result(results: Results, out_dir: Path | str) -> list[Path]:
    """OPE curves of every sequence and of the mean over sequences."""
    out = Path(out_dir)
    paths = []
    for name, per in results.stats.items():
        ope = {t: runs[OPE] for t, runs in per.items() if OPE in runs}
        if ope:
            paths += plot_pair(ope, name, out)
    ope = {t: [per[t][OPE] for per in results.stats.values() if OPE in per.get(t, {})]
           for t in results.labels}
    paths += plot_pair({t: mean_curves(runs) for t, runs in ope.items() if runs}, "mean", out)
    return paths
