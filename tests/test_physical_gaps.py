"""Physical-constraint cases no other test reached (found by the mutation run)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from boundid.sets.constraints import LinearRows, PhysicalConstraints
from boundid.sets.physical import column_bounds


@pytest.mark.parametrize("lift", [False, True])
def test_column_bounds_of_single_variable_rows(lift):
    """Reference: scipy linprog of min/max theta_i over the rows (the single-variable rows alone bound
    theta_0 above and theta_1 below; a two-variable row implies nothing per column and is ignored).
    With a lift theta = K x whose column for x_j is 2 e_i, the bounds are scaled by 2."""
    A = np.array([[2.0, 0.0, 0.0], [0.0, -3.0, 0.0], [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    A[2, 2] = 4.0
    b = np.array([4.0, 6.0, -8.0, 100.0])
    rows = LinearRows(A, b, tuple("abcd"), tuple("abcd"))
    K = None
    if lift:
        K = 2.0 * np.eye(3)
    cons = PhysicalConstraints(("x0", "x1", "x2"), rows, lift=K)
    lo, hi = column_bounds(cons)
    single = A[:3]                      # the reference uses the single-variable rows only
    k = 2.0 if lift else 1.0
    for i in range(3):
        res = linprog(-np.eye(3)[i], A_ub=single, b_ub=b[:3], bounds=[(None, None)] * 3, method="highs")
        if res.status == 3:             # unbounded above
            assert hi[i] == np.inf
        else:
            assert hi[i] == pytest.approx(-k * res.fun)
    assert lo[1] == pytest.approx(k * -2.0) and np.isneginf(lo[0]) and np.isneginf(lo[2])
    assert hi[0] == pytest.approx(k * 2.0) and hi[2] == pytest.approx(k * -2.0)
