# SPDX-License-Identifier: Apache-2.0
"""Analysis: score stored runs (ours, OpenCV's, the stored peers') into one `Results`, reading only storage.

Each label's runs are loaded from the results directory, or from a peer directory when the results hold
no runs under that label. Runs of one label that different code or settings produced are not mixed
silently: loading them together is an error unless asked for (`allow_mixed`).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.devset import DEFAULT_SEQUENCES as DEFAULT_SEQUENCES  # re-exported
from swir_tracker_ros.harness.devset import (
    SequenceInfo,
    catalogue,
    data_dirs,
    group_of,
    video_of,
)
from swir_tracker_ros.harness.evaluate import OPE, Run
from swir_tracker_ros.harness.metrics import SRE_PERTURBATIONS
from swir_tracker_ros.harness.peers import PeerDirectory
from swir_tracker_ros.harness.protocol import Results, RunStats
from swir_tracker_ros.harness.runner import frame_size, kind_of
from swir_tracker_ros.harness.sources import open_source, read_gt, source_fingerprint
from swir_tracker_ros.harness.store import REPO, RunRecord, RunStore, Truth, identity

DEFAULT_PEERS = REPO.parent / "shared" / "peers"
_MAKERS = ("tracker", "configuration", "overrides", "code", "numerics")  # what may not differ in one label


def folder_truth(folder: Path, max_frames: int | None = None) -> Truth:
    """The truth of a sequence folder from its gt.txt and meta.json, without decoding its frames."""
    src = open_source(folder, max_frames=max_frames)
    gt = read_gt(folder)[:max_frames] if max_frames else read_gt(folder)
    occ_frames = src.meta.get("occlusion_frames")
    occ = [None if occ_frames is None else (k + 1) in set(occ_frames) for k in range(len(gt))]
    w, h = frame_size(src)
    return Truth(src.key, kind_of(src), src.fps, gt, occ, [None] * len(gt), w, h, source_fingerprint(src))


def truth_for(store: RunStore, sequence: str, infos: dict[str, SequenceInfo]) -> Truth:
    """The stored truth of a sequence key, else that of the data folders' sequence of that name."""
    truth = store.load_truth(sequence)
    if truth is not None:
        return truth
    name, _, frames = sequence.partition("@")
    if name in infos:
        return folder_truth(infos[name].folder, int(frames) if frames else None)
    raise HarnessError(f"no stored truth for {sequence} in {store.root} and no sequence folder {name} in the "
                       "data folders (--data)")


def _makers(rec: RunRecord) -> str:
    ident = identity(rec.provenance)
    return json.dumps({k: ident[k] for k in _MAKERS}, sort_keys=True)


def load_results(store: RunStore, labels: Sequence[str], sequences: Sequence[str] | None = None,
                 starts: Sequence[str] | None = None, style: str = "otb",
                 data: Path | Sequence[Path] | None = None, peer_dir: Path = DEFAULT_PEERS,
                 allow_mixed: bool = False) -> Results:
    """Scores of the stored runs of `labels` on `sequences` (default: every sequence stored for them) from
    `starts` (default: OPE and the 12 SRE starts of `style`). `data`: the data folders (default: the
    development set, `devset.data_dirs`); a sequence is grouped by the data folder it is in and belongs
    to the video its meta.json names (`devset`)."""
    peers = PeerDirectory(peer_dir)
    stored = set(store.labels())
    for label in labels:
        if label not in stored and not peers.has(label):
            raise HarnessError(f"no runs labelled {label!r}: stored in {store.root} are "
                               f"{', '.join(sorted(stored)) or 'none'}; peers in {peers.root} are "
                               f"{', '.join(peers.labels()) or 'none'}")
    if sequences is None:
        sequences = sorted({s for label in labels if label in stored for s in store.sequences(label)})
    if starts is None:
        starts = (OPE, *SRE_PERTURBATIONS)
    infos = catalogue(data_dirs([data] if isinstance(data, (str, Path)) else data))
    results = Results(labels=list(labels))
    makers: dict[str, dict[str, tuple[str, str]]] = {label: {} for label in labels}
    meta: dict[str, dict] = {label: {"commits": set(), "codes": set()} for label in labels}
    for seq in sequences:
        truth = truth_for(store, seq, infos)
        results.groups[seq] = group_of(seq, truth.kind, infos)
        results.videos[seq] = video_of(seq, infos)
        for label in labels:
            for start in starts:
                st = None if start == OPE else style
                rec = (store.load(label, seq, start, st) if label in stored
                       else peers.load(label, truth, start, st))
                if rec is None:
                    continue
                if rec.provenance.get("fingerprint") != truth.fingerprint:
                    raise HarnessError(f"{label} on {seq} from {start}: the stored run was made on other "
                                       f"content than the stored truth of {seq}; play it again (--rerun)")
                makers[label].setdefault(_makers(rec), (seq, start))
                meta[label]["commits"].add(str(rec.provenance.get("commit", "-")))
                meta[label]["codes"].add(str(rec.provenance.get("code")))
                meta[label].update({k: rec.provenance.get(k)
                                    for k in ("tracker", "configuration", "overrides")})
                run = Run(rec.boxes, truth.gt, truth.occluded, rec.seconds, rec.states, truth.occlusion,
                          rec.init, rec.init_index)
                results.add(seq, label, start, RunStats.of(run, truth.fps))
    for label, seen in makers.items():
        if len(seen) > 1 and not allow_mixed:
            (a, (s1, p1)), (b, (s2, p2)) = list(seen.items())[:2]
            diff = [k for k in _MAKERS if json.loads(a)[k] != json.loads(b)[k]]
            raise HarnessError(f"the stored runs labelled {label} were made differently ({', '.join(diff)} "
                               f"differ: {s1} {p1} vs {s2} {p2}); play them again with --rerun, or "
                               "score them together anyway with --allow-mixed")
    results.labels = [label for label in labels if any(label in per for per in results.stats.values())]
    results.meta = {"labels": {k: {**v, "commits": sorted(v["commits"]), "codes": sorted(v["codes"])}
                               for k, v in meta.items() if k in results.labels},
                    "style": style, "results": str(store.root), "scored": "frames after the start frame; a "
                    "frame reported as failure keeps its last box"}
    return results
