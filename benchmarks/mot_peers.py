# SPDX-License-Identifier: Apache-2.0
"""Peer multi-object trackers (SORT, ByteTrack, OC-SORT of the `trackers` package) on replayed detections.

Runs inside the peer venv (.venv-mot, `make mot-venv`, requirements-mot.txt): `trackers` declares the
non-headless `opencv-python`, which must not meet the project's headless OpenCV in .venv or .venv-bench.
`mot_eval.py` (in .venv, with motmetrics) calls it as a subprocess and scores its output like our rows:

    .venv-mot/bin/python benchmarks/mot_peers.py IN.json OUT.json

IN.json: {"frame_rate": fps, "frames": [[[x, y, w, h, score], ...] per frame], "configs": [{"name": str,
"tracker": "sort" | "bytetrack" | "ocsort", "kwargs": {...}}]}; scores in [0, 1].
OUT.json: {name: [[[id, x, y, w, h], ...] per frame]}: the confirmed tracks of each frame (tracker_id >= 0),
with the boxes the peers output (the matched detections). Nothing here imports the project.

    .venv-mot/bin/python benchmarks/mot_peers.py --hota IN.json OUT.json

HOTA (Luiten et al., IJCV 2021) of tracking outputs by `trackers.eval` (TrackEval's matching): IN.json
{"gt": [[frame, id, x, y, w, h], ...], "runs": {name: [[frame, id, x, y, w, h], ...]}}; OUT.json {name: HOTA
in [0, 1]} (0 for a run without boxes). Rows are written as MOT17 lines (conf 1, class 1 pedestrian,
visibility 1): `trackers.eval` drops other classes.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import supervision as sv
from trackers import ByteTrackTracker, OCSORTTracker, SORTTracker

TRACKERS = {"sort": SORTTracker, "bytetrack": ByteTrackTracker, "ocsort": OCSORTTracker}


def run(frames: list[list[list[float]]], tracker: str, kwargs: dict, frame_rate: float) -> dict:
    trk = TRACKERS[tracker](frame_rate=frame_rate, **kwargs)
    out = []
    times = []
    for dets in frames:
        a = np.asarray(dets, dtype=np.float64).reshape(-1, 5)
        xyxy = np.column_stack([a[:, 0], a[:, 1], a[:, 0] + a[:, 2], a[:, 1] + a[:, 3]])
        d = sv.Detections(xyxy=xyxy.reshape(-1, 4), confidence=a[:, 4].copy(),
                          class_id=np.zeros(len(a), dtype=int))
        t0 = time.perf_counter()
        res = trk.update(d)
        times.append(time.perf_counter() - t0)
        ids = np.asarray(res.tracker_id if res.tracker_id is not None else [], dtype=int)
        rows = []
        for k in np.flatnonzero(ids >= 0):
            x0, y0, x1, y1 = (float(v) for v in res.xyxy[k])
            rows.append([int(ids[k]), x0, y0, x1 - x0, y1 - y0])
        out.append(rows)
    return {"tracks": out, "ms": 1000.0 * float(np.mean(times)) if times else 0.0}


def hota(gt: list[list[float]], runs: dict[str, list[list[float]]]) -> dict[str, float]:
    """HOTA of every run against the ground truth (MOT files written to a temporary folder)."""
    from trackers.eval import evaluate_mot_sequence

    def write(path: Path, rows: list[list[float]]) -> None:
        path.write_text("".join(f"{int(f)},{int(i)},{x:.3f},{y:.3f},{w:.3f},{h:.3f},1,1,1\n"
                                for f, i, x, y, w, h in rows))

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        write(Path(tmp) / "gt.txt", gt)
        for name, rows in runs.items():
            if not rows:
                out[name] = 0.0
                continue
            write(Path(tmp) / "run.txt", rows)
            res = evaluate_mot_sequence(Path(tmp) / "gt.txt", Path(tmp) / "run.txt", metrics=["HOTA"])
            out[name] = float(res.HOTA.HOTA)
    return out


def main(argv: list[str]) -> int:
    if len(argv) == 3 and argv[0] == "--hota":
        with open(argv[1]) as f:
            job = json.load(f)
        with open(argv[2], "w") as f:
            json.dump(hota(job["gt"], job["runs"]), f)
        return 0
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    with open(argv[0]) as f:
        job = json.load(f)
    res = {c["name"]: run(job["frames"], c["tracker"], c["kwargs"], job["frame_rate"])
           for c in job["configs"]}
    with open(argv[1], "w") as f:
        json.dump(res, f)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
