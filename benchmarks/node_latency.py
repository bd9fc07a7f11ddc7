# SPDX-License-Identifier: Apache-2.0
"""Image -> /track/pan_tilt_error latency and drops of the installed `tracker` node (prints figures).

Starts the `tracker` executable as a separate process, publishes a synthetic 640x512 mono16 target
sequence at 25 Hz over DDS (sensor-data QoS) and measures, per frame, the wall time from the image
header stamp (set just before publishing) to the arrival of /track/pan_tilt_error with that stamp.
The node's /diagnostics of the same run give the core's per-frame time (`Tracker.update`) and the
in-node latency. Not a test: it asserts nothing, it prints numbers.

    .venv/bin/python benchmarks/node_latency.py [--frames 2000] [--rate 25]
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", str(101 + os.getpid() % 100))

import rclpy  # the DDS environment above must be set before rclpy loads
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped, Vector3Stamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import Image, RegionOfInterest

from msg_adapters.diagnostics import status_values
from msg_adapters.errors import MessageError
from msg_adapters.geometry import box_from_polygon
from msg_adapters.image import numpy_to_image
from msg_adapters.qos import profile
from msg_adapters.stamps import header, seconds_to_stamp, stamp_to_seconds
from swir_tracker_ros import topics
from swir_tracker_ros.nodes.tracker_node import DIAG_NAME

REPO = Path(__file__).resolve().parent.parent
TARGET = 32

# Fast DDS's built-in shared-memory segment (512 KiB) is smaller than one 640x512 mono16 frame (640 KiB),
# so such frames travel as UDP fragments, and best-effort samples are lost whenever a fragment overflows
# the socket buffer. A shared-memory transport with a larger segment carries them whole.
SHM_PROFILE_FILE = REPO / "config" / "fastdds_shm_udp.xml"


class SyntheticSequence:
    """A textured target on a Lissajous path over a noisy, vignetted 16-bit background (8 noise frames)."""

    def __init__(self, width: int, height: int, seed: int = 1) -> None:
        rng = np.random.default_rng(seed)
        self.width, self.height = width, height
        yy, xx = np.mgrid[0:height, 0:width]
        vignette = np.cos((xx - width / 2) / width * 2.0) * np.cos((yy - height / 2) / height * 2.0)
        base = 4000.0 + 800.0 * vignette
        self.backgrounds = [np.clip(base + rng.normal(0, 60, (height, width)), 0, 65535).astype(np.uint16)
                            for _ in range(8)]
        cells = rng.integers(0, 2, (TARGET // 4, TARGET // 4)).repeat(4, 0).repeat(4, 1)
        self.patch = (5000 * cells + 2000).astype(np.uint16)

    def centre(self, i: int) -> tuple[float, float]:
        return (self.width / 2 + 0.25 * self.width * math.sin(2 * math.pi * i / 400.0),
                self.height / 2 + 0.2 * self.height * math.sin(2 * math.pi * i / 300.0))

    def frame(self, i: int) -> np.ndarray:
        img = self.backgrounds[i % len(self.backgrounds)].copy()
        cx, cy = self.centre(i)
        x0, y0 = round(cx - TARGET / 2), round(cy - TARGET / 2)
        img[y0:y0 + TARGET, x0:x0 + TARGET] += self.patch
        return img


class Bench(Node):
    def __init__(self) -> None:
        super().__init__("node_latency_bench")
        self.pub = self.create_publisher(Image, topics.IMAGE, profile(topics.LATEST))
        self.init = self.create_publisher(RegionOfInterest, topics.TRACK_INIT, profile(topics.RELIABLE))
        self.latency: dict[float, float] = {}
        self.boxes: dict[float, PolygonStamped] = {}
        self.diags: list[dict[str, str]] = []
        record, reliable = profile(topics.RECORD), profile(topics.RELIABLE)
        self.create_subscription(Vector3Stamped, topics.PAN_TILT_ERROR, self._on_error, record)
        self.create_subscription(PolygonStamped, topics.TRACK_BOX, self._on_box, record)
        self.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, self._on_diag, reliable)

    def _on_error(self, msg: Vector3Stamped) -> None:
        stamp = stamp_to_seconds(msg.header.stamp)
        self.latency[stamp] = time.time() - stamp

    def _on_box(self, msg: PolygonStamped) -> None:
        self.boxes[stamp_to_seconds(msg.header.stamp)] = msg

    def _on_diag(self, msg: DiagnosticArray) -> None:
        with contextlib.suppress(MessageError):
            self.diags.append(status_values(msg, DIAG_NAME))




def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=2000)
    ap.add_argument("--warmup", type=int, default=50, help="frames sent first and left out of the figures")
    ap.add_argument("--rate", type=float, default=25.0)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=512)
    ap.add_argument("--executable", default=str(Path(sys.prefix) / "bin" / "tracker"))
    ap.add_argument("--transport", choices=("shm", "default"), default="shm",
                    help="shm: Fast DDS shared memory with a 16 MiB segment, and UDP "
                    "(config/fastdds_shm_udp.xml); "
                         "default: Fast DDS built-in transports")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="node_latency_"))
    if args.transport == "shm":
        os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(SHM_PROFILE_FILE)  # here and in the node

    seq = SyntheticSequence(args.width, args.height)
    cx, cy = seq.centre(0)
    log = tmp / "tracker.log"
    cmd = [args.executable, "--ros-args", "--params-file", str(REPO / "params" / "tracker.yaml"),
           "-p", "fov_h_deg:=20.0"]
    fh = log.open("wb")
    proc = subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT, start_new_session=True)
    rclpy.init()
    node = Bench()
    # Outputs are received on their own thread, so that building and pacing frames never delays them.
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    spinner = threading.Thread(target=ex.spin, daemon=True)
    spinner.start()
    stamps: list[float] = []
    try:
        end = time.monotonic() + 60
        while node.pub.get_subscription_count() == 0 and time.monotonic() < end and proc.poll() is None:
            time.sleep(0.1)
        if node.pub.get_subscription_count() == 0:
            print(f"tracker did not subscribe; log {log}:\n{log.read_text(errors='replace')}")
            return 1
        time.sleep(1.0)  # let discovery settle in both directions
        period = 1.0 / args.rate
        total = args.warmup + args.frames
        nxt = time.monotonic()
        msg = numpy_to_image(seq.frame(0), header(0.0, "swir"))
        t_start = time.monotonic()
        # The target stands still during the warm-up; the selection arrives with the first frames.
        node.init.publish(RegionOfInterest(x_offset=round(cx - TARGET / 2), y_offset=round(cy - TARGET / 2),
                                           width=TARGET, height=TARGET))
        for i in range(total):
            time.sleep(max(0.0, nxt - time.monotonic()))
            stamp = time.time()
            msg.header.stamp = seconds_to_stamp(stamp)
            node.pub.publish(msg)
            stamps.append(stamp_to_seconds(msg.header.stamp))
            nxt += period
            k = max(0, i + 1 - args.warmup)
            msg = numpy_to_image(seq.frame(k), header(0.0, "swir"))  # next frame built while waiting
        wall = time.monotonic() - t_start
        time.sleep(2.5)  # drain: late answers and the last diagnostics window
    finally:
        ex.shutdown()
        spinner.join(5)
        node.destroy_node()
        rclpy.try_shutdown()
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(15)
            except subprocess.TimeoutExpired:
                proc.kill()
        fh.close()

    measured = stamps[args.warmup:]
    lat = np.array([node.latency[s] for s in measured if s in node.latency]) * 1e3
    drops = sum(1 for s in measured if s not in node.boxes)  # never processed (a box goes out every frame)
    no_error = sum(1 for s in measured if s not in node.latency)
    errors = []
    for i, s in enumerate(stamps):
        if i >= args.warmup and s in node.boxes and (box := box_from_polygon(node.boxes[s])) is not None:
            tx, ty = seq.centre(i - args.warmup)
            errors.append(math.hypot(box.cx - tx, box.cy - ty))
    windows = [d for d in node.diags if int(d.get("window_processed", "0")) > 0]
    core_mean = np.average([float(d["core_ms_mean"]) for d in windows],
                           weights=[int(d["window_processed"]) for d in windows]) if windows else math.nan
    core_p50 = float(np.median([float(d["core_ms_p50"]) for d in windows])) if windows else math.nan
    core_p99 = max((float(d["core_ms_p99"]) for d in windows), default=math.nan)
    node_p99 = max((float(d["latency_ms_p99"]) for d in windows), default=math.nan)
    last = node.diags[-1] if node.diags else {}
    p50, p99 = (np.percentile(lat, 50), np.percentile(lat, 99)) if lat.size else (math.nan, math.nan)
    print(f"node latency: {args.width}x{args.height} mono16 at {args.rate:g} Hz, {len(measured)} frames "
          f"measured (+{args.warmup} warm-up), sent in {wall:.1f} s; transport {args.transport}; "
          f"load average {os.getloadavg()[0]:.2f}, nice {os.nice(0)}")
    print(f"  image -> /track/pan_tilt_error  p50 {p50:6.2f} ms  p99 {p99:6.2f} ms  max {lat.max():6.2f} ms")
    print(f"  dropped frames (no /track/box): {drops} of {len(measured)}; frames without pan_tilt_error: "
          f"{no_error}; node totals: "
          f"skipped {last.get('total_dropped_skipped', '?')}, stale {last.get('total_dropped_stale', '?')}, "
          f"malformed {last.get('total_dropped_malformed', '?')}, callback errors "
          f"{last.get('total_callback_errors', '?')}")
    print(f"  core Tracker.update per frame (node /diagnostics, same run): mean {core_mean:.2f} ms, "
          f"p50 {core_p50:.2f} ms (median of 1 s windows), p99 {core_p99:.2f} ms (worst window)")
    age_p50 = float(np.median([float(d["stamp_age_ms_p50"]) for d in windows])) if windows else math.nan
    over_p50 = float(np.median([float(d["overhead_ms_p50"]) for d in windows])) if windows else math.nan
    over_p99 = max((float(d["overhead_ms_p99"]) for d in windows), default=math.nan)
    print(f"  in-node receive -> publish p99 {node_p99:.2f} ms (worst window); stamp -> publish p50 "
          f"{age_p50:.2f} ms (median of windows)")
    print(f"  in-node time beyond the core (decode, ego shift, publish): p50 {over_p50:.2f} ms, "
          f"p99 {over_p99:.2f} ms (worst window)")
    print(f"  p99 latency beyond the core's p99: {p99 - core_p99:.2f} ms (target < 15 ms, zero drops)")
    if errors:
        print(f"  tracking: centre error mean {np.mean(errors):.2f} px, max {np.max(errors):.2f} px over "
              f"{len(errors)} frames with a box")
    return 0


if __name__ == "__main__":
    sys.exit(main())
