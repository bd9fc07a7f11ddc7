# SPDX-License-Identifier: Apache-2.0
"""The papers' simulation claims (paper 001 §4, dissertation §6.2.1) pinned on a fixed seed with margins.

The full Monte Carlo (500 runs, more deltas and variants) is benchmarks/reproduce_kalman_papers.py; here 120
runs of the paper 001 scenario, the same seed. Claims that fail in our runs are pinned as observed.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from swir_tracker_ros.kalman import Huber, RobustKalmanFilter
from swir_tracker_ros.kalman.paperclaims import (
    PAPER001_RADAR,
    ROBUST,
    cee_stat,
    evaluate_claims,
    sensitivity_variants,
)
from swir_tracker_ros.kalman.simulation import (
    batch_filter,
    draw_noise,
    run_scenario,
    start_state,
    trajectory,
)

SEED = 20230621
RUNS = 120


@pytest.fixture(scope="module")
def main_results():
    res = run_scenario(PAPER001_RADAR, (0.0, 0.07, 0.15, 0.25), RUNS, SEED)
    return {round(r.delta, 2): r for r in res}


def test_batch_engine_equals_the_filter_class() -> None:
    """The vectorised simulation runs exactly the maths of RobustKalmanFilter (A1-A4)."""
    sc = replace(PAPER001_RADAR, n_steps=300)
    truth = trajectory(sc)
    y = truth[None, :] + draw_noise(3, sc.n_steps, 1).noise(0.15, sc.sigma_o2)
    k0, x0, P0 = start_state(y, sc)
    T = sc.T
    for method in ("A1", "A2", "A3", "A4"):
        af = 0.85 if method == "A3" else None
        est = batch_filter(y[:, k0:], x0, P0, sc, method, Huber(1.5), af)
        for run in range(3):
            kf = RobustKalmanFilter([[1, T], [0, 1]], [[1, 0]], [[sc.Q]], [[sc.R]], G=[[0], [1]],
                                    x=x0[run], P=[[P0[0], P0[1]], [P0[1], P0[2]]], method=method,
                                    alpha_f=af, robust_components=None)
            out = []
            for yk in y[run, k0:]:
                kf.predict()
                kf.update([yk])
                out.append(kf.x[0])
            assert np.allclose(out, est[run], rtol=0, atol=1e-7)


def test_start_states() -> None:
    """Eq. 32 (notes U7): x0 = [y2, 50 (y2 - y1)], P0 = [[1, 50], [50, 5000.1]]; the protected start stays
    accurate with 4 gross outliers among its 15 samples."""
    sc = replace(PAPER001_RADAR, startup="eq32")
    y = np.array([[1000.0, 1001.0, 1002.0]])
    k0, x0, P0 = start_state(y, sc)
    assert k0 == 2 and x0.tolist() == [[1001.0, 50.0]] and P0.tolist() == pytest.approx([1.0, 50.0, 5000.1])
    sc = replace(PAPER001_RADAR, startup="repeated_median", n_start=15)
    t = np.arange(15) * sc.T
    y = (1000.0 + 50.0 * t + 0.1 * np.sin(7 * t))[None, :].copy()
    y[0, [2, 5, 13, 14]] += [300.0, -250.0, 400.0, 280.0]
    k0, x0, _ = start_state(y, sc)
    assert k0 == 15
    assert x0[0, 0] == pytest.approx(1000.0 + 50.0 * t[-1], abs=0.5)
    assert x0[0, 1] == pytest.approx(50.0, abs=5)


def test_c1_efficiency_without_outliers(main_results) -> None:
    """A2-A4 'not significantly worse' than A1 at delta = 0: within 25 % (observed 5-15 %), none lost."""
    r = main_results[0.0]
    a1 = cee_stat(r, "A1")
    for m in ROBUST:
        assert cee_stat(r, m) <= 1.25 * a1
        assert r.methods[m].lost_rate == 0.0
    assert cee_stat(r, "A2") > cee_stat(r, "A4") > a1  # the price of robustness is real, and A2 pays most


@pytest.mark.parametrize("delta", [0.07, 0.15])
def test_c2_resistance_with_outliers(main_results, delta) -> None:
    """A2-A4 'significantly better' than A1: mean CEE below half of A1's (the a-priori criterion; observed
    1-13 %, A3 has the heaviest tail), median run below a tenth (observed 1-3 %)."""
    r = main_results[delta]
    for m in ROBUST:
        assert cee_stat(r, m) < 0.5 * cee_stat(r, "A1")
        assert cee_stat(r, m, "median") < 0.1 * cee_stat(r, "A1", "median")
        assert r.methods[m].lost_rate <= 0.02


@pytest.mark.parametrize("delta", [0.07, 0.15])
def test_c3_ranking_typical_run(main_results, delta) -> None:
    """Median run: A2 best, A4 within 25 % of A2, A3 between A4 and A1 (paper 001 §4).

    At delta = 0.07 A2 and A4 are nearly tied (A2 lower by 2-4 %), at 0.15 A2 is clearly best."""
    c = {m: cee_stat(main_results[delta], m, "median") for m in ("A1", *ROBUST)}
    assert c["A2"] < (1.0 if delta < 0.1 else 0.9) * c["A4"]
    assert c["A4"] <= 1.25 * c["A2"]
    assert c["A4"] < c["A3"] < c["A1"]


def test_c4_still_working_at_25_percent(main_results) -> None:
    r = main_results[0.25]
    for m in ROBUST:
        assert cee_stat(r, m, "median") < 0.05 * cee_stat(r, "A1", "median")
    assert r.methods["A4"].lost_rate == 0.0
    assert r.methods["A2"].lost_rate <= 0.05


def test_evaluate_claims_reports_every_claim(main_results) -> None:
    verdicts = evaluate_claims(list(main_results.values()))
    names = [v.claim.split()[0] for v in verdicts]
    assert names.count("C1") == 1 and names.count("C2") == 2 and names.count("C4") == 1
    assert all(v.holds_median for v in verdicts if v.claim.startswith(("C1", "C2")))


def test_unprotected_start_loses_runs_with_an_outlier_in_the_first_two_samples() -> None:
    """Raw eq. 32: A2/A3 lose about the runs whose y1 or y2 is an outlier (1 - (1 - delta)^2 = 27.8 %
    at delta = 0.15); the linear A1 never loses a run. The protected start cuts this to a few percent."""
    sc = sensitivity_variants(PAPER001_RADAR)["raw eq.32 start"]
    (r,) = run_scenario(sc, (0.15,), RUNS, SEED)
    assert r.methods["A1"].lost_rate == 0.0
    for m in ("A2", "A3"):
        assert 0.12 <= r.methods[m].lost_rate <= 0.35
    assert r.methods["A4"].lost_rate < r.methods["A2"].lost_rate


def test_strong_manoeuvre_loses_a2_and_a3_but_not_a4() -> None:
    """Manoeuvres x5 (up to 30 m/s^2): the manoeuvre bias exceeds 1.5 s, A2's redescending correction and
    A3's clipped one cannot follow; A4 (paper 000's form) and A1 keep the track even without outliers."""
    sc = sensitivity_variants(PAPER001_RADAR)["manoeuvres x5"]
    (r,) = run_scenario(sc, (0.0,), 40, SEED)
    assert r.methods["A2"].lost_rate == 1.0 and r.methods["A3"].lost_rate >= 0.9
    assert r.methods["A4"].lost_rate == 0.0 and r.methods["A1"].lost_rate == 0.0
