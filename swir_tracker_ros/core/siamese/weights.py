# SPDX-License-Identifier: Apache-2.0
"""The pinned network weights (upstream commit, paths, sha256) and the fetch/verify step of `make models`.

The ONNX files are a dependency like a wheel, never repository content: `make models` runs this file as a
script (standard library only, so it runs before anything is installed) to put them under
`<venv>/share/swir_tracker_ros/models/{v2,v3,lighttrack}/`, copied from a local mirror (`../shared/models`,
which holds `nanotrack/` and `lighttrack/`) when there is one, else from the pinned upstream; checked against
the sha256 below either way.

- NanoTrack v2 / v3 (HonglinChu/SiamTrackers, Apache-2.0): the ONNX files are downloaded as published.
- LightTrack-Mobile (Yan et al., CVPR 2021; the authors' MIT checkpoint): upstream publishes no small ONNX,
  only an OpenVINO IR (l-sf/LightTrack_openvino). Without a mirror copy the IR is downloaded at the pinned
  commit, checked, and converted by the mirror's own `convert_ir_to_onnx.py` (run with `--python`, which needs
  `onnx` and `numpy`); the ONNX it writes is checked against the pin like any other file. The converter is
  never copied into this repository: without it, one error says what is missing and how to get it.
- YOLOX-Nano, the acquisition's learned person detector (`DETECTOR_PINNED`; Megvii's Apache-2.0 COCO
  checkpoint of release 0.1.1rc0 exported to ONNX by the authors' tools/export_onnx.py, as committed by
  Kazuhito00/YOLOX-ONNX-TFLite-Sample, whose notebook records the export; docs/acquisition.md), with the
  upstream's LICENSE beside it. No shared mirror holds it, so it is optional: `make models` installs it when
  it can (mirror `detector/`, a local git mirror of the upstream repository (`--git-mirrors`, default
  $SWIR_TRACKER_GIT_MIRRORS: a folder of `owner+name` git directories, as `fetch` leaves them), else the
  download) and otherwise says what is missing without failing; the acquisition node refuses that
  detector alone.

    python swir_tracker_ros/core/siamese/weights.py --dest DIR [--mirror DIR] [--no-download] [--python PY]
        [--converter FILE] [--optional] [--git-mirrors DIR]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

RAW_URL = "https://raw.githubusercontent.com/{repo}/{commit}/{path}"
SHARE_SUBDIR = ("share", "swir_tracker_ros", "models")  # under a prefix (venv, colcon install)
CONVERTER = "lighttrack/convert_ir_to_onnx.py"  # the IR -> ONNX converter, under the mirror


@dataclass(frozen=True)
class Upstream:
    """A public repository at a pinned commit."""

    repo: str
    commit: str
    licence: str
    folder: str  # where the weights are in it

    def raw(self, path: str) -> str:
        """The raw URL of `path` at the pinned commit."""
        return RAW_URL.format(repo=self.repo, commit=self.commit, path=path)

    @property
    def page(self) -> str:
        """The weights' folder at the pinned commit (what an error message points a user to)."""
        return f"https://github.com/{self.repo}/tree/{self.commit}/{self.folder}"


NANOTRACK = Upstream("HonglinChu/SiamTrackers", "248663fde6bf7c40190cf10ee396d5662919ecd3",
                     "Apache-2.0 (NanoTrack/LICENSE of the upstream repository)", "NanoTrack/models")
LIGHTTRACK_IR = Upstream("l-sf/LightTrack_openvino", "5eaaf93fddeecf0dfce4e8c0daf4ab2bf7f4a4c1",
                         "MIT (the authors' checkpoint, researchmm/LightTrack LICENSE)", "models")
YOLOX_NANO = Upstream("Kazuhito00/YOLOX-ONNX-TFLite-Sample", "3d4f1119d0694200671c08069ecb847aa0d8495a",
                      "Apache-2.0 (LICENSE of the upstream repository; YOLOX itself, "
                      "Megvii-BaseDetection/YOLOX, is Apache-2.0)", "model")
