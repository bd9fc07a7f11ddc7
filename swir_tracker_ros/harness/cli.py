# SPDX-License-Identifier: Apache-2.0
"""The `harness` command: make-bag, synth, info, eval, compare, table, verdict, regress, replay, track
(docs/harness.md)."""

from __future__ import annotations

import argparse
import json
import signal
import sys
from pathlib import Path

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness import commands
from swir_tracker_ros.harness.analysis import DEFAULT_PEERS, DEFAULT_SEQUENCES
from swir_tracker_ros.harness.bagio import FrameRecord, bag_info, write_bag
from swir_tracker_ros.harness.compare import OPENCV_TRACKERS
from swir_tracker_ros.harness.devset import CORPUS_ENV, DEV
from swir_tracker_ros.harness.evaluate import DEFAULT, OPE, configurations
from swir_tracker_ros.harness.metrics import SRE_STYLES
from swir_tracker_ros.harness.numerics import ENVIRONMENTS
from swir_tracker_ros.harness.protocol import Results
from swir_tracker_ros.harness.regress import REGRESSION_DIR
from swir_tracker_ros.harness.runner import PROTOCOLS
from swir_tracker_ros.harness.sources import SYNTH_PREFIX, Source, convert_bits, open_source
from swir_tracker_ros.harness.tables import format_eval
from swir_tracker_ros.harness.track import add_track_parser
from swir_tracker_ros.harness.verdict import KEEP_SE, METRICS
from swir_tracker_ros.scene import scenarios
from swir_tracker_ros.scene.camera import CameraView
from swir_tracker_ros.scene.scenarios import make_scenario


def _err(msg: str) -> None:
    print(f"harness: error: {msg}", file=sys.stderr)


def _bag_from_source(src: Source, out: Path, storage: str, compress: str | None, bits: int | None,
                     hfov_deg: float) -> int:
    first = next(iter(src.frames()), None)
    if first is None:
        raise HarnessError(f"{src.location}: no frames")
    src_bits = src.bits or (8 if first.image.dtype.itemsize == 1 else 16)
    out_bits = bits or src_bits
    if src.kind == "synth":
        cam = make_scenario(src.location).views[0].camera_info()
    else:
        h, w = first.image.shape[:2]
        cam = CameraView(hfov_deg=hfov_deg, width=w, height=h).camera_info()
    meta = {"name": src.name, "fps": src.fps, "bits": out_bits, "source": src.location, "kind": src.kind}
    if src.meta.get("occlusion_ranges") is not None:
        meta["occlusion_ranges"] = src.meta["occlusion_ranges"]

    def frames():
        for fr in src.frames():
            img = convert_bits(fr.image, src_bits, bits) if bits else fr.image
            yield FrameRecord(fr.stamp_ns, img, fr.gt, fr.occluded)

    return write_bag(out, frames(), storage=storage, compress=compress, camera_info=cam,
                     custom={"swir_sequence": json.dumps(meta)})


def cmd_make_bag(a: argparse.Namespace) -> int:
    src = open_source(a.src, max_frames=a.frames)
    n = _bag_from_source(src, Path(a.out), a.storage, a.compress, a.bits, a.hfov)
    print(f"wrote {n} frames of {src.name} to {a.out} ({a.storage}{', zstd' if a.compress else ''})")
    return 0


def cmd_synth(a: argparse.Namespace) -> int:
    if a.list or not a.name:
        for name, spec in scenarios().items():
            row = f"Table 1 row {spec.table1_row}" if spec.table1_row else "extra"
            print(f"{name:<30} {spec.duration_s:5.1f} s  {spec.camera:<6} {row:<13} {spec.challenges}")
        return 0
    if not a.out:
        raise HarnessError("synth needs NAME and OUT (or --list)")
    src = open_source(SYNTH_PREFIX + a.name, max_frames=a.frames)
    n = _bag_from_source(src, Path(a.out), a.storage, a.compress, a.bits, 8.0)
    print(f"wrote {n} frames of scenario {a.name} to {a.out}")
    return 0


