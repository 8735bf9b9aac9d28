"""Tests of boundid.sets.polytope: exact LP geometry of the feasible set of strips."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, HalfspaceIntersection

from boundid.errors import InfeasibleDataError, InputError
from boundid.sets import Polytope


def random_problem(rng, p, N, noise=1.0):
    theta = rng.normal(size=p)
    W = rng.normal(size=(N, p))
    e = 0.5 + rng.random(N)
    y = W @ theta + noise * e * rng.uniform(-1, 1, N)
    return W, y, e, theta


def brute_vertices(W, y, e):
    """Vertices by scipy HalfspaceIntersection on ALL strip sides (no screening, no scaling),
    interior point from a plain scipy linprog Chebyshev LP: an independent implementation."""
    H = np.vstack([W, -W])
    h = np.concatenate([y + e, e - y])
    nrm = np.linalg.norm(H, axis=1)
    res = linprog(np.r_[np.zeros(W.shape[1]), -1.0], A_ub=np.hstack([H, nrm[:, None]]), b_ub=h,
                  bounds=[(None, None)] * W.shape[1] + [(0, None)], method="highs")
    hs = HalfspaceIntersection(np.hstack([H, -h[:, None]]), res.x[:-1])
    return hs.intersections


@pytest.mark.parametrize("p,N,seed", [(2, 20, 0), (2, 200, 1), (3, 40, 2), (3, 300, 3), (4, 60, 4)])
def test_bounds_equal_vertex_extremes(p, N, seed):
    """bounds() == min/max over the vertices from an independent halfspace intersection (1e-7);
    argmin/argmax rows are points of P attaining them; vertices() and volume() match too."""
    rng = np.random.default_rng(seed)
    W, y, e, theta = random_problem(rng, p, N)
    P = Polytope.from_strips(W, y, e)
    b = P.bounds()
    V = brute_vertices(W, y, e)
    scale = np.abs(V).max()
    assert np.allclose(b.lo, V.min(axis=0), atol=1e-7 * scale, rtol=0)
    assert np.allclose(b.hi, V.max(axis=0), atol=1e-7 * scale, rtol=0)
    assert np.all(P.contains(b.vertices(), rtol=1e-8))
    assert np.allclose(np.diag(b.argmin), b.lo) and np.allclose(np.diag(b.argmax), b.hi)
    assert np.all(b.lo <= theta) and np.all(theta <= b.hi)
    mine = P.vertices()
    # every brute-force vertex is one of ours and vice versa
    d = np.linalg.norm(mine[:, None, :] - V[None, :, :], axis=2)
    assert d.min(axis=0).max() < 1e-7 * scale and d.min(axis=1).max() < 1e-7 * scale
    assert P.volume() == pytest.approx(ConvexHull(V).volume, rel=1e-7)


def test_bounds_equal_naive_linprog_p14():
    """p = 14: bounds() equal 28 independent scipy.optimize.linprog solves on the full LP."""
    rng = np.random.default_rng(7)
    W, y, e, _ = random_problem(rng, 14, 400)
    b = Polytope.from_strips(W, y, e).bounds()
    A_ub = np.vstack([W, -W])
    b_ub = np.concatenate([y + e, e - y])
    for j in range(14):
        c = np.zeros(14)
        c[j] = 1.0
        lo = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=(None, None), method="highs").fun
        hi = -linprog(-c, A_ub=A_ub, b_ub=b_ub, bounds=(None, None), method="highs").fun
        assert b.lo[j] == pytest.approx(lo, abs=1e-7)
        assert b.hi[j] == pytest.approx(hi, abs=1e-7)


def test_box_and_halfspaces_match_linprog():
    """Box prior and halfspaces change the bounds exactly as in a plain linprog with the same
    constraints; a rank-deficient W closed by the box is fine (no artificial box involved)."""
    rng = np.random.default_rng(3)
    W = rng.normal(size=(30, 2)) @ np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])  # theta_3, theta_4 unseen
    W[:, 2] = W[:, 0] + W[:, 1]  # rank 3: theta_4 only in the prior
    y = W @ np.array([0.3, -0.2, 0.1, 0.5]) + rng.uniform(-0.2, 0.2, 30)
    box = (np.full(4, -1.0), np.array([1.0, 1.0, 1.0, 0.8]))
    hs = (np.array([[1.0, 1.0, 1.0, 1.0]]), np.array([1.2]))
    P = Polytope.from_strips(W, y, 0.2, box=box, halfspaces=hs)
    b = P.bounds()
    A_ub = np.vstack([W, -W, hs[0]])
    b_ub = np.concatenate([y + 0.2, 0.2 - y, hs[1]])
    for j in range(4):
        c = np.eye(4)[j]
        lo = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=list(zip(*box, strict=True)), method="highs").fun
        hi = -linprog(-c, A_ub=A_ub, b_ub=b_ub, bounds=list(zip(*box, strict=True)), method="highs").fun
        assert b.lo[j] == pytest.approx(lo, abs=1e-8) and b.hi[j] == pytest.approx(hi, abs=1e-8)


def test_unbounded_set_raises():
    """A W of rank 1 in 2-D, with no prior, leaves a whole line feasible: InputError, not inf."""
    W = np.array([[1.0, 2.0], [2.0, 4.0], [-1.0, -2.0]])
    with pytest.raises(InputError, match="unbounded"):
        Polytope.from_strips(W, np.zeros(3), 1.0).bounds()


def test_consistency_matches_minimax_linprog():
    """gamma* equals the Chebyshev-norm (minimax) fit from a plain linprog; P empty iff > 1,
    and an inconsistent data set raises InfeasibleDataError naming the rows, not NaN."""
    rng = np.random.default_rng(11)
    W, y, e, _ = random_problem(rng, 3, 50)
    y[5] += 20.0  # an outlier
    P = Polytope.from_strips(W, y, e)
    Wn, yn = W / e[:, None], y / e
    res = linprog(np.r_[0, 0, 0, 1.0], A_ub=np.vstack([np.hstack([Wn, -np.ones((50, 1))]),
                                                       np.hstack([-Wn, -np.ones((50, 1))])]),
                  b_ub=np.r_[yn, -yn], bounds=[(None, None)] * 3 + [(0, None)], method="highs")
    c = P.consistency()
    assert c.gamma == pytest.approx(res.fun, rel=1e-8)
    assert c.gamma > 1 and P.is_empty() and c.empty
    assert 5 in c.violated
    for method in (P.bounds, P.chebyshev_center, P.vertices):
        with pytest.raises(InfeasibleDataError, match=r"gamma\* = .*rows"):
            method()
    ok = Polytope.from_strips(W[:5], y[:5], e[:5])
    assert not ok.is_empty() and ok.consistency().gamma <= 1


def test_empty_prior_raises():
    """Halfspaces that contradict the box: the prior alone is empty."""
    P = Polytope.from_strips(np.eye(2), np.zeros(2), 1.0, box=(np.zeros(2), np.ones(2)),
                             halfspaces=(np.array([[1.0, 1.0]]), np.array([-1.0])))
    assert P.is_empty()
    with pytest.raises(InfeasibleDataError, match="prior"):
        P.bounds()


def test_chebyshev_center_of_box_and_triangle():
    """Closed forms: a box [0,2]x[0,4] has Chebyshev radius 1 (centre x = 1); the triangle
    x>=0, y>=0, x+y<=1 has inradius 1/(2+sqrt 2) at (r, r)."""
    P = Polytope.from_strips(np.eye(2), np.array([1.0, 2.0]), np.array([1.0, 2.0]))
    x, r = P.chebyshev_center()
    assert r == pytest.approx(1.0) and x[0] == pytest.approx(1.0) and 1 - 1e-9 <= x[1] <= 3 + 1e-9
    T = Polytope.from_strips(np.eye(2), np.full(2, 10.0), 10.0, halfspaces=(np.array([[1.0, 1.0]]), [1.0]))
    x, r = T.chebyshev_center()
    rin = 1 / (2 + np.sqrt(2))
    assert r == pytest.approx(rin) and np.allclose(x, rin)


def test_nonredundant_matches_facets():
    """nonredundant() == the strips owning a facet of the independent ConvexHull of the vertices;
    duplicated strips keep exactly one copy; P rebuilt from them has the same vertices."""
    rng = np.random.default_rng(5)
    W, y, e, _ = random_problem(rng, 3, 60)
    W, y, e = np.vstack([W, W[:3]]), np.r_[y, y[:3]], np.r_[e, e[:3]]  # exact duplicates
    P = Polytope.from_strips(W, y, e)
    keep = P.nonredundant()
    V = brute_vertices(W, y, e)
    hull = ConvexHull(V)
    facets = np.unique(np.round(hull.equations, 8), axis=0)
    assert len(keep) <= len(facets)
    sub = Polytope.from_strips(W[keep], y[keep], e[keep])
    Vs = sub.vertices()
    assert len(Vs) == len(P.vertices())
    d = np.linalg.norm(Vs[:, None] - P.vertices()[None], axis=2)
    assert d.min(axis=1).max() < 1e-8
    for i in range(3):  # never both copies of a duplicated strip
        assert not (i in keep and 60 + i in keep)
    # each kept strip is needed: dropping it adds vertices outside P
    for k in keep[:5]:
        rest = np.setdiff1d(np.arange(len(y)), [k])
        Vr = Polytope.from_strips(W[rest], y[rest], e[rest]).vertices()
        assert not np.all(P.contains(Vr, rtol=1e-9))


def test_tightened_extent_support():
    """tightened() strips equal extent() along w_k; extent/support equal the vertex extremes."""
    rng = np.random.default_rng(9)
    W, y, e, _ = random_problem(rng, 3, 30)
    P = Polytope.from_strips(W, y, e)
    V = P.vertices()
    d = rng.normal(size=3)
    lo, hi = P.extent(d)
    assert lo == pytest.approx((V @ d).min(), abs=1e-9) and hi == pytest.approx((V @ d).max(), abs=1e-9)
    assert P.support(d) == pytest.approx(hi, abs=1e-9)
    T = P.tightened()
    proj = V @ W.T
    assert np.allclose(T.y - T.e_max, proj.min(axis=0), atol=1e-9)
    assert np.allclose(T.y + T.e_max, proj.max(axis=0), atol=1e-9)
    assert np.all(T.e_max <= e + 1e-12)
    assert T.volume() == pytest.approx(P.volume(), rel=1e-8)


def test_volume_of_cube_and_one_dim():
    """Closed forms: the cube [-1,1]^3 has volume 8; a 1-D set is an interval."""
    P = Polytope.from_strips(np.eye(3), np.zeros(3), 1.0)
    assert P.volume() == pytest.approx(8.0)
    assert len(P.vertices()) == 8
    assert set(map(tuple, np.round(P.vertices(), 12))) == set(itertools.product([-1.0, 1.0], repeat=3))
    Q = Polytope.from_strips([[1.0], [2.0]], [0.0, 1.0], [1.0, 2.0])
    assert Q.volume() == pytest.approx(1.5) and np.allclose(Q.vertices().ravel(), [-0.5, 1.0])


@pytest.mark.parametrize("args,msg", [
    ((np.ones((3, 2)), np.ones(4), 1.0), "rows"),
    ((np.ones((3, 2)), np.ones(3), [1.0, 1.0]), "shape"),
    ((np.ones((3, 2)), np.ones(3), 0.0), "positive"),
    ((np.array([[1.0, np.nan]]), np.ones(1), 1.0), "NaN"),
    ((np.ones((3, 2)), np.array([1.0, np.nan, 1.0]), 1.0), "NaN"),
])
def test_bad_input_raises(args, msg):
    """Wrong shapes, NaN, non-positive bounds: InputError naming the problem."""
    with pytest.raises(InputError, match=msg):
        Polytope.from_strips(*args)


def test_bad_prior_and_high_dim_vertices_raise():
    """Box with lo >= hi, halfspace shape errors, vertices() beyond p = 6: InputError."""
    W = np.eye(2)
    with pytest.raises(InputError, match="lo < hi"):
        Polytope.from_strips(W, np.zeros(2), 1.0, box=([0.0, 1.0], [1.0, 1.0]))
    with pytest.raises(InputError, match="columns"):
        Polytope.from_strips(W, np.zeros(2), 1.0, halfspaces=(np.ones((1, 3)), [1.0]))
    with pytest.raises(InputError, match="p <= 6"):
        Polytope.from_strips(np.eye(7), np.zeros(7), 1.0).vertices()


def test_support_point_is_a_maximiser():
    """support_point's vertex attains the support value; against the max over Qhull vertices."""
    rng = np.random.default_rng(11)
    W = rng.normal(size=(12, 3))
    P = Polytope.from_strips(W, W @ np.ones(3), 1.0)
    V = P.vertices()
    for d in rng.normal(size=(5, 3)):
        v, x = P.support_point(d)
        assert v == pytest.approx(np.max(V @ d), rel=1e-9, abs=1e-9)
        assert d @ x == pytest.approx(v, rel=1e-9, abs=1e-9) and P.contains(x, rtol=1e-8)


