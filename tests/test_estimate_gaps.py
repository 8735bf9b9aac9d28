"""Estimate fields and summaries no other test read (gaps found by the mutation run)."""

from __future__ import annotations

import time

import numpy as np

from boundid.estimators import OBE, RLS, ols


def _data(seed=0, N=80, p=3):
    rng = np.random.default_rng(seed)
    theta = rng.normal(size=p) + 2.0
    W = rng.normal(size=(N, p))
    return W, W @ theta + 0.1 * rng.normal(size=N)


def test_rls_relative_std_and_time():
    """Closed form: rel_std_pct = 100 std_err / |theta|; time_s is the time spent in fit, so it lies
    between 0 and the wall time measured around the call."""
    W, y = _data()
    t0 = time.perf_counter()
    est = RLS(3, shape0=1e6).fit(W, y)
    wall = time.perf_counter() - t0
    np.testing.assert_allclose(est.statistics.rel_std_pct, 100.0 * est.statistics.std_err / np.abs(est.center),
                               rtol=1e-12)
    assert 0.0 <= est.time_s <= wall


def test_estimates_without_outliers_have_no_outlier_residuals():
    """Least-squares estimates never flag outliers: outliers and outlier_residuals are both empty."""
    W, y = _data(1)
    for est in (ols(W, y), RLS(3, shape0=1e6).fit(W, y)):
        assert est.outliers.size == 0 and est.outlier_residuals.size == 0


def test_summary_explains_only_unverified_sets():
    """The summary has a 'Why' line exactly when the kind is "unverified", carrying its reason."""
    W, y = _data(2)
    good = OBE(3, shape0=100.0).fit(W, y, 0.5)
    assert good.kind == "guaranteed" and "Why" not in good.summary()
    rng = np.random.default_rng(0)
    Wb = rng.normal(size=(12, 2))
    e = np.full(12, 1e9)
    e[7], e[8:] = 1e-2, 1.0
    yb = Wb @ np.array([0.3, -0.2]) + 0.5 * e * rng.uniform(-1, 1, 12)
    bad = OBE(2, shape0=1e10, form="standard").fit(Wb, yb, e)
    assert bad.kind == "unverified"
    why = [line for line in bad.summary().splitlines() if "Why" in line]
    assert len(why) == 1 and "rounding error" in why[0]
