# SPDX-License-Identifier: Apache-2.0
"""Standard and M-robust Kalman filters: equations, equality inside the threshold, missed measurements."""

from __future__ import annotations

import numpy as np
import pytest

from swir_tracker_ros.errors import KalmanError
from swir_tracker_ros.kalman import (
    Huber,
    KalmanFilter,
    RobustKalmanFilter,
    Tukey,
    dcfca_box_model,
    kcf_box_model,
    predict,
    robust_update,
    update,
)
from swir_tracker_ros.kalman.statlin import alpha_fixed, scalar_update
from swir_tracker_ros.types import Box

T = 0.02
F2 = np.array([[1.0, T], [0.0, 1.0]])
G2 = np.array([[0.0], [1.0]])
H2 = np.array([[1.0, 0.0]])


def radar_filter(cls=KalmanFilter, **kw):
    return cls(F2, H2, np.array([[0.1]]), np.array([[1.0]]), G=G2, x=[0.0, 0.0], P=np.eye(2) * 10, **kw)


def test_steady_state_gain_matches_note_u6() -> None:
    """notes/seed-001.md U6: K = [0.1064, 0.2989] and h M h' = 0.1191 for the radar model."""
    kf = radar_filter()
    for _ in range(3000):
        kf.predict()
        M = kf.P.copy()
        kf.update([0.0])
    K = kf.P @ H2.T / 1.0  # P h'/r = K at the optimum
    assert K.ravel() == pytest.approx([0.1064, 0.2989], abs=5e-4)
    assert M[0, 0] == pytest.approx(0.1191, abs=5e-4)


def test_vector_update_equals_textbook_form() -> None:
    rng = np.random.default_rng(1)
    A = rng.standard_normal((4, 4))
    P = A @ A.T + np.eye(4)
    x = rng.standard_normal(4)
    H = rng.standard_normal((2, 4))
    R = np.diag([0.5, 2.0])
    z = rng.standard_normal(2)
    xn, Pn = update(x, P, z, R, H)
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)  # paper 000 eq. 17
    assert xn == pytest.approx(x + K @ (z - H @ x))  # eq. 18
    assert Pn == pytest.approx((np.eye(4) - K @ H) @ P)  # eq. 19
    _, Pp = predict(x, P, np.eye(4) * 1.1, np.eye(2), G=np.ones((4, 2)))
    assert Pp == pytest.approx(1.21 * P + np.ones((4, 4)) * 2)


def test_robust_equals_standard_exactly_inside_threshold() -> None:
    """Every residual inside the threshold: A2, A4 (and A3 with alpha_f = 1) are bit-identical to the KF."""
    m = kcf_box_model()
    box = Box(100.0, 80.0, 20.0, 60.0)
    rng = np.random.default_rng(7)
    filters = [KalmanFilter(m)] + [RobustKalmanFilter(m, method=k, robust_components=None)
                                   for k in ("A2", "A4")]
    filters.append(RobustKalmanFilter(m, method="A3", alpha_f=alpha_fixed(0.0), robust_components=None))
    for f in filters:
        f.initialize(m.state_from_box(box), m.P0)
    xv, Pv = filters[0].x.copy(), filters[0].P.copy()
    for t in range(200):
        z = m.measurement_from_box(box.shifted(0.8 * t, 0.3 * t)) + 0.3 * rng.standard_normal(4)
        infos = []
        for f in filters:
            f.predict()
            infos.append(f.update(z))
        xv, Pv = predict(xv, Pv, m.F, m.Q, m.G)
        xv, Pv = update(xv, Pv, z, m.R, m.H)
        assert all(np.all(np.abs(i.normalized) <= 1.5) for i in infos[1:]), "test data left the linear zone"
        for f in filters[1:]:
            assert np.array_equal(f.x, filters[0].x) and np.array_equal(f.P, filters[0].P)
        assert filters[0].x == pytest.approx(xv, rel=1e-10, abs=1e-9)
        assert np.allclose(filters[0].P, Pv, rtol=1e-9, atol=1e-9)


