# SPDX-License-Identifier: Apache-2.0
"""`harness track` (swir_tracker_ros/harness/track.py, recording.py): one shared sequence turned into each
input form the command reads (a 16-bit TIFF folder, bags of 8 and 16 bits, a lossless 16-bit video, an MP4)
gives the boxes the harness's own play gives on the same frames; bad inputs are refused with one line and
exit 2 before anything is written; Ctrl-C and a bad frame keep what was tracked. Configuration `measured`
(correlation filters only: no model files)."""

from __future__ import annotations

import csv
import io
import re
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import SEQUENCES
from rosbags.rosbag2 import Writer

from msg_adapters import bag as mb
from msg_adapters.backend import ROSBAGS
from msg_adapters.ground_truth import occluded_msg
from swir_tracker_ros.harness import cli, track, track_outputs
from swir_tracker_ros.harness.bagio import FrameRecord, write_bag
from swir_tracker_ros.harness.evaluate import make_tracker_factory, run_starts
from swir_tracker_ros.harness.recording import open_recording
from swir_tracker_ros.harness.sources import (
    T0_NS,
    convert_bits,
    frame_files,
    open_source,
    read_frame,
    read_gt,
)
from swir_tracker_ros.harness.store import OPE, RunStore
from swir_tracker_ros.types import Box

SEQ = SEQUENCES / "otb_crossing"
N = 25  # frames of the sequence the inputs are made of
CONF = "measured"


@pytest.fixture(scope="module")
def forms(tmp_path_factory) -> dict[str, Path]:
    """The first N frames of SEQ in every input form, with their ground truth as a gt.txt beside."""
    if not SEQ.is_dir():
        pytest.skip(f"shared sequence {SEQ} not found")
    base = tmp_path_factory.mktemp("forms")
    frames = [read_frame(f) for f in frame_files(SEQ)[:N]]
    out = {"seq": SEQ, "gt": base / "gt.txt", "tiff16": base / "tiff16", "tiff8": base / "tiff8",
           "mp4": base / "crossing.mp4", "mkv16": base / "crossing16.mkv"}
    out["gt"].write_text("\n".join((SEQ / "gt.txt").read_text().splitlines()[:N]) + "\n")
    for name, bits in (("tiff16", 16), ("tiff8", 8)):
        out[name].mkdir()
        for k, img in enumerate(frames):
            assert cv2.imwrite(str(out[name] / f"{k + 1:06d}.tif"), convert_bits(img, 8, bits))
    for name, bits in (("bag8", None), ("bag16", 16)):
        out[name] = base / name
        argv = ["make-bag", str(SEQ), str(out[name]), "--frames", str(N)] + (["--bits", "16"] if bits else [])
        assert cli.main(argv) == 0
    h, w = frames[0].shape
    mp4 = cv2.VideoWriter(str(out["mp4"]), cv2.VideoWriter_fourcc(*"mp4v"), 25.0, (w, h))
    for img in frames:
        mp4.write(cv2.cvtColor(img, cv2.COLOR_GRAY2BGR))
    mp4.release()
    ffv1 = cv2.VideoWriter(str(out["mkv16"]), cv2.CAP_FFMPEG, cv2.VideoWriter_fourcc(*"FFV1"), 25.0, (w, h),
                           [cv2.VIDEOWRITER_PROP_DEPTH, cv2.CV_16U, cv2.VIDEOWRITER_PROP_IS_COLOR, 0])
    if ffv1.isOpened():
        for img in frames:
            ffv1.write(convert_bits(img, 8, 16))
        ffv1.release()
    else:
        out.pop("mkv16")
    return out


def harness_play(spec: Path, overrides: tuple[str, ...] = ()) -> list[Box | None]:
    """The boxes `harness eval` plays on the first N frames of `spec` (its OPE loop, evaluate.run_starts)."""
    return run_starts(open_source(spec, N), make_tracker_factory(CONF, overrides))[OPE].pred