def test_supports_equal_one_linprog_per_direction():
    """supports (batched: one LP per distinct maximising vertex, the other directions answered
    from its normal cone) equal one scipy linprog per direction on the full LP, p = 6; half the
    directions are perturbed copies of others, so that normal cones are shared."""
    rng = np.random.default_rng(12)
    W, y, e, _ = random_problem(rng, 6, 200)
    P = Polytope.from_strips(W, y, e)
    D = rng.normal(size=(30, 6))
    D = np.vstack([D, D + 1e-3 * rng.normal(size=D.shape)])
    A_ub, b_ub = np.vstack([W, -W]), np.concatenate([y + e, e - y])
    ref = [-linprog(-d, A_ub=A_ub, b_ub=b_ub, bounds=(None, None), method="highs").fun for d in D]
    np.testing.assert_allclose(P.supports(D), ref, rtol=1e-9, atol=1e-9)


def one_lp_per_side(W, y, e, box=None, halfspaces=None):
    """The textbook redundancy removal, kept here only as the independent reference: sequential
    elimination over every side of every strip in index order (upper, then lower side), each
    tested by one scipy linprog (HiGHS) with that side removed: kept if g^T theta can then exceed
    its bound by more than 1e-8 (1 + |bound|) (or without limit). Rows are w/e normalised to unit
    norm. Returns the strips with a kept side."""
    A, c = W / e[:, None], y / e
    nrm = np.linalg.norm(A, axis=1)
    G = np.empty((2 * len(y), W.shape[1]))
    G[0::2], G[1::2] = A / nrm[:, None], -A / nrm[:, None]
    b = np.empty(2 * len(y))
    b[0::2], b[1::2] = (c + 1) / nrm, (1 - c) / nrm
    H = np.zeros((0, W.shape[1])) if halfspaces is None else np.asarray(halfspaces[0], dtype=float)
    h = np.zeros(0) if halfspaces is None else np.asarray(halfspaces[1], dtype=float)
    bounds = [(None, None)] * W.shape[1] if box is None else list(zip(*box, strict=True))
    alive = np.ones(len(b), dtype=bool)
    for i in range(len(b)):
        others = alive.copy()
        others[i] = False
        res = linprog(-G[i], A_ub=np.vstack([G[others], H]), b_ub=np.concatenate([b[others], h]),
                      bounds=bounds, method="highs")
        assert res.status in (0, 3), res.message
        alive[i] = res.status == 3 or -res.fun > b[i] + 1e-8 * (1 + abs(b[i]))
    return np.unique(np.flatnonzero(alive) // 2)


@pytest.mark.parametrize("seed", range(12))
def test_nonredundant_equals_one_lp_per_side(seed):
    """nonredundant() (box screen, ray shooting, batched Clarkson test) returns exactly the
    strips of the one-LP-per-side sequential elimination (scipy linprog, reference above), with
    and without a prior box and halfspaces, duplicated strips included."""
    rng = np.random.default_rng(100 + seed)
    p, N = int(rng.integers(2, 6)), int(rng.integers(15, 120))
    W, y, e, theta = random_problem(rng, p, N)
    if seed % 4 == 3:                                     # exact duplicates of a few strips
        W, y, e = np.vstack([W, W[:4]]), np.r_[y, y[:4]], np.r_[e, e[:4]]
    box = hs = None
    if seed % 3 == 1:
        b = Polytope.from_strips(W, y, e).bounds()
        box = (b.center - 0.6 * b.half_width, b.center + 0.9 * b.half_width)
        H = rng.normal(size=(2, p))
        hs = (H, H @ b.center + 0.3 * np.abs(H) @ b.half_width)
    P = Polytope.from_strips(W, y, e, box=box, halfspaces=hs)
    assert np.array_equal(P.nonredundant(), one_lp_per_side(W, y, e, box, hs))


def test_nonredundant_without_interior():
    """A P flat along one direction (two strips meet in a hyperplane) has no interior: the
    relaxed-LP path decides every side. The strips returned give back P (equal supports in
    random directions, by HiGHS on the subset) and each is needed (the reference's criterion)."""
    rng = np.random.default_rng(21)
    W, y, e, theta = random_problem(rng, 3, 40)
    w = np.array([0.3, -0.7, 0.5])
    s = w @ theta
    W, y, e = np.vstack([W, w, w]), np.r_[y, s - 1.0, s + 1.0], np.r_[e, 1.0, 1.0]   # w^T theta = s
    P = Polytope.from_strips(W, y, e)
    keep = P.nonredundant()
    assert {40, 41} <= set(keep.tolist())
    ref = one_lp_per_side(W, y, e)
    assert set(ref.tolist()) == set(keep.tolist())
    sub = Polytope.from_strips(W[keep], y[keep], e[keep])
    for d in rng.normal(size=(6, 3)):
        assert sub.support(d) == pytest.approx(P.support(d), abs=1e-8)


def test_staged_bounds_and_consistency_match_linprog(monkeypatch):
    """The staged paths (strided samples, box screens, changes of frame, screened consistency
    LP), normally taken from N = 160,000 on, forced at N = 6000 by smaller stages: bounds()
    equal 2p scipy linprog solves on every strip, gamma* equals the minimax linprog (with an
    outlier, gamma* > 1, and without), and on consistent data the level screen drops strips."""
    import boundid.sets.polytope as pm
    from boundid.sets._working_set import sample_levels

    monkeypatch.setattr(pm, "sample_levels", lambda m: sample_levels(m, smallest=200, ratio=4))
    kept = []
    screen = pm.Polytope._level_screen
    monkeypatch.setattr(pm.Polytope, "_level_screen", lambda self, *a: kept.append(screen(self, *a)) or kept[-1])
    rng = np.random.default_rng(17)
    W, y, e, theta = random_problem(rng, 5, 6000)
    b = Polytope.from_strips(W, y, e).bounds()
    A_ub, b_ub = np.vstack([W, -W]), np.concatenate([y + e, e - y])
    for j in range(5):
        c = np.eye(5)[j]
        assert b.lo[j] == pytest.approx(linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=(None, None)).fun, abs=1e-8)
        assert b.hi[j] == pytest.approx(-linprog(-c, A_ub=A_ub, b_ub=b_ub, bounds=(None, None)).fun, abs=1e-8)
    y_out = y.copy()
    y_out[123] += 30.0
    for yy in (y, y_out):
        Wn, yn = W / e[:, None], yy / e
        ref = linprog(np.r_[np.zeros(5), 1.0], A_ub=np.vstack([np.hstack([Wn, -np.ones((6000, 1))]),
                                                               np.hstack([-Wn, -np.ones((6000, 1))])]),
                      b_ub=np.r_[yn, -yn], bounds=[(None, None)] * 5 + [(0, None)])
        assert Polytope.from_strips(W, yy, e).consistency().gamma == pytest.approx(ref.fun, rel=1e-8)
    assert len(kept) == 2 and kept[0] is not None and len(kept[0]) < 6000


