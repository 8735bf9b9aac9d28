"""OBE cases no other test reached (found by the mutation run of issue 13): a strip the trace
criterion declines, and the verdict on a one-parameter fit."""

from __future__ import annotations

import numpy as np
import pytest

from boundid.estimators import OBE
from boundid.estimators import _obe_kernels as K


def _trace_objective(q, sigma, G, eps, T, H):
    """tr(sigma' M'^-1) after the update with q = lambda / alpha (REFERENCES §1 pencil, gamma = 1;
    Sherman-Morrison for the inverse)."""
    return (sigma + q - q * eps**2 / (1.0 + q * G)) * (T - q * H / (1.0 + q * G))


def test_trace_weight_declines_a_strip_that_cannot_shrink_the_trace():
    """Brute force on a log grid of q in [1e-8, 1e8]: when no q > 0 lowers tr(sigma' M'^-1) below
    its value at q = 0, the weight is exactly (lambda, alpha) = (0, 1) (no update). The strips are
    wide (half-width close to E's extent along w) and nearly centred, so the case occurs often."""
    rng = np.random.default_rng(21)
    grid = np.logspace(-8, 8, 4001)
    declined = 0
    for _ in range(300):
        n = int(rng.integers(2, 7))
        A = rng.normal(size=(n, n))
        P = A @ A.T + 0.05 * np.eye(n)
        w = rng.normal(size=n)
        sigma = rng.uniform(0.2, 1.0)
        g = P @ w
        G = w @ g
        r = np.sqrt(sigma * G)
        gam = rng.uniform(0.9, 1.0) * r
        eps = rng.uniform(-1.0, 1.0) * 0.1 * (r - gam)
        Gn, en, T, Hn = G / gam**2, eps / gam, np.trace(P), (g @ g) / gam**2
        lam, alpha = K.weight_trace(n, sigma, Gn, en, T, Hn)
        f0 = _trace_objective(0.0, sigma, Gn, en, T, Hn)
        if np.all(_trace_objective(grid, sigma, Gn, en, T, Hn) >= f0 * (1 - 1e-12)):
            assert (lam, alpha) == (0.0, 1.0)
            declined += 1
        else:
            assert lam > 0.0 and alpha == pytest.approx(1.0 - lam)
    assert declined > 30


@pytest.mark.parametrize("form", ["standard", "factorized"])
@pytest.mark.parametrize("criterion", ["volume", "trace", "dasgupta-huang"])
def test_one_parameter_fit_is_the_exact_interval_and_guaranteed(form, criterion):
    """Closed form: with p = 1 the feasible set is [max lo_k, min hi_k] over the strips
    lo_k, hi_k = (y_k -+ e_k) / w_k (w_k > 0). Volume and trace intersect exactly; every criterion
    keeps the truth; rounding of a fresh interval is a few units of roundoff, so the verdict is
    "guaranteed"."""
    rng = np.random.default_rng(5)
    w = rng.uniform(0.5, 2.0, 40)
    theta = 0.7
    e = rng.uniform(0.2, 0.6, 40)
    y = w * theta + rng.uniform(-1, 1, 40) * e
    est = OBE(1, shape0=100.0, form=form, criterion=criterion).fit(w[:, None], y, e)
    assert est.kind == "guaranteed"
    lo, hi = np.max((y - e) / w), np.min((y + e) / w)
    assert est.intervals[0][0] <= theta <= est.intervals[1][0]
    assert est.intervals[0][0] <= lo + 1e-9 and est.intervals[1][0] >= hi - 1e-9
    if criterion != "dasgupta-huang":
        assert est.intervals[0][0] == pytest.approx(lo, abs=1e-9)
        assert est.intervals[1][0] == pytest.approx(hi, abs=1e-9)
