"""The exact layer does not depend on the units of the parameters or of y.

Each case draws a well-scaled problem (W0 gaussian, truth u), then hides it behind column scales
c_j in [1e-12, 1e12] (W = W0 * c, theta = u / c) and an error bound e = rel * rms(W0 u) with
rel in [1e-9, 1e6]. The truth satisfies every strip with a margin of 1e-6 e, so P is not empty.
Reference: scipy.optimize.linprog on the same polytope written in the dimensionless coordinates
v = (c * theta - u) / e, where it is well posed (unit-scale rows, O(1) bounds): an independent
LP, compared in those coordinates, i.e. relative to each column's own scale and to e.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from boundid.errors import InfeasibleDataError, SolverError
from boundid.sets import Polytope, sdp


def scaled_case(seed: int):
    rng = np.random.default_rng(seed)
    p = int(rng.integers(2, 6))
    N = int(rng.integers(6 * p, 40 * p))
    W0 = rng.normal(size=(N, p))
    u = rng.normal(size=p)
    col = 10.0 ** rng.uniform(-12, 12, p)
    rel = 10.0 ** rng.uniform(-9, 6)
    e = rel * float(np.sqrt(np.mean((W0 @ u) ** 2)))
    noise = rng.uniform(-1, 1, N) * e * (1 - 1e-6)
    noise[:2] = [e * (1 - 1e-6), -e * (1 - 1e-6)]                  # two strips grazing the truth
    W = W0 * col
    theta = u / col
    y = W @ theta + noise
    box = None
    if rng.random() < 0.5:                                          # a prior box in u units
        hb = e * 10.0 ** rng.uniform(-0.5, 1.0, p)
        box = ((u - hb) / col, (u + hb) / col)
    return W, y, e, theta, u, col, box, W0


def reference_bounds(W0, r, e, box_v):
    """min / max of v_j over {|r/e - W0 v| <= 1} ∩ box_v by 2p scipy linprog calls."""
    p = W0.shape[1]
    A_ub = np.vstack([W0, -W0])
    b_ub = np.concatenate([1 + r / e, 1 - r / e])
    bounds = [(None, None)] * p if box_v is None else list(zip(*box_v, strict=True))
    lo, hi = np.empty(p), np.empty(p)
    for j in range(p):
        c = np.eye(p)[j]
        lo[j] = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=bounds, method="highs").fun
        hi[j] = -linprog(-c, A_ub=A_ub, b_ub=b_ub, bounds=bounds, method="highs").fun
    return lo, hi


def check_case(seed: int):
    W, y, e, theta, u, col, box, W0 = scaled_case(seed)
    r = y - W @ theta
    assert np.all(np.abs(r) <= e), "the generator must give a feasible truth"
    P = Polytope(W, y, e, box=box)
    cons = P.consistency()
    assert not cons.empty and not P.is_empty(), f"seed {seed}: feasible data declared empty (gamma {cons.gamma})"
    assert cons.gamma <= 1 + cons.tol
    b = P.bounds()                                                  # must not raise
    box_v = None if box is None else ((col * box[0] - u) / e, (col * box[1] - u) / e)
    ref_lo, ref_hi = reference_bounds(W0, r, e, box_v)
    v_lo, v_hi = (col * b.lo - u) / e, (col * b.hi - u) / e
    # agreement in v: relative to each column's scale and to e; the last term is the rounding of
    # theta = u / c itself when e << |u| (the data cannot resolve P better than that)
    tol = 1e-6 * np.maximum(1.0, ref_hi - ref_lo) + 64 * np.finfo(float).eps * np.abs(u) / e
    assert np.all(np.abs(v_lo - ref_lo) <= tol), f"seed {seed}: lo {v_lo} vs {ref_lo}"
    assert np.all(np.abs(v_hi - ref_hi) <= tol), f"seed {seed}: hi {v_hi} vs {ref_hi}"
    assert np.all(v_lo <= tol) and np.all(v_hi >= -tol), f"seed {seed}: the truth is outside the bounds"
    # the certificates, checked on the original data
    assert b.residual_ratio <= 1 + 1e-6 and b.vertex_excess <= 1.0
    assert np.all(P.contains(b.point, rtol=1e-6))


@pytest.mark.parametrize("seed", range(40))
def test_scaled_problems_agree_with_linprog(seed):
    """Seeded sweep (40 cases): never 'infeasible' for a feasible truth; bounds equal an
    independent well-posed scipy linprog (see the module docstring); certificates hold."""
    check_case(seed)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(40, 400))
def test_scaled_problems_agree_with_linprog_long(seed):
    """The same property on 360 more seeds (make test-all)."""
    check_case(seed)


def test_issue_13_reproducers():
    """A column x1e-10 (e = 0.1) and a column x1e-6 (e = 1e3), truth inside every strip:
    not empty, and the bounds of the scaled column equal linprog on the rescaled problem."""
    rng = np.random.default_rng(0)
    for col_scale, e in ((1e-10, 0.1), (1e-6, 1e3)):
        W0 = rng.normal(size=(200, 5))
        th0 = rng.normal(size=5)
        y = W0 @ th0 + rng.uniform(-e, e, 200) * 0.999
        c = np.ones(5)
        c[2] = col_scale
        P = Polytope(W0 * c, y, e)
        assert not P.is_empty()
        b = P.bounds()
        lo, hi = reference_bounds(W0, y - W0 @ th0, e, None)
        assert np.allclose((c * b.lo - th0) / e, lo, atol=1e-6 * max(1.0, (hi - lo).max()))
        assert np.allclose((c * b.hi - th0) / e, hi, atol=1e-6 * max(1.0, (hi - lo).max()))


def test_inconsistent_scaled_data_still_detected():
    """Scaling does not hide a real contradiction: an outlier 20 e off, in a problem with columns
    x1e-9 and x1e9, gives gamma* > 1 equal to the minimax LP of the well-scaled problem."""
    rng = np.random.default_rng(4)
    W0 = rng.normal(size=(60, 3))
    y = W0 @ np.array([0.5, -1.0, 2.0]) + rng.uniform(-1, 1, 60)
    y[7] += 20.0
    c = np.array([1e-9, 1.0, 1e9])
    P = Polytope(W0 * c, y, 1.0)
    res = linprog(np.r_[0, 0, 0, 1.0], A_ub=np.vstack([np.hstack([W0, -np.ones((60, 1))]),
                                                       np.hstack([-W0, -np.ones((60, 1))])]),
                  b_ub=np.r_[y, -y], bounds=[(None, None)] * 3 + [(0, None)], method="highs")
    cons = P.consistency()
    assert cons.empty and cons.gamma == pytest.approx(res.fun, rel=1e-8)
    with pytest.raises(InfeasibleDataError, match="gamma"):
        P.bounds()


def test_sdp_ellipsoids_are_scale_equivariant():
    """Inner, outer and John ellipsoids of P(W0 * c) are those of P(W0) mapped by theta = u / c:
    ln vol shifts by -sum ln c (closed form of the change of variables); the outer one contains
    every vertex of the scaled polytope (Qhull)."""
    rng = np.random.default_rng(12)
    W0 = rng.normal(size=(40, 3))
    y = W0 @ rng.normal(size=3) + rng.uniform(-1, 1, 40)
    c = np.array([1e-8, 3.0, 1e7])
    P0, Ps = Polytope(W0, y, 1.0), Polytope(W0 * c, y, 1.0)
    shift = -np.sum(np.log(c))
    for f in (sdp.inner_ellipsoid, sdp.outer_ellipsoid, sdp.john_outer):
        e0, es = f(P0).ellipsoid, f(Ps).ellipsoid
        assert es.log_volume() == pytest.approx(e0.log_volume() + shift, abs=1e-4)
        assert np.allclose(c * es.center, e0.center, atol=1e-5 * np.sqrt(np.diag(e0.shape)).max())
    assert np.all(sdp.outer_ellipsoid(Ps).ellipsoid.contains(Ps.vertices()))


def test_solver_failures_raise_solver_error(monkeypatch):
    """A wrong LP answer never comes back as bounds: vertices moved 1e-3 off P fail their
    certificate (SolverError naming the strip and the remedy); an LP 'infeasible' on data whose
    minimax point satisfies every strip is a SolverError too, not InfeasibleDataError."""
    rng = np.random.default_rng(3)
    W = rng.normal(size=(50, 3))
    y = W @ np.ones(3) + rng.uniform(-0.5, 0.5, 50)
    real = Polytope._minimize_many

    def shifted(self, costs, levels=(), threads=False):
        return real(self, costs, levels, threads) + 1e-3

    monkeypatch.setattr(Polytope, "_minimize_many", shifted)
    with pytest.raises(SolverError, match="certificate"):
        Polytope(W, y, 0.5).bounds()

    def infeasible(self, costs, levels=(), threads=False):
        raise self._status_error("infeasible")

    monkeypatch.setattr(Polytope, "_minimize_many", infeasible)
    with pytest.raises(SolverError, match="numerical failure"):
        Polytope(W, y, 0.5).bounds()
