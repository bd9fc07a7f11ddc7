# SPDX-License-Identifier: Apache-2.0
"""`harness replay` against the real `tracker` node: bag -> ROS graph -> /track/* -> recorded bag -> score."""

from __future__ import annotations

import subprocess

from conftest import executable

from swir_tracker_ros.harness import cli
from swir_tracker_ros.harness.bagio import bag_info


def test_replay_scores_the_tracker_node(tmp_path, sequences_dir, processes):
    bag = tmp_path / "crossing"
    assert cli.main(["make-bag", str(sequences_dir / "otb_crossing"), str(bag), "--frames", "30"]) == 0
    node = processes.start("tracker")
    out = tmp_path / "replayed"
    proc = subprocess.run([executable("harness"), "replay", str(bag), "--out", str(out), "--wait", "60"],
                          capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0, proc.stderr + processes.log(node)
    assert "tracker_node" in proc.stdout
    answered = int(proc.stdout.split("frames answered")[0].split()[-1].split("/")[0])
    assert answered >= 15  # best-effort, depth-1 image QoS may drop a few frames
    counts = {t.topic: t.read for t in bag_info(out).topics}
    assert counts["/track/box"] >= answered and counts["/track/state"] > 0
    p20 = float(next(ln for ln in proc.stdout.splitlines() if ln.startswith("crossing")).split()[2])
    assert p20 > 0.6
