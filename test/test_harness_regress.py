# SPDX-License-Identifier: Apache-2.0
"""The regression gate: the CI subset passes its stored thresholds, and a degraded tracker fails them."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
import yaml

from swir_tracker_ros.configs import CONFIGURATIONS
from swir_tracker_ros.harness import cli
from swir_tracker_ros.harness import evaluate as ev
from swir_tracker_ros.harness.evaluate import EvalResult
from swir_tracker_ros.harness.metrics import score
from swir_tracker_ros.harness.regress import REGRESSION_DIR, check, config_path, load_config
from swir_tracker_ros.types import Box

GT = Box(10, 10, 20, 40)


def result_with(p20_shift: float) -> EvalResult:
    good = score([GT] * 10, [GT] * 10, 1.0)
    moved = score([GT.shifted(p20_shift, 0)] * 10, [GT] * 10, 1.0)
    return EvalResult({"seq": {"robust_adaptive": good, "cf": moved}})


def test_check_passes_and_fails_by_direction():
    thr = {"seq": {"cf": {"precision_20": 0.9, "center_error": 10.0, "lost_frames": 0}}}
    assert check(result_with(5.0), thr) == []
    bad = check(result_with(25.0), thr)  # forced down: centre 25 px off
    assert {(v.metric, v.threshold, v.value) for v in bad} == {
        ("precision_20", 0.9, 0.0), ("center_error", 10.0, 25.0), ("lost_frames", 0.0, 10.0)}
    assert bad[0].delta < 0
    assert check(result_with(0.0), {"mean": {"robust_adaptive": {"success_auc": 0.9}}}) == []


def test_missing_sequence_or_variant_fails():
    v = check(result_with(0.0), {"other": {"cf": {"precision_20": 0.1}}, "seq": {"kalman": {"fps": 1}}})
    assert len(v) == 2 and all(math.isnan(x.value) for x in v)


def test_stored_configs_are_well_formed():
    names = {p.stem for p in REGRESSION_DIR.glob("*.yaml")}
    assert {"ci", "full"} <= names
    for n in names:
        cfg = load_config(config_path(n))
        for seq, per in cfg["thresholds"].items():
            for variant, metrics in per.items():
                assert variant in CONFIGURATIONS and metrics, (n, seq, variant)


def test_ci_subset_passes(capsys):
    """`make test` runs the CI regression subset through the real tracker core (about 500 tracked frames)."""
    rc = cli.main(["regress", "--set", "ci", "--quiet"])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "all scores at or above the thresholds" in out


class _Drifting:
    """A tracker forced down: the real core's boxes pushed 30 px to the right after frame 5."""

    def __init__(self, inner) -> None:
        self.inner, self.n = inner, 0

    def init(self, frame, box, bit_depth=None):
        self.inner.init(frame, box, bit_depth=bit_depth)

    def update(self, frame, bit_depth=None):
        self.n += 1
        res = self.inner.update(frame, bit_depth=bit_depth)
        return replace(res, box=res.box.shifted(30.0, 0.0)) if self.n > 5 else res


def test_forced_down_score_fails_the_gate(tmp_path, monkeypatch, capsys):
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(yaml.safe_dump({
        "variants": ["cf"], "sources": [{"synth": "control_no_occlusion", "frames": 30}],
        "thresholds": {"control_no_occlusion": {"cf": {"precision_20": 0.9, "success_auc": 0.6}}}}))
    assert cli.main(["regress", "--config", str(cfg), "--quiet"]) == 0
    capsys.readouterr()
    real = ev.make_tracker_factory

    def drifting(variant, pipeline="kcf", overrides=()):
        make = real(variant, pipeline, overrides)
        return lambda: _Drifting(make())

    monkeypatch.setattr(ev, "make_tracker_factory", drifting)
    assert cli.main(["regress", "--config", str(cfg), "--quiet"]) == 1
    out = capsys.readouterr().out
    assert "REGRESSION: 2 score(s) below the thresholds" in out
    line = next(ln for ln in out.splitlines()
                if ln.startswith("control_no_occlusion") and "precision_20" in ln)
    assert "0.900" in line and "-0." in line  # threshold and the (negative) change


def test_unknown_set_is_an_error(capsys):
    assert cli.main(["regress", "--set", "nope"]) == 2
    assert "no regression set 'nope'" in capsys.readouterr().err


@pytest.mark.parametrize("bad", [{"variants": ["cf"]}, {"sources": [], "variants": [], "thresholds": {}}])
def test_config_validation(tmp_path, bad):
    p = tmp_path / "c.yaml"
    p.write_text(yaml.safe_dump(bad))
    if "sources" in bad:
        assert load_config(p)["sources"] == []
    else:
        with pytest.raises(Exception, match="lacks"):
            load_config(p)