def test_robust_step_forms_paper000_and_001() -> None:
    """A4 = paper 000 eq. 33-35; A2 = paper 001 eq. 23 with alpha_k = psi(u)/u; A3 with alpha_f."""
    x = np.array([1.0, 2.0])
    P = np.array([[2.0, 0.5], [0.5, 1.0]])
    h = np.array([1.0, 0.0])
    r, y, k = 1.0, 30.0, 1.5
    d = np.sqrt(h @ P @ h + r)  # eq. 31
    eps = y - h @ x
    u = eps / d
    w = k / abs(u)  # eq. 32
    KR = w * P @ h / d**2  # eq. 33
    x4, P4, st = scalar_update(x, P, y, h, r, Huber(k), "A4")
    assert st.weight == pytest.approx(w) and st.scale == pytest.approx(d)
    assert x4 == pytest.approx(x + KR * eps)  # eq. 34
    assert np.allclose(P4, (np.eye(2) - np.outer(KR, h)) @ P)  # eq. 35
    x2, P2, _ = scalar_update(x, P, y, h, r, Huber(k), "A2")
    assert x2 == pytest.approx(x + KR * d * np.clip(u, -k, k))  # paper 001 eq. 23
    assert np.allclose(P2, P4)
    x3, P3, _ = scalar_update(x, P, y, h, r, Huber(k), "A3", alpha_f=0.85)
    K3 = 0.85 * P @ h / d**2
    assert x3 == pytest.approx(x + K3 * d * k)
    assert np.allclose(P3, (np.eye(2) - np.outer(K3, h)) @ P)
    # A2 is redescending: a ten times larger outlier moves the state ten times less
    x2b, _, _ = scalar_update(x, P, 10 * (y - 1) + 1, h, r, Huber(k), "A2")
    assert np.linalg.norm(x2b - x) == pytest.approx(np.linalg.norm(x2 - x) / 10, rel=1e-9)


def test_sequential_update_is_the_scalar_steps_bit_for_bit() -> None:
    """The per-component loop (fast path for an all-finite z, Python-float operands, plain-tuple steps)
    gives the same bits as `scalar_update` applied component by component, for C- and Fortran-ordered H."""
    m = kcf_box_model()
    x0 = m.state_from_box(Box(3.0, 4.0, 10.0, 20.0)) + np.linspace(0.1, 0.7, 7)
    P0 = m.P0 + 0.05
    P0 = 0.5 * (P0 + P0.T)
    z = m.measurement_from_box(Box(5.0, 1.0, 11.0, 19.0))
    for method in ("A2", "A3", "A4"):
        x, P = x0, P0
        for j in range(4):
            robust = j in (0, 1)
            x, P, _ = scalar_update(x, P, z[j], m.H[j], m.R[j, j], Huber(0.7) if robust else None,
                                    method if robust else "A1", alpha_f=0.9)
        for H in (m.H, np.asfortranarray(m.H)):
            xs, Ps, info = robust_update(x0, P0, z, m.R, H, Huber(1.5), (0, 1), method, alpha_f=0.9,
                                         threshold=0.7)
            assert xs.tobytes() == x.tobytes() and Ps.tobytes() == P.tobytes()
            assert info.used.all() and not info.nonfinite and info.weights[0] < 1.0


def test_only_chosen_components_are_robust() -> None:
    m = kcf_box_model()
    kf = RobustKalmanFilter(m, robust_components=(0, 1))
    kf.initialize(m.state_from_box(Box(0, 0, 10, 20)), m.P0)
    kf.predict()
    z = m.measurement_from_box(Box(0, 0, 10, 20)) + np.array([50.0, -50.0, 80.0, 0.0])
    info = kf.update(z, threshold=0.5)
    assert info.threshold == 0.5
    assert info.weights[0] < 0.2 and info.weights[1] < 0.2
    assert info.weights[2] == 1.0 and info.alphas[2] == 1.0  # size gets the standard update
    assert kf.update(None).coasted


