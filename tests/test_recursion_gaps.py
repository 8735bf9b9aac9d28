"""Zonotope recursion counts and outlier residuals (gaps found by the mutation run)."""

from __future__ import annotations

import numpy as np
import pytest

from boundid.estimators import ZonotopeRecursion
from boundid.estimators import _set_kernels as K
from boundid.estimators.zonotope_recursion import zonotope_step
from boundid.sets import Box


@pytest.mark.parametrize("p", [2, 4])
def test_zonotope_counts_and_outlier_residuals_match_the_numpy_steps(p):
    """Second algorithm: the plain-numpy zonotope_step replayed row by row gives the number of
    updates (rows where a candidate other than Z itself wins) and, at each planted outlier (a row
    50 e away from the truth), the residual y_k - w_k^T c_k against the centre held at that row;
    the compiled loop reports the same."""
    rng = np.random.default_rng(40 + p)
    N = 200
    theta = rng.normal(size=p)
    W = rng.normal(size=(N, p))
    e = np.full(N, 0.5)
    y = W @ theta + rng.uniform(-0.5, 0.5, N)
    bad = np.array([60, 130])
    y[bad] += 50.0 * e[bad] * np.array([1.0, -1.0])
    h0 = np.full(p, 10.0)
    c, G = np.zeros(p), np.diag(h0)
    n_upd, res = 0, []
    for k in range(N):
        c_before = c.copy()
        st, c, G, choice = zonotope_step(c, G, W[k], y[k], e[k], 2 * p)
        n_upd += st == K.UPDATE and choice != -2            # -2: Z itself kept (no update)
        if st == K.OUTLIER:
            res.append(y[k] - W[k] @ c_before)
    est = ZonotopeRecursion(p, prior=Box.from_center(np.zeros(p), h0)).fit(W, y, e)
    assert est.n_updates == n_upd
    np.testing.assert_array_equal(est.outliers, bad)
    np.testing.assert_allclose(est.outlier_residuals, res, rtol=1e-9)
