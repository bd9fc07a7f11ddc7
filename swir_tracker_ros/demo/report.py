# SPDX-License-Identifier: Apache-2.0
"""Plots (matplotlib Agg) and the summary JSON / Markdown / HTML report of the closed-loop demo."""

from __future__ import annotations

import html
import json
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from swir_tracker_ros.demo.analysis import SETTLE_S, RunSummary, read_trace, series, track_start
from swir_tracker_ros.demo.recording import RunRecords

COLOURS = {True: "tab:blue", False: "tab:orange"}


def _shade_occlusions(ax, summary: RunSummary) -> None:
    for e in summary.episodes:
        ax.axvspan(e["start"], e["end"], color="grey", alpha=0.18, lw=0)


def plot_errors(runs: list[tuple[RunRecords, RunSummary]], path: Path) -> Path:
    """Pan and tilt centring error (true target angle from the optical axis) against scene time."""
    fig, axes = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    for rec, _summ in runs:
        s = series(rec)
        name = f"{rec.label} (ego-motion compensation {'on' if rec.ego_motion_compensation else 'off'})"
        for ax, values in zip(axes, (s.pan_error, s.tilt_error)):
            ax.plot(s.t, np.degrees(values), color=COLOURS[rec.ego_motion_compensation], lw=1.2, label=name)
    if runs:
        _shade_occlusions(axes[0], runs[0][1])
        _shade_occlusions(axes[1], runs[0][1])
        cam = runs[0][0].camera
        if cam:
            half_h = math.degrees(math.atan2(cam["width"] / 2, cam["fx"]))
            half_v = math.degrees(math.atan2(cam["height"] / 2, cam["fy"]))
            for ax, half in zip(axes, (half_h, half_v)):
                ax.axhline(half, color="red", ls=":", lw=0.8)
                ax.axhline(-half, color="red", ls=":", lw=0.8)
    axes[0].set_ylabel("pan error (deg)")
    axes[1].set_ylabel("tilt error (deg)")
    axes[1].set_xlabel("scene time (s); grey: target occluded; red dotted: edge of the image")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title("Centring error of the target (true angle from the optical axis)")
    for ax in axes:
        ax.axhline(0.0, color="black", lw=0.5)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def plot_settled(runs: list[tuple[RunRecords, RunSummary]], path: Path) -> Path:
    """The settled centring error (from SETTLE_S after the track starts): pan and tilt, zoomed in, with
    each run's mean and p95 in the legend and the target's stops and turns marked."""
    fig, axes = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    top = 0.5
    for rec, summ in runs:
        s = series(rec)
        keep = s.stamp >= track_start(rec, s) + SETTLE_S
        tag = "on" if rec.ego_motion_compensation else "off"
        name = (f"ego-motion compensation {tag}: mean {summ.centring_error_settled_mean_deg:.3f}, "
                f"p95 {summ.centring_error_settled_p95_deg:.3f} deg")
        for ax, values in zip(axes, (s.pan_error, s.tilt_error)):
            deg = np.degrees(values[keep])
            ax.plot(s.t[keep], deg, color=COLOURS[rec.ego_motion_compensation], lw=1.0, label=name)
            top = max(top, float(np.percentile(np.abs(deg), 99)) if deg.size else 0.0)
    if runs:
        for ax, axis in zip(axes, ("pan", "tilt")):
            _shade_occlusions(ax, runs[0][1])
            for e in runs[0][1].stop_turn_events:
                if e["axis"] == axis:
                    ax.axvline(e["t"], color="purple", ls="--", lw=0.8)
                    ax.text(e["t"], 0.9 * top, f" {e['kind']}", color="purple", fontsize=7)
    for ax, label in zip(axes, ("pan error (deg)", "tilt error (deg)")):
        ax.set_ylim(-1.1 * top, 1.1 * top)
        ax.set_ylabel(label)
        ax.axhline(0.0, color="black", lw=0.5)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="lower right", fontsize=7)
    axes[0].set_title(f"Settled centring error (from {SETTLE_S:g} s after the track starts)")
    axes[1].set_xlabel("scene time (s); grey: target occluded; purple: the target stops or turns")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def plot_head(runs: list[tuple[RunRecords, RunSummary]], traces: list[np.ndarray], path: Path) -> Path:
    """Head pan/tilt (joint states and the simulator's true pose) next to the target's true direction."""
    fig, axes = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    t_end = 1.0
    for k, ((rec, _summ), trace) in enumerate(zip(runs, traces)):
        truth = np.array(rec.truth, dtype=np.float64).reshape(-1, 8)
        truth = truth[truth[:, 1] > 0]
        if not len(truth):
            continue
        start = truth[0, 0] - truth[0, 1]  # wall-clock time of scene time 0
        t_end = max(t_end, float(truth[-1, 1]))
        colour = COLOURS[rec.ego_motion_compensation]
        tag = "ego on" if rec.ego_motion_compensation else "ego off"
        head = np.array(rec.joints, dtype=np.float64).reshape(-1, 4)
        for i, ax in enumerate(axes):
            if len(head):
                ax.plot(head[:, 0] - start, np.degrees(head[:, 2 + i]), color=colour, lw=1.4,
                        label=f"head, /positioner/joint_states ({tag})")
            if len(trace):
                ax.plot(trace[:, 0] - start, np.degrees(trace[:, 1 + i]), color="black", lw=0.6, ls="--",
                        label="head, pelco_sim true pose" if k == 0 else None)
            if k == 0:  # the target's direction is the same in every run: rendered pose + its angle
                ax.plot(truth[:, 1], np.degrees(truth[:, 6 + i] + truth[:, 4 + i]), color="tab:green",
                        lw=1.0, label="target direction (ground truth)")
    axes[0].set_ylabel("pan (deg, + left)")
    axes[1].set_ylabel("tilt (deg, + up)")
    axes[1].set_xlabel("scene time (s); grey: target occluded")
    axes[0].set_title("Head angles over time")
    axes[0].legend(loc="best", fontsize=7)
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.set_xlim(-1.0, t_end)
    if runs:
        _shade_occlusions(axes[0], runs[0][1])
        _shade_occlusions(axes[1], runs[0][1])
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