UPSTREAM_COMMIT = NANOTRACK.commit
GIT_MIRRORS_VAR = "SWIR_TRACKER_GIT_MIRRORS"  # default of --git-mirrors


@dataclass(frozen=True)
class PinnedFile:
    """One file: its path under the model directory (`path`), under the mirror (`mirror`), its sha256, its
    upstream and its path there (`upstream`; empty for a file converted from `IR_PINNED`)."""

    path: str
    mirror: str
    sha256: str
    source: Upstream
    upstream: str = ""


PINNED: tuple[PinnedFile, ...] = (
    PinnedFile("v2/nanotrack_backbone_sim.onnx", "nanotrack/v2/nanotrack_backbone_sim.onnx",
               "530bdd0cd00f19afab79a863e71ba71e3312395a5dc9151af675082bdaaa2fc4", NANOTRACK,
               "NanoTrack/models/nanotrackv2/nanotrack_backbone_sim.onnx"),
    PinnedFile("v2/nanotrack_head_sim.onnx", "nanotrack/v2/nanotrack_head_sim.onnx",
               "0d8c0637be849f092cc7236cae02e55c8b9455ebe37ba50601d6115db4247cd9", NANOTRACK,
               "NanoTrack/models/nanotrackv2/nanotrack_head_sim.onnx"),
    PinnedFile("v3/nanotrack_backbone.onnx", "nanotrack/v3/nanotrack_backbone.onnx",
               "50be1320abf9384fd3479ea829f95e244cf3f3838190c5ab60c750fb8c1ce828", NANOTRACK,
               "NanoTrack/models/nanotrackv3/nanotrack_backbone.onnx"),
    PinnedFile("v3/nanotrack_head.onnx", "nanotrack/v3/nanotrack_head.onnx",
               "75357903be3f4817c965af16cb5a11fd32b1467f597a408405a98635ac63f61d", NANOTRACK,
               "NanoTrack/models/nanotrackv3/nanotrack_head.onnx"),
    PinnedFile("lighttrack/lighttrack_backbone.onnx", "lighttrack/lighttrack_backbone.onnx",
               "f0e093ce18657fc2476529345ee2dec1f247249096b20f724b17a8bede991026", LIGHTTRACK_IR),
    PinnedFile("lighttrack/lighttrack_head_16.onnx", "lighttrack/lighttrack_head_16.onnx",
               "460ff640af512366a476c7b246d4ee5327e6df974fdfc92b5c26710e2975673f", LIGHTTRACK_IR),
    PinnedFile("lighttrack/lighttrack_head_18.onnx", "lighttrack/lighttrack_head_18.onnx",
               "054536b3ec0b866007db117955fc6d55e66896c2459fd55b13511c0efa7c2c31", LIGHTTRACK_IR),
)

IR_PINNED: tuple[PinnedFile, ...] = (  # LightTrack-M's upstream OpenVINO IR, the converter's input
    PinnedFile("ir/z_feature.xml", "lighttrack/ir/z_feature.xml",
               "4e5b6d9ac3acd8b66482795562e48cedfda30581ba77b2c13dc85198c52bfbfd", LIGHTTRACK_IR,
               "models/z_feature.xml"),
    PinnedFile("ir/z_feature.bin", "lighttrack/ir/z_feature.bin",
               "51aca0febe12de49eff78e0fa6804ed3790b0cd7bf67091d58e9e19406bf5afc", LIGHTTRACK_IR,
               "models/z_feature.bin"),
    PinnedFile("ir/head.xml", "lighttrack/ir/head.xml",
               "cea013e5af21039fef6a7cac7fdc73367e3de12c3e61629dd44a66cfa1c2c8b4", LIGHTTRACK_IR,
               "models/head.xml"),
    PinnedFile("ir/head.bin", "lighttrack/ir/head.bin",
               "a0b7a07d68aa5ab741b02659b21e1090fd6b1df9c8aab8f7fa03f77dd09c7ffd", LIGHTTRACK_IR,
               "models/head.bin"),
)


