# SPDX-License-Identifier: Apache-2.0
"""The closed-loop demo: scoring, parameters, the launch file, and a shortened end-to-end run."""

from __future__ import annotations

import ast
import json
import math
import re
import subprocess
import sys

import pytest
from conftest import REPO, executable

from swir_tracker_ros.demo.analysis import occlusion_episodes, series, summarise
from swir_tracker_ros.demo.config import DemoParams, load_demo_params
from swir_tracker_ros.demo.recording import RunRecords
from swir_tracker_ros.demo.report import make_plots, text_table, write_reports
from swir_tracker_ros.demo.runner import pty_url
from swir_tracker_ros.errors import DemoError

CAM = {"width": 576, "height": 504, "fx": 4118.0, "fy": 4118.0, "cx": 288.0, "cy": 252.0}


def synthetic_records(ego: bool = True, recover: bool = True) -> RunRecords:
    """25 fps, 6 s: the head closes a 2 deg offset; target hidden 2.0-3.0 s; tracker re-acquires (or not)."""
    rec = RunRecords(label="synthetic", ego_motion_compensation=ego, duration_s=6.0, camera=dict(CAM),
                     outcome="completed")
    t_start = 1000.0
    for k in range(151):
        t = k / 25.0
        stamp = t_start + t
        err = math.radians(2.0) * math.exp(-t)  # pan error decays as the head turns
        visible = 0.0 if 2.0 <= t <= 3.0 else 1.0
        u = 288.0 - CAM["fx"] * math.tan(err)
        gt = [u - 17.0, 200.0, 34.0, 100.0]
        rec.truth.append([stamp, t, 1.0, visible, err, 0.0, -err + math.radians(2.0), 0.0])
        rec.gt.append([stamp, gt])
        lost = not recover and t > 2.0
        box = [u - 17.0 + (80.0 if lost else 2.0), 201.0, 34.0, 100.0]
        rec.track.append([stamp, stamp + 0.03, box])
        state = "lost" if lost else ("occluded" if visible == 0.0 else "tracking")
        rec.state.append([stamp, stamp + 0.03, state])
        rec.error.append([stamp, stamp + 0.03, err, 0.0])
        rec.frames.append([stamp, stamp + 0.005])
        rec.joints.append([stamp, stamp, math.radians(2.0) - err, 0.0])
    rec.truth.insert(0, [t_start - 0.04, 0.0, 1.0, 1.0, math.radians(2.0), 0.0, 0.0, 0.0])  # paused frame
    return rec


def test_summary_scores_a_synthetic_run() -> None:
    s = summarise(synthetic_records())
    assert s.frames == 150 and s.in_view_fraction == 1.0 and s.in_view_at_end  # t = 0: scene paused
    assert s.occlusions == 1 and s.occlusions_survived == 1
    assert s.initial_offset_deg[0] == pytest.approx(2.0 * math.exp(-0.04))
    assert s.head_travel_deg[0] == pytest.approx(2.0 * (math.exp(-0.04) - math.exp(-6.0)), abs=0.01)
    assert s.head_turn_towards_deg[0] == pytest.approx(s.head_travel_deg[0])  # it only ever turned left
    assert s.latency_p50_ms == pytest.approx(30.0, abs=0.5)
    assert s.camera_fps == pytest.approx(25.0, rel=0.01) and s.tracker_fps == pytest.approx(25.0, rel=0.01)
    assert s.precision_20px == 1.0 and s.final_state == "tracking"
    assert 0.0 < s.centring_error_mean_deg < s.centring_error_p95_deg < 2.0


def test_an_occlusion_that_loses_the_target_is_not_survived() -> None:
    rec = synthetic_records(recover=False)
    episodes = occlusion_episodes(series(rec))
    assert len(episodes) == 1 and not episodes[0].survived
    assert episodes[0].start == pytest.approx(2.0) and episodes[0].end == pytest.approx(3.0)
    assert summarise(rec).lost_frames > 0


def test_episodes_from_scene_visibility_cover_a_target_out_of_view() -> None:
    """With the head-independent visibility, an occlusion while the head has lost the target still counts."""
    rec = synthetic_records()
    for row, gt, state in zip(rec.truth[1:], rec.gt, rec.state):
        if row[1] >= 4.0:  # the target is out of the image from 4 s on and the tracker has lost it
            row[4], gt[1], state[2] = math.radians(6.0), None, "occluded"
    s = summarise(rec, lambda t: [0.0 if 4.4 <= x <= 5.0 or 2.0 <= x <= 3.0 else 1.0 for x in t])
    assert [e["note"] for e in s.episodes] == ["survived", "target out of view"]
    assert s.occlusions == 2 and s.occlusions_survived == 1