ROWS = (
    ("outcome", "outcome", "{}"),
    ("scene time recorded", "duration_s", "{:.1f} s"),
    ("target centre in view", "time_in_view_s", "{:.1f} s"),
    ("  share of the run", "in_view_fraction", "{:.1%}"),
    ("  in view at the end", "in_view_at_end", "{}"),
    ("centring error, mean", "centring_error_mean_deg", "{:.3f} deg"),
    ("centring error, 95th percentile", "centring_error_p95_deg", "{:.3f} deg"),
    ("centring error settled (3 s after the track starts), mean", "centring_error_settled_mean_deg",
     "{:.3f} deg"),
    ("centring error settled, 95th percentile", "centring_error_settled_p95_deg", "{:.3f} deg"),
    ("largest overshoot after the target stops or turns", "overshoot_deg", "{:.3f} deg"),
    ("centring error, mean (pixels)", "centring_error_mean_px", "{:.1f} px"),
    ("centring error, 95th percentile (pixels)", "centring_error_p95_px", "{:.1f} px"),
    ("tracker box centre error, mean", "track_centre_error_mean_px", "{:.1f} px"),
    ("tracker precision at 20 px", "precision_20px", "{:.1%}"),
    ("head turn towards the target's start, pan", "head_turn_towards_deg", "{0[0]:.2f} deg"),
    ("head turn towards the target's start, tilt", "head_turn_towards_deg", "{0[1]:.2f} deg"),
    ("occlusions (visible < 50 %, >= 0.2 s)", "occlusions", "{}"),
    ("occlusions survived", "occlusions_survived", "{}"),
    ("camera frames/s", "camera_fps", "{:.1f}"),
    ("tracker outputs/s", "tracker_fps", "{:.1f}"),
    ("latency frame stamp -> tracker output, p50", "latency_p50_ms", "{:.1f} ms"),
    ("latency frame stamp -> tracker output, p95", "latency_p95_ms", "{:.1f} ms"),
    ("latency frame stamp -> error at the bridge, p50", "bridge_error_age_p50_ms", "{:.1f} ms"),
    ("latency frame stamp -> Pelco frame written, p50", "bridge_command_age_p50_ms", "{:.1f} ms"),
    ("latency frame stamp -> Pelco frame written, p95", "bridge_command_age_p95_ms", "{:.1f} ms"),
    ("frames with state lost", "lost_frames", "{}"),
    ("final tracker state", "final_state", "{}"),
)


def _fmt(fmt: str, value) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return "n/a"
    try:
        return fmt.format(value)
    except (IndexError, TypeError, ValueError):
        return "n/a"


def summary_table(summaries: list[RunSummary]) -> list[list[str]]:
    """Header row plus one row per figure, one column per run."""
    head = ["", *[f"ego-motion compensation {'ON' if s.ego_motion_compensation else 'OFF'}"
                  for s in summaries]]
    rows = [head]
    for title, key, fmt in ROWS:
        rows.append([title, *[_fmt(fmt, getattr(s, key)) for s in summaries]])
    return rows


def text_table(summaries: list[RunSummary]) -> str:
    rows = summary_table(summaries)
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows)


def _machine_line(machine: dict) -> str:
    if not machine:
        return ""
    return (f"Machine: {machine.get('cpus')} CPUs, load average {machine.get('load_average_start')} at the "
            f"start and {machine.get('load_average_end')} at the end (other work competes with the real-time "
            "loop when this exceeds the CPU count).")


