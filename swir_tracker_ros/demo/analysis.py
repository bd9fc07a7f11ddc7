# SPDX-License-Identifier: Apache-2.0
"""Scores of one closed-loop run from its records: time in view, centring error, occlusions, rate, latency."""

from __future__ import annotations

import csv
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from swir_tracker_ros.demo.recording import RunRecords

OCCLUDED_BELOW = 0.5  # an occlusion episode: less than half of the target visible ...
MIN_EPISODE_S = 0.2  # ... for at least this long (shorter dips are merged into neighbours or ignored)
RECOVERY_S = 1.0  # survived: on target within this long after the target is visible again
ON_TARGET_PX = 20.0  # on target: track centre within max(this, half the target width) of the truth
SETTLE_S = 3.0  # the settled centring error counts from this long after the track starts (issue 34)
MOVING_DEG_S = 0.2  # the target moves along an axis while its true angular rate exceeds this ...
MIN_RUN_S = 0.5  # ... and a stop or turn ends a motion that lasted at least this long
OVERSHOOT_WINDOW_S = 2.0  # the head's overshoot is looked for this long after a stop or turn


@dataclass(frozen=True)
class Series:
    """Per-frame series of the running scene, aligned on the camera frames (one row per frame)."""

    t: np.ndarray  # scene time, s
    stamp: np.ndarray  # frame header stamp, s
    pan_error: np.ndarray  # true angle of the target centre from the optical axis, rad (REP-103)
    tilt_error: np.ndarray
    visible: np.ndarray  # visible fraction of the target
    centre_in_view: np.ndarray  # bool: the target's centre is inside the image
    gt: list  # Box-like [x, y, w, h] or None per frame
    track: list  # [x, y, w, h] or None: the tracker's box for that frame (None: no output for it)
    state: list  # tracker state string for that frame ("" when none arrived)
    head_pan: np.ndarray  # head pose the frame was rendered at, rad
    head_tilt: np.ndarray


@dataclass(frozen=True)
class Episode:
    """One occlusion of the target: scene-time interval and whether the track survived it."""

    start: float
    end: float
    min_visible: float
    survived: bool
    note: str = ""  # "survived", "not re-acquired", or "target out of view" (the head had already lost it)


@dataclass
class RunSummary:
    """The figures the report prints for one run (angles in degrees, times in seconds)."""

    label: str
    ego_motion_compensation: bool
    outcome: str
    duration_s: float
    frames: int
    time_in_view_s: float
    in_view_fraction: float
    in_view_at_end: bool
    centring_error_mean_deg: float
    centring_error_p95_deg: float
    centring_error_mean_px: float
    centring_error_p95_px: float
    track_centre_error_mean_px: float
    precision_20px: float
    occlusions: int
    occlusions_survived: int
    camera_fps: float
    tracker_fps: float
    latency_p50_ms: float
    latency_p95_ms: float
    lost_frames: int
    final_state: str
    false_tracking_frames: int = 0  # state `tracking` while the box does not overlap the true target
    frames_skipped: int = 0  # camera frames of the run the tracker produced no output for
    initial_offset_deg: list[float] = field(default_factory=list)  # target pan/tilt from the axis at start
    head_travel_deg: list[float] = field(default_factory=list)  # pan/tilt turned between start and end
    # Largest pan/tilt turn towards the target's initial direction (positive: the head went that way).
    head_turn_towards_deg: list[float] = field(default_factory=list)
    episodes: list[dict] = field(default_factory=list)
    # From SETTLE_S after the track started to the end of the run (issue 34): the true angle of the target
    # from the optical axis, and the head's largest overshoot after the target stopped or turned.
    centring_error_settled_mean_deg: float = math.nan
    centring_error_settled_p95_deg: float = math.nan
    overshoot_deg: float = 0.0
    stop_turn_events: list[dict] = field(default_factory=list)  # scene t, axis, kind, overshoot_deg
    # Latency budget of the loop, from the bridge's /diagnostics (ms): frame stamp -> error at the bridge,
    # frame stamp -> Pelco frame written (p50 over the report windows; p95: 95th percentile of their p95).
    bridge_error_age_p50_ms: float = math.nan
    bridge_command_age_p50_ms: float = math.nan
    bridge_command_age_p95_ms: float = math.nan

    def as_dict(self) -> dict:
        return asdict(self)


