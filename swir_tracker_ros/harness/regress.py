# SPDX-License-Identifier: Apache-2.0
"""Regression gate: evaluate a stored regression set and fail when a score falls below its threshold."""

from __future__ import annotations

import json
import math
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import yaml

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.bagio import FrameRecord, write_bag
from swir_tracker_ros.harness.evaluate import EvalResult, evaluate
from swir_tracker_ros.harness.metrics import Score
from swir_tracker_ros.harness.sources import Source, open_source

REPO = Path(__file__).resolve().parents[2]
REGRESSION_DIR = REPO / "test" / "regression"
DEFAULT_SEQUENCES = REPO.parent / "shared" / "data" / "sequences"
HIGHER_IS_BETTER = {"precision_20": True, "success_auc": True, "occluded_precision_20": True,
                    "center_error": False, "lost_frames": False, "fps": True}


@dataclass(frozen=True)
class Violation:
    sequence: str
    variant: str
    metric: str
    threshold: float
    value: float

    @property
    def delta(self) -> float:
        return self.value - self.threshold


def config_path(name_or_path: str) -> Path:
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") and p.exists():
        return p
    cand = REGRESSION_DIR / f"{name_or_path}.yaml"
    if not cand.exists():
        known = ", ".join(sorted(x.stem for x in REGRESSION_DIR.glob("*.yaml")))
        raise HarnessError(f"no regression set {name_or_path!r} (known in {REGRESSION_DIR}: {known})")
    return cand


def load_config(path: Path) -> dict:
    try:
        cfg = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise HarnessError(f"{path}: unreadable regression config: {exc}") from None
    for key in ("sources", "variants", "thresholds"):
        if key not in cfg:
            raise HarnessError(f"{path}: regression config lacks {key!r}")
    return cfg


def check(result: EvalResult, thresholds: dict) -> list[Violation]:
    """Every (sequence or 'mean', variant, metric) whose score is worse than its stored threshold.

    Higher is better for precision/success/fps (threshold = minimum); lower is better for centre error and
    lost frames (threshold = maximum). A missing sequence or variant is itself a violation (value nan).
    """
    means = result.mean()
    out = []
    for seq, per_variant in thresholds.items():
        scores: dict[str, Score] = means if seq == "mean" else result.sequences.get(seq, {})
        for variant, metrics in per_variant.items():
            s = scores.get(variant)
            for metric, thr in metrics.items():
                if metric not in HIGHER_IS_BETTER:
                    raise HarnessError(f"unknown metric {metric!r} in thresholds of {seq}/{variant}")
                val = getattr(s, metric) if s is not None else math.nan
                val = math.nan if val is None else float(val)
                ok = val >= thr if HIGHER_IS_BETTER[metric] else val <= thr
                if not ok:  # nan compares False: a missing score fails
                    out.append(Violation(seq, variant, metric, float(thr), val))
    return out


def format_violations(violations: list[Violation]) -> str:
    head = f"{'sequence':<30} {'variant':<18} {'metric':<22} {'threshold':>10} {'value':>10} {'change':>10}"
    rows = [head, "-" * len(head)]
    for v in violations:
        rows.append(f"{v.sequence:<30} {v.variant:<18} {v.metric:<22} {v.threshold:>10.3f} {v.value:>10.3f} "
                    f"{v.delta:>+10.3f}")
    return "\n".join(rows)


def _materialise(entry: dict, sequences_dir: Path, tmp: Path) -> Source:
    """A config entry -> Source; synthetic scenarios go through a bag first (the harness is bag-driven)."""
    frames = entry.get("frames")
    if "synth" in entry:
        src = open_source(f"synth:{entry['synth']}", max_frames=frames)
        bag = tmp / src.name
        meta = {"name": src.name, "fps": src.fps, "bits": src.bits, "source": f"synth:{src.name}"}
        write_bag(bag, (FrameRecord(f.stamp_ns, f.image, f.gt, f.occluded) for f in src.frames()),
                  storage=entry.get("storage", "sqlite3"), custom={"swir_sequence": json.dumps(meta)})
        return open_source(bag)
    if "sequence" in entry:
        return open_source(sequences_dir / entry["sequence"], max_frames=frames)
    if "bag" in entry:
        return open_source(Path(entry["bag"]).expanduser(), max_frames=frames)
    raise HarnessError(f"regression source needs synth:, sequence: or bag:, got {entry}")


def run_regression(config: Path, sequences_dir: Path = DEFAULT_SEQUENCES,
                   progress: Callable[[str], None] | None = None) -> tuple[EvalResult, list[Violation]]:
    cfg = load_config(config)
    with tempfile.TemporaryDirectory(prefix="harness-regress-") as tmp:
        sources = [_materialise(e, Path(sequences_dir), Path(tmp)) for e in cfg["sources"]]
        result = evaluate(sources, cfg["variants"], cfg.get("pipeline", "kcf"), progress)
    return result, check(result, cfg["thresholds"])
