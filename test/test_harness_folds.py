# SPDX-License-Identifier: Apache-2.0
"""The two folds (sorted folder names, alternating) and the both-folds verdict between two configurations."""

from __future__ import annotations

import pytest

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.folds import (
    FoldChange,
    decide,
    fold_changes,
    fold_of_names,
    folds,
    format_verdict,
)
from swir_tracker_ros.harness.metrics import SRE_PERTURBATIONS
from swir_tracker_ros.harness.protocol import Results, RunStats, standard_error


def test_the_fold_rule_alternates_over_the_sorted_folder_names(sequences_dir):
    fold = folds(sequences_dir)
    names = sorted(fold)
    assert len(names) == 24
    assert [fold[n] for n in names] == ["fold 1", "fold 2"] * 12
    assert fold["antiuav_irclip04"] == "fold 1" and fold["antiuav_irclip07"] == "fold 2"
    assert fold["vottir2015_horse"] == "fold 2"
    assert fold_of_names(["c", "a", "b"]) == {"a": "fold 1", "b": "fold 2", "c": "fold 1"}
    assert folds(sequences_dir / "no_such_dir") == {}


def _stats(auc: float) -> RunStats:
    return RunStats(auc, 1.0, 0, 0, 10, 0.0)


def _results(deltas: dict[str, list[float]]) -> Results:
    """base: AUC 0.5 on every start; cand: 0.5 + the sequence's delta of that start (cycled)."""
    res = Results()
    for k, (seq, ds) in enumerate(deltas.items()):
        res.groups[seq] = "fold 1" if k % 2 == 0 else "fold 2"
        for i, p in enumerate(SRE_PERTURBATIONS):
            res.add(seq, "base", p, _stats(0.5))
            res.add(seq, "cand", p, _stats(0.5 + ds[i % len(ds)]))
    return res


def test_fold_changes_and_their_noise():
    res = _results({"a": [0.02, 0.04], "b": [-0.01, 0.01], "c": [0.0, 0.06], "d": [-0.03]})
    f1, f2 = fold_changes(res, "base", "cand")
    assert (f1.fold, f1.sequences, f2.sequences) == ("fold 1", 2, 2)
    assert f1.delta == pytest.approx((0.03 + 0.03) / 2) and f2.delta == pytest.approx(-0.015)
    # paired noise: the starts' spread of the change in each sequence
    assert f1.noise == pytest.approx(standard_error([[0.02, 0.04] * 6, [0.0, 0.06] * 6]))
    assert f1.a_noise == 0.0 and f2.noise > 0.0
    text = format_verdict("base", "cand", [f1, f2])
    assert "fold 1" in text and "+0.0300" in text and "-0.0150" in text
    assert "verdict: REJECT cand over base: improves on fold 1 but costs fold 2 0.0150, more than its " \
           "noise" in text


def test_the_rule_keeps_a_change_only_when_both_folds_agree_within_noise():
    up = FoldChange("fold 1", 12, 0.50, 0.53, 0.01, 0.01, 0.01)
    assert decide([up, FoldChange("fold 2", 12, 0.40, 0.41, 0.01, 0.01, 0.01)])[0]
    keep, why = decide([up, FoldChange("fold 2", 12, 0.40, 0.395, 0.01, 0.01, 0.01)])
    assert keep and "less than its noise" in why
    keep, why = decide([up, FoldChange("fold 2", 12, 0.40, 0.38, 0.01, 0.01, 0.01)])
    assert not keep and "more than its noise" in why
    assert not decide([FoldChange("fold 1", 12, 0.5, 0.4, 0.0, 0.0, 0.01), up.__class__(
        "fold 2", 12, 0.5, 0.5, 0.0, 0.0, 0.01)])[0]


def test_the_verdict_needs_every_sre_start():
    res = _results({"a": [0.01], "b": [0.01]})
    del res.stats["b"]["cand"]["left"]
    with pytest.raises(HarnessError, match=r"cand has no stored SRE run on b from left"):
        fold_changes(res, "base", "cand")
