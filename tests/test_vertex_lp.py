"""The dense vertex simplex of the working-set LPs, against scipy's linprog (HiGHS through scipy,
a separate model built from the same numbers) and against closed forms on degenerate
polytopes; and the working-set LP's hand-over to HiGHS when the vertex simplex gives up."""

import numpy as np
import pytest
from scipy.optimize import linprog

from boundid.sets._vertex_lp import INFEASIBLE, NO_START, OPTIMAL, REACHED, STEP_LIMIT, UNBOUNDED, vertex_simplex
from boundid.sets._working_set import Block, LPStatusError, WorkingSetLP


def _dense(G, lo, up, col_lo, col_hi):
    n = G.shape[1]
    return np.vstack([np.eye(n), G]), np.concatenate([col_lo, lo]), np.concatenate([col_hi, up])


def _linprog_max(d, G, lo, up, col_lo, col_hi):
    A_ub = np.vstack([G[np.isfinite(up)], -G[np.isfinite(lo)]])
    b_ub = np.concatenate([up[np.isfinite(up)], -lo[np.isfinite(lo)]])
    res = linprog(-d, A_ub=A_ub, b_ub=b_ub, bounds=list(zip(col_lo, col_hi, strict=True)), method="highs")
    assert res.status == 0
    return -res.fun


def _corner(d):
    return np.arange(d.size), np.where(d >= 0, 1.0, -1.0)


def _strips(rng, m, n):
    """m random unit strips around a point inside, most of them cutting the box [-1, 1]^n."""
    G = rng.normal(size=(m, n))
    G /= np.linalg.norm(G, axis=1)[:, None]
    c = G @ rng.uniform(-0.2, 0.2, n)
    half = rng.uniform(0.3, 1.5, m)
    return G, c - half, c + half


def test_optima_and_certificates_match_linprog():
    rng = np.random.default_rng(0)
    n, m = 8, 300
    G, lo, up = _strips(rng, m, n)
    col_lo, col_hi = -np.ones(n), np.ones(n)
    A, LO, UP = _dense(G, lo, up, col_lo, col_hi)
    act = side = None
    for _ in range(40):
        d = rng.normal(size=n)
        if act is None:                              # the first from the box corner (dual simplex)
            act, side = _corner(d)
        status, x, lam, _ = vertex_simplex(A, LO, UP, d, act, side, 1e-10, 1e-10, 10_000)
        assert status == OPTIMAL                     # later ones warm, from the last vertex (primal)
        assert d @ x == pytest.approx(_linprog_max(d, G, lo, up, col_lo, col_hi), abs=1e-9)
        # the certificate: d = N^T lam with lam >= 0 over the basis rows, all active at x
        N = side[:, None] * A[act]
        np.testing.assert_allclose(N.T @ lam, d, atol=1e-10)
        assert lam.min() >= -1e-10
        np.testing.assert_allclose(N @ x, np.where(side > 0, UP[act], -LO[act]), atol=1e-10)
        assert np.all(A @ x <= UP + 1e-10) and np.all(A @ x >= LO - 1e-10)


@pytest.mark.parametrize("n", [3, 6])
def test_degenerate_cross_polytope(n):
    """|z|_1 <= 1 as 2^n rows: every vertex lies on 2^(n-1) of them (far more than n, the most
    degenerate vertex there is); max d^T z = |d|_inf (closed form)."""
    signs = np.array(np.meshgrid(*[[-1.0, 1.0]] * n)).reshape(n, -1).T
    G = signs / np.sqrt(n)
    up = np.full(len(G), 1 / np.sqrt(n))
    A, LO, UP = _dense(G, np.full(len(G), -np.inf), up, -2 * np.ones(n), 2 * np.ones(n))
    rng = np.random.default_rng(1)
    act = side = None
    for d in [*np.eye(n), *(-np.eye(n)), *rng.normal(size=(20, n)), np.ones(n)]:
        if act is None:
            act, side = _corner(d)
        status, x, _, _ = vertex_simplex(A, LO, UP, d, act, side, 1e-10, 1e-10, 10_000)
        assert status == OPTIMAL
        assert d @ x == pytest.approx(np.abs(d).max(), abs=1e-12)


