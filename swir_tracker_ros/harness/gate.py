# SPDX-License-Identifier: Apache-2.0
"""The regression gate's thresholds: averaged protocols, each threshold with the spread it was set against.

A regression set (test/regression/<name>.yaml) names sources, configurations and a protocol (OPE and/or
SRE starts, an SRE style). The gated value of a (sequence, configuration) is the mean over the protocol's
starts of a run score (success AUC, precision at 20 px); row `mean` is the mean of those over the set's
sequences. One run of a chaotic tracker moves with the floating-point kernels of the machine; a mean over
13 starts moves much less. Each threshold records

    min:      the gate fails below it
    measured: the value when it was set (mean over the numeric environments measured)
    spread:   max - min of the value over those environments (`harness/numerics.py`)

and `calibrate` sets min = lowest value - max(factor x spread, floor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.metrics import SRE_STYLES
from swir_tracker_ros.harness.protocol import Results
from swir_tracker_ros.harness.runner import PROTOCOLS, protocol_starts

GATED = ("success_auc", "precision_20")  # higher is better
MEAN_ROW = "mean"
Key = tuple[str, str, str]  # (sequence or "mean", configuration, metric)


@dataclass(frozen=True)
class Threshold:
    minimum: float
    measured: float
    spread: float


@dataclass
class GateConfig:
    """A regression set as loaded from its YAML (module docstring)."""

    path: Path
    name: str
    protocols: tuple[str, ...]
    style: str
    configurations: list[str]
    sources: list[dict]
    overrides: list[str] = field(default_factory=list)
    thresholds: dict[Key, Threshold] = field(default_factory=dict)
    comment: str = ""  # the YAML's leading comment block

    @property
    def starts(self) -> tuple[str, ...]:
        return protocol_starts(self.protocols)


def _threshold(path: Path, where: str, spec: object) -> Threshold:
    if not isinstance(spec, dict) or not {"min", "spread"} <= set(spec):
        raise HarnessError(f"{path}: threshold {where} must be {{min: X, measured: M, spread: S}} (the "
                           f"spread it was set against), got {spec!r}; re-baseline with "
                           "`harness regress --calibrate`")
    try:
        return Threshold(float(spec["min"]), float(spec.get("measured", spec["min"])), float(spec["spread"]))
    except (TypeError, ValueError):
        raise HarnessError(f"{path}: threshold {where} has a value that is not a number: {spec!r}") from None


def load_config(path: Path) -> GateConfig:
    """A regression set; HarnessError naming the file and the key that is missing or wrong."""
    try:
        text = path.read_text()
        cfg = yaml.safe_load(text)
    except (OSError, yaml.YAMLError) as exc:
        raise HarnessError(f"{path}: unreadable regression config: {exc}") from None
    if not isinstance(cfg, dict):
        raise HarnessError(f"{path}: a regression config is a mapping")
    if "variants" in cfg and "configurations" not in cfg:
        cfg["configurations"] = cfg.pop("variants")  # the old spelling
    for key in ("sources", "configurations", "thresholds"):
        if key not in cfg:
            raise HarnessError(f"{path}: regression config lacks {key!r}")
    protocols = tuple(cfg.get("protocol", ["ope"]))
    if not protocols or any(p not in PROTOCOLS for p in protocols):
        raise HarnessError(f"{path}: protocol must be a list from {', '.join(PROTOCOLS)}, got {protocols}")
    style = cfg.get("style", "otb")
    if style not in SRE_STYLES:
        raise HarnessError(f"{path}: style must be one of {', '.join(SRE_STYLES)}, got {style!r}")
    out = GateConfig(path, str(cfg.get("set", path.stem)), protocols, style, list(cfg["configurations"]),
                     list(cfg["sources"]), [str(o) for o in cfg.get("overrides", [])])
    out.comment = "\n".join(ln for ln in _leading_comment(text))
    for seq, per in (cfg["thresholds"] or {}).items():
        for conf, metrics in (per or {}).items():
            if conf not in out.configurations:
                raise HarnessError(f"{path}: thresholds name {conf!r}, which is not in configurations")
            for metric, spec in (metrics or {}).items():
                if metric not in GATED:
                    raise HarnessError(f"{path}: unknown metric {metric!r} in {seq}/{conf}; gated: "
                                       f"{', '.join(GATED)}")
                out.thresholds[(str(seq), conf, metric)] = _threshold(path, f"{seq}/{conf}/{metric}", spec)
    return out


def _leading_comment(text: str) -> list[str]:
    lines = []
    for ln in text.splitlines():
        if not ln.startswith("#"):
            break
        lines.append(ln)
    return lines


def averaged(results: Results, labels: dict[str, str], starts: tuple[str, ...]) -> dict[Key, float]:
    """The gated values: per (sequence, configuration) the mean over `starts` of each metric, and the
    `mean` row over the sequences; `labels` maps a configuration to the label its runs are stored under."""
    out: dict[Key, float] = {}
    for conf, label in labels.items():
        per_seq = {seq: results.averaged(seq, label, starts) for seq in results.stats}
        for metric in GATED:
            vals = [v[metric] for v in per_seq.values() if v is not None]
            for seq, v in per_seq.items():
                if v is not None:
                    out[(seq, conf, metric)] = v[metric]
            if vals and len(vals) == len(per_seq):
                out[(MEAN_ROW, conf, metric)] = sum(vals) / len(vals)
    return out


@dataclass(frozen=True)
class Violation:
    sequence: str
    configuration: str
    metric: str
    threshold: Threshold
    value: float  # nan: no value (a missing run fails)

    @property
    def delta(self) -> float:
        return self.value - self.threshold.minimum


def check(values: dict[Key, float], thresholds: dict[Key, Threshold]) -> list[Violation]:
    """Every threshold whose value is below its minimum, or missing."""
    out = []
    for key, thr in thresholds.items():
        val = values.get(key, math.nan)
        if not val >= thr.minimum:  # nan compares False: a missing value fails
            out.append(Violation(*key, thr, val))
    return out


def format_gate(values: dict[Key, float], thresholds: dict[Key, Threshold]) -> str:
    """Every gated value beside its threshold, the spread it was set against and how far above it is."""
    head = (f"{'sequence':<30} {'configuration':<18} {'metric':<13} {'value':>7} {'min':>7} {'spread':>7} "
            f"{'margin':>8}")
    rows = [head, "-" * len(head)]
    for key in sorted(thresholds, key=lambda k: (k[0] == MEAN_ROW, k)):
        thr, val = thresholds[key], values.get(key, math.nan)
        flag = "" if val >= thr.minimum else "  FAIL"
        rows.append(f"{key[0]:<30} {key[1]:<18} {key[2]:<13} {val:>7.3f} {thr.minimum:>7.3f} "
                    f"{thr.spread:>7.3f} {val - thr.minimum:>+8.3f}{flag}")
    return "\n".join(rows)


def calibrate(measured: dict[str, dict[Key, float]], factor: float = 2.0,
              floor: float = 0.02) -> dict[Key, Threshold]:
    """Thresholds from the values measured in each numeric environment (env -> values): spread = max - min
    over the environments, min = the lowest value - max(factor x spread, floor), rounded down to 0.001 and
    never below 0. A key measured in only some environments is left out."""
    if not measured:
        raise HarnessError("nothing measured to calibrate from")
    envs = list(measured.values())
    keys = [k for k in envs[0] if all(k in e for e in envs)]
    out = {}
    for k in keys:
        vals = [e[k] for e in envs]
        lo, hi = min(vals), max(vals)
        margin = max(factor * (hi - lo), floor)
        out[k] = Threshold(max(0.0, math.floor(round((lo - margin) * 1000.0, 6)) / 1000.0),
                           round(sum(vals) / len(vals), 4), round(hi - lo, 4))
    return out


def config_text(cfg: GateConfig, thresholds: dict[Key, Threshold], header: list[str]) -> str:
    """The regression set's YAML with new thresholds: `header` as its leading comment, then the set."""
    body = {"set": cfg.name, "protocol": list(cfg.protocols), "style": cfg.style,
            "configurations": cfg.configurations, "overrides": cfg.overrides}
    text = "\n".join(f"# {ln}" if ln else "#" for ln in header) + "\n"
    text += yaml.safe_dump(body, sort_keys=False, default_flow_style=None, width=110)
    flow = [yaml.safe_dump(s, default_flow_style=True, sort_keys=False).strip() for s in cfg.sources]
    text += "sources:\n" + "".join(f"  - {f}\n" for f in flow)
    text += "thresholds:\n"
    seqs = sorted({k[0] for k in thresholds}, key=lambda s: (s == MEAN_ROW, s))
    for seq in seqs:
        text += f"  {seq}:\n"
        for conf in cfg.configurations:
            items = [(m, thresholds[(seq, conf, m)]) for m in GATED if (seq, conf, m) in thresholds]
            if items:
                text += f"    {conf}:\n" + "".join(
                    f"      {m}: {{min: {t.minimum:.3f}, measured: {t.measured:.4f}, "
                    f"spread: {t.spread:.4f}}}\n"
                    for m, t in items)
    return text
