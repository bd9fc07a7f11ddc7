# SPDX-License-Identifier: Apache-2.0
"""Faster networks (issue 53 item 1): the int8 heads made by harness/quantise.py are the pinned files
(core/siamese/int8.py), their maps stay close to the float heads' on real crops, a bad precision is refused
with its reason, int8 without its files is refused naming the fix, and LightTrack-M's input normalisation
done in numpy gives the file's own features bit for bit."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from swir_tracker_ros.core.siamese.int8 import rounded_range
from swir_tracker_ros.core.siamese.locator import locate, pinned
from swir_tracker_ros.core.siamese.network import bgr_batch, network, session
from swir_tracker_ros.core.siamese.params import VERSIONS, SiameseParams
from swir_tracker_ros.core.siamese.tracker import SiameseTracker
from swir_tracker_ros.core.siamese.weights import sha256_of
from swir_tracker_ros.errors import ModelError, ParameterError
from swir_tracker_ros.harness.quantise import make, tracker_crops

# Measured on these crops (otb_walking2 frames 10 and 30, not a calibration sequence; antiuav_irclip04 frame
# 60): largest score difference 0.058 (LightTrack-M), 0.077 (v3), 0.047 (v2), smallest per crop 0.008;
# largest side-distance difference 3.1 / 3.6 / 2.8 search-crop pixels (benchmarks/network_speed.py prints
# the same measures over 12 crops of otb_walking2). The bounds leave room for another CPU's float features.
SCORE_TOLERANCE = 0.15
SIDE_TOLERANCE = 8.0  # search-crop pixels (the side distances reach ~120 px)


@pytest.fixture(scope="module")
def int8_dir(tmp_path_factory: pytest.TempPathFactory, sequences_dir: Path) -> Path:
    """A model directory with the verified float files (links) and the int8 heads made from them here."""
    from conftest import _weights

    _weights(("v2", "v3", "lighttrack"), "NanoTrack / LightTrack-M")
    root = tmp_path_factory.mktemp("models")
    for c in VERSIONS.values():
        for rel in c.files:
            (root / rel).parent.mkdir(parents=True, exist_ok=True)
            (root / rel).symlink_to(locate(rel).resolve())
    make(root, sequences=sequences_dir, check=False)
    return root


def crops(sequences_dir: Path, version: str, name: str, frames: tuple[int, ...]):
    """(exemplar crop of frame 1's box, search crops of `frames` around the previous frame's box)."""
    return tracker_crops(version, sequences_dir / name, frames)


@pytest.mark.parametrize("version", ["v2", "v3", "lighttrack"])
def test_the_made_int8_heads_are_the_pinned_files(int8_dir: Path, version: str) -> None:
    """Made from the pinned float heads and the named calibration frames, each file has the pinned sha256
    (the bytes are deterministic: `make models` checks them like a downloaded file)."""
    for rel in VERSIONS[version].files_for("int8")[1:]:
        assert sha256_of(int8_dir / rel) == pinned(rel).sha256, rel


@pytest.mark.parametrize("version", ["v2", "v3", "lighttrack"])
def test_int8_maps_are_close_to_float_on_real_crops(int8_dir: Path, version: str,
                                                    sequences_dir: Path) -> None:
    c = VERSIONS[version]
    f32, i8 = network(c, int8_dir), network(c, int8_dir, precision="int8")
    assert i8.head_path.name.endswith("_int8.onnx") and f32.head_path.name != i8.head_path.name
    cases = [("otb_walking2", (10, 30)), ("antiuav_irclip04", (60,))]
    for name, frames in cases:
        z, xs = crops(sequences_dir, version, name, frames)
        f32.set_exemplar(z)
        i8.set_exemplar(z)
        for x in xs:
            (s32, d32), (s8, d8) = f32.search(x), i8.search(x)
            assert s8.shape == s32.shape and d8.shape == d32.shape
            assert 0.0 < float(np.abs(s8 - s32).max()) < SCORE_TOLERANCE  # int8: not the float head
            assert float(np.abs(d8 - d32).max()) < SIDE_TOLERANCE


def test_a_bad_precision_is_refused_with_its_reason() -> None:
    with pytest.raises(ParameterError, match="precision"):
        SiameseTracker(SiameseParams(version="v3", precision="int4"))
    with pytest.raises(ParameterError, match="precision"):
        VERSIONS["v3"].files_for("float16")


def test_int8_without_its_files_is_refused_naming_the_fix(tmp_path: Path) -> None:
    """A model directory with the float files only: float32 builds, int8 names the missing head and `make
    models` (one line, at construction)."""
    from conftest import _weights

    _weights(("v3",), "NanoTrack")
    for rel in VERSIONS["v3"].files:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).symlink_to(locate(rel).resolve())
    SiameseTracker(SiameseParams(version="v3", model_dir=str(tmp_path)))
    with pytest.raises(ModelError, match=r"v3/nanotrack_head_int8\.onnx is missing.*make models") as err:
        SiameseTracker(SiameseParams(version="v3", model_dir=str(tmp_path), precision="int8"))
    assert "\n" not in str(err.value)


def test_a_made_file_other_than_the_pin_is_refused(int8_dir: Path, tmp_path: Path) -> None:
    """The int8 head is verified like a downloaded file: changed bytes are a corrupt file."""
    for rel in VERSIONS["v2"].files_for("int8"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes((int8_dir / rel).read_bytes())
    head = tmp_path / VERSIONS["v2"].files_for("int8")[1]
    head.write_bytes(head.read_bytes() + b"\0")
    with pytest.raises(ModelError, match="corrupt"):
        network(VERSIONS["v2"], tmp_path, precision="int8")


@pytest.mark.usefixtures("lighttrack_weights")
def test_lighttrack_numpy_input_gives_the_files_features_bit_for_bit(sequences_dir: Path) -> None:
    """The backbone without its input nodes, fed by `lighttrack_input`, equals the published graph fed the
    uint8 BGR crop: gray crops and a colour one."""
    c = VERSIONS["lighttrack"]
    net = network(c)
    whole = session(net.backbone_path)
    z, xs = crops(sequences_dir, "lighttrack", "otb_walking2", (10,))
    colour = np.dstack([xs[0], np.roll(xs[0], 3, axis=0), 255 - xs[0]])  # three different channels
    for patch in (z, xs[0], colour):
        ref = whole.run(None, {"image": bgr_batch(patch)})[0]
        assert np.array_equal(net.features(patch), ref)


def test_rounded_range_widens_outward_to_the_kept_bits() -> None:
    lo, hi = rounded_range(-0.30001, 5.0001, bits=7)
    assert lo <= -0.30001 and hi >= 5.0001
    assert hi - 5.0001 < 2.0 ** (math.floor(math.log2(5.0)) - 6) and -0.30001 - lo < 2.0 ** -8
    for v in (lo, hi):  # on the 7-bit grid of its own magnitude
        step = 2.0 ** (math.floor(math.log2(abs(v))) - 6)
        assert v / step == round(v / step)
    assert rounded_range(0.0, 1.0) == (0.0, 1.0)
    assert rounded_range(-0.1234, 2.9) == rounded_range(-0.12340001, 2.9000001)  # last-digit noise: same