def cmd_info(a: argparse.Namespace) -> int:
    info = bag_info(a.bag)
    size = sum(f.stat().st_size for f in (Path(p) for p in info.files) if f.exists())
    print(f"Files:             {', '.join(info.files)}")
    print(f"Bag size:          {size / 2**20:.1f} MiB")
    print(f"Storage id:        {info.storage}")
    print(f"Metadata version:  {info.version if info.version is not None else '- (single storage file)'}")
    print(f"Compression:       {info.compression or 'none'}")
    print(f"Read mode:         {info.read_mode}")
    print(f"Duration:          {info.duration_s:.3f} s")
    print(f"Start / end:       {info.start_ns / 1e9:.9f} / {info.end_ns / 1e9:.9f}")
    decl = sum(t.declared or 0 for t in info.topics)
    print(f"Messages:          declared {decl}, read {sum(t.read for t in info.topics)}")
    print("Topic information:")
    for t in info.topics:
        d = "-" if t.declared is None else str(t.declared)
        print(f"  Topic: {t.topic} | Type: {t.msgtype} | Count: declared {d}, read {t.read}")
    if info.custom.get("swir_sequence"):
        print(f"Sequence:          {info.custom['swir_sequence']}")
    for note in info.notes:
        print(f"Note: {note}")
    return 0


def cmd_replay(a: argparse.Namespace) -> int:
    # rclpy is imported only here: every other command runs without a ROS install
    from swir_tracker_ros.harness.replay import replay

    out = Path(a.out) if a.out else Path(str(Path(a.bag).resolve()) + "_replayed")
    res = replay(a.bag, out, a.rate, a.wait, a.grace)
    result = Results(labels=["tracker_node"])
    result.add(Path(a.bag).name, "tracker_node", OPE, res.stats)
    print(format_eval(result))
    print(f"{res.answered}/{res.frames} frames answered on /track/box; recording in {res.recorded}")
    return 0


def _stored_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--results", default=None,
                   help="results directory of the stored runs (default: $SWIR_RESULTS or "
                        f"{commands.DEFAULT_RESULTS})")
    p.add_argument("--data", dest="data_folders", nargs="+", action="extend", default=None, metavar="DIR",
                   help=f"data folders (folders of sequence folders; repeatable): the groups of the tables, "
                        f"the videos of the verdict, the sequences of SRC `{DEV}`; `{DEV}` or nothing: the "
                        f"development set, {DEFAULT_SEQUENCES} and the built corpus (${CORPUS_ENV}, else "
                        "../corpus beside the repository)")
    p.add_argument("--peer-dir", default=str(DEFAULT_PEERS),
                   help="stored runs of trackers outside the project, e.g. ecohc_py (default: %(default)s)")
    p.add_argument("--sre-style", choices=SRE_STYLES, default="otb",
                   help="SRE start boxes: the OTB toolkit's shiftInitBB (otb), rigid 10 %% shifts (shift), "
                        "or the same 12 starts 1 px apart (pixel: the answer's stability; metrics.sre_box)")
    p.add_argument("--markdown", default=None, help="also write the tables as Markdown")
    p.add_argument("--json", default=None, help="write the scores as JSON")
    p.add_argument("--quiet", action="store_true")