DETECTOR_PINNED: tuple[PinnedFile, ...] = (  # optional: installed when obtainable (module docstring)
    PinnedFile("detector/yolox_nano.onnx", "detector/yolox_nano.onnx",
               "695e750a5d5754bb5a8d5325643b59282191a7e7a564e435a415fd3c578eab14", YOLOX_NANO,
               "model/yolox_nano.onnx"),
    PinnedFile("detector/LICENSE", "detector/LICENSE",
               "c71d239df91726fc519c6eb72d318ec65820627232b2f796219e87dcf35d0ab4", YOLOX_NANO, "LICENSE"),
)


class FetchError(Exception):
    """A model file could not be copied, downloaded or converted, or its content is not the pinned one."""


def pinned(path: str) -> PinnedFile:
    """The pin of `path` (e.g. "v2/nanotrack_head_sim.onnx"); KeyError if it is not pinned."""
    for f in (*PINNED, *DETECTOR_PINNED):
        if f.path == path:
            return f
    raise KeyError(path)


def sha256_of(path: Path) -> str:
    """Hex sha256 of a file's bytes."""
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def url_of(f: PinnedFile) -> str:
    """The raw URL of a pinned upstream file at the pinned commit."""
    return f.source.raw(f.upstream)


def download(url: str, out: Path, timeout: float = 60.0) -> None:
    """Write the bytes at `url` to `out` (the default fetcher)."""
    with urllib.request.urlopen(url, timeout=timeout) as resp, out.open("wb") as fh:
        shutil.copyfileobj(resp, fh)


def _checked(f: PinnedFile, tmp: Path, origin: str) -> None:
    got = sha256_of(tmp)
    if got != f.sha256:
        raise FetchError(f"{f.path} from {origin} has sha256 {got}, pinned {f.sha256}")


def _put(f: PinnedFile, target: Path, produce: Callable[[Path], str]) -> str:
    """Write `target` atomically from `produce(tmp) -> origin`, verified against the pin."""
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(dir=target.parent, suffix=".part")
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        origin = produce(tmp)
        _checked(f, tmp, origin)
        os.chmod(tmp, 0o644)  # mkstemp makes it private; a model file is read by everyone
        os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)
    return origin


def _downloaded(f: PinnedFile, fetch: Callable[[str, Path], None]) -> Callable[[Path], str]:
    def produce(tmp: Path) -> str:
        origin = url_of(f)
        try:
            fetch(origin, tmp)
        except OSError as exc:
            raise FetchError(f"{f.path}: download from {origin} failed: {exc}; {how_to_get(f)}") from None
        return origin
    return produce


def how_to_get(f: PinnedFile) -> str:
    """What to do when `f` cannot be put in place (the one fix sentence of an error)."""
    return (f"put ../shared (its models/{f.mirror.split('/')[0]}) beside the repository and run `make "
            f"models`, or download it from {f.source.page}, or set SWIR_TRACKER_MODELS to a directory "
            f"holding {f.path} ({'docs/acquisition.md' if f in DETECTOR_PINNED else 'docs/siamese.md'})")


def git_dir(root: Path, repo: str) -> Path | None:
    """The git directory of `repo` ("owner/name") under a folder of local mirrors: `owner+name` or
    `owner/name`, itself a git directory or holding `repo/` or `.git` (the layouts `fetch` and
    ../shared/mot_corpus/build.py use); None when there is none."""
    owner, name = repo.split("/", 1)
    for base in (root / f"{owner}+{name}", root / owner / name):
        for cand in (base / "repo" / ".git", base / "repo", base / ".git", base):
            if (cand / "HEAD").is_file() and (cand / "objects").is_dir():
                return cand
    return None


def _from_git(f: PinnedFile, gdir: Path) -> Callable[[Path], str]:
    """Write `f`'s upstream file at the pinned commit out of a local git mirror (`git cat-file`)."""
    def produce(tmp: Path) -> str:
        spec = f"{f.source.commit}:{f.upstream}"
        try:
            with tmp.open("wb") as out:
                run = subprocess.run(["git", f"--git-dir={gdir}", "cat-file", "blob", spec], stdout=out,
                                     stderr=subprocess.PIPE, text=False, check=False)
        except OSError as exc:
            raise FetchError(f"{f.path}: cannot run git ({exc})") from None
        if run.returncode != 0:
            raise FetchError(f"{f.path}: {gdir} has no {spec} "
                             f"({run.stderr.decode(errors='replace').strip() or 'git failed'})")
        return f"{gdir} at {f.source.commit[:12]}"
    return produce


