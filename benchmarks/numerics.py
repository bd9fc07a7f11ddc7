# SPDX-License-Identifier: Apache-2.0
"""Issue 32: the chaos-prone tests and the CI regression gate under each numeric environment, one table.

The environments (`swir_tracker_ros/harness/numerics.py`) select other floating-point kernels on this machine
(OpenBLAS core type, OpenCV's CPU dispatch, Numba's target CPU). The tests and CI never set them; this
script runs each check in a subprocess with them set:

    make test-numerics                                  # chaos-prone tests + CI gate, every environment
    .venv/bin/python benchmarks/numerics.py --suite     # the whole suite (`pytest test`) instead
    .venv/bin/python benchmarks/numerics.py --envs default openblas-sandybridge

The gate's columns: PASS/FAIL against test/regression/ci.yaml, and the smallest margin (averaged value minus
its minimum) with the threshold it belongs to. `--detail` adds the gated values per environment and their
spread (what `harness regress --calibrate` sets the thresholds from).
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
import time
from pathlib import Path

from swir_tracker_ros.harness.gate import check, load_config
from swir_tracker_ros.harness.numerics import ENVIRONMENTS, check_names, describe, run_in
from swir_tracker_ros.harness.regress import config_path, read_values

REPO = Path(__file__).resolve().parents[1]
# Tests whose outcome rests on whole tracking runs or on mechanisms set up on real frames: what moves first
# when the floating-point kernels change.
CHAOS_TESTS = ("test/test_tracker_motion.py", "test/test_tracker_redetection.py",
               "test/test_tracker_pipeline.py",
               "test/test_harness_regress.py::test_a_change_that_costs_accuracy_fails_the_gate")
COUNTS = ("passed", "failed", "error", "skipped", "xfailed", "xpassed")


def pytest_counts(output: str) -> dict[str, int]:
    """The counts of pytest's last summary line (`3 failed, 615 passed, 1 xfailed in 437.24s`)."""
    lines = [ln for ln in output.splitlines() if re.search(r"\d+ (passed|failed|error)", ln)]
    found = dict.fromkeys(COUNTS, 0)
    last = lines[-1] if lines else ""
    for n, word in re.findall(r"(\d+) (passed|failed|errors?|skipped|xfailed|xpassed)", last):
        found[word.rstrip("s") if word.startswith("error") else word] = int(n)
    return found


def run_tests(env: str, targets: list[str]) -> tuple[dict[str, int], float, str]:
    t0 = time.monotonic()
    proc = run_in(env, ["-m", "pytest", *targets, "-q", "-p", "no:cacheprovider"], cwd=str(REPO))
    failed = [ln for ln in proc.stdout.splitlines() if ln.startswith(("FAILED", "ERROR"))]
    return pytest_counts(proc.stdout), time.monotonic() - t0, "; ".join(failed)


def run_gate(env: str, set_name: str, jobs: int, tmp: Path) -> tuple[dict, float]:
    out = tmp / f"{env}.json"
    t0 = time.monotonic()
    proc = run_in(env, ["-m", "swir_tracker_ros.harness", "regress", "--set", set_name, "--measure",
                        str(out), "--jobs", str(jobs), "--quiet"], cwd=str(REPO))
    if proc.returncode != 0:
        raise SystemExit(f"numerics: the {set_name} set failed to run in {env}:\n{proc.stderr[-2000:]}")
    return read_values(out), time.monotonic() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", nargs="+", default=["all"], help=f"{', '.join(ENVIRONMENTS)} or all")
    ap.add_argument("--suite", action="store_true",
                    help="run the whole suite (pytest test) in each environment")
    ap.add_argument("--tests", nargs="*", default=None, help="pytest targets instead of the chaos-prone ones")
    ap.add_argument("--gate", default="ci", help="regression set to measure in each environment ('' to skip)")
    ap.add_argument("--jobs", type=int, default=1, help="--jobs of the gate's runs")
    ap.add_argument("--detail", action="store_true", help="also print the gated values per environment")
    a = ap.parse_args(argv)
    envs = check_names(a.envs)
    targets = ["test"] if a.suite else list(a.tests if a.tests is not None else CHAOS_TESTS)
    cfg = load_config(config_path(a.gate)) if a.gate and not a.suite else None
    rows, values = [], {}
    with tempfile.TemporaryDirectory(prefix="numerics-") as tmp:
        for env in envs:
            print(f"numerics: {env} ({describe(env)}) ...", file=sys.stderr, flush=True)
            counts, secs, failed = run_tests(env, targets)
            row = {"env": env, "counts": counts, "seconds": secs, "failed": failed}
            if cfg is not None:
                values[env], row["gate_seconds"] = run_gate(env, a.gate, a.jobs, Path(tmp))
                bad = check(values[env], cfg.thresholds)
                margins = [(values[env].get(k, float("nan")) - t.minimum, k)
                           for k, t in cfg.thresholds.items()]
                row["gate"] = "PASS" if not bad else f"FAIL ({len(bad)})"
                row["margin"] = min(margins)
            rows.append(row)
    print_table(rows, targets, a.gate if cfg is not None else None)
    if a.detail and cfg is not None:
        print_detail(values, cfg.thresholds)
    return 0 if all(r["counts"]["failed"] == r["counts"]["error"] == 0 and r.get("gate", "PASS") == "PASS"
                    for r in rows) else 1


def print_table(rows: list[dict], targets: list[str], gate: str | None) -> None:
    what = "whole suite" if targets == ["test"] else "chaos-prone tests"
    head = f"{'environment':<22}{'variables':<34}{what + ' (passed/failed/skipped/xfailed)':<46}{'wall':>7}"
    if gate:
        head += f"  {'gate ' + gate:<10}{'smallest margin':<48}"
    print(head)
    print("-" * len(head))
    for r in rows:
        c = r["counts"]
        counts = f"{c['passed']} / {c['failed'] + c['error']} / {c['skipped']} / {c['xfailed']}"
        line = f"{r['env']:<22}{describe(r['env'])[:32]:<34}{counts:<46}{r['seconds']:>6.0f}s"
        if gate:
            m, key = r["margin"]
            line += f"  {r['gate']:<10}{m:+.3f} {'/'.join(key)}"
        print(line)
        if r["failed"]:
            print(f"{'':<22}failed: {r['failed']}")


def print_detail(values: dict[str, dict], thresholds: dict) -> None:
    envs = list(values)
    print(f"\n{'threshold':<56}" + "".join(f"{e[:14]:>15}" for e in envs) + f"{'spread':>9}{'min':>8}")
    for key in sorted(thresholds):
        vals = [values[e].get(key, float("nan")) for e in envs]
        print(f"{' / '.join(key):<56}" + "".join(f"{v:>15.4f}" for v in vals)
              + f"{max(vals) - min(vals):>9.4f}{thresholds[key].minimum:>8.3f}")


if __name__ == "__main__":
    sys.exit(main())
