# SPDX-License-Identifier: Apache-2.0
"""Shapes of the influence functions and the statistical-linearisation coefficients of paper 001."""

from __future__ import annotations

import numpy as np
import pytest

from swir_tracker_ros.errors import KalmanError
from swir_tracker_ros.kalman import Andrews, Clipping, Hampel, Huber, Smith, Tukey, make_influence
from swir_tracker_ros.kalman.statlin import alpha_fixed, alpha_optimal_gaussian, alpha_optimal_mixture

U = np.linspace(-20, 20, 4001)
ALL = [Huber(), Clipping(), Hampel(), Andrews(), Tukey(), Smith()]


@pytest.mark.parametrize("f", ALL, ids=lambda f: type(f).__name__)
def test_common_shape(f) -> None:
    """Odd psi, unit slope at 0, weight = psi/u in [0, 1], dpsi matches a numerical derivative."""
    psi = f.psi(U)
    assert np.allclose(psi, -f.psi(-U))
    assert f.weight(0.0) == 1.0 and f.dpsi(0.0) == pytest.approx(1.0)
    w = f.weight(U)
    assert np.all((w >= 0) & (w <= 1 + 1e-12))
    nz = U != 0
    assert np.allclose(w[nz] * U[nz], psi[nz])
    h = 1e-6
    smooth = np.abs(np.abs(U) - f.threshold) > 1e-3  # away from the kinks
    if isinstance(f, Hampel):
        smooth &= np.abs(np.abs(U) - f.b) > 1e-3
        smooth &= np.abs(np.abs(U) - f.c) > 1e-3
    if isinstance(f, Andrews):
        smooth = np.abs(np.abs(U) - f.k * np.pi) > 1e-3
    num = (f.psi(U + h) - f.psi(U - h)) / (2 * h)
    assert np.allclose(f.dpsi(U)[smooth], num[smooth], atol=1e-5)
    assert isinstance(f.psi(0.3), float)


def test_huber_is_clipping_of_u() -> None:
    """Paper 000 eq. 26 / notes U2: psi = clip(u, -1.5, 1.5), weight 1.5/|u| outside."""
    f = Huber(1.5)
    assert np.array_equal(f.psi(U), np.clip(U, -1.5, 1.5))
    assert f.weight(3.0) == 0.5 and f.weight(-6.0) == 0.25 and f.weight(1.5) == 1.0


def test_redescending_functions_reject_far_residuals() -> None:
    assert Clipping(3.0).psi(3.01) == 0.0 and Clipping(3.0).psi(2.99) == 2.99
    h = Hampel(1.7, 3.4, 8.5)
    assert h.psi(2.5) == 1.7 and h.psi(8.6) == 0.0
    assert h.psi(5.95) == pytest.approx(1.7 * (8.5 - 5.95) / (8.5 - 3.4))
    assert Andrews(1.5).psi(1.5 * np.pi + 0.01) == 0.0
    assert Andrews(1.5).psi(1.5 * np.pi / 2) == pytest.approx(1.5)  # maximum k at u = k pi / 2
    assert Tukey(4.685).psi(4.7) == 0.0
    assert Tukey(4.685).psi(1.0) == pytest.approx(1.0 * (1 - (1 / 4.685) ** 2) ** 2)
    assert Smith(3.0).psi(3.0) == 0.0 and Smith(3.0).psi(3.0 / np.sqrt(3)) == pytest.approx(2 / np.sqrt(3))


def test_with_threshold_and_factory() -> None:
    assert Huber().with_threshold(0.1).k == 0.1
    h = Hampel().with_threshold(3.4)
    assert (h.a, h.b, h.c) == pytest.approx((3.4, 6.8, 17.0))
    assert make_influence("tukey", k=5.0) == Tukey(5.0)
    with pytest.raises(KalmanError):
        make_influence("cauchy")
    with pytest.raises(KalmanError):
        Huber(0.0)
    with pytest.raises(KalmanError):
        Hampel(3.0, 2.0, 8.0)


def test_sl_coefficients_match_note() -> None:
    """notes/seed-001.md U4, U5, §2.5: alpha_f (26)/(27) and the exact Gaussian / mixture SL coefficient."""
    assert alpha_fixed(0.07) == pytest.approx(0.93) and alpha_fixed(0.15) == pytest.approx(0.85)
    assert alpha_fixed(0.07, form="27") == pytest.approx(0.8057, abs=1e-4)
    assert alpha_fixed(0.15, form="27") == pytest.approx(0.7364, abs=1e-4)
    for sigma, a in ((0.5, 0.9973), (1, 0.8664), (1.5, 0.6827), (2, 0.5467), (3, 0.3829)):
        assert alpha_optimal_gaussian(sigma) == pytest.approx(a, abs=1e-4)
    assert alpha_optimal_mixture(0.07, 100) == pytest.approx(0.2069, abs=1e-4)
    assert alpha_optimal_mixture(0.15, 1000) == pytest.approx(0.0425, abs=1e-4)
    z = np.random.default_rng(0).standard_normal(400_000)
    mc = np.mean(Huber(1.5).psi(z) * z) / np.mean(z * z)
    assert mc == pytest.approx(0.866386, abs=3e-3)