def fetch_optional(dest: Path, mirror: Path | None = None, git_mirrors: Path | None = None,
                   fetch: Callable[[str, Path], None] | None = download,
                   files: tuple[PinnedFile, ...] = DETECTOR_PINNED) -> dict[str, str]:
    """The optional pinned files (the person detector) under `dest`, verified: already there, else copied
    from `mirror`, else taken from a local git mirror of the upstream under `git_mirrors`, else downloaded
    with `fetch`. Never raises: {path: origin} for each file put in place, {path: "missing: <why and how to
    get it>"} for each that could not be."""
    dest = Path(dest)
    done: dict[str, str] = {}
    for f in files:
        target = dest / f.path
        if target.is_file() and sha256_of(target) == f.sha256:
            done[f.path] = "present"
            continue
        tries: list[Callable[[Path], str]] = []
        src = mirror / f.mirror if mirror is not None else None
        if src is not None and src.is_file():
            tries.append(lambda tmp, src=src: (shutil.copyfile(src, tmp), str(src))[1])
        gdir = git_dir(git_mirrors, f.source.repo) if git_mirrors is not None else None
        if gdir is not None:
            tries.append(_from_git(f, gdir))
        if fetch is not None:
            tries.append(_downloaded(f, fetch))
        why = ["no mirror copy, no local git mirror and downloading is off"] if not tries else []
        for produce in tries:
            try:
                done[f.path] = _put(f, target, produce)
                break
            except (FetchError, OSError) as exc:
                why.append(str(exc))
        else:
            why_text, fix = "; ".join(why), how_to_get(f)
            done[f.path] = f"missing: {why_text}" + ("" if fix in why_text else f"; {fix}")
    return done


@dataclass
class Converter:
    """The mirror's IR -> ONNX converter of LightTrack-M and the interpreter to run it (needs onnx, numpy)."""

    script: Path | None
    python: str = sys.executable

    def run(self, ir: Path, out: Path) -> None:
        if self.script is None or not self.script.is_file():
            raise FetchError(f"no IR-to-ONNX converter ({self.script or CONVERTER}) to make the LightTrack-M "
                             f"ONNX files from the upstream IR {LIGHTTRACK_IR.page}")
        try:
            run = subprocess.run([self.python, str(self.script), "--ir", str(ir), "--out", str(out)],
                                 capture_output=True, text=True, check=False)
        except OSError as exc:
            raise FetchError(f"cannot run {self.python} for {self.script} ({exc}); `make venv` first"
                             ) from None
        if run.returncode != 0:
            last = (run.stderr.strip().splitlines() or ["no output"])[-1]
            raise FetchError(f"{self.script} failed with {self.python} ({last}); it needs the onnx and numpy "
                             f"packages (`make venv` installs them; pass --python)")


def _convert_lighttrack(dest: Path, files: list[PinnedFile], fetch: Callable[[str, Path], None] | None,
                        converter: Converter) -> dict[str, str]:
    """Download and check the pinned IR, convert it, check and place the ONNX files."""
    if fetch is None:
        raise FetchError(f"{files[0].path}: no mirror copy and downloading is off; {how_to_get(files[0])}")
    if converter.script is None or not converter.script.is_file():
        raise FetchError(f"{files[0].path}: no mirror copy, and no IR-to-ONNX converter ({CONVERTER} of the "
                         f"shared models) to make it from the upstream IR at {LIGHTTRACK_IR.page}; "
                         f"{how_to_get(files[0])}")
    with tempfile.TemporaryDirectory() as work:
        ir, out = Path(work, "ir"), Path(work, "out")
        ir.mkdir()
        out.mkdir()
        for f in IR_PINNED:
            _put(f, ir / Path(f.path).name, _downloaded(f, fetch))
        try:
            converter.run(ir, out)
        except FetchError as exc:
            raise FetchError(f"{files[0].path}: {exc}; {how_to_get(files[0])}") from None
        done = {}
        for f in files:
            made = out / Path(f.path).name

            def produce(tmp: Path, made: Path = made) -> str:
                shutil.copyfile(made, tmp)
                return f"converted from {LIGHTTRACK_IR.page}"
            done[f.path] = _put(f, dest / f.path, produce)
    return done


