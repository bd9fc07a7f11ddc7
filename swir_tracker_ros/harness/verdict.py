# SPDX-License-Identifier: Apache-2.0
"""The verdict between two stored trackers: paired over videos, on OPE.

Per sequence the OPE score (success AUC, or precision at 20 px) of the base and of the candidate; per video
the means over its sequences (the windows of one video, `devset`), then the candidate minus the base. Over
the videos: the mean difference, its standard error sd / sqrt(n) (sample sd, n videos), wins and losses.
The rule: keep the candidate only when the mean gain is more than twice its standard error. Videos, not
sequences, are the unit: windows of one video are not independent draws.

A second view, when SRE runs of both are stored: on the sequences that have all 12 SRE starts of both (the
shared 24), the SRE mean AUC and spread (max - min over the starts) of each, and the same paired statistic
on the SRE means. It informs; the call is made on OPE over the videos.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.metrics import SRE_PERTURBATIONS
from swir_tracker_ros.harness.protocol import Results

KEEP_SE = 2.0  # keep a candidate only when its mean gain over the videos exceeds this many standard errors
METRICS = ("success_auc", "precision_20")


@dataclass(frozen=True)
class Pair:
    """One unit (a sequence or a video) scored for the base and the candidate."""

    name: str
    base: float
    candidate: float
    sequences: tuple[str, ...] = ()  # a video's sequences

    @property
    def diff(self) -> float:
        return self.candidate - self.base


@dataclass(frozen=True)
class Paired:
    """The paired statistic over units (`pairs`): mean difference, standard error, wins, losses."""

    pairs: tuple[Pair, ...]

    @property
    def n(self) -> int:
        return len(self.pairs)

    @property
    def mean_diff(self) -> float:
        return sum(p.diff for p in self.pairs) / self.n

    @property
    def se(self) -> float:
        """Sample standard deviation of the differences over sqrt(n)."""
        m = self.mean_diff
        return math.sqrt(sum((p.diff - m) ** 2 for p in self.pairs) / (self.n - 1) / self.n)

    @property
    def wins(self) -> int:
        return sum(p.diff > 0 for p in self.pairs)

    @property
    def losses(self) -> int:
        return sum(p.diff < 0 for p in self.pairs)

    @property
    def keep(self) -> bool:
        return self.mean_diff > KEEP_SE * self.se

    def mean(self, side: str) -> float:
        return sum(getattr(p, side) for p in self.pairs) / self.n


def by_video(rows: Sequence[Pair], videos: dict[str, str]) -> Paired:
    """Per-sequence pairs averaged per video (`videos`: sequence -> video; a sequence missing from it is
    a video of its own), in the order the videos are first seen; HarnessError below two videos."""
    groups: dict[str, list[Pair]] = {}
    for r in rows:
        groups.setdefault(videos.get(r.name, r.name), []).append(r)
    pairs = tuple(Pair(v, sum(r.base for r in rs) / len(rs), sum(r.candidate for r in rs) / len(rs),
                       tuple(r.name for r in rs)) for v, rs in groups.items())
    if len(pairs) < 2:
        raise HarnessError(f"a paired verdict needs at least 2 videos scored for both, got {len(pairs)}")
    return Paired(pairs)


@dataclass
class Verdict:
    """The paired verdict of `candidate` against `base` (module docstring)."""

    base: str
    candidate: str
    metric: str
    sequences: list[Pair]  # per sequence (OPE)
    videos: Paired  # per video (OPE): the call
    missing: list[str] = field(default_factory=list)  # sequences of the set not scored for both
    sre: Paired | None = None  # per video, SRE means on the sequences with every start of both
    sre_spread: tuple[float, float] | None = None  # mean SRE spread of base, candidate on those

    def to_json(self) -> dict:
        v = self.videos
        out = {"base": self.base, "candidate": self.candidate, "metric": self.metric, "protocol": "ope",
               "videos": v.n, "sequences": len(self.sequences), "mean_base": v.mean("base"),
               "mean_candidate": v.mean("candidate"), "mean_diff": v.mean_diff, "se": v.se, "wins": v.wins,
               "losses": v.losses, "keep": v.keep, "rule": f"keep only when mean_diff > {KEEP_SE:g} se",
               "per_video": [{"video": p.name, "sequences": list(p.sequences), "base": p.base,
                              "candidate": p.candidate, "diff": p.diff} for p in v.pairs],
               "per_sequence": [{"sequence": p.name, "base": p.base, "candidate": p.candidate, "diff": p.diff}
                                for p in self.sequences],
               "missing": self.missing, "sre": None}
        if self.sre is not None and self.sre_spread is not None:
            out["sre"] = {"videos": self.sre.n, "sequences": sum(len(p.sequences) for p in self.sre.pairs),
                          "mean_base": self.sre.mean("base"), "mean_candidate": self.sre.mean("candidate"),
                          "mean_diff": self.sre.mean_diff, "se": self.sre.se,
                          "spread_base": self.sre_spread[0],
                          "spread_candidate": self.sre_spread[1]}
        return out


def paired_verdict(results: Results, base: str, candidate: str, metric: str = "success_auc",
                   sequences: Sequence[str] | None = None) -> Verdict:
    """The verdict on `sequences` (default: every sequence of `results`); the videos are `results.videos`."""
    if metric not in METRICS:
        raise HarnessError(f"verdict metric {metric!r}; choose from {', '.join(METRICS)}")
    rows, missing = [], []
    for seq in sequences if sequences is not None else list(results.stats):
        a, b = results.ope(seq, base), results.ope(seq, candidate)
        if a is None or b is None:
            missing.append(seq)
        else:
            rows.append(Pair(seq, getattr(a, metric), getattr(b, metric)))
    verdict = Verdict(base, candidate, metric, rows, by_video(rows, results.videos), missing)
    sre_rows, spreads = [], []
    for p in rows:
        a, b = results.sre(p.name, base), results.sre(p.name, candidate)
        if a and b and a["runs"] == b["runs"] == len(SRE_PERTURBATIONS):
            sre_rows.append(Pair(p.name, a["mean"], b["mean"]))
            spreads.append((a["spread"], b["spread"]))
    if len({results.videos.get(r.name, r.name) for r in sre_rows}) >= 2:
        verdict.sre = by_video(sre_rows, results.videos)
        n = len(spreads)
        verdict.sre_spread = (sum(a for a, _ in spreads) / n, sum(b for _, b in spreads) / n)
    return verdict


def _line(name: str, base: float, cand: float, width: int, extra: str = "") -> str:
    return f"{name:<{width}}{base:>10.3f}{cand:>11.3f}{cand - base:>+9.3f}  {extra}"


def format_verdict(v: Verdict) -> str:
    """The per-sequence table, the per-video differences, the statistic and the call."""
    metric = "AUC" if v.metric == "success_auc" else "P@20"
    w = max(28, *(len(p.name) + 2 for p in v.sequences), *(len(p.name) + 2 for p in v.videos.pairs))
    head = f"{'OPE ' + metric + ' per sequence':<{w}}{'base':>10}{'candidate':>11}{'diff':>9}  video"
    out = [f"base {v.base}, candidate {v.candidate}", "", head, "-" * len(head)]
    videos = {s: p.name for p in v.videos.pairs for s in p.sequences}
    out += [_line(p.name, p.base, p.candidate, w, videos[p.name]) for p in v.sequences]
    head = f"{'OPE ' + metric + ' per video':<{w}}{'base':>10}{'candidate':>11}{'diff':>9}  windows"
    out += ["", head, "-" * len(head)]
    out += [_line(p.name, p.base, p.candidate, w, str(len(p.sequences))) for p in v.videos.pairs]
    s = v.videos
    out += ["-" * len(head), _line(f"mean over {s.n} videos", s.mean("base"), s.mean("candidate"), w), ""]
    if v.missing:
        out.append(f"not scored for both (left out): {len(v.missing)} sequence(s), e.g. {v.missing[0]}")
    out.append(f"paired over {s.n} videos ({len(v.sequences)} sequences): mean diff {s.mean_diff:+.4f}, "
               f"SE {s.se:.4f} ({s.mean_diff / s.se if s.se else math.inf:+.1f} SE), wins {s.wins}, "
               f"losses {s.losses}, ties {s.n - s.wins - s.losses}")
    if v.sre is not None and v.sre_spread is not None:
        r = v.sre
        (sa, sb) = v.sre_spread
        out.append(f"SRE view ({sum(len(p.sequences) for p in r.pairs)} sequences with every start, "
                   f"{r.n} videos): SRE AUC {r.mean('base'):.3f} -> {r.mean('candidate'):.3f}, mean diff "
                   f"{r.mean_diff:+.4f} SE {r.se:.4f}; SRE spread {sa:.3f} -> {sb:.3f}")
    call = "KEEP" if s.keep else "REJECT"
    why = "more" if s.keep else "not more"
    out.append(f"verdict: {call} {v.candidate} over {v.base}: the mean gain {s.mean_diff:+.4f} is {why} than "
               f"{KEEP_SE:g} SE ({KEEP_SE * s.se:.4f}) (rule: keep only when mean gain > {KEEP_SE:g} SE over "
               "the videos, OPE)")
    return "\n".join(out)
