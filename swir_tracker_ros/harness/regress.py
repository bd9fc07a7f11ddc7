# SPDX-License-Identifier: Apache-2.0
"""Regression sets: play a set's configurations over its sources (stored runs), compute the gated averages
(`gate`), and re-baseline its thresholds across the numeric environments (`numerics`) in one command."""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import date
from pathlib import Path

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.analysis import DEFAULT_SEQUENCES, load_results
from swir_tracker_ros.harness.gate import GateConfig, Key, Threshold, averaged, calibrate, config_text
from swir_tracker_ros.harness.numerics import describe, run_in
from swir_tracker_ros.harness.protocol import Results
from swir_tracker_ros.harness.runner import Player, play
from swir_tracker_ros.harness.sources import Source, open_source
from swir_tracker_ros.harness.store import REPO, RunStore, code_hash, git_commit, numerics

REGRESSION_DIR = REPO / "test" / "regression"


def config_path(name_or_path: str, regression_dir: Path = REGRESSION_DIR) -> Path:
    """A regression YAML given by path, or by set name in `regression_dir`."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") and p.exists():
        return p
    cand = regression_dir / f"{name_or_path}.yaml"
    if not cand.exists():
        known = ", ".join(sorted(x.stem for x in regression_dir.glob("*.yaml"))) or "none"
        raise HarnessError(f"no regression set {name_or_path!r} (known in {regression_dir}: {known})")
    return cand


def set_sources(cfg: GateConfig, sequences_dir: Path) -> list[Source]:
    """The set's sources: `{synth: NAME}`, `{sequence: NAME}` (in `sequences_dir`) or `{bag: PATH}`, each
    with an optional `frames` limit."""
    out = []
    for entry in cfg.sources:
        frames = entry.get("frames")
        if "synth" in entry:
            out.append(open_source(f"synth:{entry['synth']}", max_frames=frames))
        elif "sequence" in entry:
            out.append(open_source(sequences_dir / entry["sequence"], max_frames=frames))
        elif "bag" in entry:
            out.append(open_source(Path(entry["bag"]).expanduser(), max_frames=frames))
        else:
            raise HarnessError(f"{cfg.path}: a source needs synth:, sequence: or bag:, got {entry}")
    return out


@dataclass
class SetRun:
    results: Results
    values: dict[Key, float]  # the gated averages (gate.averaged)
    labels: dict[str, str]  # configuration -> stored label


def run_set(cfg: GateConfig, sequences_dir: Path = DEFAULT_SEQUENCES, store: RunStore | None = None,
            jobs: int = 1, rerun: bool = False, overrides: Sequence[str] = (),
            progress: Callable[[str], None] | None = None) -> SetRun:
    """Play the set (runs already stored with the same provenance are reused) and score it from storage.
    `overrides` (on top of the set's own) apply to every configuration, under labels of their own."""
    sources = set_sources(cfg, sequences_dir)
    allover = [*cfg.overrides, *overrides]
    players = [Player.ours(c, allover) for c in cfg.configurations]
    with tempfile.TemporaryDirectory(prefix="harness-regress-") as tmp:
        store = store or RunStore(tmp)
        play(sources, players, cfg.starts, cfg.style, store, jobs, rerun, progress)
        labels = {p.configuration: p.label for p in players}
        results = load_results(store, list(labels.values()), [s.key for s in sources], cfg.starts, cfg.style,
                               sequences_dir)
    return SetRun(results, averaged(results, labels, cfg.starts), labels)


def values_json(cfg: GateConfig, values: dict[Key, float]) -> dict:
    """The measured averages with what measured them (`harness regress --measure`)."""
    return {"set": cfg.name, "numerics": numerics(), "commit": git_commit(), "code": code_hash(),
            "values": [[*k, v] for k, v in sorted(values.items())]}


def read_values(path: Path) -> dict[Key, float]:
    try:
        data = json.loads(path.read_text())
        return {(s, c, m): float(v) for s, c, m, v in data["values"]}
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise HarnessError(f"{path}: not the output of `harness regress --measure`: {exc}") from None


def measure_in_envs(cfg: GateConfig, envs: Sequence[str], results_root: Path, sequences_dir: Path,
                    jobs: int = 1,
                    progress: Callable[[str], None] | None = None) -> dict[str, dict[Key, float]]:
    """Run the set in a subprocess per numeric environment (each with its own results directory under
    `results_root`, so its runs are stored apart) and collect the averages each one measured. Calibrating
    measures the current code: stored runs that other code made are played again (`--rerun`), the others
    are taken."""
    out = {}
    with tempfile.TemporaryDirectory(prefix="harness-calibrate-") as tmp:
        for env in envs:
            js = Path(tmp) / f"{env}.json"
            argv = ["-m", "swir_tracker_ros.harness", "regress", "--config", str(cfg.path),
                    "--measure", str(js), "--results", str(results_root / env),
                    "--sequences", str(sequences_dir), "--jobs", str(jobs), "--rerun", "--quiet"]
            if progress:
                progress(f"measuring {cfg.name} in {env}: {describe(env)}")
            proc = run_in(env, argv)
            if proc.returncode != 0:
                raise HarnessError(f"measuring {cfg.name} in numeric environment {env} failed:\n"
                                   f"{proc.stdout[-1500:]}{proc.stderr[-1500:]}")
            out[env] = read_values(js)
    return out


def calibration_header(cfg: GateConfig, measured: dict[str, dict[Key, float]], factor: float,
                       floor: float) -> list[str]:
    """The comment block of a re-baselined set: what was measured, where, and the rule."""
    starts = len(cfg.starts)
    return [f"Regression set {cfg.name!r}: the mean over {starts} starts ({' + '.join(cfg.protocols)}, "
            f"style {cfg.style}) of each run score,",
            "per (sequence, configuration), and their mean over the sequences (row `mean`).",
            f"Written by `harness regress --set {cfg.name} --calibrate --write` (docs/harness.md, "
            f"\"Re-baselining\") on {date.today().isoformat()},",
            f"commit {git_commit()}, code {code_hash()}, CPU {numerics()['cpu']},",
            f"numeric environments: {', '.join(measured)}.",
            "measured = mean of the value over those environments; spread = max - min over them;",
            f"min = lowest value - max({factor:g} x spread, {floor:g}), rounded down."
            " The gate fails below min.",
            "Never lower a threshold to let a change pass; re-baseline when the tracker changed on purpose."]


def recalibrate(cfg: GateConfig, measured: dict[str, dict[Key, float]], factor: float,
                floor: float) -> tuple[dict[Key, Threshold], str]:
    """New thresholds and the set's YAML text with them."""
    thresholds = calibrate(measured, factor, floor)
    return thresholds, config_text(cfg, thresholds, calibration_header(cfg, measured, factor, floor))
