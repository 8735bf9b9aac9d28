"""Tests of the recursive set families (boundid.estimators: box, parallelotope, zonotope, exact and
limited polytope recursions, boxed and windowed OBE).

Independent references: the guarantee itself (the truth must lie in every set); the exact hull
of set ∩ strip by vertex enumeration (scipy HalfspaceIntersection / ConvexHull, Qhull); the exact
LP bounds and vertices of the feasible polytope (boundid.sets.Polytope, HiGHS); a numerical
optimiser (scipy.optimize.minimize) for the zonotope's F-radius step; brute force over the
parallelotope's p + 1 candidates; and the plain-numpy statement of each step for the compiled
loops.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import linprog, minimize
from scipy.spatial import ConvexHull, HalfspaceIntersection

from boundid.errors import InfeasibleDataError, InputError
from boundid.estimators import (
    OBE,
    BoxedOBE,
    BoxRecursion,
    LimitedPolytopeRecursion,
    ParallelotopeRecursion,
    PolytopeRecursion,
    WindowedOBE,
    ZonotopeRecursion,
)
from boundid.estimators import _set_kernels as K
from boundid.estimators.box_recursion import box_step
from boundid.estimators.parallelotope_recursion import parallelotope_step
from boundid.estimators.zonotope_recursion import segments, zonotope_step
from boundid.sets import Box, ConvexSet, Ellipsoid, Parallelotope, Polytope, Zonotope

FAMILIES = {
    "box": lambda p, **kw: BoxRecursion(p, **kw),
    "parallelotope": lambda p, **kw: ParallelotopeRecursion(p, **kw),
    "zonotope": lambda p, **kw: ZonotopeRecursion(p, **kw),
    "polytope": lambda p, **kw: PolytopeRecursion(p, **kw),
    "limited": lambda p, **kw: LimitedPolytopeRecursion(p, max_strips=2 * p, block=3, **kw),
    "boxed_obe": lambda p, **kw: BoxedOBE(p, box_every=4, **kw),
    "windowed_obe": lambda p, **kw: WindowedOBE(p, window=8, **kw),
}
MODES = ("uniform", "at the bound", "alternating", "adversarial")


# ---------------------------------------------------------------------------- helpers
def _exact_vertices(A, b):
    """Vertices of {x : A x <= b} (bounded, with interior) by Qhull, the interior point being
    the Chebyshev centre (HiGHS via scipy.optimize.linprog)."""
    nrm = np.linalg.norm(A, axis=1)
    res = linprog(np.r_[np.zeros(A.shape[1]), -1.0], A_ub=np.c_[A, nrm], b_ub=b,
                  bounds=[(None, None)] * A.shape[1] + [(0, None)], method="highs")
    assert res.status == 0 and res.x[-1] > 0
    hs = HalfspaceIntersection(np.c_[A, -b], res.x[:-1])
    V = hs.intersections
    return V[ConvexHull(V).vertices]


def _strip_rows(w, y, e):
    return np.vstack([w, -w]), np.array([y + e, e - y])


def _cutting_strip(rng, S, p):
    """A strip that cuts the set S (a ConvexSet): its width a random fraction of S's extent along w."""
    w = rng.normal(size=p)
    if p > 2 and rng.random() < 0.3:
        w[rng.integers(p)] = 0.0
    lo, hi = -S.support(-w), S.support(w)
    e = rng.uniform(0.05, 0.4) * (hi - lo)
    y = rng.uniform(lo + 0.2 * e, hi - 0.2 * e)
    return w, y, e


def _problem(seed, p, mode):
    """A random bounded-error problem: truth, rows, bounds, prior box (the truth inside it, or
    for one seed in three exactly on one of its faces), and how the errors are drawn."""
    rng = np.random.default_rng(seed)
    N = int(rng.integers(1, 41))
    theta = rng.normal(size=p)
    W = 10 ** rng.uniform(-3, 3) * rng.normal(size=(N, p))
    if rng.random() < 0.3:
        W[rng.random(W.shape) < 0.3] = 0.0
        W[np.all(W == 0, axis=1), 0] = 1.0
    e = rng.uniform(0.1, 1.0, N) * 10 ** rng.uniform(-2, 2)
    h0 = rng.uniform(2.0, 20.0, p)
    c0 = theta + 0.9 * rng.uniform(-1, 1, p) * h0
    if seed % 3 == 0:
        j = int(rng.integers(p))
        theta[j] = c0[j] + h0[j]          # exactly the box's upper side, as Box.from_center rounds it
    u = {"uniform": rng.uniform(-1, 1, N), "at the bound": rng.choice([-1.0, 1.0], N),
         "alternating": (-1.0) ** np.arange(N), "adversarial": None}[mode]
    return theta, W, e, c0, h0, u


