# SPDX-License-Identifier: Apache-2.0
"""Make the int8 heads (`SiameseParams.precision` "int8"; core/siamese/int8.py: recipe and pins) from the
verified float files, calibrated on named development frames; `make models` runs it after the float files.

Calibration pairs: for each sequence of `CALIBRATION` (../shared/data/sequences), the exemplar crop of frame
1's ground-truth box and the search crops of frames `CALIBRATION_FRAMES`, each centred on the previous
frame's ground-truth box and scaled from its size, cut exactly as `SiameseTracker` cuts them (SiamFC context
0.5, sub-pixel crops, the first frame's mean as padding; LightTrack-M: every search crop at 256 and at 288
px, one per head). The head's calibration inputs are those crops' float backbone features (the verified
float backbone, one thread), each search paired with its sequence's exemplar. Each made file is checked
against its pin before it is put in place.

    python -m swir_tracker_ros.harness.quantise [--dest DIR] [--sequences DIR] [--optional] [--no-check]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from swir_tracker_ros.core.siamese.crops import context_side, cut_subpixel
from swir_tracker_ros.core.siamese.int8 import MADE_PINNED, quantise_model
from swir_tracker_ros.core.siamese.network import network
from swir_tracker_ros.core.siamese.params import VERSIONS
from swir_tracker_ros.core.siamese.weights import SHARE_SUBDIR, PinnedFile, sha256_of
from swir_tracker_ros.errors import ModelError
from swir_tracker_ros.harness.sources import frame_files, read_frame, read_gt

CALIBRATION: tuple[str, ...] = (
    "antiuav_irclip04", "dtb70_mountainbike6", "otb_bolt", "otb_crossing", "otb_skating1", "ptbtir_airplane",
    "uav123_person12_1", "vottir2015_horse",
)
"""Calibration sequences of ../shared/data/sequences: thermal and visible, large and small targets."""
CALIBRATION_FRAMES: tuple[int, ...] = (5, 10, 15, 20, 25, 30)
"""0-based frames searched per calibration sequence (each around the previous frame's ground truth)."""
DEFAULT_SEQUENCES = Path(__file__).resolve().parents[3] / "shared" / "data" / "sequences"


class QuantiseError(Exception):
    """An int8 head cannot be made (no calibration frames, no original) or is not the pinned one."""


def calibration_crops(version: str, sequences: Path
                      ) -> tuple[list[np.ndarray], list[list[np.ndarray]], list[int]]:
    """(exemplar crops, search crops per instance size, the exemplar index of each search) of the calibration
    sequences (module docstring)."""
    c = VERSIONS[version]
    sizes = [s for s in (c.instance_size, c.big_instance_size) if s]
    missing = [s for s in CALIBRATION if not (sequences / s).is_dir()]
    if missing:
        raise QuantiseError(f"the calibration sequence {sequences / missing[0]} is missing (the int8 "
                            f"heads are calibrated on {len(CALIBRATION)} named sequences of "
                            f"../shared/data/sequences; pass --sequences)")
    exemplars: list[np.ndarray] = []
    searches: list[list[np.ndarray]] = [[] for _ in sizes]
    owner: list[int] = []
    for name in CALIBRATION:
        files, gt = frame_files(sequences / name), read_gt(sequences / name)
        first = read_frame(files[0])
        fill = np.mean(first, axis=(0, 1))
        b = gt[0]
        exemplars.append(cut_subpixel(first, b.cx, b.cy, context_side(b.w, b.h, 0.5), c.exemplar_size, fill))
        for k in CALIBRATION_FRAMES:
            if k >= len(files) or not gt[k - 1].is_valid():
                continue
            prev = gt[k - 1]
            img, s_z = read_frame(files[k]), context_side(prev.w, prev.h, 0.5)
            owner.append(len(exemplars) - 1)
            for j, inst in enumerate(sizes):
                searches[j].append(cut_subpixel(img, prev.cx, prev.cy, s_z * inst / c.exemplar_size, inst,
                                                fill))
    return exemplars, searches, owner


def tracker_crops(version: str, folder: Path, frames: Iterable[int], instance: int = 0, limit: int = 0
                  ) -> tuple[np.ndarray, list[np.ndarray]]:
    """(the exemplar crop of the first frame's ground truth, the search crops (side `instance`, 0: the
    version's) of `frames` around the previous frame's ground truth), cut as the tracker cuts them; frames
    whose previous box is not valid are skipped, and at most `limit` crops are cut (0: all)."""
    c = VERSIONS[version]
    inst = instance or c.instance_size
    files, gt = frame_files(folder), read_gt(folder)
    first = read_frame(files[0])
    fill = np.mean(first, axis=(0, 1))
    b = gt[0]
    z = cut_subpixel(first, b.cx, b.cy, context_side(b.w, b.h, 0.5), c.exemplar_size, fill)
    xs: list[np.ndarray] = []
    for k in frames:
        prev = gt[k - 1]
        if prev is None or not prev.is_valid():
            continue
        s_z = context_side(prev.w, prev.h, 0.5)
        img = read_frame(files[k])
        xs.append(cut_subpixel(img, prev.cx, prev.cy, s_z * inst / c.exemplar_size, inst, fill))
        if limit and len(xs) == limit:
            break
    return z, xs


def head_feeds(version: str, originals: Path, sequences: Path) -> dict[str, list[dict[str, np.ndarray]]]:
    """{float head path under the model directory: calibration feeds} of a version: the float backbone's
    features of the calibration crops, each search paired with its sequence's exemplar."""
    c = VERSIONS[version]
    net = network(c, originals)
    exemplars, searches, owner = calibration_crops(version, sequences)
    zs = [net.features(z) for z in exemplars]
    heads = [h for h in (c.head, c.big_head) if h]
    names = ("input1", "input2") if c.family == "nanotrack" else ("zf", "xf")
    out = {}
    for head, crops in zip(heads, searches):
        out[head] = [{names[0]: zs[owner[i]], names[1]: net.features(x)} for i, x in enumerate(crops)]
    return out


def made_for(version: str) -> list[PinnedFile]:
    """The made (int8) files of a version."""
    c = VERSIONS[version]
    return [f for f in MADE_PINNED if f.path in c.files_for("int8")]


def make(dest: Path, originals: Path | None = None, sequences: Path = DEFAULT_SEQUENCES,
         versions: tuple[str, ...] = ("v2", "v3", "lighttrack"), check: bool = True) -> dict[str, str]:
    """Every int8 head of `versions` under `dest`, made from the verified float files of `originals`
    (default `dest`) and checked against its pin unless `check` is False; {path: "present" | "made"}.
    QuantiseError (one line) when a file cannot be made or is not the pinned one."""
    originals = Path(originals or dest)
    done: dict[str, str] = {}
    for version in versions:
        todo = [f for f in made_for(version)
                if not (check and (dest / f.path).is_file() and sha256_of(dest / f.path) == f.sha256)]
        done.update({f.path: "present" for f in made_for(version) if f not in todo})
        if not todo:
            continue
        try:
            feeds = head_feeds(version, originals, sequences)
        except ModelError as exc:
            raise QuantiseError(f"cannot make the int8 heads of {version}: {exc}") from None
        for f in todo:
            head = f.path.replace("_int8.onnx", ".onnx")
            target = dest / f.path
            target.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp_name = tempfile.mkstemp(dir=target.parent, suffix=".part")
            os.close(fd)
            tmp = Path(tmp_name)
            try:
                quantise_model(originals / head, feeds[head], tmp)
                got = sha256_of(tmp)
                if check and got != f.sha256:
                    raise QuantiseError(f"{f.path} made from {head} has sha256 {got}, pinned {f.sha256} "
                                        f"(another onnxruntime than requirements.txt's, or other calibration "
                                        f"frames?)")
                os.chmod(tmp, 0o644)
                os.replace(tmp, target)
            finally:
                tmp.unlink(missing_ok=True)
            done[f.path] = "made"
    return done


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dest", default=str(Path(sys.prefix).joinpath(*SHARE_SUBDIR)),
                    help="model directory holding the float files; the int8 heads are written beside them")
    ap.add_argument("--originals", default=None, help="where the float files are (default: --dest)")
    ap.add_argument("--sequences", default=str(DEFAULT_SEQUENCES),
                    help="folder of the calibration sequences (../shared/data/sequences)")
    ap.add_argument("--no-check", action="store_true",
                    help="write the files without comparing them with the pins (to make new pins)")
    ap.add_argument("--optional", action="store_true", help="say what cannot be made, but exit 0")
    a = ap.parse_args(argv)
    try:
        done = make(Path(a.dest), Path(a.originals) if a.originals else None, Path(a.sequences),
                    check=not a.no_check)
    except QuantiseError as exc:
        print(f"models: int8 heads not made: {exc}. precision int8 will refuse to start; float32 works.",
              file=sys.stderr)
        return 0 if a.optional else 1
    for path, how in done.items():
        print(f"models: {path}: {how} ({'sha256 ok' if not a.no_check else sha256_of(Path(a.dest) / path)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