def run_track(args: list[str], out: Path, capsys) -> tuple[int, list[dict], str, str]:
    """`harness track` in-process: exit status, the CSV's rows, stdout, stderr."""
    rc = cli.main(["track", *args, "--config", CONF, "--out", str(out), "--quiet"])
    cap = capsys.readouterr()
    rows = []
    csvs = list(out.glob("*.csv")) if out.is_dir() else []
    if csvs:
        with csvs[0].open() as fh:
            rows = list(csv.DictReader(fh))
    return rc, rows, cap.out, cap.err


def boxes(rows: list[dict]) -> dict[int, tuple[float, ...]]:
    return {int(r["frame"]): tuple(float(r[k]) for k in "xywh") for r in rows}


def assert_same(rows: list[dict], pred: list[Box | None]) -> None:
    got = boxes(rows)
    assert sorted(got) == list(range(len(pred)))
    assert all(got[k] == pred[k].as_tuple() for k in got), "boxes differ from the harness's play"


def gt_box(k: int = 0) -> str:
    return ",".join(f"{v:g}" for v in read_gt(SEQ)[k].as_tuple())


# --- the same boxes as the harness on every lossless form -------------------------------------------------

def test_tiff16_folder_gives_the_boxes_of_harness_eval_on_the_16_bit_bag(forms, tmp_path, capsys) -> None:
    rc, rows, out, _ = run_track([str(forms["tiff16"]), "--box", gt_box()], tmp_path / "o", capsys)
    assert rc == 0 and rows[0]["state"] == "init"
    assert_same(rows, harness_play(forms["bag16"]))
    assert "frame folder" in out and "tiff16.mp4" in out


def test_bags_and_sequence_folder_give_the_boxes_of_harness_eval(forms, tmp_path, capsys) -> None:
    reference = harness_play(SEQ)
    for k, spec in enumerate((forms["bag8"], SEQ)):  # without --box: the source's first ground-truth box
        rc, rows, out, _ = run_track([str(spec), "--frames", str(N)], tmp_path / f"o{k}", capsys)
        assert rc == 0
        assert_same(rows, reference)
        assert "success AUC" in out  # scored against the source's own ground truth
    rc, rows, _, _ = run_track([str(forms["bag16"]), "--frames", str(N)], tmp_path / "o16", capsys)
    assert rc == 0
    assert_same(rows, harness_play(forms["bag16"]))


def test_the_stored_run_of_harness_eval_is_the_csv(forms, tmp_path, capsys) -> None:
    """The command line `harness eval` itself, read back from its store."""
    results = tmp_path / "results"
    argv = ["eval", str(forms["bag8"]), "--tracker", CONF, "--results", str(results), "--quiet"]
    assert cli.main(argv) == 0
    capsys.readouterr()
    stored = RunStore(results).load(CONF, open_source(forms["bag8"]).key, OPE, None)
    assert stored is not None
    rc, rows, _, _ = run_track([str(forms["tiff8"]), "--box", gt_box()], tmp_path / "o", capsys)
    assert rc == 0
    assert_same(rows, stored.boxes)


def test_lossless_16_bit_video_is_read_as_16_bit(forms, tmp_path, capsys) -> None:
    if "mkv16" not in forms:
        pytest.skip("this OpenCV cannot write FFV1 16-bit video")
    rec = open_recording(forms["mkv16"])
    first = next(iter(rec.frames()))
    assert rec.kind == "video" and rec.bits == 16 and first.image.dtype == np.uint16
    rc, rows, _, _ = run_track([str(forms["mkv16"]), "--box", gt_box()], tmp_path / "o", capsys)
    assert rc == 0
    assert_same(rows, harness_play(forms["bag16"]))


def test_mp4_is_lossy_but_scores_within_002_of_harness_eval(forms, tmp_path, capsys) -> None:
    rc, rows, out, _ = run_track([str(forms["mp4"]), "--box", gt_box(), "--gt", str(forms["gt"])],
                                 tmp_path / "o", capsys)
    assert rc == 0 and len(rows) == N
    auc = float(re.search(r"success AUC (\d\.\d+)", out).group(1))
    results = tmp_path / "results"
    assert cli.main(["eval", str(SEQ), "--frames", str(N), "--tracker", CONF, "--results", str(results),
                     "--json", str(tmp_path / "e.json"), "--quiet"]) == 0
    ref = float(re.search(r'"success_auc": (\d\.\d+)', (tmp_path / "e.json").read_text()).group(1))
    assert abs(auc - ref) <= 0.02, (auc, ref)


