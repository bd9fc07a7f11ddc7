# SPDX-License-Identifier: Apache-2.0
"""Adaptive threshold tables, adaptive R, the box models, and covariance safety over 1e5 steps."""

from __future__ import annotations

import numpy as np
import pytest

from swir_tracker_ros.errors import KalmanError, ParameterError
from swir_tracker_ros.kalman import (
    DISSERTATION_DCFCA,
    PAPER000_KCF,
    AdaptiveNoise,
    AdaptiveNoiseParams,
    Huber,
    RobustKalmanFilter,
    ThresholdMap,
    dcfca_box_model,
    kcf_box_model,
    predict,
)
from swir_tracker_ros.kalman.adaptive import m_variance, mad_scale
from swir_tracker_ros.kalman.statlin import scalar_update
from swir_tracker_ros.types import Box


def eq38(pv: float) -> float:
    """Paper 000 eq. 38 written as its branches."""
    if pv < 0.25:
        return 0.1
    if pv < 0.35:
        return 0.1 + 14 * (pv - 0.25)
    if pv < 0.7:
        return 1.5
    if pv < 0.8:
        return 1.5 + 10 * (pv - 0.7)
    return 2.5


def eq69(g: float) -> float:
    """Dissertation eq. 6.9 written as its branches."""
    if g < 0.125:
        return 0.1
    if g < 0.15:
        return 0.1 + 56 * (g - 0.125)
    if g < 0.2:
        return 1.5
    if g < 0.25:
        return 1.5 + 20 * (g - 0.2)
    return 2.5


def test_threshold_tables_equal_the_printed_branches() -> None:
    for pv in np.linspace(-0.5, 1.5, 2001):
        assert PAPER000_KCF(pv) == pytest.approx(eq38(pv), abs=1e-12)
        assert DISSERTATION_DCFCA(pv / 4) == pytest.approx(eq69(pv / 4), abs=1e-12)
    assert PAPER000_KCF(0.30) == pytest.approx(0.8) and PAPER000_KCF(0.75) == pytest.approx(2.0)
    assert DISSERTATION_DCFCA(0.1375) == pytest.approx(0.8)
    assert DISSERTATION_DCFCA(0.225) == pytest.approx(2.0)
    assert PAPER000_KCF(float("nan")) == 0.1


def test_floor_band_is_below_the_first_breakpoint() -> None:
    """The "not the target" band of eq. 38 / eq. 6.9: k at its floor of 0.1 exactly there."""
    assert PAPER000_KCF.floor_peak == 0.25 and DISSERTATION_DCFCA.floor_peak == 0.125
    for table in (PAPER000_KCF, DISSERTATION_DCFCA):
        for pv in np.linspace(0.0, 1.0, 1001):
            assert table.at_floor(pv) == (pv < table.floor_peak)
            if table.at_floor(pv):
                assert table(pv) == 0.1
        assert table.at_floor(float("nan")) and table.at_floor(float("-inf"))
        assert not table.at_floor(table.floor_peak) and table(table.floor_peak + 0.01) > 0.1
    custom = ThresholdMap(((0.0, 1.0), (1.0, 3.0)))
    assert custom(0.5) == 2.0 and custom(9.0) == 3.0
    with pytest.raises(KalmanError):
        ThresholdMap(((0.5, 1.0), (0.4, 2.0)))


def test_mad_and_m_variance_recover_gaussian_scale_under_outliers() -> None:
    rng = np.random.default_rng(5)
    r = 2.0 * rng.standard_normal(20000)
    r[::10] = 200.0 * rng.standard_normal(2000)  # 10 % gross outliers
    d = mad_scale(r)
    assert d == pytest.approx(2.0 * 1.1, rel=0.1)  # MAD is only mildly inflated by 10 % outliers
    V = m_variance(r, d, 0.0, Huber(1.5))
    # eq. 5.94 (times d^2) stays near 4; the sample variance does not
    assert 3.0 < V < 8.0 and np.var(r) > 1000


def test_adaptive_noise_warmup_then_tracks_the_true_variance() -> None:
    rng = np.random.default_rng(11)
    R0 = np.diag([1.0, 1.0])
    an = AdaptiveNoise(R0, AdaptiveNoiseParams(n_d=10, n_r=200, warmup=30), components=(0,))
    H = np.eye(2)
    P = np.zeros((2, 2))
    for _ in range(29):
        R = an.push(rng.standard_normal(2) * 3.0, np.zeros(2), P, H)
        assert np.array_equal(R, R0), "nominal R during warm-up"
    Rs = []
    for _ in range(400):
        R = an.push(np.array([3.0 * rng.standard_normal(), 5.0]), np.zeros(2), P, H)
        Rs.append(R[0, 0])
        assert R[1, 1] == 1.0  # not an adapted component
    assert np.median(Rs[200:]) == pytest.approx(9.0, rel=0.35)
    before = an.R.copy()
    an.push(np.array([np.nan, 0.0]), np.zeros(2), P, H)  # a missed measurement is not pushed
    assert an.R[0, 0] > 0 and np.isfinite(an.R).all() and before.shape == an.R.shape
    an.reset()
    assert np.array_equal(an.R, R0)
    with pytest.raises(ParameterError):
        AdaptiveNoiseParams(n_d=2).validate()
    with pytest.raises(ParameterError):
        AdaptiveNoiseParams(formula="other").validate()