def test_gives_up_with_a_status():
    n = 3
    G = np.array([[1.0, 0.0, 0.0]])
    # infeasible: x_0 >= 2 inside the box [-1, 1]^3 (the dual simplex finds no leaving row)
    A, LO, UP = _dense(G, np.array([2.0]), np.array([3.0]), -np.ones(n), np.ones(n))
    act, side = _corner(np.ones(n))
    assert vertex_simplex(A, LO, UP, np.ones(n), act, side, 1e-10, 1e-10, 100)[0] == INFEASIBLE
    # unbounded: no upper bound along x_2 (start at a vertex of the lower corner)
    A, LO, UP = _dense(G, np.array([-1.0]), np.array([1.0]), -np.ones(n), np.array([1.0, 1.0, np.inf]))
    act, side = np.arange(n), -np.ones(n)
    assert vertex_simplex(A, LO, UP, np.ones(n), act, side, 1e-10, 1e-10, 100)[0] == UNBOUNDED
    # no step allowed; and a start that is neither primal nor dual feasible
    A, LO, UP = _dense(G, np.array([-1.0]), np.array([0.5]), -np.ones(n), np.ones(n))
    act, side = _corner(np.ones(n))
    assert vertex_simplex(A, LO, UP, np.ones(n), act.copy(), side.copy(), 1e-10, 1e-10, 0)[0] == STEP_LIMIT
    assert vertex_simplex(A, LO, UP, -np.ones(n), act, side, 1e-10, 1e-10, 100)[0] == NO_START


def test_working_set_lp_matches_linprog_without_highs():
    rng = np.random.default_rng(2)
    n, m = 10, 2000
    G, lo, up = _strips(rng, m, n)
    lp = WorkingSetLP([Block(G, lo.copy(), up.copy())], -np.ones(n), np.ones(n), tol=1e-9)
    D = rng.normal(size=(30, n))
    vals, V, which = lp.supports(D)
    ref = np.array([_linprog_max(d, G, lo, up, -np.ones(n), np.ones(n)) for d in D])
    np.testing.assert_allclose(vals, ref, atol=1e-9)
    np.testing.assert_allclose(np.einsum("ij,ij->i", D, V[which]), vals, atol=1e-12)
    assert lp.n_highs == 0 and lp.n_solves > 0


def test_highs_answers_when_the_vertex_simplex_cannot_start():
    """No finite column bounds and no basis yet: HiGHS solves, its basis seeds the next solves;
    an infeasible working set is reported by HiGHS's verdict."""
    rng = np.random.default_rng(3)
    n = 4
    G, lo, up = _strips(rng, 40, n)
    lp = WorkingSetLP([Block(G, lo.copy(), up.copy())], np.full(n, -np.inf), np.full(n, np.inf),
                      seed=[(0, np.arange(40))], tol=1e-9)
    d = rng.normal(size=n)
    x, _ = lp.minimize(-d)
    assert lp.n_highs == 1
    assert d @ x == pytest.approx(_linprog_max(d, G, lo, up, np.full(n, -np.inf), np.full(n, np.inf)), abs=1e-9)
    lp.minimize(-rng.normal(size=n))                 # warm from HiGHS's basis: no second hand-over
    assert lp.n_highs == 1
    bad = WorkingSetLP([Block(np.eye(n)[:1], np.array([2.0]), np.array([3.0]))], -np.ones(n), np.ones(n),
                       seed=[(0, np.arange(1))])
    with pytest.raises(LPStatusError, match="infeasible"):
        bad.minimize(np.ones(n))
    assert bad.n_highs == 1


def test_bound_flip_instead_of_a_false_unbounded_edge():
    """The box [-1, 1]^2 from the corner (1, 1), max -x0 + x1/2: the edge leaving x0 <= 1 ends at
    x0 >= -1, the other side of the same row (a bound flip); optimum 1.5 at (-1, 1)."""
    A, LO, UP = _dense(np.zeros((0, 2)), np.zeros(0), np.zeros(0), -np.ones(2), np.ones(2))
    act, side = np.arange(2), np.ones(2)
    status, x, _, _ = vertex_simplex(A, LO, UP, np.array([-1.0, 0.5]), act, side, 1e-10, 1e-10, 100)
    assert status == OPTIMAL
    np.testing.assert_allclose(x, [-1.0, 1.0])


