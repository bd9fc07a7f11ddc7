# SPDX-License-Identifier: Apache-2.0
"""The networks' pinned weights: fetch/verify (mirror copy; mocked download, LightTrack-M's IR converted by
the shared converter) and the run-time locator's one error on a missing or corrupt file
(core/siamese/weights.py, locator.py)."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

from swir_tracker_ros.core.siamese import locator
from swir_tracker_ros.core.siamese.params import SiameseParams
from swir_tracker_ros.core.siamese.tracker import SiameseTracker
from swir_tracker_ros.core.siamese.weights import (
    CONVERTER,
    IR_PINNED,
    PINNED,
    UPSTREAM_COMMIT,
    Converter,
    FetchError,
    fetch_models,
    sha256_of,
    url_of,
)
from swir_tracker_ros.errors import ModelError, TrackerError

V2 = [f for f in PINNED if f.path.startswith("v2/")]


@pytest.fixture(scope="module")
def mirror(shared_dir: Path) -> Path:
    d = shared_dir / "models"
    if not all((d / f.mirror).is_file() for f in (*PINNED, *IR_PINNED)):
        pytest.skip(f"the model mirror {d} is not there (no model files to verify against)")
    return d


def test_pins_are_the_mirrors_hashes(mirror: Path) -> None:
    """The pinned sha256 are those of the published files (SHA256SUMS of each mirror folder)."""
    sums = {}
    for folder in ("nanotrack", "lighttrack"):
        for line in (mirror / folder / "SHA256SUMS").read_text().splitlines():
            if line:
                digest, rel = line.split()
                sums[f"{folder}/{rel}"] = digest
    assert {f.mirror: f.sha256 for f in (*PINNED, *IR_PINNED)} == sums
    assert all(sha256_of(mirror / f.mirror) == f.sha256 for f in V2)


def test_fetch_copies_from_the_mirror_then_keeps_what_is_verified(mirror: Path, tmp_path: Path) -> None:
    done = fetch_models(tmp_path, mirror, fetch=None)
    assert set(done) == {f.path for f in PINNED} and all(v.startswith(str(mirror)) for v in done.values())
    assert not (tmp_path / "ir").exists()  # the IR is the converter's input, not a run-time file
    assert fetch_models(tmp_path, mirror, fetch=None) == dict.fromkeys(done, "present")


def test_fetch_downloads_at_the_pinned_commit_when_there_is_no_mirror(mirror: Path, tmp_path: Path) -> None:
    """NanoTrack downloaded as published; LightTrack-M's upstream IR downloaded, checked and converted by the
    shared converter into the pinned ONNX bytes."""
    pytest.importorskip("onnx")
    urls: list[str] = []

    def fake_download(url: str, out: Path) -> None:  # serves the published bytes for the pinned URL
        urls.append(url)
        rel = next(f.mirror for f in (*PINNED, *IR_PINNED) if f.upstream and url == url_of(f))
        shutil.copyfile(mirror / rel, out)

    done = fetch_models(tmp_path / "m", None, fake_download, Converter(mirror / CONVERTER, sys.executable))
    assert urls == [url_of(f) for f in (*PINNED, *IR_PINNED) if f.upstream]
    assert all(u.startswith("https://raw.githubusercontent.com/") for u in urls)
    assert all(UPSTREAM_COMMIT in u for u in urls[:4])
    assert all(f.source.commit in url_of(f) for f in IR_PINNED)
    assert all(sha256_of(tmp_path / "m" / f.path) == f.sha256 for f in PINNED) and len(done) == len(PINNED)
    assert done["lighttrack/lighttrack_backbone.onnx"].startswith("converted from https://github.com/l-sf/")


def test_fetch_refuses_content_that_is_not_the_pinned_one(tmp_path: Path) -> None:
    def bad_download(url: str, out: Path) -> None:
        out.write_bytes(b"<html>rate limited</html>")

    with pytest.raises(FetchError, match="sha256"):
        fetch_models(tmp_path, None, bad_download)
    assert not any(p.suffix == ".onnx" for p in tmp_path.rglob("*"))  # nothing half-written left in place
    with pytest.raises(FetchError, match="downloading is off"):
        fetch_models(tmp_path, None, None)


def test_missing_file_is_one_error_naming_it_and_the_fix(tmp_path: Path) -> None:
    with pytest.raises(ModelError) as err:
        SiameseTracker(SiameseParams(model_dir=str(tmp_path)))
    msg = str(err.value)
    assert "v2/nanotrack_backbone_sim.onnx" in msg and "make models" in msg and locator.ENV_VAR in msg
    assert isinstance(err.value, TrackerError)


def test_corrupt_file_is_the_same_error(mirror: Path, tmp_path: Path) -> None:
    for f in V2:
        (tmp_path / f.path).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(mirror / f.mirror, tmp_path / f.path)
    head = tmp_path / "v2/nanotrack_head_sim.onnx"
    head.write_bytes(head.read_bytes()[:-10])
    with pytest.raises(ModelError, match=r"nanotrack_head_sim\.onnx is corrupt.*make models"):
        SiameseTracker(SiameseParams(model_dir=str(tmp_path)))


def test_environment_variable_names_the_directory(mirror: Path, tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    nano = mirror / "nanotrack"
    monkeypatch.setenv(locator.ENV_VAR, str(nano))
    assert locator.candidate_dirs() == [nano]
    assert locator.locate("v2/nanotrack_head_sim.onnx") == nano / "v2/nanotrack_head_sim.onnx"
    monkeypatch.setenv(locator.ENV_VAR, str(tmp_path))
    with pytest.raises(ModelError, match=str(tmp_path)):
        locator.locate("v2/nanotrack_head_sim.onnx")
