# SPDX-License-Identifier: Apache-2.0
"""Tables of a `Results`: trackers side by side, per sequence and per group (the data folders, synthetic
scenarios, other sources), and over all the data folders together."""

from __future__ import annotations

import math
from collections.abc import Sequence

from swir_tracker_ros.harness.devset import OTHER, SYNTHETIC
from swir_tracker_ros.harness.evaluate import OPE
from swir_tracker_ros.harness.protocol import Results

EVAL_FIELDS = ("precision_20", "success_auc", "center_error", "zero_iou", "fps")
# (title, label column, [(row label, a cell per tracker)])
Table = tuple[str, str, list[tuple[str, list[str]]]]

# (row label, summary key, format) of the mean rows, in print order
_MEAN_ROWS = (("OPE mean AUC", "ope_auc", ".3f"), ("OPE mean P@20", "ope_precision_20", ".3f"),
              ("OPE false tracking frames", "ope_false_tracking", "d"),
              ("OPE IoU=0 frames", "ope_zero_iou", "d"),
              ("OPE false-loss rate (present, said gone)", "ope_false_loss", ".3f"),
              ("OPE false-tracking rate (IoU<0.1)", "ope_false_tracking_rate", ".3f"),
              ("OPE absent frames", "ope_absent", "d"),
              ("OPE gone recall (absent frames)", "ope_gone_recall", ".3f"),
              ("SRE mean AUC", "sre_auc", ".3f"), ("SRE AUC standard error", "sre_se", ".4f"),
              ("SRE mean P@20", "sre_precision_20", ".3f"),
              ("SRE spread (max-min, mean)", "sre_spread", ".3f"),
              ("SRE spread vs the carried start box", "sre_carried_spread", ".3f"),
              ("SRE AUC vs the carried start box", "sre_carried_mean", ".3f"),
              ("SRE spread of exact tracking (floor)", "sre_floor_spread", ".3f"),
              ("SRE false tracking (all runs)", "sre_false_tracking", "d"),
              ("SRE IoU=0 frames (all runs)", "sre_zero_iou", "d"), ("fps (OPE, mean)", "fps", ".1f"))


def _f(v: float | int | None, fmt: str = ".3f") -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, fmt)


def ordered_groups(results: Results) -> list[tuple[str, list[str]]]:
    """The groups in the order first seen, the synthetic scenarios and other sources last."""
    by = results.by_group()
    last = (SYNTHETIC, OTHER)
    return [(g, by[g]) for g in (*(g for g in by if g not in last), *last) if g in by]


def _ope_cell(results: Results, seq: str, label: str) -> str:
    r = results.ope(seq, label)
    return "-" if r is None else f"{r.success_auc:.3f} / {r.precision_20:.2f} / {r.false_tracking}"


def _absence_cell(results: Results, seq: str, label: str) -> str:
    r = results.ope(seq, label)
    if r is None:
        return "-"
    return f"{_f(r.gone_recall, '.2f')} / {_f(r.false_loss_rate, '.2f')} / {_f(r.false_tracking_rate, '.2f')}"


def _sre_cell(results: Results, seq: str, label: str) -> str:
    v = results.sre(seq, label)
    return "-" if v is None else f"{v['mean']:.3f} [{v['min']:.3f}, {v['max']:.3f}]"


def protocol_tables(results: Results) -> list[Table]:
    """Per group: the per-sequence OPE and SRE tables with the group's mean as the last row, then all the
    group's means; and the means over both folds when both are present."""
    tr = results.labels
    tables: list[Table] = []
    has_ope = any(OPE in runs for per in results.stats.values() for runs in per.values())
    has_sre = any(len(runs) > (OPE in runs) for per in results.stats.values() for runs in per.values())
    groups = ordered_groups(results)
    for group, seqs in groups:
        summ = [results.summary(t, seqs) for t in tr]
        if has_ope:
            rows = [(s, [_ope_cell(results, s, t) for t in tr]) for s in seqs]
            rows.append((f"mean {group} ({len(seqs)})", [
                "-" if "ope_auc" not in m else f"{m['ope_auc']:.3f} / {m['ope_precision_20']:.2f} / "
                f"{m['ope_false_tracking']}" for m in summ]))
            tables.append((f"OPE {group}: AUC / P@20 / FT", "sequence", rows))
            rows = [(s, [_absence_cell(results, s, t) for t in tr]) for s in seqs]
            rows.append((f"mean {group} ({len(seqs)})", [
                "-" if "ope_auc" not in m else f"{_f(m.get('ope_gone_recall'), '.2f')} / "
                f"{m['ope_false_loss']:.2f} / {m['ope_false_tracking_rate']:.2f}" for m in summ]))
            tables.append((f"OPE {group}: gone recall / false loss / false tracking", "sequence", rows))
        if has_sre:
            rows = [(s, [_sre_cell(results, s, t) for t in tr]) for s in seqs]
            rows.append((f"mean {group} ({len(seqs)})", [
                "-" if "sre_auc" not in m else f"{m['sre_auc']:.3f} +- {m['sre_se']:.3f}" for m in summ]))
            tables.append((f"SRE {group}: AUC mean [min, max] over the starts; mean +- standard error",
                           "sequence", rows))
        tables.append((f"MEAN {group} ({len(seqs)})", "", _mean_rows(summ, group == SYNTHETIC)))
    real = [(g, seqs) for g, seqs in groups if g not in (SYNTHETIC, OTHER)]
    if len(real) > 1:
        every = [s for _, seqs in real for s in seqs]
        tables.append((f"MEAN {' + '.join(g for g, _ in real)} ({len(every)})", "",
                       _mean_rows([results.summary(t, every) for t in tr], False)))
    return tables