def test_no_false_optimum_from_a_bad_basis():
    """A basis row on an infinite side (no vertex) or whose own bounds cross (lo > up) is never
    certified optimal."""
    A, LO, UP = _dense(np.array([[1.0, 1.0]]) / np.sqrt(2), np.array([-np.inf]), np.array([np.inf]),
                       -np.ones(2), np.ones(2))
    status, x, _, _ = vertex_simplex(A, LO, UP, np.ones(2), np.array([0, 2]), np.ones(2), 1e-10, 1e-10, 100)
    assert status != OPTIMAL
    A, LO, UP = _dense(np.array([[1.0, 1.0]]) / np.sqrt(2), np.array([0.5]), np.array([0.2]), -np.ones(2), np.ones(2))
    status, x, _, _ = vertex_simplex(A, LO, UP, np.ones(2), np.array([0, 2]), np.ones(2), 1e-10, 1e-10, 100)
    assert status != OPTIMAL


def test_polytope_without_a_prior_box_needs_highs_once():
    """Without a prior box the first frame has no finite corner: HiGHS answers the first LP, its
    basis then carries the vertex simplex (bound flips keep it from false unbounded edges).
    Reference: the LP bounds against linprog on the same strips."""
    rng = np.random.default_rng(0)
    p, N, e = 6, 3000, 0.05
    W = rng.normal(size=(N, p))
    W = np.cumsum(W, axis=0) * 0.05 + W
    y = W @ rng.normal(size=p) + rng.uniform(-e, e, N)
    from boundid.sets.polytope import Polytope

    P = Polytope(W, y, e)
    b = P.bounds()
    assert P._engine.n_highs <= 1
    A_ub, b_ub = np.vstack([W, -W]), np.concatenate([y + e, e - y])
    for j in range(p):
        c = np.eye(p)[j]
        lo = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * p, method="highs",
                     options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}).fun
        assert b.lo[j] == pytest.approx(lo, abs=1e-7 * (b.hi[j] - b.lo[j]))


def test_new_objective_starts_at_the_best_remembered_optimum(monkeypatch):
    """A new objective starts at the archived optimum of the pool with the lowest cost: asked again
    for a direction solved earlier (after others moved the last basis away), its first simplex
    run starts at that direction's own optimal basis and takes no step; the answers still match
    linprog (an independent solver)."""
    import boundid.sets._working_set as ws

    rng = np.random.default_rng(4)
    n, m = 8, 1500
    G, lo, up = _strips(rng, m, n)
    lp = WorkingSetLP([Block(G, lo.copy(), up.copy())], -np.ones(n), np.ones(n), tol=1e-9)
    D = rng.normal(size=(12, n))
    for d in D:
        lp.minimize_many(-d[None, :])
    steps = []
    real = ws.vertex_simplex

    def counting(*args):
        out = real(*args)
        steps.append(out[3])
        return out

    monkeypatch.setattr(ws, "vertex_simplex", counting)
    x = lp.minimize_many(-D[0][None, :])[0]
    assert steps[0] == 0
    assert D[0] @ x == pytest.approx(_linprog_max(D[0], G, lo, up, -np.ones(n), np.ones(n)), abs=1e-9)


def test_simplex_stops_at_its_target_on_the_way_to_the_optimum():
    """With a target below the optimum the primal simplex stops at a vertex at or beyond it (REACHED),
    a feasible point with fewer steps; with one above, the optimum as without a target."""
    rng = np.random.default_rng(5)
    n, m = 8, 400
    G, lo, up = _strips(rng, m, n)
    col_lo, col_hi = -np.ones(n), np.ones(n)
    A, LO, UP = _dense(G, lo, up, col_lo, col_hi)
    d0 = rng.normal(size=n)
    act, side = _corner(d0)
    assert vertex_simplex(A, LO, UP, d0, act, side, 1e-10, 1e-10, 10_000)[0] == OPTIMAL
    reached = 0
    for _ in range(20):
        d = rng.normal(size=n)
        best = _linprog_max(d, G, lo, up, col_lo, col_hi)
        start = d @ vertex_simplex(A, LO, UP, d, act.copy(), side.copy(), 1e-10, 1e-10, 0)[1]
        target = start + 0.3 * (best - start)
        status, x, _, steps = vertex_simplex(A, LO, UP, d, act.copy(), side.copy(), 1e-10, 1e-10, 10_000, target)
        full = vertex_simplex(A, LO, UP, d, act.copy(), side.copy(), 1e-10, 1e-10, 10_000)
        assert status in (REACHED, OPTIMAL)
        assert target <= d @ x <= best + 1e-9
        assert np.all(A @ x <= UP + 1e-9) and np.all(A @ x >= LO - 1e-9)
        assert steps <= full[3]
        reached += status == REACHED
        status, x, _, _ = vertex_simplex(A, LO, UP, d, act.copy(), side.copy(), 1e-10, 1e-10, 10_000, best + 1.0)
        assert status == OPTIMAL and d @ x == pytest.approx(best, abs=1e-9)
    assert reached >= 10