def _misses_stepwise(make, p, seed, mode):
    """Feed the rows one at a time; returns (steps, steps where the truth is outside the set,
    outliers declared). Adversarial errors sit at the bound on the side that puts the truth on
    the cutting face: sign(w^T theta - w^T c) with c the current set's centre."""
    theta, W, e, c0, h0, u = _problem(seed, p, mode)
    est = make(p, prior=Box.from_center(c0, h0))
    center = est.prior.center
    misses = 0
    for k in range(W.shape[0]):
        uk = u[k] if u is not None else (1.0 if W[k] @ theta >= W[k] @ center else -1.0)
        yk = W[k] @ theta + uk * e[k]
        res = est.partial_fit(W[k:k + 1], [yk], e[k])
        misses += not res.set.contains(theta)
        center = res.center
    return W.shape[0], misses, res.outliers.size


def _property_run(family, n_problems, dims):
    total = 0
    for mode, p, seed in itertools.product(MODES, dims, range(n_problems)):
        steps, misses, outliers = _misses_stepwise(FAMILIES[family], p, 1000 * p + seed, mode)
        assert misses == 0 and outliers == 0, (family, mode, p, seed, misses, outliers)
        total += steps
    return total


# ---------------------------------------------------------------------------- the guarantee
_DIMS = {"polytope": (1, 2, 3, 4), "windowed_obe": (2, 3)}
_LONG_DIMS = {"polytope": (1, 2, 3, 4), "windowed_obe": (2, 3), "zonotope": (1, 2, 3, 5, 6)}


@pytest.mark.parametrize("family", list(FAMILIES))
def test_truth_inside_every_set_of_every_step(family):
    """Guarantee (no reference needed): with the truth in the prior box (a third of the problems
    on its face) and every error inside its bound, the truth lies in the set after every step,
    for uniform errors, errors exactly at the bound (random, alternating and adversarial signs),
    regressors scaled by 1e-3 .. 1e3 and sparse rows. Zero misses, zero outliers."""
    n = 1 if family == "windowed_obe" else 4
    _property_run(family, n, _DIMS.get(family, (1, 2, 3, 5)))


@pytest.mark.slow
@pytest.mark.parametrize("family", list(FAMILIES))
def test_truth_inside_every_set_of_every_step_long(family):
    """The same guarantee over many more random problems (see the fast version)."""
    n = 10 if family == "windowed_obe" else 60
    _property_run(family, n, _LONG_DIMS.get(family, (1, 2, 3, 5, 8)))


@pytest.mark.parametrize("family", list(FAMILIES))
@pytest.mark.parametrize("p", [2, 3])
def test_final_set_contains_the_exact_feasible_polytope(family, p):
    """Every vertex of the exact feasible polytope ∩ prior box (Polytope.vertices: LP bounds then
    Qhull) lies in the family's set, and every interval contains the exact LP interval."""
    rng = np.random.default_rng(50 + p)
    N = 60
    theta = rng.normal(size=p)
    W = rng.normal(size=(N, p))
    e = np.full(N, 0.3)
    y = W @ theta + rng.uniform(-1, 1, N) * e
    est = FAMILIES[family](p, prior=Box.from_center(np.zeros(p), 5.0)).fit(W, y, e)
    P = Polytope(W, y, e, box=(-5 * np.ones(p), 5 * np.ones(p)))
    assert np.all(est.set.contains(P.vertices()))
    b = P.bounds()
    lo, hi = est.intervals
    assert np.all(lo <= b.lo + 1e-9) and np.all(hi >= b.hi - 1e-9)


