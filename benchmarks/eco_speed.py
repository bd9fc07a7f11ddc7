# SPDX-License-Identifier: Apache-2.0
"""Speed of the ECO base filter (core/eco) against the ECO-HC Python port, on the same frames, one thread.

Used by benchmarks/core_speed.py (synthetic frames, rows "ECO ...") and on its own on real sequences:

    .venv/bin/python benchmarks/eco_speed.py [--sequences ../shared/data/sequences] [--names a,b] [--frames N]

The port (the public StrangerZhang/pyECO, ECO-HC gray configuration) is never a dependency: it is timed only
when `ECOHC_PORT_DIR` names a checkout of it whose features extension is built; its interpreter is
`ECOHC_PORT_PYTHON` (default `<dir>/.venv/bin/python`, with numpy, scipy and opencv). The port imports mxnet
for its deep features, which the hand-crafted configuration never calls: the child gives it an empty stand-in
module. Times are process CPU time per frame after the first (init excluded), OpenBLAS/OpenMP at 1 thread.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))

from core_speed import summarise  # noqa: E402  (fps, cpu_fps, p50 / p95 / max ms: one definition)

PORT_CHILD = r"""
import json, os, sys, time
import numpy as np
stub = sys.argv[3]
for d in ("mxnet/gluon/model_zoo", "mxnet/gluon/nn"):
    os.makedirs(os.path.join(stub, d), exist_ok=True)
for f, text in (("mxnet/__init__.py", ""), ("mxnet/gluon/__init__.py", ""),
                ("mxnet/gluon/model_zoo/__init__.py", "vision = None\n"),
                ("mxnet/gluon/nn/__init__.py", "class AvgPool2D:\n    pass\n")):
    open(os.path.join(stub, f), "w").write(text)
sys.path[:0] = [stub, sys.argv[4]]
import scipy.signal, scipy.signal.windows
if not hasattr(scipy.signal, "hann"):
    scipy.signal.hann = scipy.signal.windows.hann
from eco import ECOTracker
frames = np.load(sys.argv[1])
x, y, w, h = (float(v) for v in sys.argv[2].split(","))
t = ECOTracker(False)
t.init(frames[0][:, :, None], (x, y, w, h), total_frame=len(frames))
times = []
c0 = time.process_time()
for f in frames[1:]:
    t0 = time.perf_counter()
    t.update(f[:, :, None], True)
    times.append(time.perf_counter() - t0)
print(json.dumps({"times": times, "cpu": time.process_time() - c0}))
"""


def time_eco(frames: np.ndarray, box: tuple[float, ...], estimator: str = "dsst") -> dict:
    """Per-frame times of the short-term ECO tracker (core/eco/tracker.py) on `frames` (8 or 16 bit)."""
    from swir_tracker_ros.core import fhog
    from swir_tracker_ros.core.eco.params import ECOParams
    from swir_tracker_ros.core.eco.tracker import ECOTracker
    from swir_tracker_ros.types import Box

    fhog.warm_up()
    trk = ECOTracker(ECOParams(scale_estimator=estimator))
    trk.init(frames[0], Box(*box))
    trk.update(frames[0])  # compiles the ECO loops outside the timed frames
    trk.init(frames[0], Box(*box))
    times = []
    c0 = time.process_time()
    for f in frames[1:]:
        t0 = time.perf_counter()
        trk.update(f)
        times.append(time.perf_counter() - t0)
    return summarise(times, time.process_time() - c0)


def port_python() -> tuple[Path, Path] | None:
    """(interpreter, checkout) of the ECO-HC port when `ECOHC_PORT_DIR` is set and usable, else None."""
    d = os.environ.get("ECOHC_PORT_DIR")
    if not d:
        return None
    py = Path(os.environ.get("ECOHC_PORT_PYTHON", Path(d) / ".venv" / "bin" / "python"))
    if not (Path(d) / "eco" / "tracker.py").exists() or not py.exists():
        print(f"ECOHC_PORT_DIR={d}: no eco/tracker.py or no interpreter {py}", file=sys.stderr)
        return None
    return py, Path(d)


def time_port(frames8: np.ndarray, box: tuple[float, ...]) -> dict:
    """Per-frame times of the ECO-HC port on the same 8-bit frames ({} when it is not installed)."""
    found = port_python()
    if found is None:
        return {}
    py, checkout = found
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "frames8.npy")
        np.save(path, frames8)
        env = dict(
            os.environ, PYTHONPATH="", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1"
        )
        proc = subprocess.run(
            [
                str(py),
                "-c",
                PORT_CHILD,
                path,
                ",".join(str(v) for v in box),
                os.path.join(tmp, "stub"),
                str(checkout),
            ],
            capture_output=True,
            text=True,
            env=env,
            check=False,
        )
    if proc.returncode != 0:
        print(proc.stderr[-2000:], file=sys.stderr)
        return {}
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    return summarise(out["times"], out["cpu"])


def load_sequence(d: Path, limit: int) -> tuple[np.ndarray, tuple[float, ...]]:
    import cv2

    files = sorted(f for f in d.iterdir() if f.suffix in (".png", ".jpg"))[:limit]
    frames = np.stack([cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) for f in files])
    first = (d / "gt.txt").read_text().splitlines()[0].replace(",", " ").split()
    return frames, tuple(float(v) for v in first[:4])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sequences", default=str(REPO.parent / "shared" / "data" / "sequences"))
    ap.add_argument("--names", default="", help="comma-separated sequence names (default: all)")
    ap.add_argument("--frames", type=int, default=100000, help="at most this many frames per sequence")
    args = ap.parse_args()
    root = Path(args.sequences)
    names = args.names.split(",") if args.names else sorted(p.name for p in root.iterdir() if p.is_dir())
    rows, total = [], {"eco": [0, 0.0], "port": [0, 0.0]}
    print(
        f"{'sequence':22s} {'frames':>6s} {'ECO dsst':>9s} {'ECO-HC port':>11s}",
        "(CPU fps)",
    )
    for name in names:
        frames, box = load_sequence(root / name, args.frames)
        res = {
            "eco": time_eco(frames, box, "dsst"),
            "port": time_port(frames, box),
        }
        n = len(frames) - 1
        for k, r in res.items():
            if r:
                total[k][0] += n
                total[k][1] += n / r["cpu_fps"]
        cells = [
            f"{res[k]['cpu_fps']:>9.1f}" if res[k] else f"{'-':>9s}" for k in ("eco", "port")
        ]
        print(f"{name:22s} {n:6d} {cells[0]} {cells[1]:>11s}")
        rows.append({"sequence": name, "frames": n, **{k: v.get("cpu_fps") for k, v in res.items()}})
    summary = {k: (v[0] / v[1] if v[1] else None) for k, v in total.items()}
    print(
        f"{'all (frames / CPU s)':22s} {'':6s} "
        + " ".join(
            f"{summary[k]:>9.1f}" if summary[k] else f"{'-':>9s}" for k in ("eco", "port")
        )
    )
    print(json.dumps({"cpu_fps": summary, "sequences": rows}))


if __name__ == "__main__":
    main()