def test_false_tracking_and_skipped_frames_are_counted() -> None:
    """`tracking` on a box that does not overlap the target is false tracking; frames with no output
    are skipped; both decide a sweep run's success."""
    from swir_tracker_ros.demo import table

    rec = synthetic_records()
    assert summarise(rec).false_tracking_frames == 0
    for row in rec.track[100:110]:
        row[2] = [row[2][0] + 200.0, *row[2][1:]]  # on the background, 200 px away, while `tracking`
    for row in rec.track[120:125]:
        row[2] = [row[2][0] + 20.0, *row[2][1:]]  # off-centre but overlapping: not false
    del rec.state[130:133], rec.track[130:133]
    s = summarise(rec)
    assert s.false_tracking_frames == 10 and s.frames_skipped == 3
    assert not table.succeeded(s) and table.succeeded(summarise(synthetic_records()))
    rows = [table.row_from("demo", 3, True, 1, s, REPO),
            table.row_from("demo", 4, True, 1, summarise(synthetic_records()), REPO)]
    text = table.text(rows)
    assert "false-tracking frames" in text and "3/150" in text and "demo: 1 of 2 runs succeeded" in text
    assert table.markdown(rows).count("\n| demo |") == 2


def test_the_exit_status_names_each_failed_run_and_the_criteria_it_missed() -> None:
    """Issue 52 item 5: `demo` and `demo sweep` exit 1 when any run misses a success criterion, with one line
    naming each failed run and what it missed; 0 when every run succeeded."""
    from swir_tracker_ros.demo import table

    good = summarise(synthetic_records())
    false = synthetic_records()
    for row in false.track[100:104]:
        row[2] = [row[2][0] + 200.0, *row[2][1:]]  # `tracking` on background, 200 px away
    gone = synthetic_records()
    for row in gone.truth[-20:]:
        row[4] = math.radians(5.0)  # out of the 4 deg half field of view for the last 0.8 s
    cut = synthetic_records()
    cut.outcome = "interrupted"
    assert table.missed(good) == []
    assert table.exit_status([table.row_from("demo", 1, True, 1, good, REPO)]) == (0, "")
    rows = [table.row_from("demo", 1, True, 1, good, REPO),
            table.row_from("demo", 2, True, 1, summarise(false), REPO),
            table.row_from("demo_fast", 3, False, 2, summarise(gone), REPO),
            table.row_from("demo", 4, True, 1, summarise(cut), REPO)]
    assert [r.success for r in rows] == [True, False, False, False]
    status, line = table.exit_status(rows, ["demo seed 5 (did not finish: tracker exited early with code 1)"])
    assert status == 1 and "\n" not in line, line
    assert line.startswith("4 of 5 runs failed: ") and "demo seed 1 " not in line, line
    assert "demo seed 2 (4 false-tracking frames)" in line, line
    # 0.8 s of 6 s out of view: 86.7 % of the run, and not at the end
    assert ("demo_fast seed 3 ego off repeat 2 (target out of view at the end; in view 86.7% < 95%)"
            in line), line
    assert "demo seed 4 (run not completed (interrupted))" in line and "did not finish" in line, line


def _fake_runs(monkeypatch, tmp_path, module, fail_seeds: set[int]) -> list[int]:
    """Replace `module.run_once` (the closed loop) by one that returns the synthetic run's records and
    summary, with 10 false-tracking frames for a seed in `fail_seeds`; the seeds it was called with."""
    from swir_tracker_ros.demo.runner import RunResult

    called: list[int] = []

    def run_once(p, out, ego, i, log=print, video=True):
        called.append(p.seed)
        rec = synthetic_records(ego)
        if p.seed in fail_seeds:
            for row in rec.track[100:110]:
                row[2] = [row[2][0] + 200.0, *row[2][1:]]
        folder = out / ("ego_on" if ego else "ego_off")
        folder.mkdir(parents=True, exist_ok=True)
        return RunResult(rec, summarise(rec), folder, {})

    monkeypatch.setattr(module, "run_once", run_once)
    return called


