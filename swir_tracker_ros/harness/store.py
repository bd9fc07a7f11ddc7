# SPDX-License-Identifier: Apache-2.0
"""Stored runs: the raw per-frame boxes and states of every (tracker, configuration, sequence, start) on
disk, with what produced them, and each sequence's ground truth once; scoring reads only these files.

Layout under the results directory (one JSON file each, written atomically):

    truth/<sequence>.json                  ground truth, occlusion flags and shares, fps, image size
    runs/<label>/<sequence>/<start>.json   boxes, states, tracker seconds, start box, provenance

<label> names a (tracker, configuration, overrides): our configuration's name (`measured`), the name plus
a hash of its overrides (`measured+1a2b3c`) or one given with --label, `opencv_csrt` for OpenCV's CSRT.
<sequence> is the source's name, plus `@N` when only its first N frames were used. <start> is `ope` or an
SRE start (`left`, ..., `scale_1.2`), prefixed `<style>-` for the styles other than the OTB toolkit's.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import subprocess
import tempfile
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.metrics import SRE_STYLES
from swir_tracker_ros.types import Box

FORMAT = 1
OPE = "none"  # the start of the one-pass run, the ground-truth box itself (its stored file: ope.json)
PACKAGE = Path(__file__).resolve().parents[1]
REPO = PACKAGE.parent  # the repository (a source checkout) the package is in
# Provenance fields that must agree for a stored run to stand for a new one (the others are information).
IDENTITY = ("tracker", "configuration", "overrides", "code", "numerics", "fingerprint", "style")
# Environment variables that change floating-point results (kernel choice); part of `numerics()`.
NUMERIC_VARS = ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE", "OPENCV_CPU_DISABLE", "NUMBA_CPU_NAME",
                "NUMBA_CPU_FEATURES")


@lru_cache(maxsize=1)
def git_commit() -> str:
    """Short commit of the repository, `+dirty` when tracked files differ from it."""
    try:
        rev = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return rev + ("+dirty" if dirty else "")


@lru_cache(maxsize=1)
def code_hash() -> str:
    """Hash of the package's files outside the harness (core, tracker, models, ...): the code that decides
    our tracker's boxes, committed or not."""
    h = hashlib.sha1()
    for f in sorted(PACKAGE.rglob("*")):
        rel = f.relative_to(PACKAGE)
        if f.is_file() and rel.parts[0] != "harness" and "__pycache__" not in rel.parts:
            h.update(str(rel).encode() + b"\0" + f.read_bytes())
    return h.hexdigest()[:12]


@lru_cache(maxsize=1)
def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def numerics() -> dict[str, str]:
    """The numeric environment of this process: CPU, architecture and the kernel-choice variables."""
    out = {"cpu": cpu_model(), "machine": platform.machine()}
    out.update({v: os.environ[v] for v in NUMERIC_VARS if os.environ.get(v)})
    return out


def start_tag(start: str, style: str | None) -> str:
    """File stem of a start: `ope`, `left` (OTB style) or `<style>-left`."""
    if start == OPE:
        return "ope"
    return start if style in (None, "otb") else f"{style}-{start}"


def parse_tag(tag: str) -> tuple[str, str | None]:
    """(start, style) of a file stem (`start_tag`'s inverse); the OPE start has no style."""
    if tag == "ope":
        return OPE, None
    head, dash, rest = tag.partition("-")
    if dash and head in SRE_STYLES:
        return rest, head
    return tag, "otb"


def _box(v: list | None) -> Box | None:
    return None if v is None else Box(*(float(x) for x in v))


def _list(b: Box | None) -> list[float] | None:
    return None if b is None else [float(v) for v in b.as_tuple()]


@dataclass
class Truth:
    """What a sequence's runs are scored against, stored once per sequence key."""

    sequence: str  # key: name, or name@N
    kind: str  # "real" or "synth"
    fps: float
    gt: list[Box | None]
    occluded: list[bool | None]
    occlusion: list[float | None]  # covered share of the silhouette (synthetic); None elsewhere
    width: int = 0
    height: int = 0
    fingerprint: str = ""

    def to_json(self) -> dict:
        return {"format": FORMAT, "sequence": self.sequence, "kind": self.kind, "fps": self.fps,
                "width": self.width, "height": self.height, "fingerprint": self.fingerprint,
                "gt": [_list(b) for b in self.gt], "occluded": self.occluded, "occlusion": self.occlusion}

    @classmethod
    def from_json(cls, d: dict) -> Truth:
        return cls(d["sequence"], d["kind"], float(d["fps"]), [_box(b) for b in d["gt"]], list(d["occluded"]),
                   list(d["occlusion"]), int(d["width"]), int(d["height"]), d["fingerprint"])