def _nearest(stamps: np.ndarray, values: list, query: np.ndarray, tol: float = 1e-4) -> list:
    """values[i] for the stamp equal (within tol) to each query stamp, else None."""
    if len(stamps) == 0:
        return [None] * len(query)
    order = np.argsort(stamps)
    s = stamps[order]
    idx = np.clip(np.searchsorted(s, query), 0, len(s) - 1)
    out = []
    for q, i in zip(query, idx):
        best = min((j for j in (i - 1, i) if 0 <= j < len(s)), key=lambda j: abs(s[j] - q))
        out.append(values[order[best]] if abs(s[best] - q) <= tol else None)
    return out


def series(rec: RunRecords) -> Series:
    """Align ground truth, tracker boxes and states on the frames rendered while the scene clock ran."""
    truth = np.array(rec.truth, dtype=np.float64).reshape(-1, 8)
    running = truth[:, 1] > 0.0 if len(truth) else np.zeros(0, bool)
    truth = truth[running]
    stamps = truth[:, 0]
    cam = rec.camera or {"width": 576, "height": 504, "fx": 1.0, "fy": 1.0}
    pan_e, tilt_e = truth[:, 4], truth[:, 5]
    with np.errstate(invalid="ignore"):
        centre_in = ((cam["fx"] * np.tan(np.abs(pan_e)) < cam["width"] / 2.0)
                     & (cam["fy"] * np.tan(np.abs(tilt_e)) < cam["height"] / 2.0))
    gt_stamps = np.array([g[0] for g in rec.gt], dtype=np.float64)
    tr_stamps = np.array([r[0] for r in rec.track], dtype=np.float64)
    st_stamps = np.array([r[0] for r in rec.state], dtype=np.float64)
    states = [s or "" for s in _nearest(st_stamps, [r[2] for r in rec.state], stamps)]
    return Series(truth[:, 1], stamps, pan_e, tilt_e, truth[:, 3], centre_in,
                  _nearest(gt_stamps, [g[1] for g in rec.gt], stamps),
                  _nearest(tr_stamps, [r[2] for r in rec.track], stamps), states, truth[:, 6], truth[:, 7])


def _on_target(gt: list | None, track: list | None) -> bool:
    if gt is None or track is None:
        return False
    d = math.hypot(gt[0] + gt[2] / 2 - track[0] - track[2] / 2, gt[1] + gt[3] / 2 - track[1] - track[3] / 2)
    return d <= max(ON_TARGET_PX, 0.5 * gt[2])


def _overlaps(gt: list | None, track: list | None) -> bool:
    """The two [x, y, w, h] boxes share a positive area (False when either is missing)."""
    if gt is None or track is None:
        return False
    ix = min(gt[0] + gt[2], track[0] + track[2]) - max(gt[0], track[0])
    iy = min(gt[1] + gt[3], track[1] + track[3]) - max(gt[1], track[1])
    return ix > 0.0 and iy > 0.0


def false_tracking_frames(s: Series) -> int:
    """Frames the tracker called `tracking` while its box did not overlap the target's true box at all
    (the target out of the image counts as no overlap): the head is then steered by something else."""
    return sum(st == "tracking" and not _overlaps(g, tr) for st, g, tr in zip(s.state, s.gt, s.track))