def test_deinterlace_and_overrides_reach_the_tracker_as_in_eval(forms, tmp_path, capsys) -> None:
    rc, rows, _, _ = run_track([str(forms["tiff8"]), "--box", gt_box(), "--deinterlace", "even"],
                               tmp_path / "o", capsys)
    assert rc == 0
    deint = harness_play(forms["bag8"], ("conditioning.deinterlace=even",))
    assert_same(rows, deint)
    assert deint != harness_play(forms["bag8"])  # the option changes what is tracked


def patch_tracker(monkeypatch, change) -> None:
    """`harness track` builds its tracker, then `change(tracker)` (a spy, a fault) before it is used."""
    factory = track.make_tracker_factory

    def patched(name, overrides=()):
        make = factory(name, overrides)

        def build():
            trk = make()
            change(trk)
            return trk
        return build

    monkeypatch.setattr(track, "make_tracker_factory", patched)


def test_bit_depth_is_given_to_the_core_for_16_bit_frames_only(forms, tmp_path, capsys, monkeypatch) -> None:
    seen: list[int | None] = []

    def spy_on_init(trk) -> None:
        init = trk.init

        def spy(frame, box, bit_depth=None):
            seen.append(bit_depth)
            return init(frame, box, bit_depth)
        trk.init = spy

    patch_tracker(monkeypatch, spy_on_init)
    for spec in (forms["tiff16"], forms["tiff8"]):
        rc, *_ = run_track([str(spec), "--box", gt_box(), "--frames", "2", "--bit-depth", "12"],
                           tmp_path / spec.name, capsys)
        assert rc == 0
    assert seen == [12, None]  # as the node: the hint goes with 16-bit frames


def test_start_frame_and_outputs(forms, tmp_path, capsys) -> None:
    out = tmp_path / "o"
    rc, rows, text, _ = run_track([str(forms["tiff16"]), "--box", gt_box(5), "--start", "5"], out, capsys)
    assert rc == 0 and [int(r["frame"]) for r in rows] == list(range(5, N))
    assert boxes(rows)[5] == read_gt(SEQ)[5].as_tuple()
    assert list(rows[0]) == list(track_outputs.CSV_COLUMNS)
    cap = cv2.VideoCapture(str(out / "tiff16.mp4"))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == N - 5
    cap.release()
    assert (out / "tiff16.png").stat().st_size > 0
    shares = re.search(r"tracking ([\d.]+) %, occluded ([\d.]+) %, lost ([\d.]+) %", text)
    assert shares and abs(sum(float(v) for v in shares.groups()) - 100.0) < 0.2


# --- bad input: one line, exit 2, nothing written ---------------------------------------------------------

def _no_image_bag(path: Path) -> Path:
    with Writer(path, version=9) as w:
        c = w.add_connection("/ground_truth/occluded", "std_msgs/msg/Bool", typestore=mb.typestore())
        w.write(c, T0_NS, mb.serialize(occluded_msg(True, ROSBAGS)))
    return path