def test_strip_block_equals_explicit_rows():
    """StripBlock (rows computed on demand) gives the rows, bounds and violations of the same
    strips written out as arrays with numpy (r = y - W origin, n = |w * scale|)."""
    from boundid.sets._working_set import StripBlock

    rng = np.random.default_rng(8)
    W, y, e, _ = random_problem(rng, 4, 300)
    origin, scale = rng.normal(size=4), 10.0 ** rng.uniform(-2, 2, 4)
    r, n = y - W @ origin, np.linalg.norm(W * scale, axis=1)
    A = W * scale / n[:, None]
    idx = rng.choice(300, 40, replace=False)
    X = rng.normal(size=(5, 3))
    blk = StripBlock(W, y, e, origin, scale)
    assert np.allclose(blk.rows(idx), A[idx], rtol=1e-13, atol=0)
    lo, up = blk.bounds(idx)
    assert np.allclose(lo, ((r - e) / n)[idx], rtol=1e-12) and np.allclose(up, ((r + e) / n)[idx], rtol=1e-12)
    act = A @ X[:4]
    assert np.allclose(blk.violation(slice(0, 300), X[:4]), np.abs(act - (r / n)[:, None]) - (e / n)[:, None],
                       atol=1e-12)
    for side in (1, -1):                       # the consistency LP's rows on (z, t)
        s = np.hypot(n, e)
        sb = StripBlock(W, y, e, origin, scale, side=side)
        assert np.allclose(sb.rows(idx), np.hstack([W * scale, side * e[:, None]])[idx] / s[idx, None], rtol=1e-13)
        act = (W * scale @ X[:4] + side * e[:, None] * X[4]) / s[:, None]
        want = (r / s)[:, None] - act if side > 0 else act - (r / s)[:, None]
        assert np.allclose(sb.violation(slice(0, 300), X), want, atol=1e-12)


