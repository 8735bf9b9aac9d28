"""OBE cases no other test reached (found by the mutation run): a strip the trace
criterion declines, and the verdict on a one-parameter fit."""

from __future__ import annotations

import numpy as np
import pytest

from boundid.estimators import OBE
from boundid.estimators import _obe_kernels as K


def _trace_objective(q, sigma, G, eps, T, H):
    """tr(sigma' M'^-1) after the update with q = lambda / alpha ([refs §OBE] pencil, gamma = 1;
    Sherman-Morrison for the inverse; T - q H / (1 + q G) written over the common denominator, which
    does not cancel for large q)."""
    return (sigma + q - q * eps**2 / (1.0 + q * G)) * (T + q * (G * T - H)) / (1.0 + q * G)


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


@pytest.mark.parametrize("split", [None, 5])
def test_standard_form_names_the_row_that_cost_its_accuracy(split):
    """Construction: rows 0-6 have bounds 1e9 (their strips contain the prior ellipsoid of radius 1e5,
    so they are skipped) and row 7 is the first update, shrinking the ellipsoid from 1e5 to 1e-2
    along its w: the largest rounding share of the standard (subtractive) form comes from row 7,
    which the unverified reason names by its global index, also when the data arrive in two calls
    (partial_fit of rows 0-4, then partial_fit of rows 5-11: fit would start afresh)."""
    rng = np.random.default_rng(0)
    theta = np.array([0.3, -0.2])
    W = rng.normal(size=(12, 2))
    e = np.full(12, 1e9)
    e[7], e[8:] = 1e-2, 1.0
    y = W @ theta + 0.5 * e * rng.uniform(-1, 1, 12)
    est = OBE(2, shape0=1e10, form="standard")
    start = split or 0
    if split:
        est.partial_fit(W[:split], y[:split], e[:split])
        out = est.partial_fit(W[start:], y[start:], e[start:])
    else:
        out = est.fit(W, y, e)
    assert out.n_skipped >= 7
    assert out.kind == "unverified"
    assert "the largest share comes from row 7," in out.unverified_reason


def test_trace_weight_with_a_rank_one_inverse_shape():
    """M^-1 = v v^T (a flat ellipsoid, n = 3): H = G T exactly and the cubic degenerates to the
    linear b1 q + b0. Brute force on a log grid of q in [1e-6, 1e6]: when tr(sigma' M'^-1) has an
    interior minimiser the weight is that minimiser (to the grid's resolution); when q = 0 is best,
    or the trace keeps falling as q -> inf (lambda -> 1 would leave M' = w w^T singular), the
    weight is exactly (0, 1). Never negative."""
    rng = np.random.default_rng(8)
    grid = np.logspace(-6, 6, 24001)
    seen = {"update": 0, "decline": 0}
    for _ in range(300):
        v = rng.normal(size=3)
        w = rng.normal(size=3)
        sigma = rng.uniform(0.2, 1.0)
        G, T = (v @ w) ** 2 * rng.uniform(0.05, 3.0), v @ v
        H = G * T
        eps = rng.uniform(-1.0, 1.0)
        lam, alpha = K.weight_trace(3, sigma, G, eps, T, H)
        assert 0.0 <= lam < 1.0 and alpha == pytest.approx(1.0 - lam)
        f = _trace_objective(grid, sigma, G, eps, T, H)
        f0 = _trace_objective(0.0, sigma, G, eps, T, H)
        k = int(np.argmin(f))
        if f[k] >= f0 * (1 - 1e-12) or f[k] >= f[-1] * (1 - 1e-9):  # q = 0 best, or no finite minimiser
            assert lam == 0.0
            seen["decline"] += 1
        else:
            q = lam / alpha
            assert _trace_objective(q, sigma, G, eps, T, H) <= f[k] * (1 + 1e-6)
            seen["update"] += 1
    assert min(seen.values()) > 20
