# SPDX-License-Identifier: Apache-2.0
"""Reproduce the radar simulations of paper 001 §4 and dissertation §6.2.1, our numbers beside the claims.

Usage: .venv/bin/python benchmarks/reproduce_kalman_papers.py [--runs N] [--quick] [--seed S]
The papers give CEE plots only; what they say in words is printed as a claim with our verdict.
"""

from __future__ import annotations

import argparse
import sys
import time

from swir_tracker_ros.kalman.paperclaims import (
    DISSERTATION_621,
    MAIN_DELTAS,
    PAPER001_RADAR,
    SWEEP_DELTAS,
    evaluate_claims,
    format_table,
    sensitivity_variants,
)
from swir_tracker_ros.kalman.simulation import Scenario, acceleration_profile, run_scenario

PAPER_SAYS = {
    "C1": "A2-A4 CEE 'not significantly larger' than A1 at delta = 0 (001 Fig. 3, 003 Fig. 6.7)",
    "C2": "A2-A4 CEE 'significantly smaller' than A1 at delta = 0.07, 0.15 (001 Fig. 4, 003 Fig. 6.8-6.9)",
    "C3": "ranking under outliers: A2 best, A4 slightly worse, A3 worse than A2 and A4, A1 worst (001 §4)",
    "C4": "robust filters 'fairly good' for delta < 0.3 (001 §4); breakdown point 25 % (000 §V, 003 §6)",
}


def describe(sc: Scenario) -> str:
    man = ", ".join(f"{a:+g} m/s^2 on [{t0:g}, {t1:g}) s" for t0, t1, a in sc.manoeuvres) or "none"
    start = ("raw two-point start (eq. 32)" if sc.startup == "eq32"
             else f"repeated-median line over the first {sc.n_start} samples, P0 of eq. 32")
    return (f"{sc.name}: T={sc.T} s, Q={sc.Q}, R={sc.R}, N={sc.n_steps}, x0={sc.x0:g} m, v0={sc.v0:g} m/s, "
            f"manoeuvres: {man}; outliers N(0, {sc.sigma_o2:g}); start-up: {start}; "
            f"lost if position RMSE > {sc.lost_threshold:g} sigma_n")


def run_one(sc: Scenario, deltas: tuple[float, ...], runs: int, seed: int, claims: bool = True) -> None:
    t0 = time.perf_counter()
    results = run_scenario(sc, deltas, runs, seed)
    print(describe(sc))
    print(f"  (max |a| = {max(abs(acceleration_profile(sc))):g} m/s^2; {runs} runs; seed {seed}; "
          f"{time.perf_counter() - t0:.1f} s)")
    for line in format_table(results):
        print("  " + line)
    n = len(next(iter(results[0].methods.values())).cee_curve_mean)
    ks = (n // 10, n // 2, n)
    print(f"  CEE(k) mean over each filter's kept runs at k = {ks} (the papers plot CEE(k)):")
    for r in results:
        if r.delta in (0.0, 0.07, 0.15):
            cells = "  ".join(f"{m}: " + "/".join(f"{c.cee_curve_mean[k - 1]:.2e}" for k in ks)
                              for m, c in r.methods.items())
            print(f"    delta {r.delta:4.2f}  {cells}")
    if claims:
        for v in evaluate_claims(results):
            word = {True: "HOLDS", False: "FAILS"}
            verdict = f"mean {word[v.holds_mean]}, median {word[v.holds_median]}"
            print(f"  [{verdict}] {v.claim}: {v.numbers}")
    print()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=None, help="Monte Carlo runs (default 500, --quick 60)")
    ap.add_argument("--quick", action="store_true", help="main scenario and main deltas only, few runs")
    ap.add_argument("--seed", type=int, default=20230621)
    args = ap.parse_args(argv)
    runs = args.runs or (60 if args.quick else 500)
    if runs < 2:
        ap.error("--runs must be at least 2")
    print("What the papers say (figures only, no numbers):")
    for key, text in PAPER_SAYS.items():
        print(f"  {key}: {text}")
    print("CEE = (1/N) sum |x_hat_i - x_i|^2/|x_i|^2 (eq. 33/6.8), final value; mean ± sd and p10-p90")
    print("over the runs no filter lost (paired), median over all runs; 'lost' counted separately.")
    print("A3 uses alpha_f = 1 - delta (eq. 26) with the true delta.")
    print()
    if args.quick:
        run_one(PAPER001_RADAR, (*MAIN_DELTAS, 0.25), runs, args.seed)
        return 0
    for sc in (PAPER001_RADAR, DISSERTATION_621):
        run_one(sc, (*MAIN_DELTAS, *SWEEP_DELTAS), runs, args.seed)
    print("Sensitivity of the paper 001 scenario (choices the papers leave open):")
    print()
    for label, sc in sensitivity_variants(PAPER001_RADAR).items():
        print(f"--- {label}")
        # with strong manoeuvres A2/A3 lose every run: the claims have no common runs to compare
        run_one(sc, (*MAIN_DELTAS, 0.25, 0.3), runs, args.seed, claims=label != "manoeuvres x5")
    return 0


if __name__ == "__main__":
    sys.exit(main())