def _mean_rows(summ: Sequence[dict], synthetic: bool) -> list[tuple[str, list[str]]]:
    rows = [(name, [_f(m.get(key), fmt) for m in summ])
            for name, key, fmt in _MEAN_ROWS if any(key in m for m in summ)]
    if synthetic:
        for proto, pre in (("OPE", "ope"), ("SRE", "sre")):
            if any(f"{pre}_occlusions" in m for m in summ):
                counts = [(m.get(f"{pre}_occlusions"), m.get(f"{pre}_survived")) for m in summ]
                rows.append((f"{proto} occlusions survived",
                             ["-" if not n else f"{k}/{n} ({100.0 * k / n:.0f} %)" for n, k in counts]))
    return rows


def footer(results: Results) -> str:
    labels = results.meta.get("labels", {})
    made = "; ".join(f"{t}: {', '.join(labels[t].get('codes', []))} (commit "
                     f"{', '.join(labels[t].get('commits', []))})" for t in results.labels if t in labels)
    return (f"SRE style {results.meta.get('style', 'otb')}; FT = frames in state tracking (OpenCV: ok) with "
            f"IoU 0; frames after the start frame scored; a frame reported as failure keeps its last box. "
            f"AUC and P@20 over the frames with ground truth; gone recall = absent frames (gt 0,0,0,0) said "
            f"occluded or lost (mean over the sequences that have some); false loss = present frames said "
            f"gone; false tracking rate = present frames in state tracking with IoU < 0.1.\n"
            f"made by: {made}")


def format_text(results: Results, tables: list[Table] | None = None) -> str:
    """Tables as fixed-width text (the harness's console output)."""
    out: list[str] = []
    w = max([22, *(len(t) + 2 for t in results.labels)])
    for title, _, rows in protocol_tables(results) if tables is None else tables:
        head = f"{title:<44}" + "".join(f"{t:>{w}}" for t in results.labels)
        out += [head, "-" * len(head)]
        out += [f"{label:<44}" + "".join(f"{c:>{w}}" for c in cells) for label, cells in rows]
        out.append("")
    out.append(footer(results))
    return "\n".join(out)


def format_markdown(results: Results) -> str:
    """The protocol tables in Markdown (for docs and issue notes)."""
    tr = results.labels
    out: list[str] = []
    for title, column, rows in protocol_tables(results):
        out += [title, "", f"| {column} | " + " | ".join(tr) + " |", "|---|" + "---|" * len(tr)]
        out += [f"| {label} | " + " | ".join(cells) + " |" for label, cells in rows]
        out.append("")
    out.append(footer(results))
    return "\n".join(out)


def format_eval(results: Results, fields: Sequence[str] = EVAL_FIELDS) -> str:
    """OPE as one row per (sequence, tracker) and the per-sequence mean per tracker at the bottom."""
    head = f"{'sequence':<30} {'tracker':<18} " + " ".join(f"{f:>13}" for f in fields)
    lines = [head, "-" * len(head)]

    def row(name: str, t: str, values: dict) -> str:
        cells = [f"{'-':>13}" if values.get(f) is None else f"{values[f]:>13d}" if isinstance(values[f], int)
                 else f"{values[f]:>13.3f}" for f in fields]
        return f"{name:<30} {t:<18} " + " ".join(cells)

    for seq, per in results.stats.items():
        ope = [(t, per[t].get(OPE)) for t in results.labels if t in per]
        lines += [row(seq, t, r.to_json()) for t, r in ope if r is not None]
    lines.append("-" * len(head))
    for t in results.labels:
        ope = [per[t][OPE] for per in results.stats.values() if OPE in per.get(t, {})]
        if ope:
            mean: dict = {}
            for f in fields:
                vals = [getattr(r, f) for r in ope if getattr(r, f) is not None]
                mean[f] = (sum(vals) if f == "zero_iou" else sum(vals) / len(vals)) if vals else None
            lines.append(row("MEAN", t, mean))
    return "\n".join(lines)
