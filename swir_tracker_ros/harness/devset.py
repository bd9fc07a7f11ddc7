# SPDX-License-Identifier: Apache-2.0
"""The development set: the shared sequence folders and the built development corpus, and what each
sequence's meta.json says about it (the video it was cut from, its window, its absent frames).

`--data DIR ...` names folders of sequence folders (or sequence folders themselves); the short name `dev`,
and no `--data` at all, stand for the development set: `../shared/data/sequences` and the corpus built from
`../shared/corpus` (`$SWIR_CORPUS`, else `../corpus` beside the repository). A sequence's group in the
tables is the name of the folder it was found in; its video is meta.json's `video`, else its own name (a
sequence without `video` is a video of its own). Windows of one video are averaged before a paired
verdict (`verdict.py`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.sources import absent_frames, read_meta_json
from swir_tracker_ros.harness.store import REPO

DEV = "dev"  # the short name of the development set (`--data dev`, `harness eval dev`)
CORPUS_ENV = "SWIR_CORPUS"  # where the built development corpus is, when not ../corpus
DEFAULT_SEQUENCES = REPO.parent / "shared" / "data" / "sequences"
DEFAULT_CORPUS = REPO.parent / "corpus"
SYNTHETIC = "synthetic"  # the group of the synthetic scenarios
OTHER = "other"  # the group of a source outside the data folders (a bag, a foreign folder)


def corpus_dir() -> Path:
    """The built development corpus: `$SWIR_CORPUS`, else `../corpus` beside the repository."""
    return Path(os.environ.get(CORPUS_ENV) or DEFAULT_CORPUS)


def development_set() -> list[Path]:
    """The folders of the development set: the shared sequences and the built corpus."""
    return [DEFAULT_SEQUENCES, corpus_dir()]


def data_dirs(specs: Sequence[str | Path] | None = None) -> list[Path]:
    """The data folders named by `--data` (each a folder of sequence folders or one sequence folder; `dev`
    is the development set), in order, each once. Without `specs`: the development set's folders that
    exist (a fresh clone without the corpus still has the shared ones). A named folder that does not exist
    is a HarnessError."""
    if not specs:
        return [d for d in development_set() if d.is_dir()]
    out: list[Path] = []
    for spec in specs:
        for d in development_set() if str(spec) == DEV else [Path(spec)]:
            if not d.is_dir():
                hint = (f" (build the corpus: ../shared/corpus/README.md, or set ${CORPUS_ENV})"
                        if str(spec) == DEV and d == corpus_dir() else "")
                raise HarnessError(f"{d}: no such data folder{hint}")
            if d not in out:
                out.append(d)
    return out


def is_sequence(path: Path) -> bool:
    """A sequence folder: a directory with a gt.txt."""
    return (path / "gt.txt").is_file()


def sequence_folders(dirs: Sequence[Path]) -> dict[str, Path]:
    """name -> folder of every sequence in `dirs` (a folder of sequence folders, or a sequence folder);
    HarnessError when two folders of the set share a name."""
    out: dict[str, Path] = {}
    for d in dirs:
        found = [d] if is_sequence(d) else sorted(c for c in d.iterdir() if c.is_dir() and is_sequence(c))
        for f in found:
            if f.name in out and out[f.name].resolve() != f.resolve():
                raise HarnessError(f"two sequences are called {f.name}: {out[f.name]} and {f}")
            out[f.name] = f
    return out


@dataclass(frozen=True)
class SequenceInfo:
    """What the development set knows of one sequence (meta.json; nothing is decoded)."""

    name: str
    folder: Path
    group: str  # the data folder it was found in (its name): the group it is shown in
    video: str  # meta.json "video", else the sequence's own name
    window: tuple[int, int] | None = None  # meta.json "window": first and last source frame
    absent_frames: tuple[int, ...] = ()  # meta.json "absent_frames": 1-based frames without the target


def sequence_info(folder: Path, group: str | None = None) -> SequenceInfo:
    """The `SequenceInfo` of one sequence folder from its meta.json (checked by `read_meta_json`)."""
    meta = read_meta_json(folder / "meta.json")
    window = meta.get("window")
    video = str(meta.get("video") or folder.name)
    return SequenceInfo(folder.name, folder, group or folder.parent.name, video,
                        None if window is None else (int(window[0]), int(window[1])),
                        absent_frames(meta))


def catalogue(dirs: Sequence[Path]) -> dict[str, SequenceInfo]:
    """name -> `SequenceInfo` of every sequence of `dirs`; the group is the data folder's name."""
    out: dict[str, SequenceInfo] = {}
    for d in dirs:
        for name, folder in sequence_folders([d]).items():
            if name in out and out[name].folder.resolve() != folder.resolve():
                raise HarnessError(f"two sequences are called {name}: {out[name].folder} and {folder}")
            out[name] = sequence_info(folder, d.parent.name if is_sequence(d) else d.name)
    return out


def video_of(sequence: str, infos: dict[str, SequenceInfo]) -> str:
    """The video of a stored sequence key (`name` or `name@N`): its meta.json's, else its own name."""
    name = sequence.split("@", 1)[0]
    return infos[name].video if name in infos else name


def group_of(sequence: str, kind: str, infos: dict[str, SequenceInfo]) -> str:
    """The group a sequence key is shown in: its data folder, "synthetic" or "other"."""
    if kind == "synth":
        return SYNTHETIC
    name = sequence.split("@", 1)[0]
    return infos[name].group if name in infos else OTHER