def test_demo_and_sweep_exit_1_when_a_run_fails_and_2_on_bad_input(tmp_path, monkeypatch, capsys) -> None:
    """The exit status of both commands, decided from the runs' summaries (the closed loop replaced by the
    synthetic run): 0 when every run succeeded, 1 with the one-line reason when one failed, 2 on bad
    input before anything runs."""
    from swir_tracker_ros.demo import run, sweep

    monkeypatch.setattr(run, "make_plots", lambda *a, **k: [])  # the plots are not what is checked here
    _fake_runs(monkeypatch, tmp_path, run, set())
    assert run.main(["--out", str(tmp_path / "ok"), "--seed", "1"]) == 0
    assert "runs failed" not in capsys.readouterr().err
    _fake_runs(monkeypatch, tmp_path, run, {7})
    assert run.main(["--out", str(tmp_path / "bad"), "--seed", "7"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["demo: 2 of 2 runs failed: demo seed 7 (10 false-tracking frames), "
                   "demo seed 7 ego off (10 false-tracking frames)"], err
    assert run.main(["--out", str(tmp_path / "x"), "--scene", "nowhere"]) == 2
    assert capsys.readouterr().err.startswith("demo: ")

    called = _fake_runs(monkeypatch, tmp_path, sweep, {2})
    assert sweep.main(["--out", str(tmp_path / "sweep"), "--seeds", "3"]) == 1
    assert called == [1, 2, 3]
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["demo sweep: 1 of 3 runs failed: demo seed 2 (10 false-tracking frames)"], err
    _fake_runs(monkeypatch, tmp_path, sweep, set())
    assert sweep.main(["--out", str(tmp_path / "sweep"), "--seeds", "1,3"]) == 0
    assert sweep.main(["--out", str(tmp_path / "sweep"), "--seeds", "x"]) == 2

    def crashes(p, out, ego, i, log=print, video=True):
        raise DemoError("tracker exited early with code 1:\n(log tail)")

    monkeypatch.setattr(sweep, "run_once", crashes)  # a run that leaves no records failed too
    capsys.readouterr()
    assert sweep.main(["--out", str(tmp_path / "crash"), "--seeds", "4,5"]) == 1
    assert capsys.readouterr().err.strip().splitlines()[-1] == (
        "demo sweep: no run finished: demo seed 4 (did not finish: tracker exited early with code 1), "
        "demo seed 5 (did not finish: tracker exited early with code 1)")


def test_init_is_answered_by_tracking_after_the_first_init() -> None:
    """Init sent for the frame at 100.0 s, resent at 100.5 and 101.0 (the tracker had not answered yet):
    a `tracking` state for the frame at 100.2 answers it (the old rule compared with the last resend and
    waited on, while the head already followed the track)."""
    from swir_tracker_ros.demo.supervisor_node import init_answered

    assert init_answered(100.0, "tracking", 100.2)
    assert not init_answered(100.0, "tracking", 99.96)  # a state from before the init
    assert not init_answered(100.0, "idle", 100.2) and init_answered(100.0, "occluded", 100.2)


def test_sweep_seeds_and_background_load() -> None:
    from swir_tracker_ros.demo import sweep

    assert sweep.parse_seeds("3") == [1, 2, 3] and sweep.parse_seeds("7,11") == [7, 11]
    with pytest.raises(DemoError):
        sweep.parse_seeds("x")
    with sweep.BackgroundLoad(2) as load:
        procs = list(load.procs)
        assert len(procs) == 2 and all(p.poll() is None for p in procs)
    assert all(p.poll() is not None for p in procs)


def test_target_out_of_view_counts_against_time_in_view() -> None:
    rec = synthetic_records()
    for row in rec.truth[-50:]:
        row[4] = math.radians(5.0)  # beyond the 4 deg half field of view
    s = summarise(rec)
    assert not s.in_view_at_end
    assert s.time_in_view_s == pytest.approx(4.0, abs=0.1)


def test_reports_and_plots_are_written(tmp_path) -> None:
    runs = [(r, summarise(r)) for r in (synthetic_records(True), synthetic_records(False, recover=False))]
    plots = make_plots(tmp_path, runs, [tmp_path / "missing.csv"] * 2)
    assert all(p.stat().st_size > 10_000 for p in plots)
    from swir_tracker_ros.demo import table

    rows = [table.row_from("demo", 7, r.ego_motion_compensation, 1, s, tmp_path) for r, s in runs]
    paths = write_reports(tmp_path, [s for _, s in runs], {"files": {"plot": "plots/centring_error.png"},
                                                           "sweep_markdown": table.markdown(rows)})
    data = json.loads(paths["json"].read_text())
    assert [r["ego_motion_compensation"] for r in data["runs"]] == [True, False]
    assert "occlusions survived" in paths["md"].read_text()
    assert "<table>" in paths["html"].read_text() and "Sweep-style summary" in paths["html"].read_text()
    assert "demo: 2 of 2 runs succeeded" in paths["md"].read_text()  # lost, but in view throughout
    table = text_table([s for _, s in runs])
    assert "ego-motion compensation ON" in table and "ego-motion compensation OFF" in table


def test_demo_params_file_and_validation(tmp_path) -> None:
    p = load_demo_params()  # params/demo.yaml
    assert p.scene == "demo" and p.duration_s > 0
    assert not p.bag_images  # a newcomer's `make demo` stays small: the video carries the pictures
    assert p.with_overrides(scene="demo_fast", seed=3, duration_s=None).seed == 3
    with pytest.raises(DemoError, match="scene"):
        p.with_overrides(scene="nowhere")
    assert p.with_duration(3.0).duration_s == 3.0
    bad = tmp_path / "demo.yaml"
    bad.write_text("demo:\n  scene: nowhere\n")
    with pytest.raises(DemoError, match="scene"):
        load_demo_params(bad)
    bad.write_text("demo:\n  duration: 3\n")
    with pytest.raises(DemoError, match="unknown demo parameters"):
        load_demo_params(bad)
    with pytest.raises(DemoError, match="duration_s"):
        DemoParams(duration_s=0.0).validate()


def test_pty_url_from_pelco_sim_first_line() -> None:
    assert pty_url("PTY /dev/pts/7") == "/dev/pts/7"
    assert pty_url("TCP 127.0.0.1:4001") == "socket://127.0.0.1:4001"
    with pytest.raises(DemoError):
        pty_url("hello")


def test_launch_file_compiles_and_references_real_executables_and_params() -> None:
    path = REPO / "launch" / "demo.launch.py"
    source = path.read_text()
    compile(source, str(path), "exec")
    tree = ast.parse(source)
    names = {n.value for n in ast.walk(tree) if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    scripts = re.findall(r'"(\w+) = swir_tracker_ros', (REPO / "setup.py").read_text())
    for exe in ("pelco_sim", "positioner_bridge", "scene_camera", "tracker"):
        assert exe in names and exe in scripts, exe
    for params in re.findall(r'_params\("([\w.]+)"\)', source):
        assert (REPO / "params" / params).is_file(), params
    assert len(re.findall(r'_params\("([\w.]+)"\)', source)) == 3
    assert "generate_launch_description" in {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}


# --------------------------------------------------------------------------- end to end
def test_shortened_demo_end_to_end(tmp_path) -> None:
    """A few seconds of the real graph: the head turns towards the pedestrian, who is in view at the end."""
    out = tmp_path / "demo"
    proc = subprocess.run([executable("demo"), "--out", str(out), "--duration", "4", "--no-ego-compare",
                           "--bag-images"],
                          capture_output=True, text=True, timeout=150)
    logs = "\n".join(f"--- {p.name}\n{p.read_text(errors='replace')[-1500:]}"
                     for p in sorted(out.glob("*/logs/*.log")))
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:] + logs
    data = json.loads((out / "summary.json").read_text())
    (run,) = data["runs"]
    assert run["outcome"] == "completed"
    pan0, tilt0 = run["initial_offset_deg"]
    assert pan0 > 1.0 and tilt0 < -0.3  # the pedestrian starts left of and below the optical axis
    # The head turned towards the pedestrian (left and down) by a visible amount.
    assert run["head_turn_towards_deg"][0] > 0.5 and run["head_turn_towards_deg"][1] > 0.2, run
    assert run["in_view_at_end"], run
    assert run["frames"] > 25
    # The bridge had found the tracker's error stream before the scene started: the head moves within
    # a second of the start (it stood still for 2.4 s when the supervisor did not wait for that link).
    rec = json.loads((out / "ego_on" / "records.json").read_text())
    moving = [t - rec["scene_start"] for t, _recv, pan, _ in rec["joints"] if abs(pan) > math.radians(0.1)]
    assert moving and moving[0] < 1.0, moving[:3]
    # The scene starts with the tracker's first `tracking` answer to /track/init, not seconds later: the
    # head follows the track from that answer on, and turned 2.3 deg past the paused target on a loaded
    # machine while the supervisor chased its own resent inits' stamps.
    first = next(recv for stamp, recv, state in rec["state"]
                 if state == "tracking" and stamp >= rec["init_time"])
    assert rec["scene_start"] - first < 1.0, (first, rec["scene_start"])
    before = [abs(pan) for t, _recv, pan, _ in rec["joints"] if t <= rec["scene_start"]]
    assert max(before, default=0.0) < math.radians(0.5), max(before)
    exits = data["processes"]["ego_on"]
    assert set(exits) == {"pelco_sim", "positioner_bridge", "scene_camera", "tracker", "demo_supervisor"}
    for name, end in exits.items():
        assert end["returncode"] == 0 and end["how"] in ("sigint", "exited"), (name, end)
    assert (out / "ego_on" / "bag" / "metadata.yaml").is_file()
    from swir_tracker_ros.harness.bagio import read_frames  # the harness replays the demo's recording

    frames = list(read_frames(out / "ego_on" / "bag"))
    assert len(frames) >= run["frames"] and frames[0].image.shape == (504, 576)
    assert sum(f.gt is not None for f in frames) >= run["frames"] // 2
    assert (out / "ego_on" / "debug.mp4").stat().st_size > 10_000
    assert (out / "report.html").is_file() and (out / "plots" / "head_angles.png").is_file()
    assert "report:" in proc.stdout


def test_demo_module_runs_as_script_help() -> None:
    proc = subprocess.run([sys.executable, "-m", "swir_tracker_ros.demo.run", "--help"], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0 and "--no-ego-compare" in proc.stdout and "--scene" in proc.stdout
    proc = subprocess.run([sys.executable, "-m", "swir_tracker_ros.demo.run", "sweep", "--help"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and "--load" in proc.stdout and "--seeds" in proc.stdout


def test_video_sink_writes_mp4_or_falls_back_to_gif(tmp_path, monkeypatch) -> None:
    import numpy as np
    from PIL import Image

    from swir_tracker_ros.demo import video

    frame = np.zeros((504, 576, 3), np.uint8)
    sink = video.VideoSink(tmp_path / "a", fps=25.0)
    for k in range(10):
        sink.write(video.caption(frame + k, f"frame {k}"), repeat=2)
    path = sink.close()
    assert path is not None and path.suffix == ".mp4" and path.stat().st_size > 1000

    class NoEncoder:
        def __init__(self, *args) -> None:
            pass

        def isOpened(self) -> bool:
            return False

        def release(self) -> None:
            pass

    monkeypatch.setattr(video.cv2, "VideoWriter", NoEncoder)
    sink = video.VideoSink(tmp_path / "b", fps=25.0, gif_stride=2)
    for k in range(10):
        sink.write(frame + 20 * k)
    path = sink.close()
    assert path is not None and path.suffix == ".gif"
    with Image.open(path) as gif:
        assert gif.n_frames == 5 and gif.size == (288, 252)


def test_tracker_node_passes_elapsed_frames_once_the_core_takes_them(monkeypatch) -> None:
    """The closed loop's frame skipping reaches the core: with a core whose update() accepts `frames`,
    the node passes 1 + the frames skipped since the last processed stamp (core contract item 3)."""
    import numpy as np
    import rclpy
    from rclpy.context import Context

    from msg_adapters.image import numpy_to_image
    from msg_adapters.stamps import header
    from swir_tracker_ros.nodes import tracker_node
    from swir_tracker_ros.types import Box, TrackResult, TrackState

    calls: list[dict] = []

    class Core:
        state = TrackState.TRACKING

        def __init__(self, _params=None) -> None:
            pass

        @staticmethod
        def warm_up() -> bool:
            return False

        def init(self, *_a, **_k) -> None:
            pass

        def update(self, frame, ego_shift=(0.0, 0.0), bit_depth=None, frames=1.0) -> TrackResult:
            calls.append({"frames": frames})
            return TrackResult(box=Box(10.0, 10.0, 8.0, 8.0), state=TrackState.TRACKING, measured=True)

    monkeypatch.setattr(tracker_node, "Tracker", Core)
    ctx = Context()
    rclpy.init(context=ctx)
    try:
        node = tracker_node.TrackerNode(context=ctx, parameter_overrides=[
            rclpy.parameter.Parameter("init_box", value=[10.0, 10.0, 8.0, 8.0]),
            rclpy.parameter.Parameter("max_frame_age_s", value=0.0)])
        pixels = np.full((48, 64), 1000, np.uint16)
        stamps = [1.0 + k * 0.04 for k in range(8)] + [1.40, 1.44, 1.64]  # 1.28 -> skips 2, 0, 4
        for t in stamps:
            node._on_image(numpy_to_image(pixels, header(t, "cam")))
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=ctx)
    assert [c["frames"] for c in calls[-3:]] == [3.0, 1.0, 5.0], calls