def occlusion_episodes(s: Series, visibility: np.ndarray | None = None) -> list[Episode]:
    """Runs of frames with visible < OCCLUDED_BELOW lasting MIN_EPISODE_S or more (gaps shorter merged).

    `visibility`: the target's visible fraction per frame independent of the head (`world.target_visibility`),
    so every run of a scene has the same episodes; without it, the rendered frames' visibility while the
    target's centre is in view. Survived: within RECOVERY_S after the target is visible again, the tracker
    reports `tracking` on a box whose centre is on the target (see `ON_TARGET_PX`). An occlusion still going
    on when the run ends is left out.
    """
    if visibility is not None:
        hidden = np.asarray(visibility) < OCCLUDED_BELOW
    else:
        hidden = (s.visible < OCCLUDED_BELOW) & s.centre_in_view
    runs: list[list[int]] = []
    for i in np.flatnonzero(hidden):
        if runs and s.t[i] - s.t[runs[-1][1]] <= MIN_EPISODE_S:
            runs[-1][1] = int(i)
        else:
            runs.append([int(i), int(i)])
    episodes = []
    for a, b in runs:
        end = s.t[b + 1] if b + 1 < len(s.t) else s.t[b]  # hidden until the next frame shows it again
        if end - s.t[a] < MIN_EPISODE_S:
            continue
        if b + 1 >= len(s.t):
            continue  # still hidden when the run ended: not an episode the track could survive yet
        after = [k for k in range(b + 1, len(s.t)) if s.t[k] <= s.t[b] + RECOVERY_S]
        survived = any(s.state[k] == "tracking" and _on_target(s.gt[k], s.track[k]) for k in after)
        in_view = bool(s.centre_in_view[a:b + 2].any())
        note = "survived" if survived else ("not re-acquired" if in_view else "target out of view")
        vis = s.visible if visibility is None else np.asarray(visibility)
        episodes.append(Episode(float(s.t[a]), float(s.t[b]), float(vis[a:b + 1].min()), survived, note))
    return episodes


def track_start(rec: RunRecords, s: Series) -> float:
    """Stamp of the tracker's first `tracking` / `occluded` report for a frame at or after the first init
    (the supervisor's `init_answered`); the first frame's stamp when there is none."""
    init = rec.init_time if math.isfinite(rec.init_time) else -math.inf
    starts = [r[0] for r in rec.state if r[2] in ("tracking", "occluded") and r[0] >= init]
    return min(starts) if starts else (float(s.stamp[0]) if len(s.stamp) else math.nan)


def stop_turn_events(t: np.ndarray, direction: np.ndarray) -> list[tuple[float, int, str, float]]:
    """(time, sign of the rate before, 'stop' | 'turn', time the target moves again) where the target's
    motion along one axis ends.

    `direction` is the target's true angle (deg) over time `t`; its rate is a central difference over
    +-0.1 s. A motion is a run of at least MIN_RUN_S with |rate| > MOVING_DEG_S in one direction; it ends
    in a stop (the rate falls below that) or a turn (the rate changes sign at once). The last 0.1 s, where
    the difference runs off the data, ends nothing.
    """
    if len(t) < 3:
        return []
    rate = (np.interp(t + 0.1, t, direction) - np.interp(t - 0.1, t, direction)) / 0.2
    sign = np.where(np.abs(rate) > MOVING_DEG_S, np.sign(rate), 0.0)
    events, start = [], 0
    for i in range(1, len(t)):
        if sign[i] == sign[start]:
            continue
        if sign[start] != 0 and t[i - 1] - t[start] >= MIN_RUN_S and t[i] < t[-1] - 0.1:
            moving_again = np.flatnonzero(sign[i:] != 0)
            t_next = float(t[i + moving_again[0]]) if moving_again.size else float(t[-1])
            events.append((float(t[i]), int(sign[start]), "stop" if sign[i] == 0 else "turn", t_next))
        start = i
    return events