@dataclass
class RunRecord:
    """One stored run: the boxes and states as the tracker reported them, and what produced them."""

    label: str
    sequence: str
    start: str  # OPE ("none") or an SRE perturbation
    style: str | None  # SRE style of the start box (None for OPE)
    boxes: list[Box | None]
    states: list[str]
    seconds: float
    init: Box
    init_index: int
    provenance: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        return {"format": FORMAT, "label": self.label, "sequence": self.sequence, "start": self.start,
                "style": self.style, "init": _list(self.init), "init_index": self.init_index,
                "seconds": self.seconds, "provenance": self.provenance,
                "boxes": [_list(b) for b in self.boxes], "states": self.states}

    @classmethod
    def from_json(cls, d: dict) -> RunRecord:
        return cls(d["label"], d["sequence"], d["start"], d["style"], [_box(b) for b in d["boxes"]],
                   list(d["states"]), float(d["seconds"]), _box(d["init"]), int(d["init_index"]),
                   dict(d["provenance"]))


def identity(provenance: dict) -> dict:
    """The fields of a provenance that decide the boxes (`IDENTITY`)."""
    return {k: provenance.get(k) for k in IDENTITY}


def differences(stored: dict, wanted: dict) -> list[str]:
    """`field: stored -> wanted` for every identity field in which two provenances differ."""
    a, b = identity(stored), identity(wanted)
    return [f"{k}: {a[k]!r} -> {b[k]!r}" for k in IDENTITY if a[k] != b[k]]


def _write_json(path: Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    with os.fdopen(fd, "w") as f:
        json.dump(data, f)
    os.chmod(tmp, 0o644)  # mkstemp makes it private; a results directory may be shared
    os.replace(tmp, path)  # atomic: a concurrent reader never sees half a file


def _read_json(path: Path) -> dict | None:
    try:
        text = path.read_text()
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise HarnessError(f"{path}: cannot be read: {exc}") from None
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise HarnessError(f"{path}: not valid JSON ({exc}); delete it or re-run with --rerun") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise HarnessError(f"{path}: not a stored run or truth of format {FORMAT}")
    return data


class RunStore:
    """A results directory (layout in the module docstring)."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)

    def truth_path(self, sequence: str) -> Path:
        return self.root / "truth" / f"{sequence}.json"

    def run_path(self, label: str, sequence: str, start: str, style: str | None) -> Path:
        if not label or "/" in label or label.startswith("."):
            raise HarnessError(f"{label!r} cannot name a stored run (no '/', not empty, no leading '.')")
        return self.root / "runs" / label / sequence / f"{start_tag(start, style)}.json"

    def save_truth(self, truth: Truth) -> None:
        _write_json(self.truth_path(truth.sequence), truth.to_json())

    def load_truth(self, sequence: str) -> Truth | None:
        path = self.truth_path(sequence)
        data = _read_json(path)
        try:
            return None if data is None else Truth.from_json(data)
        except (KeyError, TypeError, ValueError) as exc:
            raise HarnessError(f"{path}: malformed stored truth ({exc!r})") from None

    def save(self, record: RunRecord) -> None:
        path = self.run_path(record.label, record.sequence, record.start, record.style)
        _write_json(path, record.to_json())

    def load(self, label: str, sequence: str, start: str, style: str | None) -> RunRecord | None:
        path = self.run_path(label, sequence, start, style)
        data = _read_json(path)
        try:
            return None if data is None else RunRecord.from_json(data)
        except (KeyError, TypeError, ValueError) as exc:
            raise HarnessError(f"{path}: malformed stored run ({exc!r})") from None

    def labels(self) -> list[str]:
        base = self.root / "runs"
        return sorted(p.name for p in base.iterdir() if p.is_dir()) if base.is_dir() else []

    def sequences(self, label: str) -> list[str]:
        base = self.root / "runs" / label
        return sorted(p.name for p in base.iterdir() if p.is_dir()) if base.is_dir() else []

    def starts(self, label: str, sequence: str) -> list[tuple[str, str | None]]:
        """(start, style) of every stored run of `label` on `sequence`."""
        base = self.root / "runs" / label / sequence
        return [parse_tag(p.stem) for p in sorted(base.glob("*.json"))] if base.is_dir() else []
