# SPDX-License-Identifier: Apache-2.0
"""Runs of trackers outside this project stored as text, read as peers beside ours (e.g. `ecohc_py`).

Layout (../shared/peers/README.md): `<root>/<peer>/<sequence>/<start>.txt`, one `x,y,w,h` line per frame in
0-based pixels; line 1 is the start box the peer was given (checked against the harness's own start box),
lines 2..N its output for frames 2..N. <start> is `ope` or one of the 12 OTB-style SRE starts. A peer that
never reports failure gives state `tracking` on every frame after the start.
"""

from __future__ import annotations

from pathlib import Path

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.evaluate import OPE
from swir_tracker_ros.harness.metrics import sre_box
from swir_tracker_ros.harness.sources import parse_gt_line
from swir_tracker_ros.harness.store import RunRecord, Truth, start_tag

START_TOLERANCE = 0.01  # px: the stored start box must be the harness's start box


class PeerDirectory:
    """A directory of peers' stored runs (module docstring)."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)

    def labels(self) -> list[str]:
        if not self.root.is_dir():
            return []
        return sorted(p.name for p in self.root.iterdir() if p.is_dir() and not p.name.startswith("."))

    def has(self, label: str) -> bool:
        return (self.root / label).is_dir()

    def path(self, label: str, sequence: str, start: str) -> Path:
        return self.root / label / sequence.split("@", 1)[0] / f"{start_tag(start, 'otb')}.txt"

    def load(self, label: str, truth: Truth, start: str, style: str = "otb") -> RunRecord | None:
        """The peer's run from `start` on the sequence of `truth` (None when not stored; only the OTB
        style's starts are stored). The boxes beyond the truth's frames (`name@N` keys) are cut off."""
        if start != OPE and style != "otb":
            return None
        path = self.path(label, truth.sequence, start)
        if not path.is_file():
            return None
        try:
            lines = [ln for ln in path.read_text().splitlines() if ln.strip()]
        except (OSError, UnicodeDecodeError) as exc:
            raise HarnessError(f"{path}: cannot be read: {exc}") from None
        n = len(truth.gt)
        if len(lines) < n:
            raise HarnessError(f"{path}: {len(lines)} boxes for the {n} frames of {truth.sequence}")
        boxes = [parse_gt_line(ln, path, k + 1) for k, ln in enumerate(lines[:n])]
        first = next((k for k, g in enumerate(truth.gt) if g is not None), None)
        if first is None:
            raise HarnessError(f"{truth.sequence}: no frame with ground truth")
        if first != 0:
            raise HarnessError(f"{path}: stored peer runs start on frame 1, but {truth.sequence}'s first "
                               f"ground truth is on frame {first + 1}")
        want = sre_box(truth.gt[0], start, truth.width, truth.height, "otb")
        got = boxes[0]
        if got is None or max(abs(a - b) for a, b in zip(got.as_tuple(), want.as_tuple())) > START_TOLERANCE:
            raise HarnessError(f"{path}: line 1 is the start box {got}, but the harness starts {start} from "
                               f"{want}")
        style = None if start == OPE else "otb"
        prov = {"tracker": label, "configuration": "stored", "overrides": [],
                "code": f"stored in {path.parent.parent}", "numerics": {}, "fingerprint": truth.fingerprint,
                "style": style}
        states = ["init"] + ["tracking"] * (n - 1)
        return RunRecord(label, truth.sequence, start, style, boxes, states, 0.0, want, 0, prov)
