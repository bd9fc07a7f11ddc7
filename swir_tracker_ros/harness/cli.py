# SPDX-License-Identifier: Apache-2.0
"""The `harness` command: make-bag, synth, info, eval, compare, replay, regress (docs/harness.md)."""

from __future__ import annotations

import argparse
import json
import signal
import sys
from pathlib import Path

from swir_tracker_ros.configs import CONFIGURATIONS, DEFAULT_CONFIGURATION
from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.bagio import FrameRecord, bag_info, write_bag
from swir_tracker_ros.harness.evaluate import EvalResult, evaluate, format_table
from swir_tracker_ros.harness.metrics import SRE_STYLES
from swir_tracker_ros.harness.sources import SYNTH_PREFIX, Source, convert_bits, open_source

DEFAULT_PEER_CACHE = str(Path.home() / ".cache" / "swir_tracker_ros" / "peers")


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
        from swir_tracker_ros.scene.scenarios import make_scenario

        cam = make_scenario(src.location).views[0].camera_info()
    else:
        from swir_tracker_ros.scene.camera import CameraView

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
    from swir_tracker_ros.scene import scenarios

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


def _sources(a: argparse.Namespace) -> list[Source]:
    srcs = []
    for spec in a.bags:
        if spec == SYNTH_PREFIX + "all":  # every synthetic scenario (`harness synth --list`)
            from swir_tracker_ros.scene import scenarios

            srcs += [open_source(SYNTH_PREFIX + n, a.frames) for n in scenarios()]
            continue
        p = Path(spec)
        if p.is_dir() and not (p / "gt.txt").exists() and not (p / "metadata.yaml").exists() \
                and any((c / "gt.txt").exists() for c in p.iterdir() if c.is_dir()):
            srcs += [open_source(c, a.frames, a.image_topic, a.gt_topic) for c in sorted(p.iterdir())
                     if (c / "gt.txt").exists()]  # a folder of sequence folders
        else:
            srcs.append(open_source(spec, a.frames, a.image_topic, a.gt_topic))
    return srcs


def _finish(result: EvalResult, a: argparse.Namespace) -> None:
    print(format_table(result))
    if a.json:
        Path(a.json).parent.mkdir(parents=True, exist_ok=True)
        Path(a.json).write_text(json.dumps(result.to_json(curves=a.curves), indent=1))
        print(f"wrote {a.json}")
    if a.plots:
        from swir_tracker_ros.harness.plots import plot_result

        paths = plot_result(result, a.plots)
        print(f"wrote {len(paths)} plots to {a.plots}")


def _progress(a: argparse.Namespace):
    return None if a.quiet else (lambda line: print(line, file=sys.stderr, flush=True))


def cmd_eval(a: argparse.Namespace) -> int:
    srcs = _sources(a)
    names = a.tracker or list(CONFIGURATIONS)
    result = evaluate(srcs, names, a.pipeline, _progress(a), overrides=a.set or ())
    _finish(result, a)
    return 0


def cmd_compare(a: argparse.Namespace) -> int:
    if a.protocol:
        return _compare_protocol(a)
    from swir_tracker_ros.harness.compare import add_opencv

    srcs = _sources(a)
    reuse = EvalResult()
    for path in a.reuse or []:
        try:
            reuse.merge(EvalResult.from_json(json.loads(Path(path).read_text())))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise HarnessError(f"{path}: cannot reuse this result: {exc}") from None
    variants = list(CONFIGURATIONS) if a.tracker is None else a.tracker
    result = evaluate(srcs, variants, a.pipeline, _progress(a), reuse, a.set or ())
    for name, per in result.sequences.items():  # reused OpenCV rows
        per.update({k: v for k, v in reuse.sequences.get(name, {}).items() if k.startswith("opencv_")})
    add_opencv(result, srcs, ["KCF", "CSRT", "MOSSE"] if a.opencv is None else a.opencv, _progress(a))
    _finish(result, a)
    return 0


def _compare_protocol(a: argparse.Namespace) -> int:
    """`compare --protocol ope sre`: OPE/SRE tables, false tracking, occlusions survived (protocol.py)."""
    import os

    from swir_tracker_ros.harness.protocol import (
        ProtocolResult,
        format_markdown,
        format_protocol,
        run_protocol,
    )
    if a.plots or a.curves:
        raise HarnessError("--plots and --curves belong to the plain compare, not to --protocol")
    reuse = None
    for path in a.reuse or []:
        try:
            old = ProtocolResult.from_json(json.loads(Path(path).read_text()))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise HarnessError(f"{path}: cannot reuse this protocol result: {exc}") from None
        if reuse is None:
            reuse = old
        else:
            for seq, per in old.stats.items():
                reuse.stats.setdefault(seq, {}).update(per)
    variants = [DEFAULT_CONFIGURATION] if a.tracker is None else a.tracker
    peers = ["KCF", "CSRT"] if a.opencv is None else a.opencv
    cache = None if a.no_peer_cache else (a.peer_cache or os.environ.get("SWIR_PEER_CACHE")
                                          or DEFAULT_PEER_CACHE)

    def write(result: ProtocolResult, complete: bool = False) -> None:
        if a.json:
            Path(a.json).parent.mkdir(parents=True, exist_ok=True)
            result.meta["complete"] = complete
            Path(a.json).write_text(json.dumps(result.to_json(), indent=1))

    result = run_protocol(_sources(a), variants, peers, a.protocol, a.pipeline, a.sre_style, a.jobs, cache,
                          _progress(a), reuse, write, a.set or ())
    print(format_protocol(result))
    if a.markdown:
        Path(a.markdown).write_text(format_markdown(result) + "\n")
        print(f"wrote {a.markdown}")
    if a.json:
        write(result, complete=True)
        print(f"wrote {a.json}")
    return 0


