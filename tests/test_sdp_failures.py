"""Every SDP entry point reports a failed solve unless the caller asked for the fallback (a gap the
mutation run found: only inner_ellipsoid was checked without the fallback)."""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

from boundid.errors import SolverError
from boundid.sets import Ellipsoid, Polytope, sdp


def _polytope():
    rng = np.random.default_rng(8)
    W = rng.normal(size=(15, 2))
    e = 0.5 + rng.random(15)
    y = W @ rng.normal(size=2) + e * rng.uniform(-1, 1, 15)
    return Polytope.from_strips(W, y, e)


CALLS = {
    "outer_ellipsoid": lambda: sdp.outer_ellipsoid(_polytope()),
    "inner_ellipsoid": lambda: sdp.inner_ellipsoid(_polytope()),
    "john_outer": lambda: sdp.john_outer(_polytope()),
    "enclosing_ellipsoid": lambda: sdp.enclosing_ellipsoid(np.random.default_rng(1).normal(size=(20, 2))),
    "step_ellipsoid": lambda: sdp.step_ellipsoid(Ellipsoid(np.zeros(2), np.eye(2)), [1.0, 0.5], 0.3, 0.4),
}


def _clarabel_fails(monkeypatch):
    """Make Clarabel end 'infeasible_inaccurate' (the real solve runs, its status is replaced), and the
    outer and inner ellipsoids' own interior-point solvers fail too, so that they fall back to Clarabel."""
    real = sdp._run

    def multipliers_fail(G, mid, half):
        raise SolverError("outer_ellipsoid: the S-procedure's interior-point method did not converge.")

    def inscribed_fails(A, b, x0=None):
        raise SolverError("inner_ellipsoid: the interior-point method did not converge.")

    monkeypatch.setattr(sdp, "s_procedure_multipliers", multipliers_fail)
    monkeypatch.setattr(sdp, "max_volume_inscribed", inscribed_fails)

    def clarabel_fails(problem, solver, **opts):
        real(problem, solver, **opts)
        if solver == cp.CLARABEL:
            problem._status = "infeasible_inaccurate"

    monkeypatch.setattr(sdp, "_run", clarabel_fails)


@pytest.mark.parametrize("name", sorted(CALLS))
def test_failed_solve_raises_by_default(monkeypatch, name):
    """With Clarabel failing and the default arguments the call raises SolverError naming that
    status, never a silent SCS answer."""
    _clarabel_fails(monkeypatch)
    with pytest.raises(SolverError, match="infeasible_inaccurate"):
        CALLS[name]()


def test_fallback_answer_is_verified(monkeypatch):
    """With Clarabel failing and allow_fallback=True the SCS answer is used, re-verified: the outer
    ellipsoid still contains every vertex of P (Qhull, independent of the solvers)."""
    _clarabel_fails(monkeypatch)
    P = _polytope()
    r = sdp.outer_ellipsoid(P, allow_fallback=True)
    assert r.solver == "SCS"
    assert np.all(r.ellipsoid.contains(P.vertices()))