def test_adaptive_noise_formulas_differ_by_twice_hph() -> None:
    """R = |V - HPH'| as printed (eq. 5.95) vs the post-fit-consistent V + HPH'."""
    P = np.diag([0.5, 0.0])
    H = np.eye(2)
    out = {}
    for formula in ("thesis", "postfit"):
        rng = np.random.default_rng(4)
        an = AdaptiveNoise(np.eye(2) * 4, AdaptiveNoiseParams(warmup=10, n_r=100, formula=formula), (0,))
        for _ in range(100):
            R = an.push(np.array([2.0 * rng.standard_normal(), 0.0]), np.zeros(2), P, H)
        out[formula] = R[0, 0]
    assert out["postfit"] > out["thesis"]
    assert out["postfit"] - out["thesis"] == pytest.approx(1.0)


def test_box_models_match_papers() -> None:
    m = kcf_box_model()
    assert m.F.shape == (7, 7) and m.H.shape == (4, 7)
    assert m.F[0, 4] == 1 and m.F[1, 5] == 1 and m.F[2, 6] == 1 and m.F[3, 3] == 1 and m.F[3].sum() == 1
    assert np.diag(m.Q).tolist() == [1, 1, 1, 1, 0.1, 0.1, 0.01] and np.diag(m.R).tolist() == [1, 1, 10, 10]
    box = Box(10.0, 20.0, 30.0, 60.0)
    x = m.state_from_box(box)
    assert x.tolist() == [25.0, 50.0, 1800.0, 0.5, 0, 0, 0]
    back = m.box_from_state(x)
    assert back.as_tuple() == pytest.approx(box.as_tuple())
    assert not m.box_from_state(np.array([0, 0, -1.0, 0.5, 0, 0, 0])).is_valid()
    d = dcfca_box_model(20.0, 60.0)  # notes/seed-003.md §1.2 worked example
    assert np.diag(d.Q).tolist() == pytest.approx([1, 9, 1, 9, 0.015625, 0.140625, 0.015625, 0.140625])
    assert np.diag(d.R).tolist() == pytest.approx([1, 9, 1, 9])
    assert d.F.shape == (8, 8) and d.H.shape == (4, 8) and d.G.shape == (8, 8) and d.F[3, 7] == 1
    assert d.box_from_state(d.state_from_box(box)).as_tuple() == pytest.approx(box.as_tuple())
    with pytest.raises(KalmanError):
        m.state_from_box(Box(0, 0, 0, 10))
    with pytest.raises(KalmanError):
        dcfca_box_model(0.0, 10.0)


def test_covariance_stays_symmetric_psd_over_1e5_steps() -> None:
    """Ill-conditioned 2-state filter (r alternating 1 and 1e-9, P0 = 1e6 I, tiny Q), a gross outlier every
    17th sample, methods A1-A4 in turn: after 1e5 predict/update steps P is exactly symmetric and PSD."""
    n = 100_000
    rng = np.random.default_rng(2024)
    pos = np.cumsum(np.cumsum(1e-3 * rng.standard_normal(n)))
    y = pos + 3e-5 * rng.standard_normal(n)
    y[::17] += 1e4 * rng.standard_normal(y[::17].size)
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    Q = np.diag([1e-12, 1e-6])
    h = np.array([1.0, 0.0])
    x, P = np.zeros(2), np.eye(2) * 1e6
    methods = ("A1", "A2", "A3", "A4")
    huber = Huber(1.5)
    worst_eig = np.inf
    for k in range(n):
        x, P = predict(x, P, F, Q)
        x, P, _ = scalar_update(x, P, float(y[k]), h, 1e-9 if k % 2 else 1.0, huber, methods[k % 4], 0.9)
        if k % 1000 == 999:
            assert np.array_equal(P, P.T)
            worst_eig = min(worst_eig, float(np.linalg.eigvalsh(P).min()))
    assert np.isfinite(x).all() and np.isfinite(P).all()
    assert worst_eig >= 0.0


def test_robust_filter_class_psd_with_adaptive_threshold_and_coasting() -> None:
    m = dcfca_box_model(20.0, 60.0)
    kf = RobustKalmanFilter(m)
    kf.initialize(m.state_from_box(Box(100, 100, 20, 60)), m.P0)
    rng = np.random.default_rng(9)
    for t in range(3000):
        kf.predict()
        if t % 50 < 10:
            kf.update(None)  # occlusion: coast
            continue
        z = np.array([110 + 0.5 * t, 130.0, 20.0, 60.0]) + rng.standard_normal(4)
        if rng.random() < 0.1:
            z[:2] += rng.standard_normal(2) * 200
        kf.update(z, threshold=DISSERTATION_DCFCA(rng.uniform(0.1, 0.3)))
    assert np.array_equal(kf.P, kf.P.T) and np.linalg.eigvalsh(kf.P).min() > 0
    assert abs(kf.x[0] - (110 + 0.5 * 2999)) < 20