# ---------------------------------------------------------------------------- one step, exact hull
@pytest.mark.parametrize("p", [2, 3])
def test_box_step_is_the_exact_interval_hull(p):
    """Box step against the interval hull of the vertices of box ∩ strip (Qhull): equal to 1e-9
    of the box's width, and never inside it by more than rounding (outer)."""
    rng = np.random.default_rng(60 + p)
    for _ in range(40):
        lo = rng.normal(size=p)
        hi = lo + rng.uniform(0.5, 3.0, p)
        w, y, e = _cutting_strip(rng, Box(lo, hi), p)
        status, nlo, nhi = box_step(lo, hi, w, y, e)
        assert status == K.UPDATE
        A, b = _strip_rows(w, y, e)
        V = _exact_vertices(np.vstack([np.eye(p), -np.eye(p), A]), np.concatenate([hi, -lo, b]))
        tol = 1e-9 * (hi - lo)
        np.testing.assert_allclose(nlo, V.min(axis=0), atol=tol.max())
        np.testing.assert_allclose(nhi, V.max(axis=0), atol=tol.max())
        assert np.all(nlo <= V.min(axis=0) + 1e-13) and np.all(nhi >= V.max(axis=0) - 1e-13)
        est = BoxRecursion(p, prior=Box(lo, hi)).fit(w[None], [y], e)
        np.testing.assert_allclose(est.intervals[0], nlo, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(est.intervals[1], nhi, rtol=1e-12, atol=1e-12)


def _parallelotope_halfspaces(c, G):
    T = np.linalg.inv(G)
    return np.vstack([T, -T]), np.concatenate([1 + T @ c, 1 - T @ c]), T


@pytest.mark.parametrize("p", [2, 3])
def test_parallelotope_step_is_the_least_volume_candidate(p):
    """Parallelotope step against brute force: P ∩ S by Qhull; each of the p + 1 candidates built
    from the exact extents of P ∩ S along p of the p + 1 normals (volume 2^p prod(half) / |det N|).
    The step's parallelotope contains every vertex of P ∩ S and has the least candidate volume."""
    rng = np.random.default_rng(70 + p)
    for _ in range(40):
        c = rng.normal(size=p)
        G = rng.normal(size=(p, p)) + 2 * np.eye(p)
        P = Parallelotope(c, G)
        w, y, e = _cutting_strip(rng, P, p)
        status, c2, G2, chosen = parallelotope_step(c, G, w, y, e)
        assert status == K.UPDATE
        A0, b0, T = _parallelotope_halfspaces(c, G)
        A, b = _strip_rows(w, y, e)
        V = _exact_vertices(np.vstack([A0, A]), np.concatenate([b0, b]))
        P2 = Parallelotope(c2, G2)
        assert np.all(P2.contains(V))
        normals = np.vstack([T, w])
        ext = V @ normals.T
        half = 0.5 * (ext.max(axis=0) - ext.min(axis=0))
        logvols = []
        for drop in range(p + 1):
            k = [i for i in range(p + 1) if i != drop]
            det = abs(np.linalg.det(normals[k]))
            logvols.append(p * np.log(2) + np.sum(np.log(half[k])) - np.log(det) if det > 1e-12 else np.inf)
        assert P2.log_volume() == pytest.approx(min(logvols), abs=1e-8)
        assert chosen == int(np.argmin(logvols)) or logvols[chosen] == pytest.approx(min(logvols), abs=1e-8)


def _zonotope_hull(c, G):
    signs = np.array(list(itertools.product([-1.0, 1.0], repeat=G.shape[1])))
    hull = ConvexHull(c + signs @ G.T)
    return hull.equations[:, :-1], -hull.equations[:, -1]


def _member(c, G, w, yc, sc, lam):
    """Z(lambda) from [AlamoBravoCamacho2005]'s family, written out independently."""
    v = G.T @ w
    return c + lam * (yc - w @ c), np.hstack([G - np.outer(lam, v), sc * lam[:, None]])


@pytest.mark.parametrize("p", [2, 3])
def test_zonotope_step_contains_the_exact_intersection_and_meets_its_criterion(p):
    """Zonotope step: (1) it and every member Z(lambda) of the family (random lambda) contain every
    vertex of Z ∩ S (Qhull); (2) lambda* = G v / (|v|^2 + sc^2) reaches the least F-radius found by
    BFGS; (3) the step's segment length is at most that of every candidate formed here: Z, the
    BFGS-optimal member reduced to 2p generators, and each segment elimination lambda = g_j / v_j."""
    rng = np.random.default_rng(80 + p)
    for _ in range(10):
        c = rng.normal(size=p)
        G = rng.normal(size=(p, p + 2))
        Z = Zonotope(c, G)
        w, y, e = _cutting_strip(rng, Z, p)
        status, c2, G2, choice = zonotope_step(c, G, w, y, e, 2 * p)
        assert status == K.UPDATE and G2.shape[1] <= 2 * p
        A0, b0 = _zonotope_hull(c, G)
        A, b = _strip_rows(w, y, e)
        V = _exact_vertices(np.vstack([A0, A]), np.concatenate([b0, b]))
        assert np.all(Zonotope(c2, G2).contains(V))
        lo, hi = max(y - e, -Z.support(-w)), min(y + e, Z.support(w))
        yc, sc = 0.5 * (lo + hi), 0.5 * (hi - lo)
        for lam in rng.normal(size=(3, p)):
            assert np.all(Zonotope(*_member(c, G, w, yc, sc, lam)).contains(V))
        v = G.T @ w
        lam_star = G @ v / (v @ v + sc**2)
        def frad(lam, c=c, G=G, w=w, yc=yc, sc=sc):
            return np.sum(_member(c, G, w, yc, sc, lam)[1] ** 2)

        best = minimize(frad, np.zeros(p), method="BFGS", options={"gtol": 1e-12})
        assert frad(lam_star) == pytest.approx(best.fun, rel=1e-7)
        cands = [segments(G), segments(Zonotope(*_member(c, G, w, yc, sc, best.x)).reduced(2 * p).generators)]
        for j in np.flatnonzero(v):
            Gj = _member(c, G, w, yc, sc, G[:, j] / v[j])[1]
            cands.append(segments(Gj[:, np.linalg.norm(Gj, axis=0) > 1e-12 * np.abs(G).max()]))
        assert segments(G2) <= min(cands) * (1 + 1e-9) + 1e-12


@pytest.mark.parametrize("p", [2, 3])
def test_exact_polytope_step_has_the_vertices_of_the_intersection(p):
    """Exact recursion: after a few strips and one more, the polytope's vertices are those of
    prior box ∩ all strips by Qhull (HalfspaceIntersection), one to one, to 1e-8."""
    rng = np.random.default_rng(90 + p)
    for _ in range(20):
        theta = rng.normal(size=p)
        N = int(rng.integers(2, 8))
        W = rng.normal(size=(N, p))
        e = rng.uniform(0.2, 1.0, N)
        y = W @ theta + rng.uniform(-1, 1, N) * e
        rec = PolytopeRecursion(p, prior=Box.from_center(np.zeros(p), 3.0))
        rec.fit(W[:-1], y[:-1], e[:-1])
        est = rec.update(W[-1], y[-1], e[-1])
        A = np.vstack([np.eye(p), -np.eye(p)] + [_strip_rows(W[k], y[k], e[k])[0] for k in range(N)])
        b = np.concatenate([3 * np.ones(2 * p)] + [_strip_rows(W[k], y[k], e[k])[1] for k in range(N)])
        V = _exact_vertices(A, b)
        D = est.set.vertices
        d = np.linalg.norm(D[:, None] - V[None], axis=2)
        assert len(D) == len(V) and d.min(axis=1).max() < 1e-8 and d.min(axis=0).max() < 1e-8


# ---------------------------------------------------------------------------- polytopes against LP
@pytest.mark.parametrize("p", [1, 2, 3, 4])
def test_exact_polytope_recursion_gives_the_lp_bounds(p):
    """Exact recursion over 300 samples against the exact LP bounds of the same data and prior box
    (Polytope.bounds, HiGHS): equal to 1e-9 (relative to the widths)."""
    rng = np.random.default_rng(100 + p)
    N = 300
    theta = rng.normal(size=p)
    W = rng.normal(size=(N, p))
    y = W @ theta + rng.uniform(-0.5, 0.5, N)
    est = PolytopeRecursion(p, prior=Box.from_center(np.zeros(p), 10.0)).fit(W, y, 0.5)
    b = Polytope(W, y, 0.5, box=(-10 * np.ones(p), 10 * np.ones(p))).bounds()
    scale = (b.hi - b.lo).max()
    np.testing.assert_allclose(est.intervals[0], b.lo, atol=1e-9 * scale)
    np.testing.assert_allclose(est.intervals[1], b.hi, atol=1e-9 * scale)
    assert est.info["n_facets"] >= 2 * p


def test_limited_polytope_with_every_strip_kept_is_the_batch_lp():
    """K >= N strips and one block: the limited recursion's box is the exact LP box (to its
    outward guards, 1e-8 of the old and new widths) and outside it; with K = p it stays outside
    the LP box and holds every exact vertex."""
    rng = np.random.default_rng(11)
    p, N = 4, 200
    theta = rng.normal(size=p)
    W = rng.normal(size=(N, p))
    y = W @ theta + rng.uniform(-0.5, 0.5, N)
    P = Polytope(W, y, 0.5, box=(-10 * np.ones(p), 10 * np.ones(p)))
    b = P.bounds()
    est = LimitedPolytopeRecursion(p, prior=Box.from_center(np.zeros(p), 10.0), max_strips=N, block=N).fit(W, y, 0.5)
    guard = 1e-7 * (10.0 + (b.hi - b.lo).max())   # LP_GUARD (1e-8) of the widths, doubled, and spare
    np.testing.assert_allclose(est.intervals[0], b.lo, atol=guard)
    np.testing.assert_allclose(est.intervals[1], b.hi, atol=guard)
    assert np.all(est.intervals[0] <= b.lo) and np.all(est.intervals[1] >= b.hi)
    small = LimitedPolytopeRecursion(p, prior=Box.from_center(np.zeros(p), 10.0), max_strips=p, block=20).fit(W, y, 0.5)
    assert np.all(small.intervals[0] <= b.lo + 1e-12) and np.all(small.intervals[1] >= b.hi - 1e-12)
    assert np.all(small.set.contains(P.vertices())) and small.info["n_strips_kept"] == p


# ---------------------------------------------------------------------------- compiled = numpy
@pytest.mark.parametrize("p", [1, 3, 9])
def test_compiled_loops_match_the_numpy_steps(p):
    """The numba loops against the plain-numpy step functions over 300 rows from the prior box:
    same final set (1e-9), same number of updates."""
    rng = np.random.default_rng(120 + p)
    N = 300
    theta = rng.normal(size=p)
    W = rng.normal(size=(N, p))
    e = np.full(N, 0.5)
    y = W @ theta + rng.uniform(-0.5, 0.5, N)
    h0 = np.full(p, 10.0)
    lo, hi = -h0, h0.copy()
    c, G = np.zeros(p), np.diag(h0)
    cz, Gz = np.zeros(p), np.diag(h0)
    n_box = n_par = 0
    for k in range(N):
        st, lo, hi = box_step(lo, hi, W[k], y[k], e[k])
        n_box += st == K.UPDATE
        st, c, G, _ = parallelotope_step(c, G, W[k], y[k], e[k])
        n_par += st == K.UPDATE
        st, cz, Gz, _ = zonotope_step(cz, Gz, W[k], y[k], e[k], 2 * p)
    est = BoxRecursion(p, prior=Box.from_center(np.zeros(p), h0)).fit(W, y, e)
    np.testing.assert_allclose(est.intervals, (lo, hi), rtol=1e-9, atol=1e-12)
    assert est.n_updates == n_box
    est = ParallelotopeRecursion(p, prior=Box.from_center(np.zeros(p), h0)).fit(W, y, e)
    np.testing.assert_allclose(est.set.center, c, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(est.set.generators, G, rtol=1e-9, atol=1e-12)
    assert est.n_updates == n_par
    assert est.history.log_volumes[-1] == pytest.approx(Parallelotope(c, G).log_volume(), rel=1e-9)
    est = ZonotopeRecursion(p, prior=Box.from_center(np.zeros(p), h0)).fit(W, y, e)
    np.testing.assert_allclose(est.set.center, cz, rtol=1e-9, atol=1e-12)
    ref = Zonotope(cz, Gz)   # same set; the order of (near-)equal generators may differ
    for d in rng.normal(size=(50, p)):
        assert est.set.support(d) == pytest.approx(ref.support(d), rel=1e-9, abs=1e-12)


# ---------------------------------------------------------------------------- estimator protocol
def _data(seed=0, p=3, N=30):
    rng = np.random.default_rng(seed)
    theta = rng.normal(size=p)
    W = rng.normal(size=(N, p))
    return theta, W, W @ theta + rng.uniform(-0.5, 0.5, N), np.full(N, 0.5)


@pytest.mark.parametrize("family", ["box", "parallelotope", "zonotope", "polytope", "boxed_obe"])
def test_fit_restarts_and_partial_fit_continues(family):
    """fit starts from the prior (a second fit forgets the first); partial_fit and update continue:
    fit(A) then partial_fit(B) equals fit(A + B); global history indices every record_every
    samples, plus the last sample of each call."""
    theta, W, y, e = _data()
    make = FAMILIES[family]
    one = make(3, record_every=4)
    one.fit(W[:7], y[:7], e[:7])
    first = one.fit(W, y, e)
    two = make(3, record_every=4)
    two.fit(W[:11], y[:11], e[:11])
    two.partial_fit(W[11:29], y[11:29], e[11:29])
    last = two.update(W[29], y[29], e[29])
    np.testing.assert_allclose(first.intervals, last.intervals, rtol=1e-12)
    assert first.history.index.tolist() == [3, 7, 11, 15, 19, 23, 27, 29]
    assert last.history.index.tolist() == [3, 7, 10, 11, 15, 19, 23, 27, 28, 29]
    common = np.isin(last.history.index, first.history.index)
    np.testing.assert_allclose(last.history.centers[common], first.history.centers, rtol=1e-12)
    assert first.n_samples == 30 and first.kind == "guaranteed"


@pytest.mark.parametrize("family", list(FAMILIES))
def test_estimate_holds_the_set(family):
    """Estimate.set is the family's ConvexSet (an ellipsoid for the OBE variants and the OBE); its
    intervals are the Estimate's (the limited polytope reports its padded LP box, which holds them)."""
    theta, W, y, e = _data(1)
    est = FAMILIES[family](3, prior=Box.from_center(np.zeros(3), 5.0)).fit(W, y, e)
    assert est.contains(theta)
    assert isinstance(est.set, ConvexSet)
    assert isinstance(est.set, Ellipsoid) == (family in ("boxed_obe", "windowed_obe"))
    lo, hi = est.set.intervals()
    if family == "limited":
        assert np.all(est.intervals[0] <= lo + 1e-12) and np.all(hi <= est.intervals[1] + 1e-12)
    else:
        np.testing.assert_allclose(est.intervals, (lo, hi), rtol=1e-12)
    obe = OBE(3, shape0=100.0).fit(W, y, e)
    assert isinstance(obe.set, Ellipsoid) and "ln volume" in obe.summary()


@pytest.mark.parametrize("family", ["box", "parallelotope", "zonotope", "polytope", "limited", "boxed_obe"])
def test_outliers_are_recorded_or_raised(family):
    """A row whose strip misses the set is an outlier: recorded and skipped, or raised."""
    theta, W, y, e = _data(2)
    y = y.copy()
    y[20] += 1e4
    est = FAMILIES[family](3, prior=Box.from_center(np.zeros(3), 5.0)).fit(W, y, e)
    assert est.outliers.tolist() == [20] and est.contains(theta)
    with pytest.raises(InfeasibleDataError, match="observation 20"):
        FAMILIES[family](3, prior=Box.from_center(np.zeros(3), 5.0), on_outlier="raise").fit(W, y, e)


def test_bad_options_are_refused():
    with pytest.raises(InputError, match="p <= 4"):
        PolytopeRecursion(5)
    with pytest.raises(InputError, match="order"):
        ZonotopeRecursion(3, order=1)
    with pytest.raises(InputError, match="half-width > 0"):
        BoxRecursion(3, prior=Box.from_center(np.zeros(3), [1.0, 0.0, 1.0]))
    with pytest.raises(InputError, match="prior once"):
        BoxRecursion(3, prior=Box.from_center(np.zeros(3), 1.0), shape0=4.0)
    with pytest.raises(InputError, match="3 columns"):
        BoxRecursion(3).fit(np.ones((4, 2)), np.ones(4), 1.0)
    with pytest.raises(InputError, match="max_strips"):
        LimitedPolytopeRecursion(3, max_strips=0)
    with pytest.raises(InputError, match="on_outlier"):
        ParallelotopeRecursion(3, on_outlier="ignore")