@pytest.mark.parametrize("N, p, r", [(3000, 52, 33), (600, 20, 11), (200, 10, 10)])
def test_data_rank_matches_the_svd_on_rank_deficient_rows(N, p, r):
    """Reference: numpy's matrix_rank (SVD) of the frame's unit rows, for rows of rank r < p with column
    scales over six decades (a robot's regressor block of one joint). The Gram matrix's rounding once
    counted 45 of 33 directions, and the working-set seed chased the absent ones (19 x slower gamma*)."""
    rng = np.random.default_rng(r)
    W = rng.normal(size=(N, r)) @ (rng.normal(size=(r, p)) * np.logspace(-3, 3, p))
    P = Polytope.from_strips(W, rng.normal(size=N), 1.0, box=(np.full(p, -1e3), np.full(p, 1e3)))
    F = P._get_frame()
    assert P._data_rank(F) == np.linalg.matrix_rank(W * F.scale / F.rn(np.arange(N))[1][:, None]) == r


def test_coarse_shadow_is_close_on_both_axes_of_a_lopsided_polytope():
    """A 200-gon around a disc stretched 1000:1 (parameters of different units): the shadow drawn to
    rtol = 1e-3 keeps its vertices on the exact polygon and loses under 1 % of its area, on the narrow
    axis as on the wide one (a tolerance taken on the wide axis alone drew 4 vertices, 64 % of the area)."""
    angles = np.linspace(0, np.pi, 100, endpoint=False)
    W = np.column_stack([np.cos(angles) / 1000.0, np.sin(angles)])
    P = Polytope.from_strips(W, np.zeros(100), 1.0)
    exact = P.project(0, 1)
    coarse = P.project(0, 1, rtol=1e-3)
    assert len(coarse.vertices) < len(exact.vertices)
    assert np.all(P.contains(np.asarray(coarse.vertices)))
    assert np.exp(coarse.log_volume() - exact.log_volume()) > 0.99