def write_reports(out: Path, summaries: list[RunSummary], extras: dict) -> dict[str, Path]:
    """summary.json, report.md and report.html in `out`; extras: paths (relative) and process exits."""
    data = {"runs": [s.as_dict() for s in summaries],
            **{k: v for k, v in extras.items() if k != "sweep_markdown"}}
    (out / "summary.json").write_text(json.dumps(data, indent=2, default=str))
    rows = summary_table(summaries)
    md = ["# Closed-loop pan-tilt demo", "",
          "A simulated SWIR camera (`scene_camera`) on a simulated Pelco-D head (`pelco_sim`, driven by "
          "`positioner_bridge`) follows a pedestrian with the `tracker`; every part ran as its own ROS 2 "
          "process. Centring error is the true angle of the target from the optical axis.", "",
          _machine_line(extras.get("machine", {})), "",
          "| " + " | ".join(rows[0]) + " |", "|" + "---|" * len(rows[0])]
    md += ["| " + " | ".join(r) + " |" for r in rows[1:]]
    if extras.get("sweep_markdown"):
        md += ["", "## Sweep-style summary (`demo sweep` columns; success: in view at the end and >= 95 % "
               "of the time, no false-tracking frame)", "", extras["sweep_markdown"]]
    md += ["", "## Files", ""]
    for name, rel in extras.get("files", {}).items():
        md.append(f"- {name}: [{rel}]({rel})")
    md += ["", "## Occlusion episodes", ""]
    for s in summaries:
        tag = "ON" if s.ego_motion_compensation else "OFF"
        eps = ", ".join(f"{e['start']:.1f}-{e['end']:.1f} s ({e['note']})" for e in s.episodes) or "none"
        md.append(f"- ego-motion compensation {tag}: {eps}")
    md += ["", "## Processes", ""]
    for label, exits in extras.get("processes", {}).items():
        ends = (f"{n} exit {v['returncode']} ({v['how']}, {v.get('cpu_s', float('nan')):.1f} s CPU)"
                for n, v in exits.items())
        md.append(f"- {label}: " + ", ".join(ends))
    md += ["", "![centring error](plots/centring_error.png)", "",
           "![settled centring error](plots/centring_error_settled.png)", "",
           "![head angles](plots/head_angles.png)", ""]
    (out / "report.md").write_text("\n".join(md))

    def cell(tag: str, text: str) -> str:
        return f"<{tag}>{html.escape(text)}</{tag}>"

    table = "".join("<tr>" + "".join(cell("th" if i == 0 else "td", c) for c in r) + "</tr>"
                    for i, r in enumerate(rows))
    sweep_html = ""
    if extras.get("sweep_markdown"):
        lines = extras["sweep_markdown"].splitlines()
        cells = [[c.strip() for c in ln.strip("|").split("|")] for ln in lines if ln.startswith("|")]
        cells = [c for c in cells if not all(set(x) <= {"-"} for x in c)]
        sweep_html = ("<h2>Sweep-style summary</h2><table>" + "".join(
            "<tr>" + "".join(cell("th" if i == 0 else "td", c) for c in r) + "</tr>"
            for i, r in enumerate(cells)) + "</table>" + "".join(
            cell("p", ln[2:]) for ln in lines if ln.startswith("- ")))
    files = extras.get("files", {})
    videos = "".join(f"<h3>{html.escape(n)}</h3><video src='{html.escape(p)}' controls width='576'></video>"
                     f"<p><a href='{html.escape(p)}'>{html.escape(p)}</a></p>"
                     for n, p in files.items() if p.endswith(".mp4"))
    gifs = "".join(f"<h3>{html.escape(n)}</h3><img src='{html.escape(p)}' width='576'>"
                   for n, p in files.items() if p.endswith(".gif") or (p.endswith(".png") and "frame" in n))
    page = (
        "<!doctype html><html><head><meta charset='utf-8'><title>Closed-loop pan-tilt demo</title>"
        "<style>body{font-family:sans-serif;max-width:1000px;margin:auto}td,th{padding:2px 10px;"
        "border-bottom:1px solid #ddd;text-align:left}</style></head><body>"
        "<h1>Closed-loop pan-tilt demo</h1>"
        f"<p>{html.escape(md[2])}</p><p>{html.escape(md[4])}</p><table>{table}</table>{sweep_html}"
        "<h2>Plots</h2><img src='plots/centring_error.png'><img src='plots/centring_error_settled.png'>"
        "<img src='plots/head_angles.png'>"
        f"<h2>Debug video</h2>{videos}{gifs}"
        "<p>MP4 uses the MPEG-4 Part 2 codec: if the browser does not play it, open the file with a video "
        "player (VLC, mpv, ffplay).</p></body></html>")
    (out / "report.html").write_text(page)
    return {"json": out / "summary.json", "md": out / "report.md", "html": out / "report.html"}


def make_plots(out: Path, runs: list[tuple[RunRecords, RunSummary]], trace_paths: list[Path]) -> list[Path]:
    plots = out / "plots"
    plots.mkdir(parents=True, exist_ok=True)
    traces = [read_trace(p) for p in trace_paths]
    return [plot_errors(runs, plots / "centring_error.png"),
            plot_settled(runs, plots / "centring_error_settled.png"),
            plot_head(runs, traces, plots / "head_angles.png")]