def _bad(tmp: Path, forms: dict[str, Path]) -> dict[str, tuple[list[str], str]]:
    text = tmp / "notes.mp4"
    text.write_text("not a video\n")
    empty = tmp / "empty"
    empty.mkdir()
    mixed = tmp / "mixed"
    shutil.copytree(forms["tiff8"], mixed)
    cv2.imwrite(str(mixed / "000003.tif"), np.zeros((100, 120), np.uint8))
    kinds = tmp / "kinds"
    shutil.copytree(forms["tiff8"], kinds)
    cv2.imwrite(str(kinds / "000099.png"), np.zeros((240, 360), np.uint8))
    depths = tmp / "depths"
    shutil.copytree(forms["tiff8"], depths)
    cv2.imwrite(str(depths / "000004.tif"), np.zeros((240, 360), np.uint16))
    box = ["--box", gt_box()]
    return {
        "not a video": ([str(text), *box], r"notes\.mp4: not a video"),
        "empty folder": ([str(empty), *box], r"empty: no frames"),
        "mixed sizes": ([str(mixed), *box], r"mixed: frames of mixed sizes: 000003\.tif is 120x100"),
        "mixed depths": ([str(depths), *box], r"depths: frames of mixed pixel types: 000004\.tif is 360x240 "
                                               r"I;16"),
        "mixed kinds": ([str(kinds), *box], r"kinds: the folder mixes PNG and TIFF frames"),
        "box outside": ([str(forms["tiff8"]), "--box", "400,10,20,20"], r"lies outside the 360x240 image"),
        "box malformed": ([str(forms["tiff8"]), "--box", "1,2,3"], r"--box wants x,y,w,h"),
        "bag without images": ([str(_no_image_bag(tmp / "noimg")), *box], r"no sensor_msgs/msg/Image topic"),
        "no box": ([str(forms["tiff8"])], r"--box x,y,w,h is required \(--select cannot draw it: there is "
                                          r"no display"),
        "select without display": ([str(forms["mp4"]), "--select"], r"--select cannot open a window: there "
                                                                     r"is no display"),
        "start past the end": ([str(forms["tiff8"]), *box, "--start", "99"], r"only 25 frame"),
        "one image": ([str(forms["tiff8"] / "000001.tif"), *box], r"one image; give the folder"),
        "missing": ([str(tmp / "nothing.avi"), *box], r"nothing\.avi: no such file"),
    }


def test_bad_inputs_are_one_line_exit_2_and_write_nothing(forms, tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    for case, (argv, pattern) in _bad(tmp_path, forms).items():
        out = tmp_path / f"out_{case.replace(' ', '_')}"
        rc, _, _, err = run_track(argv, out, capsys)
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert rc == 2 and len(lines) == 1 and re.search(pattern, lines[0]), (case, lines)
        assert lines[0].startswith("harness: error: ")
        assert not out.exists(), case


def test_frame_of_another_size_stops_and_keeps_what_was_tracked(forms, tmp_path, capsys) -> None:
    imgs = [read_frame(f) for f in frame_files(SEQ)[:6]]
    imgs[4] = cv2.resize(imgs[4], (180, 120))
    write_bag(tmp_path / "bag", (FrameRecord(T0_NS + k * 40_000_000, im, None) for k, im in enumerate(imgs)))
    out = tmp_path / "o"
    rc, rows, text, err = run_track([str(tmp_path / "bag"), "--box", gt_box()], out, capsys)
    assert rc == 2 and "frame 4 is 180x120, the frames before it 360x240" in err
    assert [int(r["frame"]) for r in rows] == [0, 1, 2, 3] and "wrote" in text
    assert (out / "bag.png").exists()


def test_ctrl_c_stops_cleanly_and_writes_what_was_tracked(forms, tmp_path, capsys, monkeypatch) -> None:
    def ctrl_c_on_the_7th_update(trk) -> None:
        update, calls = trk.update, []

        def update_until_ctrl_c(frame, **kw):
            calls.append(1)
            if len(calls) == 7:
                raise KeyboardInterrupt
            return update(frame, **kw)
        trk.update = update_until_ctrl_c

    patch_tracker(monkeypatch, ctrl_c_on_the_7th_update)
    out = tmp_path / "o"
    rc, rows, text, _ = run_track([str(forms["tiff8"]), "--box", gt_box()], out, capsys)
    assert rc == 130 and len(rows) == 7 and "interrupted" in text  # the start frame and 6 updates
    cap = cv2.VideoCapture(str(out / "tiff8.mp4"))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 7
    cap.release()
    assert (out / "tiff8.png").stat().st_size > 0


def test_progress_bar_only_on_a_terminal(monkeypatch) -> None:
    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    for stream, shown in ((Tty(), True), (io.StringIO(), False)):
        monkeypatch.setattr(track_outputs.sys, "stderr", stream)
        bar = track_outputs.Progress(10, True)
        bar(5, force=True)
        assert ("[###############---------------] 5/10 frames" in stream.getvalue()) is shown
