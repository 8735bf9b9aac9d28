"""The conic programs of the physically consistent bounds, solved by Clarabel directly
(:class:`boundid.sets.physical._StripProgram`: one shared working set of strips, then one of its own
for each objective still violating strips; each strip an equality row and a bounded variable of its own).

Independent references: one cvxpy problem per optimum written here with every strip at once, no
constraint generation, no scaling and no lift variable of the package's (Clarabel through cvxpy); the
package's other solve path (:meth:`boundid.sets.conic.ConicProblem.minimize_many`, two rows per strip,
through cvxpy) on the same scaled problem; the inner product of two symmetric matrices for the
triangle vectors of the PSD cones.

The cases are small random ones with LMIs: rigid bodies from random point masses (their pseudo-inertia
is the sum of m [r; 1][r; 1]^T, positive semidefinite), random regression rows, bounded noise.
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

import boundid.sets.physical as physical
from boundid.errors import InputError, SolverError
from boundid.sets.conic import ConicProblem, InfeasibleProblem, Pool
from boundid.sets.constraints import constraints, nonnegative, pseudo_inertia
from boundid.sets.physical import PhysicalSet, _smat, _StripProgram, _svec
from boundid.sets.polytope import Polytope

# ---------------------------------------------------------------------- random cases


def body(rng, n_points=5):
    """Standard parameters [m, hx, hy, hz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] of a body of random point
    masses (I about the frame origin)."""
    m = rng.uniform(0.5, 2.0, n_points)
    r = rng.normal(0.0, 0.3, (n_points, 3))
    inertia = sum(mk * (rk @ rk * np.eye(3) - np.outer(rk, rk)) for mk, rk in zip(m, r, strict=True))
    h = m @ r
    return np.array([m.sum(), *h, inertia[0, 0], inertia[0, 1], inertia[1, 1], inertia[0, 2], inertia[1, 2],
                     inertia[2, 2]])


def random_case(seed, n_bodies=2, n_friction=2, rows=50, e=0.4, lift=False):
    """(W, y, e, constraints, box, truth): n_bodies pseudo-inertia LMIs and n_friction nonnegative
    parameters on x. Without a lift theta = x; with one (two bodies) the regrouping of base
    parameters: theta = K x = (x1 + A (m2, h2), inertia of body 2, friction), A (10, 4) random: body
    2's mass and first moments only act through body 1's parameters, so every theta has a
    4-dimensional family of standard parameters x (the null space of K)."""
    rng = np.random.default_rng(seed)
    n = 10 * n_bodies + n_friction
    names = [f"x{j}" for j in range(n)]
    lmis = [pseudo_inertia(n, 10 * b, f"J{b} >= 0", "a body") for b in range(n_bodies)]
    fric = list(range(10 * n_bodies, n))
    cons = constraints(names, linear=nonnegative(names, fric, ["friction"] * len(fric)), lmis=lmis)
    x = np.concatenate([body(rng) for _ in range(n_bodies)] + [rng.uniform(0.2, 1.0, n_friction)])
    theta = x
    if lift:
        assert n_bodies == 2
        K = np.zeros((16 + n_friction, n))
        K[:10, :10] = np.eye(10)
        K[:10, 10:14] = rng.normal(0.0, 0.5, (10, 4))
        K[10:16, 14:20] = np.eye(6)
        K[16:, 20:] = np.eye(n_friction)
        cons = cons.lifted(K)
        theta = K @ x
    p = theta.size
    W = rng.normal(0.0, 1.0, (rows, p))
    y = W @ theta + rng.uniform(-e, e, rows)
    box = (theta - 3.0, theta + 3.0)
    return W, y, e, cons, box, theta


def reference_bounds(W, y, e, cons, box):
    """min and max of every theta_j over every strip, the box and the constraints: 2p cvxpy problems."""
    x = cp.Variable(cons.dim)
    theta = x if not cons.is_lifted else cons.lift @ x
    parts = [cp.abs(y - W @ theta) <= e, theta >= box[0], theta <= box[1]]
    if cons.linear.m:
        parts.append(cons.linear.A @ x <= cons.linear.b)
    for L in cons.lmis:
        M = L.F0 + sum(x[i] * L.F[i] for i in range(cons.dim) if np.any(L.F[i]))
        parts.append(0.5 * (M + M.T) >> 0)
    p = W.shape[1]
    lo, hi = np.empty(p), np.empty(p)
    for j in range(p):
        lo[j] = cp.Problem(cp.Minimize(theta[j]), parts).solve(solver=cp.CLARABEL)
        hi[j] = cp.Problem(cp.Maximize(theta[j]), parts).solve(solver=cp.CLARABEL)
    return lo, hi


# ---------------------------------------------------------------------- against every strip at once


@pytest.mark.parametrize("seed", [0, 1])
def test_bounds_match_every_strip_at_once(seed):
    """No lift: the bounds equal the all-strips cvxpy optima to 1e-6 of the widths; the certificate
    is the dual bound (proven and attained values within 1e-6 half-widths, the proven ones outside);
    every optimum is a point of the set; the LMIs narrow some intervals (so the conic programs decide
    them)."""
    W, y, e, cons, box, theta = random_case(seed)
    S = PhysicalSet(W, y, e, cons, box=box)
    b = S.bounds()
    lo, hi = reference_bounds(W, y, e, cons, box)
    w = hi - lo
    assert b.method == "SOCP/SDP (Clarabel)" and b.certificate == "dual bound" and b.info["dual_gap"] < 1e-6
    assert np.max(np.abs(b.lo - lo) / w) < 1e-6 and np.max(np.abs(b.hi - hi) / w) < 1e-6
    # the attained values are points of the set to PRIMAL_TOL (1e-6 half-widths)
    assert np.all(b.lo <= b.lo_attained + 1e-6 * w) and np.all(b.hi >= b.hi_attained - 1e-6 * w)
    assert np.all((b.lo <= theta) & (theta <= b.hi))
    pb = S.plain.bounds()
    assert np.sum(b.hi - b.lo < 0.99 * (pb.hi - pb.lo)) >= 1
    X = b.vertices()
    assert np.all(cons.violations(X) <= 1e-6) and np.all(np.abs(y[:, None] - W @ X.T) <= e + 1e-6)


def test_lifted_bounds_match_every_strip_at_once():
    """theta = K x (base parameters of two bodies): the attained bounds equal the all-strips cvxpy
    optima over x to 1e-5 of the widths (the solver's accuracy on the lifted problems, as in
    test_physical); the LMIs narrow some intervals; every optimum's standard parameters satisfy the
    LMIs and map to it."""
    W, y, e, cons, box, theta = random_case(3, lift=True)
    S = PhysicalSet(W, y, e, cons, box=box)
    b = S.bounds()
    lo, hi = reference_bounds(W, y, e, cons, box)
    w = hi - lo
    assert b.certificate == "attained"
    assert np.max(np.abs(b.lo - lo) / w) < 1e-5 and np.max(np.abs(b.hi - hi) / w) < 1e-5
    pb = S.plain.bounds()
    assert np.sum(b.hi - b.lo < 0.99 * (pb.hi - pb.lo)) >= 1
    for X, Theta in ((b.standard_argmin, b.argmin), (b.standard_argmax, b.argmax)):
        assert np.all(cons.violations(X) <= 1e-6 * np.maximum(1.0, np.abs(X).max(axis=1))[:, None])
        np.testing.assert_allclose(X @ cons.lift.T, Theta, atol=1e-8 * np.abs(X).max())


# ---------------------------------------------------------------------- against the cvxpy path


def scaled_problem(seed):
    """A ConicProblem in box coordinates (an LMI, a nonnegative row, a box) and strips on it, as
    PhysicalSet builds them: (prob, G, c, h, seed strips)."""
    W, y, e, cons, box, _ = random_case(seed, n_bodies=1, rows=40)
    S = PhysicalSet(W, y, e, cons, box=box)
    origin, scale, lp_box = S._frame()
    V = physical._variables(cons, origin, scale)
    zlo, zhi = S._z_box(origin, scale, lp_box)
    prob = ConicProblem(V.n, box=(zlo, zhi), what="test bounds")
    S._constraint_parts(prob, V)
    G, c, h = S._strips(origin, scale)
    return prob, G, c, h, S._seed(G, c, h, (S.plain.bounds().vertices() - origin) / scale)


@pytest.mark.parametrize("seeded", [True, False])
def test_strip_program_matches_the_cvxpy_path(seeded):
    """The same objectives on the same scaled problem: _StripProgram and ConicProblem.minimize_many
    (two rows per strip, through cvxpy) give the same optima to 1e-7; each optimum satisfies every
    strip; each dual bound is below its optimum and within 1e-6 of it. Without a seed the working set
    starts empty: the queue adds the violated strips, and the objectives whose first optimum violated
    strips are finished alone, on working sets of their own."""
    prob, G, c, h, seed = scaled_problem(4)
    seed = seed if seeded else np.zeros(0, dtype=int)
    n = prob.n
    costs = np.vstack([np.eye(n), -np.eye(n)])

    def rows(idx):
        return np.vstack([G[idx], -G[idx]]), np.concatenate([c[idx] + h[idx], h[idx] - c[idx]])

    def violation(V):
        return np.abs(G @ V - c[:, None]) - h[:, None]

    ref = prob.minimize_many(costs, Pool(rows, violation, len(h)), seed=seed)
    r = _StripProgram(prob, G, c, h).minimize_many(costs, seed=seed)
    np.testing.assert_allclose(r.values, ref.values, atol=1e-7)
    assert np.all(violation(r.points.T) <= 1e-7)
    assert np.all(r.dual <= r.values + 1e-12) and np.all(r.values - r.dual < 1e-6)
    assert set(r.status) <= {"optimal", "optimal_inaccurate"}
    if not seeded:
        assert r.info["solves"] > 2 * n and r.info["rounds"] > 1 and r.info["working_rows"] > 0
        assert r.info["finished_alone"] > 0 and r.info["solves_alone"] >= r.info["finished_alone"]


def test_triangle_vectors_keep_the_inner_product():
    """Clarabel's PSD-triangle vectors: <svec A, svec B> = trace(A B) for symmetric A, B, and _smat
    inverts _svec (the dual bound projects the LMI multipliers through them)."""
    rng = np.random.default_rng(5)
    for k in (1, 3, 4):
        A, B = rng.normal(size=(2, k, k))
        A, B = A + A.T, B + B.T
        assert _svec(A) @ _svec(B) == pytest.approx(np.trace(A @ B))
        np.testing.assert_allclose(_smat(_svec(A), k), A, atol=1e-15)


# ---------------------------------------------------------------------- failures, reuse


def test_infeasible_fixed_part_raises_infeasible_problem():
    """A box the LMI cannot meet (mass <= -1): Clarabel proves it infeasible, the caller is told."""
    prob = ConicProblem(10, box=(np.full(10, -2.0), np.full(10, 2.0)), what="test")
    prob.add_le(np.eye(10)[:1], [-1.0])
    L = pseudo_inertia(10, 0, "J", "a body")
    prob.add_lmi(L.F0, L.F)
    G = np.eye(10)[:2]
    with pytest.raises(InfeasibleProblem):
        _StripProgram(prob, G, np.zeros(2), np.ones(2)).minimize_many(np.eye(10)[:1])


def test_solver_failure_of_the_bounds_raises_solver_error(monkeypatch):
    """A Clarabel that fails (raises, twice: the retry too) gives SolverError with the package's
    advice, not a wrong answer."""
    W, y, e, cons, box, _ = random_case(0)
    S = PhysicalSet(W, y, e, cons, box=box)
    S.plain.bounds()

    class Failing:
        def __init__(self, *a, **k):
            raise RuntimeError("stalled")
    monkeypatch.setattr(physical.clarabel, "DefaultSolver", Failing)
    with pytest.raises(SolverError, match="scaled coordinates"):
        S.bounds()


def test_a_given_plain_polytope_is_reused():
    """plain=P: the same bounds as without it, P's own LP bounds reused (the same object); a polytope
    of other data is refused."""
    W, y, e, cons, box, _ = random_case(1, n_bodies=1, rows=30)
    P = Polytope(W, y, e, box=box)
    pb = P.bounds()
    S = PhysicalSet(W, y, e, cons, box=box, plain=P)
    assert S.plain is P and S.plain.bounds() is pb
    b, ref = S.bounds(), PhysicalSet(W, y, e, cons, box=box).bounds()
    np.testing.assert_array_equal(b.lo, ref.lo)
    np.testing.assert_array_equal(b.hi, ref.hi)
    with pytest.raises(InputError, match="same W"):
        PhysicalSet(W, y, e, cons, box=box, plain=Polytope(W, y + 1.0, e, box=box))