def _evaluation_parsers(sub: argparse._SubParsersAction) -> None:
    names = (*configurations(), DEFAULT)

    def eval_args(p: argparse.ArgumentParser) -> None:
        p.add_argument("bags", nargs="+",
                       help=f"bags, sequence folders, a folder of them, synth:NAME, synth:all, {DEV} (every "
                            "sequence of --data: by default the development set)")
        p.add_argument("--tracker", "--configuration", nargs="*", choices=names, default=None, dest="tracker",
                       help="our configurations (default: all; `compare --tracker` alone: peers only)")
        p.add_argument("--set", action="append", default=None, metavar="NAME=VALUE",
                       help="override a parameter of our configurations (repeatable; dotted names for nested "
                            "parameter groups; VALUE parsed as YAML); stored under a label of its own")
        p.add_argument("--param", action="append", default=None, metavar="NAME=VALUE",
                       help="the same as --set")
        p.add_argument("--pipeline", default=None, help="short for --set pipeline=P")
        p.add_argument("--label", default=None, help="store the runs of the one --tracker under this label")
        p.add_argument("--frames", type=int, default=None, help="only the first N frames of each source")
        p.add_argument("--image-topic", default=None)
        p.add_argument("--gt-topic", default=None)
        p.add_argument("--jobs", type=int, default=1, help="parallel (tracker, source) tasks")
        p.add_argument("--rerun", action="store_true",
                       help="play again, and replace, stored runs that other code or settings produced")
        p.add_argument("--curves", action="store_true", help="also store the curves in the JSON")
        p.add_argument("--plots", default=None, help="directory for precision/success PNGs")
        p.add_argument("--reuse", nargs="+", default=None, help=argparse.SUPPRESS)  # gone: fails with a hint
        p.add_argument("--peer-cache", default=None, help=argparse.SUPPRESS)  # gone: fails with a hint
        p.add_argument("--no-peer-cache", action="store_true", help=argparse.SUPPRESS)
        _stored_args(p)

    p = sub.add_parser("eval", help="play our configurations over sources (OPE), store and score the runs")
    eval_args(p)
    p.set_defaults(func=commands.cmd_eval)

    p = sub.add_parser("compare",
                       help="eval plus OpenCV's trackers and stored peers; --protocol: OPE/SRE by fold")
    eval_args(p)
    p.add_argument("--opencv", nargs="*", default=None, choices=OPENCV_TRACKERS,
                   help="OpenCV peers (default: KCF CSRT MOSSE; with --protocol: KCF CSRT; empty: none)")
    p.add_argument("--peers", nargs="*", default=None,
                   help="stored peers of --peer-dir to show beside (e.g. ecohc_py; nothing is run for them)")
    p.add_argument("--protocol", nargs="+", choices=PROTOCOLS, default=None,
                   help="OPE and/or SRE (12 perturbed starts), false tracking, occlusions survived, per fold")
    p.set_defaults(func=commands.cmd_compare)

    p = sub.add_parser("table", help="tables of stored runs only: labels side by side, per sequence and fold")
    p.add_argument("labels", nargs="+",
                   help="stored labels (measured, opencv_csrt, ...) or peers (ecohc_py)")
    p.add_argument("--on", dest="bags", nargs="*", default=None, metavar="SRC",
                   help="only these sources' runs (default: every sequence stored for the labels)")
    p.add_argument("--protocol", nargs="+", choices=PROTOCOLS, default=list(PROTOCOLS))
    p.add_argument("--frames", type=int, default=None, help="with --on: the runs on the first N frames")
    p.add_argument("--allow-mixed", action="store_true",
                   help="score runs of one label that different code or settings made together anyway")
    _stored_args(p)
    p.set_defaults(func=commands.cmd_table, image_topic=None, gt_topic=None)

    p = sub.add_parser("verdict",
                       help=f"two stored trackers paired over videos (OPE): per-video difference, SE, "
                            f"the call (keep only when the mean gain > {KEEP_SE:g} SE)")
    p.add_argument("base",
                   help=f"stored label of the current choice (`{DEFAULT}`: the default configuration's)")
    p.add_argument("candidate", help="stored label of the change")
    p.add_argument("--metric", choices=METRICS, default="success_auc")
    p.add_argument("--on", dest="bags", nargs="*", default=None, metavar="SRC",
                   help="only these sources' runs (default: every sequence of --data stored for either)")
    p.add_argument("--frames", type=int, default=None)
    p.add_argument("--allow-mixed", action="store_true")
    _stored_args(p)
    p.set_defaults(func=commands.cmd_verdict, image_topic=None, gt_topic=None)


