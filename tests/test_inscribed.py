"""The maximum-volume inscribed ellipsoid by the interior-point method of boundid.sets._inscribed:
against Clarabel's solve of the same polytopes (boundid.sets.sdp._inscribed with the interior-point
method bypassed, a second algorithm), against closed forms, on polytopes without an interior, and
as the solver of boundid.sets.sdp.inner_ellipsoid."""

import numpy as np
import pytest

from boundid.errors import SolverError
from boundid.sets import Polytope, sdp
from boundid.sets._inscribed import max_volume_inscribed


def polytope(n: int, seed: int):
    """(A, b): 8 n random unit sides around a random point, within a random box."""
    rng = np.random.default_rng(seed)
    G = rng.normal(size=(8 * n, n))
    G /= np.linalg.norm(G, axis=1)[:, None]
    h = G @ (0.3 * rng.normal(size=n)) + rng.uniform(0.3, 1.0, 8 * n)
    lo, hi = -rng.uniform(0.5, 2.0, n), rng.uniform(0.5, 2.0, n)
    return np.vstack([G, np.eye(n), -np.eye(n)]), np.concatenate([h, hi, -lo])


def clarabel(A, b):
    """(x, ln det E) by Clarabel: the triangular-factor form, the symmetric root's if that fails."""
    try:
        (solver, _), M, x = sdp._inscribed(A, b, True, False, interior_point=False)
    except SolverError:
        (solver, _), M, x = sdp._inscribed(A, b, False, False, interior_point=False)
    assert solver == "CLARABEL"
    return x, np.linalg.slogdet(M)[1]


@pytest.mark.parametrize("n", range(2, 13))
def test_agrees_with_clarabel(n, monkeypatch):
    """Random polytopes with boxes, n = 2..12: ln det E equals Clarabel's to 1e-7 (relative), the
    centre to 1e-5, in Clarabel's default tolerances (1e-8 on the gap; the objective is flat in the
    centre to first order, so Clarabel fixes the centre less well, measured 5e-6 at worst); the
    ellipsoid touches the polytope without leaving it (to 1e-8: the residuals stop below
    TOL (1 + |b|) in rows scaled to b = 1)."""
    monkeypatch.setattr(sdp, "_CLARABEL", {})
    for seed in (n, 100 + n):
        A, b = polytope(n, seed)
        x, E2, steps = max_volume_inscribed(A, b)
        xc, ldc = clarabel(A, b)
        assert 0.5 * np.linalg.slogdet(E2)[1] == pytest.approx(ldc, rel=1e-7, abs=1e-7)
        np.testing.assert_allclose(x, xc, atol=1e-5)
        reach = np.sqrt(np.einsum("ij,jk,ik->i", A, E2, A)) + A @ x - b
        assert -1e-8 < reach.max() < 1e-8 and steps < 30


@pytest.mark.parametrize("n", [1, 2, 3, 6])
def test_box_and_simplex_closed_forms(n):
    """The box [lo, hi]: E2 = diag(((hi - lo) / 2)^2) about its centre (2n sides bind, more than the
    n (n + 1) / 2 the Newton matrix can separate for n <= 3). The simplex {x >= 0, sum x <= 1}: the
    image of the regular simplex's insphere, centred at the centroid 1 / (n + 1) with
    E2 = (I - 1 1^T / (n + 1)) / (n (n + 1)) (its vertices' covariance over n^2 / (n + 1); n = 1:
    the interval [0, 1], half-width 1/2)."""
    lo, hi = -0.5 * np.arange(1, n + 1), np.linspace(1.0, 3.0, n)
    x, E2, _ = max_volume_inscribed(np.vstack([np.eye(n), -np.eye(n)]), np.concatenate([hi, -lo]))
    np.testing.assert_allclose(x, (lo + hi) / 2, atol=1e-8)
    np.testing.assert_allclose(E2, np.diag(((hi - lo) / 2) ** 2), atol=1e-8)
    x, E2, _ = max_volume_inscribed(np.vstack([-np.eye(n), np.ones(n)]), np.concatenate([np.zeros(n), [1.0]]))
    np.testing.assert_allclose(x, np.full(n, 1 / (n + 1)), atol=1e-8)
    np.testing.assert_allclose(E2, (np.eye(n) - 1 / (n + 1)) / (n * (n + 1)), atol=1e-8)