def fetch_models(dest: Path, mirror: Path | None = None,
                 fetch: Callable[[str, Path], None] | None = download,
                 converter: Converter | None = None) -> dict[str, str]:
    """Every pinned file under `dest`, verified: already there, else copied from `mirror` (the shared
    models folder) when it has the file, else downloaded with `fetch(url, out)` (None: no download) or, for
    LightTrack-M, converted from its downloaded IR by `converter` (default: the mirror's). Returns
    {path: origin}; FetchError on the first file that cannot be put in place with the pinned content."""
    dest = Path(dest)
    if converter is None:
        converter = Converter(mirror / CONVERTER if mirror is not None else None)
    done: dict[str, str] = {}
    to_convert: list[PinnedFile] = []
    for f in PINNED:
        target = dest / f.path
        if target.is_file() and sha256_of(target) == f.sha256:
            done[f.path] = "present"
            continue
        src = mirror / f.mirror if mirror is not None else None
        if src is not None and src.is_file():
            done[f.path] = _put(f, target, lambda tmp, src=src: (shutil.copyfile(src, tmp), str(src))[1])
        elif f.upstream:
            if fetch is None:
                where = f"{mirror} has no {f.mirror} and " if mirror is not None else ""
                raise FetchError(f"{f.path}: {where}downloading is off; {how_to_get(f)}")
            done[f.path] = _put(f, target, _downloaded(f, fetch))
        else:
            to_convert.append(f)
    if to_convert:
        done.update(_convert_lighttrack(dest, to_convert, fetch, converter))
    return {f.path: done[f.path] for f in PINNED}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dest", required=True, help="model directory to fill (…/share/swir_tracker_ros/models)")
    ap.add_argument("--mirror", default=None, help="local copy (../shared/models) to take the files from")
    ap.add_argument("--no-download", action="store_true", help="never download (mirror or nothing)")
    ap.add_argument("--python", default=sys.executable, help="interpreter for the IR converter (onnx, numpy)")
    ap.add_argument("--converter", default=None, help=f"IR-to-ONNX converter (default: <mirror>/{CONVERTER})")
    ap.add_argument("--git-mirrors", default=os.environ.get(GIT_MIRRORS_VAR),
                    help=f"folder of local git mirrors (owner+name/) to take the optional detector from "
                         f"(default ${GIT_MIRRORS_VAR})")
    ap.add_argument("--optional", action="store_true",
                    help="say what is missing and how to get it, but exit 0 (`make venv`: the correlation "
                         "filters need no model)")
    a = ap.parse_args(argv)
    mirror = Path(a.mirror) if a.mirror and Path(a.mirror).is_dir() else None
    script = Path(a.converter) if a.converter else (mirror / CONVERTER if mirror is not None else None)
    fetch = None if a.no_download else download
    try:
        done = fetch_models(Path(a.dest), mirror, fetch, Converter(script, a.python))
    except FetchError as exc:
        if a.optional:
            print(f"models: not installed: {exc}. The configurations that need a network (siamese, fused, "
                  f"...) will refuse to start; the correlation-filter ones work.", file=sys.stderr)
            return 0
        print(f"models: error: {exc}", file=sys.stderr)
        return 1
    for path, origin in done.items():
        print(f"models: {path}: {origin} (sha256 ok)")
    git_mirrors = Path(a.git_mirrors) if a.git_mirrors else None
    for path, origin in fetch_optional(Path(a.dest), mirror, git_mirrors, fetch).items():
        if origin.startswith("missing: "):
            print(f"models: {path}: not installed ({origin[9:]}). The acquisition's learned detector "
                  f"(detector: yolox) will refuse to start; the motion and HOG detectors work.",
                  file=sys.stderr)
        else:
            print(f"models: {path}: {origin} (sha256 ok)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