def _regress_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("regress",
                       help="gate a regression set on averaged protocols; exit 1 below a threshold")
    p.add_argument("--set", default="full", help="regression set name in --regression-dir (full, ci)")
    p.add_argument("--config", default=None, help="explicit regression YAML")
    p.add_argument("--regression-dir", default=str(REGRESSION_DIR), help="where set names are looked up")
    p.add_argument("--sequences", default=None,
                   help=f"folder of the real sequences (default: {DEFAULT_SEQUENCES})")
    p.add_argument("--results", default=None, help="keep the runs in this results directory and reuse them "
                                                   "(default: fresh runs in a temporary directory)")
    p.add_argument("--rerun", action="store_true", help="with --results: replace runs other code made")
    p.add_argument("--param", action="append", default=None, metavar="NAME=VALUE",
                   help="override a parameter of every configuration of the set (e.g. to show that a change "
                        "that costs accuracy fails the gate)")
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--json", default=None, help="write the scores of the set's runs as JSON")
    p.add_argument("--measure", default=None, metavar="OUT",
                   help="write the averaged values as JSON instead of gating (what --calibrate runs)")
    p.add_argument("--calibrate", action="store_true",
                   help="re-baseline: run the set in each numeric environment (--envs), print the thresholds "
                        "with their spreads (--write: into the set's YAML)")
    p.add_argument("--envs", nargs="+", default=["all"],
                   help=f"numeric environments for --calibrate: {', '.join(ENVIRONMENTS)} or all")
    p.add_argument("--write", action="store_true", help="--calibrate: rewrite the set's YAML")
    p.add_argument("--margin-factor", type=float, default=2.0,
                   help="--calibrate: margin = factor x spread ...")
    p.add_argument("--margin-floor", type=float, default=0.02, help="... but at least this")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=commands.cmd_regress)


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="harness", description="rosbag2 regression harness (docs/harness.md)")
    sub = ap.add_subparsers(dest="cmd", required=True)

    def bag_out(p: argparse.ArgumentParser) -> None:
        p.add_argument("--storage", choices=("sqlite3", "mcap"), default="sqlite3")
        p.add_argument("--compress", choices=("zstd",), default=None)
        p.add_argument("--bits", type=int, choices=(8, 16), default=None, help="rescale to 8 or 16 bit")
        p.add_argument("--frames", type=int, default=None, help="only the first N frames")

    p = sub.add_parser("make-bag", help="sequence folder (PNG + gt.txt) or synth:NAME -> rosbag2")
    p.add_argument("src")
    p.add_argument("out")
    p.add_argument("--hfov", type=float, default=8.0, help="nominal horizontal FOV for camera_info (deg)")
    bag_out(p)
    p.set_defaults(func=cmd_make_bag)

    p = sub.add_parser("synth", help="write a synthetic SWIR scenario as a bag (--list names them)")
    p.add_argument("name", nargs="?")
    p.add_argument("out", nargs="?")
    p.add_argument("--list", action="store_true")
    bag_out(p)
    p.set_defaults(func=cmd_synth)

    p = sub.add_parser("info", help="storage, duration, topics, counts declared and read")
    p.add_argument("bag")
    p.set_defaults(func=cmd_info)

    _evaluation_parsers(sub)

    p = sub.add_parser("replay", help="publish a bag to ROS (with /clock), record /track/*, score")
    p.add_argument("bag")
    p.add_argument("--rate", type=float, default=1.0)
    p.add_argument("--out", default=None, help="recording bag (default: <bag>_replayed)")
    p.add_argument("--wait", type=float, default=20.0, help="seconds to wait for the tracker node")
    p.add_argument("--grace", type=float, default=2.0, help="seconds to keep listening after the last frame")
    p.set_defaults(func=cmd_replay)

    _regress_parser(sub)
    add_track_parser(sub)
    return ap


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except HarnessError as exc:
        _err(str(exc))
        return 2
    except KeyboardInterrupt:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C must not interrupt the exit
        _err("interrupted")
        return 130