@pytest.mark.parametrize("k", [3, 7, 400])
def test_regular_polygon_gives_its_incircle(k):
    """A regular k-gon with inradius 1 about the origin: its largest ellipse is the incircle (the
    optimum is unique and the polygon's symmetries map it to itself), E2 = I, x = 0; all k sides bind."""
    t = 2 * np.pi * np.arange(k) / k + 0.1
    x, E2, _ = max_volume_inscribed(np.column_stack([np.cos(t), np.sin(t)]), np.ones(k))
    np.testing.assert_allclose(x, 0.0, atol=1e-9)
    np.testing.assert_allclose(E2, np.eye(2), atol=1e-9)


def test_no_interior_raises():
    """A start on the boundary or outside, a flat polytope, an empty one, an unbounded one (no
    Chebyshev ball, or a ball but no bounded ellipsoid): SolverError naming the cause."""
    A, ones = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4)
    with pytest.raises(SolverError, match="not strictly inside"):
        max_volume_inscribed(A, ones, x0=np.array([1.0, 0.0]))
    with pytest.raises(SolverError, match="not strictly inside"):
        max_volume_inscribed(A, ones, x0=np.array([2.0, 0.0]))
    with pytest.raises(SolverError, match="no interior"):
        max_volume_inscribed(A, np.array([1.0, 0.0, 1.0, 0.0]))        # 0 <= x2 <= 0
    with pytest.raises(SolverError, match="no interior"):
        max_volume_inscribed(A, np.array([1.0, 1.0, -2.0, 1.0]))       # 2 <= x1 <= 1
    with pytest.raises(SolverError, match="LP failed"):
        max_volume_inscribed(np.array([[1.0, 0.0]]), np.array([1.0]))
    with pytest.raises(SolverError, match="do not bound"):
        max_volume_inscribed(np.array([[0.0, 1.0], [0.0, -1.0]]), np.ones(2))


def test_inner_ellipsoid_is_solved_by_the_interior_point_method(monkeypatch):
    """sdp.inner_ellipsoid on strips with a prior box says the interior-point method answered; its
    ellipsoid lies in P and equals the one found with that method made to fail (Clarabel, the
    fallback) to 1e-6 in ln volume."""
    rng = np.random.default_rng(5)
    W = rng.normal(size=(200, 6))
    y = W @ rng.normal(size=6) + rng.uniform(-1, 1, 200)
    box = (np.full(6, -5.0), np.full(6, 5.0))
    r = sdp.inner_ellipsoid(Polytope.from_strips(W, y, 1.0, box=box))
    assert r.solver.startswith("interior point, Zhang-Gao (") and r.info["formulation"].startswith("multipliers")
    U = rng.normal(size=(2000, 6))
    U /= np.linalg.norm(U, axis=1)[:, None]
    P = Polytope.from_strips(W, y, 1.0, box=box)
    assert np.all(P.contains(r.ellipsoid.center + U @ np.linalg.cholesky(r.ellipsoid.shape).T, rtol=1e-9))

    def fails(A, b, x0=None):
        raise SolverError("inner_ellipsoid: made to fail")

    monkeypatch.setattr(sdp, "max_volume_inscribed", fails)
    ref = sdp.inner_ellipsoid(P)
    assert ref.solver == "CLARABEL"
    assert r.ellipsoid.log_volume() == pytest.approx(ref.ellipsoid.log_volume(), abs=1e-6)