def test_reaches_settles_each_direction_at_its_target_or_its_support():
    """WorkingSetLP.reaches over a pool: each answer is a point of the polytope (every pool row
    holds) at or beyond its target, or, where the support falls short (or a normal cone shares an
    optimum), the support itself, flagged exact; supports against linprog."""
    rng = np.random.default_rng(6)
    n, m = 10, 2000
    G, lo, up = _strips(rng, m, n)
    lp = WorkingSetLP([Block(G, lo.copy(), up.copy())], -np.ones(n), np.ones(n), tol=1e-9)
    D = rng.normal(size=(40, n))
    ref = np.array([_linprog_max(d, G, lo, up, -np.ones(n), np.ones(n)) for d in D])
    targets = np.where(np.arange(40) % 4 == 0, ref + 0.1, ref - 0.3 * np.abs(ref))
    vals, V, which, exact = lp.reaches(D, targets)
    X = V[which]
    np.testing.assert_allclose(np.einsum("ij,ij->i", D, X), vals, atol=1e-12)
    assert np.all(G @ X.T <= up[:, None] + 1e-9) and np.all(G @ X.T >= lo[:, None] - 1e-9)
    np.testing.assert_allclose(vals[exact], ref[exact], atol=1e-9)
    assert np.all(vals[~exact] >= targets[~exact]) and np.all(vals <= ref + 1e-9)
    assert np.all(exact[targets > ref])              # a target beyond the support: the support
    assert (~exact).sum() >= 10