def overshoots(s: Series, settled: np.ndarray) -> list[dict]:
    """The head's overshoot at every stop or turn of the target in the settled window: how far the optical
    axis travelled past the point where the target stopped or turned (deg), within OVERSHOOT_WINDOW_S and,
    after a stop, before the target moves again (the head then follows it past that point, rightly)."""
    out = []
    for axis, head, error in (("pan", s.head_pan, s.pan_error), ("tilt", s.head_tilt, s.tilt_error)):
        direction = np.degrees(head + error)
        for t_e, sign, kind, t_next in stop_turn_events(s.t, direction):
            end = t_e + OVERSHOOT_WINDOW_S if kind == "turn" else min(t_next, t_e + OVERSHOOT_WINDOW_S)
            window = settled & (s.t >= t_e) & (s.t <= end)
            if window.any():
                past = sign * (np.degrees(head[window]) - np.interp(t_e, s.t, direction))
                out.append({"t": round(t_e, 2), "axis": axis, "kind": kind,
                            "overshoot_deg": max(0.0, float(np.max(past)))})
    return out


def diagnostic_series(rec: RunRecords, name: str, key: str, t0: float, t1: float) -> np.ndarray:
    """The finite values of `key` in status `name`'s /diagnostics reports received in [t0, t1 + 1.5 s]."""
    out = []
    for d in rec.diagnostics:
        if d.get("name") == name and t0 <= d.get("recv", 0.0) <= t1 + 1.5:
            try:
                out.append(float(d["values"][key]))
            except (KeyError, TypeError, ValueError):
                continue
    values = np.array(out)
    return values[np.isfinite(values)]


def bridge_latency(rec: RunRecords, t0: float, t1: float) -> tuple[float, float, float]:
    """(frame -> bridge p50, frame -> Pelco frame p50, its p95) in ms from the bridge's /diagnostics."""
    def series_(key: str) -> np.ndarray:
        return diagnostic_series(rec, "/positioner_bridge: positioner", key, t0, t1)

    return (_stat(series_("error_age_ms_p50"), 50), _stat(series_("command_age_ms_p50"), 50),
            _stat(series_("command_age_ms_p95"), 95))


def _stat(values: np.ndarray, q: float | None = None) -> float:
    values = values[np.isfinite(values)]
    if values.size == 0:
        return math.nan
    return float(np.mean(values) if q is None else np.percentile(values, q))