def test_nonfinite_measurement_is_a_missed_measurement() -> None:
    m = dcfca_box_model(20, 60)
    for kf in (KalmanFilter(m), RobustKalmanFilter(m)):
        kf.initialize(m.state_from_box(Box(10, 10, 20, 60)), m.P0)
        kf.predict()
        x, P = kf.x.copy(), kf.P.copy()
        info = kf.update([np.nan, np.inf, -np.inf, np.nan])
        assert info.coasted and info.nonfinite and not info.used.any()
        assert np.array_equal(kf.x, x) and np.array_equal(kf.P, P)
        info = kf.update([np.nan, 20.0, 20.0, 60.0])  # partial: the finite components are used
        assert info.nonfinite and not info.coasted and info.used.tolist() == [False, True, True, True]
        assert kf.x[0] == x[0] and np.all(np.isfinite(kf.x)) and np.all(np.isfinite(kf.P))
        info = kf.update([1e308, 1e308, 20.0, 60.0])  # overflow is skipped, never stored
        assert np.all(np.isfinite(kf.x)) and np.all(np.isfinite(kf.P))


def test_bad_inputs_raise_kalman_error() -> None:
    m = kcf_box_model()
    with pytest.raises(KalmanError, match="4 components"):
        KalmanFilter(m).update([1.0, 2.0])
    with pytest.raises(KalmanError, match="threshold"):
        RobustKalmanFilter(m).update([0.0] * 4, threshold=-1.0)
    with pytest.raises(KalmanError, match="out of range"):
        RobustKalmanFilter(radar_filter().F, H2, [[0.1]], [[1.0]], G=G2)  # default (0, 1) on a scalar sensor
    with pytest.raises(KalmanError, match="A3 needs alpha_f"):
        RobustKalmanFilter(m, method="A3")
    with pytest.raises(KalmanError, match="unknown method"):
        RobustKalmanFilter(m, method="A5")
    with pytest.raises(KalmanError, match="non-finite"):
        update(np.zeros(2), np.eye(2), [np.nan], [[1.0]], H2)
    with pytest.raises(KalmanError, match="initialize"):
        KalmanFilter(m).initialize([1.0, 2.0])
    with pytest.raises(KalmanError, match="non-finite"):
        KalmanFilter(m).initialize([np.nan] * 7)
    with pytest.raises(KalmanError, match="numbers"):
        KalmanFilter(m).update(["a", None, 1, 2])


def test_per_step_r_override_and_assignment() -> None:
    a, b, c = radar_filter(), radar_filter(), radar_filter()
    for f in (a, b, c):
        f.predict()
    a.update([1.0], R=[[4.0]])
    b.R = np.array([[4.0]])
    b.update([1.0])
    c.update([1.0])
    assert np.array_equal(a.x, b.x) and not np.array_equal(a.x, c.x)


def test_non_diagonal_r_is_decorrelated() -> None:
    """Sequential processing after Cholesky decorrelation equals the vector update (paper 000 §IV-A)."""
    rng = np.random.default_rng(3)
    P = np.diag([4.0, 3.0, 2.0, 1.0])
    H = np.hstack([np.eye(2), np.zeros((2, 2))])
    R = np.array([[1.0, 0.6], [0.6, 2.0]])
    x = rng.standard_normal(4)
    z = H @ x + 0.1
    xs, Ps, info = robust_update(x, P, z, R, H, Huber(1.5))
    xv, Pv = update(x, P, z, R, H)
    assert info.weights.tolist() == [1.0, 1.0]
    assert xs == pytest.approx(xv) and Ps == pytest.approx(Pv)


def test_redescending_influence_rejects_gross_outlier() -> None:
    kf = radar_filter(RobustKalmanFilter, influence=Tukey(4.685), robust_components=None)
    kf.predict()
    x = kf.x.copy()
    info = kf.update([1e4])
    assert info.weights[0] == 0.0 and np.array_equal(kf.x, x)
