# SPDX-License-Identifier: Apache-2.0
"""The harness's evaluation commands: eval and compare play and store runs, table and verdict score stored
runs, regress gates a regression set (docs/harness.md). The parser is in `cli`."""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.analysis import DEFAULT_SEQUENCES, load_results
from swir_tracker_ros.harness.compare import OPENCV_DEFAULT
from swir_tracker_ros.harness.devset import DEV, data_dirs, sequence_folders
from swir_tracker_ros.harness.evaluate import DEFAULT, OPE, configurations, default_configuration
from swir_tracker_ros.harness.gate import GateConfig, check, format_gate, load_config
from swir_tracker_ros.harness.metrics import SRE_PERTURBATIONS
from swir_tracker_ros.harness.numerics import check_names
from swir_tracker_ros.harness.plots import plot_result
from swir_tracker_ros.harness.protocol import Results
from swir_tracker_ros.harness.regress import (
    config_path,
    measure_in_envs,
    recalibrate,
    run_set,
    values_json,
)
from swir_tracker_ros.harness.runner import Player, play, protocol_starts
from swir_tracker_ros.harness.sources import SYNTH_PREFIX, Source, open_source
from swir_tracker_ros.harness.store import RunStore
from swir_tracker_ros.harness.tables import format_eval, format_markdown, format_text
from swir_tracker_ros.harness.verdict import format_verdict, paired_verdict
from swir_tracker_ros.scene import scenarios

DEFAULT_RESULTS = "out/results"


def results_dir(a: argparse.Namespace) -> RunStore:
    """--results, else $SWIR_RESULTS, else out/results (relative to the working directory)."""
    return RunStore(a.results or os.environ.get("SWIR_RESULTS") or DEFAULT_RESULTS)


def progress(a: argparse.Namespace) -> Callable[[str], None] | None:
    return None if a.quiet else (lambda line: print(line, file=sys.stderr, flush=True))


def sources(a: argparse.Namespace) -> list[Source]:
    """The sources named on the command line: bags, sequence folders, folders of them, synth:NAME,
    synth:all and `dev` (every sequence of the data folders, `--data`: by default the development set)."""
    out = []
    for spec in a.bags:
        if spec == SYNTH_PREFIX + "all":  # every synthetic scenario (`harness synth --list`)
            out += [open_source(SYNTH_PREFIX + n, a.frames) for n in scenarios()]
            continue
        if spec == DEV:
            out += [open_source(f, a.frames) for f in sequence_folders(data_dirs(a.data_folders)).values()]
            continue
        p = Path(spec)
        if p.is_dir() and not (p / "gt.txt").exists() and not (p / "metadata.yaml").exists() \
                and any((c / "gt.txt").exists() for c in p.iterdir() if c.is_dir()):
            out += [open_source(c, a.frames, a.image_topic, a.gt_topic) for c in sorted(p.iterdir())
                    if (c / "gt.txt").exists()]  # a folder of sequence folders
        else:
            out.append(open_source(spec, a.frames, a.image_topic, a.gt_topic))
    return out


def _gone(a: argparse.Namespace) -> None:
    """The spellings of the cached-peer era fail with what to do instead."""
    if getattr(a, "reuse", None):
        raise HarnessError("--reuse is gone: every run is stored under --results DIR (default "
                           f"{DEFAULT_RESULTS}) and taken from there when it is played again")
    if getattr(a, "peer_cache", None) or getattr(a, "no_peer_cache", False):
        raise HarnessError("--peer-cache is gone: OpenCV's runs are stored under --results DIR with every "
                           "other run (use the same --results to reuse them)")


def players(a: argparse.Namespace, names: list[str]) -> list[Player]:
    overrides = [*(a.set or []), *(a.param or [])] + ([f"pipeline={a.pipeline}"] if a.pipeline else [])
    if a.label and len(names) != 1:
        raise HarnessError("--label names the runs of one configuration; give one --tracker with it")
    return [Player.ours(n, overrides, a.label) for n in names]


def _play_and_load(a: argparse.Namespace, ours: list[Player], peers: list[str], starts: tuple[str, ...],
                   style: str) -> Results:
    store = results_dir(a)
    srcs = sources(a)
    everyone = ours + [Player.opencv(t) for t in peers]
    play(srcs, everyone, starts, style, store, a.jobs, a.rerun, progress(a))
    labels = [p.label for p in everyone] + list(getattr(a, "peers", None) or [])
    return load_results(store, labels, [s.key for s in srcs], starts, style, data_dirs(a.data_folders),
                        Path(a.peer_dir))


def _write_json(path: str | None, results: Results, curves: bool = False) -> None:
    if path:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(json.dumps(results.to_json(curves), indent=1))
        print(f"wrote {path}")


def _finish_eval(results: Results, a: argparse.Namespace) -> None:
    print(format_eval(results))
    _write_json(a.json, results, a.curves)
    if a.plots:
        paths = plot_result(results, a.plots)
        print(f"wrote {len(paths)} plots to {a.plots}")


def cmd_eval(a: argparse.Namespace) -> int:
    _gone(a)
    names = a.tracker or list(configurations())
    results = _play_and_load(a, players(a, names), [], (OPE,), "otb")
    _finish_eval(results, a)
    return 0