def summarise(rec: RunRecords, visibility_fn=None) -> RunSummary:
    """Scores of one run; visibility_fn(times) -> visible fractions makes the occlusion episodes
    independent of the head (see `occlusion_episodes`)."""
    s = series(rec)
    cam = rec.camera or {"fx": math.nan, "fy": math.nan}
    n = len(s.t)
    dt = np.diff(s.t, append=s.t[-1] + (s.t[-1] - s.t[-2] if n > 1 else 0.0)) if n else np.zeros(0)
    err = np.hypot(s.pan_error, s.tilt_error)
    err_px = np.hypot(cam["fx"] * np.tan(s.pan_error), cam["fy"] * np.tan(s.tilt_error))
    track_err = np.array([
        math.hypot(g[0] + g[2] / 2 - tr[0] - tr[2] / 2, g[1] + g[3] / 2 - tr[1] - tr[3] / 2)
        if g is not None and tr is not None else math.nan for g, tr in zip(s.gt, s.track)])
    pairs = np.isfinite(track_err)
    visibility = np.asarray(visibility_fn(s.t)) if visibility_fn is not None and len(s.t) else None
    episodes = occlusion_episodes(s, visibility)
    t0, t1 = (s.stamp[0], s.stamp[-1]) if n else (0.0, 0.0)
    span = max(t1 - t0, 1e-9)
    frames_in = [r for r in rec.frames if t0 <= r[0] <= t1]
    outputs = [r for r in rec.error if t0 <= r[0] <= t1]
    latency = tracker_latency_ms(rec, t0, t1)
    joints = np.array([[r[0], r[2], r[3]] for r in rec.joints]) if rec.joints else np.zeros((0, 3))
    travel, towards = [0.0, 0.0], [0.0, 0.0]
    if len(joints) and n:
        start = joints[np.argmin(np.abs(joints[:, 0] - t0))]
        end = joints[np.argmin(np.abs(joints[:, 0] - t1))]
        travel = [math.degrees(end[1] - start[1]), math.degrees(end[2] - start[2])]
        during = joints[(joints[:, 0] >= t0) & (joints[:, 0] <= t1)]
        if len(during):
            for i, offset in enumerate((s.pan_error[0], s.tilt_error[0])):
                towards[i] = math.degrees(float(np.max((during[:, 1 + i] - start[1 + i]) * np.sign(offset))))
    settled = s.stamp >= track_start(rec, s) + SETTLE_S if n else np.zeros(0, bool)
    events = overshoots(s, settled)
    ages = bridge_latency(rec, t0, t1)
    return RunSummary(
        label=rec.label, ego_motion_compensation=rec.ego_motion_compensation, outcome=rec.outcome,
        duration_s=float(s.t[-1]) if n else 0.0, frames=n,
        time_in_view_s=float(np.sum(dt[s.centre_in_view])) if n else 0.0,
        in_view_fraction=float(np.mean(s.centre_in_view)) if n else 0.0,
        in_view_at_end=bool(n and s.centre_in_view[-1]),
        centring_error_mean_deg=math.degrees(_stat(err)), centring_error_p95_deg=math.degrees(_stat(err, 95)),
        centring_error_mean_px=_stat(err_px), centring_error_p95_px=_stat(err_px, 95),
        track_centre_error_mean_px=_stat(track_err),
        precision_20px=float(np.mean(track_err[pairs] <= 20.0)) if pairs.any() else 0.0,
        occlusions=len(episodes), occlusions_survived=sum(e.survived for e in episodes),
        camera_fps=(len(frames_in) - 1) / span if frames_in else 0.0,
        tracker_fps=(len(outputs) - 1) / span if outputs else 0.0,
        latency_p50_ms=_stat(latency, 50), latency_p95_ms=_stat(latency, 95),
        lost_frames=sum(st == "lost" for st in s.state),
        false_tracking_frames=false_tracking_frames(s),
        frames_skipped=sum(st == "" for st in s.state),
        final_state=next((r[2] for r in reversed(rec.state) if r[0] <= t1 + 1e-6), ""),
        initial_offset_deg=[math.degrees(s.pan_error[0]), math.degrees(s.tilt_error[0])] if n else [],
        head_travel_deg=travel, head_turn_towards_deg=towards, episodes=[asdict(e) for e in episodes],
        centring_error_settled_mean_deg=math.degrees(_stat(err[settled])),
        centring_error_settled_p95_deg=math.degrees(_stat(err[settled], 95)),
        overshoot_deg=max((e["overshoot_deg"] for e in events), default=0.0), stop_turn_events=events,
        bridge_error_age_p50_ms=ages[0], bridge_command_age_p50_ms=ages[1], bridge_command_age_p95_ms=ages[2],
    )


def tracker_latency_ms(rec: RunRecords, t0: float, t1: float) -> np.ndarray:
    """Frame stamp -> tracker output latencies (ms) of the run [t0, t1].

    The tracker's own /diagnostics (`stamp_age_ms_p50` of each report window: header stamp to publish on
    the node clock) when it reports them; otherwise stamp to arrival at the recorder, which also counts
    the recorder's own queue (it records every camera image, so it lags when the machine is busy).
    """
    ages = diagnostic_series(rec, "/tracker: tracker_node", "stamp_age_ms_p50", t0, t1)
    if len(ages):
        return ages
    return np.array([(r[1] - r[0]) * 1e3 for r in rec.error if t0 <= r[0] <= t1])


def read_trace(path: Path) -> np.ndarray:
    """pelco_sim's true-pose CSV as an array of rows [time, pan, tilt] (rad); empty when missing."""
    rows = []
    try:
        with path.open(newline="") as fh:
            for row in csv.reader(fh):
                try:
                    rows.append([float(row[0]), float(row[1]), float(row[2])])
                except (ValueError, IndexError):
                    continue  # header line
    except OSError:
        return np.zeros((0, 3))
    return np.array(rows).reshape(-1, 3)