def test_a_one_point_set_keeps_its_gamma_star_after_the_bounds():
    """A feasible set that is one point (the truth on a box corner, every error at +-e_max): the
    bounds' frame shrinks to nothing, and the consistency LP solved there once said gamma* = 66.5
    ("enlarge e_max 66-fold"). Reference: the truth's own residual ratio, 1 to rounding. gamma* must
    not depend on whether the bounds ran first, and an empty verdict must say it is empty to rounding."""
    rng = np.random.default_rng(7)
    cases = 0
    for _ in range(40):
        W = rng.normal(size=(15, 3))
        center, half = rng.normal(scale=3.0, size=3), rng.uniform(0.5, 3.0, size=3)
        e = rng.uniform(0.05, 0.3, size=15)
        theta = center + half * np.sign(rng.uniform(-1, 1, 3))
        y = W @ theta + np.sign(rng.uniform(-1, 1, 15)) * e
        box = (center - half, center + half)
        at_truth = float(np.max(np.abs(y - W @ theta) / e))
        first = Polytope(W, y, e, box=box).consistency().gamma
        P = Polytope(W, y, e, box=box)
        try:
            b = P.bounds()
        except InfeasibleDataError as exc:
            cases += 1
            assert "empty to solver accuracy" in str(exc)
        else:
            assert np.all(b.lo <= theta + 1e-9 * half) and np.all(theta - 1e-9 * half <= b.hi)
        assert P.consistency().gamma == pytest.approx(first, abs=1e-12)
        assert first <= at_truth + 1e-12
    assert cases > 0          # the degenerate case this guards was met


def test_a_centred_polytope_takes_half_the_lps_and_the_same_bounds():
    """P = -P (y = 0, a box symmetric about 0): bounds() solves only the minimisers and mirrors them.
    Reference: the same polytope shifted off the origin (no symmetry to use), shifted back."""
    rng = np.random.default_rng(3)
    W = rng.normal(size=(400, 6)) * rng.uniform(0.1, 10.0, 6)
    half = rng.uniform(0.5, 5.0, 6)
    e = rng.uniform(0.5, 1.5, 400)
    b = Polytope(W, np.zeros(400), e, box=(-half, half)).bounds()
    shift = 0.3 * half * rng.uniform(-1, 1, 6)
    b2 = Polytope(W, W @ shift, e, box=(-half + shift, half + shift)).bounds()
    assert np.allclose(b.lo, b2.lo - shift, rtol=0, atol=1e-9 * half.max())
    assert np.allclose(b.hi, b2.hi - shift, rtol=0, atol=1e-9 * half.max())
    assert np.array_equal(b.lo, -b.hi) and np.array_equal(b.argmin, -b.argmax)
    assert b.info["lp_solves"] <= 0.6 * b2.info["lp_solves"]