def cmd_compare(a: argparse.Namespace) -> int:
    """Our configurations and OpenCV's trackers: OPE as `eval` prints it, or with --protocol the protocol
    tables per fold; stored peers (--peers) join the tables."""
    _gone(a)
    if a.protocol is None:
        names = list(configurations()) if a.tracker is None else a.tracker
        peers = list(OPENCV_DEFAULT) if a.opencv is None else a.opencv
        _finish_eval(_play_and_load(a, players(a, names), peers, (OPE,), "otb"), a)
        return 0
    if a.plots or a.curves:
        raise HarnessError("--plots and --curves belong to the plain compare, not to --protocol")
    names = [default_configuration()] if a.tracker is None else a.tracker
    peers = ["KCF", "CSRT"] if a.opencv is None else a.opencv
    results = _play_and_load(a, players(a, names), peers, protocol_starts(a.protocol), a.sre_style)
    _print_tables(results, a)
    return 0


def _print_tables(results: Results, a: argparse.Namespace) -> None:
    print(format_text(results))
    if a.markdown:
        Path(a.markdown).write_text(format_markdown(results) + "\n")
        print(f"wrote {a.markdown}")
    _write_json(a.json, results)


def stored_label(label: str, store: RunStore) -> str:
    """A label as given, or for `default` (when nothing is stored under that name) the default
    configuration's own label."""
    return default_configuration() if label == DEFAULT and label not in store.labels() else label


def _stored(a: argparse.Namespace, labels: list[str], starts: tuple[str, ...],
            keys: list[str] | None = None) -> Results:
    if keys is None and a.bags:
        keys = [s.key for s in sources(a)]
    return load_results(results_dir(a), labels, keys, starts, a.sre_style, data_dirs(a.data_folders),
                        Path(a.peer_dir), a.allow_mixed)


def cmd_table(a: argparse.Namespace) -> int:
    """Tables of stored runs only (nothing is played)."""
    labels = [stored_label(t, results_dir(a)) for t in a.labels]
    results = _stored(a, labels, protocol_starts(a.protocol))
    if not results.stats:
        raise HarnessError(f"no stored runs of {', '.join(a.labels)} in {results_dir(a).root}")
    _print_tables(results, a)
    return 0


def cmd_verdict(a: argparse.Namespace) -> int:
    """Two stored trackers paired over the videos of the data folders (OPE), the SRE view beside, and the
    call (`verdict.py`); --json writes it."""
    store = results_dir(a)
    base, cand = stored_label(a.base, store), stored_label(a.candidate, store)
    keys = None
    if not a.bags:  # the data folders' sequences stored for either (the others are no pair)
        stored = set(store.sequences(base)) | set(store.sequences(cand))
        keys = [k for k in sequence_folders(data_dirs(a.data_folders)) if k in stored]
        if not keys:
            raise HarnessError(f"no stored run of {base} or {cand} in {store.root} on the sequences of "
                               f"{', '.join(str(d) for d in data_dirs(a.data_folders))}")
    results = _stored(a, [base, cand], (OPE, *SRE_PERTURBATIONS), keys)
    verdict = paired_verdict(results, base, cand, a.metric, keys or list(results.stats))
    print(format_verdict(verdict))
    if a.json:
        Path(a.json).parent.mkdir(parents=True, exist_ok=True)
        Path(a.json).write_text(json.dumps(verdict.to_json(), indent=1))
        print(f"wrote {a.json}")
    return 0


def cmd_regress(a: argparse.Namespace) -> int:
    cfg = load_config(config_path(a.config or a.set, Path(a.regression_dir)))
    seqs = Path(a.sequences or DEFAULT_SEQUENCES)
    if a.calibrate:
        return _calibrate(a, cfg, seqs)
    with tempfile.TemporaryDirectory(prefix="harness-regress-") as tmp:
        store = RunStore(a.results or tmp)  # without --results: fresh runs of the current code
        run = run_set(cfg, seqs, store, a.jobs, a.rerun, a.param or (), progress(a))
    if a.json:
        _write_json(a.json, run.results)
    if a.measure:
        Path(a.measure).write_text(json.dumps(values_json(cfg, run.values), indent=1))
        print(f"wrote {a.measure}")
        return 0
    print(format_gate(run.values, cfg.thresholds))
    violations = check(run.values, cfg.thresholds)
    if violations:
        print(f"\nREGRESSION: {len(violations)} value(s) below the thresholds in {cfg.path}:")
        for v in violations:
            print(f"  {v.sequence} {v.configuration} {v.metric}: {v.value:.3f} < min "
                  f"{v.threshold.minimum:.3f} "
                  f"({v.delta:+.3f}; spread {v.threshold.spread:.3f})")
        return 1
    print(f"\nregression set {cfg.name}: all {len(cfg.thresholds)} averaged values at or above the "
          "thresholds "
          f"in {cfg.path}")
    return 0


def _calibrate(a: argparse.Namespace, cfg: GateConfig, seqs: Path) -> int:
    envs = check_names(a.envs)
    root = Path(a.results or os.environ.get("SWIR_RESULTS") or DEFAULT_RESULTS) / "numerics"
    measured = measure_in_envs(cfg, envs, root, seqs, a.jobs, progress(a))
    thresholds, text = recalibrate(cfg, measured, a.margin_factor, a.margin_floor)
    width = max(len(e) for e in envs)
    for key in sorted(thresholds):
        vals = "  ".join(f"{e:>{width}} {measured[e][key]:.4f}" for e in envs)
        print(f"{' / '.join(key):<60} {vals}", file=sys.stderr)
    if a.write:
        cfg.path.write_text(text)
        print(f"wrote {cfg.path}")
    else:
        print(text)
    return 0