def test_reaches_in_two_threads_equal_one_engine_and_share_rows():
    """The directions split between an engine and its clone, solved in two threads, give the supports
    linprog gives (exact ones) or points of the polytope past their targets, as one engine does;
    afterwards both engines hold the union of their rows, and BLAS has its own thread limit back."""
    from threadpoolctl import threadpool_info

    from boundid.sets._working_set import reaches_in_threads
    rng = np.random.default_rng(7)
    n, m = 10, 2000
    G, lo, up = _strips(rng, m, n)
    lp = WorkingSetLP([Block(G, lo.copy(), up.copy())], -np.ones(n), np.ones(n), tol=1e-9)
    lp.supports(rng.normal(size=(3, n)))
    twin = lp.clone()
    D = rng.normal(size=(40, n))
    ref = np.array([_linprog_max(d, G, lo, up, -np.ones(n), np.ones(n)) for d in D])
    targets = np.where(np.arange(40) % 2 == 0, np.inf, ref - 0.3 * np.abs(ref))
    limits = [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]
    vals, V, which, exact = reaches_in_threads([lp, twin], D, targets)
    assert [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"] == limits
    np.testing.assert_allclose(np.einsum("ij,ij->i", D, V[which]), vals, atol=1e-12)
    np.testing.assert_allclose(vals[exact], ref[exact], atol=1e-9)
    assert np.all(exact[::2]) and np.all(vals[~exact] >= targets[~exact])
    X = V[which]
    assert np.all(G @ X.T <= up[:, None] + 1e-9) and np.all(G @ X.T >= lo[:, None] - 1e-9)
    assert np.array_equal(lp.ws_rows(0), twin.ws_rows(0))


def test_pruned_working_set_gives_the_same_supports_and_keeps_its_bases_consistent():
    """An engine whose working set is cut back whenever a call starts above max_rows answers every
    support as linprog does; it is cut back (its size falls) and stays small; after a prune the working
    set holds each row at its own pool row, and a remembered start whose rows were dropped brings them
    back."""
    rng = np.random.default_rng(11)
    n, m = 12, 3000
    G, lo, up = _strips(rng, m, n)
    small = WorkingSetLP([Block(G, lo.copy(), up.copy())], -np.ones(n), np.ones(n), tol=1e-9, max_rows=60)
    D = rng.normal(size=(60, n))
    D[30:] = D[:30] + 0.05 * rng.normal(size=(30, n))      # near the earlier directions: remembered starts
    ref = np.array([_linprog_max(d, G, lo, up, -np.ones(n), np.ones(n)) for d in D])
    sizes = []
    for d, r in zip(D, ref, strict=True):
        val = small.supports(d[None, :])[0][0]
        assert val == pytest.approx(r, abs=1e-9)
        sizes.append(small.n_rows)
    assert max(sizes) < 4 * 60 and any(b < a for a, b in zip(sizes, sizes[1:], strict=False))
    assert sum(small.in_ws[0]) == small.n_rows          # in_ws and the rows of _A agree
    k = small.ws_rows(0)
    np.testing.assert_array_equal(small._A[n + small.row_of[0][k]], G[k])
    np.testing.assert_array_equal(small._key[n + small.row_of[0][k]], k)
    small.prune()
    dropped = [keys[keys >= 0] for keys, _ in small._archive if not small.in_ws_key(keys[keys >= 0]).all()]
    assert dropped                                     # some remembered basis lost rows ...
    rows = small._rows_of_keys(dropped[0])             # ... which come back, each at its own row
    assert small.in_ws_key(dropped[0]).all()
    np.testing.assert_array_equal(small._A[rows], G[dropped[0]])
    x, _ = small.minimize(-D[0])
    assert -D[0] @ x == pytest.approx(-ref[0], abs=1e-9)


def test_objectives_solved_before_rows_come_back_are_checked_against_them():
    """A solve may add rows to the working set (a remembered start's pruned rows, the rows a vertex past
    its target violates). Here the second objective's solve adds exactly the rows the first one's answer
    violates, which the pass over the pool then skips as rows of the working set: the first objective
    must still be solved again, and every argmin equals linprog's optimum and satisfies every row."""
    rng = np.random.default_rng(5)
    n, m = 10, 2000
    G, lo, up = _strips(rng, m, n)
    lp = WorkingSetLP([Block(G, lo.copy(), up.copy())], -np.ones(n), np.ones(n), tol=1e-9)
    C = np.vstack([np.eye(n)[0], -np.eye(n)[0]])
    solve, answers = lp._solve, []

    def solve_adding_rows(cost, **kw):
        out = solve(cost, **kw)
        answers.append(out[0])
        if len(answers) == 2:                       # the rows the first answer violates, added mid-round
            x = answers[0]
            lp.add_rows(0, np.flatnonzero((G @ x > up + 1e-9) | (G @ x < lo - 1e-9)))
        return out

    lp._solve = solve_adding_rows
    X = lp.minimize_many(C)
    first = answers[0]
    assert np.any((G @ first > up + 1e-9) | (G @ first < lo - 1e-9))      # the case arose
    ref = np.array([-_linprog_max(-c, G, lo, up, -np.ones(n), np.ones(n)) for c in C])
    np.testing.assert_allclose(np.einsum("ij,ij->i", C, X), ref, atol=1e-9)
    assert np.all(G @ X.T <= up[:, None] + 1e-9) and np.all(G @ X.T >= lo[:, None] - 1e-9)


def test_prune_keeps_the_rows_that_bound_the_lps():
    """A direction the strips do not see, closed only by two seeded halfspace rows (no column bound):
    after many solves on one side and prunes down to a few rows, the other side's optimum is still
    bounded and equal to linprog's (the seed's rows survive every prune, in copies too)."""
    rng = np.random.default_rng(3)
    n, m = 6, 800
    G, lo, up = _strips(rng, m, n)
    G[:, -1] = 0.0                                  # the strips never see the last coordinate
    H = np.zeros((2, n))
    H[0, -1], H[1, -1] = 1.0, -1.0                  # -2 <= x_last <= 3, as two one-sided rows
    halves = Block(H, np.full(2, -np.inf), np.array([3.0, 2.0]))
    cols = (np.append(-np.ones(n - 1), -np.inf), np.append(np.ones(n - 1), np.inf))     # the last one open
    lp = WorkingSetLP([Block(G, lo.copy(), up.copy()), halves], *cols, seed=[(1, np.arange(2))], tol=1e-9,
                      max_rows=20)
    for _ in range(30):
        d = rng.normal(size=n)
        d[-1] = abs(d[-1])                          # maximising up the last coordinate: the upper row active
        lp.supports(d[None, :])
    for eng in (lp, lp.clone()):
        eng.prune()
        assert eng.in_ws[1].all()
        d = np.zeros(n)
        d[-1] = -1.0
        assert eng.supports(d[None, :])[0][0] == pytest.approx(2.0, abs=1e-9)