def cmd_replay(a: argparse.Namespace) -> int:
    from swir_tracker_ros.harness.replay import replay

    out = Path(a.out) if a.out else Path(str(Path(a.bag).resolve()) + "_replayed")
    res = replay(a.bag, out, a.rate, a.wait, a.grace)
    result = EvalResult({Path(a.bag).name: {"tracker_node": res.score}})
    print(format_table(result))
    print(f"{res.answered}/{res.frames} frames answered on /track/box; recording in {res.recorded}")
    return 0


def cmd_regress(a: argparse.Namespace) -> int:
    from swir_tracker_ros.harness.regress import (
        DEFAULT_SEQUENCES,
        config_path,
        format_violations,
        run_regression,
    )

    cfg = config_path(a.config or a.set)
    result, violations = run_regression(cfg, Path(a.sequences or DEFAULT_SEQUENCES), _progress(a))
    print(format_table(result))
    if a.json:
        Path(a.json).write_text(json.dumps(result.to_json(), indent=1))
    if violations:
        print(f"\nREGRESSION: {len(violations)} score(s) below the thresholds in {cfg}:")
        print(format_violations(violations))
        return 1
    print(f"\nregression set {cfg.stem}: all scores at or above the thresholds in {cfg}")
    return 0


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

    def eval_args(p: argparse.ArgumentParser) -> None:
        p.add_argument("bags", nargs="+", help="bags, sequence folders, a folder of them, or synth:NAME")
        p.add_argument("--tracker", nargs="*", choices=tuple(CONFIGURATIONS), default=None,
                       help="variants (default: all; `compare --tracker` alone: OpenCV only)")
        p.add_argument("--pipeline", default=None,
                       help="TrackerParams.pipeline (default: TrackerParams' own default)")
        p.add_argument("--set", action="append", default=None, metavar="NAME=VALUE",
                       help="override a TrackerParams field for our variants (repeatable; dotted names for "
                            "nested parameter groups; VALUE parsed as YAML)")
        p.add_argument("--frames", type=int, default=None, help="only the first N frames of each source")
        p.add_argument("--image-topic", default=None)
        p.add_argument("--gt-topic", default=None)
        p.add_argument("--json", default=None)
        p.add_argument("--curves", action="store_true", help="also store the curves in the JSON")
        p.add_argument("--plots", default=None, help="directory for precision/success PNGs")
        p.add_argument("--quiet", action="store_true")

    p = sub.add_parser("eval", help="replay sources through tracker variants and score them")
    eval_args(p)
    p.set_defaults(func=cmd_eval)

    p = sub.add_parser("compare", help="eval plus OpenCV KCF/CSRT/MOSSE (run in .venv-bench)")
    eval_args(p)
    p.add_argument("--reuse", nargs="+", default=None,
                   help="JSON results (--json ... --curves; with --protocol: protocol JSON) whose rows need "
                        "not be run again")
    p.add_argument("--opencv", nargs="*", default=None, choices=("KCF", "CSRT", "MOSSE"),
                   help="OpenCV peers (default: KCF CSRT MOSSE; with --protocol: KCF CSRT; empty: none)")
    p.add_argument("--protocol", nargs="+", choices=("ope", "sre"), default=None,
                   help="issue-12 protocol: OPE and/or SRE (12 perturbed starts), false tracking, occlusions "
                        "survived; our runs and peers on the same frames (docs/harness.md)")
    p.add_argument("--jobs", type=int, default=1, help="--protocol: parallel (tracker, source) tasks")
    p.add_argument("--sre-style", choices=SRE_STYLES, default="otb",
                   help="SRE start boxes: the OTB toolkit's shiftInitBB (otb), rigid 10 %% shifts (shift), "
                        "or the same 12 starts 1 px apart (pixel: the answer's stability; metrics.sre_box)")
    p.add_argument("--peer-cache", default=None,
                   help="--protocol: OpenCV results cache (default: $SWIR_PEER_CACHE or "
                        f"{DEFAULT_PEER_CACHE})")
    p.add_argument("--no-peer-cache", action="store_true", help="--protocol: always run the peers")
    p.add_argument("--markdown", default=None, help="--protocol: also write the tables as Markdown")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("replay", help="publish a bag to ROS (with /clock), record /track/*, score")
    p.add_argument("bag")
    p.add_argument("--rate", type=float, default=1.0)
    p.add_argument("--out", default=None, help="recording bag (default: <bag>_replayed)")
    p.add_argument("--wait", type=float, default=20.0, help="seconds to wait for the tracker node")
    p.add_argument("--grace", type=float, default=2.0, help="seconds to keep listening after the last frame")
    p.set_defaults(func=cmd_replay)

    p = sub.add_parser("regress", help="eval the regression set; exit 1 when a score drops below threshold")
    p.add_argument("--set", default="full", help="regression set name in test/regression (full, ci)")
    p.add_argument("--config", default=None, help="explicit regression YAML")
    p.add_argument("--sequences", default=None, help="folder of the real sequences")
    p.add_argument("--json", default=None)
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=cmd_regress)
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
